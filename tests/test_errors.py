"""Bad inputs raise clean ValueError/TypeError naming the problem, never a crash."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest

import selfcd

V, F = selfcd.scenes.grid(4)


@pytest.mark.parametrize(
    ("vertices", "faces", "error", "words"),
    [
        (V[:, :2], F, ValueError, "vertices must have shape (n, 3)"),
        (V.ravel(), F, ValueError, "vertices must have shape (n, 3)"),
        (V, F[:, :2], ValueError, "faces must have shape (m, 3)"),
        (V, F.astype(np.float64), TypeError, "faces must be an integer array"),
        (V.astype(str), F, TypeError, "vertices must be a numeric array"),
        (V.astype(bool), F, TypeError, "vertices must be a numeric array"),
        ([[0, 0], [1, 0, 0]], F, ValueError, "vertices is not a rectangular array"),
        (np.zeros((0, 3)), F, ValueError, "empty mesh"),
        (V, np.zeros((0, 3), dtype=int), ValueError, "empty mesh"),
        (np.where(np.arange(V.size).reshape(V.shape) == 7, np.nan, V), F, ValueError, "vertex 2 has a non-finite"),
        (np.where(np.arange(V.size).reshape(V.shape) == 4, np.inf, V), F, ValueError, "non-finite coordinate (inf)"),
        (V, np.vstack([F, [[0, 1, 99]]]), ValueError, "refers to vertex 99"),
        (V, np.vstack([F, [[0, 1, -1]]]), ValueError, "vertex index -1"),
        (V, np.vstack([F, [[0, 1, 2**40]]]), ValueError, "vertex index 1099511627776"),
        (V, np.array([[0, 1, 2**63 + 5]], dtype=np.uint64), ValueError, "too large"),
        (V, np.vstack([F, [[0, 0, 1]]]), ValueError, "repeats a vertex"),
        (V, np.vstack([F, F[:1, ::-1]]), ValueError, "have the same vertices"),
    ],
)
def test_bad_meshes_are_named(vertices, faces, error, words) -> None:
    with pytest.raises(error) as info:
        selfcd.Mesh(vertices, faces)
    assert words in str(info.value)


def test_other_dtypes_and_layouts_are_accepted() -> None:
    m = selfcd.Mesh(np.asfortranarray(V.astype(np.float32)), F.astype(np.uint16))
    assert (m.n_vertices, m.n_faces) == (16, 18)
    det = selfcd.Detector(m)
    wide = np.zeros((len(V), 6))
    wide[:, ::2] = V
    assert det.detect(wide[:, ::2]).shape == (0, 2)  # a strided view
    assert det.detect(V.tolist()).shape == (0, 2)


@pytest.mark.parametrize(
    ("positions", "error", "words"),
    [
        (V[:-1], ValueError, "positions has 15 vertices, the mesh has 16"),
        (V[:, :2], ValueError, "positions must have shape (n, 3)"),
        (np.full_like(V, np.nan), ValueError, "non-finite"),
        (np.array(["a"] * 48).reshape(16, 3), TypeError, "numeric"),
        (None, None, None),
    ],
)
def test_bad_positions(positions, error, words) -> None:
    det = selfcd.Detector(selfcd.Mesh(V, F))
    if error is None:
        assert det.detect(positions).shape == (0, 2)
        return
    with pytest.raises(error) as info:
        det.detect(positions)
    assert words in str(info.value)
    assert det.detect(V).shape == (0, 2), "the detector stays usable after an error"


@pytest.mark.parametrize(
    ("kwargs", "error", "words"),
    [
        ({"method": "nope"}, ValueError, "unknown method \"nope\"; expected one of brute"),
        ({"method": 3}, TypeError, "method must be a string"),
        ({"thickness": -1.0}, ValueError, "thickness must be finite and >= 0"),
        ({"thickness": float("nan")}, ValueError, "thickness"),
        ({"method": "bvh", "count": 4}, TypeError, "unknown option \"count\" for method \"bvh\""),
        ({"method": "sensor-gated", "bogus": 1}, TypeError, "unknown option \"bogus\""),
        ({"method": "sensor-gated", "count": "four"}, TypeError, "\"count\" must be"),
        ({"method": "sensor-gated", "count": 1}, ValueError, "sensor count must be at least 2"),
        ({"method": "sensor-gated", "inner": "brute"}, ValueError, "inner method"),
    ],
)
def test_bad_detector_arguments(kwargs, error, words) -> None:
    with pytest.raises(error) as info:
        selfcd.Detector(selfcd.Mesh(V, F), **kwargs)
    assert words in str(info.value)


def test_detector_needs_a_mesh() -> None:
    with pytest.raises(TypeError, match="mesh must be a selfcd.Mesh"):
        selfcd.Detector((V, F))


def test_bad_frames_and_shapes() -> None:
    mesh = selfcd.Mesh(V, F)
    with pytest.raises(ValueError, match=r"frames must have shape \(frames, 16, 3\)"):
        selfcd.compare_methods(mesh, V)
    with pytest.raises(ValueError, match="unknown method"):
        selfcd.compare_methods(mesh, V[None], ["bvh", "fast"])
    with pytest.raises(ValueError, match="unknown shape"):
        selfcd.scenes.deform(V, "melt")
    with pytest.raises(TypeError, match="takes"):
        selfcd.scenes.deform(V, "fold", turns=1)
    with pytest.raises(ValueError, match="grid side"):
        selfcd.scenes.grid(1)


def test_a_barrage_of_bad_inputs_never_crashes_the_interpreter() -> None:
    """Runs in a child interpreter: a crash (segfault, abort, panic) would show as a bad exit."""
    code = textwrap.dedent(
        """
        import numpy as np, selfcd
        V, F = selfcd.scenes.grid(4)
        bad = [np.full((4, 3), np.nan), np.zeros((0, 3)), np.zeros((3, 0)), np.zeros((2, 2, 2)), "x", None, 1.5,
               [[1, 2, 3]], np.array([[1e308, -1e308, 0]] * 16), np.zeros((16, 3), dtype=complex),
               np.array([[0, 1, 2]], dtype=np.int8), np.array([[-5, 2, 3]])]
        caught = 0
        for a in bad:
            for call in (lambda: selfcd.Mesh(a, F), lambda: selfcd.Mesh(V, a), lambda: selfcd.self_intersections(a, F),
                         lambda: selfcd.Detector(selfcd.Mesh(V, F)).detect(a),
                         lambda: selfcd.compare_methods(selfcd.Mesh(V, F), a)):
                try:
                    call()
                except (ValueError, TypeError):
                    caught += 1
        print("caught", caught)
        """
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    caught = int(out.stdout.split()[-1])
    assert caught >= 50, out.stdout
