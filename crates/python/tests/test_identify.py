"""Identification and excitation: agreement with the Rust library through an
independent route (the `lifted` CLI binary on the same data), invariants,
and the parallel example."""

from __future__ import annotations

import importlib.util
import json
import os
import pathlib
import subprocess

import numpy as np
import numpy.typing as npt
import pytest

import lifted

ROOT = pathlib.Path(__file__).resolve().parents[3]


def cli() -> pathlib.Path:
    """The CLI binary: $LIFTED_CLI (must exist when set), else target/release/lifted."""
    env = os.environ.get("LIFTED_CLI")
    if env:
        path = pathlib.Path(env)
        assert path.is_file(), f"LIFTED_CLI={env} does not exist"
        return path
    path = ROOT / "target" / "release" / "lifted"
    if not path.is_file():
        pytest.skip("lifted CLI not built (cargo build --release -p lifted-cli)")
    return path


def test_prbs_is_the_cli_signal(tmp_path: pathlib.Path) -> None:
    w = lifted.prbs(7, amplitude=2.0, hold=3, periods=2, seed=5)
    assert w.shape == (127 * 3 * 2,)
    assert set(np.unique(w)) == {-2.0, 2.0}
    # one period of an m-sequence has one more 1 than 0s
    assert w[: 127 * 3].sum() == pytest.approx(2.0 * 3)
    out = tmp_path / "prbs.csv"
    subprocess.run(
        [str(cli()), "prbs", "--order", "7", "--amplitude", "2", "--hold", "3",
         "--periods", "2", "--seed", "5", "--out", str(out)],
        check=True, capture_output=True,
    )
    data = np.genfromtxt(out, delimiter=",", names=True)
    col = [n for n in data.dtype.names if n != "t"][0]
    np.testing.assert_array_equal(data[col], w)


def test_inverse_prbs_is_the_cli_signal(tmp_path: pathlib.Path) -> None:
    w = lifted.inverse_prbs(5, amplitude=1.5, hold=2, periods=1, seed=3)
    assert w.shape == (2 * 2 * 31,)
    # the inverse PRBS has zero mean over its period 2 n_r m (eq. II-4)
    assert abs(w.sum()) < 1e-12
    out = tmp_path / "iprbs.csv"
    subprocess.run(
        [str(cli()), "prbs", "--inverse", "--order", "5", "--amplitude", "1.5", "--hold", "2",
         "--periods", "1", "--seed", "3", "--out", str(out)],
        check=True, capture_output=True,
    )
    data = np.genfromtxt(out, delimiter=",", names=True)
    col = [n for n in data.dtype.names if n != "t"][0]
    np.testing.assert_array_equal(data[col], w)


def test_design_is_the_cli_proposal(tmp_path: pathlib.Path) -> None:
    p = lifted.design(actuator_rate_hz=40.0)
    assert p["hold"] == 8 and p["generation_period"] >= 0.075
    out = tmp_path / "design.json"
    subprocess.run([str(cli()), "design", "--actuator-rate", "40", "--json", str(out)],
                   check=True, capture_output=True)
    doc = json.loads(out.read_text())
    for key in ("order", "m", "hold"):
        assert p[key] == doc[key], key
    assert p["record_length_s"] == pytest.approx(doc["record_length_s"], rel=1e-12)


def test_random_signals_seeded() -> None:
    a = lifted.gbn(500, switch_probability=0.2, seed=3)
    np.testing.assert_array_equal(a, lifted.gbn(500, switch_probability=0.2, seed=3))
    assert not np.array_equal(a, lifted.gbn(500, switch_probability=0.2, seed=4))
    r = lifted.rbs(400, amplitude=0.5, hold=4, seed=1)
    assert set(np.unique(r)) <= {-0.5, 0.5}
    assert np.all(r.reshape(-1, 4) == r.reshape(-1, 4)[:, :1])
    m = lifted.multisine(1024, amplitude=2.0, period=256)
    assert np.sqrt(np.mean(m**2)) == pytest.approx(2.0, rel=1e-9)


