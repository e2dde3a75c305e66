"""The public classes and functions: thin wrappers over `selfcd._core`."""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from . import _arrays, _core
from . import weld as _weld

DEFAULT_METHOD = "bvh-cones-contour"


def methods() -> list[str]:
    """Names of every detection method the engine knows, in report order."""
    return list(_core.methods())


def sensor_options() -> list[str]:
    """Names of the keyword options the "sensor-gated" method takes."""
    return list(_core.sensor_options())


def materials() -> list[str]:
    """Names of the cloth material presets; the first is the default."""
    return list(_core.materials())


def non_conservative_methods() -> list[str]:
    """Names of the methods that can miss contacts by design (their misses are measured)."""
    return list(_core.non_conservative_methods())


class Mesh:
    """A triangle mesh: rest positions and faces, validated once, topology built once.

    Zero-area faces (collinear or coincident corners) are valid: every query
    counts one as the segment or point it is.

    Args:
        vertices: (n, 3) float array, the rest shape.
        faces: (m, 3) integer array of vertex indices.
        weld: merge vertices at exactly equal positions first (see
            `selfcd.weld.weld`), for triangle soups such as STL files. Faces
            keep their order; `vertices` is then the welded array, and
            positions given for the input's n vertices are accepted by
            `Detector.detect`, `compare_methods` and `reference_pairs`.
            Without it, a mesh with distinct vertices at one position gets an
            `UnweldedMeshWarning`.

    Raises:
        TypeError: non-numeric vertices or non-integer faces.
        ValueError: wrong shapes, empty mesh, NaN/inf, index out of range,
            a face repeating a vertex index, duplicate faces.
    """

    def __init__(self, vertices: npt.ArrayLike, faces: npt.ArrayLike, weld: bool = False) -> None:
        if not isinstance(weld, (bool, np.bool_)):
            raise TypeError(f"weld must be a bool, got {type(weld).__name__}")
        v, f = _arrays.points(vertices, "vertices"), _arrays.faces(faces)
        self._source: np.ndarray | None = None
        if weld and len(v) and f.size and f.min() >= 0 and f.max() < len(v):  # bad indices: the engine names them
            self._n_input = len(v)
            v, f, self._source = _weld.weld(v, f)
        elif not weld:
            # The engine screens the positions while it validates the mesh; the
            # exact check runs only where some may repeat (or before an error,
            # which it preceded when it ran first).
            try:
                inner = _core.Mesh(v, f, screen_positions=True)
            except Exception:
                _weld.warn_if_unwelded(v, f)
                raise
            if inner.may_repeat_positions:
                _weld.warn_if_unwelded(v, f)
            self._inner = inner
            return
        self._inner = _core.Mesh(v, f)

    def _positions(self, value: npt.ArrayLike, name: str = "positions") -> np.ndarray:
        """(n, 3) positions of this mesh; for a welded mesh, positions of the input's vertices are mapped."""
        arr = _arrays.coordinates(value, name)
        if self._source is not None and len(arr) == self._n_input and len(arr) != self.n_vertices:
            arr = arr[self._source]
        return _arrays.coordinates(arr, name, self.n_vertices)

    def _frames(self, value: npt.ArrayLike) -> np.ndarray:
        """(f, n, 3) frames of this mesh, mapped like `_positions`."""
        arr = np.asarray(value)
        if (self._source is not None and arr.ndim == 3 and arr.shape[1] == self._n_input
                and arr.shape[1] != self.n_vertices):
            arr = arr[:, self._source]
        return _arrays.frames(arr, self.n_vertices)

    @property
    def vertices(self) -> np.ndarray:
        """Rest positions, (n, 3) float64 (a copy)."""
        return self._inner.vertices

    @property
    def faces(self) -> np.ndarray:
        """Faces, (m, 3) int64 (a copy)."""
        return self._inner.faces

    @property
    def edges(self) -> np.ndarray:
        """Unique edges, (e, 2) int64, smaller vertex first; proximity edge ids index this."""
        return self._inner.edges

    @property
    def n_vertices(self) -> int:
        """Number of vertices."""
        return self._inner.n_vertices

    @property
    def n_faces(self) -> int:
        """Number of faces."""
        return self._inner.n_faces

    @property
    def mean_edge_length(self) -> float:
        """Mean rest edge length (the particle sensor's length unit)."""
        return self._inner.mean_edge_length

    @classmethod
    def _wrap(cls, inner: _core.Mesh) -> Mesh:
        """A Mesh around an engine mesh that is already validated."""
        mesh = cls.__new__(cls)
        mesh._inner = inner
        mesh._source = None
        return mesh

    def __repr__(self) -> str:
        return f"selfcd.Mesh(n_vertices={self.n_vertices}, n_faces={self.n_faces})"


