"""Lifted: identification and control of multirate sampled-data systems.

numpy arrays in and out, samples x channels, float64. Arguments are read
by ``numpy.asarray``: lists, integer arrays and 1-D arrays (one channel) are
accepted, complex arrays are refused; a masked entry of a numpy masked
array is a missing sample, as NaN (outputs), or refused (everything else);
a bool is not an integer argument (TypeError). The numerics are the Rust crates'
(lifted-lti, lifted-prbs, lifted-subspace, ...); this package only converts
arguments and results. Every error of the library is raised as
:class:`LiftedError`, a subclass of :class:`ValueError`, or one of its
subclasses (:class:`DimensionError`, :class:`NonFiniteError`,
:class:`OrderError`, ...) carrying the Rust error's fields as attributes.
Identification, validation, simulation and MPC calls release the GIL, so
threads run them in parallel; models, results and errors pickle, so
processes can too.
"""

from __future__ import annotations

import inspect
import json
import os
from typing import Any, Literal, Sequence

import numpy as np
import numpy.typing as npt

from ._lifted import (
    ArgumentError,
    DimensionError,
    LiftedError,
    MemoryBudgetError,
    Mpc,
    NonFiniteError,
    NotExcitingError,
    OrderError,
    StateSpace,
    TooShortError,
    UnstableError,
    WorkBudgetError,
    __version__,
    design,
    gbn,
    inverse_prbs,
    multisine,
    prbs,
    rbs,
    resolve_threads,
)
from ._lifted import arxstruc as _arxstruc
from ._lifted import delayest as _delayest
from ._lifted import identify as _identify
from ._lifted import pbsid as _pbsid
from ._lifted import iv as _iv
from ._lifted import multirate as _multirate
from ._lifted import qmarkov as _qmarkov
from ._lifted import simulate_experiment as _simulate_experiment
from ._lifted import validate as _validate
from ._results import (
    ArxScan,
    Diagnostics,
    Experiment,
    IvFit,
    MultirateFit,
    OutputValidation,
    PolyModel,
    QMarkovFit,
    SubspaceFit,
    Validation,
)
from ._types import (
    BdRoute,
    C2dMethod,
    Detrend,
    Feedback,
    IdentifyMethod,
    InitialState,
    MpcKind,
    OrderCriterion,
    PbsidVariant,
    ProcessStructure,
    Refine,
    SubspaceMethod,
    SystemEstimate,
)

__all__ = [
    "__version__",
    "LiftedError",
    "ArgumentError",
    "DimensionError",
    "NonFiniteError",
    "OrderError",
    "NotExcitingError",
    "UnstableError",
    "TooShortError",
    "MemoryBudgetError",
    "WorkBudgetError",
    "StateSpace",
    "Mpc",
    "SubspaceFit",
    "Diagnostics",
    "IvFit",
    "QMarkovFit",
    "MultirateFit",
    "PolyModel",
    "ArxScan",
    "Validation",
    "OutputValidation",
    "Experiment",
    "SubspaceMethod",
    "IdentifyMethod",
    "ProcessStructure",
    "PbsidVariant",
    "SystemEstimate",
    "Feedback",
    "C2dMethod",
    "MpcKind",
    "OrderCriterion",
    "BdRoute",
    "Detrend",
    "Refine",
    "InitialState",
    "prbs",
    "inverse_prbs",
    "design",
    "rbs",
    "gbn",
    "multisine",
    "resolve_threads",
    "simulate",
    "simulate_experiment",
    "identify",
    "n4sid",
    "pbsid",
    "moesp",
    "cva",
    "arx",
    "fir",
    "oe",
    "armax",
    "bj",
    "procest",
    "impulseest",
    "arxstruc",
    "delayest",
    "iv",
    "qmarkov",
    "multirate",
    "validate",
    "to_control",
    "from_control",
]

FloatArray = npt.NDArray[np.float64]


def _is_record_list(x: object) -> bool:
    """True for a list/tuple of arrays (several records); a list of numbers
    or of lists is one array, as numpy reads it."""
    if not isinstance(x, (list, tuple)) or len(x) == 0:
        return False
    return all(
        not isinstance(e, (list, tuple, np.generic, int, float, complex))
        and hasattr(e, "__array__")
        and np.ndim(e) >= 1
        for e in x
    )


def _records(u: Any, y: Any) -> tuple[list[Any], list[Any]]:
    """``u`` and ``y`` as lists of records (one each when they are arrays)."""
    many_u, many_y = _is_record_list(u), _is_record_list(y)
    if many_u != many_y:
        which, other = ("u", "y") if many_u else ("y", "u")
        raise LiftedError(
            f"{which} is a list of {len(u if many_u else y)} records but {other} is one array: "
            "give both as lists of arrays (several records) or both as arrays"
        )
    us, ys = (list(u), list(y)) if many_u else ([u], [y])
    for name, recs in (("u", us), ("y", ys)):
        for k, r in enumerate(recs):
            shape = np.shape(r)
            # Samples are rows: a record of fewer samples than channels is
            # almost always transposed (it read as "horizons too long for 1
            # samples").
            if len(shape) == 2 and shape[0] < shape[1] and shape[0] <= 4:
                at = f"{name}[{k}]" if len(recs) > 1 else name
                raise ArgumentError(
                    f"argument '{name}': {at} has {shape[0]} sample(s) of {shape[1]} channels: "
                    f"samples are rows (N x channels); transposed? pass {at}.T"
                )
    return us, ys


def simulate(
    sys: StateSpace, u: npt.ArrayLike, x0: npt.ArrayLike | None = None, dt: float | None = None
) -> tuple[FloatArray, FloatArray]:
    """Simulates ``sys`` driven by ``u`` (N x m; 1-D: one input) from ``x0``
    (zeros when None); returns ``(y, x)`` (N x p, N x n). A model with an
    operating point (an identified one) maps plant values to plant values:
    y = y0 + G(u - u0), as ``lifted simulate --model`` does."""
    return sys.lsim(u, x0, dt)


def simulate_experiment(
    plant: StateSpace,
    r: npt.ArrayLike,
    controller: StateSpace | None = None,
    *,
    reference: bool = True,
    feedback: Feedback = "fast",
    sampling: Sequence[int] | None = None,
    holds: Sequence[int] | None = None,
    snr: float | None = None,
    seed: int = 0,
    dt: float | None = None,
) -> Experiment:
    """Open- or closed-loop, multirate experiment (``lifted_sim::Simulator``).

    Without ``controller``, ``r`` (N x m) is the plant input. With a discrete
    ``controller`` at the plant's period, ``r`` is the setpoint (N x p) when
    ``reference`` else an input disturbance (N x m); ``feedback`` is "fast"
    or "hold_last". ``sampling``: output sampling period per output, in base
    periods; ``holds``: input hold per input; ``snr``: seeded white output
    noise at this variance ratio; ``dt``: ZOH period of a continuous plant.
    A plant with an operating point is simulated in deviations, its signals
    returned in plant values. Returns an :class:`Experiment`: ``u``, ``y``
    (NaN where a channel does not sample), ``y_fast`` and ``y_clean`` (no
    added noise), all samples x channels.
    """
    d = _simulate_experiment(
        plant,
        r,
        controller,
        reference,
        feedback,
        None if sampling is None else list(sampling),
        None if holds is None else list(holds),
        snr,
        seed,
        dt,
    )
    return Experiment(u=d["u"], y=d["y"], y_fast=d["y_fast"], y_clean=d["y_clean"])


