"""USD: reading a mesh prim (time-sampled points are an animation), writing frames, round trips."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from pxr import Usd, UsdGeom

import selfcd
from selfcd import io as mesh_io
from selfcd.usd import UsdError, UsdWriter, read_usd, stage_up_axis, triangulate, write_usd


def crumpling(n: int = 9) -> tuple[np.ndarray, np.ndarray]:
    V, F = selfcd.scenes.grid(n)
    return np.stack([selfcd.scenes.deform(V, "crumple", amplitude=a, wavelength=0.4, seed=5)
                     for a in (0.0, 0.2, 0.35)]), F


@pytest.mark.parametrize("suffix", [".usda", ".usdc", ".usd"])
def test_frames_round_trip_as_float32(tmp_path: Path, suffix: str) -> None:
    frames, F = crumpling()
    path = write_usd(tmp_path / f"anim{suffix}", frames, F, fps=30, up="y")
    got, faces = read_usd(path)
    assert np.array_equal(faces, F)
    assert np.array_equal(got, frames.astype(np.float32).astype(np.float64)), "USD points are float32"
    assert stage_up_axis(path) == "y" and mesh_io.up_axis(path) == "y"
    stage = Usd.Stage.Open(str(path))
    assert stage.GetTimeCodesPerSecond() == 30 and stage.GetEndTimeCode() == len(frames) - 1
    assert UsdGeom.Mesh(stage.GetDefaultPrim().GetChildren()[0]).GetSubdivisionSchemeAttr().Get() == "none"


def test_one_shape_and_sequences_load_through_io(tmp_path: Path) -> None:
    frames, F = crumpling()
    write_usd(tmp_path / "one.usda", frames[2], F)
    V, faces = mesh_io.load_mesh(tmp_path / "one.usda")
    assert V.shape == frames[2].shape and np.array_equal(faces, F)
    write_usd(tmp_path / "anim.usdc", frames, F)
    seq, faces, labels = mesh_io.load_sequence([tmp_path / "anim.usdc"])
    assert seq.shape == frames.shape and labels == [f"{tmp_path / 'anim.usdc'}[{k}]" for k in range(3)]


def test_writer_saves_as_it_goes(tmp_path: Path) -> None:
    frames, F = crumpling()
    w = UsdWriter(tmp_path / "live.usdc", F)
    for k, p in enumerate(frames):
        w.write_frame(p)
        w.save()
        got, _ = read_usd(tmp_path / "live.usdc")
        assert (got.shape[0] if got.ndim == 3 else 1) == k + 1
    with pytest.raises(UsdError, match="shape"):
        w.write_frame(frames[0][:3])


def test_polygons_are_split_into_fans(tmp_path: Path) -> None:
    assert triangulate(np.array([4, 3, 5]), np.arange(12)).tolist() == [
        [0, 1, 2], [0, 2, 3], [4, 5, 6], [7, 8, 9], [7, 9, 10], [7, 10, 11]]
    with pytest.raises(UsdError):
        triangulate(np.array([2]), np.arange(2))
    stage = Usd.Stage.CreateNew(str(tmp_path / "quads.usda"))
    mesh = UsdGeom.Mesh.Define(stage, "/quads")
    mesh.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    stage.GetRootLayer().Save()
    V, F = read_usd(tmp_path / "quads.usda")
    assert V.shape == (4, 3) and F.tolist() == [[0, 1, 2], [0, 2, 3]]
    assert stage_up_axis(tmp_path / "quads.usda") in ("y", "z")


def test_bad_usd_files_are_input_errors(tmp_path: Path) -> None:
    (tmp_path / "garbage.usda").write_text("not usd at all")
    with pytest.raises(mesh_io.MeshFileError, match="cannot read USD"):
        mesh_io.load_mesh(tmp_path / "garbage.usda")
    stage = Usd.Stage.CreateNew(str(tmp_path / "empty.usda"))
    UsdGeom.Xform.Define(stage, "/nothing")
    stage.GetRootLayer().Save()
    with pytest.raises(mesh_io.MeshFileError, match="no mesh prim"):
        mesh_io.load_mesh(tmp_path / "empty.usda")
    with pytest.raises(UsdError, match="up"):
        UsdWriter(tmp_path / "x.usda", np.zeros((1, 3), int), up="x")
    with pytest.raises(UsdError, match="ends in"):
        UsdWriter(tmp_path / "x.obj", np.zeros((1, 3), int))


def test_detect_reads_usd_animations(tmp_path: Path) -> None:
    frames, F = crumpling(15)
    write_usd(tmp_path / "anim.usdc", frames, F)
    want = [len(p) for p in selfcd.reference_pairs(selfcd.Mesh(frames[0], F), frames.astype(np.float32))]
    out = subprocess.run([sys.executable, "-m", "selfcd", "detect", str(tmp_path / "anim.usdc"), "--json"],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == (1 if any(want) else 0), out.stderr
    assert [r["count"] for r in json.loads(out.stdout)["files"]] == want
    assert any(want)
    (tmp_path / "bad.usd").write_text("junk")
    out = subprocess.run([sys.executable, "-m", "selfcd", "detect", str(tmp_path / "bad.usd")],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 2 and "cannot read USD" in out.stderr
