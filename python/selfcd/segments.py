"""Where two intersecting triangles cross: the segment, in floating point, for drawing.

The engine decides *whether* two triangles intersect, exactly. This module
only draws *where*: for a non-coplanar pair the intersection of the two closed
triangles is a segment (possibly a point) on the line where their planes meet.
Each triangle's part on the other's plane is an interval of that line; the
intersection is the overlap of the two intervals. Coplanar or degenerate pairs
have no line: they get no segment (their triangles are still highlighted).
"""

from __future__ import annotations

import numpy as np


def _plane_crossing(tri: np.ndarray, normal: np.ndarray, offset: float) -> np.ndarray | None:
    """Points of triangle `tri` (3, 3) on the plane {x: normal . x = offset}: (2, 3) or None.

    The part of a triangle on a plane it crosses is a segment from one edge
    crossing (or vertex on the plane) to another.
    """
    dist = tri @ normal - offset
    scale = np.abs(tri @ normal).max() + abs(offset)
    dist[np.abs(dist) <= 1e-12 * max(scale, 1e-300)] = 0.0
    pts = [tri[k] for k in range(3) if dist[k] == 0.0]
    for a, b in ((0, 1), (1, 2), (2, 0)):
        if dist[a] * dist[b] < 0.0:
            t = dist[a] / (dist[a] - dist[b])
            pts.append(tri[a] + t * (tri[b] - tri[a]))
    if not pts:
        return None
    p = np.asarray(pts)
    return np.stack([p[0], p[-1]]) if len(p) <= 2 else _extremes(p)


def _extremes(p: np.ndarray) -> np.ndarray:
    """The two points of a collinear set `p` (k, 3) farthest apart."""
    d = p[np.argmax(np.linalg.norm(p - p[0], axis=1))]
    t = (p - p[0]) @ (d - p[0])
    return np.stack([p[np.argmin(t)], p[np.argmax(t)]])


def segment(t1: np.ndarray, t2: np.ndarray) -> np.ndarray | None:
    """The segment (2, 3) where triangles t1 and t2 (each (3, 3)) meet, or None.

    None for coplanar or degenerate triangles and for pairs that do not meet
    in floating point (the engine's exact answer may still say they touch).
    """
    n1 = np.cross(t1[1] - t1[0], t1[2] - t1[0])
    n2 = np.cross(t2[1] - t2[0], t2[2] - t2[0])
    line = np.cross(n1, n2)
    if not np.linalg.norm(line) > 1e-12 * np.linalg.norm(n1) * np.linalg.norm(n2):
        return None
    s1 = _plane_crossing(t1, n2, float(n2 @ t2[0]))
    s2 = _plane_crossing(t2, n1, float(n1 @ t1[0]))
    if s1 is None or s2 is None:
        return None
    s1 = s1[np.argsort(s1 @ line)]
    s2 = s2[np.argsort(s2 @ line)]
    lo = s1[0] if s1[0] @ line >= s2[0] @ line else s2[0]
    hi = s1[1] if s1[1] @ line <= s2[1] @ line else s2[1]
    if lo @ line > hi @ line:
        return None
    return np.stack([lo, hi])


def segments(positions: np.ndarray, faces: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """Intersection segments of face `pairs` (k, 2): (k, 2, 3), NaN rows where there is none."""
    out = np.full((len(pairs), 2, 3), np.nan)
    tris = positions[faces]
    for row, (a, b) in enumerate(np.asarray(pairs, dtype=np.int64)):
        s = segment(tris[a], tris[b])
        if s is not None:
            out[row] = s
    return out
