"""How many of selfcd's proximity contacts are distinct closest-feature pairs,
against ipctk's NormalCollisions on the same input.

    python3 scripts/proximity_features.py ../shared/data/dress_on_body.obj [--edges 0.6]

selfcd reports every vertex-triangle and edge-edge pair closer than d
(`selfcd.proximity_contacts`). ipctk classifies each candidate by its closest
features and keeps one collision per feature pair: vertex-vertex, edge-vertex,
edge-edge, face-vertex. This script classifies selfcd's own answer the same
way, by the weights that are exactly 0 (a vertex-triangle contact's
barycentrics) or the parameters exactly 0 or 1 (an edge-edge contact's), counts
the distinct feature pairs of each kind, and prints ipctk's counts beside them
(ipctk is a benchmark extra, optional here). d is `--edges` times the median
edge length, at the mesh's stored positions.
"""

from __future__ import annotations

import argparse

import numpy as np

import selfcd
from selfcd import io as mesh_io

VV, VE, EE, VF = range(4)


def feature_keys(contacts: dict[str, np.ndarray], faces: np.ndarray) -> np.ndarray:
    """One row (kind, ids...) per contact, naming its closest features (ids
    sorted within a feature, -1 padding), so that equal rows are one collision."""
    vt, w = contacts["vertex_triangle"], contacts["vertex_triangle_bary"]
    corners = faces[vt[:, 1]]
    nonzero = w != 0.0
    count = nonzero.sum(axis=1)
    # A triangle's kept corners, in order, padded with -1 (then sorted: -1 first).
    kept = np.sort(np.where(nonzero, corners, -1), axis=1)
    p = vt[:, 0]
    keys_vt = np.full((len(vt), 5), -1, dtype=np.int64)
    keys_vt[:, 0] = np.select([count == 3, count == 2], [VF, VE], VV)
    keys_vt[:, 1] = p
    face = count == 3
    keys_vt[face, 2] = vt[face, 1]
    edge = count == 2
    keys_vt[edge, 2:4] = kept[edge, 1:3]
    point = count == 1
    pair = np.sort(np.stack([p[point], kept[point, 2]], axis=1), axis=1)
    keys_vt[point, 1:3] = pair

    ev, st = contacts["edge_edge_vertices"], contacts["edge_edge_params"]

    def side(a: np.ndarray, b: np.ndarray, s: np.ndarray) -> np.ndarray:
        """The feature of each edge a-b at parameter s: (v, -1) at an end, else (min, max)."""
        out = np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1)
        out[s == 0.0] = np.stack([a[s == 0.0], np.full((s == 0.0).sum(), -1)], axis=1)
        out[s == 1.0] = np.stack([b[s == 1.0], np.full((s == 1.0).sum(), -1)], axis=1)
        return out

    fa = side(ev[:, 0], ev[:, 1], st[:, 0])
    fb = side(ev[:, 2], ev[:, 3], st[:, 1])
    is_edge_a, is_edge_b = fa[:, 1] >= 0, fb[:, 1] >= 0
    keys_ee = np.full((len(ev), 5), -1, dtype=np.int64)
    both = is_edge_a & is_edge_b
    lo = np.where((fa[:, 0] < fb[:, 0])[:, None], fa, fb)
    hi = np.where((fa[:, 0] < fb[:, 0])[:, None], fb, fa)
    keys_ee[both, 0] = EE
    keys_ee[both, 1:3], keys_ee[both, 3:5] = lo[both], hi[both]
    points = ~is_edge_a & ~is_edge_b
    keys_ee[points, 0] = VV
    keys_ee[points, 1:3] = np.sort(np.stack([fa[points, 0], fb[points, 0]], axis=1), axis=1)
    mixed = is_edge_a != is_edge_b
    point_of = np.where(is_edge_a[:, None], fb, fa)
    edge_of = np.where(is_edge_a[:, None], fa, fb)
    keys_ee[mixed, 0] = VE
    keys_ee[mixed, 1] = point_of[mixed, 0]
    keys_ee[mixed, 2:4] = edge_of[mixed]
    return np.concatenate([keys_vt, keys_ee])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("mesh", help="a mesh file selfcd.io reads")
    ap.add_argument("--edges", type=float, default=0.6, help="d in median edge lengths (default 0.6)")
    args = ap.parse_args()
    v, f = mesh_io.load_mesh(args.mesh)
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    d = args.edges * float(np.median(np.linalg.norm(v[e[:, 0]] - v[e[:, 1]], axis=1)))
    mesh = selfcd.Mesh(v, f)
    found = selfcd.proximity_contacts(mesh, v, d)
    keys = np.unique(feature_keys(found, np.asarray(f, dtype=np.int64)), axis=0)
    kinds = np.bincount(keys[:, 0], minlength=4)
    total = len(found["vertex_triangle"]) + len(found["edge_edge"])
    print(f"{args.mesh}: d {d:.6g}; selfcd {len(found['vertex_triangle'])} VT + {len(found['edge_edge'])} EE = "
          f"{total}; distinct feature pairs {len(keys)} (vv {kinds[VV]}, ev {kinds[VE]}, ee {kinds[EE]}, "
          f"fv {kinds[VF]}): {total / max(len(keys), 1):.2f} contacts each")
    try:
        import ipctk  # type: ignore[import-untyped]
    except ImportError:
        print("ipctk not installed (pip install ipctk): no comparison")
        return
    cm = ipctk.CollisionMesh(v, np.asarray(mesh.edges).astype(np.int32), f.astype(np.int32))
    nc = ipctk.NormalCollisions()
    nc.build(cm, v, d, broad_phase=ipctk.LBVH())
    print(f"ipctk NormalCollisions {len(nc)} (vv {len(nc.vv_collisions)}, ev {len(nc.ev_collisions)}, "
          f"ee {len(nc.ee_collisions)}, fv {len(nc.fv_collisions)})")


if __name__ == "__main__":
    main()
