"""The Python API against the brute-force reference on random meshes."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import numpy as np
import pytest

import selfcd
from conftest import brute_pairs, noisy_grid, random_shared, random_soup

CONSERVATIVE = [m for m in selfcd.methods() if m not in selfcd.non_conservative_methods()]


def as_set(pairs: np.ndarray) -> set[tuple[int, int]]:
    return {tuple(p) for p in pairs.tolist()}


def check_pairs_array(pairs: np.ndarray) -> None:
    """(k,2) int64, i < j, rows sorted and unique."""
    assert pairs.dtype == np.int64 and pairs.ndim == 2 and pairs.shape[1] == 2
    assert np.all(pairs[:, 0] < pairs[:, 1])
    keys = [tuple(p) for p in pairs.tolist()]
    assert keys == sorted(set(keys))


def test_methods_listed_from_engine() -> None:
    names = selfcd.methods()
    assert names[0] == "brute" and {"bvh", "bvh-cones", "bvh-cones-contour"} <= set(names)
    assert set(selfcd.non_conservative_methods()) < set(names)


@pytest.mark.parametrize("seed", range(6))
def test_every_method_matches_brute_on_random_soups(seed: int) -> None:
    rng = np.random.default_rng(seed)
    V, F = random_soup(rng, 120)
    want = brute_pairs(V, F)
    assert want, "the random soup should intersect somewhere"
    mesh = selfcd.Mesh(V, F)
    for method in selfcd.methods():
        try:
            det = selfcd.Detector(mesh, method)
        except ValueError as exc:  # the sensor needs a flat rest shape; a soup is not one
            assert method not in CONSERVATIVE and "flat" in str(exc), (method, exc)
            continue
        got = det.detect(V)
        check_pairs_array(got)
        if method in CONSERVATIVE:
            assert as_set(got) == want, method
        else:
            assert as_set(got) <= want, method


@pytest.mark.parametrize("seed", range(4))
def test_conservative_methods_match_brute_on_shared_vertex_meshes(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    V, F = random_shared(rng, 60, 150)
    want = brute_pairs(V, F)
    assert want
    mesh = selfcd.Mesh(V, F)
    for method in CONSERVATIVE:
        assert as_set(selfcd.Detector(mesh, method).detect(V)) == want, method
    assert as_set(selfcd.self_intersections(V, F)) == want


def test_adjacent_faces_are_never_reported(rng: np.random.Generator) -> None:
    V, F = random_shared(rng, 40, 200)
    pairs = selfcd.self_intersections(V, F)
    shared = [len(set(F[a]) & set(F[b])) for a, b in pairs.tolist()]
    assert pairs.size and not any(shared)


@pytest.mark.parametrize("seed", range(3))
def test_crumpled_cloth_animation_keeps_matching_brute(seed: int) -> None:
    """A detector keeps its BVH (and sensor) between calls: each frame still matches brute."""
    V, F = selfcd.scenes.grid(12)
    mesh = selfcd.Mesh(V, F)
    detectors = {m: selfcd.Detector(mesh, m) for m in selfcd.methods()}
    seen_contact = False
    for amplitude in np.linspace(0.0, 0.35, 8):
        P = selfcd.scenes.deform(V, "crumple", amplitude=float(amplitude), wavelength=0.4, seed=seed + 1)
        want = brute_pairs(V, F, P)
        seen_contact |= bool(want)
        for method, det in detectors.items():
            got = as_set(det.detect(P))
            assert got == want if method in CONSERVATIVE else got <= want, (method, amplitude)
    assert seen_contact


def test_any_memory_order_gives_the_same_answers(rng: np.random.Generator) -> None:
    """Fortran-order arrays (a transpose's) reach the engine without a copy
    and are read by columns; strided ones are copied. Every layout must give
    the C-order answers, also through `_core` directly."""
    V, F, P = noisy_grid(rng, 10, 0.3)
    want = selfcd.Detector(selfcd.Mesh(V, F)).detect(P)
    assert len(want) > 0
    for arr in (np.asfortranarray(P), np.ascontiguousarray(P.T).T, np.repeat(P, 2, axis=0)[::2]):
        assert np.array_equal(selfcd.Detector(selfcd.Mesh(V, F)).detect(arr), want)
        mesh = selfcd._core.Mesh(arr, np.asfortranarray(F))
        assert np.array_equal(mesh.vertices, P) and np.array_equal(mesh.faces, F)
    assert np.array_equal(selfcd.self_intersections(np.asfortranarray(P), np.asfortranarray(F)), want)


def test_last_stats_has_every_counter(rng: np.random.Generator) -> None:
    V, F, P = noisy_grid(rng, 11, 0.3)
    det = selfcd.Detector(selfcd.Mesh(V, F), "bvh")
    assert det.last_stats is None and det.last_proximity is None
    pairs = det.detect(P)
    s = det.last_stats
    assert s["contacts"] == len(pairs)
    assert s["primitive_tests"] >= len(pairs) and s["node_pairs"] > 0
    assert s["total_time"] == pytest.approx(s["refit_time"] + s["traverse_time"] + s["sensor_time"])
    assert s["triggered"] is None
    brute = selfcd.Detector(selfcd.Mesh(V, F), "brute")
    brute.detect(P)
    assert brute.last_stats["primitive_tests"] > s["primitive_tests"]


def test_default_positions_are_the_rest_shape() -> None:
    V, F = selfcd.scenes.grid(6)
    det = selfcd.Detector(selfcd.Mesh(V, F))
    assert det.method == selfcd.DEFAULT_METHOD
    assert det.detect().shape == (0, 2)


def proximity_reference(V: np.ndarray, F: np.ndarray, P: np.ndarray, d: float) -> set[tuple[int, int]]:
    """Vertex-triangle pairs closer than d, by dense sampling-free exact projection (numpy)."""
    out = set()
    for t, (a, b, c) in enumerate(F):
        A, B, C = P[a], P[b], P[c]
        for v in range(len(P)):
            if v in (a, b, c):
                continue
            if _point_triangle_distance(P[v], A, B, C) < d:
                out.add((v, t))
    return out


def _point_triangle_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> float:
    """Distance from p to triangle abc: interior projection or closest edge point."""
    n = np.cross(b - a, c - a)
    n = n / np.linalg.norm(n)
    q = p - np.dot(p - a, n) * n
    inside = all(np.dot(np.cross(y - x, q - x), n) >= 0 for x, y in ((a, b), (b, c), (c, a)))
    if inside:
        return float(abs(np.dot(p - a, n)))

    def seg(x: np.ndarray, y: np.ndarray) -> float:
        t = np.clip(np.dot(p - x, y - x) / np.dot(y - x, y - x), 0, 1)
        return float(np.linalg.norm(p - (x + t * (y - x))))

    return min(seg(a, b), seg(b, c), seg(c, a))


def test_proximity_vertex_triangle_matches_numpy_reference(rng: np.random.Generator) -> None:
    V, F = selfcd.scenes.grid(7)
    P = selfcd.scenes.deform(V, "fold", angle=np.pi, radius=0.04)
    d = 0.1
    det = selfcd.Detector(selfcd.Mesh(V, F), thickness=d)
    det.detect(P)
    prox = det.last_proximity
    got = {tuple(x) for x in prox["vertex_triangle"].tolist()}
    assert got == proximity_reference(V, F, P, d)
    assert np.all(prox["vertex_triangle_distance"] < d)
    assert prox["vertex_triangle_bary"].shape == (len(got), 3)
    edges = selfcd.Mesh(V, F).edges
    ee = prox["edge_edge"]
    assert ee.shape[0] > 0 and np.array_equal(prox["edge_edge_vertices"], edges[ee].reshape(-1, 4))
    assert det.last_stats["proximity_contacts"] == len(got) + len(ee)


def test_zero_thickness_reports_no_proximity() -> None:
    V, F = selfcd.scenes.grid(5)
    det = selfcd.Detector(selfcd.Mesh(V, F))
    det.detect(V)
    assert all(len(a) == 0 for a in det.last_proximity.values())


def test_sensor_options_reach_the_engine() -> None:
    V, F = selfcd.scenes.grid(9)
    det = selfcd.Detector(selfcd.Mesh(V, F), "sensor-gated", count=6, tolerance=1.5)
    det.detect(V)
    assert det.particles().shape == (6, 3)
    assert det.last_stats["triggered"] in (True, False)
    assert selfcd.Detector(selfcd.Mesh(V, F), "bvh").particles().shape == (0, 3)


def test_compare_methods_counts_misses_against_reference() -> None:
    V, F = selfcd.scenes.grid(11)
    frames = np.stack([selfcd.scenes.deform(V, "crumple", amplitude=a, wavelength=0.6, seed=3)
                       for a in np.linspace(0, 0.3, 10)])
    mesh = selfcd.Mesh(V, F)
    calls = []
    runs = selfcd.compare_methods(mesh, frames, progress=calls.append)
    assert [r["method"] for r in runs] == selfcd.methods()
    assert calls[-1] == len(runs) * len(frames)
    ref = selfcd.reference_pairs(mesh, frames)
    for run in runs:
        assert run["stats"]["total_time"].shape == (10,)
        assert np.all(run["spurious"] == 0)
        found = run["stats"]["contacts"]
        assert np.array_equal(found + run["missed"], [len(r) for r in ref]), run["method"]


def test_compare_progress_errors_propagate() -> None:
    V, F = selfcd.scenes.grid(5)

    def boom(done: int) -> None:
        raise KeyError("stop")

    with pytest.raises(KeyError):
        selfcd.compare_methods(selfcd.Mesh(V, F), np.stack([V, V]), ["bvh"], progress=boom)


def _longest_stall_during(work) -> tuple[float, float]:
    """Runs `work` in a thread while this thread keeps counting; returns (seconds the
    work took, longest gap between two counts). A call that held the GIL would
    stall this thread for its whole length."""
    import time

    done: list[float] = []

    def worker() -> None:
        t0 = time.perf_counter()
        work()
        done.append(time.perf_counter() - t0)

    t = threading.Thread(target=worker)
    last, longest = time.perf_counter(), 0.0
    t.start()
    while t.is_alive():
        now = time.perf_counter()
        longest, last = max(longest, now - last), now
    t.join()
    return done[0], longest


def _measure_growing(make_work, sizes=(2, 8, 32, 128)) -> tuple[float, float]:
    """`_longest_stall_during` on ever larger work until one call takes over 0.3 s."""
    for size in sizes:
        took, stall = _longest_stall_during(make_work(size))
        if took > 0.3:
            break
    return took, stall


def test_long_calls_release_the_gil() -> None:
    V, F = selfcd.scenes.grid(150)
    P = selfcd.scenes.deform(V, "crumple", amplitude=0.3, wavelength=0.4, seed=5)
    mesh = selfcd.Mesh(V, F)
    took, stall = _measure_growing(lambda k: lambda: selfcd.compare_methods(mesh, np.stack([P] * k), ["bvh"]))
    assert took > 0.3, "the call should be long enough to tell"
    assert stall < took / 2, f"compare_methods blocked Python for {stall:.3f} s of {took:.3f} s"
    sim = selfcd.Simulation("center", 30)
    took, stall = _measure_growing(lambda k: lambda: sim.run(10 * k))
    assert took > 0.3 and stall < took / 2, f"Simulation.run blocked Python for {stall:.3f} s of {took:.3f} s"


def test_threads_detecting_at_once_agree() -> None:
    V, F = selfcd.scenes.grid(120)
    P = selfcd.scenes.deform(V, "crumple", amplitude=0.3, wavelength=0.4, seed=5)
    mesh = selfcd.Mesh(V, F)
    results: list[np.ndarray] = []
    threads = [threading.Thread(target=lambda: results.append(selfcd.Detector(mesh).detect(P))) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(results) == 2 and np.array_equal(results[0], results[1]) and len(results[0]) > 0


@pytest.mark.parametrize("threads", ["1", "2"])
def test_calls_from_other_threads_finish_at_any_pool_size(threads: str) -> None:
    # A call from another thread, made while the importing thread waits
    # outside the engine, must find a pool thread to run it at any pool size
    # (a pool that took the importing thread in as one of its workers would
    # have none left at one thread: BENCHMARKS.md, twenty-third landing).
    code = """
        import threading, selfcd
        V, F = selfcd.scenes.grid(40)
        P = selfcd.scenes.deform(V, "crumple", amplitude=0.3, wavelength=0.4, seed=5)
        out = []
        t = threading.Thread(target=lambda: out.append(selfcd.self_intersections(P, F).tolist()))
        t.start()
        t.join()
        print(len(out[0]) > 0 and out[0] == selfcd.self_intersections(P, F).tolist())
    """
    env = {**os.environ, "PYTHONPATH": str(Path(selfcd.__file__).parent.parent), "RAYON_NUM_THREADS": threads}
    r = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, env=env,
                       timeout=120)
    assert r.returncode == 0 and r.stdout.strip() == "True", r.stderr



def _pool_cpus(**env: str) -> tuple[list[str], str]:
    """The CPU list of each `selfcd-<i>` pool thread, and the process's, in a fresh interpreter
    run with `env` (and neither RAYON_NUM_THREADS nor SELFCD_PIN_THREADS unless given)."""
    code = """
        import os, selfcd
        V, F = selfcd.scenes.grid(20)
        selfcd.self_intersections(V, F)
        def allowed(status):
            return next(l.split()[1] for l in open(status) if l.startswith("Cpus_allowed_list"))
        rows = []
        for tid in os.listdir("/proc/self/task"):
            if open(f"/proc/self/task/{tid}/comm").read().startswith("selfcd-"):
                rows.append(allowed(f"/proc/self/task/{tid}/status"))
        print(";".join(rows) + "|" + allowed("/proc/self/status"))
    """
    base = {k: v for k, v in os.environ.items() if k not in ("RAYON_NUM_THREADS", "SELFCD_PIN_THREADS")}
    full = {**base, "PYTHONPATH": str(Path(selfcd.__file__).parent.parent), **env}
    r = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, env=full,
                       timeout=120)
    assert r.returncode == 0, r.stderr
    threads, process = r.stdout.strip().split("|")
    return threads.split(";"), process


@pytest.mark.skipif(not sys.platform.startswith("linux") or len(os.sched_getaffinity(0)) < 2,
                    reason="pinning is for Linux with two CPUs or more")
def test_a_full_pool_is_pinned_one_thread_per_cpu_and_a_smaller_one_is_not() -> None:
    # The pool's threads stay off the caller's core between calls only when
    # pinned (BENCHMARKS.md, twenty-fifth landing); a pool smaller than the
    # machine, or one pinning was turned off for, keeps the process's CPUs.
    cpus = sorted(os.sched_getaffinity(0))
    full = str(len(cpus))
    threads, _ = _pool_cpus(RAYON_NUM_THREADS=full)
    assert sorted(threads, key=int) == [str(c) for c in cpus]
    threads, process = _pool_cpus(RAYON_NUM_THREADS=full, SELFCD_PIN_THREADS="0")
    assert len(threads) == len(cpus) and set(threads) == {process}
    threads, process = _pool_cpus(RAYON_NUM_THREADS="1")
    assert threads == [process]
    # The default pool: one thread per CPU it may use (pinned), or fewer
    # where a CPU quota says so (not pinned).
    threads, process = _pool_cpus()
    if len(threads) == len(cpus):
        assert sorted(threads, key=int) == [str(c) for c in cpus]
    else:
        assert set(threads) == {process}