def test_identification_recovers_known_poles(record: tuple[np.ndarray, np.ndarray]) -> None:
    u, y = record
    for method in ("n4sid", "moesp", "cva"):
        fit = lifted.identify(u, y, method, order=2, dt=0.5)
        model = fit["model"]
        assert model.dt == 0.5 and fit["order"] == 2
        np.testing.assert_allclose(np.sort_complex(model.poles()), [0.8 - 0.3j, 0.8 + 0.3j], atol=0.02)
        np.testing.assert_allclose(model.dcgain(), [[0.8 / 0.13]], rtol=0.05)
    auto = lifted.n4sid(u, y, dt=0.5)
    assert auto["suggested_order"] == 2
    assert len(auto["singular_values"]) >= 2


def test_several_records(record: tuple[np.ndarray, np.ndarray]) -> None:
    u, y = record
    fit = lifted.n4sid([u[:500], u[500:]], [y[:500], y[500:]], order=2)
    assert len(fit["x0"]) == 2


@pytest.mark.parametrize("method", ["n4sid", "moesp", "cva"])
def test_agrees_with_cli(record: tuple[np.ndarray, np.ndarray], tmp_path: pathlib.Path, method: str) -> None:
    """Same data, same options through the CLI (CSV → lifted identify → model JSON).

    Two records: with one file the CLI streams it (StreamingIdentifier, (B, D)
    by projection); with several it calls lifted_subspace::identify on the
    records, as the binding does."""
    u, y = record
    halves = [(u[:500], y[:500]), (u[500:], y[500:])]
    files = []
    for k, (uk, yk) in enumerate(halves):
        t = 0.5 * np.arange(len(uk))
        data = tmp_path / f"data{k}.csv"
        np.savetxt(data, np.column_stack([t, uk[:, 0], yk[:, 0]]), delimiter=",",
                   header="t,u,y", comments="", fmt="%.17g")
        files += ["--data", str(data)]
    out = tmp_path / "model.json"
    subprocess.run(
        [str(cli()), "identify", "--method", method, *files, "--inputs", "u",
         "--outputs", "y", "--order", "2", "--horizon", "10", "--estimator", "shift",
         "--detrend", "none", "--out", str(out)],
        check=True, capture_output=True,
    )
    text = out.read_text()
    from_cli = lifted.StateSpace.from_json(text)
    fit = lifted.identify([h[0] for h in halves], [h[1] for h in halves], method, order=2,
                          past=10, future=10, dt=0.5, remove_means=False, system="shift")
    ours = fit["model"]
    assert from_cli.dt == ours.dt
    np.testing.assert_allclose(np.sort_complex(ours.poles()), np.sort_complex(from_cli.poles()),
                               rtol=1e-8, atol=1e-10)
    w = np.linspace(0.0, np.pi / 0.5, 25)
    np.testing.assert_allclose(ours.freqresp(w), from_cli.freqresp(w), rtol=1e-7, atol=1e-10)
    assert json.loads(fit["model_json"])["method"] == json.loads(text)["method"]


def test_model_json_carries_the_diagnostics_like_the_cli_model_file(
    record: tuple[np.ndarray, np.ndarray], tmp_path: pathlib.Path
) -> None:
    """fit.model_json is the model file `lifted identify` writes: its
    diagnostics are fit.diagnostics (they were null), the CLI reads them
    back unchanged, and the CLI's own file of the same identification has
    the same ones but for what only the CLI knows (its data files) and the
    timings."""
    u, y = record
    fit = lifted.n4sid(u, y, dt=0.5)
    doc = json.loads(fit.model_json)
    assert fit.diagnostics and doc["diagnostics"] == fit.diagnostics
    assert doc["method"] == "n4sid"
    # the other routes' results carry their model file's diagnostics too
    for other in (lifted.iv(u, y, order=2, dt=0.5), lifted.pbsid(u, y, order=2, dt=0.5)):
        assert other.diagnostics and json.loads(other.model_json)["diagnostics"] == other.diagnostics
    model = tmp_path / "model.json"
    model.write_text(fit.model_json)
    out = subprocess.run([str(cli()), "convert", "--model", str(model), "--to", "ss", "--json"],
                         check=True, capture_output=True, text=True).stdout
    assert json.loads(out)["diagnostics"] == fit.diagnostics
    data, theirs = tmp_path / "rec.csv", tmp_path / "cli.json"
    np.savetxt(data, np.column_stack([0.5 * np.arange(len(u)), u[:, 0], y[:, 0]]), delimiter=",",
               header="t,u,y", comments="", fmt="%.17g")
    subprocess.run([str(cli()), "identify", "--data", str(data), "--inputs", "u", "--outputs", "y",
                    "--out", str(theirs)], check=True, capture_output=True)
    cli_diagnostics = json.loads(theirs.read_text())["diagnostics"]
    assert cli_diagnostics.pop("data") == [str(data)]
    ours = dict(fit.diagnostics)
    assert set(cli_diagnostics.pop("profile")) >= set(ours.pop("profile"))
    # The options each front end gave: the same but for the thread count,
    # which Python states (1) and the command leaves to the workflow (None:
    # 1 in memory); it moves the model by rounding only.
    theirs_opts, our_opts = cli_diagnostics.pop("options"), ours.pop("options")
    assert theirs_opts["identification"].pop("threads") is None
    assert our_opts["identification"].pop("threads") == 1
    assert theirs_opts == our_opts
    # So the CLI's plan names the thread count it left to the default; the
    # rest of the plan is the same.
    theirs_plan, our_plan = cli_diagnostics.pop("plan"), ours.pop("plan")
    threads = [e for e in theirs_plan["resolved"] if e["option"] == "threads"]
    assert threads == [{"option": "threads", "value": 1, "why": "one thread in memory"}]
    theirs_plan["resolved"] = [e for e in theirs_plan["resolved"] if e["option"] != "threads"]
    assert theirs_plan == our_plan
    assert cli_diagnostics == ours


