"""The `selfcd` command line end to end, in child processes, on small inputs."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import numpy as np
import pytest
import trimesh

import selfcd
from selfcd.io import save_obj


def run(*args: str, cwd: Path | None = None, timeout: int = 300) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "selfcd", *args], capture_output=True, text=True, cwd=cwd,
                          timeout=timeout)


def test_console_script_is_installed() -> None:
    scripts = Path(sysconfig.get_path("scripts"))
    exe = shutil.which("selfcd", path=str(scripts))
    assert exe, f"pip install . should put the selfcd command in {scripts}"
    out = subprocess.run([exe, "--help"], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0
    for sub in ("demo", "detect", "simulate", "bench"):
        assert sub in out.stdout


@pytest.mark.parametrize("sub", ["demo", "detect", "simulate", "bench"])
def test_each_subcommand_has_help(sub: str) -> None:
    out = run(sub, "--help")
    assert out.returncode == 0 and "Usage:" in out.stdout


@pytest.fixture(scope="module")
def obj_files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("objs")
    V, F = selfcd.scenes.grid(9)
    shapes = {"flat": V, "folded": selfcd.scenes.deform(V, "fold", angle=np.pi, radius=0.05),
              "through": selfcd.scenes.deform(V, "fold", angle=1.2 * np.pi, radius=0.05)}
    paths = {}
    for name, P in shapes.items():
        paths[name] = d / f"{name}.obj"
        save_obj(paths[name], P, F)
    np.savez(d / "through.npz", V=shapes["through"], F=F)
    trimesh.Trimesh(shapes["through"], F, process=False).export(d / "through.ply")
    paths["ply"] = d / "through.ply"
    paths["npz"] = d / "through.npz"
    V2, F2 = selfcd.scenes.grid(5)
    save_obj(d / "other.obj", V2, F2)
    paths["other"] = d / "other.obj"
    paths["expected"] = selfcd.self_intersections(shapes["through"], F)
    return paths


def test_detect_clean_mesh_exits_0(obj_files) -> None:
    out = run("detect", str(obj_files["flat"]), str(obj_files["folded"]))
    assert out.returncode == 0, out.stderr
    assert "flat.obj: 0 intersecting" in out.stdout and "folded.obj: 0 intersecting" in out.stdout


def test_detect_intersecting_mesh_exits_1_and_lists_pairs(obj_files) -> None:
    out = run("detect", str(obj_files["flat"]), str(obj_files["through"]))
    assert out.returncode == 1
    n = len(obj_files["expected"])
    assert n > 0 and f"through.obj: {n} intersecting" in out.stdout


def test_detect_json_matches_the_api(obj_files) -> None:
    out = run("detect", "--json", "--method", "bvh", str(obj_files["through"]), str(obj_files["npz"]),
              str(obj_files["ply"]))
    assert out.returncode == 1
    data = json.loads(out.stdout)
    assert data["intersecting"] is True and data["method"] == "bvh" and len(data["files"]) == 3
    for rec in data["files"]:
        assert rec["pairs"] == obj_files["expected"].tolist()
        assert rec["stats"]["contacts"] == len(obj_files["expected"])


def test_detect_one_mesh_runs_the_one_shot_query(obj_files) -> None:
    """One file with the default method runs the one-shot query: the same pairs
    as a detector, and stats with a detector's keys (its own counters)."""
    from selfcd.check import check_frames
    from selfcd.io import load_mesh

    out = run("detect", "--json", str(obj_files["through"]))
    assert out.returncode == 1
    (rec,) = json.loads(out.stdout)["files"]
    assert rec["pairs"] == obj_files["expected"].tolist()
    v, f = load_mesh(obj_files["through"])
    det = selfcd.Detector(selfcd.Mesh(v, f))
    assert np.array_equal(det.detect(v), obj_files["expected"])
    assert set(rec["stats"]) == set(det.last_stats)
    assert rec["stats"]["contacts"] == len(obj_files["expected"]) and rec["stats"]["refit_time"] == 0.0
    one = check_frames(v[None], f, ["through"])
    many = check_frames(np.stack([v, v]), f, ["a", "b"])
    assert np.array_equal(one.pairs[0], many.pairs[0]) and np.array_equal(many.pairs[1], one.pairs[0])
    assert one.stats[0]["refit_time"] == 0.0 and set(one.stats[0]) == set(many.stats[0])


def test_detect_bad_inputs_exit_2(obj_files, tmp_path: Path) -> None:
    out = run("detect", str(tmp_path / "missing.obj"))
    assert out.returncode == 2 and "no such file" in out.stderr
    out = run("detect", str(obj_files["flat"]), str(obj_files["other"]))
    assert out.returncode == 2 and "faces differ" in out.stderr
    bad = tmp_path / "bad.npz"
    np.savez(bad, X=np.zeros(3))
    out = run("detect", str(bad))
    assert out.returncode == 2 and "needs arrays V and F" in out.stderr
    out = run("detect", "--method", "nope", str(obj_files["flat"]))
    assert out.returncode == 2 and "nope" in out.stderr
    V, F = selfcd.scenes.grid(4)
    nan_frames = tmp_path / "nan.npz"
    np.savez(nan_frames, V=np.stack([V, np.full_like(V, np.nan)]), F=F)
    out = run("detect", str(nan_frames))
    assert out.returncode == 2 and "nan.npz[1]" in out.stderr and "non-finite" in out.stderr


