"""The paper's benchmark: each cloth scene simulated once, every method run on the same frames.

`paper_scenes` records the paper's three scenes with the engine's cloth
simulator (self-collision response on, as in the paper). `evaluate` runs every
detector over the recorded frames with the engine's `compare_methods`, as the
paper measures them (intersection tests: time and primitive tests per frame),
and counts missed intersections against the exact reference. The response
keeps the cloth from passing through itself, so what a gate can really miss
is proximity contacts: the methods that may miss by design are run again with
the simulator's proximity thickness and their missed proximity contacts are
counted too.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import nullcontext
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import _api

#: The paper's resolution: an 11 x 11 vertex square cloth, 200 triangles.
PAPER_RESOLUTION = 11
#: Recorded frames per scene by default, and simulation steps per frame.
DEFAULT_FRAMES, STEPS_PER_FRAME = 300, 2
#: The reference method for proximity contacts (conservative).
REFERENCE_METHOD = "bvh-cones-contour"

PAPER = {
    "two-corners": ("Pinned at two diagonal corners", 4,
                    "The paper's figure 3: the cloth hangs from two diagonal corners and barely folds."),
    "corner": ("Pinned at one corner", 6, "The paper's figure 5: the cloth falls from one corner and swings."),
    "center": ("Pinned at the centre", 8, "The paper's figure 7: the cloth drapes around its centre point and "
               "folds onto itself."),
}


@dataclass
class Scene:
    """A recorded animation: a mesh and its positions over time."""

    name: str
    title: str
    description: str
    vertices: np.ndarray
    faces: np.ndarray
    frames: np.ndarray
    dt: float = 1.0 / 60.0
    thickness: float = 0.0
    extra: dict[str, Any] = field(default_factory=dict)


@dataclass
class SceneResult:
    """Every method's per-frame results on one scene, and the exact reference."""

    scene: Scene
    runs: list[dict[str, Any]]
    reference: list[np.ndarray]
    proximity_faces: list[np.ndarray]
    proximity_counts: np.ndarray
    proximity_missed: dict[str, np.ndarray] = field(default_factory=dict)
    #: Sensor particle positions of each frame, (k, 3); k follows the convex parts, so it may change.
    particles: list[np.ndarray] | None = None


ProgressFactory = Callable[[int, str], Any]


def _bar(progress: ProgressFactory | None, total: int, label: str) -> Any:
    return progress(total, label) if progress else nullcontext(None)


def simulate(name: str, n_frames: int = DEFAULT_FRAMES, resolution: int = PAPER_RESOLUTION,
             every: int = STEPS_PER_FRAME, method: str = _api.DEFAULT_METHOD,
             progress: ProgressFactory | None = None) -> tuple[Scene, dict[str, Any]]:
    """Simulates the paper's scene `name`, recording `n_frames` frames `every` steps apart.

    Returns the recorded scene and the simulation's per-step stats.
    """
    sim = _api.Simulation(name, resolution, method)
    steps = (n_frames - 1) * every
    with _bar(progress, steps, f"{name}: simulate") as bar:
        cb = (lambda done: bar.update(done - bar.n)) if bar is not None else None
        frames, _, stats = sim.run(steps, every, cb)
    title, figure, desc = PAPER.get(name, (name, None, ""))
    scene = Scene(name, title, desc, sim.mesh.vertices, sim.mesh.faces, frames, dt=sim.dt * every,
                  thickness=sim.contact_distance,
                  extra={"paper_figure": figure, "source": "simulated", "steps": steps, "method": method,
                         "contact_thickness": sim.contact_thickness, "pinned": np.flatnonzero(sim.pinned)})
    return scene, stats


def paper_scenes(n_frames: int | None = None, resolution: int = PAPER_RESOLUTION,
                 progress: ProgressFactory | None = None) -> list[Scene]:
    """The paper's three scenes, each simulated once."""
    return [simulate(name, n_frames or DEFAULT_FRAMES, resolution, progress=progress)[0]
            for name in _api.paper_scenes()]


def scenes_note() -> str:
    """One sentence on where the demo's scenes come from."""
    return ("Each scene is simulated once with selfcd's cloth simulator (self-collision response on, driven by "
            f"{_api.DEFAULT_METHOD}); every method then runs on the recorded frames with the simulator's "
            "proximity thickness.")


def evaluate(scene: Scene, methods: list[str] | None = None,
             progress: Callable[[int], None] | None = None) -> SceneResult:
    """Runs every method (default: all) over the scene's frames, plus the exact references."""
    mesh = _api.Mesh(scene.vertices, scene.faces)
    runs = _api.compare_methods(mesh, scene.frames, methods, progress=progress)
    reference = _api.reference_pairs(mesh, scene.frames)
    faces, counts = proximity_reference(mesh, scene.frames, scene.thickness)
    missed = proximity_misses(mesh, scene, [r["method"] for r in runs], counts)
    return SceneResult(scene, runs, reference, faces, counts, missed, sensor_particles(mesh, scene.frames))


