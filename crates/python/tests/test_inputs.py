"""Arguments are read as numpy reads them: lists, integer arrays and 1-D
arrays (one channel) are accepted; complex arrays, negative counts and
unreadable values raise ArgumentError (a LiftedError, a ValueError) naming
the argument."""

from __future__ import annotations

import numpy as np
import pytest

import lifted


def test_state_space_from_lists_ints_and_vectors(plant: lifted.StateSpace) -> None:
    # The conftest plant written as a python-control user would: lists,
    # integer entries where they are whole, 1-D B (a column, length n) and
    # C (a row), scalar D broadcast to p x m.
    g = lifted.StateSpace([[1.6, -0.73], [1, 0]], [1, 0], [0.5, 0.3], 0, 0.5)
    assert g == plant
    ints = lifted.StateSpace(np.array([[0]]), np.array([1]), np.array([[2]]), np.array(0), 1.0)
    assert ints.A.dtype == np.float64 and ints.dcgain()[0, 0] == 2.0
    scalar = lifted.StateSpace(0.5, 1, 1, 0, 1.0)
    assert (scalar.nstates, scalar.ninputs, scalar.noutputs) == (1, 1, 1)
    mimo = lifted.StateSpace(np.eye(2) * 0.5, np.eye(2), np.eye(2), 0, 1.0)
    np.testing.assert_array_equal(mimo.D, np.zeros((2, 2)))


def test_records_from_lists_and_int_arrays(plant, record) -> None:
    u, y = record
    want = lifted.n4sid(u, y, order=2, dt=0.5).model
    from_lists = lifted.n4sid(u[:, 0].tolist(), y[:, 0].tolist(), order=2, dt=0.5).model
    assert from_lists == want
    # a 1-D array is one channel, everywhere a record is read
    y1, _ = lifted.simulate(plant, u[:, 0])
    y2, _ = lifted.simulate(plant, u[:, 0].astype(np.int64))  # GBN is ±1: exact
    np.testing.assert_array_equal(y1, y2)
    np.testing.assert_array_equal(plant.lsim(u.tolist())[0], y1)
    v = lifted.validate(plant, u[:, 0], y[:, 0].tolist(), lags=5)
    assert v.outputs[0].samples == len(u)
    # nested lists are one array (samples x channels), a list of arrays is
    # several records
    assert len(lifted.n4sid([u[:500], u[500:]], [y[:500], y[500:]], order=2).x0) == 2
    assert len(lifted.n4sid(u.tolist(), y.tolist(), order=2).x0) == 1
    np.testing.assert_array_equal(plant.freqresp([0.1, 1]), plant.freqresp(np.array([0.1, 1.0])))


def test_complex_arrays_are_refused_by_name(plant) -> None:
    z = np.ones((10, 1)) * (1 + 1j)
    with pytest.raises(lifted.ArgumentError, match="argument 'u': is complex") as e:
        lifted.simulate(plant, z)
    assert e.value.argument == "u"
    with pytest.raises(lifted.ArgumentError, match="argument 'A'"):
        lifted.StateSpace(np.array([[0.5j]]), [1], [1], 0)
    with pytest.raises(lifted.ArgumentError, match="argument 'y'"):
        lifted.n4sid(np.ones(100), np.ones(100) * 1j)
    with pytest.raises(lifted.ArgumentError, match="argument 'omega'"):
        plant.freqresp(np.array([1j]))
    # a real array in a complex dtype is refused too: no silent truncation
    with pytest.raises(lifted.ArgumentError, match="argument 'r'"):
        lifted.simulate_experiment(plant, np.ones(10, dtype=complex))


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda p, u, y: lifted.gbn(-1), "n"),
        (lambda p, u, y: lifted.prbs(7, hold=-2), "hold"),
        (lambda p, u, y: lifted.prbs(7, seed=-1), "seed"),
        (lambda p, u, y: lifted.multisine(100, period=-4), "period"),
        (lambda p, u, y: lifted.n4sid(u, y, order=-2), "order"),
        (lambda p, u, y: lifted.n4sid(u, y, past=-1), "past"),
        (lambda p, u, y: lifted.identify(u, y, threads=-1), "threads"),
        (lambda p, u, y: lifted.iv(u, y, alpha=-3), "alpha"),
        (lambda p, u, y: lifted.qmarkov(u, y, q=-1), "q"),
        (lambda p, u, y: lifted.multirate(u, y, [-3]), "periods[0]"),
        (lambda p, u, y: lifted.validate(p, u, y, lags=-1), "lags"),
        (lambda p, u, y: lifted.validate(p, u, y, horizons=[1, -5]), "horizons[1]"),
        (lambda p, u, y: p.step(-10), "n_samples"),
        (lambda p, u, y: lifted.simulate_experiment(p, u, sampling=[-1]), "sampling[0]"),
        (lambda p, u, y: lifted.Mpc(p, prediction_horizon=-1), "prediction_horizon"),
    ],
)
def test_negative_counts_are_value_errors_naming_the_argument(plant, record, call, name) -> None:
    u, y = record
    with pytest.raises(ValueError) as e:
        call(plant, u, y)
    assert isinstance(e.value, lifted.ArgumentError) and not isinstance(e.value, OverflowError)
    assert e.value.argument == name
    assert f"argument '{name}'" in str(e.value)


def test_other_argument_errors_name_the_argument(plant, record) -> None:
    u, y = record
    with pytest.raises(lifted.ArgumentError, match="argument 'u'.*3 dimensions"):
        lifted.n4sid(np.ones((3, 3, 3)), y)
    with pytest.raises(lifted.ArgumentError, match="argument 'B'"):
        lifted.StateSpace([[0.5]], [["a"]], [[1]], 0)
    with pytest.raises(lifted.ArgumentError, match="argument 'A'"):
        lifted.StateSpace([[0.5], [1, 2]], [1], [1], 0)  # ragged
    with pytest.raises(lifted.ArgumentError, match="argument 'x0'"):
        plant.lsim(u, x0=np.ones((2, 2)))
    with pytest.raises(lifted.ArgumentError, match="argument 'method'.*'n4sid', 'moesp', 'cva'"):
        lifted.identify(u, y, "magic")  # type: ignore[arg-type]
    # the wrong Python type is a TypeError naming the argument (pyo3's)
    with pytest.raises(TypeError, match="order"):
        lifted.n4sid(u, y, order=2.5)  # type: ignore[arg-type]
    # u as records, y as one array
    with pytest.raises(lifted.LiftedError, match="u is a list of 2 records but y is one array"):
        lifted.n4sid([u[:500], u[500:]], y)


def test_transposed_records_and_nan_outputs_are_explained(record) -> None:
    u, y = record
    # Channels as rows: it read "horizons past 2 + future 2 too long for 1
    # samples".
    with pytest.raises(lifted.ArgumentError, match="transposed"):
        lifted.n4sid(u.reshape(1, -1), y.reshape(1, -1), order=2)
    # NaN in a single-rate call: a note points at the multirate route.
    gappy = np.array(y, dtype=float)
    gappy[1] = np.nan
    with pytest.raises(lifted.NonFiniteError) as e:
        lifted.n4sid(u, gappy, order=2)
    assert any("lifted.multirate" in n for n in getattr(e.value, "__notes__", []))


def test_frequencies_above_nyquist_are_refused(plant: lifted.StateSpace) -> None:
    # dt = 0.5: π/T = 6.28 rad/s; above it a discrete response repeats an alias.
    assert plant.freqresp([np.pi / 0.5]).shape == (1, 1, 1)
    with pytest.raises(lifted.ArgumentError, match="Nyquist"):
        plant.freqresp([100.0])
