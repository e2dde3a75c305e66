#!/usr/bin/env python3
"""selfcd against its peers, in one process, on the same inputs.

Four tables, each with ratios selfcd / peer (< 1: selfcd is faster):

1. per frame, hierarchy kept (refit + query, exact pairs): selfcd's default
   detector, plain `bvh` and `bvh-cones` against warp on CPU (float32 mesh BVH
   refit + one BVH query per triangle + wp.intersect_tri_tri, pairs sharing a
   vertex skipped as selfcd does);
2. one-shot (build + query): selfcd.self_intersections against libigl's
   igl.predicates.find_self_intersections and warp build + query;
3. proximity (vertex-triangle and edge-edge pairs closer than
   d = 0.6 x median edge length) against ipctk NormalCollisions (LBVH);
   selfcd three ways: a detector kept across frames, the one-shot `selfcd.proximity_contacts`, and
   `selfcd.SelfQueries` kept across frames (the simulator's coherent queries:
   the candidate set is built in the warm-up and reused, or rebuilt when stale,
   in the timed runs);
4. continuous against ipctk Candidates + collision-free step size (LBVH, Tight
   Inclusion CCD): one large linear step from an intersection-free state, and
   the small steps between the frames of the per-frame sequence, where
   `selfcd.SelfQueries` keeps its candidate set from step to step.

Peers are optional (`pip install .[bench]`: warp-lang, libigl, ipctk); a peer
that does not import is reported as unavailable and selfcd is measured alone.
Every timing is the median over `--repeat` runs after a warm-up (warp's kernel
JIT happens there); peers and selfcd alternate inside each run so that load
on a shared machine hits them alike. Pair counts are checked against selfcd's
exact answer and disagreements are printed as -missed +spurious pairs (warp
works in float32 and is not exact). Times are wall-clock, so only ratios taken
in one run mean much.

    PYTHONPATH=python python3 scripts/bench_peers.py --repeat 7 --json peers.json
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

import selfcd
from selfcd import io as mesh_io

REPO = Path(__file__).resolve().parents[1]
GRIDS = ("flat", "folded", "crumpled")
GARMENTS = ("dress_on_body", "multilayer_skirt_on_body", "skirt_32k", "body")
INPUTS = GRIDS + GARMENTS
METHODS = (selfcd.DEFAULT_METHOD, "bvh", "bvh-cones")
GRID_TRIANGLES, QUICK_TRIANGLES = 200_000, 3_200
FRAMES = 4  # frames of the per-frame sequence
FRAME_AMPLITUDE = 0.05  # per-frame motion, in median edge lengths
STEP_AMPLITUDE = 0.5  # continuous step, in median edge lengths
WAVELENGTH = 16.0  # of both motions, in median edge lengths
PROXIMITY = 0.6  # d, in median edge lengths
PROXIMITY_FRAMES = 2  # of the sequence, alternated (proximity is slow)


# ---------------------------------------------------------------- inputs

@dataclass
class Input:
    """One benchmark input: faces, the state measured and its motions."""

    name: str
    faces: np.ndarray
    rest: np.ndarray  # the shape the mesh (and selfcd's hierarchy) is built on
    state: np.ndarray  # the positions measured
    edge: float = 0.0  # median edge length of the state
    frames: list[np.ndarray] = field(default_factory=list)

    @property
    def triangles(self) -> int:
        return len(self.faces)


def grid_input(name: str, triangles: int) -> Input:
    """The square cloth in one of the `selfcd bench` states (flat, folded: 8 layers
    half an edge apart, crumpled: passes through itself)."""
    side = max(2, round((triangles / 2) ** 0.5) + 1)
    rest, faces = selfcd.scenes.grid(side)
    shapes = {
        "flat": ("flat", {}),
        "folded": ("zfold", {"layers": 8, "gap": 0.5 / (side - 1)}),
        "crumpled": ("crumple", {"amplitude": 0.3, "wavelength": 0.4, "seed": 1}),
    }
    shape, params = shapes[name]
    return Input(name, faces, rest, selfcd.scenes.deform(rest, shape, **params))


def data_dir() -> Path:
    """shared/data beside the repository (or beside its worktree folder), or $SELFCD_DATA."""
    if "SELFCD_DATA" in os.environ:
        return Path(os.environ["SELFCD_DATA"])
    found = [p / "shared" / "data" for p in (REPO.parent, REPO.parent.parent) if (p / "shared" / "data").is_dir()]
    return found[0] if found else REPO.parent / "shared" / "data"


def file_input(name: str) -> Input:
    """A real mesh of shared/data, measured in its own shape."""
    v, f = mesh_io.load_mesh(data_dir() / f"{name}.obj")
    return Input(name, f, v, v)


def median_edge(x: np.ndarray, faces: np.ndarray) -> float:
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    return float(np.median(np.linalg.norm(x[e[:, 0]] - x[e[:, 1]], axis=1)))


def wave(x: np.ndarray, amplitude: float, wavelength: float, phase: float) -> np.ndarray:
    """A smooth displacement field: each coordinate a sine wave of the next one."""
    k = 2 * np.pi / wavelength
    d = np.sin(k * x[:, [1, 2, 0]] + phase + np.array([0.0, 1.0, 2.0]))
    return x + amplitude * d


def prepare(inp: Input) -> Input:
    inp.edge = median_edge(inp.state, inp.faces)
    lam = WAVELENGTH * inp.edge
    inp.frames = [wave(inp.state, FRAME_AMPLITUDE * inp.edge, lam, 0.7 * k) for k in range(FRAMES)]
    return inp


def intersection_free(inp: Input) -> bool:
    """Whether the state and every frame of the sequence are free of intersections."""
    return all(len(selfcd.self_intersections(x, inp.faces)) == 0 for x in [inp.state, *inp.frames])


def load_input(name: str, quick: bool) -> Input:
    if name in GRIDS:
        return prepare(grid_input(name, QUICK_TRIANGLES if quick else GRID_TRIANGLES))
    return prepare(file_input(name))


# ---------------------------------------------------------------- peers

def try_import(module: str) -> tuple[Any, str]:
    """(module, version) or (None, why it is unavailable)."""
    try:
        mod = importlib.import_module(module)
    except Exception as exc:  # a broken install raises more than ImportError
        return None, f"unavailable ({type(exc).__name__}: {exc})"
    from importlib import metadata
    dist = {"warp": "warp-lang", "igl": "libigl", "ipctk": "ipctk"}[module]
    try:
        return mod, metadata.version(dist)
    except metadata.PackageNotFoundError:
        return mod, getattr(mod, "__version__", "?")


def pair_set(pairs: np.ndarray) -> set[tuple[int, int]]:
    p = np.sort(np.asarray(pairs, dtype=np.int64).reshape(-1, 2), axis=1)
    return set(map(tuple, p.tolist()))


def pair_rows(found: dict[str, np.ndarray]) -> tuple[set, set]:
    """The vertex-triangle and edge-edge pairs of a proximity or continuous answer."""
    return tuple({tuple(r) for r in found[k].tolist()} for k in ("vertex_triangle", "edge_edge"))


def non_adjacent(pairs: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """The pairs whose faces share no vertex index (the pairs selfcd reports)."""
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    shared = (faces[pairs[:, 0]][:, :, None] == faces[pairs[:, 1]][:, None, :]).any(axis=(1, 2))
    return pairs[~shared]


def agreement(exact: set, other: set) -> list[int]:
    """[missed, spurious]: exact pairs the other set lacks, and pairs it has beyond them."""
    return [len(exact - other), len(other - exact)]


def show_agreement(frames: list[list[int]]) -> str:
    """'=' when every frame agrees, else the range over frames of missed (-) and spurious (+) pairs."""
    if not any(m or s for m, s in frames):
        return "="
    span = [f"{min(v)}" if min(v) == max(v) else f"{min(v)}..{max(v)}" for v in zip(*frames)]
    return f"-{span[0]} +{span[1]}"


class Warp:
    """warp on CPU: float32 mesh BVH, one BVH query per triangle, wp.intersect_tri_tri."""

    def __init__(self, wp: Any) -> None:
        self.wp = wp
        wp.config.log_level = wp.LOG_WARNING  # no greeting or JIT messages among the tables
        wp.init()

        @wp.kernel
        def tri_pairs(mesh: wp.uint64, pts: wp.array(dtype=wp.vec3), idx: wp.array(dtype=wp.int32),
                      count: wp.array(dtype=wp.int32), out: wp.array(dtype=wp.int32, ndim=2)):
            t = wp.tid()
            a, b, c = idx[3 * t], idx[3 * t + 1], idx[3 * t + 2]
            pa, pb, pc = pts[a], pts[b], pts[c]
            q = wp.mesh_query_aabb(mesh, wp.min(wp.min(pa, pb), pc), wp.max(wp.max(pa, pb), pc))
            f = int(0)  # noqa: UP018  (warp: a typed variable the query writes to; a bare 0 is a constant)
            while wp.mesh_query_aabb_next(q, f):
                if f > t:
                    d, e, g = idx[3 * f], idx[3 * f + 1], idx[3 * f + 2]
                    if (d != a and d != b and d != c and e != a and e != b and e != c
                            and g != a and g != b and g != c):
                        if wp.intersect_tri_tri(pa, pb, pc, pts[d], pts[e], pts[g]) != 0:
                            k = wp.atomic_add(count, 0, 1)
                            if k < out.shape[0]:
                                out[k, 0] = t
                                out[k, 1] = f

        self.kernel = tri_pairs
        self.capacity = 1 << 16

    def _arrays(self, x: np.ndarray, faces: np.ndarray) -> tuple[Any, Any]:
        wp = self.wp
        pts = wp.array(x.astype(np.float32), dtype=wp.vec3, device="cpu")
        idx = wp.array(faces.astype(np.int32).ravel(), dtype=wp.int32, device="cpu")
        return pts, idx

    def query(self, mesh: Any, pts: Any, idx: Any, n_faces: int) -> np.ndarray:
        """All non-adjacent intersecting pairs, rerun with room for all of them if needed."""
        wp = self.wp
        while True:
            count = wp.zeros(1, dtype=wp.int32, device="cpu")
            out = wp.empty((self.capacity, 2), dtype=wp.int32, device="cpu")
            wp.launch(self.kernel, dim=n_faces, inputs=[mesh.id, pts, idx, count, out], device="cpu")
            wp.synchronize()
            n = int(count.numpy()[0])
            if n <= self.capacity:
                return out.numpy()[:n]
            self.capacity = 2 * n

    def one_shot(self, x: np.ndarray, faces: np.ndarray) -> np.ndarray:
        """Build + query from numpy arrays."""
        pts, idx = self._arrays(x, faces)
        mesh = self.wp.Mesh(points=pts, indices=idx)
        return self.query(mesh, pts, idx, len(faces))

    def kept(self, x: np.ndarray, faces: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        """A per-frame detector: copy positions in, refit, query."""
        pts, idx = self._arrays(x, faces)
        mesh = self.wp.Mesh(points=pts, indices=idx)

        def frame(p: np.ndarray) -> np.ndarray:
            pts.assign(p.astype(np.float32))
            mesh.refit()
            return self.query(mesh, pts, idx, len(faces))

        return frame


# ---------------------------------------------------------------- timing

def timed(fn: Callable[[], Any]) -> tuple[float, Any]:
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def rotated(names: list[str], rep: int) -> list[str]:
    """The runners' order in run `rep`, rotated by one each run: a runner timed right
    after a given other one (warp's CPU threads keep a core busy for a while after
    its calls) would otherwise pay for that neighbour in every run."""
    k = rep % len(names)
    return names[k:] + names[:k]


def med_ms(times: list[float]) -> float:
    return 1e3 * statistics.median(times) if times else float("nan")


def ratio(a: float, b: float) -> str:
    """a / b to two decimals, or two significant digits below 0.1."""
    if not (b == b and a == a and b > 0):
        return "-"
    r = a / b
    return f"{r:.2f}" if r >= 0.1 or r == 0 else f"{r:.2g}"


def ms(v: float) -> str:
    return "-" if v != v else (f"{v:.1f}" if v >= 10 else f"{v:.2f}")


class Progress:
    """A bar on stderr (tqdm), advanced once per timed call."""

    def __init__(self, total: int, quiet: bool) -> None:
        from tqdm import tqdm
        self.bar = tqdm(total=total, desc="bench", unit="call", disable=quiet, file=sys.stderr, leave=False)

    def __call__(self, label: str) -> None:
        self.bar.set_postfix_str(label, refresh=False)
        self.bar.update(1)

    def close(self) -> None:
        self.bar.close()


# ---------------------------------------------------------------- the four measurements

def per_frame(inp: Input, reps: int, warp: Warp | None, tick: Callable[[str], None]) -> dict[str, Any]:
    mesh = selfcd.Mesh(inp.rest, inp.faces)
    runners: dict[str, Callable[[np.ndarray], np.ndarray]] = {
        m: selfcd.Detector(mesh, m).detect for m in METHODS}
    if warp is not None:
        runners["warp"] = warp.kept(inp.state, inp.faces)
    times: dict[str, list[float]] = {k: [] for k in runners}
    last: dict[str, list[np.ndarray]] = {k: [] for k in runners}
    for rep in range(reps + 1):  # run 0 is the warm-up
        for k in rotated(list(runners), rep):
            run = runners[k]
            last[k] = []
            for p in inp.frames:
                t, pairs = timed(lambda run=run, p=p: run(p))
                last[k].append(pairs)
                if rep:
                    times[k].append(t)
            tick(f"{inp.name} per-frame {k}")
    exact = [pair_set(p) for p in last[selfcd.DEFAULT_METHOD]]
    row: dict[str, Any] = {"input": inp.name, "triangles": inp.triangles,
                           "exact_pairs": [len(s) for s in exact]}
    for k in runners:
        row[f"{k}_ms"] = med_ms(times[k])
        row[f"{k}_pairs"] = [len(p) for p in last[k]]
        row[f"{k}_vs_exact"] = [agreement(e, pair_set(p)) for e, p in zip(exact, last[k])]
    return row


def one_shot(inp: Input, reps: int, warp: Warp | None, igl: Any, tick: Callable[[str], None]) -> dict[str, Any]:
    x, f = inp.state, inp.faces
    runners: dict[str, Callable[[], np.ndarray]] = {"selfcd": lambda: selfcd.self_intersections(x, f)}
    if igl is not None:
        runners["libigl"] = lambda: igl.predicates.find_self_intersections(x, f)[1]
    if warp is not None:
        runners["warp"] = lambda: warp.one_shot(x, f)
    times: dict[str, list[float]] = {k: [] for k in runners}
    out: dict[str, np.ndarray] = {}
    for rep in range(reps + 1):
        for k in rotated(list(runners), rep):
            t, out[k] = timed(runners[k])
            if rep:
                times[k].append(t)
            tick(f"{inp.name} one-shot {k}")
    exact = pair_set(out["selfcd"])
    row: dict[str, Any] = {"input": inp.name, "triangles": inp.triangles, "exact_pairs": len(exact)}
    for k in runners:
        pairs = out[k] if k != "libigl" else non_adjacent(out[k], f)
        row[f"{k}_ms"] = med_ms(times[k])
        row[f"{k}_pairs"] = len(pairs)
        row[f"{k}_vs_exact"] = agreement(exact, pair_set(pairs))
    if "libigl" in out:
        row["libigl_adjacent_pairs"] = len(out["libigl"]) - row["libigl_pairs"]
    return row


def ipc_mesh(ipctk: Any, inp: Input, edges: np.ndarray) -> Any:
    return ipctk.CollisionMesh(inp.state, edges.astype(np.int32), inp.faces.astype(np.int32))


def proximity(inp: Input, reps: int, ipctk: Any, tick: Callable[[str], None]) -> dict[str, Any]:
    """selfcd's default detector with thickness d kept across calls, the one-shot
    `selfcd.proximity_contacts` (its hierarchy built for each call) and `SelfQueries`,
    against ipctk's NormalCollisions, which rebuilds its LBVH every call."""
    d = PROXIMITY * inp.edge
    mesh = selfcd.Mesh(inp.rest, inp.faces)
    kept = selfcd.Detector(mesh, thickness=d)
    queries = selfcd.SelfQueries(mesh)
    runners: dict[str, Callable[[np.ndarray], Any]] = {
        "selfcd": lambda p: (kept.detect(p), kept)[1],
        "selfcd_fresh": lambda p: selfcd.proximity_contacts(mesh, p, d),
        "selfcd_coherent": lambda p: queries.proximity(p, d)}
    if ipctk is not None:
        cm = ipc_mesh(ipctk, inp, mesh.edges)

        def ipc(p: np.ndarray) -> Any:
            nc = ipctk.NormalCollisions()
            nc.build(cm, p, d, broad_phase=ipctk.LBVH())
            return nc

        runners["ipctk"] = ipc
    times: dict[str, list[float]] = {k: [] for k in runners}
    out: dict[str, Any] = {}
    for rep in range(reps + 1):
        for k, run in runners.items():
            for p in inp.frames[:PROXIMITY_FRAMES]:
                t, out[k] = timed(lambda run=run, p=p: run(p))
                if rep:
                    times[k].append(t)
            tick(f"{inp.name} proximity {k}")
    prox = out["selfcd"].last_proximity
    for k, what in (("selfcd_coherent", "SelfQueries.proximity"), ("selfcd_fresh", "proximity_contacts")):
        if pair_rows(prox) != pair_rows(out[k]):
            raise AssertionError(f"{inp.name}: {what} differs from the detector's")
    dists = np.concatenate([prox["vertex_triangle_distance"], prox["edge_edge_distance"]])
    row: dict[str, Any] = {
        "input": inp.name, "triangles": inp.triangles, "d": d,
        "selfcd_vertex_triangle": len(prox["vertex_triangle"]), "selfcd_edge_edge": len(prox["edge_edge"]),
        "selfcd_min_distance": float(dists.min()) if len(dists) else None,
    }
    for k in runners:
        row[f"{k}_ms"] = med_ms(times[k])
    if "ipctk" in out:
        nc = out["ipctk"]
        row["ipctk_collisions"] = len(nc)
        # ipctk reports squared distances
        last = inp.frames[PROXIMITY_FRAMES - 1]
        row["ipctk_min_distance"] = float(np.sqrt(nc.compute_minimum_distance(cm, last))) if len(nc) else None
    return row


