"""SelfQueries from Python: over a moving sequence every answer equals a fresh
query's, the candidate set is reused where the mesh moved little, bad input raises."""

import numpy as np
import pytest

import selfcd


def _sequence(frames: int = 12):
    """A 12x12-vertex sheet folding through itself, in small steps, plus a jitter that
    makes every frame's motion non-rigid."""
    V, F = selfcd.scenes.grid(12)
    seq = []
    for k, angle in enumerate(np.linspace(0.85, 1.1, frames) * np.pi):
        x = selfcd.scenes.deform(V, "fold", angle=angle, radius=0.03)
        seq.append(x + 1e-3 * np.sin(3.0 * x[:, [1, 2, 0]] + k))
    return selfcd.Mesh(V, F), F, seq


def _proximity_rows(p):
    vt = {tuple(r) for r in p["vertex_triangle"].tolist()}
    ee = {tuple(r) for r in p["edge_edge"].tolist()}
    return vt, ee


def test_every_answer_equals_a_fresh_query_over_a_sequence():
    mesh, F, seq = _sequence()
    q = selfcd.SelfQueries(mesh)
    d = 0.5 * float(np.median(np.linalg.norm(seq[0][F[:, 0]] - seq[0][F[:, 1]], axis=1)))
    reused = 0
    for x0, x1 in zip(seq, seq[1:]):
        got = q.proximity(x0, d)
        fresh = selfcd.Detector(mesh, thickness=d)
        fresh.detect(x0)
        want = fresh.last_proximity
        assert _proximity_rows(got) == _proximity_rows(want)
        for key in ("vertex_triangle_distance", "edge_edge_distance"):
            assert np.array_equal(np.sort(got[key]), np.sort(want[key]))
        reused += q.last_stats["candidate_reuses"]

        hits = q.continuous(x0, x1, 0.25 * d)
        want = selfcd.continuous_impacts(mesh, x0, x1, 0.25 * d)
        for kind in ("vertex_triangle", "edge_edge"):
            g = dict(zip(map(tuple, hits[kind].tolist()), hits[f"{kind}_toi"].tolist()))
            w = dict(zip(map(tuple, want[kind].tolist()), want[f"{kind}_toi"].tolist()))
            assert g == w

        assert np.array_equal(q.intersections(x1), selfcd.self_intersections(x1, F))
        assert np.array_equal(q.intersections(x1, cones=False), selfcd.self_intersections(x1, F))
    # The sequence moves little per frame: the candidate set must have served some queries.
    assert reused > 0
    # The fold passes through itself: the check is not vacuous.
    assert len(q.intersections(seq[-1])) > 0


def test_stats_and_skin():
    mesh, _, seq = _sequence(3)
    q = selfcd.SelfQueries(mesh, skin=0.05)
    assert q.skin == 0.05 and q.last_stats["candidate_builds"] == 0
    q.proximity(seq[0], 0.02)
    assert q.last_stats["candidate_builds"] == 1
    assert "SelfQueries" in repr(q)


def test_bad_inputs_raise():
    mesh, _, seq = _sequence(2)
    with pytest.raises(ValueError, match="skin"):
        selfcd.SelfQueries(mesh, skin=0.0)
    with pytest.raises(TypeError):
        selfcd.SelfQueries("not a mesh")
    q = selfcd.SelfQueries(mesh)
    with pytest.raises(ValueError, match="thickness"):
        q.proximity(seq[0], -1.0)
    with pytest.raises(ValueError, match="thickness"):
        q.proximity(seq[0], float("nan"))
    with pytest.raises(ValueError):
        q.intersections(seq[0][:-1])
    bad = seq[0].copy()
    bad[3, 1] = np.inf
    with pytest.raises(ValueError):
        q.continuous(seq[0], bad)
    # The queries stay usable after an error.
    assert q.intersections(seq[0]).shape[1] == 2
