"""StateSpace: invariants of known systems, conversions, JSON, python-control."""

from __future__ import annotations

import json

import numpy as np
import pytest

import lifted


def test_poles_zeros_dcgain_of_known_plant(plant: lifted.StateSpace) -> None:
    p = np.sort_complex(plant.poles())
    np.testing.assert_allclose(p, [0.8 - 0.3j, 0.8 + 0.3j], atol=1e-12)
    # G(z) = (0.5 z + 0.3) / (z² − 1.6 z + 0.73): zero at −0.6, G(1) = 0.8 / 0.13
    np.testing.assert_allclose(plant.zeros(), [-0.6], atol=1e-10)
    np.testing.assert_allclose(plant.dcgain(), [[0.8 / 0.13]], rtol=1e-12)
    assert plant.is_stable()
    assert plant.dt == 0.5 and plant.nstates == 2


def test_freqresp_matches_transfer_function(plant: lifted.StateSpace) -> None:
    w = np.array([0.0, 0.3, 1.0, 2.0])
    h = plant.freqresp(w)
    assert h.shape == (4, 1, 1)
    z = np.exp(1j * w * 0.5)
    g = (0.5 * z + 0.3) / (z**2 - 1.6 * z + 0.73)
    np.testing.assert_allclose(h[:, 0, 0], g, rtol=1e-10)


def test_step_equals_cumulated_impulse(plant: lifted.StateSpace) -> None:
    s = plant.step(200)
    assert s.shape == (1, 200, 1)
    y, x = lifted.simulate(plant, np.ones(200))
    np.testing.assert_array_equal(s[0], y)
    assert x.shape == (200, 2)
    assert abs(s[0, -1, 0] - 0.8 / 0.13) < 1e-6


def test_c2d_d2c_round_trip() -> None:
    # first order lag 1/(s + 1): ZOH pole e^{-T}
    g = lifted.StateSpace(np.array([[-1.0]]), np.array([[1.0]]), np.array([[1.0]]), np.zeros((1, 1)))
    assert g.dt is None
    gd = g.c2d(0.1)
    np.testing.assert_allclose(gd.A, [[np.exp(-0.1)]], rtol=1e-13)
    np.testing.assert_allclose(gd.B, [[1 - np.exp(-0.1)]], rtol=1e-12)
    back = gd.d2c()
    np.testing.assert_allclose(back.A, g.A, atol=1e-10)
    np.testing.assert_allclose(back.B, g.B, atol=1e-10)
    tustin = g.c2d(0.1, method="tustin")
    np.testing.assert_allclose(tustin.poles(), [(1 - 0.05) / (1 + 0.05)], rtol=1e-12)


def test_model_json_round_trip(plant: lifted.StateSpace) -> None:
    text = plant.to_json(method="manual")
    doc = json.loads(text)
    assert doc["method"] == "manual"
    back = lifted.StateSpace.from_json(text)
    assert back == plant
    np.testing.assert_array_equal(back.A, plant.A)


def test_python_control_round_trip(plant: lifted.StateSpace) -> None:
    control = pytest.importorskip("control")
    cs = lifted.to_control(plant)
    assert isinstance(cs, control.StateSpace)
    assert cs.dt == 0.5
    np.testing.assert_allclose(np.sort_complex(cs.poles()), np.sort_complex(plant.poles()), atol=1e-12)
    np.testing.assert_allclose(control.dcgain(cs), plant.dcgain()[0, 0], rtol=1e-10)
    back = lifted.from_control(cs)
    assert back == plant
    cont = lifted.from_control(control.ss([[-2.0]], [[1.0]], [[3.0]], [[0.0]]))
    assert cont.dt is None
    np.testing.assert_allclose(cont.dcgain(), [[1.5]])
    # A transfer function is realised; an unspecified time base is refused
    # (it became a continuous-time model without a word).
    tf = lifted.from_control(control.tf([1.0], [1.0, -0.5], 0.5))
    assert tf.dt == 0.5
    np.testing.assert_allclose(tf.dcgain(), [[2.0]])
    with pytest.raises(lifted.LiftedError, match="unspecified time base"):
        lifted.from_control(control.ss([[0.5]], [[1.0]], [[1.0]], [[0.0]], None))
