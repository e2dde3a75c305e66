"""The benchmark report: one self-contained HTML page (plotly.js embedded, no
network needed) plus summary.json.

Per scene: the paper's figure (detection time and primitive tests per frame
and method, sensor-triggered frames shaded, missed contacts), a 3D playback of
the cloth with contacts highlighted and sensor particles drawn, and a summary
table over every scene and method.
"""

from __future__ import annotations

import html
import json
from pathlib import Path
from typing import Any

import numpy as np
import plotly.graph_objects as go
import plotly.io as pio
from plotly.offline import get_plotlyjs
from plotly.subplots import make_subplots

from .demo import SceneResult, missed_proximity, summarize

#: Colours per method, stable across scenes.
PALETTE = ["#7f7f7f", "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b"]
#: Playback frames at most (the animation is subsampled beyond this).
MAX_PLAYBACK_FRAMES = 120

CLOTH, CONTACT, NEAR = "#9ecae1", "#d62728", "#ffbf00"


def _colors(methods: list[str]) -> dict[str, str]:
    return {m: PALETTE[i % len(PALETTE)] for i, m in enumerate(methods)}


def _intervals(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, end] frame intervals where `mask` is true."""
    out, start = [], None
    for i, on in enumerate(mask):
        if on and start is None:
            start = i
        if not on and start is not None:
            out.append((start, i - 1))
            start = None
    if start is not None:
        out.append((start, len(mask) - 1))
    return out


def benchmark_figure(result: SceneResult, colors: dict[str, str]) -> go.Figure:
    """The paper's figure 4/6/8 for one scene: time, primitive tests and misses per frame."""
    fig = make_subplots(
        rows=3, cols=1, shared_xaxes=True, vertical_spacing=0.06,
        subplot_titles=("Detection time per frame (ms; axis cut at 1.3 x the 99th percentile)", "Primitive (triangle-triangle) tests per frame (log scale; 0 not drawn)",
                        "Contacts per frame: exact reference, and what each method missed"),
    )
    frames = np.arange(result.scene.frames.shape[0])
    for run in result.runs:
        m, s, c = run["method"], run["stats"], colors[run["method"]]
        fig.add_scatter(x=frames, y=np.asarray(s["total_time"]) * 1e3, name=m, legendgroup=m, line_color=c, row=1, col=1)
        fig.add_scatter(x=frames, y=s["primitive_tests"], name=m, legendgroup=m, line_color=c, showlegend=False,
                        row=2, col=1)
        if np.any(run["missed"]):
            fig.add_bar(x=frames, y=run["missed"], name=f"{m}: missed intersections", legendgroup=m,
                        marker_color=c, row=3, col=1)
        missed_prox = missed_proximity(result, run)
        if missed_prox is not None and np.any(missed_prox):
            fig.add_bar(x=frames, y=missed_prox, name=f"{m}: missed proximity contacts", legendgroup=m,
                        marker=dict(color=c, pattern_shape="/"), row=3, col=1)
    fig.add_scatter(x=frames, y=[len(r) for r in result.reference], name="intersecting pairs (reference)",
                    line=dict(color="black", dash="dot"), row=3, col=1)
    if result.scene.thickness > 0:
        fig.add_scatter(x=frames, y=result.proximity_counts, name="proximity contacts (reference)",
                        line=dict(color="#555", dash="dash"), row=3, col=1)
    _shade_triggers(fig, result)
    times = np.concatenate([np.asarray(run["stats"]["total_time"]) * 1e3 for run in result.runs])
    if times.size:
        fig.update_yaxes(range=[0, 1.3 * float(np.percentile(times, 99)) + 1e-6], row=1, col=1)
    fig.update_yaxes(type="log", row=2, col=1)
    fig.update_xaxes(title_text="frame", row=3, col=1)
    fig.update_layout(height=720, margin=dict(l=60, r=20, t=40, b=40), legend=dict(orientation="h", y=-0.08),
                      barmode="group", template="plotly_white")
    return fig


def _shade_triggers(fig: go.Figure, result: SceneResult) -> None:
    """Shades the frames where a sensor-gated method's sensor triggered the traversal."""
    for run in result.runs:
        trig = np.asarray(run["stats"]["triggered"])
        if (trig < 0).all():
            continue
        for a, b in _intervals(trig == 1):
            fig.add_vrect(x0=a - 0.5, x1=b + 0.5, fillcolor="#2ca02c", opacity=0.12, line_width=0, row="all", col=1)
        fig.add_scatter(x=[None], y=[None], mode="markers", marker=dict(color="#2ca02c", symbol="square", opacity=0.4),
                        name=f"{run['method']}: sensor triggered", row=1, col=1)


