"""Welding: merging vertices at exactly equal positions, so that a triangle soup
(STL, or any export that splits vertices) becomes a mesh whose neighbours share
vertices. Without it, two neighbours meet only at equal coordinates, and the
exact test counts them as intersecting.

Exact means bitwise-equal coordinates after -0.0 is read as 0.0: no tolerance,
so nothing that is apart in the file is merged.
"""

from __future__ import annotations

import warnings

import numpy as np

from . import _core


class UnweldedMeshWarning(UserWarning):
    """A mesh has distinct vertices at the same position: neighbours there count as intersecting."""


def _groups(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(representative, group): each vertex's group id, numbered in first-occurrence order,
    and the first vertex of each group."""
    group, first = _core.position_groups(np.ascontiguousarray(vertices, dtype=np.float64))
    return first, group


def weld(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Merges vertices at exactly equal positions.

    Faces keep their order (face i of the result is face i of the input). A
    face whose corners merge (a zero-area face with coincident corners) keeps
    a copy of the vertex for each repeated corner, so its three indices stay
    distinct: the engine counts it as the segment or point it is.

    Args:
        vertices: (n, 3) float array.
        faces: (m, 3) integer array, indices in range.

    Returns:
        (welded vertices (k, 3), welded faces (m, 3) int64, source (k,) int64):
        welded vertex j is input vertex source[j], so positions of the input's
        vertices map to the welded mesh as positions[source].
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    return _welded(vertices, np.asarray(faces, dtype=np.int64), *_groups(vertices))


def _welded(vertices: np.ndarray, faces: np.ndarray, source: np.ndarray,
            group: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`weld` from the position groups `_groups` gave."""
    new_faces = group[faces]
    extra: list[int] = []
    for t in np.flatnonzero((new_faces[:, 0] == new_faces[:, 1]) | (new_faces[:, 1] == new_faces[:, 2])
                            | (new_faces[:, 0] == new_faces[:, 2])):
        for k in (1, 2):
            if new_faces[t, k] in new_faces[t, :k]:
                new_faces[t, k] = len(source) + len(extra)
                extra.append(int(faces[t, k]))
    source = np.concatenate([source, np.asarray(extra, dtype=np.int64)])
    return vertices[source], new_faces, source


def warn_if_unwelded(vertices: np.ndarray, faces: np.ndarray, stacklevel: int = 3) -> None:
    """Warns (UnweldedMeshWarning) when welding would merge vertices: distinct vertices of
    different faces share a position. Corners of one zero-area face may coincide."""
    faces = np.asarray(faces)
    if len(vertices) == 0 or faces.size == 0 or faces.min() < 0 or faces.max() >= len(vertices):
        return  # nothing to weld, or bad indices for the engine to name
    first, group = _groups(vertices)
    if len(first) == len(vertices):
        return  # every position distinct (the common case): nothing to weld
    welded = _welded(np.asarray(vertices, dtype=np.float64), np.asarray(faces, dtype=np.int64), first, group)
    shared = len(vertices) - len(welded[2])
    if shared > 0:
        warnings.warn(
            f"{shared} of {len(vertices)} vertices repeat another vertex's position: faces meeting there "
            "count as intersecting. If the mesh is a triangle soup (e.g. STL), weld it: weld=True "
            "(selfcd detect --weld).",
            UnweldedMeshWarning,
            stacklevel=stacklevel,
        )
