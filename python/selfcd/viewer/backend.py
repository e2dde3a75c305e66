"""Drawing a `Viewer` with polyscope: initialisation (window or headless EGL), the
structures (cloth coloured by contact state, particles, BVH boxes), the camera,
and the entry points `show`, `render` and `screenshot`. Polyscope is imported
lazily, the first time one of them runs.

Nothing is written to the working directory: polyscope's preferences file is
turned off and its imgui settings file is checked to be off.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from .panel import Panel
from .state import Viewer

# Colours (linear RGB in [0, 1]). The cloth is a saturated blue so that a test
# can find it in a screenshot by hue; contact colours have other hues.
CLOTH_COLOR = (0.16, 0.42, 0.90)
NEAR_COLOR = (1.00, 0.50, 0.00)
HIT_COLOR = (0.90, 0.08, 0.08)
PARTICLE_COLOR = (0.98, 0.85, 0.10)
BOX_COLOR = (0.45, 0.45, 0.50)
CULLED_BOX_COLOR = (0.10, 0.70, 0.25)
BACKGROUND = (1.0, 1.0, 1.0)

#: Polyscope's front direction for each up axis (any direction across the up axis).
FRONT_DIR = {"x": "z_front", "y": "z_front", "z": "neg_y_front"}
#: The direction from the model towards the camera's default position, per up axis: the model's front.
TOWARD_VIEWER = {"x": (0.0, 0.0, 1.0), "y": (0.0, 0.0, 1.0), "z": (0.0, -1.0, 0.0)}


class ViewerError(RuntimeError):
    """The viewer cannot start (no display, no OpenGL backend, polyscope missing)."""


def _display_available() -> bool:
    """True when a windowing system is reachable (X11 or Wayland)."""
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def _import_polyscope() -> Any:
    try:
        import polyscope
    except ImportError as exc:
        raise ViewerError(f"the viewer needs polyscope: pip install polyscope ({exc})") from None
    return polyscope


def init_polyscope(headless: bool, size: tuple[int, int] = (1024, 768)) -> Any:
    """Initialises polyscope once per process and returns the module.

    headless=True uses the EGL backend (no window, no display needed); without
    EGL it falls back to a window backend when a display exists (e.g. Xvfb).
    headless=False needs a display. Raises ViewerError saying what is missing.
    """
    global _init_error
    ps = _import_polyscope()
    if _init_error is not None:
        raise ViewerError(_init_error)
    if ps.is_initialized():
        if not headless and ps.is_headless():
            raise ViewerError("polyscope already runs headless in this process (after a screenshot); "
                              "open the window from a new process")
        return ps
    if not headless and not _display_available():
        raise ViewerError("no display (DISPLAY and WAYLAND_DISPLAY are unset): the window needs one. "
                          "Use --screenshot PATH to render without a window, or run under xvfb-run.")
    try:
        _init_backend(ps, headless, size)
    except ViewerError as exc:
        if not ps.is_initialized():
            # polyscope's exit hook raises "not initialized" after a failed init; a mock backend (no
            # OpenGL) keeps the exit quiet, and every later call in this process gets the first error.
            _init_error = str(exc)
            ps.init("openGL_mock")
        raise
    return ps


#: Why polyscope could not start in this process, once it failed (it cannot be initialised twice).
_init_error: str | None = None


def _init_backend(ps: Any, headless: bool, size: tuple[int, int]) -> None:
    """Initialises polyscope's OpenGL backend (see `init_polyscope`) and sets the viewer's defaults."""
    ps.set_use_prefs_file(False)  # no .polyscope.ini in the working directory
    ps.set_program_name("selfcd view")
    ps.set_print_prefix("[selfcd view] ")
    ps.set_errors_throw_exceptions(True)
    ps.set_window_size(*size)
    if headless:
        ps.set_verbosity(0)  # errors still reach the ViewerError below
        ps.set_allow_headless_backends(True)
        try:
            ps.init("openGL3_egl")
        except Exception as egl_exc:  # polyscope raises RuntimeError with the backend's message
            if not _display_available():
                raise ViewerError(
                    f"no headless OpenGL: polyscope's EGL backend failed ({egl_exc}). Install Mesa's EGL "
                    "(Debian: libegl1 libgl1 libegl-mesa0 libgl1-mesa-dri) or run under a virtual display "
                    "(xvfb-run selfcd view ...)") from None
            try:
                ps.init("openGL3_glfw")
            except Exception as glfw_exc:
                raise ViewerError(f"no OpenGL: EGL failed ({egl_exc}), and the window backend failed on display "
                                  f"{os.environ.get('DISPLAY') or os.environ.get('WAYLAND_DISPLAY')} "
                                  f"({glfw_exc})") from None
    else:
        try:
            ps.init("openGL3_glfw")
        except Exception as exc:
            raise ViewerError(f"cannot open a polyscope window on display "
                              f"{os.environ.get('DISPLAY') or os.environ.get('WAYLAND_DISPLAY')}: {exc}") from None
    io = ps.imgui.GetIO()
    if io.IniFilename:  # polyscope turns imgui's settings file off; make sure, since it would land in the cwd
        raise ViewerError(f"polyscope left imgui's settings file on ({io.IniFilename}); refusing to write it "
                          "into the working directory")
    ps.set_ground_plane_mode("none")
    ps.set_background_color(BACKGROUND)


def _box_network(boxes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Corner nodes (8k, 3) and edges (12k, 2) of k axis-aligned boxes [min, max]."""
    corners = np.array([[i, j, k] for k in (0, 1) for j in (0, 1) for i in (0, 1)], dtype=bool)
    lo, hi = boxes[:, 0, None, :], boxes[:, 1, None, :]
    nodes = np.where(corners[None], hi, lo).reshape(-1, 3)
    edges = np.array([[0, 1], [2, 3], [4, 5], [6, 7], [0, 2], [1, 3], [4, 6], [5, 7], [0, 4], [1, 5], [2, 6], [3, 7]])
    edges = (edges[None] + 8 * np.arange(len(boxes))[:, None, None]).reshape(-1, 2)
    return nodes, edges