def continuous(inp: Input, reps: int, ipctk: Any, tick: Callable[[str], None]) -> dict[str, Any]:
    """One large linear step x0 -> x1 (a smooth wave of half an edge), both one-shot; then
    the small steps between the sequence's frames, per step (see `continuous_sequence`)."""
    x0 = inp.state
    x1 = wave(x0, STEP_AMPLITUDE * inp.edge, WAVELENGTH * inp.edge, 0.3)
    mesh = selfcd.Mesh(inp.rest, inp.faces)
    runners: dict[str, Callable[[], Any]] = {"selfcd": lambda: selfcd.continuous_impacts(mesh, x0, x1)}
    if ipctk is not None:
        cm = ipc_mesh(ipctk, inp, mesh.edges)

        def ipc() -> tuple[int, float]:
            cand = ipctk.Candidates()
            cand.build(cm, x0, x1, broad_phase=ipctk.LBVH())
            return len(cand), cand.compute_collision_free_stepsize(cm, x0, x1)

        runners["ipctk"] = ipc
    times: dict[str, list[float]] = {k: [] for k in runners}
    out: dict[str, Any] = {}
    for rep in range(reps + 1):
        for k in rotated(list(runners), rep):
            t, out[k] = timed(runners[k])
            if rep:
                times[k].append(t)
            tick(f"{inp.name} continuous {k}")
    imp = out["selfcd"]
    tois = np.concatenate([imp["vertex_triangle_toi"], imp["edge_edge_toi"]])
    row: dict[str, Any] = {
        "input": inp.name, "triangles": inp.triangles,
        "selfcd_pairs": int(len(tois)), "selfcd_first_toi": float(tois.min()) if len(tois) else 1.0,
    }
    for k in runners:
        row[f"{k}_ms"] = med_ms(times[k])
    if "ipctk" in out:
        row["ipctk_candidates"], row["ipctk_step"] = out["ipctk"]
    row.update(continuous_sequence(inp, mesh, reps, ipctk, tick))
    return row


