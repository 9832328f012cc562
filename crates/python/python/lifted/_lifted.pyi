"""Type stubs of the extension module `lifted._lifted` (Rust, PyO3).

The only stub of the package: the Python modules carry inline annotations.
Checked against the built extension by ``python -m mypy.stubtest
lifted._lifted`` in CI.

What the annotations cannot say: an ``int`` parameter (or ``list[int]``
entry) refuses a ``bool`` at runtime (TypeError), and an array parameter
reads a numpy masked array's masked entries as missing samples (NaN) in
outputs (``y``, ``ys``) and refuses them everywhere else (ArgumentError).
"""

from typing import Any, Literal, Sequence, final

import numpy as np
import numpy.typing as npt

from lifted._types import (
    BdRoute,
    C2dMethod,
    Detrend,
    Feedback,
    IdentifyMethod,
    MpcKind,
    OrderCriterion,
    PbsidVariant,
    ProcessStructure,
    Refine,
    SystemEstimate,
)

__version__: str
# pyo3 lists every name added to the module
__all__ = [
    "ArgumentError",
    "DimensionError",
    "FirstPass",
    "LiftedError",
    "MemoryBudgetError",
    "Mpc",
    "NonFiniteError",
    "NotExcitingError",
    "OrderError",
    "StateSpace",
    "TooShortError",
    "UnstableError",
    "WorkBudgetError",
    "__version__",
    "_choices",
    "_diagnostics_fields",
    "arxstruc",
    "channel_scales",
    "delayest",
    "design",
    "gbn",
    "identify",
    "inverse_prbs",
    "iv",
    "multirate",
    "multisine",
    "partial_append",
    "partial_close",
    "partial_compress",
    "partial_compress_npy",
    "partial_identify",
    "partial_merge",
    "partial_plan",
    "pbsid",
    "polynomial_from_json",
    "prbs",
    "qmarkov",
    "rbs",
    "regression_absorb",
    "regression_advance",
    "regression_end_record",
    "regression_merge",
    "regression_prime",
    "regression_push",
    "regression_scan",
    "regression_npy",
    "regression_memory",
    "resolve_threads",
    "simulate_experiment",
    "validate",
]

class LiftedError(ValueError):
    """Any error of the Lifted library; the message is the Rust error's."""

    what: str | None

class ArgumentError(LiftedError):
    """A Python argument could not be read; ``argument`` is its name."""

    argument: str | None

class DimensionError(LiftedError):
    """Shapes or lengths that do not fit together."""

    expected: str | int | None
    got: str | int | None

class NonFiniteError(LiftedError):
    """A NaN or infinite value where a finite one is needed."""

    row: int | None
    col: int | None
    value: float | None

class OrderError(LiftedError):
    """A model order (or parameter count) the data or the method cannot support."""

    order: int | None
    max: int | None
    rank: int | None

class NotExcitingError(LiftedError):
    """The input is not persistently exciting."""

    rank: int | None
    needed: int | None

class UnstableError(LiftedError):
    """A stable model or loop was required."""

    spectral_radius: float | None
    pole: complex | None

class TooShortError(LiftedError):
    """The record is too short for the options."""

    got: int | None
    needed: int | None

class MemoryBudgetError(LiftedError):
    """The request would allocate more than the memory budget."""

    needed_bytes: int | None
    budget_bytes: int | None

class WorkBudgetError(LiftedError):
    """The request needs more floating-point operations than the work bound."""

    flops: float | None
    limit: float | None