def identify(
    u: Any,
    y: Any,
    method: IdentifyMethod = "n4sid",
    *,
    order: int | None = None,
    orders: Sequence[int] | None = None,
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
    plan: Any = None,
    covariance: bool = True,
    process_fixed: dict[str, float] | None = None,
    intersample: Literal["zoh", "foh"] | None = None,
    a_structure: Literal["full", "diagonal"] | None = None,
    f_structure: Literal["per-input", "common"] | None = None,
) -> SubspaceFit:
    """Subspace identification (N4SID, MOESP, CVA; also PBSID, SSARX and IV)
    of one record or several, or least-squares ARX and FIR polynomial models
    (``method="arx"`` / ``"fir"``, as :func:`arx` and :func:`fir`).

    ``u`` and ``y`` are arrays (N x m, N x p; anything numpy reads, a 1-D
    array is one channel) or lists of such arrays (several experiments).
    One record whose ``y`` holds NaN (or masked entries) only at the
    instants an output is not sampled — every ``P``-th sample measured, one
    period per output, the command line's rule for empty CSV cells — is a
    multirate record and takes the multirate routes (as
    :func:`multirate` with those periods); any other NaN is refused.

    The call goes through the identification workflow that ``lifted
    identify`` and ``lifted studio`` use (the Rust crate
    ``lifted-workflow``), with the same defaults, so the same data and
    options give the same model as the command line:

    * ``order`` None: chosen from the data by ``order_criterion`` up to
      ``max_order``; the default ``"validation"`` picks the order, the
      horizon (when ``horizon`` is None: among 5, 10, 15, 20, 30; a record
      too short for held-out blocks and for horizon 10: the horizon of
      smallest AICc among those it supports) and the
      (A, C) route (when ``system`` is None) by the simulation fit on
      held-out data: six blocks each held out once (blocked
      cross-validation) for records up to 2e4 samples, else the last third
      of the record (multirate records of up to 2e5 samples: the order
      alone, by the fit on the last third); when the model is refined and
      the record is short
      enough for the refinement's held-out check, the best three orders are
      compared by the held-out fit of the model each delivers
      (``diagnostics["structure_selection"]["refined_shortlist"]``). ``"gap"``, ``"svc"``, ``"aic"``,
      ``"aicc"``, ``"bic"``: the other rules (``lifted identify
      --order-criterion``), with horizon 10 unless given (the longest the
      record supports when it is too short for 10).
    * ``horizon``: past = future block rows (``past``/``future`` are its
      older spelling; given together they must agree).
    * ``system``: ``"shift"`` or ``"states"`` (None: chosen as above, else
      shift invariance); ``bd``: the (B, D, x0) route.
    * ``detrend``: ``"mean"`` (the means removed and stored as the model's
      operating point), ``"none"`` or ``"linear"``; ``remove_means=False``
      is ``detrend="none"``.
    * ``refine``: ``"auto"`` (default) refines by the prediction error where
      it pays (predicted work at most 4e9 operations, about 1 s, or fewer than
      10 000 samples, and a stable estimate; in memory over that work its
      iterations stop at it, one at least; ``diagnostics["refinement_decision"]``
      says why), ``"none"`` never, ``"pem"`` or ``"oe"`` always, from exactly
      the identified model (``refine_iterations``, ``refine_max_work``). The
      refined model is kept when it simulates at least as well: on six
      held-out blocks for single-rate N4SID/MOESP/CVA records of up to 2e4
      samples when they tell the two apart (``refine_check``: by default a
      paired t-test or a sign test of the per-block differences at 95 %,
      the median block agreeing; when they do not, the subspace model
      stays), else (longer records, costly checks, multirate records)
      on the records (``diagnostics["refinement_judge"]``).
    * ``feedthrough``: ``False`` fixes D = 0 (a strictly proper model, as
      MPC designs take; ``--feedthrough false``), ``True`` estimates D;
      None the method's default: N4SID/MOESP/CVA keep D only where the
      records support it (D free against D = 0 by the Bayesian information
      criterion on the simulation errors, ``diagnostics["feedthrough"]``),
      PBSID/SSARX, IV and multirate records fix D = 0.
    * ``enforce_stability``: the stabilised estimate (``--stable``).
    * ``method="pbsid"`` / ``"ssarx"`` / ``"pbsid_rowwise"``: the predictor-based closed-loop
      methods (as :func:`pbsid`: ``horizon`` or ``past`` is their past
      horizon, None: Akaike's choice; ``future`` their future horizon, None:
      min(past, 10); no D; ``order_criterion`` only ``"validation"``, the
      order by the held-out fit as above at the past horizon of the whole
      record, or ``"gap"``, the singular-value gap). On a multirate record
      (``y`` with NaN where an output is not measured) the three take the
      direct prediction-error route: the fast innovations model refined on
      the measured samples from the multirate subspace and interpolated
      starts, the lower prediction cost kept, consistent under feedback
      without the reference (``diagnostics["multirate_predictor"]``;
      ``refine="oe"`` refused, ``"none"`` returns the start with a
      warning). ``method="iv"``: the
      instrumental-variable subspace method with the inputs as instruments
      (open loop; :func:`iv` takes a closed loop's instruments; ``horizon``
      is its alpha, default 8; its automatic order by the held-out fit
      too). ``system``, ``bd`` and ``noise_model``
      apply to N4SID, MOESP and CVA only.
    * ``threads``: the correlation-kernel threads (0 = all cores; capped at
      the machine's available parallelism, the count used is
      ``fit.threads``).
    * ``gain_stop_share``: the Kalman-gain check's iterations stop at a cost
      decrease below this share of the cost's sampling spread sqrt(2/N)
      (``lifted identify --gain-stop-share``; 0: the 30 iterations;
      ``diagnostics["kalman_gain_route"]["stop"]``).
    * ``gain_covariance_start``: the Kalman-gain check minimises first on the
      covariances of its start's one-step errors (BFGS, no pass over the
      records per step), then finishes on the records (default ``True``;
      ``False``: Levenberg–Marquardt on the records alone;
      ``lifted identify --gain-covariance-start``;
      ``diagnostics["kalman_gain_route"]["covariance_iterations"]``).
    * ``refine_check``: how the six held-out blocks tell the refinement and
      the subspace model apart (``lifted identify --refine-check``):
      ``"tests:0.95"`` (the default: a paired t-test or a sign test of the
      per-block differences at that two-sided confidence), ``"t:0.95"``
      (the t-test alone) or ``"margin:3"`` (mean fits more than 3 points
      apart, the default before, chosen on a benchmark's validation halves);
      ``diagnostics["refinement_judge"]["rule"]``.
    * ``selection``: the rules an automatic order picks its model by, a dict
      with any of ``stable_tries`` (models tried for a stable one, default
      6), ``shortlist`` (orders the refined shortlist compares, 3),
      ``shortlist_span`` (multirate: points of held-out fit within which an
      order is shortlisted, 5), ``tolerance`` (points within which the
      smallest order leads, 0.5) and ``failed_fold`` (a failed held-out
      block's score and the floor of every block's fit, -100); the command
      line's ``--stable-tries``, ``--shortlist``, ``--shortlist-span``,
      ``--selection-tolerance``, ``--failed-fold``;
      ``diagnostics["selection_policy"]``.
    * ``budgets``: where the default route stops spending work, a dict with
      any of ``auto_refine_work`` (operations up to which the default
      refines, 4e9), ``auto_refine_work_joint`` (multirate, 8e9),
      ``auto_refine_samples`` (records always refined below, 10000),
      ``refine_check_samples`` (a refinement judged on held-out blocks up
      to, 20000), ``refine_check_work`` (4e9), ``gain_check_samples`` (the
      Kalman-gain check up to, 200000), ``covariance_work`` (the covariance
      pass up to, 4e9), ``gain_check_varx_work`` (4e9) and
      ``gain_check_minimise_work`` (8e9); the command line's ``--budget
      NAME=VALUE``; ``diagnostics["budgets"]``.
    * ``covariance``: estimate the covariance of a state-space model's
      entries (A, B, C, D) from the prediction-error Jacobian at the model
      (one pass within ``budgets["covariance_work"]``; MATLAB estimates
      every model's): the fit's ``parameters`` (the entries, column by
      column), ``covariance`` and ``std``, the model file's bands in
      ``lifted bode``/``step``/``report``; ``diagnostics["covariance"]``
      says what it rests on or why there is none. False skips the pass
      (``--no-covariance``).
    * ``process_fixed`` (``method="process"``): parameters held at a value
      instead of estimated, in the data's units, e.g. ``{"Td": 7.3}`` (a
      dead time known from the plant, every input) or ``{"K(u1)": 2.0}``
      (one input); ``--process-fix``. A held parameter has no variance.
    * ``a_structure`` (``method="arx"`` or ``"armax"``, several outputs):
      ``"full"`` (every output's past in every output's equation; ARX's
      default) or ``"diagonal"`` (each output's own past only: one MISO
      model per output, SIPPY's; ARMAX's default); ``--a-structure``.
    * ``f_structure`` (``method="oe"`` or ``"bj"``): ``"per-input"`` (one
      F per input-output pair, MATLAB's ``oe``/``bj``; the default) or
      ``"common"`` (one F per output shared by its input terms, SIPPY's OE
      and BJ: fewer parameters where the inputs see the same modes);
      ``--f-structure``.
    * ``intersample`` (``method="process"``): ``"zoh"`` (default, the input
      held between samples) or ``"foh"`` (linear between samples: a sampled
      continuous signal); ``--intersample``.
    * ``plan``: take every option from a plan instead of the keywords (the
      command line's ``--plan``): a :class:`SubspaceFit` or its
      ``diagnostics`` (the options that made it), the path of a model file
      or of a plan file (``lifted identify --write-plan``), or a dict of the
      workflow's options; the other keywords but ``dt`` must be left at
      their defaults. The same records then give the same model bit for
      bit; an unknown option in the plan is an ``ArgumentError`` naming it.
    * ``integrator_tolerance``: poles within this distance of the unit circle
      are integrators, kept by the refinement and reported
      (``--integrator-tolerance``; None: 2/N, N the longest record;
      ``diagnostics["integrators"]``).
    * ``method="arx"`` / ``"fir"``: the polynomial models of :func:`arx` and
      :func:`fir` (least squares, no refinement; single-rate records only).
      ``orders`` is MATLAB's order vector, ``[na, nb, nk]`` for ARX and
      ``[nb, nk]`` for FIR, the same for every input-output pair (a list
      or tuple of non-negative ints, nb >= 1; refused with the state-space
      methods and together with ``order``); None: the structure scan (na,
      nb in 1..``max_order``, FIR na = 0, ``order`` n fixing na = nb = n;
      nk in 1..5, from 0 with ``feedthrough=True``) ranked by
      ``order_criterion``: ``"validation"`` (the one-step loss on the last
      third of each record, the coefficients fitted on the rest), ``"aic"``,
      ``"aicc"`` or ``"bic"`` (MDL) (``diagnostics["structure_scan"]``).
      The fit's ``polynomial``, ``parameters``, ``covariance`` and ``std``
      hold the model and its uncertainty (for the state-space methods,
      those of the model's entries: ``covariance`` below).

    Returns a :class:`SubspaceFit`; its ``model`` carries the operating point
    (the means removed) and the Kalman gain, so ``validate(fit.model, u, y)``
    and ``simulate(fit.model, u)`` work on plant values (single-rate
    N4SID/MOESP/CVA on records of up to 2e5 samples: the gain checked on the
    records so that its one-step predictor is the best of the subspace
    step's, a regression on VARX innovations and K = 0, refined over K;
    ``diagnostics["kalman_gain_route"]``); ``diagnostics`` is the model
    file's diagnostics (route, structure selection, refinement, stability,
    warnings).
    """
    plan_text = None
    if plan is not None:
        given = {
            k: v for k, v in locals().items()
            if k in _IDENTIFY_DEFAULTS and not _same(v, _IDENTIFY_DEFAULTS[k])
        }
        if given:
            raise ArgumentError(
                "plan: the options come from the plan; leave the other keywords at their "
                f"defaults ({', '.join(sorted(given))} given)"
            )
        plan_text = _plan_json(plan)
    us, ys = _records(u, y)
    try:
        d = _identify(
            us, ys, method, order=order, orders=_orders(orders), max_order=max_order,
            order_criterion=order_criterion,
            horizon=horizon, past=past, future=future, system=system, bd=bd,
            feedthrough=feedthrough, detrend=detrend,
            remove_means=remove_means, noise_model=noise_model,
            enforce_stability=enforce_stability, refine=refine,
            refine_iterations=refine_iterations, refine_max_work=refine_max_work, dt=dt,
            threads=threads, gain_stop_share=gain_stop_share,
            integrator_tolerance=integrator_tolerance, process=process, kernel=kernel,
            refine_check=refine_check, selection=selection,
            gain_covariance_start=gain_covariance_start, budgets=budgets, plan=plan_text,
            covariance=covariance, process_fixed=process_fixed, intersample=intersample,
            a_structure=a_structure, f_structure=f_structure,
        )
    except NonFiniteError as e:
        if getattr(e, "what", None) == "y":
            e.add_note(
                "NaN (or a masked entry) marks an unsampled output only where it follows one "
                "period per output (every P-th sample measured); lifted.multirate(u, y, periods=...) "
                "identifies from the measured samples of declared periods"
            )
        raise
    return _subspace_fit(d)


