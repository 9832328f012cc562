"""Identify many records in parallel on one machine with concurrent.futures.

The Rust calls release the GIL, so a ThreadPoolExecutor runs them on all
cores without pickling the arrays. Run: python examples/parallel_identify.py
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np

import lifted


def make_records(plant: lifted.StateSpace, count: int, n: int = 800) -> list[tuple[np.ndarray, np.ndarray]]:
    """Seeded records: GBN input (seed k) and output with white noise (seed k)."""
    out = []
    for k in range(count):
        u = lifted.gbn(n, switch_probability=0.3, seed=k)
        y, _ = lifted.simulate(plant, u)
        y = y + 0.01 * np.random.default_rng(k).standard_normal(y.shape)
        out.append((u, y))
    return out


def identify_all(records: list[tuple[np.ndarray, np.ndarray]], workers: int = 4, order: int = 2) -> list[np.ndarray]:
    """Poles of the N4SID model of every record, in record order."""

    def one(rec: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
        fit = lifted.n4sid(rec[0], rec[1], order=order)
        return np.sort_complex(fit.model.poles())

    with ThreadPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(one, records))


if __name__ == "__main__":
    g = lifted.StateSpace(
        np.array([[1.6, -0.73], [1.0, 0.0]]), np.array([[1.0], [0.0]]),
        np.array([[0.5, 0.3]]), np.zeros((1, 1)), 1.0,
    )
    for k, p in enumerate(identify_all(make_records(g, 16))):
        print(k, np.round(p, 4))
