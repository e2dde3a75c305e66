"""`selfcd view`: a live polyscope viewer for the cloth scenes and for mesh files.

Two layers, so that scripts and tests can drive the viewer without a window:

* `Viewer` holds the state and the controls (play, pause, step, reset, method,
  thickness, sensor options, BVH depth). It runs a `Source` of positions (the
  paper's cloth simulated live, or frames read from files) and, on every frame,
  the chosen detection method over them, and keeps what the drawing needs:
  which faces intersect or are near, the sensor particles, per-frame stats and
  their history. It never imports polyscope.
* `PolyscopeView` draws a Viewer with polyscope: the cloth surface coloured by
  contact state, the particles as spheres, optionally the BVH boxes at a depth,
  and an imgui panel whose widgets call the Viewer's controls.

`show` opens a window; `screenshot` renders without one on polyscope's EGL
backend (servers, CI). Polyscope is imported lazily, the first time one of
them runs, so the rest of selfcd works without it and without a display.

Nothing is written to the working directory: polyscope's preferences file is
turned off and its imgui settings file is checked to be off.
"""

from __future__ import annotations

import os
import time
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import _api, _core

# Colours (linear RGB in [0, 1]). The cloth is a saturated blue so that a test
# can find it in a screenshot by hue; contact colours have other hues.
CLOTH_COLOR = (0.16, 0.42, 0.90)
NEAR_COLOR = (1.00, 0.50, 0.00)
HIT_COLOR = (0.90, 0.08, 0.08)
PARTICLE_COLOR = (0.98, 0.85, 0.10)
BOX_COLOR = (0.45, 0.45, 0.50)
CULLED_BOX_COLOR = (0.10, 0.70, 0.25)
BACKGROUND = (1.0, 1.0, 1.0)

#: Face states in `Viewer.face_state`.
FREE, NEAR, HIT = 0, 1, 2

#: The method with a particle sensor (its particles are drawn; its options are in the panel).
SENSOR_METHOD = "sensor-gated"


class ViewerError(RuntimeError):
    """The viewer cannot start (no display, no OpenGL backend, polyscope missing)."""


# ---------------------------------------------------------------- sources


class Source:
    """Where positions come from. Subclasses: `ClothSource`, `FramesSource`."""

    mesh: _api.Mesh
    #: Frames advanced since the start (or the last reset).
    frame: int = 0

    def positions(self) -> np.ndarray:
        """Current (n, 3) positions."""
        raise NotImplementedError

    def advance(self) -> bool:
        """Moves to the next frame; False when there is none (the end of a recording)."""
        raise NotImplementedError

    def reset(self) -> None:
        """Back to the first frame."""
        raise NotImplementedError

    def describe(self) -> str:
        """One line naming the source, for the panel."""
        raise NotImplementedError

    def step_stats(self) -> dict[str, Any] | None:
        """Stats of the last simulation step (cloth only), else None."""
        return None

    def extent(self) -> tuple[np.ndarray, np.ndarray]:
        """Corners (lo, hi) of a box holding every frame, for the camera's home view."""
        raise NotImplementedError


