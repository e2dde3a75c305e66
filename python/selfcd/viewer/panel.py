"""The viewer's imgui control panel: playback, method, thickness, sensor, BVH,
stats and their history. Every widget calls a `Viewer` control."""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import _api
from .sources import ClothSource
from .state import NEAR, SENSOR_METHOD, Viewer


class Panel:
    """Builds the panel each frame with `imgui` (polyscope's) for `viewer`."""

    def __init__(self, viewer: Viewer, imgui: Any) -> None:
        self.viewer = viewer
        self.imgui = imgui
        self._methods = _api.methods()

    def draw(self) -> bool:
        """Draws the panel; True when a control changed what is drawn."""
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
        return changed

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

