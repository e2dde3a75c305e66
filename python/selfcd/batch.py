"""`selfcd batch`: check many meshes and animations, on local processes or a Ray cluster.

Each input is a mesh file, an animation file (.npz with V of shape
(frames, n, 3), USD with time-sampled points) or a directory of frame files
(one animation, files in natural order: frame2 before frame10). Each input
gives one row: frames, triangles, frames with intersections, total and
largest per-frame pair count, seconds; a bad input gives a row whose "error"
says why, and the others go on.

Work is spread one input per task: over local processes
(concurrent.futures), or over Ray (`pip install "selfcd[ray]"`): "local"
starts Ray on this machine, an address ("host:port") joins a running
cluster. Workers read the inputs themselves, so on a cluster the paths must be
visible to every machine (shared storage). Ray is imported only when asked for.
"""

from __future__ import annotations

import csv
import html
import multiprocessing
import re
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

from . import _api
from . import io as mesh_io
from .check import check_frames

#: Columns of results.csv, in order.
COLUMNS = ["input", "frames", "triangles", "frames_with_intersections", "pairs_total", "pairs_max", "seconds",
           "error"]
#: File suffixes taken as frames inside a directory input.
FRAME_SUFFIXES = {".obj", ".ply", ".stl", ".off", ".glb", ".gltf", ".npz", ".usd", ".usda", ".usdc"}


def natural_key(name: str) -> list[Any]:
    """Sort key that orders digit runs by value: "f2" < "f10"."""
    return [int(part) if part.isdigit() else part.lower() for part in re.split(r"(\d+)", name)]


def frame_files(directory: Path) -> list[Path]:
    """The mesh files of a directory, in natural order; MeshFileError when there are none."""
    files = sorted((p for p in directory.iterdir() if p.is_file() and p.suffix.lower() in FRAME_SUFFIXES),
                   key=lambda p: natural_key(p.name))
    if not files:
        raise mesh_io.MeshFileError(f"{directory}: no mesh files ({', '.join(sorted(FRAME_SUFFIXES))})")
    return files


def check_input(path: str, method: str = _api.DEFAULT_METHOD) -> dict[str, Any]:
    """One results row for one input; never raises for a bad input (the row's "error" says why)."""
    t0 = time.perf_counter()
    row: dict[str, Any] = {c: "" for c in COLUMNS}
    row["input"] = path
    try:
        p = Path(path)
        files = frame_files(p) if p.is_dir() else [p]
        frames, faces, labels = mesh_io.load_sequence(files)
        counts = check_frames(frames, faces, labels, method, weld=mesh_io.weld_by_default(files)).counts()
    except (ValueError, TypeError, OSError, MemoryError) as exc:
        row["error"] = f"{type(exc).__name__}: {exc}"
    else:
        row.update(frames=int(len(frames)), triangles=int(len(faces)),
                   frames_with_intersections=int((counts > 0).sum()), pairs_total=int(counts.sum()),
                   pairs_max=int(counts.max(initial=0)))
    row["seconds"] = round(time.perf_counter() - t0, 6)
    return row


Progress = Callable[[int], None]


def run_local(inputs: list[str], method: str, workers: int, progress: Progress | None = None) -> list[dict[str, Any]]:
    """Rows for `inputs` in order, on `workers` local processes (1: in this process)."""
    if workers <= 1:
        rows = []
        for k, path in enumerate(inputs):
            rows.append(check_input(path, method))
            if progress:
                progress(k + 1)
        return rows
    out: list[dict[str, Any] | None] = [None] * len(inputs)
    # "spawn": a forked child would inherit the engine's thread pool without its threads and hang
    with ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        futures = {pool.submit(check_input, path, method): k for k, path in enumerate(inputs)}
        for done, fut in enumerate(as_completed(futures), 1):
            out[futures[fut]] = fut.result()
            if progress:
                progress(done)
    return [r for r in out if r is not None]


def run_ray(inputs: list[str], method: str, address: str, workers: int | None = None,
            progress: Progress | None = None) -> list[dict[str, Any]]:
    """Rows for `inputs` in order, one Ray task per input.

    `address` "local" starts Ray on this machine (with `workers` CPUs, default
    all); any other value is a running cluster's address. A Ray already
    initialised in this process (a notebook, a test) is used as it is.
    """
    try:
        import ray
    except ImportError:
        raise RuntimeError('--ray needs Ray: pip install "selfcd[ray]"') from None
    started = not ray.is_initialized()
    if started:
        if address == "local":
            ray.init(address="local", num_cpus=workers, include_dashboard=False, log_to_driver=False)
        else:
            ray.init(address=address, log_to_driver=False)
    try:
        task = ray.remote(num_cpus=1)(check_input)
        refs = [task.remote(path, method) for path in inputs]
        pending, done = list(refs), 0
        while pending:
            ready, pending = ray.wait(pending, num_returns=1)
            done += len(ready)
            if progress:
                progress(done)
        return list(ray.get(refs))
    finally:
        if started:
            ray.shutdown()


def write_csv(rows: list[dict[str, Any]], path: Path) -> None:
    """results.csv: one row per input, the COLUMNS."""
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=COLUMNS)
        writer.writeheader()
        writer.writerows(rows)


def render_index(rows: list[dict[str, Any]], meta: dict[str, Any]) -> str:
    """index.html: a chart of the largest per-frame pair count per input and the table of rows."""
    import plotly.graph_objects as go
    from plotly.offline import get_plotlyjs

    from .report import CONTACT, CSS, figure_div

    ok = [r for r in rows if not r["error"]]
    fig = go.Figure(go.Bar(x=[Path(r["input"]).name for r in ok], y=[r["pairs_max"] for r in ok],
                           hovertext=[r["input"] for r in ok], marker_color=CONTACT))
    fig.update_layout(height=320, margin=dict(l=60, r=20, t=20, b=80), template="plotly_white",
                      yaxis_title="most pairs in a frame")
    head = "".join(f"<th>{c}</th>" for c in COLUMNS)
    body = []
    for r in rows:
        cls = ' class="miss"' if r["error"] or r["pairs_total"] else ""
        body.append(f"<tr{cls}>" + "".join(f"<td>{html.escape(str(r[c]))}</td>" for c in COLUMNS) + "</tr>")
    bad = sum(1 for r in rows if r["error"])
    hit = sum(1 for r in ok if r["pairs_total"])
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>selfcd batch</title>
<style>{CSS}</style><script type="text/javascript">{get_plotlyjs()}</script></head>
<body>
<h1>selfcd batch</h1>
<p class="lede">{len(rows)} input(s), method {html.escape(str(meta.get('method', '')))}, run on
{html.escape(str(meta.get('runner', '')))} in {meta.get('seconds', 0):.1f} s: {hit} with self-intersections,
{bad} unreadable or invalid.</p>
<div class="chart">{figure_div(fig, "pairs-max")}</div>
<table id="results"><tr>{head}</tr>{"".join(body)}</table>
</body></html>"""


def write_results(rows: list[dict[str, Any]], out_dir: Path, meta: dict[str, Any]) -> None:
    """Writes out_dir/results.csv and out_dir/index.html."""
    out_dir.mkdir(parents=True, exist_ok=True)
    write_csv(rows, out_dir / "results.csv")
    (out_dir / "index.html").write_text(render_index(rows, meta), encoding="utf-8")
