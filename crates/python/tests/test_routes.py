"""IV, q-Markov Cover, multirate identification and validation: agreement
with the `lifted` CLI on the same data (an independent route to the same
Rust code), recovery of known plants, and bad-input exceptions."""

from __future__ import annotations

import json
import pathlib
import subprocess

import numpy as np
import pytest

import lifted
from test_identify import cli


def write_csv(path: pathlib.Path, dt: float, u: np.ndarray, y: np.ndarray) -> None:
    """t, u1…, y1… with empty cells for NaN (unsampled outputs)."""
    u, y = np.atleast_2d(u.T).T, np.atleast_2d(y.T).T
    head = ["t"] + [f"u{i + 1}" for i in range(u.shape[1])] + [f"y{i + 1}" for i in range(y.shape[1])]
    rows = [",".join(head)]
    for k in range(u.shape[0]):
        cells = [repr(k * dt)] + [repr(float(v)) for v in u[k]] + ["" if np.isnan(v) else repr(float(v)) for v in y[k]]
        rows.append(",".join(cells))
    path.write_text("\n".join(rows) + "\n")


def cli_poles(args: list[str]) -> np.ndarray:
    """Poles of `lifted identify ARGS` without refinement (the Python calls
    below pass refine="none" too: these tests check the identification
    routes against known plants, the refinement has tests of its own)."""
    out = pathlib.Path(args[args.index("--out") + 1])
    subprocess.run([str(cli()), "identify", *args, "--refine", "none"], check=True,
                   capture_output=True)
    m = lifted.StateSpace.from_json(out.read_text())
    return np.sort_complex(m.poles())


def true_poles(plant: lifted.StateSpace) -> np.ndarray:
    return np.sort_complex(plant.poles())


def test_iv_open_loop_equals_the_cli(tmp_path, plant, record) -> None:
    u, y = record
    fit = lifted.iv(u, y, order=2, alpha=8, detrend="none", refine="none", dt=0.5)
    assert fit["order"] == 2 and fit["method"] == "iv"
    data = tmp_path / "rec.csv"
    write_csv(data, 0.5, u, y)
    want = cli_poles(["--method", "iv", "--data", str(data), "--inputs", "u1", "--outputs", "y1",
                      "--order", "2", "--horizon", "8", "--detrend", "none",
                      "--out", str(tmp_path / "iv.json")])
    np.testing.assert_allclose(np.sort_complex(fit["model"].poles()), want, atol=1e-9)
    np.testing.assert_allclose(want, true_poles(plant), atol=0.02)
    assert json.loads(fit["model_json"])["method"] == "iv"


def test_iv_closed_loop_with_the_set_point_as_instrument(plant) -> None:
    """P control u = 0.3 (r - y) with an RBS set-point r and coloured-free
    white output noise: the IV estimate with r as instrument is consistent."""
    k = lifted.StateSpace(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.array([[0.3]]), 0.5)
    r = lifted.rbs(4000, seed=3).reshape(-1, 1)
    run = lifted.simulate_experiment(plant, r, k, snr=50.0, seed=4)
    fit = lifted.iv(run["u"], run["y"], r, order=2)
    np.testing.assert_allclose(np.sort_complex(fit["model"].poles()), true_poles(plant), atol=0.03)


def test_qmarkov_equals_the_cli_and_recovers_the_plant(tmp_path, plant) -> None:
    # One period of an order-8 inverse PRBS, noise free. The m-sequence's
    # circular autocorrelation is not a delta (off-peak -a^2/m), so the
    # Markov estimates are O(1/m) off and the cover is a least-squares one:
    # measured Markov error 5.0e-3 and pole error 1.3e-3 at q = 20 (order 7:
    # 2.4e-2 and 6.6e-3); bounds 1e-2 and 5e-3.
    u = lifted.inverse_prbs(8, amplitude=1.0, periods=1, seed=1).reshape(-1, 1)
    y, _ = lifted.simulate(plant, u)
    fit = lifted.qmarkov(u, y, q=20, order=2, prbs_order=8, refine="none", dt=0.5)
    assert fit["order"] == 2 and fit["stable"] and fit["stabilized_from"] is None
    assert len(fit["markov_data"]) == 20 and fit["markov_data"][0].shape == (1, 1)
    assert fit["markov_error"] < 1e-2
    np.testing.assert_allclose(np.sort_complex(fit["model"].poles()), true_poles(plant), atol=5e-3)
    data = tmp_path / "iprbs.csv"
    write_csv(data, 0.5, u, y)
    want = cli_poles(["--method", "qmarkov", "--data", str(data), "--inputs", "u1", "--outputs",
                      "y1", "--order", "2", "--q", "20", "--prbs-order", "8",
                      "--out", str(tmp_path / "qm.json")])
    np.testing.assert_allclose(np.sort_complex(fit["model"].poles()), want, atol=1e-9)