def _check_mesh(mesh: object) -> None:
    """TypeError unless `mesh` is a selfcd.Mesh."""
    if not isinstance(mesh, Mesh):
        raise TypeError(f"mesh must be a selfcd.Mesh, got {type(mesh).__name__}")


class Detector:
    """Self-collision detector for one mesh, keeping its BVH (and sensor) between calls.

    Args:
        mesh: the mesh to watch.
        method: a name from `selfcd.methods()`, e.g. "brute", "bvh",
            "bvh-cones", "bvh-cones-contour" (default, conservative).
        thickness: when > 0, vertex-triangle and edge-edge pairs closer than
            this are reported in `last_proximity` too.
        max_contacts: the most proximity contacts one `detect` may collect
            (default 20 million, about 1.3 GB); beyond it `detect` raises
            ValueError rather than exhausting memory (a thickness larger than
            the mesh makes every vertex near every face).
        **method_options: options of the method; "sensor-gated" takes the
            particle sensor's parameters (`selfcd.sensor_options()`: count, a, b,
            n_min, n_max, epsilon, step_gain, max_step, tolerance, inner,
            refit_every_frame; lengths in mean-edge units). Any other option
            raises TypeError.
    """

    def __init__(self, mesh: Mesh, method: str = DEFAULT_METHOD, thickness: float = 0.0,
                 max_contacts: int | None = None, **method_options: Any) -> None:
        _check_mesh(mesh)
        if not isinstance(method, str):
            raise TypeError(f"method must be a string, got {type(method).__name__}")
        self.mesh = mesh
        self._inner = _core.Detector(mesh._inner, method, _arrays.number(thickness, "thickness"),
                                     method_options or None, _arrays.limit(max_contacts, "max_contacts"))

    @property
    def method(self) -> str:
        """The method's name."""
        return self._inner.method

    @property
    def thickness(self) -> float:
        """Proximity thickness (0: intersections only)."""
        return self._inner.thickness

    def detect(self, positions: npt.ArrayLike | None = None) -> np.ndarray:
        """Intersecting face pairs at `positions` ((n, 3); default: the rest shape).

        Returns:
            (k, 2) int64 array of face indices, i < j, rows sorted.
        """
        pos = self.mesh.vertices if positions is None else positions
        return self._inner.detect(self.mesh._positions(pos))

    def particles(self) -> np.ndarray:
        """Current sensor particle positions, (k, 3) float64; (0, 3) for methods without a sensor."""
        return self._inner.particles()

    @property
    def last_stats(self) -> dict[str, Any] | None:
        """FrameStats of the last `detect` call (times in seconds, counters), or None."""
        return self._inner.last_stats

    @property
    def last_proximity(self) -> dict[str, np.ndarray] | None:
        """Proximity contacts of the last call, or None before the first call.

        Keys: vertex_triangle (k,2) [vertex, face], vertex_triangle_distance (k,),
        vertex_triangle_bary (k,3); edge_edge (k,2) edge ids into `Mesh.edges`,
        edge_edge_vertices (k,4), edge_edge_distance (k,), edge_edge_params (k,2).
        All empty when thickness is 0.
        """
        return self._inner.last_proximity

    def proximity_faces(self) -> np.ndarray:
        """Faces in the last call's proximity contacts, sorted, int64: the triangle of each
        vertex-triangle contact and every face on an edge of an edge-edge contact.

        What the viewer and the reports draw as "near"; empty before the first call
        and when thickness is 0.
        """
        prox = self.last_proximity
        if prox is None:
            return np.zeros(0, dtype=np.int64)
        n = np.int64(self.mesh.n_vertices)
        edges, faces = self.mesh.edges, self.mesh.faces
        touched = edges[prox["edge_edge"].ravel()]
        keys = touched[:, 0] * n + touched[:, 1]
        on_edge = np.zeros(len(faces), dtype=bool)
        for i, j in ((0, 1), (1, 2), (2, 0)):
            a, b = faces[:, i], faces[:, j]
            on_edge |= np.isin(np.minimum(a, b) * n + np.maximum(a, b), keys)
        return np.union1d(prox["vertex_triangle"][:, 1], np.flatnonzero(on_edge)).astype(np.int64)

    def __repr__(self) -> str:
        return f"selfcd.Detector(method={self.method!r}, thickness={self.thickness})"



