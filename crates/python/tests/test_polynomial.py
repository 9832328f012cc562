"""Polynomial models (issue 49): lifted.arx / lifted.fir and
identify(method="arx"|"fir", orders=...), the polynomial model and its
parameter uncertainty on the result, the structure scan (arxstruc), the
delay estimate (delayest), the refusals, and the model-file round trip."""

from __future__ import annotations

import json
import pathlib
import pickle
import re
from typing import Any

import numpy as np
import pytest

import lifted

#: y(t) - 1.5 y(t-1) + 0.7 y(t-2) = u(t-nk) + 0.5 u(t-nk-1) + e(t)
A = (-1.5, 0.7)
B = (1.0, 0.5)
TRUTH = np.array(A + B)


def simulate_arx(
    seed: int, n: int = 1000, nk: int = 1, sigma: float = 0.2,
) -> tuple[np.ndarray, np.ndarray]:
    """A seeded SISO ARX record (white input, white equation error)."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(n)
    e = sigma * rng.standard_normal(n)
    y = np.zeros(n)
    for t in range(n):
        acc = e[t]
        for i, a in enumerate(A, start=1):
            if t - i >= 0:
                acc -= a * y[t - i]
        for m, b in enumerate(B):
            if t - nk - m >= 0:
                acc += b * u[t - nk - m]
        y[t] = acc
    return u, y


@pytest.fixture(scope="module")
def arx_record() -> tuple[np.ndarray, np.ndarray]:
    return simulate_arx(3, n=2000)


def test_arx_recovers_the_parameters(arx_record) -> None:
    u, y = arx_record
    fit = lifted.arx(u, y, [2, 2, 1], dt=0.5)
    assert isinstance(fit, lifted.SubspaceFit) and fit.method == "arx"
    p = fit.polynomial
    assert isinstance(p, lifted.PolyModel)
    assert p.family == "arx" and p.dt == 0.5
    assert p.orders["na"] == [[2]] and p.orders["nb"] == [[2]] and p.orders["nk"] == [[1]]
    assert p.nk == [[1]]
    # ascending powers of q^-1, the diagonal of A monic
    assert p.a[0][0][0] == 1.0 and len(p.a[0][0]) == 3 and len(p.b[0][0]) == 2
    assert p.c == [[1.0]] and p.d == [[1.0]] and p.f == [[[1.0]]]
    # parameters in MATLAB's getpvec order [a1 a2 b0 b1], within 4 std
    assert fit.parameters is not None and fit.std is not None and fit.covariance is not None
    assert fit.parameters.shape == (4,) and fit.covariance.shape == (4, 4)
    np.testing.assert_allclose(fit.std, np.sqrt(np.diag(fit.covariance)))
    assert np.all(np.abs(fit.parameters - TRUTH) < 4 * fit.std), (fit.parameters, fit.std)
    np.testing.assert_allclose(fit.parameters, [*p.a[0][0][1:], *p.b[0][0]])
    # the noise variance of e (sigma = 0.2)
    assert p.noise_variance.shape == (1, 1)
    assert abs(p.noise_variance[0, 0] / 0.04 - 1) < 0.1
    # the model is the innovations realisation: a stable second-order predictor
    assert fit.model.nstates == 2 and fit.kalman_gain is not None
    np.testing.assert_allclose(
        np.sort_complex(fit.model.poles()), np.sort_complex(np.roots([1, *A])), atol=0.05)
    assert lifted.validate(fit.model, u, y).outputs[0].prediction_fits[0] > 90


def test_std_covers_the_truth_over_seeds() -> None:
    """Over 100 seeded records the +-1.96 sigma interval holds the truth in
    about 95 % of the 400 parameter-runs (loosely: 90-99 %)."""
    hits, runs = 0, 0
    for seed in range(100):
        u, y = simulate_arx(1000 + seed, n=400)
        fit = lifted.arx(u, y, (2, 2, 1))
        assert fit.parameters is not None and fit.std is not None
        hits += int(np.sum(np.abs(fit.parameters - TRUTH) <= 1.96 * fit.std))
        runs += 4
    assert 0.90 <= hits / runs <= 0.99, hits / runs


def test_identify_method_arx_and_the_scan(arx_record) -> None:
    u, y = arx_record
    fixed = lifted.identify(u, y, "arx", orders=[2, 2, 1])
    np.testing.assert_allclose(fixed.parameters, lifted.arx(u, y, [2, 2, 1]).parameters)
    # order n: na = nb = n, nk scanned
    fit = lifted.identify(u, y, "ARX", order=2)
    assert fit.polynomial is not None
    assert fit.polynomial.orders["na"] == [[2]] and fit.polynomial.orders["nb"] == [[2]]
    assert fit.diagnostics["structure_scan"]["chosen"]["nk"] == 1
    # no orders: the structure scan of the workflow
    scanned = lifted.arx(u, y, order_criterion="bic")
    chosen = scanned.diagnostics["structure_scan"]["chosen"]
    assert (chosen["na"], chosen["nb"], chosen["nk"]) == (2, 2, 1)


def test_state_space_fits_have_no_polynomial(record) -> None:
    """A state-space fit has no polynomial model; its parameters are its
    entries [vec A; vec B; vec C; vec D] with their covariance (issue 49),
    unless ``covariance=False``."""
    u, y = record
    fit = lifted.n4sid(u, y, order=2, dt=0.5)
    assert fit.polynomial is None
    assert json.loads(fit.model_json)["kind"] == "state_space"
    m = fit.model
    sizes = [np.asarray(x).size for x in (m.A, m.B, m.C, m.D)]
    assert fit.parameters is not None and fit.covariance is not None and fit.std is not None
    assert fit.parameters.shape == (sum(sizes),)
    np.testing.assert_array_equal(fit.parameters[: sizes[0]], np.asarray(m.A).ravel(order="F"))
    assert fit.covariance.shape == (sum(sizes), sum(sizes))
    np.testing.assert_allclose(fit.std, np.sqrt(np.diag(fit.covariance)))
    assert fit.diagnostics["covariance"]["computed"] is True
    bare = lifted.identify(u, y, order=2, dt=0.5, covariance=False)
    assert bare.parameters is None and bare.covariance is None and bare.std is None
    assert bare.diagnostics["covariance"]["computed"] is False


def test_fir() -> None:
    rng = np.random.default_rng(5)
    b = np.array([0.5, 1.0, 0.8, 0.3])
    u = rng.standard_normal(1500)
    y = np.convolve(u, np.r_[0.0, 0.0, b])[: len(u)] + 0.1 * rng.standard_normal(len(u))
    fit = lifted.fir(u, y, [4, 2])
    p = fit.polynomial
    assert p is not None and p.family == "fir" and fit.method == "fir"
    assert p.a == [[[1.0]]] and p.nk == [[2]] and p.orders["nb"] == [[4]]
    assert fit.parameters is not None and fit.std is not None
    assert np.all(np.abs(fit.parameters - b) < 4 * fit.std), (fit.parameters, fit.std)
    same = lifted.identify(u, y, "fir", orders=(4, 2))
    np.testing.assert_allclose(same.parameters, fit.parameters)


def two_outputs(seed: int, n: int, step: Any) -> tuple[np.ndarray, np.ndarray]:
    """A 2-input 2-output record: white inputs u, white noise e of standard
    deviation 0.1, y[t] = step(t, y, u, e) from y[0] = 0."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((n, 2))
    e = 0.1 * rng.standard_normal((n, 2))
    y = np.zeros((n, 2))
    for t in range(1, n):
        y[t] = step(t, y, u, e)
    return u, y


