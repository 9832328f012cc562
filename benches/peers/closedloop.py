"""Closed loop without an instrument (issue 27): lifted PBSID beside SIPPY PARSIM-K and
SIPPY N4SID on simulated closed loops and on the ball-and-beam record.

Not part of the test suite. Every tool gets the same data and is scored by this script.

Simulated loops (the reference r is NOT given to the estimators, only u and y):
* plants in innovations form x(t+1) = A x + B u + K e, y = C x + e: the output noise
  H(z) = C(zI - A)^-1 K + I is coloured (it shares the plant's poles), K the steady-state
  Kalman gain of the plant for process noise q I and unit measurement noise;
  - SISO, order 3: poles 0.9, 0.7 e^{+-0.6i}, q = 1;
  - 2x2, order 4: poles 0.95, 0.6, 0.8 e^{+-0.5i}, q = 10;
  (random B, C behind a random similarity, numpy seed 31 / 2024);
* a discrete PI controller u = M (kp eps + ki sum(eps)), eps = r - y, M = G(1)^-1
  (decoupling), kp = 0.3, ki = 0.05: the noise is fed back through the controller;
* r white with unit variance, e white with standard deviation 0.5; N samples.
Score: the relative frequency-response error of the plant model
  sqrt(sum_w ||G_est(w) - G(w)||_F^2 / sum_w ||G(w)||_F^2)
over 256 log-spaced frequencies in [1e-3, pi] rad/sample; the median over the seeds.

Tools: lifted (`$LIFTED_CLI identify --method pbsid --order n`, `--method ssarx`, and `--method n4sid
--order n --horizon 10` for reference), SIPPY (sippy-unipi) PARSIM-K and N4SID with
SS_fixed_order = n, SS_f = SS_p = 20, other options at SIPPY's defaults (D = 0).

Real record: DaISy ball-and-beam (closed loop, unstable plant), as benches/peers/realdata.py
loads and scores it (halves, estimation means removed, validation simulation fit with x0
by least squares) except that models with spectral radius >= 1 are scored too (the plant
is an integrator: every tool's model is unstable, and realdata.py would report none).

Usage (from the repository root):
  python benches/peers/closedloop.py --lifted-cli PATH [--n 10000] [--seeds 5] [--json out]
"""

import argparse
import json
import os
import sys
import tempfile
import time
import warnings

import numpy as np
import scipy.linalg as sla

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import realdata as R  # noqa: E402

warnings.filterwarnings("ignore")


def plant(seed, real, pairs, nu, ny):
    rng = np.random.default_rng(seed)
    n = len(real) + 2 * len(pairs)
    a = np.zeros((n, n))
    for i, p in enumerate(real):
        a[i, i] = p
    for k, (r, th) in enumerate(pairs):
        i = len(real) + 2 * k
        a[i:i + 2, i:i + 2] = r * np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    t = rng.standard_normal((n, n)) + 3 * np.eye(n)
    ti = np.linalg.inv(t)
    return t @ a @ ti, t @ rng.standard_normal((n, nu)), rng.standard_normal((ny, n)) @ ti


def kalman_gain(a, c, q):
    p = sla.solve_discrete_are(a.T, c.T, q * np.eye(a.shape[0]), np.eye(c.shape[0]))
    return a @ p @ c.T @ np.linalg.inv(c @ p @ c.T + np.eye(c.shape[0]))


def loops():
    out = []
    for name, seed, real, pairs, nu, ny, q in [
            ("SISO order 3", 31, [0.9], [(0.7, 0.6)], 1, 1, 1.0),
            ("2x2 order 4", 2024, [0.95, 0.6], [(0.8, 0.5)], 2, 2, 10.0)]:
        a, b, c = plant(seed, real, pairs, nu, ny)
        k = kalman_gain(a, c, q)
        g1 = c @ np.linalg.solve(np.eye(a.shape[0]) - a, b)
        out.append(dict(name=name, a=a, b=b, c=c, k=k, m=np.linalg.inv(g1), kp=0.3, ki=0.05))
    return out


def simulate(sys_, n, seed, r_sd=1.0, e_sd=0.5):
    a, b, c, k, m = sys_["a"], sys_["b"], sys_["c"], sys_["k"], sys_["m"]
    nu, ny = b.shape[1], c.shape[0]
    rng = np.random.default_rng(1000 + seed)
    r = r_sd * rng.standard_normal((n, nu))
    e = e_sd * rng.standard_normal((n, ny))
    x = np.zeros(a.shape[0])
    s = np.zeros(ny)
    u = np.zeros((n, nu))
    y = np.zeros((n, ny))
    for t in range(n):
        y[t] = c @ x + e[t]
        eps = r[t] - y[t]
        u[t] = m @ (sys_["kp"] * eps + sys_["ki"] * s)
        s += eps
        x = a @ x + b @ u[t] + k @ e[t]
    return u, y


def freqresp(a, b, c, d, w):
    n = a.shape[0]
    return np.array([c @ np.linalg.solve(np.exp(1j * x) * np.eye(n) - a, b) + d for x in w])


