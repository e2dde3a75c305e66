"""`selfcd batch`: inputs of every kind, rows equal to the serial run on local processes
and on a local Ray head, bad inputs as error rows."""

from __future__ import annotations

import csv
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
import ray

import selfcd
from selfcd import batch
from selfcd.io import save_obj
from selfcd.usd import write_usd


def crumpling(n: int, amplitudes: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray]:
    V, F = selfcd.scenes.grid(n)
    return np.stack([selfcd.scenes.deform(V, "crumple", amplitude=a, wavelength=0.4, seed=5)
                     for a in amplitudes]), F


def expected_counts(frames: np.ndarray, F: np.ndarray) -> list[int]:
    return [len(p) for p in selfcd.reference_pairs(selfcd.Mesh(frames[0], F), frames)]


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> tuple[list[str], dict[str, list[int]]]:
    """A directory of OBJ frames (named so that natural order differs from text order), an
    .npz animation, a USD animation, one mesh, and two bad inputs; with the expected counts."""
    root = tmp_path_factory.mktemp("batch")
    seq, F = crumpling(11, (0.0, 0.3, 0.1))
    (root / "seq").mkdir()
    for k, name in enumerate(["f2.obj", "f10.obj", "f100.obj"]):  # text order would be f10, f100, f2
        save_obj(root / "seq" / name, seq[k], F)
    (root / "seq" / "notes.txt").write_text("not a frame")
    anim, G = crumpling(15, (0.0, 0.2, 0.35, 0.25))
    np.savez(root / "anim.npz", V=anim, F=G)
    write_usd(root / "anim.usdc", anim, G)
    save_obj(root / "one.obj", anim[2], G)
    (root / "bad.obj").write_text("garbage\n")
    (root / "empty").mkdir()
    want = {str(root / "seq"): expected_counts(seq, F), str(root / "anim.npz"): expected_counts(anim, G),
            str(root / "anim.usdc"): expected_counts(anim.astype(np.float32).astype(np.float64), G),
            str(root / "one.obj"): expected_counts(anim[2:3], G)}
    paths = [str(root / p) for p in ("seq", "anim.npz", "bad.obj", "anim.usdc", "one.obj", "missing.ply", "empty")]
    return paths, want


def comparable(rows: list[dict]) -> list[dict]:
    """Rows without their timings."""
    return [{k: v for k, v in r.items() if k != "seconds"} for r in rows]


def test_natural_order() -> None:
    names = ["f10.obj", "f2.obj", "F1.obj", "f100.obj", "g.obj"]
    assert sorted(names, key=batch.natural_key) == ["F1.obj", "f2.obj", "f10.obj", "f100.obj", "g.obj"]


def test_rows_match_the_reference_and_bad_inputs_are_rows(inputs: tuple[list[str], dict[str, list[int]]]) -> None:
    paths, want = inputs
    rows = batch.run_local(paths, selfcd.DEFAULT_METHOD, 1)
    assert [r["input"] for r in rows] == paths
    for r in rows:
        if r["input"] in want:
            counts = want[r["input"]]
            assert r["error"] == "" and r["frames"] == len(counts)
            assert r["pairs_total"] == sum(counts) and r["pairs_max"] == max(counts)
            assert r["frames_with_intersections"] == sum(c > 0 for c in counts)
        else:
            assert r["error"] and r["frames"] == "" and r["seconds"] >= 0
    assert sum(want[paths[0]]) > 0 and want[paths[0]][0] == 0
    by_input = {r["input"]: r for r in rows}
    assert "no triangles" in by_input[paths[2]]["error"] and "no such file" in by_input[paths[5]]["error"]
    assert "no mesh files" in by_input[paths[6]]["error"]


def test_processes_equal_the_serial_run(inputs: tuple[list[str], dict[str, list[int]]]) -> None:
    paths, _ = inputs
    serial = batch.run_local(paths, "bvh", 1)
    # The engine's thread pool is running in this process now (a mesh large enough to traverse in
    # parallel): forked workers would inherit it without its threads and hang; spawned ones do not.
    selfcd.self_intersections(*selfcd.scenes.grid(70))
    done: list[int] = []
    with ThreadPoolExecutor(1) as runner:
        rows = runner.submit(batch.run_local, paths, "bvh", 2, done.append).result(timeout=120)
    assert comparable(rows) == comparable(serial)
    assert sorted(done) == list(range(1, len(paths) + 1))


def test_cli_writes_results_and_index(inputs: tuple[list[str], dict[str, list[int]]], tmp_path: Path) -> None:
    paths, want = inputs
    out = subprocess.run([sys.executable, "-m", "selfcd", "batch", *paths, "--out", str(tmp_path / "o"),
                          "--workers", "2"], capture_output=True, text=True, timeout=300)
    assert out.returncode == 2, out.stderr  # some inputs are bad
    with (tmp_path / "o" / "results.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0]) == batch.COLUMNS
    assert [r["input"] for r in rows] == paths
    assert int(rows[1]["pairs_total"]) == sum(want[paths[1]])
    page = (tmp_path / "o" / "index.html").read_text()
    assert 'id="results"' in page and "Plotly.newPlot" in page and "<script src=" not in page
    good = [p for p in paths if p in want]
    clean = subprocess.run([sys.executable, "-m", "selfcd", "batch", good[-1], "--out", str(tmp_path / "c")],
                           capture_output=True, text=True, timeout=300)
    assert clean.returncode == 1, clean.stderr  # one.obj intersects
    assert want[good[-1]][0] > 0


@pytest.fixture(scope="module")
def ray_head() -> str:
    """A local Ray head on 127.0.0.1: two CPUs, a small object store, no dashboard."""
    ray.init(address="local", num_cpus=2, object_store_memory=80 * 1024**2, include_dashboard=False,
             _node_ip_address="127.0.0.1", log_to_driver=False)
    yield ray.get_runtime_context().gcs_address
    ray.shutdown()


def test_ray_equals_the_serial_run(inputs: tuple[list[str], dict[str, list[int]]], ray_head: str,
                                   tmp_path: Path) -> None:
    paths, _ = inputs
    serial = batch.run_local(paths, selfcd.DEFAULT_METHOD, 1)
    assert comparable(batch.run_ray(paths, selfcd.DEFAULT_METHOD, "local")) == comparable(serial)
    assert ray.is_initialized(), "a Ray the caller started is left running"
    # the command line joins the running head by its address
    out = subprocess.run([sys.executable, "-m", "selfcd", "batch", *paths, "--out", str(tmp_path / "r"),
                          "--ray", ray_head], capture_output=True, text=True, timeout=300)
    assert out.returncode == 2, out.stderr
    with (tmp_path / "r" / "results.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert [r["pairs_total"] for r in rows] == [str(r["pairs_total"]) for r in serial]
    assert [r["error"] for r in rows] == [r["error"] for r in serial]
