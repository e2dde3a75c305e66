"""The viewer's state and controls, independent of any drawing (never imports polyscope)."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import _api, _core
from .sources import Source

#: Face states in `Viewer.face_state`.
FREE, NEAR, HIT = 0, 1, 2

#: The method with a particle sensor (its particles are drawn; its options are in the panel).
SENSOR_METHOD = "sensor-gated"


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
        self.face_state = np.zeros(len(self.faces), dtype=np.int8)
        self.face_state[self.detector.proximity_faces()] = NEAR
        self.face_state[self.pairs.ravel()] = HIT
        self.history.push(self.stats)