def test_parallel_example_matches_serial() -> None:
    path = pathlib.Path(__file__).resolve().parents[1] / "examples" / "parallel_identify.py"
    spec = importlib.util.spec_from_file_location("parallel_identify", path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    g = lifted.StateSpace(np.array([[1.6, -0.73], [1.0, 0.0]]), np.array([[1.0], [0.0]]),
                          np.array([[0.5, 0.3]]), np.zeros((1, 1)), 1.0)
    records = mod.make_records(g, 8)
    parallel = mod.identify_all(records, workers=4)
    serial = [np.sort_complex(lifted.n4sid(u, y, order=2)["model"].poles()) for u, y in records]
    assert len(parallel) == 8
    for p, s in zip(parallel, serial):
        np.testing.assert_array_equal(p, s)
        np.testing.assert_allclose(p, [0.8 - 0.3j, 0.8 + 0.3j], atol=0.03)


def test_pbsid_identifies_a_closed_loop_without_the_reference() -> None:
    """A plant under PI-like feedback with coloured noise fed back: the
    reference is not given. PBSID's poles are close to the plant's, N4SID's
    are biased (the closed-loop consistency itself is tested in Rust)."""
    rng = np.random.default_rng(27)
    n = 20_000
    a, b, c = np.array([[1.5, -0.7], [1.0, 0.0]]), np.array([1.0, 0.0]), np.array([0.5, 0.3])
    x = np.zeros(2)
    r = np.where(rng.random(n) < 0.5, -1.0, 1.0)
    e = rng.standard_normal(n)
    v = np.zeros(n)
    for k in range(1, n):
        v[k] = 0.9 * v[k - 1] + 0.3 * e[k]
    u = np.zeros(n)
    y = np.zeros(n)
    integ = 0.0
    for k in range(n):
        y[k] = c @ x + v[k]
        err = r[k] - y[k]
        integ += err
        u[k] = 0.2 * err + 0.05 * integ
        x = a @ x + b * u[k]
    # Plant (order 2) and AR(1) noise: the innovation model has order 3.
    truth = np.linalg.eigvals(a)

    def pole_error(fit: lifted.SubspaceFit) -> float:
        p = np.linalg.eigvals(np.asarray(fit.model.A))
        return max(min(abs(q - t) for q in p) for t in truth)

    fit = lifted.pbsid(u, y, order=3)
    assert isinstance(fit, lifted.SubspaceFit) and fit.method == "pbsid"
    # Measured 0.0027 (PBSID) against 0.063 (N4SID, biased by the feedback).
    assert pole_error(fit) < 0.01
    assert pole_error(lifted.n4sid(u, y, order=3)) > 0.03
    assert fit.model.kalman_gain is not None
    ss = lifted.pbsid(u, y, "ssarx", order=3)
    assert ss.method == "ssarx" and pole_error(ss) < 0.01
    with pytest.raises(lifted.ArgumentError, match="variant"):
        lifted.pbsid(u, y, "parsim", order=3)


def test_pbsid_identifies_a_multirate_closed_loop_without_the_reference() -> None:
    """Issue 46: the output measured every 4 samples (NaN between), a PI
    loop on the latest measurement, the reference not given. ``method="pbsid"``
    on :func:`lifted.multirate` takes the multirate prediction-error route
    (refused before); its poles
    are near the plant's (the Rust tests check the accuracy and the 1/sqrt(N)
    decay)."""
    rng = np.random.default_rng(46)
    n, period = 20_000, 4
    a, b, c = np.array([[1.5, -0.7], [1.0, 0.0]]), np.array([0.1, 0.0]), np.array([0.5, 0.3])
    x = np.zeros(2)
    level, held, integ = 1.0, 0.0, 0.0
    u = np.zeros(n)
    y = np.full(n, np.nan)
    for k in range(n):
        if rng.random() < 0.02:
            level = -level
        if k % period == 0:
            held = c @ x + 0.02 * rng.standard_normal()
            y[k] = held
        err = level - held
        u[k] = 0.2 * err + 0.05 * integ
        integ += err
        x = a @ x + b * u[k]
    fit = lifted.multirate(u, y, [period], method="pbsid", order=2)
    assert fit.diagnostics["route"].startswith("multirate prediction error")
    # NaN at every instant but every fourth follows one period: identify and
    # pbsid read the record as multirate, as the command line reads empty
    # cells, and give the same model.
    same = lifted.identify(u, y, method="pbsid", order=2)
    assert same.diagnostics["route"] == fit.diagnostics["route"]
    np.testing.assert_allclose(np.asarray(same.model.A), np.asarray(fit.fast.A), atol=1e-12)
    assert lifted.pbsid(u, y, order=2).diagnostics["output_periods"] == [period]
    assert fit.method == "pbsid" and fit.fast.kalman_gain is not None
    truth = np.linalg.eigvals(a)
    p = np.linalg.eigvals(np.asarray(fit.fast.A))
    # Measured 0.0010 (the poles are 0.75 +- 0.37j); the bound 20x that.
    err = max(min(abs(q - t) for q in p) for t in truth)
    assert err < 0.02, err


def _first_order_record(
    seed: int, n: int, *, pole: float, gain: float, noise: float
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """x+ = pole x + gain u, y = x + noise e under a random binary u (seeded)."""
    rng = np.random.default_rng(seed)
    u = np.where(rng.random(n) < 0.5, -1.0, 1.0)
    y = np.zeros(n)
    x = 0.0
    for k in range(n):
        y[k] = x + noise * rng.standard_normal()
        x = pole * x + gain * u[k]
    return u, y


def test_gain_stop_share_and_integrator_tolerance_reach_the_workflow() -> None:
    """The keywords of ``lifted identify --gain-stop-share`` and
    ``--integrator-tolerance`` (issues 46 and 47): recorded in the
    diagnostics as the command records them; a negative value is refused
    naming the keyword."""
    n = 2000
    u, y = _first_order_record(3, n, pole=0.9, gain=0.1, noise=0.01)
    fit = lifted.identify(u, y, order=1, gain_stop_share=0.0, integrator_tolerance=1e-3)
    assert fit.diagnostics["integrators"]["tolerance"] == 1e-3
    assert "30 iterations" in fit.diagnostics["kalman_gain_route"]["stop"]
    default = lifted.identify(u, y, order=1)
    assert default.diagnostics["integrators"]["tolerance"] == pytest.approx(2 / n)
    with pytest.raises(lifted.ArgumentError, match="gain_stop_share"):
        lifted.identify(u, y, order=1, gain_stop_share=-1.0)
    with pytest.raises(lifted.ArgumentError, match="integrator_tolerance"):
        lifted.identify(u, y, order=1, integrator_tolerance=-1.0)
    mr = np.where(np.arange(n) % 3 == 0, y, np.nan)
    slow = lifted.multirate(u, mr, [3], order=1, integrator_tolerance=1e-3)
    assert slow.diagnostics["integrators"]["tolerance"] == 1e-3


def test_gain_covariance_start_reaches_the_workflow() -> None:
    """``gain_covariance_start`` as ``lifted identify
    --gain-covariance-start``: the covariance route by default (its BFGS
    iterations recorded, no Gauss-Newton factor), Levenberg-Marquardt alone
    with False; both end below the best start's cost and near each other."""
    u, y = _first_order_record(5, 4000, pole=0.9, gain=0.1, noise=0.05)
    default = lifted.identify(u, y, order=2, refine="none")
    route = default.diagnostics["kalman_gain_route"]
    lm = lifted.identify(u, y, order=2, refine="none", gain_covariance_start=False)
    before = lm.diagnostics["kalman_gain_route"]
    assert before.get("covariance_iterations") is None
    starts = [route[k] for k in ("riccati_cost", "regression_cost", "zero_cost") if route[k] is not None]
    assert route["final_cost"] <= min(starts)
    if "minimisation" in route["used"]:
        assert route["covariance_iterations"] is not None and route["factors"] == 0
    assert route["final_cost"] == pytest.approx(before["final_cost"], rel=1e-3)
    with pytest.raises(TypeError):
        lifted.identify(u, y, order=2, gain_covariance_start="yes")  # type: ignore[arg-type]


def test_validate_leaves_out_a_gain_estimated_at_other_output_periods() -> None:
    """The command line's validation policy (issue 48): a multirate model's
    Kalman gain, estimated on the slow samples, is left out on a full-rate
    record (no prediction fits, the simulation error tested) and the result
    says why; on a record sampled as it was identified the gain is used. The
    model keeps the periods through its JSON (pickle) round trip."""
    n = 3000
    u, y = _first_order_record(8, n, pole=0.85, gain=0.2, noise=0.02)
    slow = np.where(np.arange(n) % 3 == 0, y, np.nan)
    fit = lifted.multirate(u, slow, [3], order=1)
    model = fit.fast
    assert model.kalman_gain is not None
    full = lifted.validate(model, u, y)
    assert full.gain_note is not None and "[3]" in full.gain_note
    assert all(np.isnan(f) for f in full.outputs[0].prediction_fits)
    assert full.residual == "simulation"
    same = lifted.validate(model, u, slow, periods=[3])
    assert same.gain_note is None
    again = lifted.StateSpace.from_json(model.to_json())
    assert lifted.validate(again, u, y).gain_note == full.gain_note


def test_refine_check_reaches_the_held_out_judge() -> None:
    """``refine_check`` (``lifted identify --refine-check``, issue 48): the
    rule that tells the refinement and the subspace model apart on the
    held-out blocks is a parameter, recorded in the judge's rule; a bad
    rule is refused naming the keyword."""
    u, y = _first_order_record(5, 2000, pole=0.9, gain=0.1, noise=0.05)
    fit = lifted.identify(u, y, order=2, refine="pem", refine_check="t:0.95")
    rule = fit.diagnostics["refinement_judge"]["rule"]
    assert "paired t-test" in rule, rule
    default = lifted.identify(u, y, order=2, refine="pem")
    assert "sign test" in default.diagnostics["refinement_judge"]["rule"]
    margin = lifted.identify(u, y, order=2, refine="pem", refine_check="margin:3")
    assert "3 points apart" in margin.diagnostics["refinement_judge"]["rule"]
    for bad in ("t:1.5", "margin:-1", "median"):
        with pytest.raises(lifted.ArgumentError, match="refine_check"):
            lifted.identify(u, y, order=2, refine_check=bad)


def test_selection_policy_is_a_keyword() -> None:
    """``selection`` (``lifted identify --stable-tries`` … ``--failed-fold``,
    issue 48): the automatic order's rules are parameters, recorded in
    ``diagnostics["selection_policy"]``; unknown keys, wrong types and
    values out of range are refused naming them."""
    u, y = _first_order_record(6, 1500, pole=0.9, gain=0.1, noise=0.05)
    fit = lifted.identify(u, y, refine="none", selection={"stable_tries": 2, "failed_fold": -50})
    policy = fit.diagnostics["selection_policy"]
    assert policy["stable_tries"] == 2 and policy["failed_fold"] == -50.0
    assert policy["shortlist"] == 3 and policy["tolerance"] == 0.5
    default = lifted.identify(u, y, refine="none")
    assert default.diagnostics["selection_policy"]["failed_fold"] == -100.0
    with pytest.raises(lifted.ArgumentError, match="unknown"):
        lifted.identify(u, y, selection={"stable_trys": 2})
    with pytest.raises(lifted.ArgumentError, match="bool"):
        lifted.identify(u, y, selection={"shortlist": True})
    with pytest.raises(lifted.ArgumentError, match="failed_fold"):
        lifted.identify(u, y, selection={"failed_fold": 5})


def test_budgets_are_a_keyword() -> None:
    """``budgets`` (``lifted identify --budget NAME=VALUE``, issue 48): the
    default route's work budgets are parameters, recorded in
    ``diagnostics["budgets"]``; under lowered refinement budgets the default
    does not refine; unknown names, wrong types and bad values are refused
    naming them."""
    u, y = _first_order_record(6, 1500, pole=0.9, gain=0.1, noise=0.05)
    default = lifted.identify(u, y, order=1)
    assert default.diagnostics["budgets"]["auto_refine_samples"] == 10000
    assert default.diagnostics["refinement_decision"].startswith("refined")
    tight = lifted.identify(
        u, y, order=1, budgets={"auto_refine_samples": 100, "auto_refine_work": 1.0}
    )
    assert tight.diagnostics["budgets"]["auto_refine_samples"] == 100
    assert tight.diagnostics["refinement_decision"].startswith("not refined")
    with pytest.raises(lifted.ArgumentError, match="auto_refine_work"):
        lifted.identify(u, y, budgets={"auto_refine_wrok": 1.0})
    with pytest.raises(lifted.ArgumentError, match="bool"):
        lifted.identify(u, y, budgets={"gain_check_samples": True})
    with pytest.raises(lifted.ArgumentError, match="refine_check_work"):
        lifted.identify(u, y, budgets={"refine_check_work": -1.0})


def test_a_plan_reproduces_its_model(tmp_path: pathlib.Path) -> None:
    """``plan`` (``lifted identify --plan``, issue 48): a fit, its diagnostics,
    a model file written by the command line or a dict of the options give
    the same model bit for bit on the same record; keywords beside a plan
    and unknown options are refused naming them."""
    u, y = _first_order_record(6, 1500, pole=0.9, gain=0.1, noise=0.05)
    first = lifted.identify(
        u, y, order=2, horizon=8, refine="pem", budgets={"gain_check_minimise_work": 1e9}
    )
    options = first.diagnostics["options"]
    for plan in (first, first.diagnostics, options, {"options": options}):
        again = lifted.identify(u, y, plan=plan)
        for k in ("A", "B", "C", "D"):
            np.testing.assert_array_equal(
                np.asarray(getattr(again.model, k)), np.asarray(getattr(first.model, k))
            )
        np.testing.assert_array_equal(
            np.asarray(again.model.kalman_gain), np.asarray(first.model.kalman_gain)
        )
    path = tmp_path / "plan.json"
    path.write_text(json.dumps({"options": options}))
    assert lifted.identify(u, y, plan=str(path)).diagnostics["options"] == options
    with pytest.raises(lifted.ArgumentError, match="order"):
        lifted.identify(u, y, order=3, plan=first)
    with pytest.raises(lifted.ArgumentError, match="identification.ordr"):
        lifted.identify(u, y, plan={"identification": {"ordr": 2}})


def test_a_command_line_model_is_made_again_in_python(tmp_path: pathlib.Path) -> None:
    """The plan crosses front ends: ``lifted identify`` with options away
    from the defaults writes a model file; ``identify(u, y, plan=that file)``
    on the same samples gives the same model bit for bit."""
    u, y = _first_order_record(8, 1200, pole=0.85, gain=0.2, noise=0.05)
    data = tmp_path / "r.csv"
    np.savetxt(data, np.column_stack([np.ravel(u), np.ravel(y)]), delimiter=",", header="u,y",
               comments="", fmt="%.17g")
    out = tmp_path / "m.json"
    subprocess.run(
        [str(cli()), "identify", "--data", str(data), "--inputs", "u", "--outputs", "y",
         "--ts", "1", "--order", "2", "--horizon", "7", "--refine", "pem", "--out", str(out)],
        check=True, capture_output=True,
    )
    model = json.loads(out.read_text())
    fit = lifted.identify(u, y, plan=str(out))
    np.testing.assert_array_equal(np.asarray(fit.model.A), np.array(model["a"]))
    np.testing.assert_array_equal(np.asarray(fit.model.C), np.array(model["c"]))
    np.testing.assert_array_equal(
        np.asarray(fit.model.kalman_gain), np.array(model["kalman_gain"])
    )
