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
from ._lifted import iv as _iv
from ._lifted import multirate as _multirate
from ._lifted import qmarkov as _qmarkov
from ._lifted import validate as _validate
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
    "iv",
    "qmarkov",
    "multirate",
    "validate",
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


def _records(u: Any, y: Any) -> tuple[list[np.ndarray], list[np.ndarray], bool]:
    many = isinstance(u, (list, tuple))
    if many != isinstance(y, (list, tuple)):
        raise LiftedError("u and y must both be arrays or both be lists of arrays")
    us: Sequence[Any] = u if many else [u]
    ys: Sequence[Any] = y if many else [y]
    return [_as_2d(a, "u") for a in us], [_as_2d(a, "y") for a in ys], many


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
) -> dict[str, Any]:
    """Instrumental-variable subspace identification, open or closed loop
    (thesis ch. 7, ``lifted_subspace::iv_identify``).

    ``instrument`` (N x m, per record when ``u`` is a list) is the external
    excitation of a closed loop (the dither at the plant input or the
    set-point), independent of the noise; None uses ``u`` (open loop).
    ``alpha`` future block rows, ``alpha_p`` past instrument rows (None: 2
    alpha, erratum L-16). Defaults are ``IvOptions``'. Returns ``model``,
    ``x0``, ``singular_values``, ``order``, ``suggested_order``,
    ``stabilized``, ``method`` and ``model_json``.
    """
    us, ys, many = _records(u, y)
    if instrument is None:
        fs: list[Any] = [None] * len(us)
    elif many:
        if not isinstance(instrument, (list, tuple)):
            raise LiftedError("with lists of records, instrument must be a list too")
        fs = [None if f is None else _as_2d(f, "instrument") for f in instrument]
    else:
        fs = [_as_2d(instrument, "instrument")]
    return _iv(us, ys, fs, order, max_order, alpha, alpha_p, enforce_stability, require_stable, dt)


def qmarkov(
    u: Any,
    y: Any,
    *,
    q: int = 60,
    order: int | None = None,
    max_order: int = 20,
    hold: int = 1,
    prbs_order: int = 8,
    amplitudes: Sequence[float] | None = None,
    last_period: bool = False,
    enforce_stability: bool = False,
    require_stable: bool = True,
    dt: float = 1.0,
) -> dict[str, Any]:
    """Weighted multirate q-Markov Cover (Zhu 2000) from inverse-PRBS tests.

    One experiment per input channel: ``u[l]`` (N x m, only column l
    non-zero, e.g. from :func:`inverse_prbs`) and ``y[l]`` (N x p); a single
    array pair is one experiment of a single-input plant. ``hold`` is n_r,
    ``prbs_order`` the m-sequence order, ``q`` the number of Markov and
    covariance parameters matched, ``order`` r (None: largest gap of diag
    Lambda up to ``max_order``). ``last_period`` uses the last PRBS period of
    a longer record. Defaults are ``QMarkovOptions``'. Returns ``model``,
    ``eigenvalues`` (order-selection values), ``order``, ``suggested_order``,
    ``markov_data``/``markov_model`` (lists of p x m arrays),
    ``markov_error``, ``covariance_error``, ``cover``, ``stable``,
    ``spectral_radius``, ``stabilized_from`` and ``model_json``.
    """
    us, ys, _ = _records(u, y)
    return _qmarkov(
        us, ys, q, order, max_order, hold, prbs_order,
        None if amplitudes is None else [float(a) for a in amplitudes],
        last_period, enforce_stability, require_stable, dt,
    )


def multirate(
    u: Any,
    y: Any,
    periods: Sequence[int],
    *,
    holds: Sequence[int] | None = None,
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
) -> dict[str, Any]:
    """Multirate identification (thesis chs. 4-5): lifting, causal lifted
    subspace identification, fast-model extraction.

    ``y`` (N x p) has NaN where output i is not sampled; it is sampled every
    ``periods[i]`` base periods from sample 0; input i is held ``holds[i]``
    samples (default 1). With ``instrument`` (N x m, the closed-loop dither)
    the lifted IV route of thesis section 7.8.2 is used (``alpha`` block rows).
    ``enforce_stability`` re-estimates an unstable lifted A by the
    zero-padded shift. Returns ``fast`` (model at ``dt``), ``lifted``,
    ``lifting_period``, ``singular_values``, ``order``, ``method`` and
    ``model_json``.
    """
    f = None if instrument is None else _as_2d(instrument, "instrument")
    return _multirate(
        _as_2d(u, "u"), _as_2d(y, "y"), [int(p) for p in periods],
        None if holds is None else [int(h) for h in holds],
        f, method, order, max_order, past, future, alpha,
        enforce_stability, require_stable, dt,
    )


def validate(
    model: StateSpace,
    u: Any,
    y: Any,
    *,
    periods: Sequence[int] | None = None,
    lags: int = 20,
    kalman_gain: Any = None,
    u0: Sequence[float] | None = None,
    y0: Sequence[float] | None = None,
    horizons: Sequence[int] = (1, 5),
    dt: float | None = None,
) -> dict[str, Any]:
    """Validation of ``model`` on a record (``lifted_lti::validate``, the CLI's
    ``validate``): per output the simulation fit (%), k-step-ahead prediction
    fits with ``kalman_gain`` (n x p), residual whiteness and independence
    from the inputs at the 99 % level (``lags`` correlation lags).

    ``y`` may have NaN at unsampled instants (``periods`` per output);
    ``u0``/``y0`` are the model's operating point (e.g. ``identify``'s).
    Returns ``{"outputs": [...], "lags": M, "horizons": [...]}``.
    """
    k = None if kalman_gain is None else _as_2d(kalman_gain, "kalman_gain")
    return _validate(
        model, _as_2d(u, "u"), _as_2d(y, "y"),
        None if periods is None else [int(p) for p in periods],
        lags, k,
        None if u0 is None else [float(v) for v in u0],
        None if y0 is None else [float(v) for v in y0],
        [int(h) for h in horizons], dt,
    )


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