# identify's keywords and their defaults, for the plan's check (u, y, dt and
# plan itself are not options).
_IDENTIFY_DEFAULTS: dict[str, Any] = {
    k: p.default
    for k, p in inspect.signature(identify).parameters.items()
    if p.default is not p.empty and k not in ("dt", "plan")
}


def _same(a: Any, b: Any) -> bool:
    """Whether a keyword's value is its default (plain values only)."""
    try:
        return bool(a == b) and type(a) is type(b)
    except (TypeError, ValueError):
        return False


def _plan_json(plan: Any) -> str:
    """The JSON text of ``identify``'s ``plan``: a fit or its diagnostics,
    a path to a model or plan file, or a dict of the options."""
    if isinstance(plan, SubspaceFit):
        return json.dumps({"diagnostics": plan.diagnostics.to_dict()})
    if isinstance(plan, (str, os.PathLike)):
        with open(plan, encoding="utf-8") as f:
            return f.read()
    if isinstance(plan, Diagnostics):
        return json.dumps({"diagnostics": plan.to_dict()})
    if isinstance(plan, dict):
        return json.dumps(plan)
    raise ArgumentError(
        "plan: a SubspaceFit, its diagnostics, a path to a model or plan file, or a dict of "
        f"the workflow's options; got {type(plan).__name__}"
    )


