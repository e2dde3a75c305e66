"""Faults: allocation failures raise MemoryError, Ctrl-C stops long calls promptly
with KeyboardInterrupt, and every parameter is checked by type and range."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import selfcd

V, F = selfcd.scenes.grid(5)
ENV = {**os.environ, "PYTHONPATH": str(Path(selfcd.__file__).parent.parent)}


def _python(code: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, env=ENV,
                          timeout=timeout)


def test_a_grid_too_large_to_allocate_is_a_memory_error() -> None:
    # Under a 4 GiB address-space limit the 51 GB vertex array cannot be reserved
    # on any machine: the engine must raise, not abort (SIGABRT, exit 134).
    r = _python("""
        import resource
        resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))
        from selfcd import bench
        try:
            bench.run([4_294_000_000], ["flat"], ["bvh"])
        except MemoryError as exc:
            print("MemoryError:", exc)
    """)
    assert r.returncode == 0, r.stderr
    assert "MemoryError: out of memory: grid vertices needs 51530821656 bytes" in r.stdout


@pytest.mark.parametrize(("size", "words"), [("0", "at least 8 triangles"), ("-3", "non-negative integers"),
                                             ("99999999999", "32-bit indices")])
def test_bench_sizes_out_of_range_exit_2(size: str, words: str) -> None:
    r = subprocess.run([sys.executable, "-m", "selfcd", "bench", "--sizes", size], capture_output=True, text=True,
                       env=ENV, timeout=120)
    assert r.returncode == 2 and words in r.stderr and "Traceback" not in r.stderr, (r.returncode, r.stderr)


def _interrupt_after(code: str, delay: float) -> tuple[subprocess.CompletedProcess[str], float]:
    """Runs `code`, sends SIGINT after `delay` s; returns the result and the seconds from signal to exit."""
    p = subprocess.Popen([sys.executable, "-c", textwrap.dedent(code)], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, env=ENV)
    time.sleep(delay)
    assert p.poll() is None, "the call ended before the interrupt"
    t0 = time.perf_counter()
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=60)
    return subprocess.CompletedProcess(p.args, p.returncode, out, err), time.perf_counter() - t0


@pytest.mark.parametrize("call", [
    "selfcd.Simulation('center', resolution=31).run(1_000_000)",
    "selfcd.compare_methods(selfcd.Mesh(V, F), np.repeat(V[None], 200_000, axis=0), ['brute'])",
])
def test_ctrl_c_stops_long_calls_promptly(call: str) -> None:
    code = f"""
        import sys, numpy as np, selfcd
        V, F = selfcd.scenes.grid(12)
        print("ready", flush=True)
        try:
            {call}
        except KeyboardInterrupt:
            print("KeyboardInterrupt", flush=True)
            sys.exit(0)
        print("finished")
    """
    r, seconds = _interrupt_after(code, 4.0)
    assert r.returncode == 0 and "KeyboardInterrupt" in r.stdout, (r.stdout, r.stderr)
    assert "PanicException" not in r.stderr
    assert seconds < 5.0, f"took {seconds:.1f} s to stop"


def test_ctrl_c_in_the_cli_exits_130(tmp_path: Path) -> None:
    frames = np.repeat(V[None], 3_000_000 // len(V), axis=0)
    np.savez(tmp_path / "long.npz", V=frames, F=F)
    r, _ = _interrupt_after(f"from selfcd.cli import main; main(['detect', {str(tmp_path / 'long.npz')!r}])", 6.0)
    assert r.returncode == 130, (r.returncode, r.stderr[-500:])
    assert "Interrupted." in r.stderr and "Traceback" not in r.stderr


M = selfcd.Mesh(V, F)


@pytest.mark.parametrize(("call", "error", "words"), [
    (lambda: selfcd.Detector(M, "sensor-gated", n_max=2**32 - 1), ValueError, "n_max must be in 1..=10000"),
    (lambda: selfcd.Detector(M, "sensor-gated", n_min=9, n_max=8), ValueError, "must not exceed n_max"),
    (lambda: selfcd.Detector(M, "sensor-gated", count=10**6), ValueError, "count must be at most"),
    (lambda: selfcd.Detector(M, thickness="0.1"), TypeError, "thickness must be a number"),
    (lambda: selfcd.Detector(M, thickness=True), TypeError, "thickness must be a number"),
    (lambda: selfcd.Detector(M, thickness=float("nan")), ValueError, "thickness must be finite"),
    (lambda: selfcd.compare_methods(M, V[None], thickness="1"), TypeError, "thickness must be a number"),
    (lambda: selfcd.continuous_impacts(M, V, V, thickness="0"), TypeError, "thickness must be a number"),
    (lambda: selfcd.Simulation("corner", self_collision="no"), TypeError, "self_collision must be True or False"),
    (lambda: selfcd.Simulation("corner", resolution=5.0), TypeError, "resolution must be an integer"),
    (lambda: selfcd.Simulation("corner", dt="0.01"), TypeError, "dt must be a number"),
    (lambda: selfcd.Simulation("corner", resolution=3).run(2.5), TypeError, "steps must be an integer"),
    (lambda: selfcd.Simulation("corner", resolution=3).run(2, every=0), ValueError, "every must be at least 1"),
    (lambda: selfcd.scenes.deform(V, "fold", angle=float("nan")), ValueError, "angle must be finite"),
    (lambda: selfcd.scenes.deform(V, "twist", turns=float("inf")), ValueError, "turns must be finite"),
    (lambda: selfcd.scenes.deform(V, "crumple", wavelength=0.0), ValueError, "wavelength must be finite and > 0"),
    (lambda: selfcd.scenes.deform(V, "roll", gap=float("nan")), ValueError, "gap must be finite"),
    (lambda: selfcd.scenes.deform(V, "fold", radius=-1.0), ValueError, "radius must be finite and >= 0"),
    (lambda: selfcd.scenes.deform(V, "zfold", layers=0), ValueError, "layers must be at least 1"),
    (lambda: selfcd.scenes.deform(V, "zfold", layers=2.5), ValueError, "layers must be a whole number"),
    (lambda: selfcd.scenes.deform(V, "noise", seed=-1), ValueError, "seed must be a whole number"),
    (lambda: selfcd.scenes.deform(V, "fold", angle="1"), TypeError, "angle must be a number"),
])
def test_parameters_are_checked(call, error, words) -> None:
    with pytest.raises(error, match=words):
        call()


@pytest.mark.parametrize("method", selfcd.methods())
def test_proximity_output_is_guarded(method: str) -> None:
    # A thickness larger than the mesh: every vertex is near every face. The
    # grid is folded onto itself so that the particle gate triggers too.
    folded = selfcd.scenes.deform(V, "fold", angle=np.pi)
    det = selfcd.Detector(M, method, thickness=10.0, max_contacts=100)
    with pytest.raises(ValueError, match="stopped at 100 contacts: thickness 10 is too large"):
        det.detect(folded)
    everything = selfcd.Detector(M, method, thickness=10.0)
    everything.detect(folded)
    n = len(everything.last_proximity["vertex_triangle"]) + len(everything.last_proximity["edge_edge"])
    assert n > 100
    exact = selfcd.Detector(M, method, thickness=10.0, max_contacts=n)
    exact.detect()  # the limit itself is allowed
    with pytest.raises(TypeError, match="max_contacts must be an integer"):
        selfcd.Detector(M, method, max_contacts=1.5)
