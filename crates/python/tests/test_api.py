"""The public surface: full signatures (no **kwargs), __version__, Python
style reprs, the Literal aliases in step with the options the extension
parses, and one stub for the binary module."""

from __future__ import annotations

import importlib.metadata
import inspect
import pathlib
import pydoc
import typing

import numpy as np
import pytest

import lifted

PACKAGE = pathlib.Path(lifted.__file__).resolve().parent


def public_callables() -> list[tuple[str, object]]:
    out = []
    for name in lifted.__all__:
        obj = getattr(lifted, name)
        routine = inspect.isroutine(obj) or isinstance(obj, type)
        if routine and not (isinstance(obj, type) and issubclass(obj, BaseException)):
            out.append((name, obj))
    return out


def test_no_var_keyword_anywhere() -> None:
    checked = 0
    for name, obj in public_callables():
        if isinstance(obj, type) and not hasattr(obj, "__text_signature__"):
            continue
        sig = inspect.signature(obj)  # type: ignore[arg-type]
        kinds = {p.kind for p in sig.parameters.values()}
        assert inspect.Parameter.VAR_KEYWORD not in kinds, name
        assert inspect.Parameter.VAR_POSITIONAL not in kinds, name
        checked += 1
    assert checked >= 20
    for fn in (lifted.n4sid, lifted.moesp, lifted.cva):
        params = inspect.signature(fn).parameters
        for key in ("order", "dt", "past", "future", "threads", "system"):
            assert params[key].kind is inspect.Parameter.KEYWORD_ONLY, (fn, key)
        assert "**" not in pydoc.render_doc(fn)


def test_extension_signatures_are_complete() -> None:
    sig = inspect.signature(lifted.StateSpace)
    assert list(sig.parameters) == ["a", "b", "c", "d", "dt", "u0", "y0", "kalman_gain"]
    assert sig.parameters["u0"].kind is inspect.Parameter.KEYWORD_ONLY
    assert list(inspect.signature(lifted.gbn).parameters) == [
        "n", "amplitude", "switch_probability", "hold", "seed"]
    assert inspect.signature(lifted.Mpc).parameters["kind"].default == "gpc"
    assert "prediction_horizon" in pydoc.render_doc(lifted.Mpc)


def test_version() -> None:
    assert lifted.__version__ == importlib.metadata.version("lifted")
    assert lifted.__version__ == lifted._lifted.__version__
    assert all(part.isdigit() for part in lifted.__version__.split(".")[:3])


def test_python_style_repr(plant: lifted.StateSpace) -> None:
    assert repr(plant) == "StateSpace(n=2, m=1, p=1, dt=0.5)"
    cont = lifted.StateSpace(-1.0, 1, 1, 0)
    assert repr(cont) == "StateSpace(n=1, m=1, p=1, dt=None)"
    g = lifted.StateSpace(0.5, 1, 1, 0, 1.0, u0=[3.0], y0=[-40.0])
    assert repr(g) == "StateSpace(n=1, m=1, p=1, dt=1.0, u0=[3.0], y0=[-40.0])"
    assert "Some(" not in repr(g) and "None" not in repr(g)


def test_result_repr_is_short(record) -> None:
    u, y = record
    fit = lifted.n4sid(u, y, order=2, dt=0.5)
    text = repr(fit)
    assert text.startswith("SubspaceFit(method='n4sid', order=2, suggested_order=2, model=StateSpace(")
    assert len(text) < 200


def test_literal_aliases_match_the_extension() -> None:
    parsed = dict(lifted._lifted._choices())
    for alias, names in parsed.items():
        assert list(typing.get_args(getattr(lifted, alias))) == names, alias
    assert set(parsed) == {
        "SubspaceMethod", "IdentifyMethod", "SystemEstimate", "PbsidVariant", "Feedback",
        "C2dMethod", "MpcKind", "OrderCriterion", "BdRoute", "Detrend", "Refine", "InitialState",
    }