def _face_colors(n_faces: int, pairs: np.ndarray, near: np.ndarray) -> list[str]:
    """Cloth colour per face: proximity contacts amber, intersecting faces red."""
    colors = np.full(n_faces, CLOTH, dtype=object)
    colors[near] = NEAR
    if len(pairs):
        colors[np.unique(pairs)] = CONTACT
    return colors.tolist()


def _at(values: np.ndarray | None, f: int) -> int:
    return 0 if values is None else int(values[f])


def _frame_title(result: SceneResult, f: int) -> str:
    """Playback title: the frame's contacts and the methods that missed some."""
    missed = [run["method"] for run in result.runs
              if int(run["missed"][f]) or int(_at(missed_proximity(result, run), f))]
    text = (f"frame {f}: {len(result.reference[f])} intersecting pairs, "
            f"{int(result.proximity_counts[f])} proximity contacts")
    return text + (f"; missed by {', '.join(missed)}" if missed else "")


def playback_figure(result: SceneResult) -> go.Figure:
    """3D playback of the cloth over the frames, contacts highlighted, sensor particles drawn."""
    scene = result.scene
    n = scene.frames.shape[0]
    picks = np.unique(np.linspace(0, n - 1, min(n, MAX_PLAYBACK_FRAMES)).round().astype(int))
    F = scene.faces

    def traces(f: int) -> list[Any]:
        p = scene.frames[f]
        data = [go.Mesh3d(x=p[:, 0], y=p[:, 1], z=p[:, 2], i=F[:, 0], j=F[:, 1], k=F[:, 2],
                          facecolor=_face_colors(len(F), result.reference[f], result.proximity_faces[f]),
                          flatshading=True, name="cloth", showscale=False,
                          lighting=dict(ambient=0.55, diffuse=0.7, specular=0.1))]
        q = result.particles[f] if result.particles is not None else np.zeros((0, 3))
        data.append(go.Scatter3d(x=q[:, 0], y=q[:, 1], z=q[:, 2], mode="markers", name="sensor particles",
                                 marker=dict(size=6, color="#2ca02c", line=dict(color="black", width=1))))
        return data

    fig = go.Figure(data=traces(int(picks[0])),
                    frames=[go.Frame(data=traces(int(f)), name=str(f), traces=[0, 1],
                                      layout=dict(title_text=_frame_title(result, int(f)))) for f in picks])
    lo, hi = scene.frames.reshape(-1, 3).min(0), scene.frames.reshape(-1, 3).max(0)
    span = np.maximum(hi - lo, 1e-9)
    pad = 0.05 * span.max()
    fig.update_layout(
        height=560, margin=dict(l=0, r=0, t=40, b=0), template="plotly_white",
        title=dict(text=_frame_title(result, int(picks[0])), font=dict(size=13)),
        scene=dict(xaxis=dict(range=[lo[0] - pad, hi[0] + pad]), yaxis=dict(range=[lo[1] - pad, hi[1] + pad]),
                   zaxis=dict(range=[lo[2] - pad, hi[2] + pad]), aspectmode="manual",
                   camera=dict(eye=dict(x=1.05, y=-1.35, z=0.75)),
                   aspectratio=dict(zip("xyz", (span + 2 * pad) / (span.max() + 2 * pad)))),
        updatemenus=[dict(type="buttons", x=0.02, y=0.02, xanchor="left", yanchor="bottom", buttons=[
            dict(label="Play", method="animate",
                 args=[None, dict(frame=dict(duration=60, redraw=True), fromcurrent=True, transition=dict(duration=0))]),
            dict(label="Pause", method="animate",
                 args=[[None], dict(frame=dict(duration=0, redraw=False), mode="immediate")]),
        ])],
        sliders=[dict(active=0, x=0.15, len=0.83, y=0.02, currentvalue=dict(prefix="frame "), steps=[
            dict(label=str(f), method="animate",
                 args=[[str(f)], dict(frame=dict(duration=0, redraw=True), mode="immediate")]) for f in picks
        ])],
    )
    return fig


def summary_table(summaries: list[dict[str, Any]]) -> str:
    """HTML table: per scene and method, time per frame, primitive tests, misses, triggers."""
    head = ("<tr><th>scene</th><th>method</th><th>mean ms/frame</th><th>median ms/frame</th>"
            "<th>mean primitive tests</th><th>total primitive tests</th><th>missed intersections</th>"
            "<th>missed proximity contacts</th><th>frames with misses</th><th>sensor triggered</th></tr>")
    rows = []
    for s in summaries:
        for m, r in s["methods"].items():
            trig = "-" if r["triggered_frames"] is None else f"{r['triggered_frames']} / {r['frames']}"
            miss_cls = ' class="miss"' if r["missed_contacts"] else ""
            prox = r["missed_proximity_contacts"]
            prox_cls = ' class="miss"' if prox else ""
            rows.append(
                f"<tr><td>{html.escape(s['name'])}</td><td>{html.escape(m)}</td>"
                f"<td>{r['mean_time_ms']:.3f}</td><td>{r['median_time_ms']:.3f}</td>"
                f"<td>{r['mean_primitive_tests']:.1f}</td><td>{r['total_primitive_tests']}</td>"
                f"<td{miss_cls}>{r['missed_contacts']}</td><td{prox_cls}>{'-' if prox is None else prox}</td>"
                f"<td>{r['frames_with_misses']}</td><td>{trig}</td></tr>")
    note = ("<p class=\"note\">Times and primitive tests are for the intersection query, as in the paper. "
            "Missed proximity contacts are measured for the methods that may miss by design (the others: -), "
            "rerun with the simulator's proximity thickness, against bvh-cones-contour.</p>")
    return f'<table id="summary">{head}{"".join(rows)}</table>{note}'