def _subspace_fit(d: dict[str, Any]) -> SubspaceFit:
    """The :class:`SubspaceFit` of the extension's result dict."""
    return SubspaceFit(
        model=d["model"],
        kalman_gain=d["kalman_gain"],
        x0=[np.asarray(x, dtype=np.float64) for x in d["x0"]],
        u0=None if d["u0"] is None else np.asarray(d["u0"], dtype=np.float64),
        y0=None if d["y0"] is None else np.asarray(d["y0"], dtype=np.float64),
        singular_values=np.asarray(d["singular_values"], dtype=np.float64),
        order=d["order"],
        suggested_order=d["suggested_order"],
        method=d["method"],
        threads=d["threads"],
        model_json=d["model_json"],
        diagnostics=Diagnostics.from_json(
            json.loads(d["diagnostics_json"]) if "diagnostics_json" in d else None
        ),
        polynomial=None if d.get("polynomial") is None else PolyModel._of(d["polynomial"]),
    )


def _orders(orders: Sequence[int] | None) -> list[int] | None:
    """The ``orders`` keyword as a list (its entries are checked, bools
    refused, by the extension); a str or a bare int is an ArgumentError."""
    if orders is None:
        return None
    if isinstance(orders, (str, bytes)) or np.ndim(orders) != 1:
        raise ArgumentError(
            f"argument 'orders': expected a list of ints ([na, nb, nk] for arx, [nb, nk] "
            f"for fir), got {orders!r}"
        )
    return list(orders)


def pbsid(
    u: Any,
    y: Any,
    variant: PbsidVariant = "pbsid",
    *,
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
) -> SubspaceFit:
    """Predictor-based subspace identification for closed-loop records
    without an external excitation: PBSID-opt (Chiuso 2007, default) or
    SSARX (Jansson 2003), through the identification workflow of ``lifted
    identify --method pbsid`` / ``ssarx`` / ``pbsid-rowwise`` with its
    defaults (same data and options, same model): ``variant`` ``"pbsid"``,
    ``"ssarx"`` or ``"pbsid_rowwise"`` (row-wise PBSID, Chiuso & Picci 2005).

    ``u``, ``y`` as for :func:`identify` (the plant's input and output as
    logged; the reference is not needed). ``past`` (the CLI's
    ``--horizon``) None chooses the past horizon by Akaike's criterion on
    the high-order predictor (up to 30; shortened, past and future, with a
    note in ``diagnostics["notes"]``, where the past outputs are linearly
    dependent given the past inputs, e.g. an output that is a noise-free
    combination of the others); ``future`` (``--future``) None is
    min(past, 10) (10 with Akaike's past, or the longest a record too
    short for 10 supports, with a warning); ``feedthrough`` None or False (no D,
    ``--feedthrough`` to estimate it) is the closed-loop default, since an
    estimated D is biased when the controller reacts within the sample.
    ``order`` None: the order of best held-out simulation fit up to
    ``max_order`` (six blocks each held out once, at the past horizon of
    the whole record, as :func:`identify`'s default;
    ``diagnostics["structure_selection"]``; the singular-value gap for
    records too short for the blocks).
    ``detrend`` / ``remove_means`` and ``refine`` (default ``"auto"``: the
    prediction-error refinement where it pays), ``refine_iterations``,
    ``refine_max_work`` as for :func:`identify`.

    Returns a :class:`SubspaceFit` whose model carries the operating point
    and the Kalman gain of the innovation model, and the model file's
    ``diagnostics``.
    """
    us, ys = _records(u, y)
    d = _pbsid(
        us, ys, variant, order=order, max_order=max_order, past=past, future=future,
        feedthrough=feedthrough, detrend=detrend, remove_means=remove_means, refine=refine,
        refine_iterations=refine_iterations, refine_max_work=refine_max_work, dt=dt,
        threads=threads,
    )
    return _subspace_fit(d)


def n4sid(
    u: Any,
    y: Any,
    *,
    order: int | None = None,
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
) -> SubspaceFit:
    """:func:`identify` with ``method="n4sid"``."""
    return identify(
        u, y, "n4sid", order=order, max_order=max_order, order_criterion=order_criterion,
        horizon=horizon, past=past, future=future, system=system, bd=bd,
        feedthrough=feedthrough, detrend=detrend,
        remove_means=remove_means, noise_model=noise_model,
        enforce_stability=enforce_stability, refine=refine,
        refine_iterations=refine_iterations, refine_max_work=refine_max_work, dt=dt,
        threads=threads,
    )


def moesp(
    u: Any,
    y: Any,
    *,
    order: int | None = None,
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
) -> SubspaceFit:
    """:func:`identify` with ``method="moesp"``."""
    return identify(
        u, y, "moesp", order=order, max_order=max_order, order_criterion=order_criterion,
        horizon=horizon, past=past, future=future, system=system, bd=bd,
        feedthrough=feedthrough, detrend=detrend,
        remove_means=remove_means, noise_model=noise_model,
        enforce_stability=enforce_stability, refine=refine,
        refine_iterations=refine_iterations, refine_max_work=refine_max_work, dt=dt,
        threads=threads,
    )


def cva(
    u: Any,
    y: Any,
    *,
    order: int | None = None,
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
) -> SubspaceFit:
    """:func:`identify` with ``method="cva"``."""
    return identify(
        u, y, "cva", order=order, max_order=max_order, order_criterion=order_criterion,
        horizon=horizon, past=past, future=future, system=system, bd=bd,
        feedthrough=feedthrough, detrend=detrend,
        remove_means=remove_means, noise_model=noise_model,
        enforce_stability=enforce_stability, refine=refine,
        refine_iterations=refine_iterations, refine_max_work=refine_max_work, dt=dt,
        threads=threads,
    )


