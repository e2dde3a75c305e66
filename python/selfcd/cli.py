"""The `selfcd` command line: demo (the paper's benchmark report), detect, simulate, bench."""

from __future__ import annotations

import json
import sys
import time
import warnings
from functools import partial
from pathlib import Path
from typing import Any

import click
import numpy as np
from tqdm import tqdm

from . import _api
from . import bench as bench_mod
from . import demo as demo_mod
from . import io as mesh_io
from .check import DetectRun, check_frames
from .weld import UnweldedMeshWarning


class InputError(click.ClickException):
    """Bad input (unreadable file, invalid mesh): exit status 2, so 1 can mean "intersections found"."""

    exit_code = 2


def _bar(total: int, desc: str) -> tqdm:
    """A progress bar on stderr; hidden on very short runs and when not a terminal."""
    return tqdm(total=total, desc=desc, unit="step", leave=False, mininterval=0.5, delay=1.0, file=sys.stderr,
                disable=None)


def _method_choice() -> click.Choice:
    return click.Choice(_api.methods())


class _Group(click.Group):
    """The command group; Ctrl-C ends any command with exit status 130 (128 + SIGINT), not click's 1."""

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt:
            click.echo("\nInterrupted.", err=True)
            raise click.exceptions.Exit(130) from None


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="selfcd")
def main() -> None:
    """selfcd: self-collision detection for deforming triangle meshes (cloth).

    Start with `selfcd demo`: it reproduces the paper's benchmark as a report.
    """


# ---------------------------------------------------------------- demo


def _table(summary: dict[str, Any]) -> str:
    """A short text table: per scene and method, time per frame, primitive tests, misses."""
    lines = [f"{'scene':<13}{'method':<19}{'mean ms':>9}{'median ms':>11}{'prim. tests':>13}{'missed int.':>12}"
             f"{'missed prox.':>13}{'triggered':>10}"]
    for s in summary["scenes"]:
        for m, r in s["methods"].items():
            trig = "-" if r["triggered_frames"] is None else str(r["triggered_frames"])
            lines.append(f"{s['name']:<13}{m:<19}{r['mean_time_ms']:>9.3f}{r['median_time_ms']:>11.3f}"
                         f"{r['mean_primitive_tests']:>13.1f}{r['missed_contacts']:>12}"
                         f"{'-' if r['missed_proximity_contacts'] is None else r['missed_proximity_contacts']:>13}{trig:>10}")
    return "\n".join(lines)


@main.command()
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("selfcd-report"),
              show_default=True, help="Folder for index.html and summary.json.")
@click.option("--frames", type=click.IntRange(2, 100000), default=demo_mod.DEFAULT_FRAMES, show_default=True,
              help=f"Frames recorded per scene, {demo_mod.STEPS_PER_FRAME} simulation steps apart.")
@click.option("--resolution", type=click.IntRange(3, 400), default=demo_mod.PAPER_RESOLUTION, show_default=True,
              help="Vertices per side of the square cloth (11: the paper's 200 triangles).")
@click.option("--method", "methods", type=_method_choice(), multiple=True,
              help="Methods to compare (repeatable; default: every method).")
def demo(out_dir: Path, frames: int, resolution: int, methods: tuple[str, ...]) -> None:
    """Run the paper's three cloth scenes through every detector and write a report.

    Each scene (cloth pinned at two corners, one corner, the centre) is
    simulated once; every method then runs on the same recorded frames and its
    misses are counted against the exact reference. Writes OUT/index.html
    (self-contained, open it in a browser) and OUT/summary.json.
    """
    from .report import write_report  # plotly is imported only when a report is written

    t0 = time.perf_counter()
    chosen = list(methods) or None
    results = []
    for scene in demo_mod.paper_scenes(frames, resolution, progress=_bar):
        n_methods = len(chosen or _api.methods())
        with _bar(n_methods * len(scene.frames), f"{scene.name}: detect") as bar:
            results.append(demo_mod.evaluate(scene, chosen, progress=lambda done: bar.update(done - bar.n)))
    meta = {"version": _api_version(), "seconds": time.perf_counter() - t0, "resolution": resolution,
            "note": demo_mod.scenes_note()}
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
@click.option("--report", "report_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Also write REPORT/index.html (pairs per frame, 3D view, table) and REPORT/summary.json.")
@click.option("--frame", type=click.IntRange(0), default=None,
              help="Frame drawn in the report's 3D view (default: the one with the most pairs).")