def continuous_sequence(inp: Input, mesh: selfcd.Mesh, reps: int, ipctk: Any,
                        tick: Callable[[str], None]) -> dict[str, Any]:
    """The steps frames[k] -> frames[k+1] of the per-frame sequence (as a simulator's
    steps, small and coherent), timed per step: `selfcd.SelfQueries` kept across steps,
    `selfcd.continuous_impacts` fresh per step, and ipctk per step. The coherent answers
    are checked against the fresh ones."""
    steps = list(zip(inp.frames, inp.frames[1:]))
    queries = selfcd.SelfQueries(mesh)
    reuses = [0, 0]  # candidate sets built, reused (timed runs)

    def coherent(a: np.ndarray, b: np.ndarray) -> Any:
        found = queries.continuous(a, b)
        stats = queries.last_stats
        reuses[0] += stats["candidate_builds"]
        reuses[1] += stats["candidate_reuses"]
        return found

    runners: dict[str, Callable[[np.ndarray, np.ndarray], Any]] = {
        "coherent": coherent, "fresh": lambda a, b: selfcd.continuous_impacts(mesh, a, b)}
    if ipctk is not None:
        cm = ipc_mesh(ipctk, inp, mesh.edges)

        def ipc(a: np.ndarray, b: np.ndarray) -> float:
            cand = ipctk.Candidates()
            cand.build(cm, a, b, broad_phase=ipctk.LBVH())
            return cand.compute_collision_free_stepsize(cm, a, b)

        runners["ipctk"] = ipc
    times: dict[str, list[float]] = {k: [] for k in runners}
    pairs = extra = 0
    for rep in range(reps + 1):
        if rep == 1:
            reuses[:] = [0, 0]
        for k, run in runners.items():
            for a, b in steps:
                t, found = timed(lambda run=run, a=a, b=b: run(a, b))
                if rep:
                    times[k].append(t)
                if k == "coherent" and rep == reps:
                    # At thickness 0 the fresh query's swept certificate may drop
                    # false positives the coherent one keeps: it must hold every
                    # fresh pair, and any extra is counted.
                    fresh = selfcd.continuous_impacts(mesh, a, b)
                    got, want = pair_rows(found), pair_rows(fresh)
                    if any(not w <= g for g, w in zip(got, want)):
                        raise AssertionError(f"{inp.name}: SelfQueries.continuous misses a pair of a fresh query")
                    extra += sum(len(g - w) for g, w in zip(got, want))
                    pairs += sum(len(found[key]) for key in ("vertex_triangle", "edge_edge"))
            tick(f"{inp.name} continuous sequence {k}")
    row = {f"seq_{k}_ms": med_ms(v) for k, v in times.items()}
    row.update(seq_steps=len(steps), seq_pairs=pairs, seq_extra=extra, seq_builds=reuses[0], seq_reuses=reuses[1])
    return row


