"""The string options of the package as ``Literal`` aliases.

Each alias lists exactly the names the extension accepts for that option
(one conversion per option type on the Rust side, ``lifted._lifted._choices()``;
the test suite checks the two lists against each other). Matching is
case-insensitive; there are no other spellings.
"""

from __future__ import annotations

from typing import Literal

__all__ = [
    "SubspaceMethod",
    "IdentifyMethod",
    "SystemEstimate",
    "PbsidVariant",
    "Feedback",
    "C2dMethod",
    "MpcKind",
    "OrderCriterion",
    "BdRoute",
    "Detrend",
    "Refine",
    "InitialState",
]

#: Weighting of the subspace identification (``lifted.dask.identify(method=...)``).
SubspaceMethod = Literal["n4sid", "moesp", "cva"]
#: Identification method of the workflow (``identify(method=...)``, the
#: CLI's ``--method``): the subspace methods, the predictor-based PBSID-opt
#: and SSARX, instrumental-variable subspace, and the least-squares
#: polynomial models ARX, FIR, OE, ARMAX and BJ (``orders=[na, nb, nk]`` /
#: ``[nb, nk]`` / ``[nb, nf, nk]`` / ``[na, nb, nc, nk]`` / ``[nb, nc, nd, nf, nk]``).
IdentifyMethod = Literal[
    "n4sid", "moesp", "cva", "pbsid", "ssarx", "pbsid_rowwise", "iv", "arx", "fir", "oe",
    "armax", "bj", "process", "impulse",
]
#: process-model structures (MATLAB's ``idproc`` types): first/second order,
#: integrating, with a zero, underdamped; each with a gain and a dead time.
ProcessStructure = Literal["p1d", "p2d", "p1di", "p2dz", "p2du"]
#: How (A, C) and then (B, D) are estimated (``identify(system=...)``):
#: shift invariance of the extended observability matrix, or regression on
#: the estimated state sequence.
SystemEstimate = Literal["shift", "states"]
#: Predictor-based closed-loop subspace method (``pbsid(variant=...)``):
#: PBSID-opt (Chiuso 2007), row-wise PBSID, or SSARX (Jansson 2003).
PbsidVariant = Literal["pbsid", "pbsid_rowwise", "ssarx"]
#: Controller feedback of a multirate closed loop (``simulate_experiment``):
#: every fast sample, or the last measured sample held.
Feedback = Literal["fast", "hold_last"]
#: Discretisation method of ``StateSpace.c2d``.
C2dMethod = Literal["zoh", "foh", "tustin"]
#: Receding-horizon law of ``Mpc``: state-space MPC or DMC.
MpcKind = Literal["gpc", "dmc"]
#: Rule of an automatic order (``identify(order_criterion=...)``, the CLI's
#: ``--order-criterion``): held-out simulation fit (with the horizon and the
#: (A, C) route), the singular-value gap, Bauer's SVC, AIC, AICc, BIC.
OrderCriterion = Literal["validation", "gap", "svc", "aic", "aicc", "bic"]
#: Route of (B, D, x0) after (A, C) (``identify(bd=...)``, ``--bd``).
BdRoute = Literal["auto", "output_error", "projection"]
#: Offsets removed before the identification (``identify(detrend=...)``).
Detrend = Literal["none", "mean", "linear"]
#: Refinement after the identification (``identify(refine=...)``).
Refine = Literal["auto", "none", "pem", "oe"]
#: Initial state of a validation's simulation (``validate(initial_state=...)``,
#: the CLI's ``--initial-state``): least squares on the record, or rest.
InitialState = Literal["estimate", "zero"]