class SelfQueries:
    """The intersection, proximity and continuous queries of one mesh over a sequence of
    frames, as the cloth simulator runs them: one hierarchy, and a candidate set of
    element pairs kept from call to call where the mesh moved coherently enough.

    Each answer equals a fresh query's (`Detector` with a thickness for proximity,
    `continuous_impacts` for continuous, `self_intersections` for intersections); only
    the work differs, and `last_stats` counts it ("candidates": answered from the set).
    Where sets go stale after a few calls (the mesh moves more than the skin in a few
    frames), proximity calls are answered one-shot in streaks between sets
    ("proximity_one_shots").

    Args:
        mesh: the mesh.
        skin: how far beyond the asked distance the candidate set reaches (> 0;
            default a quarter of the mean edge length). A larger skin keeps the set
            valid through more motion but tests more candidates per call.
    """

    def __init__(self, mesh: Mesh, skin: float | None = None) -> None:
        _check_mesh(mesh)
        self.mesh = mesh
        self._inner = _core.SelfQueries(mesh._inner, None if skin is None else _arrays.number(skin, "skin"))

    @property
    def skin(self) -> float:
        """The candidate sets' reach beyond the asked distance."""
        return self._inner.skin

    @property
    def last_stats(self) -> dict[str, Any]:
        """FrameStats of the last call (times in seconds, counters); zeros before the first."""
        return self._inner.last_stats

    def intersections(self, positions: npt.ArrayLike, cones: bool = True) -> np.ndarray:
        """Intersecting non-adjacent face pairs, (k, 2) int64, i < j, sorted; exact.

        `cones=True` runs the one-shot query (`self_intersections`'s certificates);
        `cones=False` the kept hierarchy culling by boxes only (same answer, more work)."""
        return self._inner.intersections(self.mesh._positions(positions), bool(cones))

    def proximity(self, positions: npt.ArrayLike, thickness: float) -> dict[str, np.ndarray]:
        """Vertex-triangle and edge-edge pairs closer than `thickness` (> 0), keyed as
        `Detector.last_proximity`."""
        return self._inner.proximity(self.mesh._positions(positions), _arrays.number(thickness, "thickness"))

    def continuous(self, x0: npt.ArrayLike, x1: npt.ArrayLike, thickness: float = 0.0) -> dict[str, np.ndarray]:
        """Element pairs that come within `thickness` (>= 0) during the linear step x0 -> x1,
        with times of impact; keyed as `continuous_impacts`."""
        return self._inner.continuous(self.mesh._positions(x0, "x0"), self.mesh._positions(x1, "x1"),
                                      _arrays.number(thickness, "thickness"))

    def __repr__(self) -> str:
        return f"selfcd.SelfQueries(n_faces={self.mesh.n_faces}, skin={self.skin:.4g})"


def self_intersections(vertices: npt.ArrayLike, faces: npt.ArrayLike,
                       subset: npt.ArrayLike | None = None, weld: bool = False) -> np.ndarray:
    """Exact one-shot query: intersecting non-adjacent face pairs, (k, 2) int64, i < j, sorted.

    Args:
        vertices: (n, 3) positions.
        faces: (m, 3) vertex indices.
        subset: optional face indices; only pairs of two faces in the subset are
            reported, by their ids in `faces`. Adjacency is still by shared
            vertex ids, so the answer is the full query's pairs among the subset.
        weld: merge vertices at exactly equal positions first (see `Mesh`);
            face indices are unchanged.
    """
    mesh, ids = _query_mesh(vertices, faces, subset, weld)
    if mesh is None:
        return np.zeros((0, 2), dtype=np.int64)
    pairs = _core.self_intersections(mesh._inner)  # at the mesh's rest shape: `vertices` (welded if asked)
    return pairs if ids is None else ids[pairs]


