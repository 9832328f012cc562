"""Type stubs of the extension module (Rust, PyO3)."""

from typing import Any

import numpy as np
import numpy.typing as npt

class LiftedError(ValueError):
    """Any error of the Lifted library; the message is the Rust error's."""

class StateSpace:
    """(A, B, C, D, dt); dt None = continuous time."""

    def __init__(
        self,
        a: npt.NDArray[np.float64],
        b: npt.NDArray[np.float64],
        c: npt.NDArray[np.float64],
        d: npt.NDArray[np.float64],
        dt: float | None = None,
    ) -> None: ...
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
    def poles(self) -> npt.NDArray[np.complex128]: ...
    def zeros(self) -> npt.NDArray[np.complex128]: ...
    def dcgain(self) -> npt.NDArray[np.float64]: ...
    def is_stable(self, margin: float = 0.0) -> bool: ...
    def freqresp(self, omega: npt.NDArray[np.float64]) -> npt.NDArray[np.complex128]: ...
    def step(self, n_samples: int, dt: float | None = None) -> npt.NDArray[np.float64]: ...
    def lsim(
        self,
        u: npt.NDArray[np.float64],
        x0: npt.NDArray[np.float64] | None = None,
        dt: float | None = None,
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def c2d(
        self,
        dt: float,
        method: str = "zoh",
        prewarp: float | None = None,
        input_delays: list[float] | None = None,
    ) -> StateSpace: ...
    def d2c(self) -> StateSpace: ...
    def to_json(self, method: str | None = None) -> str: ...
    @staticmethod
    def from_json(text: str) -> StateSpace: ...

class Mpc:
    """DMC (kind="dmc") or state-space MPC (kind="gpc"); None/NaN = output not sampled."""

    def __init__(
        self,
        model: StateSpace,
        kind: str = "gpc",
        prediction_horizon: int = 12,
        control_horizon: int = 3,
        output_weight: npt.NDArray[np.float64] | None = None,
        move_weight: npt.NDArray[np.float64] | None = None,
        truncation: int | None = None,
        u_min: npt.NDArray[np.float64] | None = None,
        u_max: npt.NDArray[np.float64] | None = None,
        du_max: npt.NDArray[np.float64] | None = None,
        y_min: npt.NDArray[np.float64] | None = None,
        y_max: npt.NDArray[np.float64] | None = None,
    ) -> None: ...
    def step(
        self, measured: list[float | None], reference: npt.NDArray[np.float64]
    ) -> npt.NDArray[np.float64]: ...
    def simulate(
        self,
        plant: StateSpace,
        reference: npt.NDArray[np.float64],
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
def identify(
    us: list[npt.NDArray[np.float64]],
    ys: list[npt.NDArray[np.float64]],
    method: str = "n4sid",
    order: int | None = None,
    max_order: int = 10,
    past: int = 10,
    future: int = 10,
    remove_means: bool = True,
    noise_model: bool = True,
    enforce_stability: bool = False,
    dt: float = 1.0,
    threads: int = 1,
    system: str | None = None,
) -> dict[str, Any]: ...
def simulate_experiment(
    plant: StateSpace,
    r: npt.NDArray[np.float64],
    controller: StateSpace | None = None,
    reference: bool = True,
    feedback: str = "fast",
    sampling: list[int] | None = None,
    holds: list[int] | None = None,
    snr: float | None = None,
    seed: int = 0,
    dt: float | None = None,
) -> dict[str, npt.NDArray[np.float64]]: ...
def iv(
    us: list[npt.NDArray[np.float64]],
    ys: list[npt.NDArray[np.float64]],
    instruments: list[npt.NDArray[np.float64] | None],
    order: int | None = None,
    max_order: int = 10,
    alpha: int = 8,
    alpha_p: int | None = None,
    enforce_stability: bool = False,
    require_stable: bool = False,
    dt: float = 1.0,
) -> dict[str, Any]: ...
def qmarkov(
    us: list[npt.NDArray[np.float64]],
    ys: list[npt.NDArray[np.float64]],
    q: int = 60,
    order: int | None = None,
    max_order: int = 20,
    hold: int = 1,
    prbs_order: int = 8,
    amplitudes: list[float] | None = None,
    last_period: bool = False,
    enforce_stability: bool = False,
    require_stable: bool = True,
    dt: float = 1.0,
) -> dict[str, Any]: ...
def multirate(
    u: npt.NDArray[np.float64],
    y: npt.NDArray[np.float64],
    periods: list[int],
    holds: list[int] | None = None,
    instrument: npt.NDArray[np.float64] | None = None,
    method: str = "n4sid",
    order: int | None = None,
    max_order: int = 10,
    past: int = 10,
    future: int = 10,
    alpha: int = 6,
    enforce_stability: bool = False,
    require_stable: bool = True,
    dt: float = 1.0,
) -> dict[str, Any]: ...
def validate(
    model: StateSpace,
    u: npt.NDArray[np.float64],
    y: npt.NDArray[np.float64],
    periods: list[int] | None = None,
    lags: int = 20,
    kalman_gain: npt.NDArray[np.float64] | None = None,
    u0: list[float] | None = None,
    y0: list[float] | None = None,
    horizons: list[int] = ...,
    dt: float | None = None,
) -> dict[str, Any]: ...
