"""Where the viewer's positions come from: the paper's cloth simulated live, or
frames read from files. Each source also says which axis points up."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from .. import _api

#: Axes a source may name as up.
UP_AXES = ("x", "y", "z")


def check_up(up: str) -> str:
    """`up` if it is "x", "y" or "z"; ValueError otherwise."""
    if up not in UP_AXES:
        raise ValueError(f"up must be one of {', '.join(UP_AXES)}, got {up!r}")
    return up


class Source:
    """Where positions come from. Subclasses: `ClothSource`, `FramesSource`."""

    mesh: _api.Mesh
    #: Frames advanced since the start (or the last reset).
    frame: int = 0
    #: The axis that points up ("x", "y" or "z").
    up: str = "z"

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
    """One of the paper's cloth scenes, simulated live with `selfcd.Simulation` (Z up).

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
        up: the axis that points up (`selfcd.io.up_axis` gives a file's).
    """

    def __init__(self, frames: np.ndarray, faces: np.ndarray, names: Sequence[str] | None = None,
                 up: str = "z") -> None:
        self.up = check_up(up)
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

