"""Built-in meshes and shapes: the paper's square cloth at any resolution and
analytic deformations of it (fold, z-fold, crumple, twist, roll, noise)."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from . import _api, _arrays, _core

SHAPES = ("flat", "fold", "zfold", "crumple", "twist", "roll", "noise")


def grid(n: int = 11, size: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Square cloth of n x n vertices over [0, size]^2: (vertices (n*n,3), faces (2(n-1)^2,3)).

    n = 11 is the paper's model (121 vertices, 200 triangles).
    """
    return _core.grid(int(n), float(size))


def deform(rest: npt.ArrayLike, shape: str, **params: Any) -> np.ndarray:
    """Positions of a flat rest shape put into `shape` (one of SHAPES).

    Lengths in `params` are fractions of the rest shape's width along x:
    fold(angle, radius), zfold(layers, gap), crumple(amplitude, wavelength, seed),
    twist(turns), roll(turns, gap), noise(amplitude, seed).
    """
    return _core.deform(_arrays.points(rest, "rest"), shape, **params)


def paper_names() -> list[str]:
    """The paper's cloth scenes: two-corners (figure 3), corner (figure 5), center (figure 7)."""
    return _api.paper_scenes()


def paper(name: str, resolution: int = 11, method: str = _api.DEFAULT_METHOD, **options: Any) -> _api.Simulation:
    """A simulation of the paper's scene `name` at `resolution` vertices per side.

    `options` go to `selfcd.Simulation` (dt, self_collision).
    """
    return _api.Simulation(name, resolution, method, **options)