def _query_mesh(vertices: npt.ArrayLike, faces: npt.ArrayLike, subset: npt.ArrayLike | None,
                weld: bool) -> tuple[Mesh | None, np.ndarray | None]:
    """The mesh a one-shot query runs on: the whole mesh, or the faces of `subset` over the
    same vertices (so adjacency stays by shared vertex ids) with the subset's sorted ids.
    The whole mesh is validated either way; None for a subset of fewer than two faces."""
    whole = Mesh(vertices, faces, weld=weld)
    if subset is None:
        return whole, None
    ids = _arrays.face_ids(subset, whole.n_faces, "subset")
    if len(ids) < 2:
        return None, ids
    return Mesh(vertices, _arrays.faces(faces)[ids], weld=weld), ids


def has_self_intersection(vertices: npt.ArrayLike, faces: npt.ArrayLike,
                          subset: npt.ArrayLike | None = None, weld: bool = False) -> bool:
    """Whether any two non-adjacent faces (of `subset`, if given) intersect; exact.

    Same answer as `len(self_intersections(...)) > 0`, but the traversal stops
    at the first intersecting pair (see `first_intersection`).
    """
    return first_intersection(vertices, faces, subset, weld) is not None


def first_intersection(vertices: npt.ArrayLike, faces: npt.ArrayLike,
                       subset: npt.ArrayLike | None = None, weld: bool = False) -> tuple[int, int] | None:
    """Some intersecting non-adjacent face pair (i, j), i < j, or None; exact.

    The engine's one-shot query (the same exact certificates as
    `self_intersections`, its hierarchy split only where they fail) stops at
    the first pair it finds, testing in one order: the pair is the same on
    every run, and the saving is the rest of the query (BENCHMARKS.md).
    `subset` and `weld` are as in `self_intersections` (ids in the original
    numbering).
    """
    mesh, ids = _query_mesh(vertices, faces, subset, weld)
    pair = None if mesh is None else _core.first_intersection(mesh._inner)  # at the rest shape, `vertices`
    if pair is None:
        return None
    a, b = pair
    return (a, b) if ids is None else (int(ids[a]), int(ids[b]))


def continuous_impacts(
    mesh: Mesh,
    x0: npt.ArrayLike,
    x1: npt.ArrayLike,
    thickness: float = 0.0,
    *,
    separation: float | None = None,
) -> dict[str, np.ndarray]:
    """Continuous query: element pairs that come within `thickness` during a linear step.

    Every vertex moves on a straight line from `x0` to `x1`. No false negatives:
    each vertex-triangle or edge-edge pair (not sharing a vertex) that comes
    within `thickness` is reported, with a time of impact in [0, 1] no later
    than when it does.

    A one-shot query: its hierarchy is built top-down for this step alone, split
    only where needed; at thickness 0 a part whose normals stay within 90 degrees
    of one axis and whose boundary stays one simple loop over the step is not
    descended (it cannot touch itself). For a sequence of steps,
    `SelfQueries.continuous` keeps its work from step to step.

    Args:
        mesh: the mesh.
        x0, x1: (n, 3) float positions at the start and the end of the step.
        thickness: distance that counts as contact (>= 0), the name every
            query uses for it.
        separation: the old name of `thickness` (deprecated; warns).

    Returns:
        "vertex_triangle" (k, 2) int64 (vertex, face) and "vertex_triangle_toi"
        (k,) float64; "edge_edge" (m, 2) int64 edge ids (rows of `mesh.edges`)
        and "edge_edge_toi" (m,) float64.
    """
    if separation is not None:
        warnings.warn("continuous_impacts(separation=...) is deprecated: the argument is "
                      "called thickness, as in every other query", DeprecationWarning, stacklevel=2)
        thickness = separation
    _check_mesh(mesh)
    n = mesh.n_vertices
    return _core.continuous_impacts(
        mesh._inner, _arrays.points(x0, "x0", n), _arrays.points(x1, "x1", n),
        _arrays.number(thickness, "thickness")
    )


