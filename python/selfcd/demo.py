"""The paper's benchmark: scenes recorded once, every method run on the same frames.

A scene is a mesh plus an animation (frames of positions). `evaluate` runs
every detector over it with the engine's `compare_methods`, so each method
sees exactly the same frames and its misses are counted against the exact
reference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from . import _api, scenes

#: The paper's resolution: an 11 x 11 vertex square cloth, 200 triangles.
PAPER_RESOLUTION = 11


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
    extra: dict[str, Any] = field(default_factory=dict)


@dataclass
class SceneResult:
    """Every method's per-frame results on one scene."""

    scene: Scene
    runs: list[dict[str, Any]]
    reference: list[np.ndarray]
    particles: np.ndarray | None = None


def _animate(rest: np.ndarray, shape: str, key: str, values: np.ndarray, **fixed: float) -> np.ndarray:
    """Frames of `rest` in `shape` with parameter `key` swept over `values`."""
    return np.stack([scenes.deform(rest, shape, **{key: float(v)}, **fixed) for v in values])


def analytic_scenes(n_frames: int = 120, resolution: int = PAPER_RESOLUTION) -> list[Scene]:
    """Three analytic animations of the paper's cloth: a fold pressed through
    itself, a crumple growing until the sheet passes through itself, and a roll."""
    V, F = scenes.grid(resolution)
    t = np.linspace(0.0, 1.0, n_frames)
    specs = [
        ("fold", "Fold pressed through itself", "Half the cloth folds over a cylinder, "
         "angle 0 to 1.1 pi: flat, folded on top, then pushed through.", "fold", "angle", 1.1 * math.pi * t,
         {"radius": 0.05}),
        ("crumple", "Growing crumple", "A smooth random displacement grows from 0 to 0.3 widths "
         "until the sheet folds through itself.", "crumple", "amplitude", 0.3 * t, {"wavelength": 0.6, "seed": 3}),
        ("roll", "Roll", "The cloth rolls from one end onto a spiral, up to 1.5 turns, layers 0.01 widths apart.",
         "roll", "turns", 1.5 * t, {"gap": 0.01}),
    ]
    return [
        Scene(name, title, desc, V, F, _animate(V, shape, key, vals, **fixed), extra={"source": "analytic"})
        for name, title, desc, shape, key, vals, fixed in specs
    ]


def evaluate(scene: Scene, methods: list[str] | None = None, progress: Callable[[int], None] | None = None) -> SceneResult:
    """Runs every method (default: all) over the scene's frames and the exact reference."""
    mesh = _api.Mesh(scene.vertices, scene.faces)
    runs = _api.compare_methods(mesh, scene.frames, methods, progress=progress)
    reference = _api.reference_pairs(mesh, scene.frames)
    return SceneResult(scene, runs, reference, sensor_particles(mesh, scene.frames))


def sensor_particles(mesh: _api.Mesh, frames: np.ndarray) -> np.ndarray | None:
    """Sensor particle positions per frame, (f, k, 3), or None when no method has a sensor."""
    if "sensor-gated" not in _api.methods():
        return None
    det = _api.Detector(mesh, "sensor-gated")
    out = []
    for f in frames:
        det.detect(f)
        out.append(det.particles())
    return np.stack(out)


def summarize(result: SceneResult) -> dict[str, Any]:
    """Per-method summary of one scene: times, primitive tests, misses, triggers."""
    ref_counts = [len(r) for r in result.reference]
    methods = {}
    for run in result.runs:
        s = run["stats"]
        ms = np.asarray(s["total_time"]) * 1e3
        trig = np.asarray(s["triggered"])
        methods[run["method"]] = {
            "frames": int(ms.size),
            "mean_time_ms": float(ms.mean()),
            "median_time_ms": float(np.median(ms)),
            "max_time_ms": float(ms.max()),
            "mean_primitive_tests": float(np.mean(s["primitive_tests"])),
            "total_primitive_tests": int(np.sum(s["primitive_tests"])),
            "mean_node_pairs": float(np.mean(s["node_pairs"])),
            "missed_contacts": int(np.sum(run["missed"])),
            "frames_with_misses": int(np.count_nonzero(run["missed"])),
            "spurious_contacts": int(np.sum(run["spurious"])),
            "triggered_frames": None if (trig < 0).all() else int(np.count_nonzero(trig == 1)),
        }
    scene = result.scene
    return {
        "name": scene.name,
        "title": scene.title,
        "description": scene.description,
        "vertices": int(scene.vertices.shape[0]),
        "triangles": int(scene.faces.shape[0]),
        "frames": int(scene.frames.shape[0]),
        "frames_in_contact": int(np.count_nonzero(ref_counts)),
        "max_contacts": int(max(ref_counts, default=0)),
        "source": scene.extra.get("source", ""),
        "methods": methods,
    }


def paper_scenes(n_frames: int | None = None, resolution: int = PAPER_RESOLUTION,
                 progress: Callable[[int, str], Any] | None = None) -> list[Scene]:
    """The demo's three scenes, recorded. `progress(total, label)` makes a progress bar
    (a context manager with `update(n)`) for anything that takes a while."""
    return analytic_scenes(n_frames or 120, resolution)


def scenes_note() -> str:
    """One sentence on where the demo's scenes come from."""
    return ("The scenes are analytic animations of the paper's square cloth "
            "(the cloth simulator is not in this build yet).")
