"""Input checks shared by the public API: whole-array numpy work only.

Each function turns array-likes into the contiguous dtype the engine takes, or
raises TypeError (wrong kind of data) / ValueError (wrong shape or values)
with a message naming the argument and the problem.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

_INT64_MAX = np.iinfo(np.int64).max


def _as_array(value: npt.ArrayLike, name: str) -> np.ndarray:
    """`value` as an ndarray; non-numeric data raises TypeError."""
    try:
        arr = np.asarray(value)
    except (ValueError, TypeError) as exc:  # ragged lists and the like
        raise ValueError(f"{name} is not a rectangular array: {exc}") from None
    if arr.dtype.kind not in "fiu":
        raise TypeError(f"{name} must be a numeric array, got dtype {arr.dtype}")
    return arr


def _check_n3(arr: np.ndarray, name: str, rows: str) -> None:
    """Raises ValueError unless `arr` is 2-d with 3 columns."""
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name} must have shape ({rows}, 3), got {arr.shape}")


def coordinates(value: npt.ArrayLike, name: str = "positions", n: int | None = None) -> np.ndarray:
    """An (n,3) float64 array of coordinates in C or Fortran order (the
    engine reads both in one pass, so a transposed array is not copied here);
    any other layout or dtype is copied to C order.

    Non-finite values are left for the engine, which names the vertex.
    """
    arr = _as_array(value, name)
    _check_n3(arr, name, "n")
    if n is not None and arr.shape[0] != n:
        raise ValueError(f"{name} has {arr.shape[0]} vertices, the mesh has {n}")
    if arr.dtype == np.float64 and (arr.flags.c_contiguous or arr.flags.f_contiguous):
        return arr
    return np.ascontiguousarray(arr, dtype=np.float64)


def points(value: npt.ArrayLike, name: str = "vertices", n: int | None = None) -> np.ndarray:
    """An (n,3) float64 C-contiguous array of coordinates (see `coordinates`)."""
    return np.ascontiguousarray(coordinates(value, name, n))


def faces(value: npt.ArrayLike, name: str = "faces") -> np.ndarray:
    """An (m,3) int64 C-contiguous array of vertex indices."""
    arr = _as_array(value, name)
    if arr.dtype.kind == "f":
        raise TypeError(f"{name} must be an integer array, got dtype {arr.dtype}")
    _check_n3(arr, name, "m")
    if arr.dtype.kind == "u" and arr.size and int(arr.max()) > _INT64_MAX:
        raise ValueError(f"{name} has vertex index {int(arr.max())}, too large for any mesh")
    return np.ascontiguousarray(arr, dtype=np.int64)


def frames(value: npt.ArrayLike, n: int, name: str = "frames") -> np.ndarray:
    """An (f,n,3) float64 C-contiguous array of positions over time."""
    arr = _as_array(value, name)
    if arr.ndim != 3 or arr.shape[1:] != (n, 3):
        raise ValueError(f"{name} must have shape (frames, {n}, 3), got {arr.shape}")
    return np.ascontiguousarray(arr, dtype=np.float64)


def face_ids(value: npt.ArrayLike, n_faces: int, name: str = "subset") -> np.ndarray:
    """Face ids as a sorted, duplicate-free int64 array, each in [0, n_faces)."""
    arr = np.asarray(value)
    if arr.dtype == bool or not (arr.size == 0 or arr.dtype.kind in "iu"):
        raise TypeError(f"{name} must be an integer array of face ids, got dtype {arr.dtype}")
    if arr.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {arr.shape}")
    ids = np.unique(arr.astype(np.int64))
    if ids.size and (ids[0] < 0 or ids[-1] >= n_faces):
        bad = ids[0] if ids[0] < 0 else ids[-1]
        raise ValueError(f"{name} has face id {bad}, outside 0..{n_faces - 1}")
    return ids


def number(value: object, name: str) -> float:
    """A real number (int, float or numpy scalar, not bool or str) as float; TypeError otherwise.

    Ranges are checked by the engine, which names the parameter.
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a number, got {type(value).__name__} {value!r}")
    return float(value)


def integer(value: object, name: str) -> int:
    """An integer (int or numpy integer, not bool); TypeError otherwise."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__} {value!r}")
    return int(value)


def limit(value: object, name: str) -> int | None:
    """None, or a count limit (an integer >= 0): TypeError or ValueError otherwise."""
    if value is None:
        return None
    n = integer(value, name)
    if n < 0:
        raise ValueError(f"{name} must be >= 0, got {n}")
    return n


def flag(value: object, name: str) -> bool:
    """A bool (Python or numpy); TypeError otherwise, so that "no" is not read as True."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, got {type(value).__name__} {value!r}")
    return bool(value)