def arx(
    u: Any,
    y: Any,
    orders: Sequence[int] | None = None,
    *,
    order: int | None = None,
    max_order: int = 10,
    order_criterion: OrderCriterion = "validation",
    feedthrough: bool | None = None,
    detrend: Detrend = "mean",
    remove_means: bool = True,
    dt: float = 1.0,
    threads: int = 1,
    kernel: Literal["tc", "dc"] | None = None,
    a_structure: Literal["full", "diagonal"] | None = None,
) -> SubspaceFit:
    """Least-squares ARX model (MATLAB's ``arx(data, [na nb nk])``, SIPPY's
    ARX), through the identification workflow (``identify(u, y, "arx",
    orders=...)``, ``lifted identify --method arx --orders``)::

        A(q) y(t) = B(q) u(t - nk) + e(t)
        A(q) = I + A_1 q^-1 + ... + A_na q^-na
        B(q) = B_0 + B_1 q^-1 + ... + B_{nb-1} q^-(nb-1)

    ``orders`` = ``[na, nb, nk]``, the same for every input-output pair
    (multi-output: A is full, p x p polynomials of degree na, or with
    ``a_structure="diagonal"`` each output's own past only, one MISO model
    per output as SIPPY's ARX); None chooses
    the structure by the workflow's scan (see :func:`identify`:
    ``order_criterion`` ``"validation"``, ``"aic"``, ``"aicc"`` or ``"bic"``,
    na and nb up to ``max_order``, nk 1..5; ``order`` n fixes na = nb = n).
    The records' means are removed first (``detrend``; the model maps
    deviations, ``fit.model`` carries the operating point).

    Returns a :class:`SubspaceFit` whose ``polynomial`` is the
    :class:`PolyModel` (coefficients in the data's units) and whose
    ``parameters`` are, per output i, ``[a_i1 coefficients .. a_ip
    coefficients, b_i1 .. b_im]`` (MATLAB's ``getpvec``; SISO: ``[a1 ..
    a_na, b0 .. b_{nb-1}]``), with their ``covariance`` (least squares:
    Lambda (Phi^T Phi)^-1, exact for white e) and ``std``; ``model`` is the
    innovations realisation (A, B, C, D, K) that :func:`validate`,
    :func:`simulate` and :class:`Mpc` take. Coloured noise biases ARX and
    its bounds: the equation error must be white.

    ``kernel`` ``"tc"`` or ``"dc"`` makes it the regularised ARX (MATLAB's
    ``arx`` with ``arxRegul``'s regularisation) of the structure ``orders``
    (or ``order``; a scan is refused): one kernel prior on the past outputs'
    coefficients and one on the inputs', their hyperparameters by the
    marginal likelihood (``fit.diagnostics["regularization"]``), the
    ``covariance`` the posterior's. For high orders on short or noisy
    records, where least squares over-fits.
    """
    return identify(
        u, y, "arx", order=order, orders=orders, max_order=max_order,
        order_criterion=order_criterion, feedthrough=feedthrough, detrend=detrend,
        remove_means=remove_means, dt=dt, threads=threads, kernel=kernel,
        a_structure=a_structure,
    )


def fir(
    u: Any,
    y: Any,
    orders: Sequence[int] | None = None,
    *,
    order: int | None = None,
    max_order: int = 10,
    order_criterion: OrderCriterion = "validation",
    feedthrough: bool | None = None,
    detrend: Detrend = "mean",
    remove_means: bool = True,
    dt: float = 1.0,
    threads: int = 1,
) -> SubspaceFit:
    """Least-squares FIR model (ARX with na = 0; MATLAB's ``arx(data, [0 nb
    nk])``, ``impulseest``'s structure), through the identification
    workflow (``identify(u, y, "fir", orders=...)``)::

        y(t) = B_0 u(t - nk) + B_1 u(t - nk - 1) + ... + B_{nb-1} u(t - nk - nb + 1) + e(t)

    ``orders`` = ``[nb, nk]``; None: the structure scan of :func:`identify`
    (nb up to ``max_order``, ``order`` n fixes nb = n). ``parameters`` are,
    per output, the B coefficients input by input (``[b0 .. b_{nb-1}]``
    for one input), with ``covariance`` and ``std``; otherwise as
    :func:`arx`.
    """
    return identify(
        u, y, "fir", order=order, orders=orders, max_order=max_order,
        order_criterion=order_criterion, feedthrough=feedthrough, detrend=detrend,
        remove_means=remove_means, dt=dt, threads=threads,
    )


def oe(
    u: Any,
    y: Any,
    orders: Sequence[int] | None = None,
    *,
    order: int | None = None,
    feedthrough: bool | None = None,
    detrend: Detrend = "mean",
    remove_means: bool = True,
    dt: float = 1.0,
    threads: int = 1,
    f_structure: Literal["per-input", "common"] | None = None,
) -> SubspaceFit:
    """Output-error model (MATLAB's ``oe(data, [nb nf nk])``) by
    prediction-error minimisation of the simulation error, through the
    identification workflow (``identify(u, y, "oe", orders=...)``)::

        y(t) = sum_k B_k(q)/F_k(q) u_k(t - nk) + e(t)

    ``orders`` = ``[nb, nf, nk]`` for every input-output pair, or ``order``
    n (nb = nf = n, the delays estimated by ARX fits), or neither: every
    order 1..10 estimated on the first two thirds and simulated on the last
    third, the smallest within half a point of the best kept
    (``diagnostics["structure_scan"]``). ``y`` may hold NaN
    where an output was not measured (a slow analyser: the NaN of one
    period per output): the cost uses the measured samples only, and the
    fast model comes back. ``parameters`` are, per output, the B
    coefficients input by input, then the free F coefficients input by
    input, with ``covariance`` and ``std`` (from the Jacobian at the
    optimum). ``f_structure="common"`` shares one F between an output's
    input terms, ``y = (B_1 u_1 + ... + B_m u_m)/F + e`` (SIPPY's OE
    structure); the model keeps a copy of F per input (their covariance
    entries equal) and ``diagnostics["parameters"]`` counts it once.
    """
    return identify(
        u, y, "oe", order=order, orders=orders, feedthrough=feedthrough,
        detrend=detrend, remove_means=remove_means, dt=dt, threads=threads,
        f_structure=f_structure,
    )


def armax(
    u: Any,
    y: Any,
    orders: Sequence[int] | None = None,
    *,
    order: int | None = None,
    feedthrough: bool | None = None,
    detrend: Detrend = "mean",
    remove_means: bool = True,
    dt: float = 1.0,
    threads: int = 1,
    a_structure: Literal["full", "diagonal"] | None = None,
) -> SubspaceFit:
    """ARMAX model (MATLAB's ``armax(data, [na nb nc nk])``) by
    prediction-error minimisation, through the identification workflow
    (``identify(u, y, "armax", orders=...)``)::

        A(q) y(t) = sum_k B_k(q) u_k(t - nk) + C(q) e(t)

    ``orders`` = ``[na, nb, nc, nk]`` (the same for every input-output
    pair; A diagonal, or with ``a_structure="full"`` coupling the outputs:
    every output's past in every output's equation, MATLAB's multi-output
    ``armax`` with a full ``na``), or ``order`` n (na = nb = nc = n, the
    delays estimated), or neither: the order scan of :func:`oe`.
    Consistent on closed-loop records (the direct method).
    ``parameters`` per output: the A row (a_i1 .. a_ip), the B's input by
    input, c; with ``covariance`` and ``std``. ``y`` may hold NaN where an
    output was not measured (a slow analyser) when A is diagonal: the
    one-step predictor then skips the missing samples (a Kalman filter on
    the noise model) and the cost uses the measured samples only.
    """
    return identify(
        u, y, "armax", order=order, orders=orders, feedthrough=feedthrough,
        detrend=detrend, remove_means=remove_means, dt=dt, threads=threads,
        a_structure=a_structure,
    )


