"""The scaling benchmark: mesh sizes x states x methods (the engine's
`bench::scaling`, the same measurement as `cargo run --example` on the engine)."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

from . import _core


def states() -> list[str]:
    """Names of the states the cloth is measured in (flat, crumpled, folded)."""
    return list(_core.bench_states())


def run(
    sizes: Iterable[int],
    state_names: Iterable[str],
    methods: Iterable[str],
    repeats: int = 3,
    brute_limit: int = 2000,
    progress: Callable[[int], None] | None = None,
) -> list[dict[str, Any]]:
    """Measures every (size, state, method); brute force is skipped above `brute_limit` triangles.

    Each row: triangles, state, method, build_time, refit_time, traverse_time
    (medians, seconds), bvh_bytes_per_triangle, stats (FrameStats dict), total_ms.
    `progress` is called with the number of rows done so far.
    """
    rows: list[dict[str, Any]] = []
    state_names, methods = list(state_names), list(methods)
    for size in sizes:
        chosen = [m for m in methods if not (m == "brute" and size > brute_limit)]
        done_before = len(rows)
        cb = None if progress is None else (lambda k, base=done_before: progress(base + k))
        rows += _core.bench_scaling([int(size)], state_names, chosen, int(repeats), cb)
    for r in rows:
        r["total_ms"] = (r["refit_time"] + r["traverse_time"]) * 1e3
    return rows


def table(rows: list[dict[str, Any]]) -> str:
    """Rows as an aligned text table."""
    head = (f"{'triangles':>10} {'state':<9} {'method':<18} {'build ms':>9} {'refit ms':>9} {'traverse ms':>12} "
            f"{'total ms':>9} {'prim. tests':>12} {'contacts':>9}")
    lines = [head]
    for r in rows:
        s = r["stats"]
        lines.append(f"{r['triangles']:>10} {r['state']:<9} {r['method']:<18} {r['build_time'] * 1e3:>9.2f} "
                     f"{r['refit_time'] * 1e3:>9.3f} {r['traverse_time'] * 1e3:>12.3f} {r['total_ms']:>9.3f} "
                     f"{s['primitive_tests']:>12} {s['contacts']:>9}")
    return "\n".join(lines)
