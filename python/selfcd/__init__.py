"""selfcd: self-collision detection for deforming triangle meshes.

Quick start::

    import selfcd
    V, F = selfcd.scenes.grid(11)
    det = selfcd.Detector(selfcd.Mesh(V, F))
    pairs = det.detect(selfcd.scenes.deform(V, "fold", angle=3.3))
    print(pairs, det.last_stats["primitive_tests"])
"""

from . import scenes
from ._api import (
    DEFAULT_METHOD,
    Detector,
    Mesh,
    SelfQueries,
    Simulation,
    compare_methods,
    continuous_impacts,
    first_intersection,
    has_self_intersection,
    materials,
    methods,
    non_conservative_methods,
    paper_scenes,
    proximity_contacts,
    reference_pairs,
    self_intersections,
    sensor_options,
)
from ._core import __version__

__all__ = [
    "DEFAULT_METHOD",
    "Detector",
    "Mesh",
    "SelfQueries",
    "Simulation",
    "compare_methods",
    "continuous_impacts",
    "first_intersection",
    "has_self_intersection",
    "materials",
    "methods",
    "non_conservative_methods",
    "paper_scenes",
    "proximity_contacts",
    "reference_pairs",
    "scenes",
    "self_intersections",
    "sensor_options",
    "__version__",
]
