"""Type stubs for the compiled extension `selfcd._core` (crates/selfcd-py)."""

from collections.abc import Callable
from typing import Any, final

import numpy as np

__version__: str

def methods() -> list[str]:
    """Names of every detection method the engine knows, in report order."""

def non_conservative_methods() -> list[str]:
    """Names of the methods that may miss contacts by design."""

def sensor_options() -> list[str]:
    """Names of the keyword options the `sensor-gated` method takes."""

@final
class Mesh:
    """A validated triangle mesh: rest positions, faces, topology."""

    def __new__(cls, vertices: np.ndarray, faces: np.ndarray, screen_positions: bool = False) -> Mesh:
        """Validates an (n,3) float64 vertex array and an (m,3) int64 face array; with
        `screen_positions`, also screens the vertices for repeated positions."""
    @property
    def may_repeat_positions(self) -> bool:
        """False only when screened and every position is distinct (welding would merge nothing)."""
    @property
    def vertices(self) -> np.ndarray:
        """Rest positions, (n,3) float64."""
    @property
    def faces(self) -> np.ndarray:
        """Faces, (m,3) int64."""
    @property
    def edges(self) -> np.ndarray:
        """Unique edges, (e,2) int64, smaller vertex first."""
    @property
    def n_vertices(self) -> int:
        """Number of vertices."""
    @property
    def n_faces(self) -> int:
        """Number of faces."""
    @property
    def mean_edge_length(self) -> float:
        """Mean rest edge length."""

@final
class Detector:
    """One detection method on one mesh, keeping its state between calls."""

    def __new__(cls, mesh: Mesh, method: str, thickness: float = 0.0,
                 options: dict[str, Any] | None = None, max_contacts: int | None = None) -> Detector:
        """Builds the detector; `options` are the method's keyword options; `max_contacts`
        limits the proximity contacts of one call (ValueError beyond it)."""
    def detect(self, positions: np.ndarray) -> np.ndarray:
        """Intersecting face pairs at (n,3) float64 `positions`: (k,2) int64, sorted, i<j."""
    def particles(self) -> np.ndarray:
        """Current sensor particle positions, (k,3) float64 ((0,3) without a sensor)."""
    @property
    def method(self) -> str:
        """The method's name."""
    @property
    def thickness(self) -> float:
        """Proximity thickness."""
    @property
    def n_vertices(self) -> int:
        """Vertices the detector expects."""
    @property
    def last_stats(self) -> dict[str, Any] | None:
        """FrameStats of the last call, or None."""
    @property
    def last_proximity(self) -> dict[str, np.ndarray] | None:
        """Proximity contacts of the last call, or None."""

@final
class SelfQueries:
    """Coherent intersection, proximity and continuous queries of one mesh over a frame sequence."""

    def __new__(cls, mesh: Mesh, skin: float | None = None) -> SelfQueries:
        """Builds the hierarchy; candidate sets reach `skin` beyond the asked distance."""
    def intersections(self, positions: np.ndarray, cones: bool = True) -> np.ndarray:
        """Intersecting non-adjacent face pairs, (k,2) int64, sorted, i<j."""
    def proximity(self, positions: np.ndarray, thickness: float) -> dict[str, np.ndarray]:
        """Vertex-triangle and edge-edge pairs closer than `thickness`."""
    def continuous(self, x0: np.ndarray, x1: np.ndarray, thickness: float) -> dict[str, np.ndarray]:
        """Element pairs coming within `thickness` during the linear step x0 -> x1, with times of impact."""
    @property
    def skin(self) -> float:
        """The candidate sets' reach beyond the asked distance."""
    @property
    def last_stats(self) -> dict[str, Any]:
        """FrameStats of the last call."""

