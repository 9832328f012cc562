"""MPC through lifted-mpc: set-point tracking, inferential (dual-rate) MPC, limits."""

from __future__ import annotations

import numpy as np
import pytest

import lifted


@pytest.fixture()
def lag() -> lifted.StateSpace:
    """y(k) = 0.9 y(k-1) + 0.1 u(k-1)."""
    return lifted.StateSpace(np.array([[0.9]]), np.array([[1.0]]), np.array([[0.1]]), np.zeros((1, 1)), 1.0)


@pytest.mark.parametrize("kind", ["gpc", "dmc"])
def test_tracks_set_point(lag: lifted.StateSpace, kind: str) -> None:
    # DMC's truncated step model (N = 4h = 48) converges more slowly than
    # the state-space law: 1.4e-5 off at 80 samples, 1e-16 at 300.
    run = lifted.Mpc(lag, kind).simulate(lag, np.ones((300, 1)))
    assert run["y"].shape == (300, 1) and run["u"].shape == (300, 1)
    assert run["y"][-1, 0] == pytest.approx(1.0, abs=1e-6)
    assert run["iae"][0] > 0


def test_inferential_mpc(lag: lifted.StateSpace) -> None:
    run = lifted.Mpc(lag).simulate(lag, np.ones((80, 1)), periods=[4])
    assert run["y"][-1, 0] == pytest.approx(1.0, abs=1e-6)


def test_step_with_unsampled_output_and_limits(lag: lifted.StateSpace) -> None:
    mpc = lifted.Mpc(lag, u_max=np.array([2.0]))
    u0 = mpc.step([0.0], np.array([1.0]))
    assert u0.shape == (1,) and u0[0] <= 2.0 + 1e-9
    u1 = mpc.step([None], np.array([1.0]))
    u2 = mpc.step([float("nan")], np.array([1.0]))
    # One output: a number or None will do.
    assert mpc.step(None, np.array([1.0])).shape == u2.shape
    assert mpc.step(0.0, 1.0).shape == u2.shape
    with pytest.raises(lifted.ArgumentError, match="measured"):
        mpc.step("y", 1.0)
    assert np.all(np.isfinite(np.concatenate([u1, u2])))
    assert max(u0[0], u1[0], u2[0]) <= 2.0 + 1e-9


def test_mpc_bad_input(lag: lifted.StateSpace) -> None:
    with pytest.raises(lifted.LiftedError, match="unknown MPC kind"):
        lifted.Mpc(lag, "magic")
    with pytest.raises(lifted.LiftedError):
        lifted.Mpc(lag, "dmc", truncation=3)  # N < h
    with pytest.raises(lifted.LiftedError):
        lifted.Mpc(lag, control_horizon=20)  # m > h
    mpc = lifted.Mpc(lag)
    with pytest.raises(lifted.LiftedError):
        mpc.step([0.0, 1.0], np.array([1.0]))
    with pytest.raises(lifted.LiftedError):
        mpc.step([None], np.array([1.0]))  # no sample yet: no estimate


@pytest.mark.parametrize("kind", ["gpc", "dmc"])
def test_operating_point_gives_plant_values(lag: lifted.StateSpace, kind: str) -> None:
    """With the model's operating point (u0 = 3, y0 = -40) the controller
    reads and returns plant values: the same loop as the deviation model,
    shifted by the offsets (to rounding of adding and removing 40)."""
    at = lag.with_operating_point([3.0], [-40.0])
    dev = lifted.Mpc(lag, kind, u_max=[1.5]).simulate(lag, np.ones((300, 1)))
    run = lifted.Mpc(at, kind, u_max=[4.5]).simulate(lag, np.full((300, 1), -39.0))
    np.testing.assert_allclose(run["y"], dev["y"] - 40.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(run["u"], dev["u"] + 3.0, rtol=0, atol=1e-12)
    assert run["y"][-1, 0] == pytest.approx(-39.0, abs=1e-6)
    # the limit is in plant units, and active in the first moves
    assert run["u"].max() == pytest.approx(4.5, abs=1e-9)
    a, b = lifted.Mpc(lag, kind), lifted.Mpc(at, kind)
    for y in (0.0, 0.2, None, 0.5):
        ua = a.step([y], [1.0])
        ub = b.step([None if y is None else y - 40.0], [-39.0])
        np.testing.assert_allclose(ub, ua + 3.0, rtol=0, atol=1e-12)


def test_the_default_model_feeds_mpc(record: tuple[np.ndarray, np.ndarray]) -> None:
    # Issue 47: the default identification of a plant without feedthrough
    # gives D = 0 (the records do not support a D), so lifted.Mpc takes it
    # without feedthrough=False (it refused the estimated D before).
    u, y = record
    fit = lifted.identify(u, y, dt=0.5)
    assert np.all(fit.model.D == 0.0)
    assert fit.diagnostics["feedthrough"]["used"].startswith("D = 0")
    run = lifted.Mpc(fit.model).simulate(fit.model, np.ones((60, 1)))
    assert run["y"][-1, 0] == pytest.approx(1.0, abs=1e-3)
