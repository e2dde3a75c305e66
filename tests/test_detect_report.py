"""`selfcd detect --report/--any/--frame`, the intersection segments it draws, and
queries restricted to a subset of faces."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import selfcd
from conftest import noisy_grid
from selfcd.segments import segment, segments


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "selfcd", *args], capture_output=True, text=True, timeout=300)


@pytest.fixture
def animation(tmp_path: Path) -> tuple[Path, np.ndarray, np.ndarray]:
    """A 4-frame crumpling grid: frame 0 clean, the others intersecting (frame 2 the most)."""
    V, F = selfcd.scenes.grid(21)
    frames = np.stack([selfcd.scenes.deform(V, "crumple", amplitude=a, wavelength=0.4, seed=5)
                       for a in (0.0, 0.1, 0.3, 0.2)])
    path = tmp_path / "anim.npz"
    np.savez(path, V=frames, F=F)
    return path, frames, F


# ---------------------------------------------------------------- segments


def test_segment_of_crossing_triangles_is_exact_where_floats_are() -> None:
    flat = np.array([[0.0, 0, 0], [4, 0, 0], [0, 4, 0]])
    upright = np.array([[1.0, 1, -1], [1, 1, 1], [2, 1, 1]])  # crosses z=0 along y=1, x in [1, 1.5]
    s = segment(flat, upright)
    assert s is not None
    assert np.allclose(sorted(s.tolist()), [[1, 1, 0], [1.5, 1, 0]])
    assert np.allclose(sorted(segment(upright, flat).tolist()), [[1, 1, 0], [1.5, 1, 0]])


def test_segment_is_clipped_by_both_triangles_and_none_when_apart_or_coplanar() -> None:
    small = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    wall = np.array([[0.25, -5, -1], [0.25, 5, -1], [0.25, 0, 5]])  # x = 0.25 plane, huge
    s = segment(small, wall)
    assert s is not None and np.allclose(sorted(s.tolist()), [[0.25, 0, 0], [0.25, 0.75, 0]])
    assert segment(small, wall + [5, 0, 0]) is None
    assert segment(small, small + [0.1, 0.1, 0]) is None  # coplanar: no line to draw


def test_segments_lie_on_both_triangles(rng: np.random.Generator) -> None:
    _, F, P = noisy_grid(rng, 15, 0.35)
    pairs = selfcd.self_intersections(P, F)
    assert len(pairs) > 20
    segs = segments(P, F, pairs)
    drawn = ~np.isnan(segs).any(axis=(1, 2))
    assert drawn.mean() > 0.9
    for (a, b), s in zip(pairs[drawn], segs[drawn]):
        for tri in (P[F[a]], P[F[b]]):
            n = np.cross(tri[1] - tri[0], tri[2] - tri[0])
            assert np.allclose((s - tri[0]) @ n / np.linalg.norm(n), 0, atol=1e-9)


# ---------------------------------------------------------------- subsets


def test_subset_query_is_the_full_answer_restricted(rng: np.random.Generator) -> None:
    _, F, P = noisy_grid(rng, 17, 0.35)
    full = selfcd.self_intersections(P, F)
    assert len(full) > 20
    for subset in (np.arange(0, len(F), 3), rng.choice(len(F), 100, replace=False), np.unique(full[:7]),
                   [int(full[0, 0]), int(full[0, 1])], [], [5], np.arange(len(F))):
        got = selfcd.self_intersections(P, F, subset=subset)
        want = full[np.isin(full, subset).all(axis=1)] if len(subset) else full[:0]
        assert np.array_equal(got, want)
        assert selfcd.has_self_intersection(P, F, subset=subset) == bool(len(want))
    assert selfcd.has_self_intersection(P, F) and not selfcd.has_self_intersection(*selfcd.scenes.grid(5))


def test_subset_keeps_adjacency_by_shared_vertices() -> None:
    # two triangles sharing vertex 0 and crossing there: adjacent, so never a pair, subset or not
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0.2, 0.2, -1], [0.2, 0.2, 1]])
    F = np.array([[0, 1, 2], [0, 3, 4]])
    assert len(selfcd.self_intersections(V, F, subset=[0, 1])) == 0


def test_subset_is_validated() -> None:
    V, F = selfcd.scenes.grid(4)
    with pytest.raises(ValueError, match="outside"):
        selfcd.self_intersections(V, F, subset=[0, len(F)])
    with pytest.raises(ValueError, match="outside"):
        selfcd.self_intersections(V, F, subset=[-1])
    with pytest.raises(TypeError, match="integer"):
        selfcd.self_intersections(V, F, subset=[0.5, 1.0])
    with pytest.raises(TypeError, match="integer"):
        selfcd.self_intersections(V, F, subset=np.ones(len(F), dtype=bool))
    with pytest.raises(ValueError, match="one-dimensional"):
        selfcd.self_intersections(V, F, subset=[[0, 1]])
    with pytest.raises(ValueError):  # an invalid mesh is refused even with a tiny subset
        selfcd.self_intersections(np.full_like(V, np.nan), F, subset=[0])


# ---------------------------------------------------------------- CLI


def test_detect_report_writes_page_and_summary(animation: tuple[Path, np.ndarray, np.ndarray],
                                               tmp_path: Path) -> None:
    path, frames, F = animation
    want = [len(p) for p in selfcd.reference_pairs(selfcd.Mesh(frames[0], F), frames)]
    assert want[0] == 0 and np.argmax(want) == 2
    out = run("detect", str(path), "--report", str(tmp_path / "rep"))
    assert out.returncode == 1, out.stderr
    doc = json.loads((tmp_path / "rep" / "summary.json").read_text())
    assert [f["pairs"] for f in doc["frames"]] == want
    assert [f["label"] for f in doc["frames"]] == [f"{path}[{k}]" for k in range(4)]
    assert doc["shown_frame"] == 2 and doc["pairs_max"] == want[2] and doc["pairs_total"] == sum(want)
    assert doc["shown_pairs"] == selfcd.self_intersections(frames[2], F).tolist()
    page = (tmp_path / "rep" / "index.html").read_text()
    assert 'id="counts"' in page and 'id="frame"' in page and 'id="pairs"' in page and "Frame 2:" in page
    assert "<script src=" not in page and "<link " not in page, "the report must not load anything"
    assert page.count("<tr>") == want[2] + 1


def test_detect_report_chosen_frame_and_bad_frame(animation: tuple[Path, np.ndarray, np.ndarray],
                                                  tmp_path: Path) -> None:
    path, _, _ = animation
    out = run("detect", str(path), "--report", str(tmp_path / "rep"), "--frame", "1")
    assert out.returncode == 1, out.stderr
    assert json.loads((tmp_path / "rep" / "summary.json").read_text())["shown_frame"] == 1
    out = run("detect", str(path), "--report", str(tmp_path / "bad"), "--frame", "4")
    assert out.returncode == 2 and "out of range" in out.stderr


def test_detect_report_of_a_clean_mesh(tmp_path: Path) -> None:
    V, F = selfcd.scenes.grid(6)
    np.savez(tmp_path / "flat.npz", V=V, F=F)
    out = run("detect", str(tmp_path / "flat.npz"), "--report", str(tmp_path / "rep"))
    assert out.returncode == 0, out.stderr
    doc = json.loads((tmp_path / "rep" / "summary.json").read_text())
    assert doc["frames"][0]["pairs"] == 0 and not doc["intersecting"]


def test_detect_any_stops_at_the_first_intersecting_frame(animation: tuple[Path, np.ndarray, np.ndarray],
                                                          tmp_path: Path) -> None:
    path, _, _ = animation
    out = run("detect", str(path), "--any", "--json")
    assert out.returncode == 1, out.stderr
    assert [r["file"] for r in json.loads(out.stdout)["files"]] == [f"{path}[0]", f"{path}[1]"]
    out = run("detect", str(path), "--json")
    assert len(json.loads(out.stdout)["files"]) == 4


def test_first_intersection_is_one_of_the_pairs_or_none(rng: np.random.Generator) -> None:
    for amplitude in (0.0, 0.05, 0.2, 0.35):
        _, F, P = noisy_grid(rng, 15, amplitude)
        full = {tuple(p) for p in selfcd.self_intersections(P, F).tolist()}
        first = selfcd.first_intersection(P, F)
        assert (first is None) == (not full) and (first is None or first in full)
        assert selfcd.first_intersection(P, F) == first  # the same pair every run
        assert selfcd.has_self_intersection(P, F) == bool(full)
        subset = np.arange(1, len(F), 2)
        in_subset = {p for p in full if p[0] % 2 and p[1] % 2}
        got = selfcd.first_intersection(P, F, subset=subset)
        assert (got is None) == (not in_subset) and (got is None or got in in_subset)
    assert selfcd.first_intersection(*selfcd.scenes.grid(6)) is None
    with pytest.raises(ValueError):
        selfcd.first_intersection(np.full((4, 3), np.nan), [[0, 1, 2], [1, 2, 3]])


def test_report_renders_in_chromium(animation: tuple[Path, np.ndarray, np.ndarray], tmp_path: Path) -> None:
    """The detect report in headless Chromium: no errors, both charts drawn, the 3D view shows
    red intersecting triangles and the segment trace holds the drawn segments."""
    from PIL import Image
    from playwright.sync_api import sync_playwright

    from test_report_browser import CHROMIUM, FLAGS

    path, frames, F = animation
    assert run("detect", str(path), "--report", str(tmp_path / "rep")).returncode == 1
    with sync_playwright() as p:
        browser = p.chromium.launch_persistent_context(str(tmp_path / "profile"), executable_path=CHROMIUM,
                                                       headless=True, args=FLAGS,
                                                       viewport={"width": 1280, "height": 1000})
        page = browser.new_page()
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto((tmp_path / "rep" / "index.html").as_uri())
        page.wait_for_function("() => document.querySelectorAll('.js-plotly-plot').length == 2", timeout=60000)
        names = page.eval_on_selector("#frame", "el => el.data.map(t => t.name)")
        points = page.eval_on_selector("#frame", "el => el._fullData[1].x.length")
        view = page.locator("#frame")
        view.scroll_into_view_if_needed()
        page.wait_for_timeout(1000)
        shot = tmp_path / "frame.png"
        view.screenshot(path=str(shot))
        browser.close()
    assert errors == []
    assert names == ["mesh", "intersection"]
    pairs = len(selfcd.self_intersections(frames[2], F))
    assert 0.9 * pairs * 3 <= points <= pairs * 3  # two ends and a gap per drawn segment
    rgb = np.asarray(Image.open(shot).convert("RGB"), dtype=np.int64)
    red = (rgb[..., 0] > 150) & (rgb[..., 1] < 90) & (rgb[..., 2] < 90)
    assert red.sum() > 200, red.sum()
