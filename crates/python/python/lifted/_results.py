"""Result objects of the identification, validation and simulation calls.

Plain dataclasses of numpy arrays, numbers and :class:`~lifted.StateSpace`
models, so they pickle (the model as its model-file JSON) and travel to
worker processes (``multiprocessing``, ``concurrent.futures``, Dask) as
they are. Each also answers ``result["name"]`` (and ``keys()``), the
mapping view of the dict results of earlier versions.
"""

from __future__ import annotations

import json
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
import numpy.typing as npt

from ._lifted import ArgumentError, StateSpace

__all__ = [
    "Diagnostics",
    "PolyModel",
    "ArxScan",
    "SubspaceFit",
    "IvFit",
    "QMarkovFit",
    "MultirateFit",
    "OutputValidation",
    "Validation",
    "Experiment",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


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


@dataclass(eq=False)
class Diagnostics(Mapping[str, Any]):
    """The diagnostics of a model, mirroring ``lifted_workflow::Diagnostics``.

    The entries every front end reads are fields (``route``, ``samples``,
    ``order_selection``, ``structure_selection``, ``warnings``,
    ``kalman_gain_route``, ``refinement``, ``plan``, …: the same names as
    the model file's ``diagnostics`` object, their values as JSON gives
    them); what only some routes write (a multirate extraction, a PBSID
    past selection, …) is in :attr:`details` by name. The fields are checked
    against the Rust type by the test suite
    (``lifted._lifted._diagnostics_fields()``).

    It is also the read-only mapping of the model file's ``diagnostics``
    object, so ``fit.diagnostics["structure_selection"]``, ``"plan" in
    fit.diagnostics`` and ``fit.diagnostics == file["diagnostics"]`` work
    as with the dict of earlier versions; :meth:`to_dict` gives the plain
    dict (for ``json.dumps``).
    """

    route: str | None = None
    samples: int | None = None
    base_period: float | None = None
    output_periods: list[int] | None = None
    data: list[str] | None = None
    profile: dict[str, float] | None = None
    warnings: list[str] = field(default_factory=list)
    fallbacks: list[str] | None = None
    notes: list[str] | None = None
    horizons: list[int] | None = None
    order_selection: dict[str, Any] | None = None
    order_criterion: dict[str, Any] | None = None
    structure_selection: dict[str, Any] | None = None
    compression: dict[str, Any] | str | None = None
    stabilized: bool | None = None
    stability: dict[str, Any] | None = None
    integrators: dict[str, Any] | None = None
    feedback: dict[str, Any] | None = None
    kalman_gain_route: dict[str, Any] | None = None
    refinement: dict[str, Any] | None = None
    refinement_judge: dict[str, Any] | None = None
    refinement_decision: str | None = None
    process: dict[str, Any] | None = None
    options: dict[str, Any] | None = None
    plan: dict[str, Any] | None = None
    budgets: dict[str, Any] | None = None
    selection_policy: dict[str, Any] | None = None
    details: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def from_json(cls, obj: Mapping[str, Any] | None) -> Diagnostics:
        """The diagnostics of a model file's ``diagnostics`` object (None:
        none written)."""
        if obj is None:
            return cls()
        known = {k: v for k, v in obj.items() if k in _DIAGNOSTICS_FIELDS}
        details = {k: v for k, v in obj.items() if k not in _DIAGNOSTICS_FIELDS}
        return cls(**known, details=details)

    def _typed(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for f in fields(self):
            if f.name == "details":
                continue
            v = getattr(self, f.name)
            if v is None or (f.name == "warnings" and not v):
                continue
            out[f.name] = v
        return out

    def to_dict(self) -> dict[str, Any]:
        """The model file's ``diagnostics`` object."""
        return {**self._typed(), **self.details}

    def __getitem__(self, key: str) -> Any:
        if key in _DIAGNOSTICS_FIELDS:
            value = getattr(self, key)
            if value is None or (key == "warnings" and not value):
                raise KeyError(key)
            return value
        return self.details[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self.to_dict())

    def __len__(self) -> int:
        return len(self.to_dict())

    def __repr__(self) -> str:
        return f"Diagnostics(route={self.route!r}, entries={sorted(self.to_dict())})"


#: The typed fields of :class:`Diagnostics` (``details`` aside).
_DIAGNOSTICS_FIELDS = frozenset(f.name for f in fields(Diagnostics)) - {"details"}


@dataclass(frozen=True, eq=False, repr=False)
class PolyModel(_Result):
    """A discrete-time polynomial model (MATLAB's ``idpoly``,
    ``lifted_lti::PolyModel``), as estimated by :func:`lifted.arx` and
    :func:`lifted.fir` (``fit.polynomial``)::

        A(q) y(t) = sum_k B_k(q) / F_k(q) u_k(t - nk_k) + C(q) / D(q) e(t)

    with ``q^-1`` the one-sample delay and ``e`` white noise of covariance
    ``noise_variance`` (Lambda). ARX: C = D = F = 1; FIR: A = 1 too. Multi-output:
    ``A`` is ``p x p`` polynomials (the diagonal monic, the off-diagonal
    ones starting with 0), ``B``, ``F`` and ``nk`` are ``p x m``, ``C`` and
    ``D`` one per output.

    Every polynomial is a list of coefficients in **ascending powers of
    q^-1**: ``a[i][j] = [1, a1, ..., a_na]`` (the monic diagonal), ``b[i][k]
    = [b0, ..., b_{nb-1}]`` multiplying ``u_k(t - nk[i][k])``, ``u_k(t -
    nk - 1)``, ...; ``c[i]``, ``d[i]``, ``f[i][k]`` monic. The model is in
    the data's units (the operating point, when one was removed, is the
    model file's).

    ``parameters`` is MATLAB's ``getpvec`` order: per output i, the free
    coefficients of A_i1 ... A_ip (the leading 1 of the diagonal left out),
    then B_i1 ... B_im, C_i, D_i, F_i1 ... F_im; for a SISO ARX
    ``[a1 .. a_na, b0 .. b_{nb-1}]``. ``covariance`` is their covariance
    (the least-squares one for ARX/FIR: Lambda (Phi^T Phi)^-1, exact for
    white e; None when not estimated) and ``std`` the square roots of its
    diagonal. ``orders`` holds MATLAB's orders (``na``, ``nb``, ``nc``,
    ``nd``, ``nf``, ``nk``) as nested lists, ``family`` is ``"arx"``,
    ``"armax"``, ``"oe"``, ``"bj"``, ``"fir"`` or ``"general"``, ``dt`` the
    sample period. :meth:`to_json` / :meth:`from_json` round-trip it
    (``from_json`` also reads a model file of kind ``"polynomial"``, such as
    ``fit.model_json``).
    """

    family: str
    dt: float
    a: list[list[list[float]]]
    b: list[list[list[float]]]
    c: list[list[float]]
    d: list[list[float]]
    f: list[list[list[float]]]
    nk: list[list[int]]
    orders: dict[str, Any]
    noise_variance: FloatArray
    parameters: FloatArray
    covariance: FloatArray | None
    std: FloatArray | None
    poly_json: str

    _shown = ("family", "orders", "dt")

    @classmethod
    def _of(cls, d: dict[str, Any]) -> PolyModel:
        """The model of the extension's dict."""
        cov = d["covariance"]
        std = d["std"]
        return cls(
            family=d["family"],
            dt=float(d["dt"]),
            a=d["a"],
            b=d["b"],
            c=d["c"],
            d=d["d"],
            f=d["f"],
            nk=d["nk"],
            orders=d["orders"],
            noise_variance=np.asarray(d["noise_variance"], dtype=np.float64),
            parameters=np.asarray(d["parameters"], dtype=np.float64),
            covariance=None if cov is None else np.asarray(cov, dtype=np.float64),
            std=None if std is None else np.asarray(std, dtype=np.float64),
            poly_json=d["poly_json"],
        )

    @classmethod
    def from_json(cls, text: str) -> PolyModel:
        """The polynomial model of ``text``: a model file of kind
        ``"polynomial"`` (``fit.model_json`` of an ARX/FIR fit, the file
        ``lifted identify --method arx`` writes) or the model's own JSON
        (:meth:`to_json`). A state-space model file is a
        :class:`~lifted.LiftedError` (it holds no polynomial model)."""
        from ._lifted import polynomial_from_json

        return cls._of(polynomial_from_json(text))

    def to_json(self) -> str:
        """The model's JSON (``lifted_lti::PolyModel``: polynomials,
        ``noise_variance``, ``covariance``), read back by :meth:`from_json`."""
        return self.poly_json

    def tf_data(self) -> tuple[list[list[list[float]]], list[list[list[float]]]]:
        """Numerators and denominators of the plant G(z) = z^-nk B/(A F)
        per (output, input) pair, in **descending powers of z** (the
        convention of python-control and scipy), padded to one length per
        pair. Needs a diagonal A (a coupled multi-output ARX: use the
        state-space ``fit.model``)."""
        p, m = len(self.b), len(self.b[0]) if self.b else 0
        for i in range(p):
            for j in range(p):
                if i != j and any(v != 0.0 for v in self.a[i][j]):
                    raise ArgumentError(
                        "tf_data: A is coupled between outputs (a multi-output ARX); "
                        "use the state-space model fit.model"
                    )
        nums: list[list[list[float]]] = []
        dens: list[list[list[float]]] = []
        for i in range(p):
            nrow: list[list[float]] = []
            drow: list[list[float]] = []
            for k in range(m):
                num = [0.0] * self.nk[i][k] + [float(v) for v in self.b[i][k]]
                den = [float(v) for v in np.convolve(self.a[i][i], self.f[i][k])]
                n = max(len(num), len(den))
                nrow.append(num + [0.0] * (n - len(num)))
                drow.append(den + [0.0] * (n - len(den)))
            nums.append(nrow)
            dens.append(drow)
        return nums, dens

    def to_control(self) -> Any:
        """The plant as a python-control ``TransferFunction`` (discrete,
        ``dt``), from :meth:`tf_data`; python-control must be installed
        (it is not a dependency of lifted)."""
        try:
            import control  # type: ignore[import-not-found, import-untyped, unused-ignore]
        except ImportError as e:  # pragma: no cover - depends on the environment
            raise ImportError("PolyModel.to_control needs python-control (pip install control)") from e
        nums, dens = self.tf_data()
        if len(nums) == 1 and len(nums[0]) == 1:
            return control.tf(nums[0][0], dens[0][0], self.dt)
        return control.tf(nums, dens, self.dt)


@dataclass(frozen=True, eq=False, repr=False)
class ArxScan(_Result):
    """Result of :func:`lifted.arxstruc` (MATLAB's ``arxstruc``): one row
    per ARX structure (na, nb, nk) the data determine, in the order na, nb,
    nk of the grid.

    ``loss`` (rows x outputs) is the mean squared one-step prediction
    error per output on the estimation records (all structures on the same
    ``samples`` regression rows); ``aic`` = sum_i ln V_i + 2 d / J and
    ``mdl`` = sum_i ln V_i + d ln J / J (V_i the loss of output i, d the
    ``parameters`` of all outputs, J = ``samples``); ``validation_loss``
    (rows x outputs) the one-step loss on the validation records with the
    coefficients of the estimation records (None without validation
    records). ``skipped``: the structures left out, as (na, nb, nk, why).
    :meth:`best` picks a structure (MATLAB's ``selstruc``).
    """

    na: IntArray
    nb: IntArray
    nk: IntArray
    parameters: IntArray
    loss: FloatArray
    aic: FloatArray
    mdl: FloatArray
    validation_loss: FloatArray | None
    samples: int
    validation_samples: int | None
    skipped: list[tuple[int, int, int, str]]
    best_rows: dict[str, int]

    _shown = ("samples", "validation_samples", "best_rows")

    def __len__(self) -> int:
        return len(self.na)

    def value(self, criterion: str) -> FloatArray:
        """Each row's value of ``criterion`` (lower is better): ``"aic"``,
        ``"mdl"`` or ``"validation"`` (sum_i ln of the validation loss)."""
        if criterion == "aic":
            return self.aic
        if criterion == "mdl":
            return self.mdl
        if criterion == "validation":
            if self.validation_loss is None:
                raise ArgumentError(
                    "argument 'criterion': 'validation' needs validation records "
                    "(arxstruc(u, y, u_val, y_val))"
                )
            return np.asarray(np.sum(np.log(self.validation_loss), axis=1), dtype=np.float64)
        raise ArgumentError(
            f"argument 'criterion': unknown structure criterion {criterion!r} "
            "(expected one of 'aic', 'mdl', 'validation')"
        )

    def best(self, criterion: str | None = None) -> tuple[int, int, int]:
        """The structure ``(na, nb, nk)`` that ``criterion`` picks (MATLAB's
        ``selstruc``), ready for ``lifted.arx(u, y, scan.best())``:
        ``"validation"`` (the default with validation records), ``"aic"``
        (the default without), or ``"mdl"`` (Rissanen's, more
        parsimonious). The choice is ``lifted_pem::ArxScan::best``'s, the
        rule of the workflow's structure scan: the lowest :meth:`value`,
        fewer parameters on ties (see that function for the held-out
        criterion's rule)."""
        if criterion is None:
            criterion = "validation" if self.validation_loss is not None else "aic"
        self.value(criterion)  # refuses an unknown or unavailable criterion
        r = self.best_rows[criterion]
        return (int(self.na[r]), int(self.nb[r]), int(self.nk[r]))

    @classmethod
    def _of(cls, d: dict[str, Any]) -> ArxScan:
        """The scan of the extension's dict."""
        vl = d["validation_loss"]
        return cls(
            na=np.asarray(d["na"], dtype=np.int64),
            nb=np.asarray(d["nb"], dtype=np.int64),
            nk=np.asarray(d["nk"], dtype=np.int64),
            parameters=np.asarray(d["parameters"], dtype=np.int64),
            loss=np.asarray(d["loss"], dtype=np.float64),
            aic=np.asarray(d["aic"], dtype=np.float64),
            mdl=np.asarray(d["mdl"], dtype=np.float64),
            validation_loss=None if vl is None else np.asarray(vl, dtype=np.float64),
            samples=int(d["samples"]),
            validation_samples=d["validation_samples"],
            skipped=[(int(s[0]), int(s[1]), int(s[2]), str(s[3])) for s in d["skipped"]],
            best_rows={k: int(v) for k, v in d["best"].items() if v is not None},
        )


@dataclass(frozen=True, eq=False, repr=False)
class SubspaceFit(_Result):
    """Result of :func:`lifted.identify` (N4SID, MOESP, CVA, PBSID, SSARX,
    IV, ARX, FIR), :func:`lifted.pbsid`, :func:`lifted.arx` and
    :func:`lifted.fir`.

    ``model`` carries the operating point (``u0``, ``y0``: the means removed
    from the records, None with ``remove_means=False``) and the Kalman gain
    of the noise model, so :func:`lifted.validate` and :func:`lifted.simulate`
    work on plant values as ``lifted validate --model`` does.

    ARX and FIR fits also carry the polynomial model (``polynomial``, a
    :class:`PolyModel` in the data's units; ``model`` and ``kalman_gain``
    are its innovations realisation) and its uncertainty: ``parameters``
    (MATLAB's ``getpvec`` order, see :class:`PolyModel`), ``covariance``
    and ``std``. For the state-space methods these are those of the
    model's entries: ``parameters`` = [vec A; vec B; vec C; vec D] (each
    matrix column by column), ``covariance`` their covariance from the
    prediction-error Jacobian at the model (singular: the similarity
    directions have none; None with ``covariance=False`` or beyond its
    work budget, ``diagnostics["covariance"]`` says why) and ``std`` the
    square roots of its diagonal. ``model_json`` of an ARX/FIR fit is a
    model file of kind ``"polynomial"`` that keeps the polynomials:
    ``StateSpace.from_json`` reads its model, :meth:`PolyModel.from_json`
    its polynomial model.
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
    diagnostics: Diagnostics
    polynomial: PolyModel | None = None

    _shown = ("method", "order", "suggested_order", "model")

    @property
    def parameters(self) -> FloatArray | None:
        """The polynomial model's parameters (ARX/FIR, MATLAB's ``getpvec``
        order); for a state-space fit with a covariance, its entries
        [vec A; vec B; vec C; vec D] (column by column)."""
        if self.polynomial is not None:
            return self.polynomial.parameters
        if self._state_space_covariance() is None:
            return None
        m = self.model
        return np.concatenate([np.asarray(x, dtype=np.float64).ravel(order="F") for x in (m.A, m.B, m.C, m.D)])

    @property
    def covariance(self) -> FloatArray | None:
        """The covariance of :attr:`parameters` (None when not estimated)."""
        if self.polynomial is not None:
            return self.polynomial.covariance
        return self._state_space_covariance()

    @property
    def std(self) -> FloatArray | None:
        """The standard deviations of :attr:`parameters` (None when not
        estimated)."""
        if self.polynomial is not None:
            return self.polynomial.std
        cov = self._state_space_covariance()
        return None if cov is None else np.sqrt(np.clip(np.diag(cov), 0.0, None))

    def _state_space_covariance(self) -> FloatArray | None:
        """The model file's state-space covariance, when it has one."""
        entry = json.loads(self.model_json).get("covariance")
        if not isinstance(entry, dict):
            return None
        return np.asarray(entry["matrix"], dtype=np.float64)


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
    diagnostics: Diagnostics

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
    diagnostics: Diagnostics

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
    diagnostics: Diagnostics

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