@click.option("--any", "stop_at_first", is_flag=True,
              help="Stop at the first frame with an intersection (exit status 1).")
@click.option("--weld/--no-weld", default=None,
              help="Merge vertices at exactly equal positions first, so a triangle soup's neighbours are adjacent "
                   "(default: on for .stl files, off otherwise).")
def detect(files: tuple[Path, ...], method: str, as_json: bool, max_pairs: int, report_dir: Path | None,
           frame: int | None, stop_at_first: bool, weld: bool | None) -> None:
    """Find self-intersecting triangle pairs in mesh FILES (OBJ, PLY, STL, OFF, glTF, .npz, USD).

    Several files are one animation sharing faces (the first frame is the rest
    shape); an .npz whose V is (frames, n, 3), as `selfcd simulate` writes, and
    a USD mesh with time-sampled points are animations too. Exit status: 0 no
    intersection, 1 some intersection, 2 bad input, 130 interrupted.
    """
    if weld is None:
        weld = mesh_io.weld_by_default(list(files))
    bar = partial(tqdm, desc="detect", unit="frame", leave=False, delay=1.0, disable=None)
    try:
        frames, faces, labels = mesh_io.load_sequence(list(files))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", UnweldedMeshWarning)
            run = check_frames(frames, faces, labels, method, stop_at_first, wrap=bar, weld=weld)
        for w in caught:
            click.echo(f"Warning: {w.message}", err=True)
    except (ValueError, TypeError) as exc:
        raise InputError(str(exc)) from None
    run.up = mesh_io.up_axis(files[0])
    records = [{"file": label, "count": int(len(p)), "pairs": p, "stats": s}
               for label, p, s in zip(run.labels, run.pairs, run.stats)]
    any_hit = bool(run.counts().any())
    if report_dir is not None:
        _write_detect_report(run, report_dir, frame)
    if as_json:
        for r in records:
            r["pairs"] = r["pairs"].tolist()
        click.echo(json.dumps({"method": method, "intersecting": any_hit, "files": records}, indent=2))
    else:
        for r in records:
            _print_record(r, max_pairs)
        if report_dir is not None:
            click.echo(f"Report: {(report_dir / 'index.html').resolve()}")
    sys.exit(1 if any_hit else 0)


def _write_detect_report(run: DetectRun, out_dir: Path, frame: int | None) -> None:
    """Writes the detect report for the frames checked (all, or up to the first hit with --any)."""
    from .detect_report import write_detect_report  # plotly is imported only for a report

    try:
        write_detect_report(run, out_dir, frame, {"version": _api_version()})
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--frame") from None
    except OSError as exc:
        raise click.ClickException(f"cannot write the report to {out_dir}: {exc}") from None


def _print_record(r: dict[str, Any], max_pairs: int) -> None:
    ms = r["stats"]["total_time"] * 1e3
    click.echo(f"{r['file']}: {r['count']} intersecting triangle pairs ({ms:.2f} ms)")
    shown = r["pairs"][:max_pairs].tolist()
    if shown:
        more = f" ... and {r['count'] - len(shown)} more" if r["count"] > len(shown) else ""
        click.echo("  " + " ".join(f"({a},{b})" for a, b in shown) + more)


# ---------------------------------------------------------------- batch


@main.command()
@click.argument("inputs", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), required=True,
              help="Folder for results.csv and index.html.")
@click.option("--method", type=_method_choice(), default=_api.DEFAULT_METHOD, show_default=True)
@click.option("--workers", type=click.IntRange(1, 4096), default=None,
              help="Processes (or, with --ray local, Ray CPUs); default: every CPU.")
@click.option("--ray", "ray_address", default=None, metavar="local|ADDRESS",
              help='Run on Ray: "local" starts it on this machine, ADDRESS (host:port) joins a cluster. '
                   'Needs pip install "selfcd[ray]".')
