"""ARX beside SIPPY (issue 49): time and parameter error on simulated records
with known truth, measured in one run on this machine.

Not part of the test suite. Cases (seeded, numpy):

* SISO ARX (1 - 1.5 q^-1 + 0.7 q^-2) y = q^-1 (1 + 0.5 q^-1) u + e, white u
  (sd 1) and e (sd 0.3), N samples: both tools estimate [na nb nk] = [2 2 1]
  (parameter error ||theta_hat - theta|| against the truth) and [10 10 1]
  (time only);
* 2x2 ARX with coupled A (lifted only at 1e6: SIPPY's ARX has a diagonal A and
  builds its regressors in a Python loop), [na nb nk] = [10 10 1]: the whole
  `lifted identify` run against its own read phase (`--profile`).

lifted runs as the command line on a .npy file (`lifted identify --method arx
--orders ...`: process start and reading the file included, best of
`--repeats` runs) and, when the `lifted` Python package is importable, as
`lifted.arx(u, y, orders=...)` on the arrays (best of `--repeats`, after a
warm-up call); SIPPY
(sippy-unipi `system_identification(y, u, 'ARX', ARX_orders=[na, nb, nk - 1])`:
its delay theta is nk - 1) on the arrays in memory (its reading not counted;
one warm-up call first).

    python benches/peers/arx.py --cli target/release/lifted [--sizes 1e4,1e5]
        [--big 1e6] [--json out.json]
"""

import argparse
import json
import os
import subprocess
import tempfile
import time

import numpy as np

A1 = [1.0, -1.5, 0.7]
B1 = [1.0, 0.5]
TRUTH = np.array([-1.5, 0.7, 1.0, 0.5])


def siso(n, seed):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(n)
    e = 0.3 * rng.standard_normal(n)
    y = np.zeros(n)
    for t in range(n):
        v = e[t]
        if t >= 1:
            v += 1.5 * y[t - 1] + u[t - 1]
        if t >= 2:
            v += -0.7 * y[t - 2] + 0.5 * u[t - 2]
        y[t] = v
    return u[:, None], y[:, None]


def mimo(n, seed):
    """2x2 ARX, A = [[1 - 0.8q + 0.15q^2, 0.2q], [-0.1q, 1 - 0.6q]] (q = q^-1),
    B = [[q(1 + 0.4q), 0.3q^2], [0.5q, q(0.8 - 0.2q)]]."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((n, 2))
    e = 0.1 * rng.standard_normal((n, 2))
    y = np.zeros((n, 2))
    for t in range(n):
        y1, y2 = e[t]
        if t >= 1:
            y1 += 0.8 * y[t - 1, 0] - 0.2 * y[t - 1, 1] + u[t - 1, 0]
            y2 += 0.1 * y[t - 1, 0] + 0.6 * y[t - 1, 1] + 0.5 * u[t - 1, 0] + 0.8 * u[t - 1, 1]
        if t >= 2:
            y1 += -0.15 * y[t - 2, 0] + 0.4 * u[t - 2, 0] + 0.3 * u[t - 2, 1]
            y2 += -0.2 * u[t - 2, 1]
        y[t] = (y1, y2)
    return u, y


def run_lifted(cli, path, columns, inputs, outputs, orders, repeats, profile=False):
    out = path + ".json"
    cmd = [cli, "identify", "--method", "arx", "--orders", " ".join(map(str, orders)),
           "--data", path, "--columns", columns, "--inputs", inputs, "--outputs", outputs,
           "--ts", "1", "--out", out]
    if profile:
        cmd.append("--profile")
    best, text = float("inf"), ""
    for _ in range(repeats):
        t = time.perf_counter()
        r = subprocess.run(cmd, capture_output=True, text=True, check=True)
        best = min(best, time.perf_counter() - t)
        text = r.stdout
    with open(out) as f:
        model = json.load(f)
    return best, model, text


def read_phase(text):
    for line in text.splitlines():
        if line.startswith("read "):
            return float(line.split()[1])
    return float("nan")


def run_inprocess(u, y, orders, repeats):
    """lifted's Python package on the arrays (best of `repeats`), or None."""
    try:
        import lifted
    except ImportError:
        return None
    lifted.arx(u[:100], y[:100], orders=[1, 1, 1])  # warm-up (import, first call)
    best = float("inf")
    for _ in range(repeats):
        t = time.perf_counter()
        lifted.arx(u, y, orders=orders)
        best = min(best, time.perf_counter() - t)
    return best


def run_sippy(u, y, orders):
    try:
        from sippy_unipi import system_identification
    except ImportError:
        return None, None
    na, nb, nk = orders
    # Warm-up: the first call imports and compiles what SIPPY uses.
    system_identification(y[:200].T, u[:200].T, "ARX", ARX_orders=[1, 1, 0], tsample=1.0)
    t = time.perf_counter()
    s = system_identification(y.T, u.T, "ARX", ARX_orders=[na, nb, nk - 1], tsample=1.0)
    dt = time.perf_counter() - t
    den = np.asarray(s.DENOMINATOR[0][0], dtype=float).ravel()
    num = np.asarray(s.NUMERATOR[0][0], dtype=float).ravel()
    # DEN = [1, a1, ..., a_na] (descending z powers, same numbers as q^-1
    # ascending); NUM has nk - 1 leading zeros then b0 ... (lag 1 first).
    theta = np.concatenate([den[1:na + 1], num[nk - 1:nk - 1 + nb]])
    return dt, theta


def lifted_theta(model):
    p = model["polynomial"]
    return np.concatenate([np.asarray(p["a"][0][0][1:]), np.asarray(p["b"][0][0])])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cli", required=True)
    ap.add_argument("--sizes", default="1e4,1e5")
    ap.add_argument("--big", default="1e6", help="2x2 record length ('' to skip)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json")
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as d:
        for n in [int(float(s)) for s in args.sizes.split(",") if s]:
            u, y = siso(n, 1)
            path = os.path.join(d, f"siso{n}.npy")
            np.save(path, np.hstack([u, y]))
            for orders in ([2, 2, 1], [10, 10, 1]):
                tl, model, _ = run_lifted(args.cli, path, "u1,y1", "u1", "y1", orders,
                                          args.repeats)
                ts, theta_s = run_sippy(u, y, orders)
                tp = run_inprocess(u, y, orders, args.repeats)
                row = {"case": "siso", "n": n, "orders": orders, "lifted_cli_s": tl,
                       "lifted_python_s": tp, "sippy_s": ts,
                       "speedup_cli": (ts / tl) if ts else None,
                       "speedup_python": (ts / tp) if ts and tp else None}
                if orders == [2, 2, 1]:
                    row["lifted_error"] = float(np.linalg.norm(lifted_theta(model) - TRUTH))
                    if theta_s is not None:
                        row["sippy_error"] = float(np.linalg.norm(theta_s - TRUTH))
                rows.append(row)
                print(json.dumps(row))
        if args.big:
            n = int(float(args.big))
            u, y = mimo(n, 2)
            path = os.path.join(d, f"mimo{n}.npy")
            np.save(path, np.hstack([u, y]))
            tl, _, text = run_lifted(args.cli, path, "u1,u2,y1,y2", "u1,u2", "y1,y2",
                                     [10, 10, 1], args.repeats, profile=True)
            row = {"case": "2x2", "n": n, "orders": [10, 10, 1], "lifted_s": tl,
                   "read_s": read_phase(text), "whole_over_read": tl / read_phase(text)}
            rows.append(row)
            print(json.dumps(row))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
