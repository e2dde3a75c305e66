"""Continuous and one-shot proximity queries from Python: impacts found, conservative, bad input rejected."""

import numpy as np
import pytest

import selfcd


def _fold_step():
    V, F = selfcd.scenes.grid(9)
    x0 = selfcd.scenes.deform(V, "fold", angle=0.9 * np.pi, radius=0.02)
    x1 = selfcd.scenes.deform(V, "fold", angle=1.15 * np.pi, radius=0.02)
    return selfcd.Mesh(V, F), F, x0, x1


def test_a_fold_through_itself_is_caught_before_it_intersects():
    mesh, F, x0, x1 = _fold_step()
    assert len(selfcd.self_intersections(x0, F)) == 0
    hits = selfcd.continuous_impacts(mesh, x0, x1)
    assert hits["vertex_triangle"].dtype == np.int64 and hits["vertex_triangle"].shape[1] == 2
    tois = np.concatenate([hits["vertex_triangle_toi"], hits["edge_edge_toi"]])
    assert len(tois) > 0 and np.all((tois >= 0) & (tois <= 1))
    # The first sampled time with an intersection is not before the earliest impact.
    first = next(s for s in np.linspace(0, 1, 65)[1:] if len(selfcd.self_intersections(x0 + s * (x1 - x0), F)))
    assert tois.min() <= first
    edges = mesh.edges
    assert hits["edge_edge"].max(initial=0) < len(edges)


def test_a_still_mesh_has_no_impacts_and_thickness_counts():
    mesh, F, x0, _ = _fold_step()
    hits = selfcd.continuous_impacts(mesh, x0, x0)
    assert all(len(hits[k]) == 0 for k in hits)
    near = selfcd.continuous_impacts(mesh, x0, x0, thickness=0.2)
    assert len(near["vertex_triangle"]) > 0 and np.all(near["vertex_triangle_toi"] == 0.0)


def test_the_old_name_separation_still_works_and_warns():
    mesh, F, x0, _ = _fold_step()
    with pytest.warns(DeprecationWarning, match="thickness"):
        old = selfcd.continuous_impacts(mesh, x0, x0, separation=0.2)
    new = selfcd.continuous_impacts(mesh, x0, x0, thickness=0.2)
    assert all(np.array_equal(old[k], new[k]) for k in new)


def test_bad_inputs_raise():
    mesh, F, x0, x1 = _fold_step()
    with pytest.raises(ValueError):
        selfcd.continuous_impacts(mesh, x0[:5], x1)
    with pytest.raises(ValueError):
        selfcd.continuous_impacts(mesh, x0, x1, thickness=-1.0)
    bad = x1.copy()
    bad[3, 1] = np.nan
    with pytest.raises(ValueError):
        selfcd.continuous_impacts(mesh, x0, bad)
    with pytest.raises(TypeError, match="selfcd.Mesh"):
        selfcd.continuous_impacts(x0, x0, x1)


def test_one_shot_proximity_is_the_detectors():
    """`proximity_contacts` (its hierarchy built for the call) gives a Detector's
    proximity contacts to the bit, on a fold and on a crumple."""
    mesh, F, x0, _ = _fold_step()
    V = mesh.vertices
    d = 0.6 * mesh.mean_edge_length
    crumple = selfcd.scenes.deform(V, "crumple", amplitude=0.3, wavelength=0.4)
    for x in (x0, crumple):
        det = selfcd.Detector(mesh, thickness=d)
        det.detect(x)
        want = det.last_proximity
        got = selfcd.proximity_contacts(mesh, x, d)
        assert set(got) == set(want)
        assert len(got["vertex_triangle"]) > 0 and len(got["edge_edge"]) > 0
        for k in want:
            assert np.array_equal(got[k], want[k]), k


def test_one_shot_proximity_rejects_bad_input():
    mesh, F, x0, _ = _fold_step()
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="thickness"):
            selfcd.proximity_contacts(mesh, x0, bad)
    with pytest.raises(TypeError, match="thickness must be a number"):
        selfcd.proximity_contacts(mesh, x0, "0.1")
    with pytest.raises(ValueError):
        selfcd.proximity_contacts(mesh, x0[:5], 0.1)
    with pytest.raises(TypeError, match="selfcd.Mesh"):
        selfcd.proximity_contacts(x0, x0, 0.1)
    with pytest.raises(ValueError, match="max_contacts must be >= 0"):
        selfcd.proximity_contacts(mesh, x0, 0.1, max_contacts=-1)
    # A thickness larger than the mesh: every pair is near; the limit stops it clearly.
    with pytest.raises(ValueError, match="contacts"):
        selfcd.proximity_contacts(mesh, x0, 10.0, max_contacts=100)
