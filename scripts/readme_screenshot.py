"""Makes docs/report.png for the README: the centre scene's benchmark figure and
3D playback from a fresh `selfcd demo` report, in Debian's headless Chromium.

Usage: python scripts/readme_screenshot.py [REPORT_DIR]   (default: selfcd-report)
"""

from __future__ import annotations

import io
import sys
from pathlib import Path

from PIL import Image
from playwright.sync_api import sync_playwright

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run"]
SCENE = 2  # the centre scene (paper figure 8)


def main() -> None:
    report = Path(sys.argv[1] if len(sys.argv) > 1 else "selfcd-report") / "index.html"
    out = Path(__file__).resolve().parent.parent / "docs" / "report.png"
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=FLAGS)
        page = browser.new_page(viewport={"width": 1200, "height": 900})
        page.goto(report.resolve().as_uri())
        page.wait_for_timeout(3000)
        chart = page.locator(f"#bench-{SCENE}")
        chart.scroll_into_view_if_needed()
        left = Image.open(io.BytesIO(chart.screenshot()))
        page.evaluate("""async (k) => {
            const el = document.getElementById('view-' + k);
            const steps = el.layout.sliders[0].steps;
            await Plotly.animate(el, [steps[Math.floor(steps.length * 0.6)].args[0][0]],
                                 {frame: {duration: 0, redraw: true}, mode: 'immediate'});
        }""", SCENE)
        view = page.locator(f"#view-{SCENE}")
        view.scroll_into_view_if_needed()
        page.wait_for_timeout(800)
        right = Image.open(io.BytesIO(view.screenshot()))
        browser.close()
    right = right.crop((right.width // 2 - 330, 40, right.width // 2 + 470, right.height - 90))
    scale = left.height / right.height
    right = right.resize((int(right.width * scale), left.height))
    both = Image.new("RGB", (left.width + right.width, left.height), "white")
    both.paste(left, (0, 0))
    both.paste(right, (left.width, 0))
    both = both.resize((both.width * 2 // 3, both.height * 2 // 3), Image.LANCZOS)
    out.parent.mkdir(exist_ok=True)
    both.convert("P", palette=Image.ADAPTIVE, colors=128).save(out, optimize=True)
    print(out, both.size, out.stat().st_size, "bytes")


if __name__ == "__main__":
    main()
