"""The polyscope viewer (`selfcd view`): headless screenshots checked by their
pixels, and the viewer's controls driven programmatically.

Screenshots are rendered on polyscope's EGL backend (Mesa's software renderer
is enough: no GPU, no display). A screenshot "shows the cloth" when pixels of
the cloth's colour (its hue, saturated, not black) cover a fair part of the
image and span a real shape; contact colours are told apart by hue too.
"""

from __future__ import annotations

import colorsys
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import selfcd
from selfcd import io as mesh_io
from selfcd import viewer as V
from selfcd.demo import proximity_reference

PAPER_SCENES = ["two-corners", "corner", "center"]
FRAMES = 60  # one simulated second at the default dt = 1/60 s
SIZE = (640, 480)


# ---------------------------------------------------------------- pixels


def _hsv(path_or_rgba: Path | np.ndarray) -> np.ndarray:
    """An image as (h, w, 3) HSV floats in [0, 1]."""
    if isinstance(path_or_rgba, Path):
        img = Image.open(path_or_rgba).convert("RGB")
    else:
        img = Image.fromarray(np.ascontiguousarray(path_or_rgba[..., :3]))
    return np.asarray(img.convert("HSV"), dtype=np.float64) / 255.0


def colour_mask(hsv: np.ndarray, colour: tuple[float, float, float], hue_tol_deg: float = 10.0,
                min_sat: float = 0.3) -> np.ndarray:
    """Pixels of `colour`'s hue (within hue_tol_deg), saturated and not black: shading changes
    brightness, not hue, so this finds a lit surface of that colour."""
    h0 = colorsys.rgb_to_hsv(*colour)[0]
    dh = np.abs(hsv[..., 0] - h0)
    dh = np.minimum(dh, 1.0 - dh)
    return (dh <= hue_tol_deg / 360.0) & (hsv[..., 1] >= min_sat) & (hsv[..., 2] >= 0.1)


def background_mask(path: Path) -> np.ndarray:
    """Pixels within 8/255 of the white background."""
    rgb = np.asarray(Image.open(path).convert("RGB"), dtype=np.int64)
    return np.abs(rgb - 255).max(axis=2) <= 8


def span(mask: np.ndarray) -> tuple[float, float]:
    """Width and height of the mask's bounding box, as fractions of the image's."""
    ys, xs = np.nonzero(mask)
    return (xs.max() - xs.min() + 1) / mask.shape[1], (ys.max() - ys.min() + 1) / mask.shape[0]


