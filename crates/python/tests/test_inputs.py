"""Arguments are read as numpy reads them: lists, integer arrays and 1-D
arrays (one channel) are accepted; complex arrays, negative counts and
unreadable values raise ArgumentError (a LiftedError, a ValueError) naming
the argument."""

from __future__ import annotations

import ast
import pathlib

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


def test_booleans_are_not_integers(plant, record) -> None:
    # bool is a subclass of int: order=True was order 1. Refused by the one
    # conversion of integer arguments, a TypeError with pyo3's note naming
    # the argument; numpy's bool and list entries too.
    u, y = record
    with pytest.raises(TypeError, match="expected an integer, got the bool True") as e:
        lifted.n4sid(u, y, order=True)
    assert "while processing 'order'" in e.value.__notes__
    with pytest.raises(TypeError, match="got the bool") as e:
        lifted.prbs(7, seed=np.True_)
    assert "while processing 'seed'" in e.value.__notes__
    with pytest.raises(TypeError, match="entry 1: expected an integer, got the bool False") as e:
        lifted.validate(plant, u, y, horizons=[1, False])
    assert "while processing 'horizons'" in e.value.__notes__
    with pytest.raises(TypeError, match="while processing 'periods'"):
        lifted.multirate(u, y, [True])
    # integers of every kind are still integers
    np.testing.assert_array_equal(lifted.prbs(np.int64(7), seed=np.uint8(3)), lifted.prbs(7, seed=3))
    assert lifted.n4sid(u, y, order=np.int32(2), dt=0.5).order == 2


def test_masked_output_entries_are_missing_samples(plant, record) -> None:
    # A masked entry is a missing sample, exactly as NaN: the values under
    # the mask (1e6 here) are never read.
    u = lifted.rbs(3000, seed=5).reshape(-1, 1)
    y, _ = lifted.simulate(plant, u)
    unsampled = (np.arange(3000) % 3 != 0)[:, None]
    with_nan = np.where(unsampled, np.nan, y)
    masked = np.ma.masked_array(np.where(unsampled, 1e6, y), mask=unsampled)
    opts = dict(order=2, past=5, future=5, detrend="none", refine="none", dt=0.5)
    want = lifted.multirate(u, with_nan, [3], **opts)
    got = lifted.multirate(u, masked, [3], **opts)
    assert got.fast == want.fast and got.lifting_period == 3
    # the sampling phase of a slow output is read from the mask as from NaN
    # (measured at k = 1 mod 3)
    off = (np.arange(3000) % 3 != 1)[:, None]
    got = lifted.multirate(u, np.ma.masked_array(np.where(off, -1e6, y), mask=off), [3], **opts)
    assert got.fast == lifted.multirate(u, np.where(off, np.nan, y), [3], **opts).fast
    v = lifted.validate(plant, u, masked, periods=[3], lags=5).outputs[0]
    assert v.samples == 1000
    assert v.fit == lifted.validate(plant, u, with_nan, periods=[3], lags=5).outputs[0].fit
    # a single-rate route refuses a masked output sample as it refuses NaN
    u1, y1 = record
    gappy = np.ma.masked_array(y1)
    gappy[10, 0] = np.ma.masked
    with pytest.raises(lifted.NonFiniteError) as e:
        lifted.n4sid(u1, gappy, order=2)
    assert (e.value.what, e.value.row, e.value.col) == ("y", 10, 0)
    # a masked array without masked entries is its data
    assert lifted.n4sid(u1, np.ma.masked_array(y1), order=2).model == lifted.n4sid(u1, y1, order=2).model


def test_masked_entries_are_refused_where_no_value_may_be_missing(plant, record) -> None:
    u, y = record
    gappy = np.ma.masked_array(u)
    gappy[5, 0] = np.ma.masked
    with pytest.raises(lifted.ArgumentError,
                       match=r"argument 'u': 1 masked entry \(the first at index \(5, 0\)\)") as e:
        lifted.n4sid(gappy, y, order=2)
    assert e.value.argument == "u" and "only an output can have missing samples" in str(e.value)
    for call, name in [
        (lambda: lifted.simulate(plant, gappy), "u"),
        (lambda: lifted.validate(plant, gappy, y), "u"),
        (lambda: lifted.multirate(gappy, y, [1]), "u"),
        (lambda: lifted.iv(u, y, gappy), "instrument"),
        (lambda: lifted.simulate_experiment(plant, gappy), "r"),
        (lambda: lifted.StateSpace(np.ma.masked_array([[0.5]], mask=[[True]]), [1], [1], 0), "A"),
        (lambda: plant.lsim(u, x0=np.ma.masked_array([0.0, 1.0], mask=[False, True])), "x0"),
    ]:
        with pytest.raises(lifted.ArgumentError, match="masked entr") as e:
            call()
        assert e.value.argument == name


PACKAGE = pathlib.Path(lifted.__file__).resolve().parent


def stub_int_parameters() -> list[tuple[str, str, str, str, dict[str, str]]]:
    """(class or "", function, parameter, its annotation, {required
    parameter: annotation}) for every integer parameter of the stub of
    `lifted._lifted`."""
    tree = ast.parse((PACKAGE / "_lifted.pyi").read_text())
    found = []

    def scan(owner: str, fn: ast.FunctionDef) -> None:
        n_required = len(fn.args.args) - len(fn.args.defaults)
        required = {a.arg: ast.unparse(a.annotation) for a in fn.args.args[:n_required]
                    if a.arg not in ("self", "cls") and a.annotation is not None}
        for a in fn.args.args + fn.args.kwonlyargs:
            if a.annotation is not None and "int" in {n.id for n in ast.walk(a.annotation)
                                                       if isinstance(n, ast.Name)}:
                found.append((owner, fn.name, a.arg, ast.unparse(a.annotation), required))

    for node in tree.body:
        if isinstance(node, ast.FunctionDef):
            scan("", node)
        elif isinstance(node, ast.ClassDef):
            for item in node.body:
                if isinstance(item, ast.FunctionDef):
                    scan(node.name, item)
    return found


def test_every_integer_argument_refuses_a_bool(plant) -> None:
    """Every parameter the stub types as an integer (int, int | None,
    list[int]) refuses True (or [True]) by name. The arguments are
    extracted before the call runs, so the other required arguments only
    need the right type."""

    def dummy(annotation: str) -> object:
        if "StateSpace" in annotation:
            return plant
        if annotation == "bytes":
            return b""
        if annotation.startswith("list[npt.ArrayLike"):
            return []
        if annotation == "list[int]":
            return [1]
        if annotation == "int":
            return 1
        if annotation == "str":
            return ""
        return [0.0]

    instances = {"StateSpace": plant, "Mpc": lifted.Mpc(plant)}
    checked = []
    for owner, name, param, annotation, required in stub_int_parameters():
        if not owner:
            target = getattr(lifted._lifted, name)
        elif name == "__new__":
            target = getattr(lifted._lifted, owner)
        else:
            target = getattr(instances[owner], name)
        kwargs = {k: dummy(v) for k, v in required.items()}
        kwargs[param] = [True] if annotation.startswith("list[") else True
        with pytest.raises(TypeError, match="got the bool True") as e:
            target(**kwargs)
        assert f"while processing '{param}'" in getattr(e.value, "__notes__", []), (owner, name, param)
        checked.append(f"{owner}.{name}({param})")
    # prbs, identify, multirate, validate, Mpc, StateSpace.step, ...: every
    # integer parameter of the stub (73 when this test was written)
    assert len(checked) >= 73, checked