CSS = """
body{font-family:system-ui,sans-serif;margin:0 auto;max-width:1200px;padding:1em 2em;color:#222}
h1{margin-bottom:0.2em} .lede{color:#555;margin-top:0}
table{border-collapse:collapse;font-size:0.9em;margin:1em 0} td,th{border:1px solid #ddd;padding:4px 8px;text-align:right}
td:first-child,td:nth-child(2),th{text-align:left} th{background:#f4f4f4} td.miss{background:#ffe9a8;font-weight:bold}
section.scene{border-top:2px solid #eee;margin-top:2em} .legend span{display:inline-block;width:1em;height:1em;
vertical-align:middle;margin:0 0.3em 0 1em;border:1px solid #999}
"""


def figure_div(fig: go.Figure, div_id: str) -> str:
    return pio.to_html(fig, include_plotlyjs=False, full_html=False, div_id=div_id,
                       config={"displaylogo": False, "responsive": True})


def _scene_section(k: int, result: SceneResult, summary: dict[str, Any], colors: dict[str, str]) -> str:
    s = summary
    figure_no = result.scene.extra.get("paper_figure")
    label = f" (paper figure {figure_no})" if figure_no else ""
    return f"""
<section class="scene" id="scene-{k}">
<h2>{html.escape(s['title'])}{label}</h2>
<p>{html.escape(s['description'])} {s['vertices']} vertices, {s['triangles']} triangles, {s['frames']} frames
{s['frame_dt'] * 1e3:.1f} ms apart; {s['frames_in_proximity']} frames with proximity contacts (at most
{s['max_proximity_contacts']}), {s['frames_intersecting']} frames with intersecting triangles (at most
{s['max_intersecting_pairs']} pairs).</p>
<div class="chart">{figure_div(benchmark_figure(result, colors), f"bench-{k}")}</div>
<h3>Playback</h3>
<p class="legend"><span style="background:{CLOTH}"></span>cloth <span style="background:{NEAR}"></span>proximity
contact (closer than {s['proximity_thickness']:.3g} m) <span style="background:{CONTACT}"></span>intersecting
<span style="background:#2ca02c"></span>sensor particles. The title names the methods that missed contacts in the frame.</p>
<div class="view3d">{figure_div(playback_figure(result), f"view-{k}")}</div>
</section>"""


def render_html(results: list[SceneResult], summaries: list[dict[str, Any]], meta: dict[str, Any]) -> str:
    """The whole report page as a string."""
    methods = [run["method"] for run in results[0].runs] if results else []
    colors = _colors(methods)
    sections = "".join(_scene_section(k, r, s, colors) for k, (r, s) in enumerate(zip(results, summaries)))
    note = html.escape(meta.get("note", ""))
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>selfcd benchmark report</title>
<style>{CSS}</style><script type="text/javascript">{get_plotlyjs()}</script></head>
<body>
<h1>selfcd benchmark report</h1>
<p class="lede">Self-collision detection on the cloth scenes of the paper <i>A Combination of Hierarchical
Structures and Particle Systems for Self-Collision Detection of Deforming Objects</i>.
Every method runs on the same recorded frames; misses are counted against the exact reference.
Methods: {html.escape(", ".join(methods))}. {note}</p>
<h2>Summary</h2>
{summary_table(summaries)}
{sections}
<p class="lede">selfcd {html.escape(str(meta.get("version", "")))}; generated in {meta.get("seconds", 0):.1f} s.</p>
</body></html>"""


def write_report(results: list[SceneResult], out_dir: Path, meta: dict[str, Any]) -> dict[str, Any]:
    """Writes out_dir/index.html and out_dir/summary.json; returns the summary."""
    out_dir.mkdir(parents=True, exist_ok=True)
    summaries = [summarize(r) for r in results]
    summary = {"meta": meta, "scenes": summaries}
    (out_dir / "summary.json").write_text(json.dumps(summary, indent=2))
    (out_dir / "index.html").write_text(render_html(results, summaries, meta), encoding="utf-8")
    return summary