class ClothSource(Source):
    """One of the paper's cloth scenes, simulated live with `selfcd.Simulation`.

    Args:
        scene: "two-corners", "corner" or "center".
        resolution: vertices per side (11: the paper's 200 triangles).
        response_method: the detection method inside the simulator's collision
            response (not the one the viewer inspects); a change applies on reset.
    """

    def __init__(self, scene: str, resolution: int = 11, response_method: str = _api.DEFAULT_METHOD) -> None:
        self.scene = scene
        self.resolution = resolution
        self.response_method = response_method
        self._last_step: dict[str, Any] | None = None
        self.sim = _api.Simulation(scene, resolution, response_method)
        self.mesh = self.sim.mesh
        self.frame = 0

    def positions(self) -> np.ndarray:
        return self.sim.positions

    def advance(self) -> bool:
        self._last_step = self.sim.step()
        self.frame += 1
        return True

    def reset(self) -> None:
        self.sim = _api.Simulation(self.scene, self.resolution, self.response_method)
        self._last_step = None
        self.frame = 0

    def describe(self) -> str:
        return f"scene {self.scene}, {self.resolution}x{self.resolution} vertices, t = {self.sim.time:.3f} s"

    def step_stats(self) -> dict[str, Any] | None:
        return self._last_step

    def extent(self) -> tuple[np.ndarray, np.ndarray]:
        """The rest cloth's box, extended downwards by its diagonal: room for it to hang from its pins."""
        rest = self.mesh.vertices
        lo, hi = rest.min(axis=0), rest.max(axis=0)
        lo[2] -= float(np.linalg.norm(hi[:2] - lo[:2]))
        return lo, hi


class FramesSource(Source):
    """An animation given as frames sharing faces (e.g. read from files).

    Args:
        frames: (f, n, 3) positions; the first is also the rest shape.
        faces: (m, 3) vertex indices.
        names: one label per frame (file names), shown in the panel.
    """

    def __init__(self, frames: np.ndarray, faces: np.ndarray, names: Sequence[str] | None = None) -> None:
        self.frames = np.asarray(frames, dtype=np.float64)
        if self.frames.ndim != 3 or self.frames.shape[0] == 0:
            raise ValueError(f"frames must have shape (f, n, 3) with f >= 1, got {self.frames.shape}")
        self.names = list(names) if names is not None else [f"frame {i}" for i in range(len(self.frames))]
        if len(self.names) != len(self.frames):
            raise ValueError(f"{len(self.names)} names for {len(self.frames)} frames")
        self.mesh = _api.Mesh(self.frames[0], faces)
        self.frame = 0

    def positions(self) -> np.ndarray:
        return self.frames[self.frame]

    def advance(self) -> bool:
        if self.frame + 1 >= len(self.frames):
            return False
        self.frame += 1
        return True

    def reset(self) -> None:
        self.frame = 0

    def describe(self) -> str:
        return f"{self.names[self.frame]} ({self.frame + 1}/{len(self.frames)})"

    def extent(self) -> tuple[np.ndarray, np.ndarray]:
        return self.frames.min(axis=(0, 1)), self.frames.max(axis=(0, 1))


# ---------------------------------------------------------------- viewer state


@dataclass
class History:
    """The last `size` frames' detection time (ms), primitive tests and trigger (1/0), for plots."""

    size: int = 240
    time_ms: deque = field(default_factory=deque)
    primitive_tests: deque = field(default_factory=deque)
    triggered: deque = field(default_factory=deque)

    def push(self, stats: dict[str, Any]) -> None:
        """Appends one frame's detector stats, dropping the oldest beyond `size`."""
        for q, v in ((self.time_ms, stats["total_time"] * 1e3), (self.primitive_tests, stats["primitive_tests"]),
                     (self.triggered, 1.0 if stats.get("triggered") else 0.0)):
            q.append(float(v))
            while len(q) > self.size:
                q.popleft()

    def clear(self) -> None:
        """Forgets every frame."""
        for q in (self.time_ms, self.primitive_tests, self.triggered):
            q.clear()

    def __len__(self) -> int:
        return len(self.time_ms)

    def array(self, name: str) -> np.ndarray:
        """One series as a float32 array (what imgui's PlotLines takes)."""
        return np.asarray(getattr(self, name), dtype=np.float32)


