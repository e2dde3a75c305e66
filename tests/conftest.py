"""Shared fixtures: random meshes, generated mesh files, a headless Chromium."""

from __future__ import annotations

import numpy as np
import pytest

import selfcd


def random_soup(rng: np.random.Generator, n_tris: int, spread: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Independent random triangles (no shared vertices): many crossings, no adjacency."""
    centres = rng.uniform(0, spread, (n_tris, 1, 3))
    V = (centres + rng.normal(0, 0.15, (n_tris, 3, 3))).reshape(-1, 3)
    F = np.arange(3 * n_tris, dtype=np.int64).reshape(-1, 3)
    return V, F


def random_shared(rng: np.random.Generator, n_vertices: int, n_tris: int) -> tuple[np.ndarray, np.ndarray]:
    """Random triangles over a shared vertex pool: adjacency and crossings mixed."""
    V = rng.uniform(0, 1, (n_vertices, 3))
    F = np.array([rng.choice(n_vertices, 3, replace=False) for _ in range(n_tris)], dtype=np.int64)
    _, keep = np.unique(np.sort(F, axis=1), axis=0, return_index=True)
    return V, F[np.sort(keep)]


def noisy_grid(rng: np.random.Generator, n: int, amplitude: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A grid cloth (rest) and a random crumpled + noisy shape of it."""
    V, F = selfcd.scenes.grid(n)
    P = selfcd.scenes.deform(V, "crumple", amplitude=amplitude, wavelength=0.4, seed=int(rng.integers(1 << 30)))
    P = P + rng.normal(0, 0.3 / n, P.shape)
    return V, F, P


def brute_pairs(V: np.ndarray, F: np.ndarray, P: np.ndarray | None = None) -> set[tuple[int, int]]:
    """The reference: the brute-force method's pairs as a set."""
    det = selfcd.Detector(selfcd.Mesh(V, F), "brute")
    return {tuple(p) for p in det.detect(V if P is None else P).tolist()}


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)
