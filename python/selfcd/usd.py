"""USD meshes and animations (usd-core, imported lazily: `pip install "selfcd[usd]"`).

Reading: the first mesh prim of the stage (depth-first). Its points are the
positions; when they are time-sampled (more than one sample) the file is an
animation with one frame per time sample, in time order. Polygons are split
into triangle fans (faces with more than three corners), so face ids refer to
the triangulated mesh. Positions are the prim's own (local) coordinates: a
transform maps intersecting triangles to intersecting triangles, so the
answer does not depend on it.

Writing: frames -> one mesh prim with time-sampled points (time code k for
frame k, `fps` codes per second), no subdivision, metres, a stated up axis:
what Blender, Houdini and Omniverse open as an animated mesh. The format
follows the suffix: .usda (text), .usdc or .usd (binary crate).
"""

from __future__ import annotations

from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

#: Suffixes read and written as USD.
USD_SUFFIXES = (".usd", ".usda", ".usdc")


class UsdError(ValueError):
    """A USD file could not be read or written (missing usd-core, no mesh, bad data)."""


def _pxr() -> tuple[ModuleType, ModuleType, ModuleType]:
    try:
        from pxr import Usd, UsdGeom, Vt
    except ImportError:
        raise UsdError('USD needs usd-core: pip install "selfcd[usd]"') from None
    return Usd, UsdGeom, Vt


def _open(path: Path) -> Any:
    Usd, _, _ = _pxr()
    if not path.is_file():
        raise UsdError(f"{path}: no such file")
    try:
        stage = Usd.Stage.Open(str(path))
    except Exception as exc:  # pxr raises Tf.ErrorException and others for unreadable files
        raise UsdError(f"{path}: cannot read USD: {str(exc).strip().splitlines()[-1]}") from None
    if stage is None:
        raise UsdError(f"{path}: cannot read USD")
    return stage


def stage_up_axis(path: str | Path) -> str:
    """The stage's up axis, "y" or "z" (USD's two choices)."""
    _, UsdGeom, _ = _pxr()
    return str(UsdGeom.GetStageUpAxis(_open(Path(path)))).lower()