class Viewer:
    """The viewer's state and controls, independent of any drawing.

    Every control (`play`, `pause`, `toggle_play`, `step`, `reset`, `set_method`,
    `set_thickness`, `set_sensor_option`, `set_bvh_depth`) is a plain method, so
    scripts and tests drive the viewer exactly as the panel does. After each
    change the current frame is detected again and `face_state`, `pairs`,
    `particles`, `stats` and `history` describe it.

    Args:
        source: where positions come from (`ClothSource` or `FramesSource`).
        method: detection method to run and show (a name from `selfcd.methods()`).
        thickness: proximity distance (m); faces closer than this are shown as near.
        sensor_options: options of the "sensor-gated" method (see `selfcd.sensor_options()`).
        history: frames kept for the plots.
    """

    def __init__(self, source: Source, method: str = _api.DEFAULT_METHOD, thickness: float = 0.0,
                 sensor_options: dict[str, Any] | None = None, history: int = 240) -> None:
        self.source = source
        self.mesh = source.mesh
        self.faces = self.mesh.faces
        self._check_method(method)
        self.method = method
        self.thickness = self._check_thickness(thickness)
        self.sensor_options: dict[str, Any] = dict(_core.sensor_defaults())
        for key, value in (sensor_options or {}).items():
            if key not in self.sensor_options:
                raise TypeError(f"unknown sensor option {key!r}; expected one of {', '.join(self.sensor_options)}")
            self.sensor_options[key] = value
        self.playing = False
        self.history = History(history)
        self.bvh_depth: int | None = None
        self._hierarchy: Any = None
        #: Message shown in the panel (the last rejected change), or "".
        self.message = ""
        self.detector = self._make_detector(self.method, self.thickness, self.sensor_options)
        self._detect()

    # ---------------------------------------------------------- controls

    def play(self) -> None:
        """Starts advancing one frame per `tick`."""
        self.playing = True

    def pause(self) -> None:
        """Stops advancing."""
        self.playing = False

    def toggle_play(self) -> None:
        """Play if paused, pause if playing."""
        self.playing = not self.playing

    def step(self) -> bool:
        """Advances one frame (one simulation step, or the next file) and detects it.

        Returns False, and pauses, at the end of a recording.
        """
        if not self.source.advance():
            self.playing = False
            return False
        self._detect()
        return True

    def tick(self) -> bool:
        """Called once per drawn frame: steps when playing. True when the frame changed."""
        return self.playing and self.step()

    def reset(self) -> None:
        """Back to the first frame with a fresh detector (sensor particles back at their start); clears the history."""
        self.source.reset()
        self.detector = self._make_detector(self.method, self.thickness, self.sensor_options)
        self.history.clear()
        self._detect()

    def set_method(self, method: str) -> None:
        """Swaps the detector for a new one running `method`, and detects the current frame with it."""
        self._check_method(method)
        self.detector = self._make_detector(method, self.thickness, self.sensor_options)
        self.method = method
        self.history.clear()
        self._detect()

    def set_thickness(self, thickness: float) -> None:
        """Sets the proximity distance (m; 0: intersections only); rebuilds the detector."""
        t = self._check_thickness(thickness)
        self.detector = self._make_detector(self.method, t, self.sensor_options)
        self.thickness = t
        self._detect()

    def set_sensor_option(self, key: str, value: Any) -> None:
        """Sets one parameter of the particle sensor; rebuilds the detector when it is "sensor-gated".

        Raises ValueError or TypeError (and keeps the old value) when the engine rejects it.
        """
        if key not in self.sensor_options:
            raise TypeError(f"unknown sensor option {key!r}; expected one of {', '.join(self.sensor_options)}")
        options = dict(self.sensor_options, **{key: value})
        detector = self._make_detector(SENSOR_METHOD, self.thickness, options)  # validates
        self.sensor_options = options
        if self.method == SENSOR_METHOD:
            self.detector = detector
            self._detect()

    def set_bvh_depth(self, depth: int | None) -> None:
        """Shows the BVH boxes `depth` levels below the root (None: hide them)."""
        if depth is not None:
            if depth < 0:
                raise ValueError(f"BVH depth must be >= 0, got {depth}")
            depth = min(int(depth), self.max_bvh_depth)
        self.bvh_depth = depth

    # ---------------------------------------------------------- what is drawn

    @property
    def positions(self) -> np.ndarray:
        """Current (n, 3) positions."""
        return self._positions

    @property
    def frame(self) -> int:
        """Frames advanced since the start or the last reset."""
        return self.source.frame

    @property
    def max_bvh_depth(self) -> int:
        """Depth of the deepest BVH leaf (root: 0)."""
        return int(self._bvh().max_depth)

    def bvh_boxes(self) -> tuple[np.ndarray, np.ndarray]:
        """BVH boxes at `bvh_depth` fitted to the current positions: ((k, 2, 3) [min, max], (k,) bool).

        The flag is True where the node's normal cone is under 90 degrees, so that
        the cone test alone culls its self-test (bvh-cones; bvh-cones-contour also
        needs the contour test to pass). Empty when the boxes are hidden.
        """
        if self.bvh_depth is None:
            return np.zeros((0, 2, 3)), np.zeros(0, dtype=bool)
        h = self._bvh()
        h.refit(self._positions)
        return h.boxes(self.bvh_depth), h.positive_cones(self.bvh_depth)

    def summary(self) -> dict[str, Any]:
        """The current frame in numbers: frame, contacts, detector stats (for the panel and tests)."""
        return {"frame": self.frame, "method": self.method, "intersecting_pairs": int(len(self.pairs)),
                "near_faces": int(np.count_nonzero(self.face_state == NEAR)),
                "hit_faces": int(np.count_nonzero(self.face_state == HIT)),
                "particles": int(len(self.particles)), "stats": self.stats, "step": self.source.step_stats()}

    # ---------------------------------------------------------- internals

    @staticmethod
    def _check_method(method: str) -> None:
        known = _api.methods()
        if method not in known:
            raise ValueError(f"unknown method {method!r}; expected one of {', '.join(known)}")

    @staticmethod
    def _check_thickness(thickness: float) -> float:
        t = float(thickness)
        if not (np.isfinite(t) and t >= 0):
            raise ValueError(f"thickness must be finite and >= 0, got {thickness}")
        return t

    def _make_detector(self, method: str, thickness: float, sensor: dict[str, Any]) -> _api.Detector:
        options = sensor if method == SENSOR_METHOD else {}
        return _api.Detector(self.mesh, method, thickness, **options)

    def _bvh(self) -> Any:
        if self._hierarchy is None:
            self._hierarchy = _core.Hierarchy(self.mesh._inner)
        return self._hierarchy

    def _detect(self) -> None:
        """Runs the detector on the source's current positions and derives what is drawn."""
        pos = np.ascontiguousarray(self.source.positions(), dtype=np.float64)
        self._positions = pos
        self.pairs = self.detector.detect(pos)
        self.stats: dict[str, Any] = self.detector.last_stats or {}
        self.particles = self.detector.particles()
        self.face_state = self._face_state(self.pairs, self.detector.last_proximity)
        self.history.push(self.stats)

    def _face_state(self, pairs: np.ndarray, prox: dict[str, np.ndarray] | None) -> np.ndarray:
        """HIT for faces in an intersecting pair; NEAR for the triangle of each
        vertex-triangle proximity contact and the faces on each edge of an
        edge-edge contact; FREE otherwise."""
        state = np.zeros(len(self.faces), dtype=np.int8)
        if prox is not None:
            vt = prox["vertex_triangle"]
            if len(vt):
                state[vt[:, 1]] = NEAR
            ee = prox["edge_edge_vertices"]
            if len(ee):
                on_edge = np.zeros(len(self.faces), dtype=bool)
                for a, b in ((ee[:, 0], ee[:, 1]), (ee[:, 2], ee[:, 3])):
                    on_edge |= self._faces_on_edges(a, b)
                state[on_edge] = NEAR
        if len(pairs):
            state[pairs.ravel()] = HIT
        return state

    def _faces_on_edges(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Mask of the faces having an edge (a[i], b[i]) for some i."""
        n = np.int64(self.mesh.n_vertices)
        keys = np.unique(np.minimum(a, b) * n + np.maximum(a, b))
        f = self.faces
        mask = np.zeros(len(f), dtype=bool)
        for i, j in ((0, 1), (1, 2), (2, 0)):
            mask |= np.isin(np.minimum(f[:, i], f[:, j]) * n + np.maximum(f[:, i], f[:, j]), keys)
        return mask


# ---------------------------------------------------------------- polyscope


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
    ps.set_up_dir("z_up")
    ps.set_front_dir("neg_y_front")
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
    `callback()` is polyscope's per-frame user callback: it draws the panel,
    applies what was clicked through the Viewer's controls, ticks the viewer
    and updates the structures when the frame changed.
    """

    def __init__(self, viewer: Viewer, ps: Any) -> None:
        self.viewer = viewer
        self.ps = ps
        self.imgui = ps.imgui
        self._methods = _api.methods()
        self._drawn_particles = -1
        ps.remove_all_structures()
        self.cloth = ps.register_surface_mesh("cloth", viewer.positions, viewer.faces, color=CLOTH_COLOR,
                                              edge_width=0.0, smooth_shade=False, back_face_policy="identical")
        self.update()
        self.frame_camera(*viewer.source.extent())

    def frame_camera(self, lo: np.ndarray, hi: np.ndarray, shift: float = 0.0,
                     aspect: float = 4 / 3) -> None:
        """Sets the scene extents to the box (lo, hi) and looks at it from the front, a little above.

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
        direction = np.array([0.35, -1.0, 0.45])
        direction /= np.linalg.norm(direction)
        # 0.8 x the distance at which the bounding sphere (radius diag/2) fits the 45-degree vertical field of
        # view: the box itself, seen from this direction, is narrower than its sphere and still fits.
        distance = 0.5 * diag / np.sin(np.radians(22.5)) * 0.8
        right = np.cross(-direction, [0.0, 0.0, 1.0])
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

    # ---------------------------------------------------------- panel

    def callback(self) -> None:
        """Polyscope's per-frame callback: the panel, then one viewer tick."""
        self.draw_panel()
        if self.viewer.tick():
            self.update()

    def draw_panel(self) -> None:
        """The imgui panel: playback, method, thickness, sensor, BVH, stats and history."""
        im, v = self.imgui, self.viewer
        changed = False
        im.PushItemWidth(220)
        im.TextUnformatted(v.source.describe())
        im.TextUnformatted(f"frame {v.frame}")
        if im.Button("Pause" if v.playing else "Play"):
            v.toggle_play()
        im.SameLine()
        if im.Button("Step"):
            v.step()
            changed = True
        im.SameLine()
        if im.Button("Reset"):
            v.reset()
            changed = True

        im.Separator()
        clicked, idx = im.Combo("method", self._methods.index(v.method), self._methods)
        if clicked and self._methods[idx] != v.method:
            changed |= self._apply(v.set_method, self._methods[idx])
        if isinstance(v.source, ClothSource):
            src = v.source
            clicked, idx = im.Combo("response (on reset)", self._methods.index(src.response_method), self._methods)
            if clicked:
                src.response_method = self._methods[idx]
        edge = v.mesh.mean_edge_length
        clicked, t = im.SliderFloat("thickness (m)", v.thickness, 0.0, 2.0 * edge, "%.4f")
        if clicked:
            changed |= self._apply(v.set_thickness, t)
        if v.method == SENSOR_METHOD and im.CollapsingHeader("Sensor parameters"):
            changed |= self._sensor_widgets()
        if im.CollapsingHeader("BVH boxes"):
            changed |= self._bvh_widgets()
        if v.message:
            im.TextColored((0.9, 0.1, 0.1, 1.0), v.message)

        im.Separator()
        self._stats_widgets()
        im.PopItemWidth()
        if changed:
            self.update()

    def _apply(self, control: Any, *args: Any) -> bool:
        """Runs a control; a rejected value is shown in the panel instead of raising."""
        try:
            control(*args)
        except (ValueError, TypeError) as exc:
            self.viewer.message = str(exc)
            return False
        self.viewer.message = ""
        return True

    def _sensor_widgets(self) -> bool:
        im, v = self.imgui, self.viewer
        o = v.sensor_options
        changed = False
        ints = {"count": (2, 16), "n_min": (0, 16), "n_max": (1, 64)}
        floats = {"a": (0.0, 100.0), "b": (0.0, 100.0), "tolerance": (0.1, 10.0), "epsilon": (0.001, 1.0),
                  "step_gain": (0.0, 64.0), "max_step": (0.05, 4.0)}
        for key, (lo, hi) in ints.items():
            clicked, val = im.SliderInt(key, int(o[key]), lo, hi)
            if clicked:
                changed |= self._apply(v.set_sensor_option, key, int(val))
        for key, (lo, hi) in floats.items():
            clicked, val = im.SliderFloat(key, float(o[key]), lo, hi, "%.3f")
            if clicked:
                changed |= self._apply(v.set_sensor_option, key, float(val))
        inner = ["bvh", "bvh-cones", "bvh-cones-contour"]
        clicked, idx = im.Combo("inner", inner.index(o["inner"]) if o["inner"] in inner else 0, inner)
        if clicked:
            changed |= self._apply(v.set_sensor_option, "inner", inner[idx])
        clicked, val = im.Checkbox("refit every frame", bool(o["refit_every_frame"]))
        if clicked:
            changed |= self._apply(v.set_sensor_option, "refit_every_frame", bool(val))
        im.TextUnformatted("lengths in mean rest edge lengths")
        return changed

    def _bvh_widgets(self) -> bool:
        im, v = self.imgui, self.viewer
        shown = v.bvh_depth is not None
        changed = False
        clicked, show = im.Checkbox("show boxes", shown)
        if clicked:
            v.set_bvh_depth(0 if show else None)
            changed = True
        if v.bvh_depth is not None:
            clicked, depth = im.SliderInt("depth", v.bvh_depth, 0, v.max_bvh_depth)
            if clicked:
                v.set_bvh_depth(depth)
                changed = True
            im.TextUnformatted("green: normal cone under 90 deg (cone test culls the node)")
        return changed

    def _stats_widgets(self) -> None:
        im, v = self.imgui, self.viewer
        s = v.stats
        trig = s.get("triggered")
        im.TextUnformatted(f"detection {s.get('total_time', 0.0) * 1e3:.3f} ms   "
                           f"primitive tests {s.get('primitive_tests', 0)}")
        im.TextUnformatted(f"node pairs {s.get('node_pairs', 0)}   culls {s.get('self_culls', 0)}+"
                           f"{s.get('pair_culls', 0)}   triggered {'-' if trig is None else ('yes' if trig else 'no')}")
        im.TextUnformatted(f"intersecting pairs {len(v.pairs)}   near faces "
                           f"{int(np.count_nonzero(v.face_state == NEAR))}")
        step = v.source.step_stats()
        if step is not None:
            im.TextUnformatted(f"simulation step {step['step_time'] * 1e3:.2f} ms   contacts {step['contacts']}   "
                               f"CG iterations {step['iterations']}")
        if len(v.history):
            width = (0.0, 50.0)
            im.PlotLines("ms", v.history.array("time_ms"), graph_size=width)
            im.PlotLines("tests", v.history.array("primitive_tests"), graph_size=width)
            if v.method == SENSOR_METHOD:
                im.PlotLines("triggered", v.history.array("triggered"), scale_min=0.0, scale_max=1.0,
                             graph_size=(0.0, 30.0))


# ---------------------------------------------------------------- entry points


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
