"""The cloth simulator through Python: the paper's scenes, stepping, recording."""

from __future__ import annotations

import numpy as np
import pytest

import selfcd


def test_paper_scenes_are_listed_in_the_papers_order() -> None:
    assert selfcd.paper_scenes() == ["two-corners", "corner", "center"]
    assert selfcd.scenes.paper_names() == selfcd.paper_scenes()


@pytest.mark.parametrize(("scene", "pins"), [("two-corners", [0, 120]), ("corner", [0]), ("center", [60])])
def test_pins_hold_and_the_cloth_falls(scene: str, pins: list[int]) -> None:
    sim = selfcd.scenes.paper(scene, resolution=11)
    assert sim.mesh.n_faces == 200 and list(np.flatnonzero(sim.pinned)) == pins
    rest = sim.positions
    frames, times, stats = sim.run(60, every=3)
    assert frames.shape == (21, 121, 3) and np.allclose(times, np.arange(21) * 3 * sim.dt)
    assert np.array_equal(frames[0], rest)
    assert np.allclose(frames[:, pins], rest[pins])
    free = np.setdiff1d(np.arange(121), pins)
    assert frames[-1][free, 2].mean() < -0.05, "gravity pulls the free cloth down"
    assert sim.steps == 60 and sim.time == pytest.approx(1.0)
    assert stats["step_time"].shape == (60,) and stats["detection"]["primitive_tests"].shape == (60,)


def test_the_response_leaves_no_intersection() -> None:
    sim = selfcd.Simulation("center", 11)
    frames, _, stats = sim.run(240, every=4)
    assert stats["contacts"].max() > 0, "the centre scene folds onto itself"
    assert stats["intersections"].max() == 0
    assert all(len(p) == 0 for p in selfcd.reference_pairs(sim.mesh, frames))


def test_step_by_step_matches_run() -> None:
    a, b = selfcd.Simulation("corner", 7), selfcd.Simulation("corner", 7)
    for _ in range(10):
        st = a.step()
    frames, _, _ = b.run(10)
    assert np.allclose(a.positions, frames[-1]) and st["detection"]["triggered"] is None
    assert set(a.energy()) == {"kinetic", "gravity", "elastic", "total"}


def test_any_method_drives_the_response() -> None:
    for method in selfcd.methods():
        sim = selfcd.Simulation("center", 7, method=method)
        sim.run(5)
        assert sim.method == method


@pytest.mark.parametrize(
    ("kwargs", "error", "words"),
    [
        ({"scene": "hanging"}, ValueError, "unknown cloth scene \"hanging\""),
        ({"scene": "center", "resolution": 1}, ValueError, "resolution must be at least 2"),
        ({"scene": "center", "resolution": 2.5}, TypeError, "resolution must be an integer"),
        ({"scene": "center", "method": "fast"}, ValueError, "unknown method"),
        ({"scene": "center", "dt": -1.0}, ValueError, "time step must be positive"),
    ],
)
def test_bad_simulation_arguments(kwargs, error, words) -> None:
    with pytest.raises(error) as info:
        selfcd.Simulation(**kwargs)
    assert words in str(info.value)


def test_run_arguments_are_checked() -> None:
    sim = selfcd.Simulation("center", 5)
    with pytest.raises(ValueError, match="every must be at least 1"):
        sim.run(3, every=0)
    with pytest.raises(ValueError, match="steps must be >= 0"):
        sim.run(-1)
