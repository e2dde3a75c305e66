"""The report of `selfcd detect --report DIR`: one self-contained HTML page
(plotly.js embedded, no network) plus summary.json.

The page shows the intersecting-pair count of every frame, a 3D view of one
frame (the worst by default) with its intersecting triangles in red and the
segments where they cross drawn in black, and a table of that frame's pairs.
summary.json holds "frames": one object per frame with at least "label" and
"pairs" (the count).
"""

from __future__ import annotations

import html
import json
from pathlib import Path
from typing import Any

import numpy as np
import plotly.graph_objects as go
from plotly.offline import get_plotlyjs

from .check import DetectRun
from .report import CLOTH, CONTACT, CSS, figure_div
from .segments import segments

#: Pairs listed in the page's table at most (summary.json has them all).
MAX_TABLE_ROWS = 2000
SEGMENT_COLOR = "#111111"


def counts_figure(run: DetectRun, shown: int) -> go.Figure:
    """Intersecting pairs per frame; the frame shown in 3D marked."""
    counts = run.counts()
    x = np.arange(len(counts))
    fig = go.Figure(go.Bar(x=x, y=counts, marker_color=CONTACT, name="intersecting pairs",
                           hovertext=run.labels[: len(counts)], hovertemplate="%{hovertext}: %{y} pairs"))
    fig.add_vline(x=shown, line=dict(color="#444", dash="dot"))
    fig.update_layout(height=300, margin=dict(l=60, r=20, t=30, b=40), template="plotly_white",
                      xaxis=dict(title="frame", tickformat="d"), yaxis_title="intersecting pairs", bargap=0.1)
    return fig


def frame_figure(positions: np.ndarray, faces: np.ndarray, pairs: np.ndarray, segs: np.ndarray,
                 up: str = "z") -> go.Figure:
    """3D view of one frame, `up` ("x", "y" or "z") pointing up: intersecting faces red, their
    intersection segments black."""
    colors = np.full(len(faces), CLOTH, dtype=object)
    if len(pairs):
        colors[np.unique(pairs)] = CONTACT
    p = positions
    data: list[Any] = [go.Mesh3d(x=p[:, 0], y=p[:, 1], z=p[:, 2], i=faces[:, 0], j=faces[:, 1], k=faces[:, 2],
                                 facecolor=colors.tolist(), flatshading=True, name="mesh", showscale=False,
                                 lighting=dict(ambient=0.55, diffuse=0.7, specular=0.1))]
    ok = segs[~np.isnan(segs).any(axis=(1, 2))]
    if len(ok):
        lines = np.concatenate([ok, np.full((len(ok), 1, 3), np.nan)], axis=1).reshape(-1, 3)
        data.append(go.Scatter3d(x=lines[:, 0], y=lines[:, 1], z=lines[:, 2], mode="lines", name="intersection",
                                 line=dict(color=SEGMENT_COLOR, width=5), connectgaps=False))
    fig = go.Figure(data=data)
    fig.update_layout(height=620, margin=dict(l=0, r=0, t=10, b=0), template="plotly_white",
                      scene=dict(aspectmode="data", camera=_camera(up)), legend=dict(x=0.01, y=0.99))
    return fig


def _camera(up: str) -> dict[str, Any]:
    """A plotly camera with axis `up` pointing up, looking from the front and a little above."""
    axes = "xyz"
    u = axes.index(up)
    front = (u + 2) % 3
    eye = {a: 0.0 for a in axes}
    eye[axes[front]], eye[axes[u]], eye[axes[(u + 1) % 3]] = 1.6, 0.6, 0.6
    return dict(up={a: float(a == up) for a in axes}, eye=eye)