@final
class StateSpace:
    """(A, B, C, D, dt), dt None = continuous time, with the operating point
    (u0, y0) and Kalman gain of an identified model."""

    def __new__(
        cls,
        a: npt.ArrayLike,
        b: npt.ArrayLike,
        c: npt.ArrayLike,
        d: npt.ArrayLike,
        dt: float | None = None,
        *,
        u0: npt.ArrayLike | None = None,
        y0: npt.ArrayLike | None = None,
        kalman_gain: npt.ArrayLike | None = None,
    ) -> StateSpace: ...
    @property
    def A(self) -> npt.NDArray[np.float64]: ...
    @property
    def B(self) -> npt.NDArray[np.float64]: ...
    @property
    def C(self) -> npt.NDArray[np.float64]: ...
    @property
    def D(self) -> npt.NDArray[np.float64]: ...
    @property
    def dt(self) -> float | None: ...
    @property
    def nstates(self) -> int: ...
    @property
    def ninputs(self) -> int: ...
    @property
    def noutputs(self) -> int: ...
    @property
    def u0(self) -> npt.NDArray[np.float64] | None: ...
    @property
    def y0(self) -> npt.NDArray[np.float64] | None: ...
    @property
    def kalman_gain(self) -> npt.NDArray[np.float64] | None: ...
    def with_operating_point(
        self, u0: npt.ArrayLike | None = None, y0: npt.ArrayLike | None = None
    ) -> StateSpace: ...
    def with_kalman_gain(self, kalman_gain: npt.ArrayLike | None = None) -> StateSpace: ...
    def poles(self) -> npt.NDArray[np.complex128]: ...
    def zeros(self) -> npt.NDArray[np.complex128]: ...
    def dcgain(self) -> npt.NDArray[np.float64]: ...
    def is_stable(self, margin: float = 0.0) -> bool: ...
    def freqresp(self, omega: npt.ArrayLike) -> npt.NDArray[np.complex128]: ...
    def step(self, n_samples: int, dt: float | None = None) -> npt.NDArray[np.float64]: ...
    def lsim(
        self,
        u: npt.ArrayLike,
        x0: npt.ArrayLike | None = None,
        dt: float | None = None,
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def c2d(
        self,
        dt: float,
        method: C2dMethod = "zoh",
        prewarp: float | None = None,
        input_delays: list[float] | None = None,
    ) -> StateSpace: ...
    def d2c(self) -> StateSpace: ...
    def to_json(self, method: str | None = None) -> str: ...
    @staticmethod
    def from_json(text: str) -> StateSpace: ...
    def __reduce__(self) -> tuple[Any, tuple[str]]: ...
    def __eq__(self, value: object, /) -> bool: ...

@final
class Mpc:
    """DMC (kind="dmc") or state-space MPC (kind="gpc"); None/NaN = output not sampled."""

    def __new__(
        cls,
        model: StateSpace,
        kind: MpcKind = "gpc",
        prediction_horizon: int = 12,
        control_horizon: int = 3,
        output_weight: npt.ArrayLike | None = None,
        move_weight: npt.ArrayLike | None = None,
        truncation: int | None = None,
        u_min: npt.ArrayLike | None = None,
        u_max: npt.ArrayLike | None = None,
        du_max: npt.ArrayLike | None = None,
        y_min: npt.ArrayLike | None = None,
        y_max: npt.ArrayLike | None = None,
    ) -> Mpc: ...
    def step(
        self, measured: float | None | Sequence[float | None], reference: npt.ArrayLike
    ) -> npt.NDArray[np.float64]: ...
    def simulate(
        self,
        plant: StateSpace,
        reference: npt.ArrayLike,
        periods: list[int] | None = None,
    ) -> dict[str, Any]: ...

def prbs(
    order: int, amplitude: float = 1.0, hold: int = 1, periods: int = 1, seed: int = 0
) -> npt.NDArray[np.float64]: ...
def inverse_prbs(
    order: int, amplitude: float = 1.0, hold: int = 1, periods: int = 1, seed: int = 0
) -> npt.NDArray[np.float64]: ...
def design(
    output_period: float = 0.01,
    actuator_rate_hz: float = 30.0,
    actuator_margin: float = 3.0,
    slowest_mode_hz: float = 0.025,
    amplitude: float = 1.0,
    min_order: int = 2,
) -> dict[str, Any]: ...
def rbs(n: int, amplitude: float = 1.0, hold: int = 1, seed: int = 0) -> npt.NDArray[np.float64]: ...
def gbn(
    n: int,
    amplitude: float = 1.0,
    switch_probability: float = 0.5,
    hold: int = 1,
    seed: int = 0,
) -> npt.NDArray[np.float64]: ...
def multisine(
    n: int,
    amplitude: float = 1.0,
    period: int = 1024,
    first_harmonic: int = 1,
    last_harmonic: int | None = None,
) -> npt.NDArray[np.float64]: ...
def resolve_threads(threads: int) -> int: ...
def identify(
    us: list[npt.ArrayLike],
    ys: list[npt.ArrayLike],
    method: IdentifyMethod = "n4sid",
    order: int | None = None,
    orders: list[int] | None = None,
    max_order: int = 10,
    order_criterion: OrderCriterion = "validation",
    horizon: int | None = None,
    past: int | None = None,
    future: int | None = None,
    system: SystemEstimate | None = None,
    bd: BdRoute = "auto",
    feedthrough: bool | None = None,
    detrend: Detrend = "mean",
    remove_means: bool = True,
    noise_model: bool = True,
    enforce_stability: bool = False,
    refine: Refine = "auto",
    refine_iterations: int = 100,
    refine_max_work: float = 2e10,
    dt: float = 1.0,
    threads: int = 1,
    gain_stop_share: float = 0.01,
    integrator_tolerance: float | None = None,
    process: ProcessStructure | None = None,
    kernel: Literal["tc", "dc"] | None = None,
    refine_check: str = "tests:0.95",
    selection: dict[str, float] | None = None,
    gain_covariance_start: bool = True,
    budgets: dict[str, float] | None = None,
    plan: str | None = None,
    covariance: bool = True,
    process_fixed: dict[str, float] | None = None,
    intersample: Literal["zoh", "foh"] | None = None,
    a_structure: Literal["full", "diagonal"] | None = None,
    f_structure: Literal["per-input", "common"] | None = None,
) -> dict[str, Any]: ...
def pbsid(
    us: list[npt.ArrayLike],
    ys: list[npt.ArrayLike],
    variant: PbsidVariant = "pbsid",
    order: int | None = None,
    max_order: int = 10,
    past: int | None = None,
    future: int | None = None,
    feedthrough: bool | None = None,
    detrend: Detrend = "mean",
    remove_means: bool = True,
    refine: Refine = "auto",
    refine_iterations: int = 100,
    refine_max_work: float = 2e10,
    dt: float = 1.0,
    threads: int = 1,
) -> dict[str, Any]: ...
def arxstruc(
    us: list[npt.ArrayLike],
    ys: list[npt.ArrayLike],
    us_val: list[npt.ArrayLike],
    ys_val: list[npt.ArrayLike],
    na: list[int],
    nb: list[int],
    nk: list[int],
    remove_means: bool = True,
    threads: int = 1,
) -> dict[str, Any]: ...
def delayest(
    us: list[npt.ArrayLike],
    ys: list[npt.ArrayLike],
    na: int = 2,
    nb: int = 2,
    min_delay: int = 0,
    max_delay: int = 20,
    remove_means: bool = True,
    threads: int = 1,
) -> list[list[int]]: ...
def polynomial_from_json(text: str) -> dict[str, Any]: ...
def simulate_experiment(
    plant: StateSpace,
    r: npt.ArrayLike,
    controller: StateSpace | None = None,
    reference: bool = True,
    feedback: Feedback = "fast",
    sampling: list[int] | None = None,
    holds: list[int] | None = None,
    snr: float | None = None,
    seed: int = 0,
    dt: float | None = None,
) -> dict[str, npt.NDArray[np.float64]]: ...
def iv(
    us: list[npt.ArrayLike],
    ys: list[npt.ArrayLike],
    instruments: list[npt.ArrayLike | None],
    order: int | None = None,
    max_order: int = 10,
    alpha: int | None = None,
    alpha_p: int | None = None,
    feedthrough: bool | None = None,
    order_criterion: OrderCriterion = "validation",
    detrend: Detrend = "mean",
    remove_means: bool = True,
    enforce_stability: bool = False,
    require_stable: bool = False,
    refine: Refine = "auto",
    refine_iterations: int = 100,
    refine_max_work: float = 2e10,
    dt: float = 1.0,
) -> dict[str, Any]: ...
def qmarkov(
    us: list[npt.ArrayLike],
    ys: list[npt.ArrayLike],
    q: int | None = None,
    order: int | None = None,
    max_order: int = 10,
    hold: int = 1,
    prbs_order: int | None = None,
    amplitudes: list[float] | None = None,
    last_period: bool | None = None,
    output_weight: list[float] | None = None,
    detrend: Detrend = "mean",
    remove_means: bool = True,
    enforce_stability: bool = False,
    require_stable: bool = False,
    refine: Refine = "auto",
    refine_iterations: int = 100,
    refine_max_work: float = 2e10,
    dt: float = 1.0,
) -> dict[str, Any]: ...
def multirate(
    u: npt.ArrayLike,
    y: npt.ArrayLike,
    periods: list[int],
    holds: list[int] | None = None,
    instrument: npt.ArrayLike | None = None,
    method: IdentifyMethod = "n4sid",
    order: int | None = None,
    max_order: int = 10,
    horizon: int | None = None,
    past: int | None = None,
    future: int | None = None,
    alpha: int | None = None,
    alpha_p: int | None = None,
    detrend: Detrend = "mean",
    remove_means: bool = True,
    enforce_stability: bool = False,
    require_stable: bool = False,
    refine: Refine = "auto",
    refine_iterations: int = 100,
    refine_max_work: float = 2e10,
    dt: float = 1.0,
    gain_stop_share: float = 0.01,
    integrator_tolerance: float | None = None,
) -> dict[str, Any]: ...
def validate(
    model: StateSpace,
    u: npt.ArrayLike,
    y: npt.ArrayLike,
    periods: list[int] | None = None,
    lags: int = 20,
    kalman_gain: npt.ArrayLike | None = None,
    u0: npt.ArrayLike | None = None,
    y0: npt.ArrayLike | None = None,
    horizons: list[int] = ...,  # [1, 5]
    dt: float | None = None,
    initial_state: str = "estimate",
) -> dict[str, Any]: ...
def _choices() -> list[tuple[str, list[str]]]: ...
def _diagnostics_fields() -> list[str]: ...

# Mergeable partial compressions and the regression's second pass
# (lifted.dask): every state crossing a process boundary is bytes.
@final
class FirstPass:
    def wants_second_pass(self) -> bool: ...
    def regression(self) -> bytes: ...
    def finish(
        self,
        stream: bytes | None = None,
        input_scales: list[float] | None = None,
        output_scales: list[float] | None = None,
    ) -> dict[str, Any]: ...

def channel_scales(u: npt.ArrayLike, y: npt.ArrayLike) -> tuple[list[float], list[float]]: ...
def partial_plan(
    u: npt.ArrayLike, y: npt.ArrayLike, past: int = 10, future: int = 10, remove_means: bool = True
) -> bytes: ...
def partial_compress(plan: bytes, u: npt.ArrayLike, y: npt.ArrayLike, threads: int = 1) -> bytes: ...
def partial_append(first: bytes, second: bytes) -> bytes: ...
def partial_close(piece: bytes) -> bytes: ...
def partial_merge(first: bytes, second: bytes) -> bytes: ...
def partial_identify(
    records: bytes,
    method: str = "n4sid",
    order: int | None = None,
    max_order: int = 10,
    past: int = 10,
    future: int = 10,
    remove_means: bool = True,
    noise_model: bool = True,
    dt: float = 1.0,
    threads: int = 1,
) -> FirstPass: ...
def regression_push(stream: bytes, u: npt.ArrayLike, y: npt.ArrayLike) -> bytes: ...
def regression_end_record(stream: bytes) -> bytes: ...
def regression_prime(stream: bytes, u: npt.ArrayLike, y: npt.ArrayLike) -> bytes: ...
def regression_advance(stream: bytes, u: npt.ArrayLike, y: npt.ArrayLike) -> bytes: ...
def regression_scan(stream: bytes, u: npt.ArrayLike, y: npt.ArrayLike) -> bytes: ...
def regression_merge(first: bytes, second: bytes) -> bytes: ...
def regression_absorb(stream: bytes, piece: bytes) -> bytes: ...
def partial_compress_npy(
    plan: bytes,
    path: str,
    inputs: list[int],
    outputs: list[int],
    input_scales: list[float],
    output_scales: list[float],
    threads: int = 1,
) -> bytes: ...
def regression_npy(
    stream: bytes,
    path: str,
    inputs: list[int],
    outputs: list[int],
    input_scales: list[float],
    output_scales: list[float],
    advance: bool = False,
) -> bytes: ...
def regression_memory(stream: bytes) -> int | None: ...
