#!/usr/bin/env python3
"""selfcd's cloth against Blender's cloth (bpy), in one process, on the paper's scenes.

Each scene is the same square cloth (1 m, n x n vertices, flat at z = 0,
pinned as in `selfcd.scenes.paper`) under gravity, simulated frame by frame at
60 frames per second with self-collision on in both engines:

- selfcd: `selfcd.scenes.paper(scene, resolution=n)`, one step per frame
  (dt = 1/60 s), contact thickness d = 0.1 mean edge;
- Blender: the same mesh and pins (a pin vertex group), Blender's "Cotton"
  cloth preset (quality 5 substeps per frame), self-collision on with its
  minimum distance set to the same d; `scene.frame_set(f)` steps it.

Materials are each engine's own cotton, not matched spring for spring: the
table compares what a user gets from each, wall time per frame and how many
triangle pairs intersect after each frame (counted exactly by
`selfcd.self_intersections` on both engines' positions). Frames alternate
between the engines so load hits them alike. Blender (the `bpy` wheel, Python
3.11 only) is a benchmark extra: `pip install .[bench]`.

    python3 scripts/bench_blender.py --resolution 41 --frames 120 --json blender.json
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

import selfcd

SCENES = ("two-corners", "corner", "center")
FPS = 60


class BlenderCloth:
    """A selfcd cloth scene as a Blender cloth object in a fresh, empty scene."""

    def __init__(self, bpy: Any, sim: selfcd.Simulation, frames: int) -> None:
        """The cloth of `sim` (its rest mesh, pins and contact thickness) in Blender."""
        bpy.ops.wm.read_factory_settings(use_empty=True)
        self.bpy = bpy
        V, F = sim.mesh.vertices, sim.mesh.faces
        mesh = bpy.data.meshes.new("cloth")
        mesh.from_pydata(V.tolist(), [], F.tolist())
        mesh.update()
        self.obj = bpy.data.objects.new("cloth", mesh)
        self.scene = bpy.context.scene
        self.scene.collection.objects.link(self.obj)
        pins = np.flatnonzero(sim.pinned).tolist()
        group = self.obj.vertex_groups.new(name="pin")
        group.add(pins, 1.0, "REPLACE")
        mod = self.obj.modifiers.new("cloth", "CLOTH")
        s = mod.settings
        # Blender's Cotton preset (scripts/presets/cloth/Cotton.py)
        s.quality, s.mass = 5, 0.3
        s.tension_stiffness = s.compression_stiffness = s.shear_stiffness = 15.0
        s.bending_stiffness = 0.5
        s.tension_damping = s.compression_damping = s.shear_damping = 5.0
        s.air_damping = 1.0
        s.vertex_group_mass = "pin"
        c = mod.collision_settings
        c.use_self_collision = True
        c.self_distance_min = sim.contact_thickness
        self.scene.gravity = (0.0, 0.0, -9.81)
        self.scene.render.fps = FPS
        self.scene.frame_start, self.scene.frame_end = 1, frames + 1
        mod.point_cache.frame_start, mod.point_cache.frame_end = 1, frames + 1
        self.scene.frame_set(1)
        self.frame = 1
        self.n = len(V)

    def step(self) -> None:
        self.frame += 1
        self.scene.frame_set(self.frame)

    def positions(self) -> np.ndarray:
        depsgraph = self.bpy.context.evaluated_depsgraph_get()
        evaluated = self.obj.evaluated_get(depsgraph)
        mesh = evaluated.to_mesh()
        co = np.empty(3 * self.n)
        mesh.vertices.foreach_get("co", co)
        evaluated.to_mesh_clear()
        return co.reshape(-1, 3)


def run_scene(bpy: Any, scene: str, n: int, frames: int) -> dict[str, Any]:
    sim = selfcd.Simulation(scene, resolution=n)
    faces = sim.mesh.faces
    blender = BlenderCloth(bpy, sim, frames)
    times: dict[str, list[float]] = {"selfcd": [], "blender": []}
    left: dict[str, list[int]] = {"selfcd": [], "blender": []}
    last: dict[str, np.ndarray] = {}
    for _ in range(frames):
        t0 = time.perf_counter()
        sim.step()
        times["selfcd"].append(time.perf_counter() - t0)
        last["selfcd"] = sim.positions
        left["selfcd"].append(len(selfcd.self_intersections(last["selfcd"], faces)))
        t0 = time.perf_counter()
        blender.step()
        times["blender"].append(time.perf_counter() - t0)
        last["blender"] = blender.positions()
        left["blender"].append(len(selfcd.self_intersections(last["blender"], faces)))
    row: dict[str, Any] = {"scene": scene, "resolution": n, "triangles": len(faces), "frames": frames,
                           "thickness": sim.contact_thickness}
    for k in times:
        row[f"{k}_ms"] = 1e3 * statistics.fmean(times[k])
        row[f"{k}_max_ms"] = 1e3 * max(times[k])
        row[f"{k}_intersecting_frames"] = sum(1 for c in left[k] if c)
        row[f"{k}_max_intersections"] = max(left[k])
        row[f"{k}_final_intersections"] = left[k][-1]
        # both really simulate: the cloth falls about its pins
        row[f"{k}_final_mean_z"] = float(last[k][:, 2].mean())
    return row


def table(rows: list[dict[str, Any]]) -> str:
    head = ["scene", "triangles", "frames", "selfcd ms/frame", "Blender ms/frame", "selfcd/Blender",
            "frames with intersections: selfcd / Blender", "most intersecting pairs: selfcd / Blender"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        lines.append("| " + " | ".join([
            r["scene"], str(r["triangles"]), str(r["frames"]), f"{r['selfcd_ms']:.1f}", f"{r['blender_ms']:.1f}",
            f"{r['selfcd_ms'] / r['blender_ms']:.2f}",
            f"{r['selfcd_intersecting_frames']} / {r['blender_intersecting_frames']}",
            f"{r['selfcd_max_intersections']} / {r['blender_max_intersections']}"]) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", default=",".join(SCENES), help="comma-separated paper scenes (default: all three)")
    ap.add_argument("--resolution", type=int, default=41, help="vertices per side (default 41)")
    ap.add_argument("--frames", type=int, default=120, help="frames of 1/60 s per scene (default 120)")
    ap.add_argument("--json", metavar="OUT", help="also write the rows as JSON to OUT")
    args = ap.parse_args(argv)
    scenes = [s.strip() for s in args.scenes.split(",") if s.strip()]
    for s in scenes:
        if s not in SCENES:
            ap.error(f"unknown scene {s!r}; expected one of {', '.join(SCENES)}")
    if args.frames < 1 or args.resolution < 2:
        ap.error("--frames must be >= 1 and --resolution >= 2")
    try:
        import bpy
    except ImportError:
        print("Blender's Python module (bpy) is not installed: pip install .[bench] (Python 3.11)", file=sys.stderr)
        return 2
    rows = []
    try:
        for s in scenes:
            print(f"{s}: {args.resolution} x {args.resolution}, {args.frames} frames ...", file=sys.stderr)
            rows.append(run_scene(bpy, s, args.resolution, args.frames))
    except KeyboardInterrupt:
        print("interrupted: the table holds the scenes finished so far", file=sys.stderr)
    print(f"selfcd {selfcd.__version__}; Blender {bpy.app.version_string}")
    print(table(rows))
    if args.json:
        Path(args.json).write_text(json.dumps({"blender": bpy.app.version_string, "rows": rows}, indent=1) + "\n")
    return 130 if len(rows) < len(scenes) else 0


if __name__ == "__main__":
    sys.exit(main())
