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
    ("D = 0", ["--method", "n4sid", "--order", "3", "--feedthrough", "false"],
     {"order": 3, "feedthrough": False}),
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


# ---------------------------------------------------------------------------
# The other routes: PBSID/SSARX, IV with an instrument, q-Markov Cover (one
# inverse-PRBS record per input), a multirate record. Each case: CLI flags
# and the Python call with the same options; the defaults on both sides are
# the workflow's (refinement "auto", means removed, ...).

PLANT_A = np.array([[0.9, 0.0, 0.0], [0.0, 0.7, -0.3], [0.0, 0.3, 0.7]])
PLANT_B = np.array([[1.0, 0.2], [-0.5, 1.0], [0.3, 0.7]])
PLANT_C = np.array([[1.0, 0.5, -0.3], [0.0, 0.7, 0.4]])


def plant(d: float = 0.0) -> lifted.StateSpace:
    """The 2x2 order-3 plant of :func:`record` (feedthrough d I)."""
    return lifted.StateSpace(PLANT_A, PLANT_B, PLANT_C, d * np.eye(2), TS)


def write_table(path: pathlib.Path, columns: dict[str, np.ndarray]) -> None:
    """A CSV with a time column and the named columns, 17 significant digits
    (the CLI reads back the same doubles), an empty cell for NaN (an
    unsampled output)."""
    n = len(next(iter(columns.values())))
    names = ["t", *columns]
    lines = [",".join(names)]
    for k in range(n):
        cells = [f"{k * TS:.17g}"]
        cells += ["" if np.isnan(v[k]) else f"{v[k]:.17g}" for v in columns.values()]
        lines.append(",".join(cells))
    path.write_text("\n".join(lines) + "\n")


def run_cli(tmp_path: pathlib.Path, args: list[str]) -> str:
    """`lifted identify ARGS --out …`; the model file's text."""
    out = tmp_path / "model.json"
    subprocess.run([str(cli()), "identify", *args, "--out", str(out)], check=True,
                   capture_output=True)
    return out.read_text()


def assert_same_model(fit_model: lifted.StateSpace, text: str, name: str) -> None:
    """A, B, C, D, the operating point and the Kalman gain of the Python
    model equal the CLI's model file's to 1e-10 relative to the largest
    entry (same code, same doubles, one thread: rounding only, while a
    different route, default or sample moves them by 1e-5 or more)."""
    from_cli = lifted.StateSpace.from_json(text)
    assert fit_model.dt == from_cli.dt, name
    for p, q in zip(parts(fit_model), parts(from_cli)):
        assert p.shape == q.shape, name
        scale = max(1.0, float(np.abs(q).max(initial=0.0)))
        assert float(np.abs(p - q).max(initial=0.0)) <= 1e-10 * scale, name


@pytest.fixture(scope="module")
def closed_loop(tmp_path_factory: pytest.TempPathFactory) -> tuple[pathlib.Path, np.ndarray, np.ndarray, np.ndarray]:
    """The 2x2 plant (no feedthrough) under the static feedback u = 0.3 (r - y)
    with a seeded binary set-point r and white output noise; CSV columns
    t, r1, r2, u1, u2, y1, y2."""
    rng = np.random.default_rng(261)
    n = 2000
    r = np.where(rng.random((n, 2)) < 0.5, -1.0, 1.0)
    k = lifted.StateSpace(np.zeros((0, 0)), np.zeros((0, 2)), np.zeros((2, 0)), 0.3 * np.eye(2), TS)
    run = lifted.simulate_experiment(plant(), r, k, snr=40.0, seed=262)
    u, y = run.u, run.y + np.array([1.0, -0.5])
    path = tmp_path_factory.mktemp("closed") / "loop.csv"
    write_table(path, {"r1": r[:, 0], "r2": r[:, 1], "u1": u[:, 0], "u2": u[:, 1],
                       "y1": y[:, 0], "y2": y[:, 1]})
    return path, r, u, y


CLOSED = ["--inputs", "u1,u2", "--outputs", "y1,y2"]

