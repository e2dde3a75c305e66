"""Times selfcd's one-shot query from Python called back to back, right after a
warp build+query (as `bench_peers.py` interleaves its runners), right after the
calling thread ran 20 ms of busy Python, and right after it slept 20 ms: the
differences are what handing each call's job to the pool costs when a pool
thread is still in rayon's idle loop on the caller's core (BENCHMARKS.md,
twenty-third and twenty-fourth landings). warp-lang (a benchmark extra) is
needed only for the warp way.

    SELFCD_DATA=../shared/data python3 scripts/bench_handoff.py [--inputs body,dress_on_body] [--repeat 10]

Prints, per input, the median and minimum of each way over `--repeat` calls,
alternating the ways twice. Run it with RAYON_NUM_THREADS=1 and =2 to see
whether the second thread's share survives the gap.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_peers  # noqa: E402

import selfcd  # noqa: E402
from selfcd.weld import UnweldedMeshWarning  # noqa: E402


def timed_calls(call: Callable[[], object], before: Callable[[], object] | None, repeat: int) -> list[float]:
    """Seconds of each of `repeat` calls, each preceded (untimed) by `before` if given."""
    times = []
    for _ in range(repeat):
        if before is not None:
            before()
        times.append(bench_peers.timed(call)[0])
    return times


def busy(seconds: float) -> None:
    """Keeps the calling thread running Python for `seconds`."""
    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        pass


def measure(inp: bench_peers.Input, warp: bench_peers.Warp | None, repeat: int) -> dict[str, list[float]]:
    """Seconds of selfcd's one-shot on `inp`, back to back and after each kind of gap."""
    x, f = inp.state, inp.faces
    for _ in range(3):  # warm-up: warp's kernel compile, selfcd's allocator
        if warp is not None:
            warp.one_shot(x, f)
        selfcd.self_intersections(x, f)
    ways: dict[str, Callable[[], object] | None] = {"back to back": None}
    if warp is not None:
        ways["after a warp call"] = lambda: warp.one_shot(x, f)
    ways["after 20 ms of busy Python"] = lambda: busy(0.02)
    ways["after 20 ms asleep"] = lambda: time.sleep(0.02)
    times: dict[str, list[float]] = {k: [] for k in ways}
    for _ in range(2):
        for way, before in ways.items():
            times[way] += timed_calls(lambda: selfcd.self_intersections(x, f), before, repeat)
    return times


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--inputs", default="body,dress_on_body", help="comma-separated bench_peers inputs")
    ap.add_argument("--repeat", type=int, default=10, help="calls per measurement (default 10)")
    args = ap.parse_args()
    wp, _ = bench_peers.try_import("warp")
    if wp is None:
        print("warp-lang is not installed (pip install warp-lang): timing the other ways only",
              file=sys.stderr)
    warp = None if wp is None else bench_peers.Warp(wp)
    warnings.simplefilter("ignore", UnweldedMeshWarning)
    for name in [s.strip() for s in args.inputs.split(",") if s.strip()]:
        times = measure(bench_peers.load_input(name, quick=False), warp, args.repeat)
        cells = [f"{way}: median {1e3 * statistics.median(t):.2f} ms, min {1e3 * min(t):.2f}"
                 for way, t in times.items()]
        print(f"{name}: " + "; ".join(cells))
    return 0


if __name__ == "__main__":
    sys.exit(main())
