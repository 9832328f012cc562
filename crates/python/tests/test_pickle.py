"""Everything that crosses a process boundary pickles: models (as their
model-file JSON), identification and validation results, and errors with
their structured fields; round trips through pickle, through worker
processes started by `spawn` (a fresh interpreter that must find every
class by its module name), and through Dask when it is installed."""

from __future__ import annotations

import multiprocessing
import pickle
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np
import pytest

import lifted


def _same_model(a: lifted.StateSpace, b: lifted.StateSpace) -> None:
    assert a == b
    for m in ("A", "B", "C", "D"):
        np.testing.assert_array_equal(getattr(a, m), getattr(b, m))
    assert a.dt == b.dt


def _fits(record: tuple[np.ndarray, np.ndarray]) -> dict[str, Any]:
    u, y = record
    ym = y.copy()
    ym[np.arange(len(ym)) % 2 != 0] = np.nan
    w = lifted.inverse_prbs(6, seed=1).reshape(-1, 1)
    yw, _ = lifted.simulate(lifted.StateSpace([[0.5]], [1], [1], 0, 0.5), w)
    return {
        "qmarkov": lifted.qmarkov(w, yw, q=10, order=1, prbs_order=6, dt=0.5),
        "subspace": lifted.n4sid(u + 1.0, y - 2.0, order=2, dt=0.5),
        "arx": lifted.arx(u + 1.0, y - 2.0, [2, 2, 1], dt=0.5),
        "iv": lifted.iv(u, y, order=2, dt=0.5),
        "multirate": lifted.multirate(u, ym, [2], order=2, past=5, future=5, dt=0.5),
        "validation": lifted.validate(lifted.n4sid(u, y, order=2, dt=0.5).model, u, y),
        "experiment": lifted.simulate_experiment(
            lifted.n4sid(u, y, order=2, dt=0.5).model, u[:50], snr=10.0, seed=1),
    }


def test_state_space_pickles_with_operating_point_and_gain(plant) -> None:
    g = plant.with_operating_point([1.5], [-2.0]).with_kalman_gain([[0.1], [0.2]])
    for proto in range(2, pickle.HIGHEST_PROTOCOL + 1):
        back = pickle.loads(pickle.dumps(g, protocol=proto))
        _same_model(back, g)
        np.testing.assert_array_equal(back.u0, [1.5])
        np.testing.assert_array_equal(back.kalman_gain, [[0.1], [0.2]])
    cont = lifted.StateSpace(-1.0, 1, 1, 0)
    assert pickle.loads(pickle.dumps(cont)).dt is None


def test_results_pickle(record) -> None:
    for name, fit in _fits(record).items():
        back = pickle.loads(pickle.dumps(fit))
        assert type(back) is type(fit), name
        for key in fit.keys():
            a, b = getattr(fit, key), getattr(back, key)
            if isinstance(a, lifted.StateSpace):
                _same_model(a, b)
            elif isinstance(a, np.ndarray):
                np.testing.assert_array_equal(a, b)
            elif key == "outputs":
                assert [o.fit for o in a] == [o.fit for o in b]
            else:
                assert repr(a) == repr(b), (name, key)


ERRORS = [
    (lambda: lifted.n4sid(np.ones(100), np.ones(100), order=50),
     lifted.OrderError, {"order": 50, "max": 9}),
    (lambda: lifted.n4sid(np.ones(10), np.ones(10), order=2),
     # too short for horizon 3, the shortest that identifies order 2
     lifted.TooShortError, {"got": 10, "needed": 17, "past": 3}),
    (lambda: lifted.StateSpace([[0.5, 1.0]], [[1.0]], [[1.0]], 0),
     lifted.DimensionError, {"what": "A", "expected": "square", "got": "1x2"}),
    (lambda: lifted.gbn(-3), lifted.ArgumentError, {"argument": "n"}),
]


def _raise(k: int) -> None:
    ERRORS[k][0]()


def _unpickle_in_worker(blob: bytes) -> tuple[str, str, dict[str, Any]]:
    e = pickle.loads(blob)
    return type(e).__module__ + "." + type(e).__qualname__, str(e), dict(e.__dict__)


def _identify_in_worker(u: np.ndarray, y: np.ndarray) -> lifted.SubspaceFit:
    return lifted.n4sid(u, y, order=2, dt=0.5)


def _validate_in_worker(model: lifted.StateSpace, u: np.ndarray, y: np.ndarray) -> float:
    return lifted.validate(model, u, y).outputs[0].fit


def test_errors_carry_fields_and_pickle() -> None:
    for call, cls, fields in ERRORS:
        with pytest.raises(cls) as info:
            call()
        e = info.value
        assert isinstance(e, lifted.LiftedError) and isinstance(e, ValueError)
        assert type(e).__module__ == "lifted._lifted"
        assert getattr(lifted._lifted, type(e).__name__) is type(e)
        for k, v in fields.items():
            assert getattr(e, k) == v, (cls, k)
        back = pickle.loads(pickle.dumps(e))
        assert type(back) is cls and str(back) == str(e) and back.__dict__ == e.__dict__


@pytest.fixture(scope="module")
def spawn_pool():
    with ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn")) as pool:
        yield pool


def test_errors_cross_processes(spawn_pool) -> None:
    for k, (call, cls, fields) in enumerate(ERRORS):
        # raised in the worker, unpickled here
        with pytest.raises(cls) as info:
            spawn_pool.submit(_raise, k).result()
        for name, v in fields.items():
            assert getattr(info.value, name) == v
        # raised here, unpickled in a fresh interpreter
        with pytest.raises(cls) as here:
            call()
        qualname, message, attrs = spawn_pool.submit(
            _unpickle_in_worker, pickle.dumps(here.value)).result()
        assert qualname == f"lifted._lifted.{cls.__name__}"
        assert message == str(here.value) and attrs == here.value.__dict__


def test_models_and_fits_cross_processes(spawn_pool, record) -> None:
    u, y = record
    remote = spawn_pool.submit(_identify_in_worker, u + 1.0, y - 2.0).result()
    local = _identify_in_worker(u + 1.0, y - 2.0)
    assert isinstance(remote, lifted.SubspaceFit)
    _same_model(remote.model, local.model)
    np.testing.assert_array_equal(remote.singular_values, local.singular_values)
    # a model sent to the worker keeps its operating point and gain
    fit = spawn_pool.submit(_validate_in_worker, local.model, u + 1.0, y - 2.0).result()
    assert fit == lifted.validate(local.model, u + 1.0, y - 2.0).outputs[0].fit


def test_dask_worker_round_trip(record) -> None:
    distributed = pytest.importorskip("dask.distributed")
    u, y = record
    with distributed.LocalCluster(n_workers=1, processes=True, threads_per_worker=1,
                                  host="127.0.0.1", dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            fit = client.submit(_identify_in_worker, u, y).result()
            _same_model(fit.model, _identify_in_worker(u, y).model)
            err = client.submit(_raise, 0)
            with pytest.raises(lifted.OrderError) as info:
                err.result()
            assert info.value.order == 50 and info.value.max == 9
