"""Any valid input: zero-area faces, triangle soups (weld), and clear errors with
exit status 2 for every bad file."""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import selfcd
from selfcd.weld import UnweldedMeshWarning, weld

V, F = selfcd.scenes.grid(6)


def _with_zero_area_faces() -> tuple[np.ndarray, np.ndarray]:
    """The grid plus a point face on the cloth and a segment face along its x axis edge."""
    v = np.vstack([V, [[0.5, 0.5, 0.0]] * 3, [[0.1, -0.5, 0.0], [0.1, 0.0, 0.0], [0.1, 0.5, 0.0]]])
    n = len(V)
    f = np.vstack([F, [[n, n + 1, n + 2], [n + 3, n + 4, n + 5]]])
    return v, f


@pytest.mark.parametrize("method", selfcd.methods())
def test_zero_area_faces_count_as_points_and_segments(method: str) -> None:
    v, f = _with_zero_area_faces()
    mesh = selfcd.Mesh(v, f)
    want = selfcd.Detector(mesh, "brute").detect()
    assert len(want) > 0  # the point lies on the cloth, the segment crosses its edge
    got = selfcd.Detector(mesh, method, thickness=0.05).detect()
    if method in selfcd.non_conservative_methods():
        assert set(map(tuple, got)) <= set(map(tuple, want))
    else:
        np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(selfcd.self_intersections(v, f), want)


def _soup(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return v[f].reshape(-1, 3), np.arange(3 * len(f)).reshape(-1, 3)


def test_weld_makes_a_soup_a_mesh() -> None:
    sv, sf = _soup(V, F)
    with pytest.warns(UnweldedMeshWarning, match="weld=True"):
        assert len(selfcd.self_intersections(sv, sf)) > 0  # every neighbour touches
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert len(selfcd.self_intersections(sv, sf, weld=True)) == 0
        mesh = selfcd.Mesh(sv, sf, weld=True)
    assert (mesh.n_vertices, mesh.n_faces) == (len(V), len(F))
    folded = selfcd.scenes.deform(V, "fold", angle=3.6)
    want = selfcd.Detector(selfcd.Mesh(V, F), "brute").detect(folded)
    assert len(want) > 0
    det = selfcd.Detector(mesh)
    np.testing.assert_array_equal(det.detect(folded[F].reshape(-1, 3)), want)  # the soup's own positions
    np.testing.assert_array_equal(selfcd.reference_pairs(mesh, folded[F].reshape(1, -1, 3))[0], want)
    with pytest.raises(TypeError, match="weld must be a bool"):
        selfcd.Mesh(sv, sf, weld="no")


def test_the_engine_screens_positions_and_the_warning_is_unchanged() -> None:
    """The engine's screen passes distinct positions (no exact grouping, no warning) and flags
    repeats; the warning then comes from the exact check, also before an engine error."""
    v, f = np.ascontiguousarray(V, dtype=np.float64), np.ascontiguousarray(F, dtype=np.int64)
    assert not selfcd._core.Mesh(v, f, screen_positions=True).may_repeat_positions
    assert selfcd._core.Mesh(v, f).may_repeat_positions  # not screened: may repeat
    sv, sf = _soup(V, F)
    assert selfcd._core.Mesh(sv, sf, screen_positions=True).may_repeat_positions
    signed = v.copy()
    signed[-1] = -v[0]  # opposite corners, both at the origin (-0.0 is 0.0)
    assert np.signbit(signed[-1]).all() and not np.signbit(v[0]).any()
    assert selfcd._core.Mesh(signed, f, screen_positions=True).may_repeat_positions
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        selfcd.Mesh(V, F)
        selfcd.self_intersections(V, F)
    with pytest.warns(UnweldedMeshWarning, match="1 of"):
        selfcd.Mesh(signed, f)
    collapsed = np.vstack([V, [[0.5, 0.5, 0.0]] * 3])  # one point face: its corners may coincide
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        selfcd.Mesh(collapsed, np.vstack([F, [[len(V), len(V) + 1, len(V) + 2]]]))
    with pytest.warns(UnweldedMeshWarning), pytest.raises(ValueError, match="same vertices"):
        selfcd.Mesh(sv, np.vstack([sf, sf[:1]]))  # a soup with a duplicate face: warned, then refused


def test_weld_keeps_collapsed_corners_distinct() -> None:
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0], [-0.0, 0, 0], [0.0, 0, 0]], dtype=float)
    f = np.array([[0, 1, 2], [3, 4, 5]])
    wv, wf, src = weld(v, f)
    np.testing.assert_array_equal(wf[0], [0, 1, 2])
    assert wf[1][0] == 1 and wf[1][1] == 0 and wf[1][2] == 3  # -0.0 and 0.0 merge; the repeat gets a copy
    np.testing.assert_array_equal(wv, v[src])
    selfcd.Mesh(v, f, weld=True)  # valid: the second face is a segment


