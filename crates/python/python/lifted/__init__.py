"""Lifted: identification and control of multirate sampled-data systems.

numpy arrays in and out, samples x channels, float64. The numerics are the
Rust crates' (lifted-lti, lifted-prbs, lifted-subspace); this package only
converts arguments and results. Every error of the library is raised as
:class:`LiftedError`, a subclass of :class:`ValueError`, with the Rust message.
Long computations release the GIL, so threads run them in parallel.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from ._lifted import (
    LiftedError,
    Mpc,
    StateSpace,
    design,
    gbn,
    inverse_prbs,
    multisine,
    prbs,
    rbs,
)
from ._lifted import identify as _identify
from ._lifted import simulate_experiment as _simulate_experiment

__all__ = [
    "LiftedError",
    "StateSpace",
    "Mpc",
    "prbs",
    "inverse_prbs",
    "design",
    "rbs",
    "gbn",
    "multisine",
    "simulate",
    "simulate_experiment",
    "identify",
    "n4sid",
    "moesp",
    "cva",
    "to_control",
    "from_control",
]


def _as_2d(a: Any, name: str) -> np.ndarray:
    """float64, C-contiguous, samples x channels (a 1-D array is one channel)."""
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim == 1:
        arr = arr.reshape(-1, 1)
    if arr.ndim != 2:
        raise LiftedError(f"{name} must be a 1-D or 2-D array, got {arr.ndim} dimensions")
    return np.ascontiguousarray(arr)


def simulate(
    sys: StateSpace, u: Any, x0: Any = None, dt: float | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Simulates ``sys`` driven by ``u`` (N x m); returns ``(y, x)`` (N x p, N x n)."""
    x = None if x0 is None else np.ascontiguousarray(np.asarray(x0, dtype=np.float64).ravel())
    return sys.lsim(_as_2d(u, "u"), x, dt)


def simulate_experiment(
    plant: StateSpace,
    r: Any,
    controller: StateSpace | None = None,
    *,
    reference: bool = True,
    feedback: str = "fast",
    sampling: Sequence[int] | None = None,
    holds: Sequence[int] | None = None,
    snr: float | None = None,
    seed: int = 0,
    dt: float | None = None,
) -> dict[str, np.ndarray]:
    """Open- or closed-loop, multirate experiment (``lifted_sim::Simulator``).

    Without ``controller``, ``r`` (N x m) is the plant input. With a discrete
    ``controller`` at the plant's period, ``r`` is the setpoint (N x p) when
    ``reference`` else an input disturbance (N x m); ``feedback`` is "fast"
    or "hold_last". ``sampling``: output sampling period per output, in base
    periods; ``holds``: input hold per input; ``snr``: seeded white output
    noise at this variance ratio; ``dt``: ZOH period of a continuous plant.
    Returns ``u``, ``y`` (NaN where a channel does not sample), ``y_fast``
    and ``y_clean`` (no added noise), all samples x channels.
    """
    return _simulate_experiment(
        plant,
        _as_2d(r, "r"),
        controller,
        reference,
        feedback,
        None if sampling is None else list(sampling),
        None if holds is None else list(holds),
        snr,
        seed,
        dt,
    )


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
) -> dict[str, Any]:
    """Subspace identification (N4SID, MOESP or CVA) of one record or several.

    ``u`` and ``y`` are arrays (N x m, N x p) or lists of such arrays (several
    experiments). Defaults are those of ``lifted_subspace::SubspaceOptions``:
    automatic order by the singular-value gap up to ``max_order``, horizons
    10/10, means removed, noise model estimated, ``dt`` = 1 s.
    Returns a dict with ``model`` (:class:`StateSpace`), ``kalman_gain``,
    ``x0``, ``u0``, ``y0``, ``singular_values``, ``order``,
    ``suggested_order``, ``method`` and ``model_json`` (the CLI's model file).
    ``system`` is None (the library's default ``SystemEstimate``), "shift" or
    "states"; ``threads`` the correlation-kernel threads (0 = all cores).
    """
    many = isinstance(u, (list, tuple))
    if many != isinstance(y, (list, tuple)):
        raise LiftedError("u and y must both be arrays or both be lists of arrays")
    us: Sequence[Any] = u if many else [u]
    ys: Sequence[Any] = y if many else [y]
    return _identify(
        [_as_2d(a, "u") for a in us],
        [_as_2d(a, "y") for a in ys],
        method,
        order,
        max_order,
        past,
        future,
        remove_means,
        noise_model,
        enforce_stability,
        dt,
        threads,
        system,
    )


def n4sid(u: Any, y: Any, **kwargs: Any) -> dict[str, Any]:
    """:func:`identify` with ``method="n4sid"``."""
    return identify(u, y, "n4sid", **kwargs)


def moesp(u: Any, y: Any, **kwargs: Any) -> dict[str, Any]:
    """:func:`identify` with ``method="moesp"``."""
    return identify(u, y, "moesp", **kwargs)


def cva(u: Any, y: Any, **kwargs: Any) -> dict[str, Any]:
    """:func:`identify` with ``method="cva"``."""
    return identify(u, y, "cva", **kwargs)


def to_control(sys: StateSpace) -> Any:
    """The python-control ``StateSpace`` of ``sys`` (needs ``pip install control``)."""
    try:
        import control
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("to_control needs python-control: pip install control") from e
    dt = 0 if sys.dt is None else sys.dt
    return control.ss(sys.A, sys.B, sys.C, sys.D, dt)


def from_control(cs: Any) -> StateSpace:
    """A :class:`StateSpace` from a python-control ``StateSpace``
    (``dt`` 0 is continuous; ``dt=True``, an unspecified period, is rejected)."""
    dt = cs.dt
    if dt is True:
        raise LiftedError("python-control model with unspecified sample period (dt=True)")
    dt = None if dt is None or dt == 0 else float(dt)

    def m(a: Any) -> np.ndarray:
        return np.ascontiguousarray(np.atleast_2d(np.asarray(a, dtype=np.float64)))

    return StateSpace(m(cs.A), m(cs.B), m(cs.C), m(cs.D), dt)
