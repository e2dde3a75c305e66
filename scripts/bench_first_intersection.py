"""selfcd.first_intersection (early exit) against selfcd.self_intersections (every pair)
on the real meshes of a data folder: median of 5 calls each, in one process.

    python scripts/bench_first_intersection.py DATA_DIR   (the folder of the shared real meshes)
"""
import sys
import time
from pathlib import Path

import numpy as np

import selfcd
from selfcd import io

if len(sys.argv) != 2:
    sys.exit(__doc__)
DATA = Path(sys.argv[1])
for name in ("dress_on_body", "multilayer_skirt_on_body", "body", "skirt_32k"):
    V, F = io.load_mesh(DATA / f"{name}.obj")

    def med(f):
        ts, r = [], None
        for _ in range(5):
            t = time.perf_counter()
            r = f()
            ts.append(time.perf_counter() - t)
        return float(np.median(ts)), r

    tf, first = med(lambda V=V, F=F: selfcd.first_intersection(V, F))
    ta, allp = med(lambda V=V, F=F: selfcd.self_intersections(V, F))
    assert (first is None) == (len(allp) == 0)
    print(f"{name:<26} pairs {len(allp):>5}  first {tf * 1e3:8.1f} ms  all {ta * 1e3:8.1f} ms  "
          f"all/first {ta / tf:5.2f}  first={first}")
