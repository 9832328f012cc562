"""Bad input raises LiftedError (a ValueError) with the Rust message; no crash."""

from __future__ import annotations

import numpy as np
import pytest

import lifted


def test_error_is_value_error() -> None:
    assert issubclass(lifted.LiftedError, ValueError)


def test_non_square_a() -> None:
    with pytest.raises(ValueError):
        lifted.StateSpace(np.zeros((2, 3)), np.zeros((2, 1)), np.zeros((1, 2)), np.zeros((1, 1)))


def test_nan_in_matrix() -> None:
    with pytest.raises(lifted.LiftedError):
        lifted.StateSpace(np.array([[np.nan]]), np.ones((1, 1)), np.ones((1, 1)), np.zeros((1, 1)), 1.0)


def test_negative_dt() -> None:
    with pytest.raises(lifted.LiftedError):
        lifted.StateSpace(np.ones((1, 1)) * 0.5, np.ones((1, 1)), np.ones((1, 1)), np.zeros((1, 1)), -1.0)


def test_lsim_wrong_input_width(plant: lifted.StateSpace) -> None:
    with pytest.raises(lifted.LiftedError):
        lifted.simulate(plant, np.ones((10, 2)))


def test_lsim_inf_input(plant: lifted.StateSpace) -> None:
    u = np.ones(10)
    u[3] = np.inf
    with pytest.raises(lifted.LiftedError):
        lifted.simulate(plant, u)


def test_bad_json() -> None:
    with pytest.raises(lifted.LiftedError):
        lifted.StateSpace.from_json("{not json")


def test_bad_c2d_method_and_discrete_c2d(plant: lifted.StateSpace) -> None:
    g = lifted.StateSpace(np.array([[-1.0]]), np.ones((1, 1)), np.ones((1, 1)), np.zeros((1, 1)))
    with pytest.raises(lifted.LiftedError, match="unknown c2d method"):
        g.c2d(0.1, method="magic")
    with pytest.raises(lifted.LiftedError):
        plant.c2d(0.1)


def test_excitation_bad_options() -> None:
    with pytest.raises(lifted.LiftedError):
        lifted.prbs(1)  # order below the table
    with pytest.raises(lifted.LiftedError):
        lifted.prbs(7, amplitude=-1.0)
    with pytest.raises(lifted.LiftedError):
        lifted.inverse_prbs(7, hold=0)
    with pytest.raises(lifted.LiftedError):
        lifted.inverse_prbs(7, periods=0)
    with pytest.raises(lifted.LiftedError):
        lifted.design(output_period=-0.01)
    with pytest.raises(lifted.LiftedError):
        lifted.gbn(100, switch_probability=1.5)
    with pytest.raises(lifted.LiftedError):
        lifted.rbs(100, hold=0)
    with pytest.raises(lifted.LiftedError):
        lifted.multisine(100, amplitude=float("nan"))


def test_identify_bad_input(record: tuple[np.ndarray, np.ndarray]) -> None:
    u, y = record
    with pytest.raises(lifted.LiftedError):
        lifted.n4sid(u[:5], y[:5], order=2)  # too short for the horizons
    with pytest.raises(lifted.LiftedError):
        lifted.n4sid(u, y[:-1], order=2)  # length mismatch
    bad = y.copy()
    bad[10, 0] = np.inf
    with pytest.raises(lifted.LiftedError):
        lifted.n4sid(u, bad, order=2)
    with pytest.raises(lifted.LiftedError, match="unknown identification method"):
        lifted.identify(u, y, "magic")
    with pytest.raises(lifted.LiftedError, match="unknown system estimate"):
        lifted.identify(u, y, system="magic")
    with pytest.raises(lifted.LiftedError):
        lifted.identify([u], y)
    with pytest.raises(lifted.LiftedError):
        lifted.identify(np.ones((3, 3, 3)), y)


def test_a_constant_input_is_not_exciting(record: tuple[np.ndarray, np.ndarray]) -> None:
    # The subspace layer refuses the inputs (lifted_subspace::Error::
    # NotExciting, numerical rank 0 of the 20 the input rows need); the
    # workflow names the constant column. Mapped by the variant, with its
    # fields, through the chain of the step's sources.
    u, y = record
    for call in (
        lambda: lifted.n4sid(np.ones_like(u), y, order=2),
        lambda: lifted.pbsid(np.zeros_like(u), y, order=2),
        lambda: lifted.n4sid(np.hstack([u, -3 * u]), y, order=2),  # tied inputs
    ):
        try:
            call()
        except lifted.LiftedError as e:
            assert isinstance(e, lifted.NotExcitingError), repr(e)
            assert e.rank is not None and e.needed is not None and e.rank < e.needed
            assert "not persistently exciting" in str(e)
        else:
            raise AssertionError("a non-exciting input was identified")


def test_an_input_of_too_few_frequencies_is_not_exciting(record: tuple[np.ndarray, np.ndarray]) -> None:
    # Not constant, not tied: the workflow passes the subspace step's
    # refusal on as it is, mapped by its variant with its fields.
    u, y = record
    with pytest.raises(lifted.NotExcitingError) as e:
        lifted.n4sid(np.sin(0.3 * np.arange(len(y))), y, order=2)
    assert e.value.what == "u" and 0 < e.value.rank < e.value.needed
