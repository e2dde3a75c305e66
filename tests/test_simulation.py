"""The cloth simulator through Python: the paper's scenes, stepping, recording."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import selfcd
import selfcd.usd


def test_paper_scenes_are_listed_in_the_papers_order() -> None:
    assert selfcd.paper_scenes() == ["two-corners", "corner", "center"]
    assert selfcd.scenes.paper_names() == selfcd.paper_scenes()


@pytest.mark.parametrize(("scene", "pins"), [("two-corners", [0, 120]), ("corner", [0]), ("center", [60])])
def test_pins_hold_and_the_cloth_falls(scene: str, pins: list[int]) -> None:
    sim = selfcd.scenes.paper(scene, resolution=11)
    assert sim.mesh.n_faces == 200 and list(np.flatnonzero(sim.pinned)) == pins
    rest = sim.positions
    frames, times, stats = sim.run(60, every=3)
    assert frames.shape == (21, 121, 3) and np.allclose(times, np.arange(21) * 3 * sim.dt)
    assert np.array_equal(frames[0], rest)
    assert np.allclose(frames[:, pins], rest[pins])
    free = np.setdiff1d(np.arange(121), pins)
    assert frames[-1][free, 2].mean() < -0.05, "gravity pulls the free cloth down"
    assert sim.steps == 60 and sim.time == pytest.approx(1.0)
    assert stats["step_time"].shape == (60,) and stats["detection"]["primitive_tests"].shape == (60,)


def test_the_response_leaves_no_intersection() -> None:
    sim = selfcd.Simulation("center", 11)
    frames, _, stats = sim.run(240, every=4)
    assert stats["contacts"].max() > 0, "the centre scene folds onto itself"
    assert stats["intersections"].max() == 0
    assert all(len(p) == 0 for p in selfcd.reference_pairs(sim.mesh, frames))


def test_step_by_step_matches_run() -> None:
    a, b = selfcd.Simulation("corner", 7), selfcd.Simulation("corner", 7)
    for _ in range(10):
        st = a.step()
    frames, _, _ = b.run(10)
    assert np.allclose(a.positions, frames[-1]) and st["detection"]["triggered"] is None
    assert set(a.energy()) == {"kinetic", "gravity", "elastic", "total"}


def test_any_method_drives_the_response() -> None:
    for method in selfcd.methods():
        sim = selfcd.Simulation("center", 7, method=method)
        sim.run(5)
        assert sim.method == method


@pytest.mark.parametrize(
    ("kwargs", "error", "words"),
    [
        ({"scene": "hanging"}, ValueError, "unknown cloth scene \"hanging\""),
        ({"scene": "center", "resolution": 1}, ValueError, "resolution must be at least 2"),
        ({"scene": "center", "resolution": 2.5}, TypeError, "resolution must be an integer"),
        ({"scene": "center", "method": "fast"}, ValueError, "unknown method"),
        ({"scene": "center", "dt": -1.0}, ValueError, "time step must be positive"),
    ],
)
def test_bad_simulation_arguments(kwargs, error, words) -> None:
    with pytest.raises(error) as info:
        selfcd.Simulation(**kwargs)
    assert words in str(info.value)


def test_run_arguments_are_checked() -> None:
    sim = selfcd.Simulation("center", 5)
    with pytest.raises(ValueError, match="every must be at least 1"):
        sim.run(3, every=0)
    with pytest.raises(ValueError, match="steps must be >= 0"):
        sim.run(-1)


# ---------------------------------------------------------------- any mesh: pins, obstacles, materials


def _square(n: int, z: float) -> tuple[np.ndarray, np.ndarray]:
    """An n x n square cloth of side 1 centred over the origin at height z."""
    v, f = selfcd.scenes.grid(n, 1.0)
    return v - [0.5, 0.5, -z], f


def _cloth_obstacle_pairs(sim: selfcd.Simulation, frames: np.ndarray, obstacle_frames: list[np.ndarray]) -> int:
    """Intersecting pairs with a cloth triangle, over all frames, by the brute-force
    exact reference on the combined mesh (cloth and obstacle)."""
    f, of = sim.mesh.faces, sim.obstacle_faces
    n, m = len(frames[0]), len(f)
    x = np.stack([np.concatenate([c, o]) for c, o in zip(frames, obstacle_frames)])
    pairs = selfcd.reference_pairs(selfcd.Mesh(x[0], np.concatenate([f, of + n])), x)
    return sum(int(np.count_nonzero(np.asarray(p).reshape(-1, 2).min(axis=1) < m)) for p in pairs)


def _run_recording_obstacles(sim: selfcd.Simulation, steps: int) -> tuple[np.ndarray, list[np.ndarray], dict]:
    frames, obstacles, columns = [sim.positions], [sim.obstacle_positions], []
    for _ in range(steps):
        fr, _, st = sim.run(1)
        frames.append(fr[-1])
        obstacles.append(sim.obstacle_positions)
        columns.append(st)
    stats = {k: np.concatenate([c[k] for c in columns]) for k in columns[0] if k != "detection"}
    return np.stack(frames), obstacles, stats


@pytest.mark.parametrize("spin", [0.0, 4.0])
def test_cloth_falls_on_a_sphere_static_or_rotating(spin: float) -> None:
    v, f = _square(11, 0.33)
    sv, sf = selfcd.scenes.sphere(10, 20, 0.3)
    keys = np.stack([sv @ np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]]).T
                     for a in spin * np.arange(61) / 60])
    sim = selfcd.Simulation.from_mesh(v, f, obstacles=[(keys, sf)])
    assert np.allclose(sim.obstacle_positions, keys[0])
    frames, obstacles, stats = _run_recording_obstacles(sim, 45)
    assert stats["obstacle_contacts"].max() > 0, "the cloth reached the sphere"
    assert stats["intersections"].max() == 0 and stats["obstacle_intersections"].max() == 0
    assert _cloth_obstacle_pairs(sim, frames, obstacles) == 0
    assert np.allclose(obstacles[30], keys[30]), "the animation plays one keyframe per step by default"
    centre = frames[-1][60]
    if spin == 0:
        assert 0.28 < centre[2] < 0.34, f"the centre rests on the sphere, at {centre}"
    else:
        # Rotating about +x, the top of the sphere moves towards -y: friction drags the cloth along.
        assert centre[1] < -0.05, f"the cloth is dragged along, centre at {centre}"


def test_cloth_pinned_at_the_top_hangs_still() -> None:
    v, f = selfcd.scenes.grid(9, 0.5)
    # The grid lies in the xy plane: with y up, it hangs vertically.
    sim = selfcd.Simulation.from_mesh(v, f, pins="top:0.01", up="y", material="denim")
    top = np.flatnonzero(v[:, 1] >= 0.5 - 1e-9)
    assert np.array_equal(np.flatnonzero(sim.pinned), top)
    frames, _, stats = sim.run(240, every=240)
    assert np.array_equal(frames[-1][top], v[top]), "pinned vertices never move"
    assert np.abs(sim.velocities).max() < 0.05, "after four seconds it hangs still"
    assert np.allclose(frames[-1][:, 1].min(), 0.0, atol=0.03), "hanging, it stretches only a little"
    assert stats["intersections"].max() == 0


def test_pin_specs(tmp_path) -> None:
    v, _ = selfcd.scenes.grid(5, 1.0)
    np.save(tmp_path / "ids.npy", np.array([3, 1]))
    (tmp_path / "ids.txt").write_text("0\n24\n")
    pins = selfcd.scenes.pins
    assert list(pins(v, "top:0", up="y")) == [20, 21, 22, 23, 24] and list(pins(v, "top:0.25", up="y")) == list(range(15, 25))
    assert list(pins(v, "top:1")) == list(range(25)), "a flat cloth is all top along z"
    assert list(pins(v, [f"indices:{tmp_path / 'ids.npy'}", f"indices:{tmp_path / 'ids.txt'}"])) == [0, 1, 3, 24]
    assert list(pins(v, "box:-0.1,-0.1,-1,0.3,0.3,1")) == [0, 1, 5, 6]
    assert list(pins(v, [2, 4])) == [2, 4] and list(pins(v, np.arange(25) < 2)) == [0, 1]
    for bad, words in [("top:2", "fraction"), ("box:1,2", "six numbers"), ("side:1", "unknown pin spec"),
                       (f"indices:{tmp_path / 'none.txt'}", "no such file"), ([25], "vertex ids")]:
        with pytest.raises(ValueError, match=words):
            pins(v, bad)
    with pytest.raises(ValueError, match="up axis"):
        pins(v, "top:0.1", up="w")


def test_obstacle_sources(tmp_path) -> None:
    sv, sf = selfcd.scenes.sphere(4, 6, 1.0)
    for k in (2, 10, 1):
        selfcd.io.save_obj(tmp_path / f"frame{k}.obj", sv * k, sf)
    frames, faces = selfcd.scenes.obstacle(tmp_path)
    assert frames.shape == (3, len(sv), 3) and np.allclose(frames[:, 0, 2], [1, 2, 10]), "natural order"
    np.savez(tmp_path / "anim.npz", V=frames, F=faces)
    assert np.array_equal(selfcd.scenes.obstacle(tmp_path / "anim.npz")[0], frames)
    assert selfcd.scenes.obstacle(tmp_path / "frame1.obj")[0].shape == (1, len(sv), 3)
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(ValueError, match="needs frame files"):
        selfcd.scenes.obstacle(empty)


def test_materials_and_bad_mesh_options() -> None:
    assert selfcd.materials() == ["cotton", "silk", "denim"]
    v, f = _square(5, 0.0)
    with pytest.raises(ValueError, match="unknown material \"tweed\""):
        selfcd.Simulation.from_mesh(v, f, material="tweed")
    with pytest.raises(ValueError, match="friction"):
        selfcd.Simulation.from_mesh(v, f, friction=-1.0)
    with pytest.raises(ValueError, match="rest has 3 vertices"):
        selfcd.Simulation.from_mesh(v, f, rest=v[:3])


def test_rest_shape_differs_from_the_start() -> None:
    v, f = _square(5, 0.0)
    sim = selfcd.Simulation.from_mesh(v * [1.2, 1.0, 1.0], f, rest=v, pins="box:-1,-1,-1,1,1,1")
    sim.run(5)
    assert np.allclose(sim.positions, v * [1.2, 1.0, 1.0]) and np.allclose(sim.mesh.vertices, v)


def test_split_body_keeps_the_largest_and_closed_components() -> None:
    sv, sf = selfcd.scenes.sphere(4, 6, 1.0)  # closed: part of the body
    bv, bf = _square(9, -2.0)  # the largest: the body, even though open
    cv, cf = _square(3, 2.0)  # open and smaller: the garment
    parts = [(bv, bf), (cv, cf), (sv, sf)]
    offsets = np.cumsum([0] + [len(p[0]) for p in parts])
    v = np.concatenate([p[0] for p in parts])
    f = np.concatenate([p[1] + o for p, o in zip(parts, offsets)])
    (gv, gf), (body_v, body_f) = selfcd.scenes.split_body(v, f)
    assert np.array_equal(gv, cv) and np.array_equal(gf, cf)
    assert np.array_equal(body_v, np.concatenate([bv, sv])) and np.array_equal(body_f, np.concatenate([bf, sf + len(bv)]))
    with pytest.raises(ValueError, match="no garment"):
        selfcd.scenes.split_body(sv, sf)


# ---------------------------------------------------------------- selfcd simulate --mesh


def _cli(*args: str, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "selfcd", *args], capture_output=True, text=True, timeout=300, **kw)


def test_simulate_mesh_with_obstacle_writes_npz_obj_and_stats(tmp_path) -> None:
    v, f = _square(7, 0.33)
    selfcd.io.save_obj(tmp_path / "cloth.obj", v, f)
    selfcd.io.save_obj(tmp_path / "ball.obj", *selfcd.scenes.sphere(8, 16, 0.3))
    out = tmp_path / "out"
    (out / "obj").mkdir(parents=True)
    (out / "obj" / "cloth_00099.obj").write_text("stale")
    r = _cli("simulate", "--mesh", str(tmp_path / "cloth.obj"), "--obstacle", str(tmp_path / "ball.obj"),
             "--pin", "box:-1,-1,-1,-0.4,-0.4,1", "--frames", "6", "--every", "5", "--obj", "--usd", "drape.usda",
             "--out", str(out))
    assert r.returncode == 0, r.stderr
    data = np.load(out / "frames.npz")
    assert data["V"].shape == (6, 49, 3) and data["OV"].shape[0] == 6 and len(data["OF"]) == 8 * 16 * 2 - 2 * 16
    assert data["pinned"].sum() == 1 and np.allclose(data["V"][:, 0], v[0])
    assert sorted(p.name for p in (out / "obj").iterdir()) == [f"{k}_{i:05d}.obj" for k in ("cloth", "obstacle")
                                                               for i in range(6)]
    stats = json.loads((out / "stats.json").read_text())
    assert stats["summary"]["steps"] == 25 and stats["summary"]["max_intersections"] == 0
    usd_v, usd_f = selfcd.usd.read_usd(out / "drape.usda")
    assert usd_v.shape == (6, 49, 3) and np.allclose(usd_v, data["V"], atol=1e-6) and np.array_equal(usd_f, f)
    assert selfcd.usd.read_usd(out / "drape_obstacles.usda")[0].shape == data["OV"].shape
    assert {"obstacle_time", "obstacle_contacts", "solve_time"} <= set(stats["steps"])


def test_simulate_checks_its_output_folder_and_options(tmp_path) -> None:
    v, f = _square(4, 0.0)
    selfcd.io.save_obj(tmp_path / "c.obj", v, f)
    blocker = tmp_path / "file"
    blocker.write_text("")
    r = _cli("simulate", "--mesh", str(tmp_path / "c.obj"), "--frames", "2", "--out", str(blocker / "out"))
    assert r.returncode == 2 and "cannot write to output folder" in r.stderr
    r = _cli("simulate", "--mesh", str(tmp_path / "c.obj"), "--scene", "center", "--frames", "2")
    assert r.returncode == 2 and "not both" in r.stderr
    r = _cli("simulate", "--mesh", str(tmp_path / "c.obj"), "--pin", "top:7", "--frames", "2",
             "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and "fraction" in r.stderr


def test_interrupted_simulate_keeps_its_frames(tmp_path) -> None:
    v, f = _square(25, 0.0)
    selfcd.io.save_obj(tmp_path / "c.obj", v, f)
    out = tmp_path / "out"
    p = subprocess.Popen([sys.executable, "-m", "selfcd", "simulate", "--mesh", str(tmp_path / "c.obj"),
                          "--frames", "100000", "--out", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True)
    deadline = time.monotonic() + 120
    while not (out / "stats.json").exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    time.sleep(1.0)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=120)
    assert p.returncode == 130 and "interrupted" in err
    data = np.load(out / "frames.npz")
    stats = json.loads((out / "stats.json").read_text())
    assert len(data["V"]) == stats["summary"]["frames"] > 1
    assert stats["summary"]["steps"] == len(data["V"]) - 1