class PolyscopeView:
    """Draws a `Viewer` with polyscope and builds its imgui control panel.

    `update()` pushes the viewer's current frame into the polyscope structures;
    `callback()` is polyscope's per-frame user callback: it draws the `Panel`
    (whose widgets call the Viewer's controls), ticks the viewer and updates
    the structures when the frame changed. The source's up axis points up.
    """

    def __init__(self, viewer: Viewer, ps: Any) -> None:
        self.viewer = viewer
        self.ps = ps
        self.panel = Panel(viewer, ps.imgui)
        self._drawn_particles = -1
        self.up = viewer.source.up
        ps.set_up_dir(f"{self.up}_up")
        ps.set_front_dir(FRONT_DIR[self.up])
        ps.remove_all_structures()
        self.cloth = ps.register_surface_mesh("cloth", viewer.positions, viewer.faces, color=CLOTH_COLOR,
                                              edge_width=0.0, smooth_shade=False, back_face_policy="identical")
        self.update()
        self.frame_camera(*viewer.source.extent())

    def frame_camera(self, lo: np.ndarray, hi: np.ndarray, shift: float = 0.0,
                     aspect: float = 4 / 3) -> None:
        """Sets the scene extents to the box (lo, hi) and looks at it from the front (TOWARD_VIEWER
        for the source's up axis), a little above and to the right.

        `shift` moves the box left by that fraction of the image width (to leave room for a panel
        on the right of an image whose width / height is `aspect`).
        """
        ps = self.ps
        lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
        diag = max(float(np.linalg.norm(hi - lo)), 1e-9)
        ps.set_automatically_compute_scene_extents(False)
        ps.set_bounding_box(lo, hi)
        ps.set_length_scale(diag)
        centre = (lo + hi) / 2
        up = np.eye(3)["xyz".index(self.up)]
        toward = np.asarray(TOWARD_VIEWER[self.up])
        direction = 0.35 * np.cross(up, toward) + toward + 0.45 * up
        direction /= np.linalg.norm(direction)
        # 0.8 x the distance at which the bounding sphere (radius diag/2) fits the 45-degree vertical field of
        # view: the box itself, seen from this direction, is narrower than its sphere and still fits.
        distance = 0.5 * diag / np.sin(np.radians(22.5)) * 0.8
        right = np.cross(-direction, up)
        right /= np.linalg.norm(right)
        half_width = distance * np.tan(np.radians(22.5)) * aspect
        target = centre + 2 * shift * half_width * right
        ps.look_at(target + distance * direction, target)

    def update(self) -> None:
        """Pushes positions, face colours, particles and BVH boxes of the current frame."""
        v = self.viewer
        self.cloth.update_vertex_positions(v.positions)
        palette = np.array([CLOTH_COLOR, NEAR_COLOR, HIT_COLOR])
        self.cloth.add_color_quantity("contacts", palette[v.face_state], defined_on="faces", enabled=True)
        self._update_particles()
        self._update_boxes()

    def _update_particles(self) -> None:
        p = self.viewer.particles
        ps = self.ps
        if len(p) != self._drawn_particles:
            if ps.has_point_cloud("particles"):
                ps.remove_point_cloud("particles")
            if len(p):
                cloud = ps.register_point_cloud("particles", p, color=PARTICLE_COLOR, radius=0.02)
                cloud.set_point_render_mode("sphere")
            self._drawn_particles = len(p)
        elif len(p):
            ps.get_point_cloud("particles").update_point_positions(p)

    def _update_boxes(self) -> None:
        ps = self.ps
        boxes, positive = self.viewer.bvh_boxes()
        if ps.has_curve_network("bvh"):
            ps.remove_curve_network("bvh")
        if len(boxes) == 0:
            return
        nodes, edges = _box_network(boxes)
        net = ps.register_curve_network("bvh", nodes, edges, color=BOX_COLOR, radius=0.0015)
        colors = np.where(np.repeat(positive, 12)[:, None], CULLED_BOX_COLOR, BOX_COLOR)
        net.add_color_quantity("cone under 90 deg", colors, defined_on="edges", enabled=True)

    def callback(self) -> None:
        """Polyscope's per-frame callback: the panel, then one viewer tick."""
        if self.panel.draw():
            self.update()
        if self.viewer.tick():
            self.update()

    def draw_panel(self) -> None:
        """Draws the panel only (headless screenshots with the panel)."""
        if self.panel.draw():
            self.update()


