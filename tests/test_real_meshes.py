"""Exactness on real garments and bodies: the meshes of shared/data (read there,
never copied) against the exact pair counts its README gives, computed by a
rational-arithmetic reference independent of selfcd."""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pytest

import selfcd
from selfcd import io as mesh_io

REPO = Path(__file__).resolve().parents[1]


def data_dir() -> Path:
    """shared/data beside the repository (or beside its worktree folder), or $SELFCD_DATA."""
    if "SELFCD_DATA" in os.environ:
        return Path(os.environ["SELFCD_DATA"])
    for base in (REPO.parent, REPO.parent.parent):
        if (base / "shared" / "data").is_dir():
            return base / "shared" / "data"
    raise FileNotFoundError(f"no shared/data beside {REPO}; set SELFCD_DATA")


def readme_counts() -> dict[str, int]:
    """file stem -> exact intersecting pairs, from the README's table (last column)."""
    rows = re.findall(r"^\| (\w+)\.obj \|.*\| ([\d,]+) \|$", (data_dir() / "README.md").read_text(), re.M)
    return {name: int(count.replace(",", "")) for name, count in rows}


# The README counts pairs by vertex index, as the files are (unwelded):
# multilayer_skirt_on_body repeats 24 positions, which selfcd warns about.
pytestmark = pytest.mark.filterwarnings("ignore::selfcd.weld.UnweldedMeshWarning")

COUNTS = {"dress_on_body": 923, "multilayer_skirt_on_body": 1242, "skirt_32k": 0, "body": 495}
CONSERVATIVE = [m for m in selfcd.methods() if m not in selfcd.non_conservative_methods() and m != "brute"]


@pytest.fixture(scope="module")
def meshes() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    return {name: mesh_io.load_mesh(data_dir() / f"{name}.obj") for name in COUNTS}


@pytest.fixture(scope="module")
def exact(meshes) -> dict[str, np.ndarray]:
    return {name: selfcd.self_intersections(v, f) for name, (v, f) in meshes.items()}


def test_readme_lists_these_counts():
    assert readme_counts() == COUNTS


@pytest.mark.parametrize("name", COUNTS)
def test_self_intersections_match_the_reference_count(name, exact):
    pairs = exact[name]
    assert len(pairs) == COUNTS[name]
    assert len(np.unique(pairs, axis=0)) == len(pairs)


@pytest.mark.parametrize("method", CONSERVATIVE)
@pytest.mark.parametrize("name", COUNTS)
def test_conservative_methods_find_the_same_pairs(name, method, meshes, exact):
    v, f = meshes[name]
    det = selfcd.Detector(selfcd.Mesh(v, f), method)
    assert np.array_equal(det.detect(v), exact[name])


def test_repeated_positions_are_warned_about(meshes):
    v, f = meshes["multilayer_skirt_on_body"]
    with pytest.warns(selfcd.weld.UnweldedMeshWarning, match="24 of 43275 vertices"):
        selfcd.Mesh(v, f)


def test_brute_force_agrees_on_the_body(meshes, exact):
    v, f = meshes["body"]
    pairs = selfcd.Detector(selfcd.Mesh(v, f), "brute").detect(v)
    assert np.array_equal(pairs, exact["body"])


@pytest.mark.parametrize("name", ["skirt_32k", "body"])
def test_continuous_certificate_keeps_the_pairs_on_a_wave(name, meshes):
    """At thickness 0 the fresh continuous query skips patches its swept certificate
    proves free of contact; on a wave of half a median edge over these meshes it must
    still report what the uncertified coherent query reports (no pair lost)."""
    v, f = meshes[name]
    mesh = selfcd.Mesh(v, f)
    edge = float(np.median(np.linalg.norm(v[f[:, 0]] - v[f[:, 1]], axis=1)))
    x1 = v + 0.5 * edge * np.sin(2 * np.pi * v[:, [0]] / (16 * edge)) * np.array([[0.3, 1.0, 0.2]])
    fresh = selfcd.continuous_impacts(mesh, v, x1)
    coherent = selfcd.SelfQueries(mesh).continuous(v, x1, 0.0)
    for key in ("vertex_triangle", "edge_edge"):
        assert np.array_equal(fresh[key], coherent[key])


@pytest.mark.parametrize("name", ["dress_on_body", "body"])
def test_kept_detectors_give_the_fresh_pairs_on_a_sequence(name, meshes):
    """A kept default detector starts each traversal from the front kept
    from the last frame (bvh/traverse.rs), skips the front's jobs that stayed
    clear of the motion, and reuses contour certificates (bvh/kept.rs); over
    a wave sequence every frame must equal a fresh query, and every reuse
    must happen (else this test would check nothing new)."""
    v, f = meshes[name]
    mesh = selfcd.Mesh(v, f)
    det = selfcd.Detector(mesh)
    edge = float(np.median(np.linalg.norm(v[f[:, 0]] - v[f[:, 1]], axis=1)))
    k = 2 * np.pi / (16 * edge)
    reused = front_jobs = skipped = 0
    for step in range(6):
        x = v + 0.05 * edge * np.sin(k * v[:, [1, 2, 0]] + 0.7 * step + np.array([0.0, 1.0, 2.0]))
        assert np.array_equal(det.detect(x), selfcd.self_intersections(x, f)), step
        reused += det.last_stats["certificates_reused"]
        front_jobs += det.last_stats["front_jobs"]
        skipped += det.last_stats["front_skips"]
    assert reused > 1000, reused
    assert front_jobs > 1000, front_jobs
    assert skipped > 1000, skipped


@pytest.mark.parametrize("name", ["skirt_32k", "body"])
def test_one_shot_proximity_is_the_detectors_on_real_meshes(name, meshes):
    """`proximity_contacts` (top-down, built for the call) against a kept
    Detector's proximity (bottom-up, checked against brute force elsewhere):
    the same contacts, array for array, at d = 0.6 median edges."""
    v, f = meshes[name]
    mesh = selfcd.Mesh(v, f)
    d = 0.6 * float(np.median(np.linalg.norm(v[f[:, 0]] - v[f[:, 1]], axis=1)))
    det = selfcd.Detector(mesh, thickness=d)
    det.detect(v)
    want = det.last_proximity
    got = selfcd.proximity_contacts(mesh, v, d)
    assert len(got["vertex_triangle"]) > 1000 and len(got["edge_edge"]) > 1000
    for key in want:
        assert np.array_equal(got[key], want[key]), key
    # The arrays' rows line up (both sides above are converted alike, and
    # these answers are long enough to be filled in parallel): each edge
    # pair's vertices are its edges', and each vertex-triangle distance is
    # that of the vertex to its closest point, rebuilt from the weights.
    edges = np.asarray(mesh.edges)
    ee, vt = got["edge_edge"], got["vertex_triangle"]
    assert got["edge_edge_vertices"].shape == (len(ee), 4)
    assert np.array_equal(got["edge_edge_vertices"], edges[ee].reshape(-1, 4))
    closest = np.einsum("ij,ijk->ik", got["vertex_triangle_bary"], v[f[vt[:, 1]]])
    dist = np.linalg.norm(v[vt[:, 0]] - closest, axis=1)
    assert np.allclose(dist, got["vertex_triangle_distance"], rtol=1e-9, atol=1e-12 * d)
    assert (got["vertex_triangle_distance"] < d).all() and (got["edge_edge_distance"] < d).all()