def bj(
    u: Any,
    y: Any,
    orders: Sequence[int] | None = None,
    *,
    order: int | None = None,
    feedthrough: bool | None = None,
    detrend: Detrend = "mean",
    remove_means: bool = True,
    dt: float = 1.0,
    threads: int = 1,
    f_structure: Literal["per-input", "common"] | None = None,
) -> SubspaceFit:
    """Box-Jenkins model (MATLAB's ``bj(data, [nb nc nd nf nk])``) by
    prediction-error minimisation (``identify(u, y, "bj", orders=...)``)::

        y(t) = sum_k B_k(q)/F_k(q) u_k(t - nk) + C(q)/D(q) e(t)

    ``orders`` = ``[nb, nc, nd, nf, nk]``, or ``order`` n (every degree n,
    the delays estimated), or neither: the order scan of :func:`oe`.
    Consistent on closed-loop records.
    ``parameters`` per output: the B's, c, d, the F's; with ``covariance``
    and ``std``. ``y`` may hold NaN where an output was not measured, as
    in :func:`armax` (the predictor skips the missing samples).
    ``f_structure="common"`` shares one F between an output's input terms
    (SIPPY's BJ structure), as in :func:`oe`.
    """
    return identify(
        u, y, "bj", order=order, orders=orders, feedthrough=feedthrough,
        detrend=detrend, remove_means=remove_means, dt=dt, threads=threads,
        f_structure=f_structure,
    )


def procest(
    u: Any,
    y: Any,
    process: ProcessStructure = "p1d",
    *,
    dt: float = 1.0,
    detrend: Detrend = "mean",
    threads: int = 1,
    fixed: dict[str, float] | None = None,
    intersample: Literal["zoh", "foh"] = "zoh",
) -> SubspaceFit:
    """Process model with dead time per input-output pair (MATLAB's
    ``procest``), through the identification workflow
    (``identify(u, y, "process", process=...)``): ``"p1d"``
    K e^(-Td s)/(1 + Tp1 s), ``"p2d"`` two real poles, ``"p1di"``
    integrating, ``"p2dz"`` with a zero, ``"p2du"`` underdamped; the dead
    time need not be a multiple of ``dt`` (exact zero-order-hold
    discretisation with a fractional delay). Fitted by output error on the
    measured samples (NaN where an output was not measured: a slow
    analyser's record works); the inputs are taken relative to their first
    sample (the plant at rest before the test) and an output offset is
    estimated. ``fit.diagnostics["process"]["outputs"][i]`` holds the
    parameter ``names`` (``K(u1)``, ``Tp1(u1)``, ``Td(u1)``, ...,
    ``offset``), their values (``parameters``) and standard deviations
    (``std``) in the data's units; ``fit.model`` is the exact discrete
    equivalent. ``fixed`` holds parameters at a value instead of estimating
    them (``{"Td": 7.3}``: a known dead time; ``identify``'s
    ``process_fixed``). ``intersample="foh"`` takes the inputs as linear
    between their samples (a sampled continuous signal) instead of held
    (MATLAB's ``InterSample``; exact first-order-hold discretisation with
    the fractional delay).
    """
    return identify(u, y, "process", process=process, dt=dt, detrend=detrend, threads=threads,
                    process_fixed=fixed, intersample=intersample)


def impulseest(
    u: Any,
    y: Any,
    lags: int = 70,
    *,
    delay: int = 1,
    kernel: Literal["tc", "dc"] = "tc",
    dt: float = 1.0,
    detrend: Detrend = "mean",
    threads: int = 1,
) -> SubspaceFit:
    """Regularised FIR model (MATLAB's ``impulseest``): ``lags``
    coefficients per input from ``delay``, the prior a TC kernel
    c lambda^max(i,j) (or DC, c rho^|i-j| lambda^((i+j)/2)) whose
    hyperparameters maximise the marginal likelihood; ``fit.polynomial``
    holds the coefficients with their posterior ``covariance``/``std``,
    ``fit.diagnostics["hyperparameters"]`` the (c, lambda, rho) per
    output.
    """
    return identify(
        u, y, "impulse", orders=[lags, delay], kernel=kernel, dt=dt, detrend=detrend,
        threads=threads,
    )


def arxstruc(
    u: Any,
    y: Any,
    u_val: Any = None,
    y_val: Any = None,
    *,
    na: Sequence[int] = range(1, 11),
    nb: Sequence[int] = range(1, 11),
    nk: Sequence[int] = (1,),
    remove_means: bool = True,
    threads: int = 1,
) -> ArxScan:
    """ARX structure scan (MATLAB's ``arxstruc`` + ``selstruc``,
    ``lifted_pem::arx_scan``): every structure of the grid ``na x nb x nk``
    (MATLAB's ``struc(na, nb, nk)``; na = 0 is FIR) fitted by least squares
    on one compression of the records ``u``, ``y`` (arrays or lists of
    arrays), all on the same regression rows. Each is scored by Akaike's
    criterion and Rissanen's MDL and, with validation records ``u_val``,
    ``y_val`` (both or neither), by the one-step prediction loss on them
    with the coefficients of the estimation records.

    ``remove_means`` subtracts each record's column means first (as
    :func:`identify` does; False: the records as given). Structures the
    data do not determine are left out (``skipped``). Returns an
    :class:`ArxScan` (per structure ``na``, ``nb``, ``nk``, ``parameters``,
    ``loss`` per output, ``aic``, ``mdl``, ``validation_loss``);
    ``scan.best("mdl")`` picks ``(na, nb, nk)`` for :func:`arx`.
    """
    us, ys = _records(u, y)
    if (u_val is None) != (y_val is None):
        raise ArgumentError(
            "argument 'u_val': give both validation records u_val and y_val, or neither"
        )
    uv, yv = ([], []) if u_val is None else _records(u_val, y_val)
    d = _arxstruc(
        us, ys, uv, yv, _grid(na, "na"), _grid(nb, "nb"), _grid(nk, "nk"),
        remove_means=remove_means, threads=threads,
    )
    return ArxScan._of(d)


def _grid(values: Sequence[int], name: str) -> list[int]:
    """A candidate list (an int is one candidate)."""
    if isinstance(values, (str, bytes)):
        raise ArgumentError(f"argument '{name}': expected a list of ints, got {values!r}")
    if np.ndim(values) == 0:
        return [values]  # type: ignore[list-item]
    return list(values)


def delayest(
    u: Any,
    y: Any,
    *,
    na: int = 2,
    nb: int = 2,
    min_delay: int = 0,
    max_delay: int = 20,
    remove_means: bool = True,
    threads: int = 1,
) -> npt.NDArray[np.int64]:
    """Input delays (MATLAB's ``delayest(data, na, nb, nkmin, nkmax)``,
    ``lifted_pem::estimate_delays``): for each output and input, the delay
    nk in ``min_delay..max_delay`` samples whose ARX model (A of degree
    ``na``, ``nb`` B coefficients per input) has the lowest one-step loss,
    all candidates on one compression and the same rows (inputs by turns,
    two sweeps). ``remove_means`` as :func:`arxstruc`. Returns the delays,
    an int array p x m (``int(d[0, 0])`` for one input and output).
    """
    us, ys = _records(u, y)
    d = _delayest(
        us, ys, na=na, nb=nb, min_delay=min_delay, max_delay=max_delay,
        remove_means=remove_means, threads=threads,
    )
    return np.asarray(d, dtype=np.int64).reshape(len(d), -1)