def show(viewer: Viewer, size: tuple[int, int] = (1280, 900)) -> None:
    """Opens a polyscope window on `viewer` and blocks until it is closed."""
    ps = init_polyscope(headless=False, size=size)
    view = PolyscopeView(viewer, ps)
    ps.set_user_callback(view.callback)
    try:
        ps.show()
    finally:
        ps.clear_user_callback()


def _headless_view(viewer: Viewer, size: tuple[int, int], include_ui: bool) -> Any:
    """Polyscope, initialised headless, holding `viewer`'s current frame."""
    ps = init_polyscope(headless=True, size=size)
    view = PolyscopeView(viewer, ps)
    # One image: fit the cloth; with the panel, only ours (on the right), and the cloth moved left of it.
    ps.set_build_default_gui_panels(not include_ui)
    view.frame_camera(viewer.positions.min(axis=0), viewer.positions.max(axis=0), shift=0.2 if include_ui else 0.0,
                      aspect=size[0] / size[1])
    if include_ui:
        ps.set_user_callback(view.draw_panel)
    else:
        ps.clear_user_callback()
    return ps


def render(viewer: Viewer, size: tuple[int, int] = (1024, 768), include_ui: bool = False) -> np.ndarray:
    """Renders the viewer's current frame without a window: an (h, w, 4) uint8 RGBA image."""
    ps = _headless_view(viewer, size, include_ui)
    try:
        return ps.screenshot_to_buffer(transparent_bg=False, include_UI=include_ui)
    finally:
        ps.clear_user_callback()


def screenshot(viewer: Viewer, path: str | Path, size: tuple[int, int] = (1024, 768),
               include_ui: bool = False) -> Path:
    """Renders the viewer's current frame without a window and saves it (.png or .jpg); returns the absolute path."""
    path = Path(path).resolve()
    if path.suffix.lower() not in (".png", ".jpg", ".jpeg"):
        raise ViewerError(f"{path}: screenshots are written as .png or .jpg")
    if not path.parent.is_dir():
        raise ViewerError(f"{path.parent}: no such directory for the screenshot")
    ps = _headless_view(viewer, size, include_ui)
    try:
        ps.screenshot(str(path), transparent_bg=False, include_UI=include_ui)
    finally:
        ps.clear_user_callback()
    if not path.is_file():
        raise ViewerError(f"{path}: polyscope did not write the screenshot")
    return path


def run_frames(viewer: Viewer, frames: int) -> float:
    """Advances `frames` frames (stopping at the end of a recording); returns the seconds it took."""
    t0 = time.perf_counter()
    for _ in range(frames):
        if not viewer.step():
            break
    return time.perf_counter() - t0
