"""lifted_sim through simulate_experiment: multirate NaN pattern, agreement
with the plain state-space simulation, the loop equation in closed loop."""

from __future__ import annotations

import numpy as np
import pytest

import lifted


def test_open_loop_multirate(plant: lifted.StateSpace) -> None:
    u = lifted.rbs(300, hold=3, seed=2)
    out = lifted.simulate_experiment(plant, u, sampling=[3])
    y, y_fast = out["y"], out["y_fast"]
    assert y.shape == (300, 1)
    sampled = ~np.isnan(y[:, 0])
    assert sampled.sum() == 100 and np.all(sampled[::3])
    np.testing.assert_array_equal(y[sampled], y_fast[sampled])
    # noise free: the same as StateSpace.lsim (an independent route in lifted-lti)
    ref, _ = lifted.simulate(plant, u)
    np.testing.assert_allclose(y_fast, ref, rtol=1e-12, atol=1e-12)


def test_noise_is_seeded_at_the_snr(plant: lifted.StateSpace) -> None:
    u = lifted.gbn(4000, seed=1)
    a = lifted.simulate_experiment(plant, u, snr=10.0, seed=5)
    b = lifted.simulate_experiment(plant, u, snr=10.0, seed=5)
    np.testing.assert_array_equal(a["y"], b["y"])
    noise = a["y_fast"] - a["y_clean"]
    assert np.var(a["y_clean"]) / np.var(noise) == pytest.approx(10.0, rel=1e-6)


def test_closed_loop_obeys_the_loop_equation(plant: lifted.StateSpace) -> None:
    k = lifted.StateSpace(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.array([[0.05]]), 0.5)
    r = np.ones(200)
    out = lifted.simulate_experiment(plant, r, k)
    u, y = out["u"], out["y_fast"]
    np.testing.assert_allclose(u[:, 0], 0.05 * (1.0 - y[:, 0]), atol=1e-12)
    # static loop gain L = 0.05 · 0.8/0.13: y → L/(1 + L)
    gain = 0.05 * 0.8 / 0.13
    assert y[-1, 0] == pytest.approx(gain / (1 + gain), rel=1e-6)


def test_simulation_bad_input(plant: lifted.StateSpace) -> None:
    with pytest.raises(lifted.LiftedError):
        lifted.simulate_experiment(plant, np.ones((10, 2)))
    with pytest.raises(lifted.LiftedError):
        lifted.simulate_experiment(plant, np.ones(10), sampling=[0])
    with pytest.raises(lifted.LiftedError, match="unknown feedback"):
        lifted.simulate_experiment(plant, np.ones(10), plant, feedback="magic")
    cont = lifted.StateSpace(np.array([[-1.0]]), np.ones((1, 1)), np.ones((1, 1)), np.zeros((1, 1)))
    with pytest.raises(lifted.LiftedError):
        lifted.simulate_experiment(cont, np.ones(10))
    out = lifted.simulate_experiment(cont, np.ones(10), dt=0.1)
    assert out["y"][-1, 0] == pytest.approx(1 - np.exp(-0.9), rel=1e-12)