# ---------------------------------------------------------------- tables

def table(head: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(head) + " |", "|" + "|".join("---" if i == 0 else "---:" for i in range(len(head))) + "|"]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def frame_table(rows: list[dict[str, Any]]) -> str:
    head = ["input", "triangles", "selfcd ms", "bvh ms", "bvh-cones ms", "warp refit+query ms",
            "selfcd/warp", "bvh/warp", "bvh-cones/warp", "exact pairs", "bvh-cones vs exact", "warp vs exact"]
    body = []
    for r in rows:
        w = r.get("warp_ms", float("nan"))
        body.append([r["input"], str(r["triangles"]), ms(r[f"{selfcd.DEFAULT_METHOD}_ms"]), ms(r["bvh_ms"]),
                     ms(r["bvh-cones_ms"]), ms(w), ratio(r[f"{selfcd.DEFAULT_METHOD}_ms"], w),
                     ratio(r["bvh_ms"], w), ratio(r["bvh-cones_ms"], w), ",".join(map(str, r["exact_pairs"])),
                     show_agreement(r["bvh-cones_vs_exact"]),
                     show_agreement(r["warp_vs_exact"]) if "warp_vs_exact" in r else "-"])
    return table(head, body)


def oneshot_table(rows: list[dict[str, Any]]) -> str:
    head = ["input", "triangles", "selfcd ms", "libigl ms", "warp build+query ms", "selfcd/libigl",
            "selfcd/warp", "exact pairs", "libigl vs exact", "warp vs exact"]
    body = []
    for r in rows:
        li, w = r.get("libigl_ms", float("nan")), r.get("warp_ms", float("nan"))
        body.append([r["input"], str(r["triangles"]), ms(r["selfcd_ms"]), ms(li), ms(w), ratio(r["selfcd_ms"], li),
                     ratio(r["selfcd_ms"], w), str(r["exact_pairs"]),
                     *(show_agreement([r[k]]) if k in r else "-" for k in ("libigl_vs_exact", "warp_vs_exact"))])
    return table(head, body)