def proximity_misses(mesh: _api.Mesh, scene: Scene, methods: list[str], counts: np.ndarray) -> dict[str, np.ndarray]:
    """Per-frame proximity contacts missed by each method that may miss by design.

    Every method's proximity contacts are a subset of the reference's (the same
    exact distance test), so the difference of the counts is the number missed.
    """
    risky = [m for m in methods if m in _api.non_conservative_methods()]
    if scene.thickness <= 0 or not risky:
        return {}
    runs = _api.compare_methods(mesh, scene.frames, risky, thickness=scene.thickness)
    return {r["method"]: np.maximum(counts - np.asarray(r["stats"]["proximity_contacts"]), 0) for r in runs}


def proximity_reference(mesh: _api.Mesh, frames: np.ndarray, thickness: float) -> tuple[list[np.ndarray], np.ndarray]:
    """Per frame: the faces in proximity contact (for drawing) and the number of contacts."""
    if thickness <= 0:
        return [np.zeros(0, dtype=np.int64)] * len(frames), np.zeros(len(frames), dtype=np.int64)
    det = _api.Detector(mesh, REFERENCE_METHOD, thickness=thickness)
    faces, counts = [], []
    for f in frames:
        det.detect(f)
        prox = det.last_proximity
        counts.append(len(prox["vertex_triangle"]) + len(prox["edge_edge"]))
        faces.append(det.proximity_faces())
    return faces, np.asarray(counts, dtype=np.int64)


def sensor_particles(mesh: _api.Mesh, frames: np.ndarray) -> list[np.ndarray] | None:
    """Sensor particle positions of each frame, (k, 3) arrays (k may change from frame to
    frame: particles are added and merged as convex parts appear and vanish), or None
    when the sensor cannot run here."""
    if "sensor-gated" not in _api.methods():
        return None
    try:
        det = _api.Detector(mesh, "sensor-gated")
    except ValueError:  # e.g. a curved rest shape, which the sensor does not support
        return None
    out = []
    for f in frames:
        det.detect(f)
        out.append(det.particles())
    return out


def missed_proximity(result: SceneResult, run: dict[str, Any]) -> np.ndarray | None:
    """Proximity contacts per frame that `run`'s method missed, or None where not measured
    (conservative methods)."""
    return result.proximity_missed.get(run["method"])


def summarize(result: SceneResult) -> dict[str, Any]:
    """Per-method summary of one scene: times, primitive tests, misses, triggers."""
    ref_counts = [len(r) for r in result.reference]
    methods = {}
    for run in result.runs:
        s = run["stats"]
        ms = np.asarray(s["total_time"]) * 1e3
        trig = np.asarray(s["triggered"])
        missed_prox = missed_proximity(result, run)
        any_missed = np.asarray(run["missed"]) > 0
        if missed_prox is not None:
            any_missed |= missed_prox > 0
        methods[run["method"]] = {
            "frames": int(ms.size),
            "mean_time_ms": float(ms.mean()),
            "median_time_ms": float(np.median(ms)),
            "max_time_ms": float(ms.max()),
            "mean_primitive_tests": float(np.mean(s["primitive_tests"])),
            "total_primitive_tests": int(np.sum(s["primitive_tests"])),
            "mean_node_pairs": float(np.mean(s["node_pairs"])),
            "missed_contacts": int(np.sum(run["missed"])),
            "frames_with_misses": int(np.count_nonzero(any_missed)),
            "spurious_contacts": int(np.sum(run["spurious"])),
            "missed_proximity_contacts": None if missed_prox is None else int(missed_prox.sum()),
            "triggered_frames": None if (trig < 0).all() else int(np.count_nonzero(trig == 1)),
        }
    scene = result.scene
    return {
        "name": scene.name,
        "title": scene.title,
        "description": scene.description,
        "paper_figure": scene.extra.get("paper_figure"),
        "vertices": int(scene.vertices.shape[0]),
        "triangles": int(scene.faces.shape[0]),
        "frames": int(scene.frames.shape[0]),
        "frame_dt": scene.dt,
        "proximity_thickness": scene.thickness,
        "frames_intersecting": int(np.count_nonzero(ref_counts)),
        "max_intersecting_pairs": int(max(ref_counts, default=0)),
        "frames_in_proximity": int(np.count_nonzero(result.proximity_counts)),
        "max_proximity_contacts": int(result.proximity_counts.max(initial=0)),
        "source": scene.extra.get("source", ""),
        "methods": methods,
    }