def run_cli(*args: str, cwd: Path, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    """Runs `python -m selfcd ARGS` in `cwd`."""
    return subprocess.run([sys.executable, "-m", "selfcd", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=300, env=env)


# ---------------------------------------------------------------- headless screenshots


@pytest.mark.parametrize("scene", PAPER_SCENES)
def test_headless_screenshot_shows_the_cloth(scene: str, tmp_path: Path) -> None:
    """`selfcd view --scene S --frames 60 --screenshot` writes an image where the cloth is plainly visible."""
    out = tmp_path / "shots" / f"{scene}.png"
    out.parent.mkdir()
    r = run_cli("view", "--scene", scene, "--frames", str(FRAMES), "--screenshot", str(out), "--size",
                f"{SIZE[0]}x{SIZE[1]}", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert f"frame {FRAMES}" in r.stdout
    # The particle count follows the cloth's convex parts, never below the 4 a flat cloth starts with.
    count = re.search(r"(\d+) particles", r.stdout)
    assert count is not None and int(count.group(1)) >= 4, r.stdout
    img = Image.open(out)
    assert img.size == SIZE

    hsv = _hsv(out)
    background = background_mask(out)
    cloth = colour_mask(hsv, V.CLOTH_COLOR)
    surface = cloth | colour_mask(hsv, V.NEAR_COLOR) | colour_mask(hsv, V.HIT_COLOR, hue_tol_deg=6)
    particles = colour_mask(hsv, V.PARTICLE_COLOR, hue_tol_deg=6, min_sat=0.5)
    # Not blank: a drawing on a background, not one flat colour.
    assert 0.05 <= 1 - background.mean() <= 0.9
    # The cloth's own colour covers a fair part of the image (measured: 11.7 % to 19.8 % at 640x480),
    # and with its contact colours it stays a figure on the background, not a full-screen fill.
    assert cloth.mean() >= 0.05, f"cloth colour covers only {cloth.mean():.3%}"
    assert surface.mean() <= 0.8
    # ... in one shape of real size, not a speck.
    w, h = span(cloth)
    assert w >= 0.15 and h >= 0.15, (w, h)
    # The sensor particles (yellow spheres) are drawn.
    assert particles.sum() >= 20
    # polyscope left no settings file in the working directory.
    assert not (tmp_path / ".polyscope.ini").exists() and not (tmp_path / "imgui.ini").exists()


def test_files_view_highlights_self_intersections(tmp_path: Path) -> None:
    """`selfcd view FILE --screenshot` paints intersecting faces red; an untouched flat cloth has none."""
    V0, F = selfcd.scenes.grid(11)
    folded = selfcd.scenes.deform(V0, "roll", turns=2, gap=-0.01)  # rolled into itself
    pairs = selfcd.self_intersections(folded, F)
    assert len(pairs) > 0
    mesh_io.save_obj(tmp_path / "flat.obj", V0, F)
    mesh_io.save_obj(tmp_path / "folded.obj", folded, F)

    shots = {}
    for name in ("flat", "folded"):
        out = tmp_path / f"{name}.png"
        r = run_cli("view", f"{name}.obj", "--screenshot", str(out), "--size", "640x480", cwd=tmp_path)
        assert r.returncode == 0, r.stderr
        shots[name] = (r.stdout, _hsv(out))
    assert "0 intersecting pairs" in shots["flat"][0]
    assert f"{len(pairs)} intersecting pairs" in shots["folded"][0]
    red = {k: colour_mask(hsv, V.HIT_COLOR, hue_tol_deg=6).mean() for k, (_, hsv) in shots.items()}
    assert red["flat"] == 0.0
    assert red["folded"] >= 0.002, red


def test_animation_files_step_through_frames(tmp_path: Path) -> None:
    """Several files are one animation: --frames N shows the N-th file."""
    V0, F = selfcd.scenes.grid(11)
    shapes = [V0, selfcd.scenes.deform(V0, "fold", angle=1.5), selfcd.scenes.deform(V0, "roll", turns=2, gap=-0.01)]
    for i, shape in enumerate(shapes):
        mesh_io.save_obj(tmp_path / f"f{i}.obj", shape, F)
    files = ["f0.obj", "f1.obj", "f2.obj"]
    r = run_cli("view", *files, "--frames", "5", "--screenshot", "last.png", "--size", "320x240", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "frame 2" in r.stdout  # stops at the last file
    expected = len(selfcd.self_intersections(shapes[2], F))
    assert expected > 0 and f"{expected} intersecting pairs" in r.stdout
    assert (tmp_path / "last.png").is_file()


def test_panel_renders_headless() -> None:
    """The imgui panel is built in a headless frame and covers part of the image."""
    v = V.Viewer(V.ClothSource("center", 7), "sensor-gated", thickness=0.05)
    V.run_frames(v, 10)
    v.set_bvh_depth(2)
    plain = V.render(v, (640, 480))
    with_panel = V.render(v, (640, 480), include_ui=True)
    assert plain.shape == with_panel.shape == (480, 640, 4)
    changed = np.any(plain[..., :3] != with_panel[..., :3], axis=2).mean()
    assert changed > 0.05, changed


# ---------------------------------------------------------------- controls


@pytest.fixture
def cloth_viewer() -> V.Viewer:
    """The centre scene at 9 x 9 vertices, sensor-gated, with the simulator's contact distance."""
    src = V.ClothSource("center", 9)
    return V.Viewer(src, "sensor-gated", thickness=src.sim.contact_distance)


def test_step_advances_the_frame(cloth_viewer: V.Viewer) -> None:
    v = cloth_viewer
    start = v.positions.copy()
    assert v.frame == 0 and len(v.history) == 1
    assert v.step()
    assert v.frame == 1 and len(v.history) == 2
    assert v.source.sim.steps == 1
    assert not np.array_equal(v.positions, start)  # gravity moved the free vertices
    assert v.stats["triggered"] is not None and v.summary()["step"] is not None


def test_play_pause_and_tick(cloth_viewer: V.Viewer) -> None:
    v = cloth_viewer
    assert not v.tick() and v.frame == 0  # paused: nothing happens
    v.play()
    assert v.tick() and v.tick() and v.frame == 2
    v.toggle_play()
    assert not v.playing and not v.tick() and v.frame == 2
    v.toggle_play()
    assert v.playing


def test_reset_restores_positions(cloth_viewer: V.Viewer) -> None:
    v = cloth_viewer
    start = v.positions.copy()
    start_particles = v.particles.copy()
    old_detector = v.detector
    V.run_frames(v, 20)
    assert not np.allclose(v.positions, start)
    v.reset()
    assert v.frame == 0
    np.testing.assert_array_equal(v.positions, start)
    assert v.detector is not old_detector  # fresh sensor
    np.testing.assert_allclose(v.particles, start_particles)
    assert len(v.history) == 1


def test_method_change_swaps_the_detector(cloth_viewer: V.Viewer) -> None:
    v = cloth_viewer
    V.run_frames(v, 5)
    old = v.detector
    assert len(v.particles) == 4
    v.set_method("bvh")
    assert v.detector is not old and v.detector.method == "bvh" and v.method == "bvh"
    assert len(v.particles) == 0 and v.stats["triggered"] is None
    assert v.frame == 5  # same frame, detected again
    with pytest.raises(ValueError, match="unknown method"):
        v.set_method("nope")
    assert v.method == "bvh"
    v.set_method("sensor-gated")
    assert len(v.particles) == 4


def test_method_change_keeps_contacts_of_conservative_methods() -> None:
    """On the same frame every conservative method marks the same intersecting faces."""
    V0, F = selfcd.scenes.grid(11)
    folded = selfcd.scenes.deform(V0, "roll", turns=2, gap=-0.01)
    v = V.Viewer(V.FramesSource(np.stack([V0, folded]), F, ["flat", "folded"]), "brute")
    assert not np.any(v.face_state == V.HIT)
    assert v.step() and not v.step()  # the second step is past the end: pauses
    expected = v.face_state.copy()
    assert np.any(expected == V.HIT)
    for m in ("bvh", "bvh-cones", "bvh-cones-contour"):
        v.set_method(m)
        np.testing.assert_array_equal(v.face_state, expected)
    hit = np.zeros(len(F), dtype=bool)
    hit[selfcd.self_intersections(folded, F).ravel()] = True
    np.testing.assert_array_equal(expected == V.HIT, hit)


def test_sensor_option_and_thickness(cloth_viewer: V.Viewer) -> None:
    v = cloth_viewer
    v.set_sensor_option("count", 6)
    assert len(v.particles) == 6 and v.sensor_options["count"] == 6
    with pytest.raises(ValueError, match="count"):
        v.set_sensor_option("count", 1)
    assert v.sensor_options["count"] == 6
    with pytest.raises(TypeError, match="unknown sensor option"):
        v.set_sensor_option("colour", 1)
    V.run_frames(v, 30)
    assert np.any(v.face_state == V.NEAR)  # the centre scene's flaps touch
    v.set_thickness(0.0)
    assert not np.any(v.face_state == V.NEAR) and v.thickness == 0.0
    with pytest.raises(ValueError, match="thickness"):
        v.set_thickness(-1.0)


def test_bvh_boxes_at_depth(cloth_viewer: V.Viewer) -> None:
    v = cloth_viewer
    assert v.bvh_boxes()[0].shape == (0, 2, 3)
    v.set_bvh_depth(0)
    boxes, positive = v.bvh_boxes()
    assert boxes.shape == (1, 2, 3) and positive.tolist() == [True]  # the flat rest cloth: one cone culls it all
    np.testing.assert_allclose(boxes[0, 0], v.positions.min(axis=0))
    np.testing.assert_allclose(boxes[0, 1], v.positions.max(axis=0))
    v.set_bvh_depth(10_000)  # clamped: every leaf
    assert v.bvh_depth == v.max_bvh_depth
    boxes, _ = v.bvh_boxes()
    assert len(boxes) == len(v.faces)
    V.run_frames(v, 30)
    v.set_bvh_depth(0)
    boxes, positive = v.bvh_boxes()  # refitted to the draped cloth, whose normals span more than 90 degrees
    np.testing.assert_allclose(boxes[0, 0], v.positions.min(axis=0))
    assert positive.tolist() == [False]


# ---------------------------------------------------------------- command line


def test_view_help_and_usage(tmp_path: Path) -> None:
    r = run_cli("view", "--help", cwd=tmp_path)
    assert r.returncode == 0 and "--screenshot" in r.stdout and "polyscope" in r.stdout
    r = run_cli("view", cwd=tmp_path)
    assert r.returncode == 2 and "either --scene NAME or mesh FILES" in r.stderr
    r = run_cli("view", "--scene", "center", "--screenshot", "x.gif", cwd=tmp_path)
    assert r.returncode == 1 and ".png or .jpg" in r.stderr


def test_window_without_display_says_so(tmp_path: Path) -> None:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    r = run_cli("view", "--scene", "center", cwd=tmp_path, env=env)
    assert r.returncode == 1
    assert "no display" in r.stderr and "--screenshot" in r.stderr


def test_no_headless_backend_says_why(tmp_path: Path) -> None:
    """With no EGL driver (glvnd pointed at no vendor file) and no display, the error names the fix."""
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["__EGL_VENDOR_LIBRARY_FILENAMES"] = str(tmp_path / "no-such-vendor.json")
    r = run_cli("view", "--scene", "center", "--screenshot", "x.png", cwd=tmp_path, env=env)
    assert r.returncode == 1
    assert "no headless OpenGL" in r.stderr and "libegl-mesa0" in r.stderr
    assert "Traceback" not in r.stderr and "Exception ignored" not in r.stderr  # one clear message, no noise
    assert not (tmp_path / "x.png").exists()


def test_cli_without_polyscope_import(tmp_path: Path) -> None:
    """The other commands never import polyscope."""
    code = ("import sys; from click.testing import CliRunner; from selfcd.cli import main; "
            "r = CliRunner().invoke(main, ['--help']); assert r.exit_code == 0; "
            "assert 'polyscope' not in sys.modules and 'selfcd.viewer' not in sys.modules")
    r = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr


# ---------------------------------------------------------------- up axis and near faces


def test_up_axis_is_chosen_per_file_and_overridable(tmp_path: Path) -> None:
    """A tall sheet standing in the x-y plane: upright when Y is up (OBJ's default), lying when Z is."""
    V0, F = selfcd.scenes.grid(11)
    sheet = V0 * [0.3, 1.0, 0.0]
    mesh_io.save_obj(tmp_path / "sheet.obj", sheet, F)
    assert mesh_io.up_axis(tmp_path / "sheet.obj") == "y" and mesh_io.up_axis(tmp_path / "x.npz") == "z"
    spans = {}
    for up in (None, "z", "y"):
        out = tmp_path / f"{up}.png"
        args = ["view", "sheet.obj", "--screenshot", str(out), "--size", "480x480"] + (["--up", up] if up else [])
        r = run_cli(*args, cwd=tmp_path)
        assert r.returncode == 0, r.stderr
        spans[up] = span(colour_mask(_hsv(out), V.CLOTH_COLOR))
    assert spans[None] == spans["y"]
    assert spans["y"][1] > 1.5 * spans["y"][0], spans  # standing: taller than wide
    assert spans["z"][1] < spans["z"][0], spans  # on its back, seen from the front: wider than tall
    with pytest.raises(ValueError, match="up"):
        V.FramesSource(sheet[None], F, up="w")


def test_near_faces_are_the_engines_proximity_faces() -> None:
    """The viewer's near faces are `Detector.proximity_faces` (what the demo report draws), less the hit ones."""
    src = V.ClothSource("center", 9)
    v = V.Viewer(src, "bvh-cones-contour", thickness=src.sim.contact_distance)
    V.run_frames(v, 30)
    near = v.detector.proximity_faces()
    prox = v.detector.last_proximity
    assert len(prox["vertex_triangle"]) and len(prox["edge_edge"]) and len(near)
    assert set(prox["vertex_triangle"][:, 1]) <= set(near)
    edges = v.mesh.edges[prox["edge_edge"].ravel()]
    for a, b in edges:
        on = [f for f, tri in enumerate(v.faces) if a in tri and b in tri]
        assert set(on) <= set(near)
    expected = np.zeros(len(v.faces), dtype=np.int8)
    expected[near] = V.NEAR
    expected[v.pairs.ravel()] = V.HIT
    np.testing.assert_array_equal(v.face_state, expected)
    faces, counts = proximity_reference(v.mesh, v.positions[None], v.thickness)
    np.testing.assert_array_equal(faces[0], near)
    assert counts[0] == len(prox["vertex_triangle"]) + len(prox["edge_edge"])