def proximity_table(rows: list[dict[str, Any]]) -> str:
    head = ["input", "triangles", "selfcd kept ms", "selfcd one-shot ms", "selfcd coherent ms", "ipctk ms",
            "kept/ipctk", "one-shot/ipctk", "coherent/ipctk", "selfcd VT+EE pairs", "ipctk collisions",
            "min distance selfcd / ipctk"]
    body = []
    for r in rows:
        ip = r.get("ipctk_ms", float("nan"))
        md = r["selfcd_min_distance"], r.get("ipctk_min_distance")
        body.append([r["input"], str(r["triangles"]), ms(r["selfcd_ms"]), ms(r["selfcd_fresh_ms"]),
                     ms(r["selfcd_coherent_ms"]), ms(ip), ratio(r["selfcd_ms"], ip), ratio(r["selfcd_fresh_ms"], ip),
                     ratio(r["selfcd_coherent_ms"], ip),
                     f"{r['selfcd_vertex_triangle']}+{r['selfcd_edge_edge']}", str(r.get("ipctk_collisions", "-")),
                     " / ".join("-" if v is None else f"{v:.6g}" for v in md)])
    return table(head, body)


def continuous_table(rows: list[dict[str, Any]]) -> str:
    head = ["input", "triangles", "one step: selfcd ms", "ipctk ms", "selfcd/ipctk", "selfcd pairs, first toi",
            "ipctk candidates, step", "sequence, per step: selfcd coherent ms", "selfcd fresh ms", "ipctk ms",
            "coherent/ipctk", "fresh/ipctk", "steps, pairs (+ coherent's extra false positives), sets built/reused"]
    body = []
    for r in rows:
        ip, sip = r.get("ipctk_ms", float("nan")), r.get("seq_ipctk_ms", float("nan"))
        peer = f"{r['ipctk_candidates']}, {r['ipctk_step']:.4g}" if "ipctk_step" in r else "-"
        body.append([r["input"], str(r["triangles"]), ms(r["selfcd_ms"]), ms(ip), ratio(r["selfcd_ms"], ip),
                     f"{r['selfcd_pairs']}, {r['selfcd_first_toi']:.4g}", peer, ms(r["seq_coherent_ms"]),
                     ms(r["seq_fresh_ms"]), ms(sip), ratio(r["seq_coherent_ms"], sip),
                     ratio(r["seq_fresh_ms"], sip),
                     f"{r['seq_steps']}, {r['seq_pairs']} (+{r.get('seq_extra', 0)}), {r['seq_builds']}/{r['seq_reuses']}"])
    return table(head, body)


