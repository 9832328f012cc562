"""Shared fixtures: a seeded second-order plant and its simulated record."""

from __future__ import annotations

import numpy as np
import pytest

import lifted


@pytest.fixture(scope="session")
def plant() -> lifted.StateSpace:
    """Discrete 2-state SISO plant, poles 0.8 ± 0.3j, dt = 0.5 s."""
    a = np.array([[1.6, -0.73], [1.0, 0.0]])
    b = np.array([[1.0], [0.0]])
    c = np.array([[0.5, 0.3]])
    d = np.zeros((1, 1))
    return lifted.StateSpace(a, b, c, d, 0.5)


@pytest.fixture(scope="session")
def record(plant: lifted.StateSpace) -> tuple[np.ndarray, np.ndarray]:
    """u: seeded GBN (1000 samples); y: plant output plus seeded white noise."""
    u = lifted.gbn(1000, amplitude=1.0, switch_probability=0.3, seed=7)
    y, _ = lifted.simulate(plant, u)
    rng = np.random.default_rng(11)
    return u.reshape(-1, 1), y + 0.01 * rng.standard_normal(y.shape)