def test_multirate_equals_the_cli_and_recovers_the_fast_plant(tmp_path, plant) -> None:
    u = lifted.rbs(3000, seed=5).reshape(-1, 1)
    y, _ = lifted.simulate(plant, u)
    y[np.arange(3000) % 3 != 0] = np.nan
    fit = lifted.multirate(u, y, [3], order=2, past=5, future=5, detrend="none", refine="none",
                           dt=0.5)
    assert fit["lifting_period"] == 3 and fit["fast"].dt == 0.5
    got = np.sort_complex(fit["fast"].poles())
    np.testing.assert_allclose(got, true_poles(plant), atol=1e-6)
    data = tmp_path / "mr.csv"
    write_csv(data, 0.5, u, y)
    want = cli_poles(["--method", "n4sid", "--data", str(data), "--inputs", "u1", "--outputs",
                      "y1", "--output-period", "y1=3", "--order", "2", "--horizon", "5",
                      "--detrend", "none", "--out", str(tmp_path / "mr.json")])
    np.testing.assert_allclose(got, want, atol=1e-9)


def test_a_slow_output_sampled_off_the_first_row_is_identified(plant) -> None:
    # Measured at k = 1 mod 3: the phase is read from the NaN pattern (the
    # record was refused: "sample 0 is sampled but not finite"); the same
    # fast model as the record measured from k = 0 on its own samples.
    u = lifted.rbs(3001, seed=5).reshape(-1, 1)
    y, _ = lifted.simulate(plant, u)
    y[np.arange(3001) % 3 != 1] = np.nan
    fit = lifted.multirate(u, y, [3], order=2, past=5, future=5, detrend="none", refine="none",
                           dt=0.5)
    np.testing.assert_allclose(np.sort_complex(fit["fast"].poles()), true_poles(plant), atol=1e-6)


def test_validate_fits_and_residual_tests(plant, record) -> None:
    u, y = record
    v = lifted.validate(plant, u, y, lags=10, initial_state="zero")
    (o,) = v["outputs"]
    yhat, _ = lifted.simulate(plant, u)
    fit = 100 * (1 - np.linalg.norm(y - yhat) / np.linalg.norm(y - y.mean()))
    assert o["fit"] == pytest.approx(fit, abs=1e-9)
    # from the least-squares x0 (the default) the fit can only be higher
    assert lifted.validate(plant, u, y, lags=10).outputs[0].fit >= fit - 1e-9
    assert o["white"] and o["independent"]  # the residual is the white noise
    assert len(o["auto"]) == 10 and len(o["cross"][0]) == 21
    assert v["horizons"] == []
    ident = lifted.n4sid(u, y, order=2, dt=0.5)
    v = lifted.validate(ident["model"], u, y, kalman_gain=ident["kalman_gain"],
                        u0=ident["u0"], y0=ident["y0"])
    assert v["horizons"] == [1, 5] and len(v["outputs"][0]["prediction_fits"]) == 2
    assert v["outputs"][0]["prediction_fits"][0] > 95.0
    # multirate: only the measured samples count
    ym = y.copy()
    ym[np.arange(len(ym)) % 4 != 0] = np.nan
    assert lifted.validate(plant, u, ym, periods=[4], lags=5)["outputs"][0]["samples"] == 250


def test_routes_reject_bad_input(plant, record) -> None:
    u, y = record
    with pytest.raises(lifted.LiftedError, match="instrument"):
        lifted.iv([u], [y], u)
    with pytest.raises(lifted.LiftedError):
        lifted.iv(u, y, np.ones((10, 1)))  # instrument length
    with pytest.raises(lifted.LiftedError, match="periods"):
        lifted.multirate(u, y, [3, 3])
    with pytest.raises(lifted.LiftedError, match="unknown identification method"):
        lifted.multirate(u, y, [1], method="magic")
    with pytest.raises(lifted.LiftedError):
        lifted.qmarkov(u, y, q=20, prbs_order=7)  # not an inverse-PRBS record
    with pytest.raises(lifted.LiftedError, match="Kalman gain"):
        lifted.validate(plant, u, y, kalman_gain=np.zeros((3, 1)))
    with pytest.raises(lifted.LiftedError):
        lifted.validate(plant, u, np.full_like(y, np.nan))
    bad = u.copy()
    bad[3, 0] = np.inf
    with pytest.raises(lifted.LiftedError):
        lifted.multirate(bad, y, [1])