def fr_error(model, sys_):
    w = np.logspace(-3, np.log10(np.pi), 256)
    a, b, c, d = (np.atleast_2d(np.asarray(x, dtype=float)) for x in model)
    g = freqresp(sys_["a"], sys_["b"], sys_["c"], np.zeros((sys_["c"].shape[0], sys_["b"].shape[1])), w)
    ge = freqresp(a, b, c, d, w)
    return float(np.sqrt(np.sum(np.abs(ge - g) ** 2) / np.sum(np.abs(g) ** 2)))


def lifted(cli, workdir, u, y, method, order, extra=()):
    csv = os.path.join(workdir, "est.csv")
    R.write_csv(csv, u, y, 1.0)
    r = R.run_lifted(cli, workdir, csv, u.shape[1], y.shape[1], method, order, list(extra), 600, u, y)
    if r.get("status") not in ("ok", "unstable"):
        return None, r
    out = os.path.join(workdir, [f for f in os.listdir(workdir) if f.startswith(f"m_{method}_{order}")][0])
    mats, diag, _ = R.read_model(out)
    os.remove(out)
    return mats, r


def sippy(u, y, method, order, horizon=20):
    from sippy_unipi import system_identification
    s = system_identification(y.T, u.T, method, SS_fixed_order=order, SS_f=horizon, SS_p=horizon)
    return [np.asarray(x) for x in (s.A, s.B, s.C, s.D)]


def simulated(cli, n, seeds):
    rows = []
    for sys_ in loops():
        order = sys_["a"].shape[0]
        errs = {k: [] for k in ("lifted PBSID", "lifted SSARX", "lifted N4SID", "SIPPY PARSIM-K",
                                "SIPPY N4SID")}
        secs = {k: 0.0 for k in errs}
        for seed in range(seeds):
            u, y = simulate(sys_, n, seed)
            with tempfile.TemporaryDirectory() as wd:
                for key, method, extra in [("lifted PBSID", "pbsid", ()),
                                           ("lifted SSARX", "ssarx", ()),
                                           ("lifted N4SID", "n4sid", ("--horizon", "10"))]:
                    t0 = time.perf_counter()
                    mats, r = lifted(cli, wd, u, y, method, order, extra)
                    secs[key] += time.perf_counter() - t0
                    errs[key].append(fr_error(mats, sys_) if mats is not None else np.inf)
            for key, method in [("SIPPY PARSIM-K", "PARSIM-K"), ("SIPPY N4SID", "N4SID")]:
                t0 = time.perf_counter()
                try:
                    mats = sippy(u, y, method, order)
                    errs[key].append(fr_error(mats, sys_))
                except Exception:  # noqa: BLE001  a peer failure is a result
                    errs[key].append(np.inf)
                secs[key] += time.perf_counter() - t0
        row = {"loop": sys_["name"], "n": n, "seeds": seeds,
               "median_fr_error": {k: float(np.median(v)) for k, v in errs.items()},
               "fr_errors": errs, "seconds_per_run": {k: v / seeds for k, v in secs.items()}}
        print(json.dumps(row["median_fr_error"]), row["loop"], flush=True)
        rows.append(row)
    return rows


def ballbeam(cli, data_dir):
    recs = json.load(open(os.path.join(HERE, "realdata_records.json")))["records"]
    rec = [r for r in recs if r["name"] == "ballbeam"][0]
    (ue, ye, uv, yv), _ = R.load_record(rec, data_dir)
    R.spectral_radius = lambda a: 0.0  # score unstable models too (see the module docs)
    out = []
    for order in rec["orders"]:
        row = {"order": order}
        with tempfile.TemporaryDirectory() as wd:
            for key, method, extra in [("lifted PBSID", "pbsid", ()),
                                       ("lifted PBSID p=20", "pbsid", ("--horizon", "20")),
                                       ("lifted SSARX", "ssarx", ()),
                                       ("lifted N4SID", "n4sid", ())]:
                mats, r = lifted(cli, wd, ue, ye, method, order, extra)
                row[key] = R.score(mats, uv, yv)[0] if mats is not None else None
        for key, method in [("SIPPY PARSIM-K", "PARSIM-K"), ("SIPPY N4SID", "N4SID")]:
            row[key] = R.score(sippy(ue, ye, method, order), uv, yv)[0]
        print(json.dumps(row), flush=True)
        out.append(row)
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--lifted-cli", required=True)
    ap.add_argument("--n", type=int, default=10000)
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--data-dir", default=os.environ.get("REALDATA_DIR", "/work/realdata"))
    ap.add_argument("--json")
    args = ap.parse_args()
    res = {"simulated": simulated(args.lifted_cli, args.n, args.seeds)}
    if os.path.exists(os.path.join(args.data_dir, "ballbeam.dat")):
        res["ballbeam"] = ballbeam(args.lifted_cli, args.data_dir)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(res, f, indent=1)


if __name__ == "__main__":
    main()
