"""Checking a loaded mesh or animation: the intersecting pairs of every frame.

One detector (one hierarchy, refitted per frame) runs over the frames in order,
as `selfcd detect` and `selfcd batch` do; the first frame is the rest shape. A
single mesh checked with the default method runs the one-shot query instead
(`selfcd.self_intersections`: the same pairs, its hierarchy built only where
needed), and its stats are that query's.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from . import _api, _core


@dataclass
class DetectRun:
    """The frames checked: per frame its label, pairs (k, 2) and the detector's stats."""

    labels: list[str]
    frames: np.ndarray
    faces: np.ndarray
    pairs: list[np.ndarray]
    stats: list[dict[str, Any]]
    method: str
    up: str = "z"

    def counts(self) -> np.ndarray:
        """Intersecting pairs per checked frame."""
        return np.asarray([len(p) for p in self.pairs], dtype=np.int64)

    def seconds(self) -> list[float]:
        """Detection time per checked frame."""
        return [float(s["total_time"]) for s in self.stats]

    def worst_frame(self) -> int:
        """The frame with the most intersecting pairs (the first of equals)."""
        return int(np.argmax(self.counts())) if self.pairs else 0


def check_frames(frames: np.ndarray, faces: np.ndarray, labels: list[str], method: str = _api.DEFAULT_METHOD,
                 stop_at_first: bool = False,
                 wrap: Callable[[Iterable[str]], Iterable[str]] = lambda it: it, weld: bool = False) -> DetectRun:
    """Runs one detector over `frames` (f, n, 3) in order.

    Args:
        stop_at_first: stop after the first frame with an intersection.
        wrap: wraps the label iterator (a progress bar).
        weld: merge vertices at equal positions (`selfcd.Mesh(weld=True)`); frames and
            faces stay as given, pairs are face ids either way.

    Raises:
        ValueError, TypeError: an invalid mesh, or a frame with bad positions
            (the message names the frame's label).
    """
    mesh = _api.Mesh(frames[0], faces, weld=weld)
    run = DetectRun([], frames, faces, [], [], method)
    if len(frames) == 1 and method == _api.DEFAULT_METHOD:
        for label in wrap(labels[:1]):
            pairs, stats = _core.one_shot_detection(mesh._inner)
            run.labels.append(label)
            run.pairs.append(pairs)
            run.stats.append(stats)
        return run
    det = _api.Detector(mesh, method)
    for label, positions in zip(wrap(labels), frames):
        try:
            pairs = det.detect(positions)
        except (ValueError, TypeError) as exc:
            raise type(exc)(f"{label}: {exc}") from None
        run.labels.append(label)
        run.pairs.append(pairs)
        run.stats.append(det.last_stats or {})
        if stop_at_first and len(pairs):
            break
    run.frames = frames[: len(run.labels)]
    return run