# (name, CLI flags, Python call on (u, y, r)).
CLOSED_CASES: list[tuple[str, list[str], Any]] = [
    ("pbsid defaults", ["--method", "pbsid"], lambda u, y, r: lifted.pbsid(u, y, dt=TS)),
    ("pbsid order 3", ["--method", "pbsid", "--order", "3"],
     lambda u, y, r: lifted.pbsid(u, y, order=3, dt=TS)),
    ("ssarx order 3, past 12, future 6", ["--method", "ssarx", "--order", "3", "--horizon", "12",
                                          "--future", "6"],
     lambda u, y, r: lifted.pbsid(u, y, "ssarx", order=3, past=12, future=6, dt=TS)),
    ("pbsid feedthrough, no refinement, no detrending",
     ["--method", "pbsid", "--order", "3", "--horizon", "10", "--feedthrough", "--refine", "none",
      "--detrend", "none"],
     lambda u, y, r: lifted.pbsid(u, y, order=3, past=10, feedthrough=True, refine="none",
                                  detrend="none", dt=TS)),
    ("pbsid through identify, refine oe", ["--method", "pbsid", "--order", "3", "--refine", "oe"],
     lambda u, y, r: lifted.identify(u, y, "pbsid", order=3, refine="oe", dt=TS)),
    ("ssarx through identify", ["--method", "ssarx", "--order", "3", "--horizon", "8"],
     lambda u, y, r: lifted.identify(u, y, "ssarx", order=3, horizon=8, dt=TS)),
    ("row-wise pbsid defaults", ["--method", "pbsid-rowwise"],
     lambda u, y, r: lifted.pbsid(u, y, "pbsid_rowwise", dt=TS)),
    ("row-wise pbsid through identify, refine pem",
     ["--method", "pbsid-rowwise", "--order", "3", "--refine", "pem"],
     lambda u, y, r: lifted.identify(u, y, "pbsid_rowwise", order=3, refine="pem", dt=TS)),
    ("iv with the set-point as instrument", ["--method", "iv", "--instrument", "r1,r2"],
     lambda u, y, r: lifted.iv(u, y, r, dt=TS)),
    ("iv order 3, alpha 6, alpha_p 10, refine pem",
     ["--method", "iv", "--instrument", "r1,r2", "--order", "3", "--horizon", "6",
      "--instrument-past", "10", "--refine", "pem"],
     lambda u, y, r: lifted.iv(u, y, r, order=3, alpha=6, alpha_p=10, refine="pem", dt=TS)),
    ("iv stable, aic, linear detrending",
     ["--method", "iv", "--instrument", "r1,r2", "--stable", "--order-criterion", "aic",
      "--detrend", "linear"],
     lambda u, y, r: lifted.iv(u, y, r, enforce_stability=True, require_stable=True,
                               order_criterion="aic", detrend="linear", dt=TS)),
    ("iv open loop through identify", ["--method", "iv", "--order", "3"],
     lambda u, y, r: lifted.identify(u, y, "iv", order=3, dt=TS)),
]


@pytest.mark.parametrize(("name", "flags", "call"), CLOSED_CASES, ids=[c[0] for c in CLOSED_CASES])
def test_closed_loop_routes_equal_the_cli(
    closed_loop: tuple[pathlib.Path, np.ndarray, np.ndarray, np.ndarray],
    tmp_path: pathlib.Path,
    name: str,
    flags: list[str],
    call: Any,
) -> None:
    path, r, u, y = closed_loop
    text = run_cli(tmp_path, [*flags, "--data", str(path), *CLOSED])
    fit = call(u, y, r)
    assert_same_model(fit.model, text, name)
    doc = json.loads(text)
    assert fit.method == doc["method"]
    for key in ("order_selection", "refinement", "refinement_decision", "stability"):
        assert fit.diagnostics.get(key) == doc["diagnostics"].get(key), (name, key)


def qmarkov_records(hold: int) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """One inverse-PRBS record (order 7, held `hold` samples, one period) per
    input of the 2x2 plant with feedthrough, seeded output noise."""
    rng = np.random.default_rng(263)
    sys = plant(0.1)
    us, ys = [], []
    for l in range(2):
        w = lifted.inverse_prbs(7, amplitude=0.8, hold=hold, periods=1, seed=l + 1)
        u = np.zeros((len(w), 2))
        u[:, l] = w
        y, _ = lifted.simulate(sys, u)
        us.append(u)
        ys.append(y + 0.01 * rng.standard_normal(y.shape))
    return us, ys


QMARKOV_CASES: list[tuple[str, int, list[str], dict[str, Any]]] = [
    ("qmarkov defaults", 1, ["--prbs-order", "7"], {"prbs_order": 7}),
    ("qmarkov order 3, q 30, no refinement", 1,
     ["--prbs-order", "7", "--order", "3", "--q", "30", "--refine", "none"],
     {"prbs_order": 7, "order": 3, "q": 30, "refine": "none"}),
    ("qmarkov hold 2, amplitude, output weights, refine pem", 2,
     ["--prbs-order", "7", "--hold", "2", "--order", "3", "--amplitude", "0.8",
      "--output-weight", "1,2", "--refine", "pem"],
     {"prbs_order": 7, "hold": 2, "order": 3, "amplitudes": 0.8, "output_weight": [1.0, 2.0],
      "refine": "pem"}),
]