def test_demo_writes_report_and_summary(tmp_path: Path) -> None:
    out = run("demo", "--frames", "6", "--out", str(tmp_path / "rep"))
    assert out.returncode == 0, out.stderr
    summary = json.loads((tmp_path / "rep" / "summary.json").read_text())
    assert [s["name"] for s in summary["scenes"]] == selfcd.paper_scenes()
    assert [s["paper_figure"] for s in summary["scenes"]] == [4, 6, 8]
    for scene in summary["scenes"]:
        assert scene["frames"] == 6 and scene["triangles"] == 200 and scene["proximity_thickness"] > 0
        assert list(scene["methods"]) == selfcd.methods()
        for name, m in scene["methods"].items():
            assert m["frames"] == 6 and m["mean_time_ms"] >= 0 and m["spurious_contacts"] == 0
            if name in selfcd.non_conservative_methods():
                assert m["missed_proximity_contacts"] is not None
            else:
                assert m["missed_contacts"] == 0 and m["missed_proximity_contacts"] is None
    html = (tmp_path / "rep" / "index.html").read_text()
    assert "Plotly.newPlot" in html and 'id="summary"' in html
    assert "<script src=" not in html and "<link " not in html, "the report must not load anything from the network"
    for m in selfcd.methods():
        assert m in out.stdout


def test_demo_with_chosen_methods_and_resolution(tmp_path: Path) -> None:
    out = run("demo", "--frames", "4", "--resolution", "6", "--method", "bvh", "--method", "sensor-gated",
              "--out", str(tmp_path / "rep"))
    assert out.returncode == 0, out.stderr
    summary = json.loads((tmp_path / "rep" / "summary.json").read_text())
    for scene in summary["scenes"]:
        assert scene["triangles"] == 50 and list(scene["methods"]) == ["bvh", "sensor-gated"]
        assert scene["methods"]["sensor-gated"]["triggered_frames"] is not None
    assert run("demo", "--method", "fastest").returncode == 2


def test_simulate_saves_frames_and_stats_that_detect_reads(tmp_path: Path) -> None:
    out = run("simulate", "--scene", "center", "--frames", "20", "--every", "2", "--out", str(tmp_path / "sim"))
    assert out.returncode == 0, out.stderr
    data = np.load(tmp_path / "sim" / "frames.npz")
    assert data["V"].shape == (20, 121, 3) and data["F"].shape == (200, 3) and data["time"].shape == (20,)
    assert data["pinned"].sum() == 1
    assert np.allclose(data["time"][1:] - data["time"][:-1], 2 / 60)
    stats = json.loads((tmp_path / "sim" / "stats.json").read_text())
    assert stats["summary"]["steps"] == 38 and len(stats["steps"]["step_time"]) == 38
    assert len(stats["steps"]["detection"]["primitive_tests"]) == 38
    assert stats["summary"]["max_intersections"] == 0
    check = run("detect", "--json", str(tmp_path / "sim" / "frames.npz"))
    assert check.returncode == 0, "the response leaves no intersection"
    assert len(json.loads(check.stdout)["files"]) == 20


def test_simulate_without_response_passes_through_itself(tmp_path: Path) -> None:
    out = run("simulate", "--scene", "center", "--frames", "60", "--every", "4", "--no-self-collision",
              "--out", str(tmp_path / "sim"))
    assert out.returncode == 0, out.stderr
    check = run("detect", str(tmp_path / "sim" / "frames.npz"))
    assert check.returncode == 1 and "frames.npz[59]" in check.stdout


def test_simulate_rejects_unknown_scene(tmp_path: Path) -> None:
    out = run("simulate", "--scene", "hanging", "--frames", "3", "--out", str(tmp_path / "x"))
    assert out.returncode == 2 and "two-corners" in out.stderr


def test_bench_table_and_json(tmp_path: Path) -> None:
    out = run("bench", "--sizes", "50,300", "--states", "flat,crumpled", "--repeats", "1", "--brute-limit", "100",
              "--json", str(tmp_path / "b.json"))
    assert out.returncode == 0, out.stderr
    rows = json.loads((tmp_path / "b.json").read_text())
    n = len(selfcd.methods())
    assert len(rows) == 2 * n + 2 * (n - 1), "brute is skipped above the limit"
    assert {r["state"] for r in rows} == {"flat", "crumpled"}
    assert {r["triangles"] for r in rows if r["method"] == "brute"} == {50}
    crumpled = [r for r in rows if r["state"] == "crumpled" and r["triangles"] > 100]
    assert all(r["stats"]["contacts"] == crumpled[0]["stats"]["contacts"] for r in crumpled
               if r["method"] not in selfcd.non_conservative_methods())
    assert "traverse ms" in out.stdout
    assert run("bench", "--states", "molten").returncode == 2


def test_demo_keeps_particles_of_every_frame_when_their_count_changes() -> None:
    """Particles are added as convex parts appear (a fold), so frames hold different counts."""
    from selfcd import demo

    v, f = selfcd.scenes.grid(21)
    frames = np.stack([selfcd.scenes.deform(v, "fold", angle=3.5 * t) for t in np.linspace(0, 1, 20)])
    particles = demo.sensor_particles(selfcd.Mesh(v, f), frames)
    assert particles is not None and len(particles) == len(frames)
    assert all(p.ndim == 2 and p.shape[1] == 3 for p in particles)
    assert len({len(p) for p in particles}) > 1  # the case np.stack refused