def proximity_contacts(mesh: Mesh, positions: npt.ArrayLike, thickness: float,
                       max_contacts: int | None = None) -> dict[str, np.ndarray]:
    """Proximity query: element pairs closer than `thickness` at `positions`.

    A one-shot query on a hierarchy built for this call alone. Its contacts are a
    `Detector(mesh, thickness=thickness)`'s `last_proximity`, to the bit; for a
    sequence of frames, `SelfQueries.proximity` keeps its work from frame to frame.

    Args:
        mesh: the mesh.
        positions: (n, 3) float vertex positions.
        thickness: report pairs strictly closer than this (> 0, finite).
        max_contacts: most contacts collected before the query fails with
            ValueError (default: a `Detector`'s, 20 million).

    Returns:
        "vertex_triangle" (k, 2) int64 (vertex, face), "vertex_triangle_distance"
        (k,) and "vertex_triangle_bary" (k, 3); "edge_edge" (m, 2) int64 edge ids
        (rows of `mesh.edges`), "edge_edge_vertices" (m, 4), "edge_edge_distance"
        (m,) and "edge_edge_params" (m, 2); sorted by element ids.
    """
    _check_mesh(mesh)
    return _core.proximity_contacts(
        mesh._inner, _arrays.points(positions, "positions", mesh.n_vertices),
        _arrays.number(thickness, "thickness"), _arrays.limit(max_contacts, "max_contacts"))


def compare_methods(
    mesh: Mesh,
    frames: npt.ArrayLike,
    methods: Sequence[str] | None = None,
    thickness: float = 0.0,
    progress: Callable[[int], None] | None = None,
) -> list[dict[str, Any]]:
    """Runs each method over the same frames and counts misses against the exact reference.

    Args:
        mesh: the mesh.
        frames: (f, n, 3) positions, in order (stateful methods see an animation).
        methods: method names; default every method.
        thickness: proximity thickness passed to every detector.
        progress: called with the number of (method, frame) runs done so far (with 0
            during the exact reference pass, which runs first).

    Returns:
        One dict per method: "method", "stats" (per-frame arrays keyed like
        `Detector.last_stats`; "triggered" is int8 with -1 for methods without
        a sensor), "missed" and "spurious" (int64 per frame).
    """
    arr = mesh._frames(frames)
    names = None if methods is None else list(methods)
    return _core.compare_methods(mesh._inner, arr, names, _arrays.number(thickness, "thickness"), progress)


def reference_pairs(mesh: Mesh, frames: npt.ArrayLike) -> list[np.ndarray]:
    """Exact intersecting face pairs of each frame, as a list of (k, 2) int64 arrays."""
    return _core.reference_pairs(mesh._inner, mesh._frames(frames))


def paper_scenes() -> list[str]:
    """Names of the paper's cloth scenes: two-corners, corner, center."""
    return list(_core.paper_scenes())