def test_mimo_arx_parameter_order() -> None:
    """Per output: A_i1, A_i2 (the free coefficients), then B_i1, B_i2."""
    u, y = two_outputs(8, 3000, lambda t, y, u, e: [
        0.5 * y[t - 1, 0] + 0.1 * y[t - 1, 1] + u[t - 1, 0] + 0.3 * u[t - 1, 1] + e[t, 0],
        -0.2 * y[t - 1, 0] + 0.4 * y[t - 1, 1] + 0.5 * u[t - 1, 0] - u[t - 1, 1] + e[t, 1],
    ])
    fit = lifted.arx(u, y, [1, 1, 1])
    truth = np.array([-0.5, -0.1, 1.0, 0.3, 0.2, -0.4, 0.5, -1.0])
    assert fit.parameters is not None and fit.std is not None
    assert fit.parameters.shape == (8,) and fit.std.shape == (8,)
    assert np.all(np.abs(fit.parameters - truth) < 4 * fit.std), (fit.parameters, fit.std)
    p = fit.polynomial
    assert p is not None and p.noise_variance.shape == (2, 2)
    assert p.a[0][1][0] == 0.0 and p.a[0][0][0] == 1.0  # off-diagonal starts with 0
    assert p.nk == [[1, 1], [1, 1]]