def pairs_table(pairs: np.ndarray, segs: np.ndarray) -> str:
    """HTML table of a frame's pairs (the first MAX_TABLE_ROWS) with their segment lengths."""
    lengths = np.linalg.norm(segs[:, 1] - segs[:, 0], axis=1) if len(segs) else np.zeros(0)
    rows = []
    for (a, b), length in zip(pairs[:MAX_TABLE_ROWS], lengths[:MAX_TABLE_ROWS]):
        shown = "coplanar / point" if np.isnan(length) else f"{length:.4g}"
        rows.append(f"<tr><td>{a}</td><td>{b}</td><td>{shown}</td></tr>")
    more = (f"<p class=\"note\">{len(pairs) - MAX_TABLE_ROWS} more pairs in summary.json.</p>"
            if len(pairs) > MAX_TABLE_ROWS else "")
    head = "<tr><th>face</th><th>face</th><th>segment length</th></tr>"
    return f'<table id="pairs">{head}{"".join(rows)}</table>{more}'


def summary(run: DetectRun, shown: int, meta: dict[str, Any]) -> dict[str, Any]:
    """The summary.json document."""
    counts = run.counts()
    return {
        "meta": meta,
        "method": run.method,
        "vertices": int(run.frames.shape[1]),
        "triangles": int(len(run.faces)),
        "intersecting": bool(counts.any()),
        "frames_with_intersections": int(np.count_nonzero(counts)),
        "pairs_total": int(counts.sum()),
        "pairs_max": int(counts.max(initial=0)),
        "shown_frame": shown,
        "frames": [{"index": k, "label": label, "pairs": int(c), "seconds": s}
                   for k, (label, c, s) in enumerate(zip(run.labels, counts, run.seconds()))],
        "shown_pairs": run.pairs[shown].tolist() if run.pairs else [],
    }


def render_html(run: DetectRun, shown: int, doc: dict[str, Any]) -> str:
    """The whole page as a string."""
    pairs = run.pairs[shown]
    segs = segments(run.frames[shown], run.faces, pairs)
    drawn = int(np.count_nonzero(~np.isnan(segs).any(axis=(1, 2))))
    label = html.escape(run.labels[shown])
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>selfcd detect report</title>
<style>{CSS}</style><script type="text/javascript">{get_plotlyjs()}</script></head>
<body>
<h1>selfcd detect report</h1>
<p class="lede">{len(run.labels)} frame(s), {doc['vertices']} vertices, {doc['triangles']} triangles, method
{html.escape(run.method)}. {doc['frames_with_intersections']} frame(s) with intersecting triangles; at most
{doc['pairs_max']} pairs in a frame, {doc['pairs_total']} over all frames. Pairs are non-adjacent triangles
(sharing no vertex) whose closed triangles intersect, decided exactly.</p>
<h2>Intersecting pairs per frame</h2>
<div class="chart">{figure_div(counts_figure(run, shown), "counts")}</div>
<h2 id="frame-title">Frame {shown}: {label}</h2>
<p class="legend"><span style="background:{CLOTH}"></span>mesh <span style="background:{CONTACT}"></span>intersecting
triangle <span style="background:{SEGMENT_COLOR}"></span>intersection segment ({drawn} of {len(pairs)} pairs
drawn; coplanar pairs have no segment).</p>
<div class="view3d">{figure_div(frame_figure(run.frames[shown], run.faces, pairs, segs, run.up), "frame")}</div>
<h2>Pairs in frame {shown}</h2>
{pairs_table(pairs, segs)}
<p class="lede">selfcd {html.escape(str(doc['meta'].get('version', '')))}.</p>
</body></html>"""


def write_detect_report(run: DetectRun, out_dir: Path, frame: int | None = None,
                        meta: dict[str, Any] | None = None) -> dict[str, Any]:
    """Writes out_dir/index.html and out_dir/summary.json; returns the summary.

    `frame` picks the frame drawn in 3D (default: the worst); ValueError when
    it is out of range.
    """
    n = len(run.pairs)
    shown = run.worst_frame() if frame is None else frame
    if not 0 <= shown < max(n, 1):
        raise ValueError(f"--frame {frame} is out of range: {n} frame(s) were checked")
    out_dir.mkdir(parents=True, exist_ok=True)
    doc = summary(run, shown, meta or {})
    (out_dir / "summary.json").write_text(json.dumps(doc, indent=1))
    (out_dir / "index.html").write_text(render_html(run, shown, doc), encoding="utf-8")
    return doc