def report(results: dict[str, Any]) -> str:
    parts = [f"selfcd {results['selfcd']}; " + "; ".join(f"{k} {v}" for k, v in results["peers"].items()),
             f"load before: {results['load_before']}", f"load after: {results.get('load_after', '-')}"]
    titles = {"per_frame": ("Per frame, hierarchy kept (refit + query), exact pairs; ms per frame", frame_table),
              "one_shot": ("One-shot (build + query)", oneshot_table),
              "proximity": ("Proximity, d = 0.6 x median edge length, per frame", proximity_table),
              "continuous": ("Continuous, from an intersection-free state: one large step, then the sequence's "
                                "small steps", continuous_table)}
    for key, (title, fmt) in titles.items():
        if results[key]:
            parts.append(f"\n{title}\n\n{fmt(results[key])}")
    return "\n".join(parts)


# ---------------------------------------------------------------- main

def load_average() -> str:
    try:
        return subprocess.run(["uptime"], capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "load average: {:.2f}, {:.2f}, {:.2f}".format(*os.getloadavg())


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--inputs", default=",".join(INPUTS),
                    help=f"comma-separated inputs (default: all of {', '.join(INPUTS)})")
    ap.add_argument("--repeat", type=int, default=5, help="timed runs per measurement, after a warm-up (default 5)")
    ap.add_argument("--quick", action="store_true",
                    help=f"grids of {QUICK_TRIANGLES} triangles instead of {GRID_TRIANGLES} (for a test)")
    ap.add_argument("--tables", default="per_frame,one_shot,proximity,continuous",
                    help="comma-separated tables to measure (default: all four)")
    ap.add_argument("--json", metavar="OUT", help="also write every row (and versions, load) as JSON to OUT")
    ap.add_argument("--no-progress", action="store_true", help="no progress bar")
    args = ap.parse_args(argv)
    args.inputs = [s.strip() for s in args.inputs.split(",") if s.strip()]
    args.tables = [s.strip() for s in args.tables.split(",") if s.strip()]
    for name in args.inputs:
        if name not in INPUTS:
            ap.error(f"unknown input {name!r}; expected one of {', '.join(INPUTS)}")
    for name in args.tables:
        if name not in ("per_frame", "one_shot", "proximity", "continuous"):
            ap.error(f"unknown table {name!r}")
    if args.repeat < 1:
        ap.error("--repeat must be at least 1")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    wp, wp_version = try_import("warp")
    igl, igl_version = try_import("igl")
    if igl is not None:
        import igl.predicates  # noqa: F401  (a submodule, not imported by `import igl`)
    ipctk, ipc_version = try_import("ipctk")
    results: dict[str, Any] = {
        "selfcd": selfcd.__version__, "peers": {"warp-lang": wp_version, "libigl": igl_version, "ipctk": ipc_version},
        "command": " ".join([Path(sys.argv[0]).name] + (sys.argv[1:] if argv is None else argv)),
        "machine": f"{platform.machine()}, {os.cpu_count()} cores", "quick": args.quick, "repeat": args.repeat,
        "load_before": load_average(), "per_frame": [], "one_shot": [], "proximity": [], "continuous": [],
    }
    warp = Warp(wp) if wp is not None else None
    calls = {"per_frame": len(METHODS) + (warp is not None), "one_shot": 1 + (igl is not None) + (warp is not None),
             "proximity": 3 + (ipctk is not None), "continuous": 3 + 2 * (ipctk is not None)}
    total = len(args.inputs) * (1 + (args.repeat + 1) * sum(calls[t] for t in args.tables))  # 1: loading
    bar = Progress(total, args.no_progress)
    status = 0
    try:
        for name in args.inputs:
            bar(f"loading {name}")
            inp = load_input(name, args.quick)
            if "per_frame" in args.tables:
                results["per_frame"].append(per_frame(inp, args.repeat, warp, bar))
            if "one_shot" in args.tables:
                results["one_shot"].append(one_shot(inp, args.repeat, warp, igl, bar))
            if "proximity" in args.tables:
                results["proximity"].append(proximity(inp, args.repeat, ipctk, bar))
            # continuous queries assume intersection-free starts
            if "continuous" in args.tables and intersection_free(inp):
                results["continuous"].append(continuous(inp, args.repeat, ipctk, bar))
    except KeyboardInterrupt:
        status = 130
        print("interrupted: the tables hold the inputs finished so far", file=sys.stderr)
    finally:
        bar.close()
    results["load_after"] = load_average()
    print(report(results))
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1) + "\n")
    return status


if __name__ == "__main__":
    sys.exit(main())