def test_arxstruc_finds_the_structure_by_mdl() -> None:
    u, y = simulate_arx(21, n=3000, nk=2)
    scan = lifted.arxstruc(u, y, na=range(1, 5), nb=range(1, 5), nk=[1, 2, 3])
    assert isinstance(scan, lifted.ArxScan)
    assert len(scan) == 4 * 4 * 3 and scan.validation_loss is None
    assert scan.loss.shape == (48, 1) and scan.aic.shape == (48,)
    assert list(scan.na[:3]) == [1, 1, 1] and list(scan.nk[:3]) == [1, 2, 3]
    assert list(scan.parameters[:3]) == [2, 2, 2]
    assert scan.best("mdl") == (2, 2, 2)
    r = int(np.argmin(scan.mdl))
    assert (scan.na[r], scan.nb[r], scan.nk[r]) == (2, 2, 2)
    # MDL = sum ln V + d ln J / J
    j = scan.samples
    np.testing.assert_allclose(
        scan.mdl, np.log(scan.loss[:, 0]) + scan.parameters * np.log(j) / j, rtol=1e-12)
    # held-out records: the validation loss, and the default criterion
    u_val, y_val = simulate_arx(22, n=1500, nk=2)
    held = lifted.arxstruc(u, y, u_val, y_val, na=range(1, 5), nb=range(1, 5), nk=[1, 2, 3])
    assert held.validation_loss is not None and held.validation_loss.shape == (48, 1)
    assert held.validation_samples is not None
    assert held.best() == held.best("validation")
    assert held.best("validation")[2] == 2 and held.best("mdl") == (2, 2, 2)
    fit = lifted.arx(u, y, scan.best("mdl"))
    assert fit.parameters is not None and fit.std is not None
    assert np.all(np.abs(fit.parameters - TRUTH) < 4 * fit.std)
    assert pickle.loads(pickle.dumps(scan)).best("mdl") == (2, 2, 2)


def test_delayest_finds_the_delay() -> None:
    u, y = simulate_arx(31, n=2000, nk=4)
    d = lifted.delayest(u, y)
    assert d.shape == (1, 1) and d.dtype == np.int64
    assert int(d[0, 0]) == 4
    assert int(lifted.delayest(u, y, min_delay=1, max_delay=6)[0, 0]) == 4


def test_refusals(arx_record) -> None:
    u, y = arx_record
    cases = [
        (lambda: lifted.arx(u, y, [2, 2]), lifted.ArgumentError, "orders"),
        (lambda: lifted.fir(u, y, [2, 2, 1]), lifted.ArgumentError, "orders"),
        (lambda: lifted.arx(u, y, [2, -1, 1]), lifted.ArgumentError, "orders[1]"),
        (lambda: lifted.arx(u, y, [2, 0, 1]), lifted.ArgumentError, "orders"),
        (lambda: lifted.fir(u, y, [0, 1]), lifted.ArgumentError, "orders"),
        (lambda: lifted.arx(u, y, []), lifted.ArgumentError, "orders"),
        (lambda: lifted.arx(u, y, 3), lifted.ArgumentError, None),  # type: ignore[arg-type]
        (lambda: lifted.arx(u, y, "221"), lifted.ArgumentError, None),  # type: ignore[arg-type]
        (lambda: lifted.arx(u, y, [2, 2, 1], order=2), lifted.ArgumentError, "orders"),
        (lambda: lifted.identify(u, y, "n4sid", orders=[2, 2, 1]), lifted.ArgumentError, "orders"),
        (lambda: lifted.fir(u, y, [2, 0], feedthrough=False), lifted.ArgumentError, "orders"),
        (lambda: lifted.arx(np.ones(300), y[:300], [2, 2, 1]), lifted.NotExcitingError, None),
        (lambda: lifted.arx(u[:5], y[:5], [2, 2, 1]), lifted.TooShortError, None),
        (lambda: lifted.arxstruc(u, y, na=[]), lifted.ArgumentError, "na"),
        (lambda: lifted.arxstruc(u, y, na=[0], nb=[0]), lifted.ArgumentError, "nb"),
        (lambda: lifted.arxstruc(u, y, u), lifted.ArgumentError, None),
        (lambda: lifted.arxstruc(u, y, na=[1], nb=[1]).best("validation"),
         lifted.ArgumentError, None),
        (lambda: lifted.arxstruc(u, y, na=[1], nb=[1]).best("bic"), lifted.ArgumentError, None),
        (lambda: lifted.delayest(u, y, nb=0), lifted.ArgumentError, "nb"),
        (lambda: lifted.delayest(u, y, min_delay=5, max_delay=2), lifted.ArgumentError,
         "max_delay"),
        (lambda: lifted.delayest(u, y, na=-1), lifted.ArgumentError, "na"),
        (lambda: lifted.delayest(np.zeros(300), y[:300]), lifted.NotExcitingError, None),
    ]
    for k, (call, cls, argument) in enumerate(cases):
        with pytest.raises(cls) as e:
            call()
        assert isinstance(e.value, ValueError), k
        if argument is not None:
            assert e.value.argument == argument, (k, e.value)  # type: ignore[attr-defined]
    # the workflow's message reaches Python
    with pytest.raises(lifted.ArgumentError, match="only used with the arx and fir methods"):
        lifted.identify(u, y, "moesp", orders=[2, 2, 1])
    with pytest.raises(lifted.ArgumentError, match=r"\[na nb nk\] \(3 numbers\)"):
        lifted.arx(u, y, [2, 2])
    # types: as everywhere in the package, a float or a bool is a TypeError
    for bad in ([2, 2.5, 1], [2, True, 1], [2, np.True_, 1]):
        with pytest.raises(TypeError):
            lifted.arx(u, y, bad)  # type: ignore[arg-type]
    with pytest.raises(TypeError):
        lifted.delayest(u, y, nb=True)


