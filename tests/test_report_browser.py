"""The report opened in real headless Chromium (Debian's, driven by playwright):
charts and the WebGL 3D view render, no error overlay, a screenshot is saved."""

from __future__ import annotations

import io
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from PIL import Image
from playwright.sync_api import sync_playwright

CHROMIUM = os.environ.get("SELFCD_CHROMIUM", "/usr/bin/chromium")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run"]
#: Where screenshots go (kept after the run for a person to look at).
SHOTS = Path(os.environ.get("SELFCD_SCREENSHOTS", Path(__file__).parent / "screenshots"))


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("report")
    done = subprocess.run([sys.executable, "-m", "selfcd", "demo", "--frames", "12", "--out", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return out / "index.html"


@pytest.fixture(scope="module")
def page(report: Path, tmp_path_factory: pytest.TempPathFactory):
    assert shutil.which(CHROMIUM) or Path(CHROMIUM).exists(), f"{CHROMIUM} missing: run scripts/test.sh"
    profile = tmp_path_factory.mktemp("chromium-profile")
    with sync_playwright() as p:
        browser = p.chromium.launch_persistent_context(
            str(profile), executable_path=CHROMIUM, headless=True, args=FLAGS,
            viewport={"width": 1280, "height": 1000})
        pg = browser.new_page()
        pg.errors = []
        pg.on("pageerror", lambda e: pg.errors.append(str(e)))
        pg.on("console", lambda m: pg.errors.append(m.text) if m.type == "error" else None)
        pg.goto(report.as_uri())
        pg.wait_for_function("() => document.querySelectorAll('.js-plotly-plot').length >= 6", timeout=60000)
        pg.wait_for_timeout(1500)
        yield pg
        browser.close()


def test_page_loads_without_errors(page) -> None:
    assert page.errors == []
    assert page.title() == "selfcd benchmark report"
    assert page.locator("#summary tr").count() > 1


def test_benchmark_charts_draw_every_method(page) -> None:
    for k in range(3):
        names = page.eval_on_selector(f"#bench-{k}", "el => el.data.map(t => t.name)")
        traces = page.locator(f"#bench-{k} .scatterlayer .trace").count()
        assert "intersecting pairs (reference)" in names and "proximity contacts (reference)" in names and traces >= 2 * 4 + 1, (k, names)
        assert page.locator(f"#bench-{k} .scatterlayer path.js-line").count() > 0


def _cloth_pixels(png: bytes) -> tuple[int, int]:
    """(pixels that are not background, pixels of cloth blue) in a screenshot."""
    img = Image.open(io.BytesIO(png)).convert("RGB")
    px = list(zip(*(iter(img.tobytes()),) * 3))
    non_white = sum(1 for r, g, b in px if r + g + b < 720)
    blue = sum(1 for r, g, b in px if b > r + 30 and b > 120)
    return non_white, blue


def test_webgl_view_renders_the_cloth(page) -> None:
    SHOTS.mkdir(parents=True, exist_ok=True)
    for k in range(3):
        view = page.locator(f"#view-{k}")
        view.scroll_into_view_if_needed()
        page.wait_for_timeout(500)
        assert page.locator(f"#view-{k} canvas").count() >= 1, "no WebGL canvas"
        text = view.inner_text()
        assert "WebGL" not in text, f"plotly error overlay: {text[:200]}"
        _, blue = _cloth_pixels(view.screenshot(path=str(SHOTS / f"view-{k}.png")))
        assert blue > 2000, f"scene {k}: the 3D view looks blank ({blue} cloth pixels)"


def _show_frame(page, step: int) -> str:
    """Animates the scene-0 playback to slider step `step` (negative: from the end); returns the frame name."""
    return page.evaluate("""async (step) => {
        const el = document.getElementById('view-0');
        const steps = el.layout.sliders[0].steps;
        const name = steps[(step + steps.length) % steps.length].args[0][0];
        await Plotly.animate(el, [name], {frame: {duration: 0, redraw: true}, mode: 'immediate'});
        return name;
    }""", step)


def test_playback_slider_moves_the_cloth(page) -> None:
    view = page.locator("#view-0")
    view.scroll_into_view_if_needed()
    first = _show_frame(page, 0)
    page.wait_for_timeout(800)
    before = _cloth_pixels(view.screenshot(path=str(SHOTS / "view-0-first.png")))
    last = _show_frame(page, -1)
    page.wait_for_timeout(800)
    after = _cloth_pixels(view.screenshot(path=str(SHOTS / "view-0-last.png")))
    assert int(first) < int(last) and after != before, (first, last, before, after)


def test_full_page_screenshot(page) -> None:
    SHOTS.mkdir(parents=True, exist_ok=True)
    page.evaluate("() => window.scrollTo(0, 0)")
    path = SHOTS / "report.png"
    page.screenshot(path=str(path), full_page=True)
    non_white, _ = _cloth_pixels(path.read_bytes())
    assert non_white > 100000
