"""One workflow under every front end (issue 26): the same data and options
through the ``lifted identify`` binary and through ``lifted.identify`` give
the same model to 1e-10. Both go through the Rust crate ``lifted-workflow``;
the third front end, the studio's service call with options it builds
itself, is checked against the binary with the same option sets by
``crates/cli/tests/workflow.rs``."""

from __future__ import annotations

import json
import pathlib
import subprocess
from typing import Any

import numpy as np
import pytest

import lifted

from test_identify import cli

TS = 0.5


def record(n: int) -> tuple[np.ndarray, np.ndarray]:
    """2x2, order 3 (poles 0.9, 0.7 +- 0.3j), random binary inputs, white
    output noise, offsets (2, -1)."""
    rng = np.random.default_rng(26)
    a = np.array([[0.9, 0.0, 0.0], [0.0, 0.7, -0.3], [0.0, 0.3, 0.7]])
    b = np.array([[1.0, 0.2], [-0.5, 1.0], [0.3, 0.7]])
    c = np.array([[1.0, 0.5, -0.3], [0.0, 0.7, 0.4]])
    d = np.array([[0.1, 0.0], [0.0, 0.2]])
    u = np.where(rng.random((n, 2)) < 0.5, -0.7, 1.3)
    x = np.zeros(3)
    y = np.empty((n, 2))
    for k in range(n):
        y[k] = c @ x + d @ u[k]
        x = a @ x + b @ u[k]
    return u, y + np.array([2.0, -1.0]) + 0.05 * rng.standard_normal(y.shape)


# (name, CLI flags, lifted.identify keywords): the same options spelled by
# each front end.
CASES: list[tuple[str, list[str], dict[str, Any]]] = [
    ("defaults", ["--method", "n4sid"], {}),
    ("moesp, order 3", ["--method", "moesp", "--order", "3"], {"method": "moesp", "order": 3}),
    ("cva, horizon 15", ["--method", "cva", "--horizon", "15"], {"method": "cva", "horizon": 15}),
    (
        "no detrending, order 3, horizon 8, state sequences",
        ["--method", "n4sid", "--detrend", "none", "--order", "3", "--horizon", "8",
         "--estimator", "states"],
        {"detrend": "none", "order": 3, "horizon": 8, "system": "states"},
    ),
    ("linear detrending", ["--method", "n4sid", "--detrend", "linear", "--order", "3"],
     {"detrend": "linear", "order": 3}),
    ("refine pem", ["--method", "n4sid", "--order", "3", "--refine", "pem"],
     {"order": 3, "refine": "pem"}),
]


def parts(model: lifted.StateSpace) -> list[np.ndarray]:
    """The matrices, operating point and Kalman gain of a model."""
    out = [np.asarray(m, dtype=float) for m in (model.A, model.B, model.C, model.D)]
    for v in (model.u0, model.y0, model.kalman_gain):
        out.append(np.zeros(0) if v is None else np.asarray(v, dtype=float))
    return out


@pytest.fixture(scope="module")
def data(tmp_path_factory: pytest.TempPathFactory) -> tuple[pathlib.Path, np.ndarray, np.ndarray]:
    u, y = record(2000)
    path = tmp_path_factory.mktemp("workflow") / "data.csv"
    t = TS * np.arange(len(u))
    # 17 significant digits: the CLI reads back the same doubles.
    np.savetxt(path, np.column_stack([t, u, y]), delimiter=",", header="t,u1,u2,y1,y2",
               comments="", fmt="%.17g")
    table = np.loadtxt(path, delimiter=",", skiprows=1)
    assert np.array_equal(table[:, 1:3], u) and np.array_equal(table[:, 3:], y)
    return path, u, y


@pytest.mark.parametrize(("name", "flags", "keywords"), CASES, ids=[c[0] for c in CASES])
def test_cli_and_python_give_the_same_model(
    data: tuple[pathlib.Path, np.ndarray, np.ndarray],
    tmp_path: pathlib.Path,
    name: str,
    flags: list[str],
    keywords: dict[str, Any],
) -> None:
    path, u, y = data
    out = tmp_path / "model.json"
    subprocess.run(
        [str(cli()), "identify", *flags, "--data", str(path), "--inputs", "u1,u2",
         "--outputs", "y1,y2", "--out", str(out)],
        check=True, capture_output=True,
    )
    text = out.read_text()
    from_cli = lifted.StateSpace.from_json(text)
    fit = lifted.identify(u, y, dt=TS, **keywords)
    assert fit.model.dt == from_cli.dt
    ours, theirs = parts(fit.model), parts(from_cli)
    # Same code (lifted-workflow), same doubles, one thread: the two agree
    # to the last bit; 1e-10 relative to the largest entry leaves room for
    # rounding only, while a different route, structure, offset or sample
    # moves the entries by 1e-5 or more.
    for p, q in zip(ours, theirs):
        assert p.shape == q.shape, name
        scale = max(1.0, float(np.abs(q).max(initial=0.0)))
        assert float(np.abs(p - q).max(initial=0.0)) <= 1e-10 * scale, name
    doc = json.loads(text)
    assert fit.method == doc["method"]
    for key in ("structure_selection", "order_selection", "refinement", "stability"):
        assert fit.diagnostics.get(key) == doc["diagnostics"].get(key), (name, key)


def test_past_and_future_are_the_horizon(data: tuple[pathlib.Path, np.ndarray, np.ndarray]) -> None:
    _, u, y = data
    a = lifted.identify(u, y, order=3, horizon=12, system="shift")
    b = lifted.identify(u, y, order=3, past=12, future=12, system="shift")
    np.testing.assert_array_equal(np.asarray(a.model.A), np.asarray(b.model.A))
    with pytest.raises(lifted.ArgumentError, match="one horizon"):
        lifted.identify(u, y, order=3, past=12, future=10)
    with pytest.raises(lifted.ArgumentError):
        lifted.identify(u, y, remove_means=False, detrend="linear")
    with pytest.raises(lifted.ArgumentError, match="refine_iterations"):
        lifted.identify(u, y, order=3, refine="pem", refine_iterations=0)