class Simulation:
    """A cloth in motion (mass-spring cloth, implicit Euler, self- and obstacle
    collision response driven by a detection method): one of the paper's scenes,
    or any mesh with `Simulation.from_mesh`.

    Args:
        scene: "two-corners", "corner" or "center" (see `paper_scenes()`).
        resolution: vertices per side of the 1 m square cloth (11: the paper's 200 triangles).
        method: the detection method driving the collision response.
        dt: time step in seconds (default 1/60).
        self_collision: False lets the cloth pass through itself.
    """

    def __init__(self, scene: str, resolution: int = 11, method: str = DEFAULT_METHOD, dt: float | None = None,
                 self_collision: bool = True) -> None:
        for name, value in (("scene", scene), ("method", method)):
            if not isinstance(value, str):
                raise TypeError(f"{name} must be a string, got {type(value).__name__}")
        resolution = _arrays.integer(resolution, "resolution")
        if resolution < 2:
            raise ValueError(f"resolution must be at least 2 vertices per side, got {resolution}")
        self._inner = _core.Simulation(scene, resolution, method, None if dt is None else _arrays.number(dt, "dt"),
                                       _arrays.flag(self_collision, "self_collision"))
        self.mesh = Mesh._wrap(self._inner.mesh)

    @classmethod
    def from_mesh(cls, vertices: npt.ArrayLike, faces: npt.ArrayLike, *, rest: npt.ArrayLike | None = None,
                  pins: Any = (), obstacles: Sequence[Any] = (), up: str = "z", material: str = "cotton",
                  method: str = DEFAULT_METHOD, dt: float | None = None, frame_time: float | None = None,
                  self_collision: bool = True, friction: float | None = None,
                  obstacle_friction: float | None = None) -> Simulation:
        """A cloth over any triangle mesh, starting at `vertices`.

        Args:
            rest: rest shape with the same triangles (say, a garment's flat pattern); default `vertices`.
            pins: vertices held fixed: pin specs ("top:FRACTION", "indices:FILE", "box:x0,y0,z0,x1,y1,z1"),
                vertex ids, or a boolean mask (see `selfcd.scenes.pins`); several are combined.
            obstacles: meshes the cloth collides with: files, directories of frame files, (V, F)
                pairs, or (frames (k, n, 3), F) animations (see `selfcd.scenes.obstacle`).
            up: the up axis, "x", "y" or "z": gravity points down it.
            material: a preset of `selfcd.materials()` (cotton, silk, denim).
            dt: time step (s), default 1/60.
            frame_time: seconds per obstacle keyframe (default: dt).
            friction, obstacle_friction: Coulomb coefficients of cloth-cloth and
                cloth-obstacle contacts (default 0.3 and 0.5).
        """
        from . import scenes

        v = _arrays.points(vertices, "vertices")
        f = _arrays.faces(faces)
        r = None if rest is None else _arrays.points(rest, "rest", len(v))
        ids = scenes.pins(v, pins, up)
        obs = [scenes.obstacle(o) for o in obstacles]
        step = 1.0 / 60.0 if dt is None else float(dt)
        self = cls.__new__(cls)
        self._inner = _core.Simulation.from_mesh(
            v, f, r, ids, obs, step if frame_time is None else float(frame_time), scenes.gravity(up), material,
            method, dt, bool(self_collision), friction, obstacle_friction)
        self.mesh = Mesh._wrap(self._inner.mesh)
        return self

    @property
    def obstacle_positions(self) -> np.ndarray:
        """Positions of every obstacle (merged in order) at the current time, (n, 3); empty without obstacles."""
        return self._inner.obstacle_positions

    @property
    def obstacle_faces(self) -> np.ndarray:
        """Faces of the merged obstacle mesh, (m, 3)."""
        return self._inner.obstacle_faces

    def step(self) -> dict[str, Any]:
        """Advances one time step; returns its stats ("detection" holds the detector's FrameStats)."""
        return self._inner.step()

    def run(self, steps: int, every: int = 1,
            progress: Callable[[int], None] | None = None) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
        """Runs `steps` steps in the engine, recording positions every `every` steps.

        Returns:
            frames (f, n, 3) starting with the current state, their times (f,),
            and per-step stats as arrays ("detection": per-step FrameStats arrays).
        """
        steps, every = _arrays.integer(steps, "steps"), _arrays.integer(every, "every")
        if steps < 0:
            raise ValueError(f"steps must be >= 0, got {steps}")
        if every < 1:
            raise ValueError(f"every must be at least 1, got {every}")
        return self._inner.run(steps, every, progress)

    @property
    def positions(self) -> np.ndarray:
        """Current positions, (n, 3) float64."""
        return self._inner.positions

    @property
    def velocities(self) -> np.ndarray:
        """Current velocities, (n, 3) float64."""
        return self._inner.velocities

    @property
    def pinned(self) -> np.ndarray:
        """Which vertices are pinned, (n,) bool."""
        return self._inner.pinned

    @property
    def scene(self) -> str | None:
        """The scene's name (None for `from_mesh`)."""
        return self._inner.scene

    @property
    def resolution(self) -> int | None:
        """Vertices per side (None for `from_mesh`)."""
        return self._inner.resolution

    @property
    def method(self) -> str:
        """The detection method driving the response."""
        return self._inner.method

    @property
    def dt(self) -> float:
        """Time step (s)."""
        return self._inner.dt

    @property
    def contact_thickness(self) -> float:
        """Contact thickness d (m): the distance the cloth keeps from itself."""
        return self._inner.contact_thickness

    @property
    def contact_distance(self) -> float:
        """Distance within which the detector reports proximity contacts, d + margin (m)."""
        return self._inner.contact_distance

    @property
    def time(self) -> float:
        """Simulated time (s)."""
        return self._inner.time

    @property
    def steps(self) -> int:
        """Steps taken."""
        return self._inner.steps

    def energy(self) -> dict[str, float]:
        """Kinetic, gravitational, elastic and total energy of the current state (J)."""
        return self._inner.energy()

    def __repr__(self) -> str:
        if self.scene is None:
            return f"selfcd.Simulation.from_mesh({self.mesh.n_vertices} vertices, method={self.method!r})"
        return f"selfcd.Simulation(scene={self.scene!r}, resolution={self.resolution}, method={self.method!r})"
