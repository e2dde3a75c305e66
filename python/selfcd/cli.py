"""The `selfcd` command line: demo (the paper's benchmark report), detect, simulate, bench."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path
from typing import Any

import click
import numpy as np
from tqdm import tqdm

from . import _api, bench as bench_mod, demo as demo_mod, io as mesh_io


class InputError(click.ClickException):
    """Bad input (unreadable file, invalid mesh): exit status 2, so 1 can mean "intersections found"."""

    exit_code = 2


def _bar(total: int, desc: str) -> tqdm:
    """A progress bar on stderr; hidden on very short runs and when not a terminal."""
    return tqdm(total=total, desc=desc, unit="step", leave=False, mininterval=0.5, delay=1.0, file=sys.stderr,
                disable=None)


def _method_choice() -> click.Choice:
    return click.Choice(_api.methods())


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="selfcd")
def main() -> None:
    """selfcd: self-collision detection for deforming triangle meshes (cloth).

    Start with `selfcd demo`: it reproduces the paper's benchmark as a report.
    """


# ---------------------------------------------------------------- demo


def _table(summary: dict[str, Any]) -> str:
    """A short text table: per scene and method, time per frame, primitive tests, misses."""
    lines = [f"{'scene':<14}{'method':<20}{'mean ms':>9}{'median ms':>11}{'prim. tests':>13}{'missed':>8}{'trig.':>7}"]
    for s in summary["scenes"]:
        for m, r in s["methods"].items():
            trig = "-" if r["triggered_frames"] is None else str(r["triggered_frames"])
            lines.append(f"{s['name']:<14}{m:<20}{r['mean_time_ms']:>9.3f}{r['median_time_ms']:>11.3f}"
                         f"{r['mean_primitive_tests']:>13.1f}{r['missed_contacts']:>8}{trig:>7}")
    return "\n".join(lines)


@main.command()
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("selfcd-report"),
              show_default=True, help="Folder for index.html and summary.json.")
@click.option("--frames", type=click.IntRange(2, 100000), default=None,
              help="Frames per scene (default: the scene's own length).")
@click.option("--resolution", type=click.IntRange(3, 400), default=demo_mod.PAPER_RESOLUTION, show_default=True,
              help="Vertices per side of the square cloth (11: the paper's 200 triangles).")
@click.option("--method", "methods", type=_method_choice(), multiple=True,
              help="Methods to compare (repeatable; default: every method).")
def demo(out_dir: Path, frames: int | None, resolution: int, methods: tuple[str, ...]) -> None:
    """Run the paper's three scenes through every detector and write a report.

    Each scene is recorded once; every method then runs on the same frames and
    its misses are counted against the exact reference. Writes OUT/index.html
    (self-contained, open it in a browser) and OUT/summary.json.
    """
    t0 = time.perf_counter()
    chosen = list(methods) or None
    results = []
    for scene in demo_mod.paper_scenes(frames, resolution, progress=_bar):
        n_methods = len(chosen or _api.methods())
        with _bar(n_methods * len(scene.frames), f"{scene.name}: detect") as bar:
            results.append(demo_mod.evaluate(scene, chosen, progress=lambda done: bar.update(done - bar.n)))
    meta = {"version": _api_version(), "seconds": time.perf_counter() - t0, "resolution": resolution,
            "note": demo_mod.scenes_note()}
    from .report import write_report  # plotly is imported only when a report is written

    summary = write_report(results, out_dir, meta)
    click.echo(_table(summary))
    click.echo(f"\nReport: {(out_dir / 'index.html').resolve()}  ({time.perf_counter() - t0:.1f} s)")


def _api_version() -> str:
    from . import __version__

    return __version__


# ---------------------------------------------------------------- detect


@main.command()
@click.argument("files", nargs=-1, required=True, type=click.Path(dir_okay=False, path_type=Path))
@click.option("--method", type=_method_choice(), default=_api.DEFAULT_METHOD, show_default=True)
@click.option("--json", "as_json", is_flag=True, help="Print machine-readable JSON instead of text.")
@click.option("--max-pairs", type=click.IntRange(0), default=10, show_default=True,
              help="Pairs listed per file in text output.")
def detect(files: tuple[Path, ...], method: str, as_json: bool, max_pairs: int) -> None:
    """Find self-intersecting triangle pairs in mesh FILES (OBJ, PLY, ... or .npz with V and F).

    Several files are one animation sharing faces (the first file is the rest
    shape). Exit status: 0 no intersection, 1 some intersection, 2 bad input.
    """
    try:
        frames, faces = mesh_io.load_sequence(list(files))
        det = _api.Detector(_api.Mesh(frames[0], faces), method)
    except (ValueError, TypeError) as exc:
        raise InputError(str(exc)) from None
    records = []
    for path, positions in zip(tqdm(files, desc="detect", leave=False, delay=1.0, disable=None), frames):
        pairs = det.detect(positions)
        records.append({"file": str(path), "count": int(len(pairs)), "pairs": pairs.tolist(),
                        "stats": det.last_stats})
    any_hit = any(r["count"] for r in records)
    if as_json:
        click.echo(json.dumps({"method": method, "intersecting": any_hit, "files": records}, indent=2))
    else:
        for r in records:
            _print_record(r, max_pairs)
    sys.exit(1 if any_hit else 0)


def _print_record(r: dict[str, Any], max_pairs: int) -> None:
    ms = r["stats"]["total_time"] * 1e3
    click.echo(f"{r['file']}: {r['count']} intersecting triangle pairs ({ms:.2f} ms)")
    shown = r["pairs"][:max_pairs]
    if shown:
        more = f" ... and {r['count'] - len(shown)} more" if r["count"] > len(shown) else ""
        click.echo("  " + " ".join(f"({a},{b})" for a, b in shown) + more)


# ---------------------------------------------------------------- bench


@main.command()
@click.option("--sizes", default="200,2000,20000", show_default=True, help="Triangle counts, comma-separated.")
@click.option("--states", default=None, help="States, comma-separated (default: all of flat, crumpled, folded).")
@click.option("--method", "methods", type=_method_choice(), multiple=True, help="Methods (default: all).")
@click.option("--repeats", type=click.IntRange(1), default=3, show_default=True, help="Detections per row (median).")
@click.option("--brute-limit", type=click.IntRange(0), default=2000, show_default=True,
              help="Skip brute force above this many triangles.")
@click.option("--json", "json_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Also write the rows as JSON to this file ('-': JSON on stdout instead of the table).")
def bench(sizes: str, states: str | None, methods: tuple[str, ...], repeats: int, brute_limit: int,
          json_path: Path | None) -> None:
    """Scaling benchmark: mesh sizes x states x methods; build, refit and traversal times."""
    try:
        size_list = [int(s) for s in sizes.split(",") if s.strip()]
    except ValueError:
        raise click.BadParameter(f"not a list of integers: {sizes}", param_hint="--sizes") from None
    known = bench_mod.states()
    state_list = known if states is None else [s.strip() for s in states.split(",") if s.strip()]
    bad = [s for s in state_list if s not in known]
    if bad:
        raise click.BadParameter(f"unknown state {bad[0]!r}; expected {', '.join(known)}", param_hint="--states")
    method_list = list(methods) or _api.methods()
    with _bar(len(size_list) * len(state_list) * len(method_list), "bench") as bar:
        rows = bench_mod.run(size_list, state_list, method_list, repeats, brute_limit,
                             progress=lambda done: bar.update(done - bar.n))
    if json_path is not None and str(json_path) == "-":
        click.echo(json.dumps(rows, indent=2))
        return
    click.echo(bench_mod.table(rows))
    if json_path is not None:
        json_path.write_text(json.dumps(rows, indent=2))
        click.echo(f"\nJSON: {json_path}")


if __name__ == "__main__":  # pragma: no cover
    main()
