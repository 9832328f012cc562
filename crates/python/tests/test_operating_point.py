"""The identified model carries its operating point and Kalman gain, and
validate/simulate use them: the same fits and outputs as the CLI's
`lifted validate` / `lifted simulate` with the model file (an independent
route through the CLI's own model-file reader and validation service)."""

from __future__ import annotations

import json
import pathlib
import subprocess

import numpy as np
import pytest

import lifted
from test_identify import cli

U0, Y0 = 3.0, -40.0


@pytest.fixture(scope="module")
def offset_record(record: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The shared record moved to the operating point u = 3, y = -40."""
    u, y = record
    return u + U0, y + Y0


def write_csv(path: pathlib.Path, dt: float, u: np.ndarray, y: np.ndarray) -> None:
    t = dt * np.arange(len(u))
    np.savetxt(path, np.column_stack([t, u[:, 0], y[:, 0]]), delimiter=",",
               header="t,u1,y1", comments="", fmt="%.17g")


def cli_fits(model_json: pathlib.Path, data: pathlib.Path) -> list[float]:
    """Simulation, 1-step and 5-step fits (%) of `lifted validate`'s table."""
    out = subprocess.run([str(cli()), "validate", "--model", str(model_json), "--data", str(data)],
                         check=True, capture_output=True, text=True).stdout
    row = next(line for line in out.splitlines() if line.startswith("y1 "))
    return [float(c) for c in row.split()[1:4]]


def test_identified_model_carries_operating_point_and_gain(offset_record) -> None:
    u, y = offset_record
    fit = lifted.n4sid(u, y, order=2, dt=0.5)
    m = fit.model
    np.testing.assert_allclose(m.u0, [u.mean()], rtol=1e-12)
    # y0 is the output mean plus the offset the regression estimated: the
    # plant's output at u0, Y0 + G(1) (u0 - U0) (G(1) = 0.8/0.13, noise
    # 0.01; measured within 1e-3)
    np.testing.assert_allclose(m.y0, [Y0 + 0.8 / 0.13 * (m.u0[0] - U0)], atol=5e-3)
    assert m.kalman_gain is not None and m.kalman_gain.shape == (2, 1)
    np.testing.assert_array_equal(m.kalman_gain, fit.kalman_gain)
    doc = json.loads(fit.model_json)
    assert doc["operating_point"] == {"u0": m.u0.tolist(), "y0": m.y0.tolist()}
    assert len(doc["kalman_gain"]) == 2
    # the model file round trip keeps both
    back = lifted.StateSpace.from_json(fit.model_json)
    assert back == m
    # without means removed the model relates the data as they are: its
    # operating point is the origin (validate then scores it on them)
    raw = lifted.n4sid(u, y, order=2, remove_means=False).model
    np.testing.assert_array_equal(raw.u0, [0.0])
    np.testing.assert_array_equal(raw.y0, [0.0])


def test_validate_uses_the_operating_point_like_the_cli(offset_record, tmp_path) -> None:
    u, y = offset_record
    fit = lifted.n4sid(u, y, order=2, dt=0.5)
    v = lifted.validate(fit.model, u, y)
    (o,) = v.outputs
    # The plant is recovered (noise 0.01 on an output of std ~3): a fit of
    # 99.7 % measured; without the offsets applied it is about -1200 %.
    assert o.fit > 99.0 and len(o.prediction_fits) == 2
    assert lifted.validate(fit.model.with_operating_point(), u, y).outputs[0].fit < 0
    data, model = tmp_path / "rec.csv", tmp_path / "m.json"
    write_csv(data, 0.5, u, y)
    model.write_text(fit.model_json)
    want = cli_fits(model, data)
    # the CLI prints two decimals
    np.testing.assert_allclose([o.fit, *o.prediction_fits], want, atol=0.005 + 1e-9)
    # explicit offsets replace the model's
    same = lifted.validate(fit.model.with_operating_point(), u, y, u0=fit.model.u0, y0=fit.model.y0)
    assert same.outputs[0].fit == pytest.approx(o.fit, abs=1e-12)


def test_validate_estimates_the_initial_state_like_the_cli(plant, tmp_path) -> None:
    """A record that starts away from rest: validate fits it from the
    least-squares x0 (recovering the state it started from), as the CLI
    does; from rest the transient costs fit."""
    u = lifted.gbn(300, amplitude=1.0, switch_probability=0.3, seed=3).reshape(-1, 1)
    x0 = np.array([4.0, -2.0])
    y, _ = lifted.simulate(plant, u, x0)
    v = lifted.validate(plant, u, y)
    assert v.x0 is not None
    np.testing.assert_allclose(v.x0, x0, atol=1e-8)
    assert v.outputs[0].fit == pytest.approx(100.0, abs=1e-6)
    rest = lifted.validate(plant, u, y, initial_state="zero")
    assert rest.x0 is None and rest.outputs[0].fit < 99.0
    data, model = tmp_path / "rec.csv", tmp_path / "m.json"
    write_csv(data, 0.5, u, y)
    model.write_text(plant.to_json())
    # (a model without an operating point: the record as it is, as here)
    out = subprocess.run([str(cli()), "validate", "--model", str(model), "--data", str(data),
                          "--detrend", "none"], check=True, capture_output=True, text=True).stdout
    row = next(line for line in out.splitlines() if line.startswith("y1 "))
    # the CLI prints two decimals
    assert float(row.split()[1]) == pytest.approx(v.outputs[0].fit, abs=0.005 + 1e-9)


def test_simulate_applies_the_operating_point_like_the_cli(offset_record, tmp_path) -> None:
    u, y = offset_record
    fit = lifted.n4sid(u, y, order=2, dt=0.5)
    ysim, _ = lifted.simulate(fit.model, u)
    dev, _ = lifted.simulate(fit.model.with_operating_point(), u - fit.model.u0)
    np.testing.assert_allclose(ysim, dev + fit.model.y0, rtol=1e-13, atol=1e-12)
    data, model, out = tmp_path / "rec.csv", tmp_path / "m.json", tmp_path / "sim.csv"
    write_csv(data, 0.5, u, y)
    model.write_text(fit.model_json)
    subprocess.run([str(cli()), "simulate", "--model", str(model), "--input", str(data),
                    "--inputs", "u1", "--out", str(out)], check=True, capture_output=True)
    cli_y = np.genfromtxt(out, delimiter=",", names=True)["y1"]
    # both print/parse f64 exactly; the two routes differ in rounding order only
    np.testing.assert_allclose(ysim[:, 0], cli_y, rtol=1e-10, atol=1e-10)
    # simulate_experiment returns plant values too
    exp = lifted.simulate_experiment(fit.model, u)
    np.testing.assert_allclose(exp.y, ysim, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(exp.u, u, rtol=1e-15, atol=1e-12)


def test_operating_point_and_gain_are_checked(plant) -> None:
    with pytest.raises(lifted.DimensionError):
        plant.with_operating_point(u0=[1.0, 2.0])
    with pytest.raises(lifted.DimensionError, match="Kalman gain"):
        plant.with_kalman_gain(np.zeros((3, 1)))
    with pytest.raises(lifted.NonFiniteError):
        plant.with_operating_point(y0=[np.nan])
    g = plant.with_operating_point(u0=[1.0])
    np.testing.assert_array_equal(g.y0, [0.0])
    # conversions keep the operating point, not the (discrete-time) gain
    k = g.with_kalman_gain(np.ones((2, 1)))
    c = k.d2c()
    np.testing.assert_array_equal(c.u0, [1.0])
    assert c.kalman_gain is None


def test_cli_model_file_operating_point_is_read(offset_record, tmp_path) -> None:
    """A model identified by `lifted identify` (the CLI's own mean removal
    and model file) validates in Python as in `lifted validate`."""
    u, y = offset_record
    data, model = tmp_path / "rec.csv", tmp_path / "cli.json"
    write_csv(data, 0.5, u, y)
    subprocess.run([str(cli()), "identify", "--method", "n4sid", "--data", str(data),
                    "--inputs", "u1", "--outputs", "y1", "--order", "2", "--out", str(model)],
                   check=True, capture_output=True)
    m = lifted.StateSpace.from_json(model.read_text())
    doc = json.loads(model.read_text())
    np.testing.assert_array_equal(m.u0, doc["operating_point"]["u0"])
    np.testing.assert_array_equal(m.y0, doc["operating_point"]["y0"])
    o = lifted.validate(m, u, y).outputs[0]
    want = cli_fits(model, data)
    got = [o.fit, *o.prediction_fits] if "kalman_gain" in doc else [o.fit]
    np.testing.assert_allclose(got, want[: len(got)], atol=0.005 + 1e-9)
    assert o.fit > 99.0