def batch(inputs: tuple[Path, ...], out_dir: Path, method: str, workers: int | None, ray_address: str | None) -> None:
    """Check many meshes and animations; write OUT/results.csv and OUT/index.html.

    Each INPUT is a mesh file, an animation file (.npz, USD) or a directory of
    frame files (one animation, in natural order). results.csv has one row per
    input: input, frames, triangles, frames_with_intersections, pairs_total,
    pairs_max, seconds, and error (why a bad input could not be checked; the
    others go on). Exit status: 0 nothing intersects, 1 some input
    self-intersects, 2 some input could not be checked.
    """
    import os

    from . import batch as batch_mod

    paths = [str(p) for p in inputs]
    n_workers = workers or min(os.cpu_count() or 1, len(paths))
    t0 = time.perf_counter()
    with _bar(len(paths), "batch") as bar:
        update = lambda done: bar.update(done - bar.n)  # noqa: E731
        try:
            if ray_address is None:
                rows = batch_mod.run_local(paths, method, n_workers, update)
            else:
                rows = batch_mod.run_ray(paths, method, ray_address, workers, update)
        except RuntimeError as exc:
            raise click.ClickException(str(exc)) from None
    runner = f"{n_workers} local process(es)" if ray_address is None else f"Ray ({ray_address})"
    try:
        batch_mod.write_results(rows, out_dir, {"method": method, "runner": runner,
                                                "seconds": time.perf_counter() - t0})
    except OSError as exc:
        raise click.ClickException(f"cannot write results to {out_dir}: {exc}") from None
    bad = [r for r in rows if r["error"]]
    hit = [r for r in rows if not r["error"] and r["pairs_total"]]
    for r in rows:
        click.echo(f"{r['input']}: " + (f"error: {r['error']}" if r["error"] else
                                        f"{r['frames']} frame(s), {r['frames_with_intersections']} with "
                                        f"intersections, at most {r['pairs_max']} pairs"))
    click.echo(f"Results: {(out_dir / 'results.csv').resolve()}  index: {(out_dir / 'index.html').resolve()}")
    sys.exit(2 if bad else 1 if hit else 0)


# ---------------------------------------------------------------- simulate


@main.command()
@click.option("--scene", type=click.Choice(_api.paper_scenes()), default=None,
              help="One of the paper's cloth scenes (or give --mesh).")