def test_the_diagnostics_dataclass_mirrors_the_rust_type(record: tuple[np.ndarray, np.ndarray]) -> None:
    """lifted.Diagnostics has the typed fields of lifted_workflow::Diagnostics
    (and `details`); a fit's diagnostics read as fields and as the model
    file's mapping, and write back the file's object."""
    import dataclasses
    import json

    names = [f.name for f in dataclasses.fields(lifted.Diagnostics)]
    assert names == list(lifted._lifted._diagnostics_fields()) + ["details"]
    u, y = record
    fit = lifted.identify(u, y, dt=0.5)
    d = fit.diagnostics
    assert isinstance(d, lifted.Diagnostics)
    file = json.loads(fit.model_json)["diagnostics"]
    assert d == file and d.to_dict() == file
    assert d.route is not None and d.route == d["route"]
    assert d.samples == len(u) and d.plan is not None and d.plan["route"]
    assert d.structure_selection is not None and d.structure_selection["order"] == fit.order
    assert "horizons" in d and d.horizons == d["horizons"]
    assert set(d.details) <= set(file) and not set(d.details) & set(names)
    # Route entries no field names stay by name; unknown keys are details.
    other = lifted.Diagnostics.from_json({"route": "r", "lifting_period": 3})
    assert other.details == {"lifting_period": 3} and other["lifting_period"] == 3
    assert "warnings" not in other and other.warnings == []
    assert lifted.Diagnostics.from_json(None) == {}


def _partial(v: str, u: np.ndarray, y: np.ndarray) -> object:
    """The streamed (lifted.dask) route's identification step, which takes a
    SubspaceMethod."""
    from lifted import _lifted as ext

    plan = ext.partial_plan(u, y, 5, 5)
    records = ext.partial_close(ext.partial_compress(plan, u, y))
    return ext.partial_identify(records, v, order=2, past=5, future=5)


@pytest.mark.parametrize(
    ("alias", "call"),
    [
        ("SubspaceMethod", lambda v, p, u, y: _partial(v, u, y)),
        ("IdentifyMethod", lambda v, p, u, y: lifted.identify(u, y, v, order=2)),
        ("SystemEstimate", lambda v, p, u, y: lifted.n4sid(u, y, order=2, system=v)),
        ("PbsidVariant", lambda v, p, u, y: lifted.pbsid(u, y, v, order=2)),
        ("Feedback", lambda v, p, u, y: lifted.simulate_experiment(
            p, np.ones(20), lifted.StateSpace(np.zeros((0, 0)), np.zeros((0, 1)),
                                              np.zeros((1, 0)), 0.05, 0.5), feedback=v)),
        ("C2dMethod", lambda v, p, u, y: lifted.StateSpace(-1.0, 1, 1, 0).c2d(0.1, method=v)),
        ("MpcKind", lambda v, p, u, y: lifted.Mpc(p, v)),
        ("OrderCriterion", lambda v, p, u, y: lifted.n4sid(u, y, order_criterion=v, horizon=5, max_order=4)),
        ("BdRoute", lambda v, p, u, y: lifted.n4sid(u, y, order=2, horizon=5, system="shift", bd=v)),
        ("Detrend", lambda v, p, u, y: lifted.n4sid(u, y, order=2, horizon=5, system="shift", detrend=v)),
        ("Refine", lambda v, p, u, y: lifted.n4sid(u, y, order=2, horizon=5, system="shift", refine=v,
                                                    refine_iterations=2)),
        ("InitialState", lambda v, p, u, y: lifted.validate(
            lifted.StateSpace(0.5, 1.0, 1.0, 0.0, 1.0), u[:, :1], y[:, :1], initial_state=v)),
    ],
)
def test_every_literal_is_accepted_and_nothing_else(alias, call, plant, record) -> None:
    u, y = record
    names = typing.get_args(getattr(lifted, alias))
    for v in names:
        call(v, plant, u, y)
    with pytest.raises(lifted.ArgumentError) as e:
        call("magic", plant, u, y)
    listed = ", ".join(f"'{n}'" for n in names)
    assert f"(expected one of {listed})" in str(e.value)
    # the former aliases are gone
    for old in ("bilinear", "holdlast", "ss", "statespace", "shift_invariance", "state_sequence"):
        if old not in names:
            with pytest.raises(lifted.ArgumentError):
                call(old, plant, u, y)


def test_one_stub_for_the_extension() -> None:
    stubs = sorted(p.name for p in PACKAGE.glob("*.pyi"))
    assert stubs == ["_lifted.pyi"]
    assert (PACKAGE / "py.typed").is_file()