@pytest.mark.parametrize(("name", "hold", "flags", "keywords"), QMARKOV_CASES,
                         ids=[c[0] for c in QMARKOV_CASES])
def test_qmarkov_equals_the_cli(
    tmp_path: pathlib.Path, name: str, hold: int, flags: list[str], keywords: dict[str, Any]
) -> None:
    us, ys = qmarkov_records(hold)
    files = []
    for l, (u, y) in enumerate(zip(us, ys)):
        f = tmp_path / f"iprbs{l}.csv"
        write_table(f, {"u1": u[:, 0], "u2": u[:, 1], "y1": y[:, 0], "y2": y[:, 1]})
        files += ["--data", str(f)]
    text = run_cli(tmp_path, ["--method", "qmarkov", *files, *flags, *CLOSED])
    fit = lifted.qmarkov(us, ys, dt=TS, **keywords)
    assert_same_model(fit.model, text, name)
    doc = json.loads(text)
    assert fit.method == doc["method"] == "qmarkov"
    assert fit.markov_error == doc["diagnostics"]["markov_error"]
    assert len(fit.markov_data) == len(fit.markov_model) == doc["diagnostics"]["q"]


def multirate_record() -> tuple[np.ndarray, np.ndarray]:
    """The 2x2 plant (no feedthrough) on binary inputs, y1 sampled every 2 and
    y2 every 3 base periods (NaN between), seeded output noise, offsets."""
    rng = np.random.default_rng(264)
    n = 3000
    u = np.where(rng.random((n, 2)) < 0.5, -1.0, 1.0)
    y, _ = lifted.simulate(plant(), u)
    y = y + np.array([0.5, 1.0]) + 0.02 * rng.standard_normal(y.shape)
    k = np.arange(n)
    y[k % 2 != 0, 0] = np.nan
    y[k % 3 != 0, 1] = np.nan
    return u, y


MULTIRATE_CASES: list[tuple[str, list[str], dict[str, Any]]] = [
    ("multirate n4sid order 3", ["--method", "n4sid", "--order", "3"], {"order": 3}),
    ("multirate moesp order 3, horizon 6, no refinement",
     ["--method", "moesp", "--order", "3", "--horizon", "6", "--refine", "none"],
     {"method": "moesp", "order": 3, "horizon": 6, "refine": "none"}),
    ("multirate cva automatic order, refine pem", ["--method", "cva", "--refine", "pem"],
     {"method": "cva", "refine": "pem"}),
    ("multirate iv order 3", ["--method", "iv", "--order", "3"], {"method": "iv", "order": 3}),
]


@pytest.mark.parametrize(("name", "flags", "keywords"), MULTIRATE_CASES,
                         ids=[c[0] for c in MULTIRATE_CASES])
def test_multirate_equals_the_cli(
    tmp_path: pathlib.Path, name: str, flags: list[str], keywords: dict[str, Any]
) -> None:
    u, y = multirate_record()
    path = tmp_path / "mr.csv"
    write_table(path, {"u1": u[:, 0], "u2": u[:, 1], "y1": y[:, 0], "y2": y[:, 1]})
    text = run_cli(tmp_path, [*flags, "--data", str(path), *CLOSED,
                              "--output-period", "y1=2,y2=3"])
    fit = lifted.multirate(u, y, [2, 3], dt=TS, **keywords)
    assert_same_model(fit.fast, text, name)
    doc = json.loads(text)
    assert fit.method == doc["method"]
    assert fit.lifting_period == 6 and fit.lifted.dt == 6 * TS
    for key in ("order_selection", "refinement", "stability", "extraction", "multirate_start"):
        assert fit.diagnostics.get(key) == doc["diagnostics"].get(key), (name, key)


def test_new_options_are_refused_where_they_do_not_apply(
    data: tuple[pathlib.Path, np.ndarray, np.ndarray],
) -> None:
    _, u, y = data
    with pytest.raises(lifted.ArgumentError, match="future"):
        lifted.identify(u, y, "n4sid", order=3, past=10, future=5)
    with pytest.raises(lifted.ArgumentError, match="stable"):
        lifted.identify(u, y, "pbsid", order=3, enforce_stability=True)
    with pytest.raises(lifted.ArgumentError, match="last_period"):
        us, ys = qmarkov_records(1)
        lifted.qmarkov([np.vstack([u, u]) for u in us], [np.vstack([y, y]) for y in ys],
                       prbs_order=7, last_period=False)
