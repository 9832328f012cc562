"""Result objects of the identification, validation and simulation calls.

Plain dataclasses of numpy arrays, numbers and :class:`~lifted.StateSpace`
models, so they pickle (the model as its model-file JSON) and travel to
worker processes (``multiprocessing``, ``concurrent.futures``, Dask) as
they are. Each also answers ``result["name"]`` (and ``keys()``), the
mapping view of the dict results of earlier versions.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

import numpy as np
import numpy.typing as npt

from ._lifted import StateSpace

__all__ = [
    "SubspaceFit",
    "IvFit",
    "QMarkovFit",
    "MultirateFit",
    "OutputValidation",
    "Validation",
    "Experiment",
]

FloatArray = npt.NDArray[np.float64]


class _Result:
    """Mapping-style access and a short repr for the result dataclasses."""

    #: Fields shown by ``repr`` (the rest are arrays or long lists).
    _shown: tuple[str, ...] = ()

    def __getitem__(self, key: str) -> Any:
        if key not in self.keys():
            raise KeyError(key)
        return getattr(self, key)

    def __contains__(self, key: object) -> bool:
        return key in self.keys()

    def keys(self) -> list[str]:
        """The field names (the keys of the former dict results)."""
        return [f.name for f in fields(self)]  # type: ignore[arg-type]

    def __repr__(self) -> str:
        parts = ", ".join(f"{k}={getattr(self, k)!r}" for k in self._shown)
        return f"{type(self).__name__}({parts})"


@dataclass(frozen=True, eq=False, repr=False)
class SubspaceFit(_Result):
    """Result of :func:`lifted.identify` (N4SID, MOESP, CVA, PBSID, SSARX,
    IV) and :func:`lifted.pbsid`.

    ``model`` carries the operating point (``u0``, ``y0``: the means removed
    from the records, None with ``remove_means=False``) and the Kalman gain
    of the noise model, so :func:`lifted.validate` and :func:`lifted.simulate`
    work on plant values as ``lifted validate --model`` does.
    """

    model: StateSpace
    kalman_gain: FloatArray | None
    x0: list[FloatArray]
    u0: FloatArray | None
    y0: FloatArray | None
    singular_values: FloatArray
    order: int
    suggested_order: int
    method: str
    threads: int
    model_json: str
    diagnostics: dict[str, Any]

    _shown = ("method", "order", "suggested_order", "model")


@dataclass(frozen=True, eq=False, repr=False)
class IvFit(_Result):
    """Result of :func:`lifted.iv` (closed-loop instrumental-variable subspace).

    ``model`` carries the operating point (the offsets removed) and, when
    the prediction-error refinement was kept, its Kalman gain;
    ``diagnostics`` is the model file's diagnostics.
    """

    model: StateSpace
    x0: list[FloatArray]
    singular_values: FloatArray
    order: int
    suggested_order: int
    stabilized: bool
    method: str
    model_json: str
    diagnostics: dict[str, Any]

    _shown = ("method", "order", "suggested_order", "stabilized", "model")


@dataclass(frozen=True, eq=False, repr=False)
class QMarkovFit(_Result):
    """Result of :func:`lifted.qmarkov` (weighted multirate q-Markov Cover).

    ``markov_model``, ``markov_error``, ``covariance_error`` and ``cover``
    describe the identified cover (before any refinement); ``stable`` and
    ``spectral_radius`` the model returned; ``diagnostics`` is the model
    file's diagnostics.
    """

    model: StateSpace
    eigenvalues: FloatArray
    order: int
    suggested_order: int
    markov_data: list[FloatArray]
    markov_model: list[FloatArray]
    markov_error: float
    covariance_error: float
    cover: str
    stable: bool
    spectral_radius: float
    stabilized_from: float | None
    method: str
    model_json: str
    diagnostics: dict[str, Any]

    _shown = ("method", "order", "cover", "stable", "model")


@dataclass(frozen=True, eq=False, repr=False)
class MultirateFit(_Result):
    """Result of :func:`lifted.multirate`: the fast model at the base period
    (``fast``, also ``model``; after the workflow's refinement, with the
    operating point) and the lifted model it was extracted from;
    ``diagnostics`` is the model file's diagnostics."""

    fast: StateSpace
    lifted: StateSpace
    lifting_period: int
    singular_values: FloatArray
    order: int
    method: str
    model_json: str
    diagnostics: dict[str, Any]

    _shown = ("method", "order", "lifting_period", "fast")

    @property
    def model(self) -> StateSpace:
        """The fast model (the identified model at the base period)."""
        return self.fast


@dataclass(frozen=True, eq=False, repr=False)
class OutputValidation(_Result):
    """Validation of one output (see :func:`lifted.validate`)."""

    name: str
    fit: float
    prediction_fits: list[float]
    samples: int
    bound: float
    auto: list[float]
    cross: list[list[float]]
    white: bool
    independent: bool
    simulated: FloatArray

    _shown = ("name", "fit", "prediction_fits", "white", "independent")


@dataclass(frozen=True, eq=False, repr=False)
class Validation(_Result):
    """Result of :func:`lifted.validate`: one :class:`OutputValidation` per output."""

    outputs: list[OutputValidation]
    lags: int
    horizons: list[int]
    stable: bool
    spectral_radius: float
    #: The initial state the simulation started from when it was estimated
    #: (``initial_state="estimate"`` on a stable model); ``None`` for rest.
    x0: FloatArray | None = None
    #: The residual of the whiteness and independence tests: ``"one-step
    #: prediction"`` (the innovations of a model with its Kalman gain on a
    #: single-rate record, as MATLAB's ``resid``) or ``"simulation"``.
    residual: str = "simulation"
    #: Why the model's Kalman gain was left out, when it was: it was
    #: estimated with the outputs sampled at other periods than this
    #: record's (the command line's rule: no prediction fits, the residual
    #: tests on the simulation error); ``None`` otherwise.
    gain_note: str | None = None

    _shown = ("outputs", "horizons", "stable", "residual")


@dataclass(frozen=True, eq=False, repr=False)
class Experiment(_Result):
    """Result of :func:`lifted.simulate_experiment` (samples x channels)."""

    u: FloatArray
    y: FloatArray
    y_fast: FloatArray
    y_clean: FloatArray

    def __repr__(self) -> str:
        return f"Experiment(samples={self.u.shape[0]}, inputs={self.u.shape[1]}, outputs={self.y.shape[1]})"