def position_groups(positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(group id per vertex, first vertex per group), int64: exactly equal positions, first-occurrence order."""

def self_intersections(mesh: Mesh, positions: np.ndarray | None = None) -> np.ndarray:
    """Exact intersecting face pairs at `positions` (default: the rest shape), (k,2) int64, sorted, i<j."""

def first_intersection(mesh: Mesh, positions: np.ndarray | None = None) -> tuple[int, int] | None:
    """Some intersecting non-adjacent face pair (i, j), i < j, or None (at `positions`, default the rest
    shape); stops at the first found."""

def one_shot_detection(mesh: Mesh, positions: np.ndarray | None = None) -> tuple[np.ndarray, dict[str, Any]]:
    """`self_intersections` with a Detector's stats dict (traverse_time: the whole query)."""

def continuous_impacts(mesh: Mesh, x0: np.ndarray, x1: np.ndarray, thickness: float = 0.0) -> dict[str, np.ndarray]:
    """Element pairs coming within `thickness` during the linear step x0 -> x1, with times of impact."""

def proximity_contacts(mesh: Mesh, positions: np.ndarray, thickness: float,
                       max_contacts: int | None = None) -> dict[str, np.ndarray]:
    """Vertex-triangle and edge-edge pairs closer than `thickness` at `positions` (one-shot)."""

def compare_methods(mesh: Mesh, frames: np.ndarray, methods: list[str] | None = None, thickness: float = 0.0,
                    progress: Callable[[int], object] | None = None) -> list[dict[str, Any]]:
    """Every method over the same (f,n,3) frames, misses counted against the exact reference."""

def reference_pairs(mesh: Mesh, frames: np.ndarray) -> list[np.ndarray]:
    """Exact intersecting face pairs of each frame."""

def grid(n: int, size: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Square grid cloth of n x n vertices: (vertices, faces)."""

def deform(rest: np.ndarray, shape: str, **params: float) -> np.ndarray:
    """Positions of a flat rest shape put into an analytic shape."""

def paper_scenes() -> list[str]:
    """Names of the paper's cloth scenes, in the paper's order."""

def materials() -> list[str]:
    """Names of the cloth material presets (the first is the default)."""

@final
class Simulation:
    """One of the paper's cloth scenes in motion, stepped with a detection method."""

    def __new__(cls, scene: str, resolution: int = 11, method: str = "bvh-cones-contour",
                 dt: float | None = None, self_collision: bool = True) -> Simulation:
        """Builds the scene's cloth and simulator."""
    @staticmethod
    def from_mesh(vertices: np.ndarray, faces: np.ndarray, rest: np.ndarray | None = None,
                  pins: np.ndarray | None = None, obstacles: list[tuple[np.ndarray, np.ndarray]] = ...,
                  frame_time: float = ..., gravity: tuple[float, float, float] = ...,
                  material: str = "cotton", method: str = "bvh-cones-contour", dt: float | None = None,
                  self_collision: bool = True, friction: float | None = None,
                  obstacle_friction: float | None = None) -> Simulation:
        """A cloth over any mesh, with pins (vertex ids) and obstacles ((keyframes (k,n,3), faces));
        defaults: no obstacles, frame_time 1/60 s, gravity (0, 0, -9.81)."""
    @property
    def obstacle_positions(self) -> np.ndarray:
        """Obstacle positions (merged) at the current time, (n,3)."""
    @property
    def obstacle_faces(self) -> np.ndarray:
        """Faces of the merged obstacle mesh, (m,3)."""
    def step(self) -> dict[str, Any]:
        """Advances one time step; returns its stats."""
    def run(self, steps: int, every: int = 1, progress: Callable[[int], object] | None = None
            ) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
        """Runs `steps` steps: (frames (f,n,3), times (f,), per-step stats arrays)."""
    @property
    def positions(self) -> np.ndarray:
        """Current positions, (n,3)."""
    @property
    def velocities(self) -> np.ndarray:
        """Current velocities, (n,3)."""
    @property
    def mesh(self) -> Mesh:
        """The cloth's mesh."""
    @property
    def pinned(self) -> np.ndarray:
        """Pinned vertices, (n,) bool."""
    @property
    def scene(self) -> str | None:
        """The scene's name (None for a mesh)."""
    @property
    def resolution(self) -> int | None:
        """Vertices per side (None for a mesh)."""
    @property
    def method(self) -> str:
        """The detection method driving the response."""
    @property
    def dt(self) -> float:
        """Time step (s)."""
    @property
    def contact_thickness(self) -> float:
        """Contact thickness d (m)."""
    @property
    def contact_distance(self) -> float:
        """Proximity detection distance d + margin (m)."""
    @property
    def time(self) -> float:
        """Simulated time (s)."""
    @property
    def steps(self) -> int:
        """Steps taken."""
    def energy(self) -> dict[str, float]:
        """Kinetic, gravity, elastic and total energy (J)."""

def bench_states() -> list[str]:
    """Names of the scaling benchmark's states."""

def bench_scaling(sizes: list[int], states: list[str], methods: list[str], reps: int = 3,
                  progress: Callable[[int], object] | None = None) -> list[dict[str, Any]]:
    """The engine's scaling benchmark: one dict per (size, state, method)."""

def sensor_defaults() -> dict[str, Any]:
    """Default values of the particle sensor's options, as a dict."""

@final
class Hierarchy:
    """The bottom-up BVH of one mesh (as the BVH detectors build it), refitted on demand."""

    def __new__(cls, mesh: Mesh) -> Hierarchy:
        """Builds the hierarchy of `mesh` on its rest shape."""
    def refit(self, positions: np.ndarray) -> None:
        """Refits every box and cone to (n,3) float64 positions."""
    @property
    def max_depth(self) -> int:
        """Depth of the deepest leaf (root: 0)."""
    @property
    def n_nodes(self) -> int:
        """Number of nodes."""
    def boxes(self, depth: int) -> np.ndarray:
        """Boxes of the cut at `depth`, (k,2,3) float64 [min, max]."""
    def positive_cones(self, depth: int) -> np.ndarray:
        """For each node of the cut at `depth`: is its normal cone under 90 degrees, (k,) bool."""
