"""Writes an OBJ of separate wavy square sheets stacked a little apart: the case the
one-shot query's split by pieces is for (layers that certify on their own, with
only their pairs descended). A benchmark input for `prof` (BENCHMARKS.md,
twenty-third landing), not test data.

    python3 scripts/stacked_sheets.py OUT.obj [--layers 2] [--side 224] [--gap 0.5]

Each sheet is a `side` x `side` vertex grid over the unit square, z = 0.06 sin(2 pi x)
(the wave of the topdown module's layered test), lifted by `gap` edge lengths per
layer. Sheets share no vertex, so the mesh has one piece per layer; no two
triangles intersect. Written with `selfcd.io.save_obj` (the selfcd package
installed).
"""

from __future__ import annotations

import argparse

import numpy as np

from selfcd.io import save_obj


def stacked_sheets(layers: int, side: int, gap: float) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (layers side^2, 3), faces (layers 2 (side-1)^2, 3)) of the stacked sheets."""
    xs = np.linspace(0.0, 1.0, side)
    x, y = np.meshgrid(xs, xs, indexing="ij")
    edge = 1.0 / (side - 1)
    i, j = np.meshgrid(np.arange(side - 1), np.arange(side - 1), indexing="ij")
    a = (i * side + j).ravel()
    b, c, d = a + side, a + 1, a + side + 1
    grid = np.concatenate([np.stack([a, b, c], 1), np.stack([c, b, d], 1)])
    verts, faces = [], []
    for layer in range(layers):
        z = 0.06 * np.sin(2.0 * np.pi * x) + layer * gap * edge
        verts.append(np.stack([x.ravel(), y.ravel(), z.ravel()], 1))
        faces.append(grid + layer * side * side)
    return np.concatenate(verts), np.concatenate(faces)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", help="OBJ file to write")
    ap.add_argument("--layers", type=int, default=2, help="number of sheets (default 2)")
    ap.add_argument("--side", type=int, default=224, help="vertices per side of each sheet (default 224)")
    ap.add_argument("--gap", type=float, default=0.5, help="spacing of the sheets in edge lengths (default 0.5)")
    args = ap.parse_args()
    if args.layers < 1 or args.side < 2 or not args.gap > 0.0:
        ap.error("need --layers >= 1, --side >= 2 and --gap > 0")
    v, f = stacked_sheets(args.layers, args.side, args.gap)
    save_obj(args.out, v, f)
    print(f"{args.out}: {len(v)} vertices, {len(f)} triangles in {args.layers} sheets")


if __name__ == "__main__":
    main()
