"""Built-in meshes and shapes: the paper's square cloth at any resolution and
analytic deformations of it (fold, z-fold, crumple, twist, roll, noise); and
what a simulation of any mesh is made of: pin specs, obstacles, the up axis."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from . import _api, _arrays, _core
from . import io as mesh_io

AXES = ("x", "y", "z")

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


def sphere(rings: int = 16, segments: int = 32, radius: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """A closed UV sphere about the origin, poles on z: (vertices, faces)."""
    if rings < 2 or segments < 3 or not radius > 0:
        raise ValueError(f"sphere needs rings >= 2, segments >= 3, radius > 0; got {rings}, {segments}, {radius}")
    theta = np.pi * np.arange(1, rings) / rings
    phi = 2 * np.pi * np.arange(segments) / segments
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    ring = np.stack([st * np.cos(phi), st * np.sin(phi), np.broadcast_to(ct, st.shape * np.array([1, segments]))], -1)
    v = np.concatenate([[[0, 0, 1]], ring.reshape(-1, 3), [[0, 0, -1]]]) * radius
    south = len(v) - 1
    at = lambda i, j: 1 + (i - 1) * segments + j % segments  # noqa: E731
    f = []
    for j in range(segments):
        f += [(0, at(1, j), at(1, j + 1)), (south, at(rings - 1, j + 1), at(rings - 1, j))]
        for i in range(1, rings - 1):
            f += [(at(i, j), at(i + 1, j), at(i + 1, j + 1)), (at(i, j), at(i + 1, j + 1), at(i, j + 1))]
    return v, np.asarray(f, dtype=np.int64)


def axis(up: str) -> int:
    """Index of the up axis "x", "y" or "z"."""
    if up not in AXES:
        raise ValueError(f"up axis must be one of x, y, z; got {up!r}")
    return AXES.index(up)


def gravity(up: str, g: float = 9.81) -> tuple[float, float, float]:
    """Gravity (m/s^2) pointing down the `up` axis."""
    out = [0.0, 0.0, 0.0]
    out[axis(up)] = -g
    return (out[0], out[1], out[2])


def _pin_spec(v: np.ndarray, spec: str, up: str) -> np.ndarray:
    """The vertex ids one pin spec selects (see `pins`)."""
    kind, _, arg = spec.partition(":")
    if kind == "top":
        try:
            frac = float(arg)
        except ValueError:
            raise ValueError(f"pin spec {spec!r}: top:FRACTION needs a number") from None
        if not 0 <= frac <= 1:
            raise ValueError(f"pin spec {spec!r}: the fraction must be in [0, 1]")
        h = v[:, axis(up)]
        return np.flatnonzero(h >= h.max() - frac * (h.max() - h.min()))
    if kind == "box":
        try:
            b = np.array([float(x) for x in arg.split(",")])
        except ValueError:
            b = np.zeros(0)
        if b.shape != (6,):
            raise ValueError(f"pin spec {spec!r}: box needs six numbers x0,y0,z0,x1,y1,z1")
        lo, hi = np.minimum(b[:3], b[3:]), np.maximum(b[:3], b[3:])
        return np.flatnonzero(np.all((v >= lo) & (v <= hi), axis=1))
    if kind == "indices":
        path = Path(arg)
        if not path.is_file():
            raise ValueError(f"pin spec {spec!r}: no such file {path}")
        try:
            ids = np.load(path) if path.suffix == ".npy" else np.loadtxt(path, ndmin=1)
        except ValueError as exc:
            raise ValueError(f"pin spec {spec!r}: cannot read vertex ids: {exc}") from None
        ids = np.asarray(ids).ravel()
        if ids.size and (not np.all(ids == np.round(ids)) or ids.min() < 0 or ids.max() >= len(v)):
            raise ValueError(f"pin spec {spec!r}: vertex ids must be integers in [0, {len(v)})")
        return ids.astype(np.int64)
    raise ValueError(f"unknown pin spec {spec!r}; expected top:FRACTION, indices:FILE or box:x0,y0,z0,x1,y1,z1")


def pins(vertices: npt.ArrayLike, specs: Any, up: str = "z") -> np.ndarray:
    """Sorted ids of the vertices selected by `specs`, any of (or a list of):

    - "top:FRACTION": within FRACTION of the mesh's height of its top, along `up`;
    - "indices:FILE": vertex ids in a text file (whitespace separated) or an .npy file;
    - "box:x0,y0,z0,x1,y1,z1": inside the axis-aligned box (closed);
    - an array of vertex ids, or a boolean mask over the vertices.
    """
    v = _arrays.points(vertices, "vertices")
    axis(up)
    if isinstance(specs, str) or (isinstance(specs, np.ndarray) and specs.dtype == bool):
        specs = [specs]
    elif isinstance(specs, np.ndarray) or (len(specs) and not isinstance(specs[0], (str, np.ndarray, list, tuple))):
        specs = [np.asarray(specs)]
    chosen = [np.zeros(0, dtype=np.int64)]
    for s in specs:
        if isinstance(s, str):
            chosen.append(_pin_spec(v, s, up))
            continue
        a = np.asarray(s)
        if a.dtype == bool:
            if a.shape != (len(v),):
                raise ValueError(f"a pin mask must have one entry per vertex ({len(v)}), got shape {a.shape}")
            a = np.flatnonzero(a)
        elif a.size and (a.dtype.kind not in "iu" or a.min() < 0 or a.max() >= len(v)):
            raise ValueError(f"pinned vertex ids must be integers in [0, {len(v)})")
        chosen.append(a.astype(np.int64).ravel())
    return np.unique(np.concatenate(chosen))


def _natural_key(path: Path) -> list[Any]:
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", path.name)]


def obstacle(source: Any) -> tuple[np.ndarray, np.ndarray]:
    """An obstacle as (keyframes (k, n, 3) float64, faces (m, 3) int64) from:
    a mesh file (static); an .npz with V of shape (k, n, 3) and F (animated);
    a directory of frame files sharing their faces, in natural order (frame2 before frame10);
    a (V, F) pair, V of shape (n, 3) or (k, n, 3).
    """
    if isinstance(source, (str, Path)):
        path = Path(source)
        if path.is_dir():
            files = sorted((p for p in path.iterdir() if p.is_file() and not p.name.startswith(".")), key=_natural_key)
            if not files:
                raise ValueError(f"{path}: an obstacle directory needs frame files, found none")
            frames, faces, _ = mesh_io.load_sequence(files)
            return np.ascontiguousarray(frames, dtype=np.float64), _arrays.faces(faces)
        v, f = mesh_io.load_mesh(path)
    else:
        v, f = source
    v = np.asarray(v, dtype=np.float64)
    if v.ndim == 2:
        v = v[None]
    f = _arrays.faces(f)
    return _arrays.frames(v, v.shape[1] if v.ndim == 3 else -1, "obstacle vertices"), f


def components(faces: npt.ArrayLike, n_vertices: int) -> np.ndarray:
    """Connected component id of every face (faces sharing a vertex are connected), 0..k-1."""
    f = _arrays.faces(faces)
    parent = list(range(n_vertices))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for a, b, c in f.tolist():
        ra = root(a)
        for x in (b, c):
            rx = root(x)
            if rx != ra:
                parent[rx] = ra
    roots = np.array([root(a) for a in f[:, 0].tolist()], dtype=np.int64)
    return np.unique(roots, return_inverse=True)[1].ravel()


def split_body(vertices: npt.ArrayLike, faces: npt.ArrayLike) -> tuple[tuple[np.ndarray, np.ndarray],
                                                                          tuple[np.ndarray, np.ndarray]]:
    """Splits a garment-on-body mesh by connected components: the body is the
    largest component together with every closed one (every edge in exactly
    two faces: head, eyes), the garment the other, open components (its panels).
    Returns ((garment V, F), (body V, F)), each with its unused vertices dropped."""
    v, f = _arrays.points(vertices, "vertices"), _arrays.faces(faces)
    labels = components(f, len(v))
    sizes = np.bincount(labels)
    body = np.zeros(len(sizes), dtype=bool)
    body[np.argmax(sizes)] = True
    for c in range(len(sizes)):
        fc = f[labels == c]
        e = np.sort(np.concatenate([fc[:, [0, 1]], fc[:, [1, 2]], fc[:, [2, 0]]]), axis=1)
        body[c] |= bool(np.all(np.unique(e, axis=0, return_counts=True)[1] == 2))
    if body.all():
        raise ValueError("every component is closed or the largest: no garment to simulate")

    def part(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        used, inverse = np.unique(f[mask], return_inverse=True)
        return v[used], inverse.reshape(-1, 3).astype(np.int64)

    return part(~body[labels]), part(body[labels])
