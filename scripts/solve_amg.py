"""How many conjugate-gradient iterations the cloth's implicit system needs
under algebraic multigrid preconditioners from pyamg, against selfcd's own.

    DUMP=/tmp/sys.bin target/release/examples/cloth_solve center 101 150 3 all
    python3 scripts/solve_amg.py /tmp/sys.bin

`cloth_solve` prints selfcd's iterations (block Jacobi, its V-cycle and its
two-level form) on the system it writes; this script solves the same system
with the same stopping rule (the preconditioned residual norm down by
`--tolerance` against that of the filtered right-hand side, from the same warm
start) and the pinned rows removed, as the filter does. The pyamg
preconditioners are one V(1,1) cycle of smoothed aggregation (damped block
Jacobi smoothing), with a near-null space of the three translations, or of the
translations and the three rotations about the cloth's centroid (the rigid
motions: a spring network's energy does not change under them), with the
tentative prolongation unsmoothed (plain aggregation), Jacobi-smoothed, or
energy-minimised. pyamg is a benchmark extra, never needed at run time
(`pip install pyamg`).
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import scipy.sparse as sp

Vector = np.ndarray
Apply = Callable[[Vector], Vector]


def load(path: str) -> dict[str, Any]:
    """The system `cloth_solve` wrote (its module doc gives the layout)."""
    raw = np.fromfile(path, dtype="<f8")
    n, m = int(raw[0]), int(raw[1])
    sizes = {"diag": 9 * n, "links": 11 * m, "b": 3 * n, "start": 3 * n, "x": 3 * n, "pinned": n}
    if raw.size != 2 + sum(sizes.values()):
        raise SystemExit(f"{path}: {raw.size} values, not a system of {n} rows and {m} links")
    parts, at = {}, 2
    for name, size in sizes.items():
        parts[name] = raw[at:at + size]
        at += size
    links = parts["links"].reshape(m, 11)
    ends = links[:, :2].astype(np.int64)
    rows = np.concatenate([np.arange(n), ends[:, 0], ends[:, 1]])
    cols = np.concatenate([np.arange(n), ends[:, 1], ends[:, 0]])
    blocks = np.concatenate([parts["diag"].reshape(n, 3, 3), -links[:, 2:].reshape(m, 3, 3),
                             -links[:, 2:].reshape(m, 3, 3)])
    i = (3 * rows[:, None, None] + np.arange(3)[None, :, None]).repeat(3, 2)
    j = (3 * cols[:, None, None] + np.arange(3)[None, None, :]).repeat(3, 1)
    a = sp.csr_matrix((blocks.ravel(), (i.ravel(), j.ravel())), shape=(3 * n, 3 * n))
    free = parts["pinned"] < 0.5
    keep = np.repeat(free, 3)
    return {"a": a[keep][:, keep].tocsr(), "b": parts["b"][keep], "start": parts["start"][keep],
            "x": parts["x"].reshape(n, 3)[free], "diag": parts["diag"].reshape(n, 3, 3)[free],
            "rows": n, "pinned": int(n - free.sum())}


def pcg(a: sp.csr_matrix, b: Vector, start: Vector, precondition: Apply, tolerance: float,
        most: int = 1000) -> int:
    """Iterations of selfcd's rule: stop when r.P^-1 r <= tol^2 (b.P^-1 b)."""
    x = start.copy()
    r = b - a @ x
    z = precondition(r)
    reference = b @ precondition(b)
    delta = r @ z
    c = z.copy()
    it = 0
    while it < most and delta > tolerance * tolerance * reference:
        q = a @ c
        alpha = delta / (c @ q)
        x += alpha * c
        r -= alpha * q
        z = precondition(r)
        delta, last = r @ z, delta
        c = z + (delta / last) * c
        it += 1
    return it


def near_null_space(x: np.ndarray, rotations: bool) -> np.ndarray:
    """Translations, and with `rotations` the rigid rotations about the centroid."""
    k = len(x)
    t = np.kron(np.ones((k, 1)), np.eye(3))
    if not rotations:
        return t
    p = x - x.mean(axis=0)
    r = np.stack([np.cross(np.eye(3)[axis], p) for axis in range(3)], axis=2)
    return np.concatenate([t, r.reshape(3 * k, 3)], axis=1)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("system", help="a file written by cloth_solve with DUMP=FILE")
    ap.add_argument("--tolerance", type=float, default=1e-3)
    args = ap.parse_args()
    try:
        import pyamg  # type: ignore[import-untyped]
    except ImportError as e:
        raise SystemExit("needs pyamg (a benchmark extra): pip install pyamg") from e
    s = load(args.system)
    a, b, start = s["a"], s["b"], s["start"]
    print(f"{s['rows']} rows, {s['pinned']} pinned, tolerance {args.tolerance}")
    jacobi = sp.block_diag([np.linalg.inv(d) for d in s["diag"]]).tocsr()
    print(f"block Jacobi: {pcg(a, b, start, lambda r: jacobi @ r, args.tolerance)} iterations")
    smoother = ("block_jacobi", {"omega": 2.0 / 3.0, "iterations": 1})
    for rotations in (False, True):
        nulls = near_null_space(s["x"], rotations)
        for name, smooth in (("plain aggregation", None), ("smoothed (Jacobi)", ("jacobi", {"omega": 4.0 / 3.0})),
                             ("smoothed (energy)", "energy")):
            t0 = time.perf_counter()
            ml = pyamg.smoothed_aggregation_solver(a, B=nulls, symmetry="symmetric", smooth=smooth, max_coarse=100,
                                                   presmoother=smoother, postsmoother=smoother)
            setup = time.perf_counter() - t0
            m = ml.aspreconditioner(cycle="V")
            its = pcg(a, b, start, lambda r, m=m: m @ r, args.tolerance)
            sizes = [lv.A.shape[0] // 3 for lv in ml.levels]
            space = "translations + rotations" if rotations else "translations"
            print(f"pyamg {name}, {space}: {its} iterations; levels {sizes}, "
                  f"operator complexity {ml.operator_complexity():.2f}, setup {setup:.2f} s")


if __name__ == "__main__":
    main()
