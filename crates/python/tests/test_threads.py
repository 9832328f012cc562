"""The GIL is released during the long calls (so threads run them in
parallel), `threads` options are capped by the machine, and the memory
budget surfaces as MemoryBudgetError."""

from __future__ import annotations

import os
import sys
import threading
import time
from typing import Callable

import numpy as np
import pytest

import lifted


def other_thread_ran_during(call: Callable[[], object]) -> bool:
    """Runs `call` on this thread while a second thread records time stamps;
    True when a stamp falls in the middle 80 % of the call.

    With the GIL held for the whole call the second thread can only run
    before the call starts and after it returns (a switch interval, set to
    0.1 ms here, at either end), never in its middle; with the GIL released
    it runs throughout. No bound on the call's own duration is asserted: the
    sizes below make it last hundreds of milliseconds (0.35-0.7 s measured),
    thousands of switch intervals."""
    stamps: list[float] = []
    stop = threading.Event()

    def ticker() -> None:
        while not stop.is_set():
            stamps.append(time.perf_counter())

    old = sys.getswitchinterval()
    sys.setswitchinterval(1e-4)
    t = threading.Thread(target=ticker)
    try:
        t.start()
        while not stamps:
            time.sleep(0.001)
        start = time.perf_counter()
        call()
        end = time.perf_counter()
    finally:
        stop.set()
        t.join()
        sys.setswitchinterval(old)
    lo, hi = start + 0.1 * (end - start), start + 0.9 * (end - start)
    return any(lo <= s <= hi for s in stamps)


@pytest.fixture(scope="module")
def lag() -> lifted.StateSpace:
    return lifted.StateSpace(0.9, 1, 0.1, 0, 1.0)


@pytest.fixture(scope="module")
def long_record(lag: lifted.StateSpace) -> tuple[np.ndarray, np.ndarray]:
    u = lifted.gbn(400_000, seed=1)
    y, _ = lifted.simulate(lag, u)
    return u, y


def test_mpc_simulate_releases_the_gil(lag: lifted.StateSpace) -> None:
    mpc = lifted.Mpc(lag)
    assert other_thread_ran_during(lambda: mpc.simulate(lag, np.ones(1_000_000)))


def test_identify_and_validate_release_the_gil(long_record, lag) -> None:
    u, y = long_record
    assert other_thread_ran_during(lambda: lifted.n4sid(u, y, order=1, past=20, future=20))
    model = lifted.n4sid(u[:2000], y[:2000], order=1).model
    assert other_thread_ran_during(
        lambda: [lifted.validate(model, u, y, lags=5) for _ in range(3)])


def test_mpc_step_from_threads(lag: lifted.StateSpace) -> None:
    """Controllers stepped from four threads at once (step runs with the
    GIL released, too short a call for other_thread_ran_during to observe)
    give exactly the moves of serial stepping."""
    def run() -> list[float]:
        mpc = lifted.Mpc(lag, u_max=[2.0])
        return [float(mpc.step([0.1 * k], [1.0])[0]) for k in range(200)]

    serial = run()
    results: list[list[float]] = []
    threads = [threading.Thread(target=lambda: results.append(run())) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert results == [serial] * 4


def test_threads_are_capped_by_the_machine(record) -> None:
    u, y = record
    available = lifted.resolve_threads(0)
    assert 1 <= available <= (os.cpu_count() or 1)
    assert lifted.resolve_threads(100_000) == available
    assert lifted.resolve_threads(1) == 1
    many = lifted.n4sid(u, y, order=2, threads=100_000)
    assert many.threads == available
    one = lifted.n4sid(u, y, order=2, threads=1)
    assert one.threads == 1
    # the thread count changes the summation order of the correlations
    # only: poles agree to rounding (measured 1e-15)
    np.testing.assert_allclose(np.sort_complex(many.model.poles()),
                               np.sort_complex(one.model.poles()), atol=1e-10)


def test_memory_budget_is_a_lifted_error(record, monkeypatch: pytest.MonkeyPatch) -> None:
    u, y = record
    # LIFTED_MEMORY_LIMIT is read at each request (lifted_linalg::budget).
    monkeypatch.setenv("LIFTED_MEMORY_LIMIT", "1000")
    with pytest.raises(lifted.MemoryBudgetError) as e:
        lifted.n4sid(u, y, order=2)
    assert isinstance(e.value, lifted.LiftedError) and isinstance(e.value, ValueError)
    assert e.value.budget_bytes == 1000 and e.value.needed_bytes > 1000
    assert "LIFTED_MEMORY_LIMIT" in str(e.value)
    monkeypatch.delenv("LIFTED_MEMORY_LIMIT")
    # a horizon far beyond the record is refused before anything is allocated
    with pytest.raises((lifted.TooShortError, lifted.MemoryBudgetError)):
        lifted.n4sid(u, y, order=2, past=100_000, future=100_000)