def test_position_groups_match_numpy_unique() -> None:
    """The engine's grouping equals numpy's exact row grouping (first-occurrence numbering)."""
    rng = np.random.default_rng(5)
    v = rng.integers(-3, 4, size=(4000, 3)).astype(float) * rng.choice([0.5, 1e-300, 1e300], size=(4000, 1))
    v[rng.random(4000) < 0.1] *= -1.0  # signed zeros among the repeats
    group, first = selfcd._core.position_groups(v)
    _, idx, inv = np.unique(v + 0.0, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(idx, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    np.testing.assert_array_equal(first, idx[order])
    np.testing.assert_array_equal(group, rank[inv.reshape(-1)])
    assert len(first) < len(v)


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(Path(selfcd.__file__).parent.parent)}
    return subprocess.run([sys.executable, "-m", "selfcd", *args], capture_output=True, text=True, env=env,
                          timeout=120)


def test_detect_welds_stl_by_default(tmp_path: Path) -> None:
    import trimesh

    folded = selfcd.scenes.deform(V, "fold", angle=3.6)
    path = tmp_path / "soup.stl"
    trimesh.Trimesh(folded, F, process=False).export(path)
    want = len(selfcd.self_intersections(folded, F))
    welded = _run("detect", str(path), "--json")
    assert welded.returncode == 1 and f'"count": {want}' in welded.stdout
    raw = _run("detect", str(path), "--no-weld")
    assert raw.returncode == 1 and "Warning:" in raw.stderr and "--weld" in raw.stderr
    assert f"{want} intersecting" not in raw.stdout


def _bad_files(tmp: Path) -> list[tuple[str, str]]:
    rng = np.random.default_rng(0)
    garbage = rng.integers(0, 256, 3000, dtype=np.uint8).tobytes()
    for name in ("g.obj", "g.stl", "g.ply", "g.off"):
        (tmp / name).write_bytes(garbage)
    (tmp / "empty.obj").write_bytes(b"")
    (tmp / "empty.npz").write_bytes(b"")
    np.savez(tmp / "nothing.npz")
    (tmp / "text.stl").write_text("hello\n")
    os.mkfifo(tmp / "fifo.obj")
    (tmp / "folder.obj").mkdir()
    return [
        ("g.obj", "not a valid OBJ file"),
        ("g.stl", "not an STL file"),
        ("g.ply", "not a readable PLY file"),
        ("g.off", "not a valid OFF file"),
        ("empty.obj", "the file is empty"),
        ("empty.npz", "the file is empty"),
        ("nothing.npz", "needs arrays V and F"),
        ("text.stl", "no triangles found"),
        ("fifo.obj", "not a regular file"),
        ("folder.obj", "is a directory"),
        ("missing.obj", "no such file"),
        ("/dev/null", "not a regular file"),
    ]


def test_every_bad_file_is_a_clear_error_with_status_2(tmp_path: Path) -> None:
    from selfcd.io import MeshFileError, load_mesh

    for name, words in _bad_files(tmp_path):
        path = Path(name) if name.startswith("/") else tmp_path / name
        with pytest.raises(MeshFileError, match=words):
            load_mesh(path)
    # The command line, on a few of them (each run starts an interpreter).
    for name in ("g.stl", "empty.npz", "fifo.obj"):
        r = _run("detect", str(tmp_path / name))
        assert r.returncode == 2, (name, r.returncode, r.stderr)
        assert "Error:" in r.stderr and "Traceback" not in r.stderr and "charset" not in r.stderr


def test_batch_welds_stl_like_detect(tmp_path: Path) -> None:
    import trimesh

    from selfcd.batch import check_input

    folded = selfcd.scenes.deform(V, "fold", angle=3.6)
    path = tmp_path / "soup.stl"
    trimesh.Trimesh(folded, F, process=False).export(path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        row = check_input(str(path))
    assert row["pairs_total"] == len(selfcd.self_intersections(folded, F)) > 0, row
