"""The scaling benchmark: mesh sizes x shapes x methods, median time per detection."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Callable, Iterable

import numpy as np

from . import _api, scenes

#: Shapes the benchmark puts the cloth in, with their parameters.
STATES: dict[str, dict[str, float]] = {
    "flat": {},
    "fold": {"angle": 3.14159, "radius": 0.02},
    "zfold": {"layers": 4, "gap": 0.01},
    "crumple": {"amplitude": 0.3, "wavelength": 0.5, "seed": 7},
}


@dataclass
class BenchRow:
    """One (size, state, method) measurement."""

    triangles: int
    vertices: int
    state: str
    method: str
    median_ms: float
    min_ms: float
    primitive_tests: int
    node_pairs: int
    contacts: int


def _measure(mesh: _api.Mesh, positions: np.ndarray, method: str, repeats: int) -> tuple[list[float], dict]:
    det = _api.Detector(mesh, method)
    times, stats = [], {}
    for _ in range(repeats):
        det.detect(positions)
        stats = det.last_stats
        times.append(stats["total_time"] * 1e3)
    return times, stats


def run(
    sizes: Iterable[int],
    states: Iterable[str],
    methods: Iterable[str],
    repeats: int = 3,
    brute_limit: int = 2000,
    progress: Callable[[], None] | None = None,
) -> list[BenchRow]:
    """Measures every combination; brute force is skipped above `brute_limit` triangles."""
    rows = []
    for size in sizes:
        V, F = scenes.grid(scenes_side(size))
        mesh = _api.Mesh(V, F)
        for state in states:
            if state not in STATES:
                raise ValueError(f"unknown state {state!r}; expected one of {', '.join(STATES)}")
            P = scenes.deform(V, state, **STATES[state])
            for method in methods:
                if not (method == "brute" and len(F) > brute_limit):
                    times, s = _measure(mesh, P, method, repeats)
                    rows.append(BenchRow(len(F), len(V), state, method, float(np.median(times)), float(min(times)),
                                         s["primitive_tests"], s["node_pairs"], s["contacts"]))
                if progress:
                    progress()
    return rows


def scenes_side(triangles: int) -> int:
    """Vertices per side of the square grid closest to `triangles` triangles."""
    return max(2, int(round((triangles / 2) ** 0.5)) + 1)


def as_dicts(rows: list[BenchRow]) -> list[dict]:
    """Rows as plain dicts (for JSON)."""
    return [asdict(r) for r in rows]


def table(rows: list[BenchRow]) -> str:
    """Rows as an aligned text table."""
    head = f"{'triangles':>10} {'state':<9} {'method':<18} {'median ms':>10} {'prim. tests':>12} {'node pairs':>11} {'contacts':>9}"
    lines = [head]
    for r in rows:
        lines.append(f"{r.triangles:>10} {r.state:<9} {r.method:<18} {r.median_ms:>10.3f} {r.primitive_tests:>12} "
                     f"{r.node_pairs:>11} {r.contacts:>9}")
    return "\n".join(lines)
