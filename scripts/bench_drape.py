"""Cloth with obstacles, timed: a garment draped on its body, and a 20k square
cloth falling on a sphere. Prints a markdown table for BENCHMARKS.md.

    PYTHONPATH=python python3 scripts/bench_drape.py --data DIR [--steps 30] [--garment NAME]

Per step: wall-clock ms of the whole step and of its parts (solve; self-collision
queries: proximity, continuous, intersection checks; cloth-obstacle queries:
the same three; response: the rest), contacts, and intersections left at the
end of the step (self, then cloth-obstacle; the last frame is checked again by
the exact query on the combined mesh).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import selfcd


def garment_on_body(data: Path, name: str) -> tuple[str, selfcd.Simulation]:
    v, f = selfcd.io.load_mesh(data / f"{name}.obj")
    (gv, gf), (bv, bf) = selfcd.scenes.split_body(v, f)
    sim = selfcd.Simulation.from_mesh(gv, gf, obstacles=[(bv, bf)], up="y")
    return f"{name}: garment on its body (static)", sim


def square_on_sphere() -> tuple[str, selfcd.Simulation]:
    n = 101  # 2 x 100^2 = 20,000 triangles
    v, f = selfcd.scenes.grid(n, 1.0)
    v = v - [0.5, 0.5, -0.33]
    sphere = selfcd.scenes.sphere(32, 64, 0.3)
    return "20k square cloth falling on a sphere", selfcd.Simulation.from_mesh(v, f, obstacles=[sphere])


def left_on_combined_mesh(sim: selfcd.Simulation) -> tuple[int, int]:
    """(cloth-cloth, cloth-obstacle) intersecting pairs now, by the exact query on the combined mesh."""
    x, o = sim.positions, sim.obstacle_positions
    m = sim.mesh.n_faces
    pairs = selfcd.self_intersections(np.concatenate([x, o]), np.concatenate([sim.mesh.faces, sim.obstacle_faces + len(x)]))
    pairs = np.asarray(pairs).reshape(-1, 2)
    cloth = pairs[pairs.min(axis=1) < m]
    cross = int(np.count_nonzero(cloth.max(axis=1) >= m))
    return len(cloth) - cross, cross


def bench(label: str, sim: selfcd.Simulation, steps: int) -> str:
    t0 = time.perf_counter()
    _, _, st = sim.run(steps, every=steps)
    wall = time.perf_counter() - t0
    ms = {k: 1e3 * float(np.mean(st[k])) for k in ("step_time", "solve_time", "detect_time", "obstacle_time",
                                                    "response_time")}
    self_left, cross_left = left_on_combined_mesh(sim)
    start = selfcd.self_intersections(sim.mesh.vertices, sim.mesh.faces)
    return (f"| {label} | {sim.mesh.n_faces:,} / {len(sim.obstacle_faces):,} | {steps} | {ms['step_time']:.0f} | "
            f"{ms['solve_time']:.0f} | {ms['detect_time']:.0f} | {ms['obstacle_time']:.0f} | "
            f"{ms['response_time']:.0f} | {np.mean(st['contacts'] - st['obstacle_contacts']):.0f} / "
            f"{np.mean(st['obstacle_contacts']):.0f} | {int(st['obstacle_intersections'].max())} "
            f"({cross_left}) | {int(st['intersections'].max() - st['obstacle_intersections'].max())} "
            f"({self_left}; {len(start)} in the input) | {wall:.1f} s |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=30)
    ap.add_argument("--data", type=Path, required=True, help="folder holding the garment meshes")
    ap.add_argument("--garment", default="dress_on_body", choices=["dress_on_body", "multilayer_skirt_on_body"])
    args = ap.parse_args()
    print("| scene | cloth / obstacle triangles | steps | ms/step | solve | self-collision | obstacle collision "
          "| response | contacts/step (self / obstacle) | cloth-obstacle intersections left, max (last frame, exact) "
          "| cloth self-intersections left, max (last frame, exact; at the start) | wall |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for label, sim in (garment_on_body(args.data, args.garment), square_on_sphere()):
        print(bench(label, sim, args.steps), flush=True)


if __name__ == "__main__":
    main()