@click.option("--mesh", "mesh_file", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Cloth mesh file (OBJ, PLY, ... or .npz with V and F): its positions are the start.")
@click.option("--rest", "rest_file", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Rest shape with the same triangles as --mesh (say, a flat sewing pattern); default: the mesh.")
@click.option("--pin", "pin_specs", multiple=True, metavar="SPEC",
              help="Pinned vertices: top:FRACTION (within that fraction of the height of the top), "
                   "indices:FILE (ids, text or .npy), box:x0,y0,z0,x1,y1,z1. Repeatable.")
@click.option("--obstacle", "obstacle_paths", multiple=True, type=click.Path(path_type=Path), metavar="PATH",
              help="Obstacle: a mesh file (static), a directory of frame files (natural order) or an .npz with "
                   "V (frames, n, 3) and F; played one frame per output frame, interpolated. Repeatable.")
@click.option("--up", type=click.Choice(["x", "y", "z"]), default="z", show_default=True,
              help="Up axis of --mesh: gravity points down it.")
@click.option("--material", type=click.Choice(_api.materials()), default=_api.materials()[0], show_default=True,
              help="Cloth material preset (--mesh).")
@click.option("--friction", type=click.FloatRange(min=0), default=None,
              help="Coulomb friction of cloth-cloth contacts (default 0.3).")
@click.option("--obstacle-friction", type=click.FloatRange(min=0), default=None,
              help="Coulomb friction of cloth-obstacle contacts (default 0.5).")
@click.option("--frames", type=click.IntRange(1, 1000000), required=True, help="Frames to record.")
@click.option("--every", type=click.IntRange(1), default=1, show_default=True, help="Simulation steps per frame.")
@click.option("--resolution", type=click.IntRange(2, 4096), default=demo_mod.PAPER_RESOLUTION, show_default=True,
              help="Vertices per side of the 1 m square cloth (--scene).")
@click.option("--method", type=_method_choice(), default=_api.DEFAULT_METHOD, show_default=True,
              help="Detection method driving the self-collision response.")
@click.option("--dt", type=click.FloatRange(min=0, min_open=True), default=None, help="Time step (s); default 1/60.")
@click.option("--no-self-collision", is_flag=True, help="Let the cloth pass through itself.")
@click.option("--obj", "write_obj", is_flag=True, help="Also write every frame as OBJ files in OUT/obj/.")
@click.option("--usd", "usd_name", default=None, metavar="NAME",
              help="Also write the frames as USD (time-sampled points) to OUT/NAME (.usd, .usda or .usdc), "
                   "obstacles to OUT/NAME_obstacles (needs usd-core; up axis y or z).")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Output folder (default: ./selfcd-sim-SCENE or ./selfcd-sim-MESH).")
def simulate(scene: str | None, mesh_file: Path | None, rest_file: Path | None, pin_specs: tuple[str, ...],
             obstacle_paths: tuple[Path, ...], up: str, material: str, friction: float | None,
             obstacle_friction: float | None, frames: int, every: int, resolution: int, method: str,
             dt: float | None, no_self_collision: bool, write_obj: bool, usd_name: str | None,
             out_dir: Path | None) -> None:
    """Simulate a cloth: one of the paper's scenes, or any mesh with pins and obstacles.

    Writes OUT/frames.npz (V: frames x vertices x 3, F: faces, time, pinned;
    with obstacles also OV: frames x obstacle vertices x 3 and OF), OUT/stats.json
    (per-step solver, contact and detection stats) and, with --obj,
    OUT/obj/cloth_NNNNN.obj (and obstacle_NNNNN.obj), with --usd a USD
    animation at the frame rate. Files are written as the
    run goes: an interrupted run keeps the frames it computed. The frames can
    be checked with `selfcd detect OUT/frames.npz`.
    """
    if (scene is None) == (mesh_file is None):
        raise click.UsageError("give either --scene NAME or --mesh FILE (not both)")
    if scene is not None and (rest_file or pin_specs or obstacle_paths):
        raise click.UsageError("--rest, --pin and --obstacle need --mesh")
    out_dir = out_dir or Path(f"selfcd-sim-{scene or mesh_file.stem}")
    _prepare_output(out_dir, write_obj)
    try:
        if scene is not None:
            sim = _api.Simulation(scene, resolution, method, dt=dt, self_collision=not no_self_collision)
        else:
            v, f = mesh_io.load_mesh(mesh_file)
            rest = None if rest_file is None else mesh_io.load_mesh(rest_file)
            if rest is not None and not np.array_equal(rest[1], f):
                raise ValueError(f"{rest_file}: the rest shape must have the same triangles as {mesh_file}")
            step = 1.0 / 60.0 if dt is None else dt
            sim = _api.Simulation.from_mesh(
                v, f, rest=None if rest is None else rest[0], pins=list(pin_specs),
                obstacles=[str(p) for p in obstacle_paths], up=up, material=material, method=method, dt=dt,
                frame_time=step * every, self_collision=not no_self_collision, friction=friction,
                obstacle_friction=obstacle_friction)
    except (ValueError, TypeError) as exc:
        raise InputError(str(exc)) from None
    name = scene or mesh_file.name
    try:
        usd = None if usd_name is None else _usd_writers(out_dir / usd_name, sim, 1.0 / (sim.dt * every), up)
    except ValueError as exc:
        raise InputError(str(exc)) from None
    recording = _Recording(out_dir, sim, write_obj, usd)
    steps = (frames - 1) * every
    try:
        with _bar(steps, f"{name}: simulate") as bar:
            for _ in range(frames - 1):
                positions, _, stats = sim.run(every, every)
                recording.add(positions[-1], stats)
                bar.update(every)
    except KeyboardInterrupt:
        summary = recording.save()
        click.echo(f"{name}: interrupted after {summary['steps']} steps; {summary['frames']} frames kept in "
                   f"{out_dir}", err=True)
        sys.exit(130)
    summary = recording.save()
    click.echo(f"{name}: {summary['steps']} steps of {sim.dt * 1e3:.2f} ms, {sim.mesh.n_faces} triangles, "
               f"method {method}")
    click.echo(f"  mean step {summary['mean_step_ms']:.2f} ms (self-collision {summary['mean_detect_ms']:.2f} ms, "
               f"obstacles {summary['mean_obstacle_ms']:.2f} ms); steps with contacts "
               f"{summary['steps_with_contacts']}; intersections left {summary['max_intersections']}")
    click.echo(f"  frames: {out_dir / 'frames.npz'}  stats: {out_dir / 'stats.json'}")


def _usd_writers(path: Path, sim: _api.Simulation, fps: float, up: str) -> list[Any]:
    """USD writers for the cloth at `path` and, with obstacles, for them next to it; UsdError (a ValueError) if not."""
    from .usd import UsdWriter

    writers = [UsdWriter(path, sim.mesh.faces, fps, up)]
    if len(sim.obstacle_faces):
        writers.append(UsdWriter(path.with_name(f"{path.stem}_obstacles{path.suffix}"), sim.obstacle_faces, fps, up))
    return writers


def _prepare_output(out_dir: Path, write_obj: bool) -> None:
    """Creates OUT, checks it is writable, and removes an earlier run's output
    (so nothing stale is left next to this run's); bad folder: exit status 2."""
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        probe = out_dir / ".selfcd-write-test"
        probe.write_text("")
        probe.unlink()
        for old in ("frames.npz", "stats.json"):
            (out_dir / old).unlink(missing_ok=True)
        obj_dir = out_dir / "obj"
        if obj_dir.is_dir():
            for old in obj_dir.glob("*_[0-9][0-9][0-9][0-9][0-9].obj"):
                old.unlink()
        if write_obj:
            obj_dir.mkdir(exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot write to output folder {out_dir}: {exc.strerror or exc}") from None


class _Recording:
    """Frames and stats of a run, saved as they come: OBJ files per frame, and
    frames.npz and stats.json rewritten (atomically) at most every few seconds and at the end."""

    SAVE_EVERY_S = 5.0

    def __init__(self, out_dir: Path, sim: _api.Simulation, write_obj: bool, usd: list[Any] | None = None) -> None:
        self.out_dir, self.sim, self.write_obj, self.usd = out_dir, sim, write_obj, usd or []
        self.frames: list[np.ndarray] = []
        self.obstacles: list[np.ndarray] = []
        self.times: list[float] = []
        self.stats: list[dict[str, Any]] = []
        self.saved_at = time.monotonic()
        self._frame(sim.positions)
        self.save()

    def _frame(self, positions: np.ndarray) -> None:
        k = len(self.frames)
        self.frames.append(positions)
        self.times.append(self.sim.time)
        ov = self.sim.obstacle_positions
        self.obstacles.append(ov)
        if self.write_obj:
            mesh_io.save_obj(self.out_dir / "obj" / f"cloth_{k:05d}.obj", positions, self.sim.mesh.faces)
            if len(ov):
                mesh_io.save_obj(self.out_dir / "obj" / f"obstacle_{k:05d}.obj", ov, self.sim.obstacle_faces)
        for writer, p in zip(self.usd, (positions, ov)):
            writer.write_frame(p)

    def add(self, positions: np.ndarray, stats: dict[str, Any]) -> None:
        self._frame(positions)
        self.stats.append(stats)
        if time.monotonic() - self.saved_at > self.SAVE_EVERY_S:
            self.save()

    def save(self) -> dict[str, Any]:
        """Writes frames.npz and stats.json for what was recorded; returns the summary."""
        self.saved_at = time.monotonic()
        for writer in self.usd:
            writer.save()
        arrays = {"V": np.stack(self.frames), "F": self.sim.mesh.faces, "time": np.array(self.times),
                  "pinned": self.sim.pinned}
        if len(self.obstacles[0]):
            arrays |= {"OV": np.stack(self.obstacles), "OF": self.sim.obstacle_faces}
        _replace(self.out_dir / "frames.npz", lambda f: np.savez_compressed(f, **arrays))
        columns = {k: np.concatenate([np.atleast_1d(s[k]) for s in self.stats]) if self.stats else np.zeros(0)
                   for k in (self.stats[0] if self.stats else {}) if k != "detection"}
        detection = {k: np.concatenate([s["detection"][k] for s in self.stats])
                     for k in (self.stats[0]["detection"] if self.stats else {})}
        summary = _summary(self.sim, len(self.frames), columns)
        per_step = {k: v.tolist() for k, v in columns.items()}
        per_step["detection"] = {k: np.asarray(v).tolist() for k, v in detection.items()}
        text = json.dumps({"summary": summary, "steps": per_step}, indent=1)
        _replace(self.out_dir / "stats.json", lambda f: f.write(text.encode()))
        return summary


def _replace(path: Path, write: Any) -> None:
    """Writes `path` through a temporary file and a rename, so a reader never sees half a file."""
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as f:
        write(f)
    tmp.replace(path)


def _summary(sim: _api.Simulation, n_frames: int, stats: dict[str, np.ndarray]) -> dict[str, Any]:
    n = len(stats.get("step_time", ()))
    mean_ms = lambda k: float(np.mean(stats[k]) * 1e3) if n else 0.0  # noqa: E731
    return {
        "scene": sim.scene, "resolution": sim.resolution, "method": sim.method, "dt": sim.dt, "steps": n,
        "frames": n_frames, "triangles": sim.mesh.n_faces, "obstacle_triangles": int(len(sim.obstacle_faces)),
        "contact_thickness": sim.contact_thickness,
        "mean_step_ms": mean_ms("step_time"), "mean_solve_ms": mean_ms("solve_time"),
        "mean_detect_ms": mean_ms("detect_time"), "mean_obstacle_ms": mean_ms("obstacle_time"),
        "mean_response_ms": mean_ms("response_time"),
        "mean_contacts": float(np.mean(stats["contacts"])) if n else 0.0,
        "steps_with_contacts": int(np.count_nonzero(stats["contacts"])) if n else 0,
        "max_intersections": int(np.max(stats["intersections"], initial=0)) if n else 0,
    }


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
        if any(s < 0 for s in size_list):
            raise ValueError
    except ValueError:
        raise click.BadParameter(f"not a list of non-negative integers: {sizes}", param_hint="--sizes") from None
    known = bench_mod.states()
    state_list = known if states is None else [s.strip() for s in states.split(",") if s.strip()]
    bad = [s for s in state_list if s not in known]
    if bad:
        raise click.BadParameter(f"unknown state {bad[0]!r}; expected {', '.join(known)}", param_hint="--states")
    method_list = list(methods) or _api.methods()
    with _bar(len(size_list) * len(state_list) * len(method_list), "bench") as bar:
        try:
            rows = bench_mod.run(size_list, state_list, method_list, repeats, brute_limit,
                                 progress=lambda done: bar.update(done - bar.n))
        except (ValueError, MemoryError) as exc:  # a size out of range, or too large to allocate
            raise InputError(f"--sizes: {exc}") from None
    if json_path is not None and str(json_path) == "-":
        click.echo(json.dumps(rows, indent=2))
        return
    click.echo(bench_mod.table(rows))
    if json_path is not None:
        json_path.write_text(json.dumps(rows, indent=2))
        click.echo(f"\nJSON: {json_path}")


# ---------------------------------------------------------------- view


def _size(value: str) -> tuple[int, int]:
    """Parses WIDTHxHEIGHT."""
    try:
        w, h = (int(x) for x in value.lower().split("x"))
    except ValueError:
        raise click.BadParameter(f"expected WIDTHxHEIGHT, e.g. 1024x768, got {value!r}", param_hint="--size") from None
    if not (16 <= w <= 8192 and 16 <= h <= 8192):
        raise click.BadParameter(f"each side must be in 16..8192, got {value!r}", param_hint="--size")
    return w, h


@main.command()
@click.argument("files", nargs=-1, type=click.Path(dir_okay=False, path_type=Path))
@click.option("--scene", type=click.Choice(_api.paper_scenes()), default=None,
              help="Simulate one of the paper's cloth scenes live (instead of FILES).")
@click.option("--resolution", type=click.IntRange(3, 400), default=11, show_default=True,
              help="Vertices per side of the cloth (11: the paper's 200 triangles).")
@click.option("--method", type=_method_choice(), default=None,
              help="Detection method shown (default: sensor-gated for a scene, so its particles show; "
                   f"{_api.DEFAULT_METHOD} for files).")
@click.option("--response-method", type=_method_choice(), default=_api.DEFAULT_METHOD, show_default=True,
              help="Method inside the simulator's collision response (scenes only).")
@click.option("--thickness", type=click.FloatRange(0), default=None,
              help="Proximity distance in metres: faces closer show orange (default: the simulator's contact "
                   "distance for a scene, 0 for files: intersections only, in red).")
@click.option("--bvh-depth", type=click.IntRange(0), default=None,
              help="Show the BVH boxes this deep below the root (green: normal cone under 90 degrees).")
@click.option("--frames", type=click.IntRange(0), default=0, show_default=True,
              help="Frames to advance before the window opens or the screenshot is taken.")
@click.option("--screenshot", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Render without a window (EGL, no display needed), save this .png (or .jpg) and exit.")
@click.option("--size", default="1024x768", show_default=True, help="Window or screenshot size, WIDTHxHEIGHT.")
@click.option("--with-panel", is_flag=True, help="Include the control panel in the screenshot.")
@click.option("--paused", is_flag=True, help="Open the window paused (default: playing).")
@click.option("--up", type=click.Choice(["x", "y", "z"]), default=None,
              help="The axis that points up (default: z for scenes and .npz/.stl, the stage's for USD, "
                   "y for OBJ, PLY, OFF and glTF).")
def view(files: tuple[Path, ...], scene: str | None, resolution: int, method: str | None, response_method: str,
         thickness: float | None, bvh_depth: int | None, frames: int, screenshot: Path | None, size: str,
         with_panel: bool, paused: bool, up: str | None) -> None:
    """Watch a cloth scene live, or mesh FILES, in an interactive polyscope window.

    `selfcd view --scene center` simulates the paper's scene and shows the
    cloth, the sensor particles (yellow spheres), faces in contact (orange:
    closer than the thickness, red: intersecting) and, on request, BVH boxes.
    The panel has play/pause, step, reset, the method, the thickness, the
    sensor's parameters, live stats and their history.

    `selfcd view FILE...` shows a mesh, or an animation (several files sharing
    faces, or an .npz from `selfcd simulate`), with its self-intersections in red.

    With --screenshot PATH no window opens: polyscope renders headless on EGL
    (Mesa is enough, no GPU or display needed) after --frames frames and saves
    the image. polyscope is imported only by this command.
    """
    from . import viewer as viewer_mod  # polyscope is imported only when the viewer runs

    if (scene is None) == (not files):
        raise click.UsageError("give either --scene NAME or mesh FILES (not both)")
    dims = _size(size)
    try:
        if scene is not None:
            source: viewer_mod.Source = viewer_mod.ClothSource(scene, resolution, response_method)
            source.up = up or source.up
            default_method, default_thickness = viewer_mod.SENSOR_METHOD, source.sim.contact_distance
        else:
            seq, faces, labels = mesh_io.load_sequence(list(files))
            source = viewer_mod.FramesSource(seq, faces, labels, up or mesh_io.up_axis(files[0]))
            default_method, default_thickness = _api.DEFAULT_METHOD, 0.0
        v = viewer_mod.Viewer(source, method or default_method,
                              default_thickness if thickness is None else thickness)
        v.set_bvh_depth(bvh_depth)
    except (ValueError, TypeError) as exc:
        raise InputError(str(exc)) from None
    viewer_mod.run_frames(v, frames)
    try:
        if screenshot is not None:
            path = viewer_mod.screenshot(v, screenshot, dims, include_ui=with_panel)
            s = v.summary()
            click.echo(f"{path}  (frame {s['frame']}, {s['method']}: {s['intersecting_pairs']} intersecting pairs, "
                       f"{s['near_faces']} near faces, {s['particles']} particles)")
        else:
            if not paused:
                v.play()
            viewer_mod.show(v, dims)
    except viewer_mod.ViewerError as exc:
        raise click.ClickException(str(exc)) from None


if __name__ == "__main__":  # pragma: no cover
    main()
