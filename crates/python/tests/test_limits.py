"""No argument can abort the interpreter: sizes the extension would have to
allocate are checked first (memory budget, work bound, sampling-pattern
length) and raise LiftedError subclasses. Each case runs in a child
process, so a regression shows as a failed test, not a crashed suite."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

CASES = {
    # one 2^40-sample signal: 8.8 TB
    "gbn": ("lifted.gbn(2**40)", "MemoryBudgetError"),
    "rbs": ("lifted.rbs(2**40, hold=3)", "MemoryBudgetError"),
    "multisine_n": ("lifted.multisine(2**40)", "MemoryBudgetError"),
    # one period tabulated whatever the length
    "multisine_period": ("lifted.multisine(100, period=2**40)", "MemoryBudgetError"),
    "multisine_work": ("lifted.multisine(100, period=10**7)", "WorkBudgetError"),
    "step": ("plant.step(2**40)", "MemoryBudgetError"),
    # the simulator's sampling pattern: lcm of holds and periods
    "holds": ("lifted.simulate_experiment(plant, np.ones(50), holds=[2**40])", "ArgumentError"),
    "sampling": ("lifted.simulate_experiment(plant, np.ones(50), sampling=[2**21 + 1, 2**21 + 3])",
                 "ArgumentError"),
    "horizon": ("lifted.n4sid(np.ones(200), np.ones(200), past=10**5, future=10**5)",
                "LiftedError"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_huge_sizes_raise(case: str) -> None:
    call, expected = CASES[case]
    code = textwrap.dedent(f"""
        import numpy as np
        import lifted
        plant = lifted.StateSpace([[1.6, -0.73], [1, 0]], [1, 0], [0.5, 0.3], 0, 0.5)
        try:
            {call}
        except lifted.{expected} as e:
            print("raised", type(e).__name__, e)
        else:
            print("returned")
    """)
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.startswith("raised"), run.stdout