def iv(
    u: Any,
    y: Any,
    instrument: Any = None,
    *,
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
) -> IvFit:
    """Instrumental-variable subspace identification, open or closed loop
    (thesis ch. 7), through the identification workflow of ``lifted
    identify --method iv --instrument ...`` with its defaults (same data and
    options, same model).

    ``instrument`` (N x m, per record when ``u`` is a list) is the external
    excitation of a closed loop (the dither at the plant input or the
    set-point; the CLI's ``--instrument`` columns), independent of the
    noise; None uses ``u`` (open loop). ``alpha`` future block rows
    (``--horizon``, None: 8, or the longest a record too short for 8
    supports, with a warning), ``alpha_p`` past instrument rows
    (``--instrument-past``, None: 2 alpha, erratum L-16). ``feedthrough``
    (``--feedthrough``) estimates a direct feedthrough D; the default
    D = 0 is the closed-loop one (with a controller that reacts within the
    sample the noise reaches u at once, and an estimated D takes it).
    ``order_criterion``
    ``"validation"`` (the default: with ``order`` None, the order of best
    held-out simulation fit, six blocks each held out once,
    ``diagnostics["structure_selection"]``; multirate records: the fit on
    the last third, as the multirate subspace methods; the gap for records
    too short for the blocks) or ``"gap"``, ``"aic"``,
    ``"aicc"``, ``"bic"``. ``detrend`` / ``remove_means``,
    ``enforce_stability`` (the stabilised estimate), ``refine`` (default
    ``"auto"``), ``refine_iterations``, ``refine_max_work`` as for
    :func:`identify`; ``require_stable`` fails on an unstable model (else it
    is returned with a warning in ``diagnostics``). Returns an
    :class:`IvFit`.
    """
    us, ys = _records(u, y)
    fs: list[Any]
    if instrument is None:
        fs = [None] * len(us)
    elif len(us) > 1 or _is_record_list(u):
        if not isinstance(instrument, (list, tuple)):
            raise LiftedError("with lists of records, instrument must be a list too")
        fs = list(instrument)
    else:
        fs = [instrument]
    d = _iv(
        us, ys, fs, order=order, max_order=max_order, alpha=alpha, alpha_p=alpha_p,
        feedthrough=feedthrough, order_criterion=order_criterion, detrend=detrend,
        remove_means=remove_means, enforce_stability=enforce_stability, require_stable=require_stable, refine=refine,
        refine_iterations=refine_iterations, refine_max_work=refine_max_work, dt=dt,
    )
    return IvFit(
        model=d["model"],
        x0=[np.asarray(x, dtype=np.float64) for x in d["x0"]],
        singular_values=np.asarray(d["singular_values"], dtype=np.float64),
        order=d["order"],
        suggested_order=d["suggested_order"],
        stabilized=d["stabilized"],
        method=d["method"],
        model_json=d["model_json"],
        diagnostics=Diagnostics.from_json(json.loads(d["diagnostics_json"])),
    )


def qmarkov(
    u: Any,
    y: Any,
    *,
    q: int | None = None,
    order: int | None = None,
    max_order: int = 10,
    hold: int = 1,
    prbs_order: int | None = None,
    amplitudes: float | Sequence[float] | None = None,
    last_period: bool | None = None,
    output_weight: float | Sequence[float] | None = None,
    detrend: Detrend = "mean",
    remove_means: bool = True,
    enforce_stability: bool = False,
    require_stable: bool = False,
    refine: Refine = "auto",
    refine_iterations: int = 100,
    refine_max_work: float = 2e10,
    dt: float = 1.0,
) -> QMarkovFit:
    """Weighted multirate q-Markov Cover (Zhu 2000) from inverse-PRBS tests,
    through the identification workflow of ``lifted identify --method
    qmarkov`` (one data file per input) with its defaults (same data and
    options, same model).

    One experiment per input channel: ``u[l]`` (N x m, only column l
    non-zero, e.g. from :func:`inverse_prbs`) and ``y[l]`` (N x p); a single
    array pair is one experiment of a single-input plant. ``hold`` is n_r
    (``--hold``), ``prbs_order`` the m-sequence order (``--prbs-order``,
    None: 8), ``q`` the number of Markov and covariance parameters matched
    (``--q``, None: 60 capped below n_r m), ``order`` r (None: largest gap
    of diag Lambda up to ``max_order``), ``amplitudes`` the PRBS magnitude,
    one value or one per input (``--amplitude``, None: read from the data),
    ``output_weight`` the diagonal output weighting Q (``--output-weight``,
    None: the identity). A record of one PRBS period is used as it is, a
    longer one by its last period (``last_period=False`` insists on one
    period, ``True`` or None accept both). ``detrend`` / ``remove_means``,
    ``refine`` (default ``"auto"``), ``refine_iterations``,
    ``refine_max_work`` as for :func:`identify`; ``enforce_stability``
    stabilises an unstable cover (the q-Markov route itself refuses an
    unstable cover otherwise); ``require_stable`` fails on an unstable
    final model. Returns a :class:`QMarkovFit`.
    """
    us, ys = _records(u, y)
    d = _qmarkov(
        us, ys, q=q, order=order, max_order=max_order, hold=hold, prbs_order=prbs_order,
        amplitudes=_floats(amplitudes), last_period=last_period,
        output_weight=_floats(output_weight), detrend=detrend, remove_means=remove_means,
        enforce_stability=enforce_stability, require_stable=require_stable, refine=refine,
        refine_iterations=refine_iterations, refine_max_work=refine_max_work, dt=dt,
    )
    diagnostics = json.loads(d["diagnostics_json"])
    stability = diagnostics.get("stability", {})
    return QMarkovFit(
        model=d["model"],
        eigenvalues=np.asarray(d["singular_values"], dtype=np.float64),
        order=d["order"],
        suggested_order=d["suggested_order"],
        markov_data=d["markov_data"],
        markov_model=d["markov_model"],
        markov_error=diagnostics["markov_error"],
        covariance_error=diagnostics["covariance_error"],
        cover=diagnostics["cover"],
        stable=bool(stability.get("stable", diagnostics.get("stable"))),
        spectral_radius=float(stability.get("spectral_radius", diagnostics.get("spectral_radius"))),
        stabilized_from=diagnostics.get("stabilized_from"),
        method=d["method"],
        model_json=d["model_json"],
        diagnostics=Diagnostics.from_json(diagnostics),
    )


def _floats(x: float | Sequence[float] | None) -> list[float] | None:
    """One number or a sequence of numbers as a list of floats (None stays)."""
    if x is None:
        return None
    if np.ndim(x) == 0:
        return [float(x)]  # type: ignore[arg-type]
    return [float(v) for v in x]  # type: ignore[union-attr]