def test_model_json_keeps_the_polynomial(arx_record, tmp_path: pathlib.Path) -> None:
    u, y = arx_record
    fit = lifted.arx(u, y, [2, 2, 1], dt=0.5)
    assert fit.polynomial is not None
    doc = json.loads(fit.model_json)
    assert doc["kind"] == "polynomial" and doc["method"] == "arx"
    assert doc["polynomial"]["ts"] == 0.5 and "covariance" in doc["polynomial"]
    path = tmp_path / "arx.json"
    path.write_text(fit.model_json)
    text = path.read_text()
    back = lifted.PolyModel.from_json(text)
    np.testing.assert_array_equal(back.parameters, fit.polynomial.parameters)
    np.testing.assert_array_equal(back.covariance, fit.polynomial.covariance)
    np.testing.assert_array_equal(back.noise_variance, fit.polynomial.noise_variance)
    assert back.a == fit.polynomial.a and back.b == fit.polynomial.b
    assert back.orders == fit.polynomial.orders and back.family == "arx"
    # the state-space model of the same file, with its operating point and gain
    model = lifted.StateSpace.from_json(text)
    assert model == fit.model
    # the polynomial model's own JSON
    again = lifted.PolyModel.from_json(back.to_json())
    np.testing.assert_array_equal(again.parameters, back.parameters)
    np.testing.assert_array_equal(again.std, back.std)
    # a state-space model file holds no polynomial model
    ss = lifted.n4sid(u, y, order=2)
    with pytest.raises(lifted.LiftedError, match="not 'polynomial'"):
        lifted.PolyModel.from_json(ss.model_json)
    with pytest.raises(lifted.ArgumentError):
        lifted.PolyModel.from_json("{")


def test_arx_fit_pickles(arx_record) -> None:
    u, y = arx_record
    fit = lifted.arx(u, y, [2, 2, 1])
    back = pickle.loads(pickle.dumps(fit))
    assert back.polynomial is not None and fit.polynomial is not None
    np.testing.assert_array_equal(back.parameters, fit.parameters)
    np.testing.assert_array_equal(back.covariance, fit.covariance)
    assert repr(back.polynomial) == repr(fit.polynomial)
    assert back.model == fit.model and back.model_json == fit.model_json


