"""Reading meshes and animations: OBJ, PLY and the other formats trimesh reads,
.npz archives holding arrays V (vertices, (n,3) or (frames,n,3)) and F (faces),
and USD (a mesh prim with time-sampled points is an animation; see `selfcd.usd`)."""

from __future__ import annotations

import os
import stat
import zipfile
from pathlib import Path

import numpy as np

from .usd import USD_SUFFIXES, UsdError


class MeshFileError(ValueError):
    """A mesh file could not be read or does not fit the others in a sequence."""


def _load_npz(path: Path) -> tuple[np.ndarray, np.ndarray]:
    try:
        with np.load(path) as data:
            for v_key, f_key in (("V", "F"), ("vertices", "faces")):
                if v_key in data and f_key in data:
                    return np.asarray(data[v_key]), np.asarray(data[f_key])
            names = sorted(data.files)
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise MeshFileError(f"{path}: not a valid .npz archive ({exc})") from None
    raise MeshFileError(f"{path}: .npz needs arrays V and F (or vertices and faces), has {names}")


_TEXT_FORMATS = {".obj": "OBJ", ".off": "OFF"}


def _check_stl(path: Path, data: bytes) -> None:
    """Raises unless `data` is a binary STL (sized as its header says) or UTF-8 text."""
    if len(data) >= 84:
        count = int.from_bytes(data[80:84], "little")
        if len(data) == 84 + 50 * count:
            return
    try:
        data.decode("utf-8")
    except UnicodeDecodeError:
        raise MeshFileError(f"{path}: not an STL file: neither a binary STL ({len(data)} bytes, not 84 + 50 x "
                            "the triangle count in its header) nor ASCII STL text") from None


def _check_bytes(path: Path) -> None:
    """Clear errors for files trimesh would misread: binary data in a text format, a broken STL."""
    data = path.read_bytes()
    suffix = path.suffix.lower()
    if suffix == ".stl":
        _check_stl(path, data)
    elif suffix in _TEXT_FORMATS:
        try:
            data.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise MeshFileError(f"{path}: not a valid {_TEXT_FORMATS[suffix]} file (binary data, not UTF-8 text "
                                f"at byte {exc.start})") from None


def _load_trimesh(path: Path) -> tuple[np.ndarray, np.ndarray]:
    import trimesh  # imported lazily: it is only needed for mesh files

    _check_bytes(path)
    kwargs = {"maintain_order": True} if path.suffix.lower() == ".obj" else {}
    kind = path.suffix.lstrip(".").upper() or "mesh"
    try:
        mesh = trimesh.load(path, process=False, force="mesh", **kwargs)
    except Exception as exc:  # trimesh raises many types for unreadable files
        raise MeshFileError(f"{path}: not a readable {kind} file ({type(exc).__name__}: {exc})") from None
    if not hasattr(mesh, "faces") or len(mesh.faces) == 0:
        raise MeshFileError(f"{path}: no triangles found (not a valid {kind} file?)")
    return np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64)


def _check_path(path: Path) -> None:
    """Raises MeshFileError unless `path` is a regular file we can open."""
    try:
        st = path.stat()
    except FileNotFoundError:
        raise MeshFileError(f"{path}: no such file") from None
    except OSError as exc:
        raise MeshFileError(f"{path}: cannot access: {exc.strerror}") from None
    if stat.S_ISDIR(st.st_mode):
        raise MeshFileError(f"{path}: is a directory, not a mesh file")
    if not stat.S_ISREG(st.st_mode):
        raise MeshFileError(f"{path}: not a regular file (a FIFO, device or socket); save the mesh to a file")
    if not os.access(path, os.R_OK):
        raise MeshFileError(f"{path}: permission denied")
    if st.st_size == 0:
        raise MeshFileError(f"{path}: the file is empty")


def weld_by_default(paths: list[str | Path]) -> bool:
    """Whether to weld a mesh read from `paths` unless told: yes for STL, a triangle soup by format."""
    return any(Path(p).suffix.lower() == ".stl" for p in paths)


def load_mesh(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (n,3), faces (m,3)) of one file; raises MeshFileError."""
    path = Path(path)
    _check_path(path)
    if path.suffix.lower() == ".npz":
        return _load_npz(path)
    if path.suffix.lower() in USD_SUFFIXES:
        return _load_usd(path)
    return _load_trimesh(path)


def _load_usd(path: Path) -> tuple[np.ndarray, np.ndarray]:
    from .usd import read_usd

    try:
        return read_usd(path)
    except UsdError as exc:
        raise MeshFileError(str(exc)) from None


def load_sequence(paths: list[str | Path]) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """An animation from files sharing faces: (frames (f,n,3), faces (m,3), frame labels).

    A .npz whose V has shape (f,n,3) (as `selfcd simulate` writes) is f frames,
    labelled "file[k]". Raises MeshFileError when a file's faces or vertex
    count differ from the first file's.
    """
    frames: list[np.ndarray] = []
    labels: list[str] = []
    faces = None
    for p in paths:
        v, f = load_mesh(p)
        if faces is None:
            faces = f
        elif f.shape != faces.shape or not np.array_equal(f, faces):
            raise MeshFileError(f"{p}: faces differ from {paths[0]}; a sequence must share its faces")
        many = v.ndim == 3
        for k, frame in enumerate(v if many else [v]):
            if frames and frame.shape != frames[0].shape:
                raise MeshFileError(f"{p}: {len(frame)} vertices, but {paths[0]} has {len(frames[0])}")
            frames.append(frame)
            labels.append(f"{p}[{k}]" if many else str(p))
    if faces is None:
        raise MeshFileError("no files given")
    return np.stack(frames), faces, labels


def save_obj(path: str | Path, vertices: np.ndarray, faces: np.ndarray) -> None:
    """Writes a plain OBJ file (1-based indices), for tests and examples."""
    lines = [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in np.asarray(vertices, dtype=np.float64)]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in np.asarray(faces, dtype=np.int64)]
    Path(path).write_text("\n".join(lines) + "\n")


#: Up axis by file suffix: glTF is Y-up by its specification and OBJ, PLY and
#: OFF exports from DCC tools are Y-up by convention; STL comes from CAD (Z-up);
#: .npz is what `selfcd simulate` writes (Z-up). USD files state their own.
UP_BY_SUFFIX = {".obj": "y", ".ply": "y", ".off": "y", ".glb": "y", ".gltf": "y", ".stl": "z", ".npz": "z"}


def up_axis(path: str | Path) -> str:
    """The up axis ("x", "y" or "z") a file's positions are meant to be viewed with."""
    path = Path(path)
    if path.is_dir():
        return "z"
    if path.suffix.lower() in USD_SUFFIXES:
        from .usd import stage_up_axis

        return stage_up_axis(path)
    return UP_BY_SUFFIX.get(path.suffix.lower(), "y")