def triangulate(counts: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """Triangle fans of polygons given as USD's faceVertexCounts and faceVertexIndices: (m, 3) int64."""
    counts = np.asarray(counts, dtype=np.int64)
    indices = np.asarray(indices, dtype=np.int64)
    if (counts < 3).any() or counts.sum() != len(indices):
        raise UsdError("faceVertexCounts and faceVertexIndices do not describe polygons of 3 or more corners")
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    fan = np.repeat(starts, counts - 2)
    offset = np.arange(len(fan)) - np.repeat(np.cumsum(counts - 2) - (counts - 2), counts - 2)
    return np.stack([indices[fan], indices[fan + offset + 1], indices[fan + offset + 2]], axis=1)


def read_usd(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """(positions, faces) of the first mesh prim: positions (n, 3), or (f, n, 3) when its
    points are time-sampled; faces (m, 3) int64. Raises UsdError."""
    _, UsdGeom, _ = _pxr()
    path = Path(path)
    stage = _open(path)
    mesh = next((UsdGeom.Mesh(p) for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)), None)
    if mesh is None:
        raise UsdError(f"{path}: no mesh prim")
    name = mesh.GetPath()
    points = mesh.GetPointsAttr()
    times = points.GetTimeSamples()
    samples = [points.Get(t) for t in times] if times else [points.Get()]
    if any(s is None for s in samples):
        raise UsdError(f"{path}: mesh {name} has no points")
    frames = [np.asarray(s, dtype=np.float64).reshape(-1, 3) for s in samples]
    if len({len(f) for f in frames}) != 1:
        raise UsdError(f"{path}: mesh {name} changes its point count over time")
    counts, indices = mesh.GetFaceVertexCountsAttr().Get(), mesh.GetFaceVertexIndicesAttr().Get()
    if counts is None or indices is None or len(counts) == 0:
        raise UsdError(f"{path}: mesh {name} has no faces")
    try:
        faces = triangulate(np.asarray(counts), np.asarray(indices))
    except UsdError as exc:
        raise UsdError(f"{path}: mesh {name}: {exc}") from None
    return (np.stack(frames) if len(frames) > 1 else frames[0]), faces


class UsdWriter:
    """Writes frames of one mesh as time-sampled points, one frame at a time.

    `save()` may be called after any frame (a long run that is interrupted then
    keeps what it wrote); the file is complete after each save.

    Args:
        path: .usd, .usda or .usdc file to create (replaced if it exists).
        faces: (m, 3) vertex indices.
        fps: time codes per second; frame k is at time code k.
        up: the stage's up axis, "y" or "z".
    """

    def __init__(self, path: str | Path, faces: np.ndarray, fps: float = 24.0, up: str = "z") -> None:
        Usd, UsdGeom, Vt = _pxr()
        self.path = Path(path)
        if self.path.suffix.lower() not in USD_SUFFIXES:
            raise UsdError(f"{self.path}: a USD file name ends in {', '.join(USD_SUFFIXES)}")
        if up not in ("y", "z"):
            raise UsdError(f"up must be 'y' or 'z' (USD's choices), got {up!r}")
        if not fps > 0:
            raise UsdError(f"fps must be > 0, got {fps}")
        faces = np.asarray(faces, dtype=np.int64)
        try:
            self._stage = Usd.Stage.CreateNew(str(self.path))
        except Exception as exc:
            raise UsdError(f"{self.path}: cannot create: {str(exc).strip().splitlines()[-1]}") from None
        UsdGeom.SetStageUpAxis(self._stage, UsdGeom.Tokens.y if up == "y" else UsdGeom.Tokens.z)
        UsdGeom.SetStageMetersPerUnit(self._stage, 1.0)
        self._stage.SetTimeCodesPerSecond(fps)
        self._stage.SetFramesPerSecond(fps)
        root = UsdGeom.Xform.Define(self._stage, "/selfcd")
        self._stage.SetDefaultPrim(root.GetPrim())
        self._mesh = UsdGeom.Mesh.Define(self._stage, "/selfcd/mesh")
        self._mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        self._mesh.CreateFaceVertexCountsAttr(Vt.IntArray([3] * len(faces)))
        self._mesh.CreateFaceVertexIndicesAttr(Vt.IntArray(faces.ravel().tolist()))
        self._points = self._mesh.CreatePointsAttr()
        self._extent = self._mesh.CreateExtentAttr()
        self._n = int(faces.max(initial=-1)) + 1
        self.frames = 0

    def write_frame(self, positions: np.ndarray) -> None:
        """Appends one frame, (n, 3) positions, at the next time code."""
        _, _, Vt = _pxr()
        p = np.ascontiguousarray(positions, dtype=np.float32)
        if p.ndim != 2 or p.shape[1] != 3 or len(p) < self._n:
            raise UsdError(f"positions must have shape (n, 3) with n >= {self._n}, got {p.shape}")
        t = float(self.frames)
        self._points.Set(Vt.Vec3fArray.FromNumpy(p), t)
        self._extent.Set(Vt.Vec3fArray.FromNumpy(np.stack([p.min(0), p.max(0)])), t)
        self.frames += 1
        self._stage.SetStartTimeCode(0.0)
        self._stage.SetEndTimeCode(t)

    def save(self) -> None:
        """Writes the file as it stands."""
        self._stage.GetRootLayer().Save()


def write_usd(path: str | Path, frames: np.ndarray, faces: np.ndarray, fps: float = 24.0, up: str = "z") -> Path:
    """Writes frames (f, n, 3), or one shape (n, 3), as a USD mesh with time-sampled points."""
    frames = np.asarray(frames, dtype=np.float64)
    writer = UsdWriter(path, faces, fps, up)
    for p in frames if frames.ndim == 3 else [frames]:
        writer.write_frame(p)
    writer.save()
    return writer.path
