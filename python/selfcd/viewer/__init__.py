"""`selfcd view`: a live polyscope viewer for the cloth scenes and for mesh files.

Four modules, so that scripts and tests can drive the viewer without a window:

* `sources`: where positions come from (`ClothSource`: the paper's cloth
  simulated live; `FramesSource`: frames read from files) and which axis is up.
* `state`: `Viewer` holds the state and the controls (play, pause, step,
  reset, method, thickness, sensor options, BVH depth); on every frame it runs
  the chosen detection method and keeps what the drawing needs: which faces
  intersect, which are near (the engine's proximity contacts,
  `Detector.proximity_faces`, as in the reports), the sensor particles, stats
  and their history. It never imports polyscope.
* `backend`: `PolyscopeView` draws a Viewer with polyscope; `show` opens a
  window, `screenshot` and `render` draw without one on EGL (servers, CI).
* `panel`: the imgui panel whose widgets call the Viewer's controls.

Polyscope is imported lazily, the first time the backend runs.
"""

from .backend import (
    BACKGROUND,
    BOX_COLOR,
    CLOTH_COLOR,
    CULLED_BOX_COLOR,
    HIT_COLOR,
    NEAR_COLOR,
    PARTICLE_COLOR,
    PolyscopeView,
    ViewerError,
    init_polyscope,
    render,
    run_frames,
    screenshot,
    show,
)
from .panel import Panel
from .sources import UP_AXES, ClothSource, FramesSource, Source, check_up
from .state import FREE, HIT, NEAR, SENSOR_METHOD, History, Viewer

__all__ = [
    "BACKGROUND", "BOX_COLOR", "CLOTH_COLOR", "CULLED_BOX_COLOR", "HIT_COLOR", "NEAR_COLOR", "PARTICLE_COLOR",
    "FREE", "HIT", "NEAR", "SENSOR_METHOD", "UP_AXES",
    "ClothSource", "FramesSource", "History", "Panel", "PolyscopeView", "Source", "Viewer", "ViewerError",
    "check_up", "init_polyscope", "render", "run_frames", "screenshot", "show",
]