def test_readme_arx_example(tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> None:
    text = (pathlib.Path(__file__).resolve().parents[1] / "README.md").read_text()
    code = re.search(r"## Polynomial.*?```python\n(.*?)```", text, re.S)
    assert code is not None
    monkeypatch.chdir(tmp_path)
    scope: dict[str, object] = {}
    exec(compile(code.group(1), "README.md", "exec"), scope)
    fit = scope["fit"]
    assert isinstance(fit, lifted.SubspaceFit) and fit.polynomial is not None
    assert fit.parameters is not None and fit.std is not None
    assert np.all(np.abs(fit.parameters - TRUTH) < 4 * fit.std)
    assert scope["best"] == (2, 2, 1)
    back = scope["back"]
    assert isinstance(back, lifted.PolyModel)
    np.testing.assert_array_equal(back.parameters, fit.parameters)


def test_oe_from_an_output_measured_every_five_samples() -> None:
    """OE (``lifted.oe``) on a record whose output is measured every 5th
    sample (NaN between): the fast model's parameters within 4.5 std."""
    rng = np.random.default_rng(7)
    n = 6000
    u = rng.standard_normal(n)
    y = np.zeros(n)
    # y = q^-2 (0.5 + 0.3 q^-1) / (1 - 1.2 q^-1 + 0.5 q^-2) u
    x = np.zeros(n)
    for t in range(n):
        x[t] = (1.2 * x[t - 1] if t >= 1 else 0.0) - (0.5 * x[t - 2] if t >= 2 else 0.0)
        x[t] += (0.5 * u[t - 2] if t >= 2 else 0.0) + (0.3 * u[t - 3] if t >= 3 else 0.0)
    y = x + 0.05 * rng.standard_normal(n)
    y[np.arange(n) % 5 != 0] = np.nan
    fit = lifted.oe(u, y, [2, 2, 2])
    assert fit.polynomial is not None
    assert fit.polynomial.family == "oe"
    truth = np.array([0.5, 0.3, -1.2, 0.5])
    assert fit.parameters is not None and fit.std is not None
    assert np.all(np.abs(fit.parameters - truth) < 4.5 * fit.std)


def test_bj_from_an_output_measured_every_four_samples() -> None:
    """BJ (``lifted.bj``) on a record whose output is measured every 4th
    sample (NaN between): the predictor skips the missing samples and the
    fast model's plant parameters lie within 4.5 std; the noise model's D
    too (its C is weakly determined from every 4th sample)."""
    rng = np.random.default_rng(9)
    n = 8000
    u = rng.standard_normal(n)
    e = 0.1 * rng.standard_normal(n)
    x = np.zeros(n)
    v = np.zeros(n)
    for t in range(n):
        x[t] = (1.2 * x[t - 1] if t >= 1 else 0.0) - (0.5 * x[t - 2] if t >= 2 else 0.0)
        x[t] += (0.5 * u[t - 2] if t >= 2 else 0.0) + (0.3 * u[t - 3] if t >= 3 else 0.0)
        v[t] = (0.8 * v[t - 1] if t >= 1 else 0.0) + e[t] + (0.4 * e[t - 1] if t >= 1 else 0.0)
    y = x + v + 10.0
    y[np.arange(n) % 4 != 0] = np.nan
    fit = lifted.bj(u, y, [2, 1, 1, 2, 2])
    assert fit.polynomial is not None
    assert fit.polynomial.family == "bj"
    # Parameters: b1 b2, c1, d1, f1 f2.
    truth = np.array([0.5, 0.3, 0.4, -0.8, -1.2, 0.5])
    assert fit.parameters is not None and fit.std is not None
    assert np.all(np.abs(fit.parameters - truth) < 4.5 * fit.std)
    assert fit.diagnostics["measured"] == [2000]


def test_armax_and_bj() -> None:
    """ARMAX (1 - 1.5q + 0.7q^2) y = q(1 + 0.5q) u + (1 + 0.5q) e and its
    parameters within 4.5 std; BJ of an OE plant with coloured noise."""
    rng = np.random.default_rng(11)
    n = 4000
    u = rng.standard_normal(n)
    e = 0.3 * rng.standard_normal(n)
    y = np.zeros(n)
    for t in range(n):
        y[t] = e[t]
        if t >= 1:
            y[t] += 1.5 * y[t - 1] + u[t - 1] + 0.5 * e[t - 1]
        if t >= 2:
            y[t] += -0.7 * y[t - 2] + 0.5 * u[t - 2]
    fit = lifted.armax(u, y, [2, 2, 1, 1])
    assert fit.polynomial is not None and fit.polynomial.family == "armax"
    truth = np.array([-1.5, 0.7, 1.0, 0.5, 0.5])
    assert fit.parameters is not None and fit.std is not None
    assert np.all(np.abs(fit.parameters - truth) < 4.5 * fit.std)
    fit = lifted.bj(u, y, [2, 1, 1, 2, 1])
    assert fit.polynomial is not None and fit.polynomial.family == "bj"
    with pytest.raises(lifted.ArgumentError):
        lifted.armax(u, y, [2, 2, 1])


def test_procest_first_order_plus_dead_time() -> None:
    """A step test of K = 2, tau = 20 s, theta = 7.3 s (dt = 1 s): the
    printed parameters within 2 %, named after the record's inputs."""
    n = 500
    u = np.where((np.arange(n) >= 20) & (np.arange(n) < 270), 1.0, 0.0)
    # Exact ZOH response of K/(1 + tau s) with dead time 7.3 s.
    a = np.exp(-1.0 / 20.0)
    frac = 0.3
    b_full = 2.0 * (1.0 - a)
    # Fractional delay: the input change reaches the plant 0.3 s into the
    # sample after the integer delay of 7.
    y = np.zeros(n)
    x = 0.0
    for t in range(n):
        y[t] = x
        u_now = u[t - 7] if t >= 7 else 0.0
        u_prev = u[t - 8] if t >= 8 else 0.0
        # Over [t, t+1): u_prev for 0.3 s, then u_now for 0.7 s.
        x = a * x + 2.0 * (np.exp(-0.7 / 20.0) - a) * u_prev + 2.0 * (1.0 - np.exp(-0.7 / 20.0)) * u_now
    del b_full, frac
    rng = np.random.default_rng(3)
    fit = lifted.procest(u + 5.0, y + 40.0 + 0.01 * rng.standard_normal(n), "p1d")
    out = fit.diagnostics["process"]["outputs"][0]
    assert out["names"][:3] == ["K(u1)", "Tp1(u1)", "Td(u1)"]
    for got, want in zip(out["parameters"][:3], [2.0, 20.0, 7.3]):
        assert abs(got - want) < 0.02 * want, out
    with pytest.raises(lifted.ArgumentError):
        lifted.identify(u, y, "arx", process="p1d")
    # A dead time known from the plant, held: 7.3 exactly, no deviation.
    held = lifted.procest(u + 5.0, y + 40.0 + 0.01 * rng.standard_normal(n), "p1d",
                          fixed={"Td": 7.3})
    out = held.diagnostics["process"]["outputs"][0]
    assert out["parameters"][2] == pytest.approx(7.3, abs=1e-12) and out["std"][2] == 0.0
    assert abs(out["parameters"][1] - 20.0) < 0.02 * 20.0, out
    with pytest.raises(lifted.LiftedError, match="Tq"):
        lifted.procest(u, y, "p1d", fixed={"Tq": 1.0})
    with pytest.raises(lifted.LiftedError, match="process_fixed"):
        lifted.identify(u, y, "n4sid", process_fixed={"Td": 1.0})


def test_impulseest_regularised_fir() -> None:
    """lifted.impulseest: 70 TC-regularised coefficients with posterior
    std, the first ones near the impulse response of 0.3/(1 - 1.6q + 0.7q^2)."""
    rng = np.random.default_rng(5)
    n = 400
    u = rng.standard_normal(n)
    x = np.zeros(n)
    for t in range(n):
        x[t] = (1.6 * x[t - 1] if t >= 1 else 0.0) - (0.7 * x[t - 2] if t >= 2 else 0.0)
        x[t] += 0.3 * u[t - 1] if t >= 1 else 0.0
    y = x + 0.1 * rng.standard_normal(n)
    fit = lifted.impulseest(u, y)
    assert fit.parameters is not None and fit.std is not None
    assert len(fit.parameters) == 70
    g = [0.3, 0.48, 0.558]
    assert np.all(np.abs(fit.parameters[:3] - g) < 4.5 * fit.std[:3] + 1e-4)
    assert "hyperparameters" in fit.diagnostics


def test_tf_data_and_python_control() -> None:
    """The plant of an ARMAX fit as z-polynomials (descending powers), and
    as a python-control transfer function when python-control is there."""
    rng = np.random.default_rng(13)
    n = 3000
    u = rng.standard_normal(n)
    y = np.zeros(n)
    for t in range(n):
        y[t] = 0.05 * rng.standard_normal()
        if t >= 1:
            y[t] += 1.5 * y[t - 1] + u[t - 1]
        if t >= 2:
            y[t] += -0.7 * y[t - 2] + 0.5 * u[t - 2]
    fit = lifted.arx(u, y, [2, 2, 1])
    assert fit.polynomial is not None
    nums, dens = fit.polynomial.tf_data()
    num, den = nums[0][0], dens[0][0]
    # G(z) = z^-1 (b0 + b1 z^-1) / (1 + a1 z^-1 + a2 z^-2) = (b0 z + b1) / (z^2 + a1 z + a2).
    assert len(num) == len(den) == 3 and num[0] == 0.0 and den[0] == 1.0
    np.testing.assert_allclose(num[1:], [1.0, 0.5], atol=0.01)
    np.testing.assert_allclose(den[1:], [-1.5, 0.7], atol=0.01)
    control = pytest.importorskip("control")
    g = fit.polynomial.to_control()
    assert isinstance(g, control.TransferFunction) and g.dt == 1.0


def test_oe_without_orders_scans_the_order() -> None:
    """Issue 49: ``lifted.oe(u, y)`` without orders scans the orders by the
    held-out simulation fit; the scan is in the diagnostics."""
    rng = np.random.default_rng(7)
    n = 2000
    u = np.where(rng.random(n) < 0.5, -1.0, 1.0)
    w = np.zeros(n)
    for t in range(n):
        w[t] = (0.5 * (u[t - 2] if t >= 2 else 0.0) + 0.3 * (u[t - 3] if t >= 3 else 0.0)
                + 1.2 * (w[t - 1] if t >= 1 else 0.0) - 0.5 * (w[t - 2] if t >= 2 else 0.0))
    y = w + 0.1 * rng.standard_normal(n)
    fit = lifted.oe(u, y)
    scan = fit.diagnostics["structure_scan"]
    assert scan["order"] == 2, scan
    assert [c["order"] for c in scan["candidates"]] == list(range(1, 11))


def test_arx_with_a_kernel_is_the_regularised_arx() -> None:
    """lifted.arx(..., kernel="tc"): the regularised ARX of the given
    structure, both kernels' hyperparameters in the diagnostics, the
    posterior std; refused without a structure."""
    rng = np.random.default_rng(7)
    n = 300
    u = rng.standard_normal(n)
    x = np.zeros(n)
    for t in range(n):
        x[t] = (1.6 * x[t - 1] if t >= 1 else 0.0) - (0.7 * x[t - 2] if t >= 2 else 0.0)
        x[t] += 0.3 * u[t - 1] if t >= 1 else 0.0
    y = x + 0.3 * rng.standard_normal(n)
    fit = lifted.arx(u, y, [20, 20, 1], kernel="tc")
    assert fit.parameters is not None and fit.std is not None
    assert len(fit.parameters) == 40 and np.all(fit.std > 0)
    reg = fit.diagnostics["regularization"]
    assert reg["kernel"] == "Tc"
    assert 0.5 < reg["hyperparameters"][0]["a"]["lambda"] < 1.0
    assert 0.5 < reg["hyperparameters"][0]["b"]["lambda"] < 1.0
    with pytest.raises(lifted.LiftedError, match="kernel"):
        lifted.arx(u, y, kernel="tc")


def test_procest_with_a_first_order_hold() -> None:
    """lifted.procest(..., intersample="foh"): a FOPDT plant driven by a
    smooth sampled input, the record from a fine simulation of the
    continuous plant (the input linear between its samples, delayed):
    K, Tp1, Td within a percent; the diagnostics name the hold; another
    method refuses the option."""
    rng = np.random.default_rng(11)
    n, sub = 600, 200
    raw = rng.standard_normal(n)
    u = np.zeros(n)
    for t in range(101, n):
        u[t] = 0.9 * u[t - 1] + 0.3 * raw[t]
    # K 2, T 20 s, Td 7.3 s; the input linear between samples, delayed.
    k, tau, td, h = 2.0, 20.0, 7.3, 1.0 / sub
    a = np.exp(-h / tau)
    x, y = 0.0, np.zeros(n)
    for t in range(n):
        y[t] = x
        times = t + (np.arange(sub) + 0.5) * h - td
        v = np.interp(times, np.arange(n), u, left=0.0, right=0.0)
        for vi in v:
            x = a * x + k * (1 - a) * vi
    fit = lifted.procest(u, y, "p1d", intersample="foh")
    out = fit.diagnostics["process"]
    assert out["intersample"] == "Foh"
    p = out["outputs"][0]["parameters"]
    assert abs(p[0] - 2.0) < 0.02 and abs(p[1] - 20.0) < 0.2 and abs(p[2] - 7.3) < 0.05, p
    with pytest.raises(lifted.LiftedError, match="intersample"):
        lifted.identify(u, y, "n4sid", intersample="foh")


def test_arx_with_a_diagonal_a_is_one_miso_fit_per_output() -> None:
    """lifted.arx(..., a_structure="diagonal") on a 2x2 record: each
    output's equation holds its own past only, the same coefficients as a
    fit of that output alone (SIPPY's MIMO ARX), fewer parameters than the
    full A; another method refuses the option by name."""
    u, y = two_outputs(21, 2000, lambda t, y, u, e: [
        0.7 * y[t - 1, 0] + 0.2 * y[t - 1, 1] + u[t - 1, 0] + e[t, 0],
        0.5 * y[t - 1, 1] + 0.5 * u[t - 1, 1] + 0.3 * u[t - 1, 0] + e[t, 1],
    ])
    diagonal = lifted.arx(u, y, [1, 1, 1], a_structure="diagonal")
    full = lifted.arx(u, y, [1, 1, 1])
    assert diagonal.parameters is not None and full.parameters is not None
    assert len(diagonal.parameters) == 6 and len(full.parameters) == 8
    assert diagonal.diagnostics["a_structure"] == "diagonal"
    alone = np.concatenate(
        [lifted.arx(u, y[:, i], [1, 1, 1]).parameters for i in range(2)]  # type: ignore[list-item]
    )
    np.testing.assert_allclose(diagonal.parameters, alone, rtol=1e-9, atol=1e-12)
    with pytest.raises(lifted.LiftedError, match="a_structure"):
        lifted.identify(u, y, "oe", orders=[1, 1, 1], a_structure="diagonal")


def test_armax_with_a_coupled_a() -> None:
    """lifted.armax(..., a_structure="full") on a 2x2 record whose outputs
    feed each other: the cross coefficients of A estimated near the truth
    (y1 takes 0.2 y2(t-1): A_12 = -0.2 q^-1; y2 takes 0.3 y1(t-1)), more
    parameters than the default diagonal A, and a lower one-step loss on
    both outputs."""
    u, y = two_outputs(23, 4000, lambda t, y, u, e: [
        0.7 * y[t - 1, 0] + 0.2 * y[t - 1, 1] + u[t - 1, 0] + e[t, 0] + 0.4 * e[t - 1, 0],
        0.5 * y[t - 1, 1] + 0.3 * y[t - 1, 0] + 0.5 * u[t - 1, 1] + e[t, 1],
    ])
    diagonal = lifted.armax(u, y, [1, 1, 1, 1])
    full = lifted.armax(u, y, [1, 1, 1, 1], a_structure="full")
    assert diagonal.diagnostics["a_structure"] == "diagonal"
    assert full.diagnostics["a_structure"] == "full"
    assert full.parameters is not None and diagonal.parameters is not None
    # Per output: A row (2), B (2), C (1) against A_ii (1), B (2), C (1).
    assert len(full.parameters) == 10 and len(diagonal.parameters) == 8
    # Output 1: [a11, a12, b11, b12, c1]; output 2: [a21, a22, b21, b22, c2].
    p = full.parameters
    assert abs(p[1] + 0.2) < 0.02 and abs(p[5] + 0.3) < 0.02, p
    for i in range(2):
        assert diagonal.diagnostics["loss"][i] > 1.05 * full.diagnostics["loss"][i]
    # y2 from an analyser every 3rd sample (NaN between): one Kalman
    # predictor for both outputs on their measured samples; the cross
    # coefficients again within 4.5 sigma of the truth.
    slow = y.copy()
    slow[np.arange(len(slow)) % 3 != 0, 1] = np.nan
    multirate = lifted.armax(u, slow, [1, 1, 1, 1], a_structure="full")
    assert multirate.diagnostics["a_structure"] == "full"
    assert multirate.diagnostics["measured"] == [4000, 1334]
    assert multirate.parameters is not None and multirate.std is not None
    p, s = np.asarray(multirate.parameters), np.asarray(multirate.std)
    assert abs(p[1] + 0.2) < 4.5 * s[1] and abs(p[5] + 0.3) < 4.5 * s[5], (p, s)


def test_oe_with_a_common_denominator() -> None:
    """lifted.oe(..., f_structure="common"): one F shared by both inputs'
    terms, y = (B1 u1 + B2 u2)/F + e (SIPPY's OE structure) — the copies
    of F equal, 3 free parameters against 4, the truth within 4.5 sigma;
    also from the output measured every 3rd sample (NaN between); BJ takes
    it too; ARX refuses the option by name."""
    rng = np.random.default_rng(33)
    n = 3000
    u = rng.standard_normal((n, 2))
    w = np.zeros(n)
    for t in range(1, n):
        w[t] = 0.8 * w[t - 1] + u[t - 1, 0] + 0.5 * u[t - 1, 1]
    y = w + 0.1 * rng.standard_normal(n)
    truth = np.array([1.0, 0.5, -0.8, -0.8])
    for yy in (y, np.where(np.arange(n) % 3 == 0, y, np.nan)):
        fit = lifted.oe(u, yy, [1, 1, 1], f_structure="common")
        assert fit.diagnostics["f_structure"] == "common"
        assert fit.diagnostics["parameters"] == 3
        assert fit.parameters is not None and fit.std is not None
        p, s = np.asarray(fit.parameters), np.asarray(fit.std)
        assert p[2] == p[3]
        assert np.all(np.abs(p - truth) < 4.5 * s), (p, s)
    per_input = lifted.oe(u, y, [1, 1, 1])
    assert per_input.diagnostics["parameters"] == 4
    bj = lifted.bj(u, y, [1, 1, 1, 1, 1], f_structure="common")
    assert bj.diagnostics["f_structure"] == "common"
    assert bj.diagnostics["parameters"] == 5
    assert bj.parameters is not None
    assert bj.parameters[-1] == bj.parameters[-2]
    with pytest.raises(lifted.LiftedError, match="f_structure"):
        lifted.identify(u, y, "arx", orders=[1, 1, 1], f_structure="common")