def multirate(
    u: npt.ArrayLike,
    y: npt.ArrayLike,
    periods: Sequence[int],
    *,
    holds: Sequence[int] | None = None,
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
) -> MultirateFit:
    """Multirate identification (thesis chs. 4-5): lifting, causal lifted
    subspace identification, fast-model extraction (and, for inputs held one
    sample, a second start from the record with its slow outputs
    interpolated, the better-fitting one kept: ``diagnostics
    ["multirate_start"]``), through the
    identification workflow that ``lifted identify`` runs on a record with
    output periods (``--output-period``), with its defaults (same data and
    options, same model).

    ``y`` (N x p) has NaN where output i is not sampled; it is sampled every
    ``periods[i]`` base periods from sample 0; input i is held ``holds[i]``
    samples (default 1). ``method`` ``"n4sid"``, ``"moesp"`` or ``"cva"``
    with ``horizon`` block rows (``past``/``future`` its older spelling,
    which must agree; None: 10); ``"pbsid"``, ``"ssarx"`` or
    ``"pbsid_rowwise"``: a plant under feedback without its reference, by
    the direct prediction-error method on the measured samples from the
    subspace and interpolated starts (consistent in closed loop;
    ``diagnostics["multirate_predictor"]``); with ``instrument`` (N x m, the closed-loop
    dither; the CLI's ``--instrument``) or ``method="iv"`` the lifted IV
    route of thesis section 7.8.2 (``alpha`` block rows, None: 6;
    ``alpha_p`` past instrument rows). ``enforce_stability`` re-estimates
    an unstable lifted A by the zero-padded shift; ``require_stable`` fails
    on an unstable model (else it carries a warning in ``diagnostics``).
    ``detrend`` / ``remove_means``, ``refine`` (default ``"auto"``: the fast
    model refined by the prediction error on the measured samples where it
    pays), ``refine_iterations``, ``refine_max_work``,
    ``gain_stop_share``, ``integrator_tolerance`` as for :func:`identify`.
    A record whose periods and holds are all 1 takes the single-rate route (``lifted`` is then the model, ``lifting_period`` 1).
    Returns a :class:`MultirateFit`.
    """
    d = _multirate(
        u, y, list(periods), holds=None if holds is None else list(holds),
        instrument=instrument, method=method, order=order, max_order=max_order,
        horizon=horizon, past=past, future=future, alpha=alpha, alpha_p=alpha_p,
        detrend=detrend, remove_means=remove_means, enforce_stability=enforce_stability,
        require_stable=require_stable, refine=refine, refine_iterations=refine_iterations,
        refine_max_work=refine_max_work, dt=dt, gain_stop_share=gain_stop_share,
        integrator_tolerance=integrator_tolerance,
    )
    return MultirateFit(
        fast=d["model"],
        lifted=d["model"] if d["lifted"] is None else d["lifted"],
        lifting_period=1 if d["lifting_period"] is None else d["lifting_period"],
        singular_values=np.asarray(d["singular_values"], dtype=np.float64),
        order=d["order"],
        method=d["method"],
        model_json=d["model_json"],
        diagnostics=Diagnostics.from_json(json.loads(d["diagnostics_json"])),
    )


def validate(
    model: StateSpace,
    u: npt.ArrayLike,
    y: npt.ArrayLike,
    *,
    periods: Sequence[int] | None = None,
    lags: int = 20,
    kalman_gain: npt.ArrayLike | None = None,
    u0: npt.ArrayLike | None = None,
    y0: npt.ArrayLike | None = None,
    horizons: Sequence[int] = (1, 5),
    dt: float | None = None,
    initial_state: InitialState = "estimate",
) -> Validation:
    """Validation of ``model`` on a record (``lifted_lti::validate``, the CLI's
    ``validate``): per output the simulation fit (%), k-step-ahead prediction
    fits with the Kalman gain (n x p), residual whiteness and independence
    from the inputs at the 99 % level (``lags`` correlation lags). The
    residual is the one-step prediction error when a Kalman gain is used on
    a single-rate record (as MATLAB's ``resid``), else the simulation error
    (``Validation.residual`` says which).

    The model's operating point and Kalman gain are used, as
    ``lifted validate --model`` uses the model file's; ``u0``, ``y0`` and
    ``kalman_gain`` replace them when given (``model.with_operating_point()``
    drops the operating point). ``y`` may have NaN at unsampled instants
    (``periods`` per output). The simulation and the predictor start from
    the initial state that fits the record best in least squares
    (``initial_state="estimate"``, as MATLAB's ``compare``; returned as
    ``x0``) or from rest (``"zero"``). Returns a :class:`Validation`.
    """
    d = _validate(
        model, u, y,
        None if periods is None else list(periods),
        lags, kalman_gain, u0, y0, list(horizons), dt, initial_state,
    )
    outputs = [
        OutputValidation(
            name=o["name"],
            fit=o["fit"],
            prediction_fits=o["prediction_fits"],
            samples=o["samples"],
            bound=o["bound"],
            auto=o["auto"],
            cross=o["cross"],
            white=o["white"],
            independent=o["independent"],
            simulated=np.asarray(o["simulated"], dtype=np.float64),
        )
        for o in d["outputs"]
    ]
    return Validation(
        outputs=outputs,
        lags=d["lags"],
        horizons=d["horizons"],
        stable=d["stable"],
        spectral_radius=d["spectral_radius"],
        x0=None if d["x0"] is None else np.asarray(d["x0"], dtype=np.float64),
        residual=d["residual"],
        gain_note=d["gain_note"],
    )


def to_control(sys: StateSpace) -> Any:
    """The python-control ``StateSpace`` of ``sys`` (needs ``pip install control``;
    the operating point and Kalman gain have no python-control counterpart)."""
    try:
        import control  # type: ignore[import-untyped]
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("to_control needs python-control: pip install control") from e
    dt = 0 if sys.dt is None else sys.dt
    return control.ss(sys.A, sys.B, sys.C, sys.D, dt)


def from_control(cs: Any) -> StateSpace:
    """A :class:`StateSpace` from a python-control ``StateSpace`` or
    ``TransferFunction`` (realised by ``control.ss``). ``dt`` 0 is
    continuous; ``dt=True`` (discrete, period unspecified) and ``dt=None``
    (python-control's unspecified time base) are rejected: give the model
    its period (``control.ss(..., dt=T)``) or 0."""
    if not all(hasattr(cs, k) for k in ("A", "B", "C", "D")):
        try:
            import control
        except ImportError as e:  # pragma: no cover - depends on the environment
            raise LiftedError("from_control needs python-control (pip install control)") from e
        try:
            cs = control.ss(cs)
        except Exception as e:
            raise ArgumentError(
                f"argument 'cs': not a python-control StateSpace or TransferFunction ({e})"
            ) from e
    dt = cs.dt
    if dt is True:
        raise LiftedError("python-control model with unspecified sample period (dt=True)")
    if dt is None:
        raise LiftedError(
            "python-control model with an unspecified time base (dt=None): give it its "
            "sample period, or dt=0 for a continuous-time model"
        )
    dt = None if dt == 0 else float(dt)

    def m(a: Any) -> FloatArray:
        return np.ascontiguousarray(np.atleast_2d(np.asarray(a, dtype=np.float64)))

    return StateSpace(m(cs.A), m(cs.B), m(cs.C), m(cs.D), dt)
