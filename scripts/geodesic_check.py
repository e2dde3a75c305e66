"""Compares the sensor's geodesic distances (fast marching, `sensor::geodesic`)
with exact polyhedral geodesics: potpourri3d's edge-flip solver (FlipOut)
shortens the edge path between two vertices to a geodesic, whose length is
the reference. Benchmark extra: ``pip install .[bench]`` (or ``pip install potpourri3d``).

    cargo run --release -p selfcd --example sensor_geodesic -- MESH.obj 8 12 > d.csv
    python scripts/geodesic_check.py MESH.obj d.csv [PAIRS_PER_SOURCE]

Prints, per distance band (mean edges), the number of pairs and the median
and extreme relative errors (march - exact) / exact.
"""

import sys

import numpy as np
import potpourri3d as pp3d


def read_obj(path):
    v, f = [], []
    with open(path) as fh:
        for line in fh:
            w = line.split()
            if not w:
                continue
            if w[0] == "v":
                v.append([float(x) for x in w[1:4]])
            elif w[0] == "f":
                idx = [int(x.split("/")[0]) - 1 for x in w[1:]]
                f.extend([idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1))
    return np.array(v), np.array(f)


def main():
    mesh, csv = sys.argv[1], sys.argv[2]
    per_source = int(sys.argv[3]) if len(sys.argv) > 3 else 40
    v, f = read_obj(mesh)
    unit, rows = None, {}
    with open(csv) as fh:
        for line in fh:
            if line.startswith("# unit"):
                unit = float(line.split()[2])
            elif line[0].isdigit():
                s, t, d = line.split(",")
                rows.setdefault(int(s), []).append((int(t), float(d)))
    rng = np.random.default_rng(1)
    solver = pp3d.EdgeFlipGeodesicSolver(v, f)
    bands = [(0, 2), (2, 4), (4, 8), (8, 12), (12, 1e9)]
    errors = {b: [] for b in bands}
    for s, targets in sorted(rows.items()):
        far = [t for t in targets if t[1] >= 2.0]
        for i in rng.choice(len(far), size=min(per_source, len(far)), replace=False):
            t, d = far[i]
            path = solver.find_geodesic_path(s, t)
            exact = np.linalg.norm(np.diff(path, axis=0), axis=1).sum() / unit
            band = next(b for b in bands if b[0] <= exact < b[1])
            errors[band].append((d - exact) / exact)
    print("| exact distance (mean edges) | pairs | median relative error | most negative | most positive |")
    print("|---|---:|---:|---:|---:|")
    for b, e in errors.items():
        if e:
            e = np.array(e)
            hi = b[1] if b[1] < 1e9 else "inf"
            print(f"| {b[0]}-{hi} | {len(e)} | {np.median(e):+.4f} | {e.min():+.4f} | {e.max():+.4f} |")


if __name__ == "__main__":
    main()
