from typing import Any

import numpy as np
import numpy.typing as npt

from ._lifted import LiftedError as LiftedError
from ._lifted import Mpc as Mpc
from ._lifted import StateSpace as StateSpace
from ._lifted import design as design
from ._lifted import gbn as gbn
from ._lifted import inverse_prbs as inverse_prbs
from ._lifted import multisine as multisine
from ._lifted import prbs as prbs
from ._lifted import rbs as rbs

def simulate(
    sys: StateSpace, u: Any, x0: Any = None, dt: float | None = None
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
def simulate_experiment(
    plant: StateSpace,
    r: Any,
    controller: StateSpace | None = None,
    *,
    reference: bool = True,
    feedback: str = "fast",
    sampling: list[int] | None = None,
    holds: list[int] | None = None,
    snr: float | None = None,
    seed: int = 0,
    dt: float | None = None,
) -> dict[str, npt.NDArray[np.float64]]: ...
def identify(
    u: Any,
    y: Any,
    method: str = "n4sid",
    *,
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
def n4sid(u: Any, y: Any, **kwargs: Any) -> dict[str, Any]: ...
def moesp(u: Any, y: Any, **kwargs: Any) -> dict[str, Any]: ...
def cva(u: Any, y: Any, **kwargs: Any) -> dict[str, Any]: ...
def iv(
    u: Any,
    y: Any,
    instrument: Any = None,
    *,
    order: int | None = None,
    max_order: int = 10,
    alpha: int = 8,
    alpha_p: int | None = None,
    enforce_stability: bool = False,
    require_stable: bool = False,
    dt: float = 1.0,
) -> dict[str, Any]: ...
def qmarkov(
    u: Any,
    y: Any,
    *,
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
    u: Any,
    y: Any,
    periods: list[int],
    *,
    holds: list[int] | None = None,
    instrument: Any = None,
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
    u: Any,
    y: Any,
    *,
    periods: list[int] | None = None,
    lags: int = 20,
    kalman_gain: Any = None,
    u0: list[float] | None = None,
    y0: list[float] | None = None,
    horizons: tuple[int, ...] = (1, 5),
    dt: float | None = None,
) -> dict[str, Any]: ...
def to_control(sys: StateSpace) -> Any: ...
def from_control(cs: Any) -> StateSpace: ...
