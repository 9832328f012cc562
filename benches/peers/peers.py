#!/usr/bin/env python3
"""Peer comparison: SIPPY (sippy-unipi) N4SID, nfoursid and lifted on the same data.

Run through ``benches/peers/run.sh`` (it builds the venv and the lifted binary).
Not part of the test suite.

Data recipe (identical for every tool, written once per N to CSV):
  * true system: 2 inputs, 2 outputs, order 4, discrete, sample time 1,
    A = blockdiag([[0.9, 0.2], [-0.2, 0.9]], 0.7, -0.5),
    B = [[1, 0], [0, 1], [1, 0.5], [0.3, 1]],
    C = [[1, 0, 1, 0], [0, 1, 0, 1]], D = 0;
  * input: independent random binary signals +-1,
    numpy.random.default_rng(SEED).choice([-1.0, 1.0], size=(N, 2));
  * output: the exact response from x0 = 0 (scipy.signal.lfilter of each
    input-output transfer function) plus white Gaussian noise of standard
    deviation 0.1 from the same generator (rng.normal(0, 0.1, (N, 2)));
  * CSV columns u1,u2,y1,y2, one row per sample, header line, %.17g.
Every tool identifies order 4 with 20 block rows (past = future = 20).

Measured per tool and N: identification time (inside the process, CSV parsing
excluded), wall time and peak resident memory of the whole process
(/usr/bin/time -v, includes the interpreter and the data), and the relative
frequency-response error sqrt(sum_w |G^(w) - G(w)|_F^2 / sum_w |G(w)|_F^2)
on 256 frequencies in [0, pi] against the true system.
"""
import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

SEED = 20261121
ORDER = 4
BLOCK_ROWS = 20


def true_system():
    a = np.zeros((4, 4))
    a[:2, :2] = [[0.9, 0.2], [-0.2, 0.9]]
    a[2, 2] = 0.7
    a[3, 3] = -0.5
    b = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 0.5], [0.3, 1.0]])
    c = np.array([[1.0, 0.0, 1.0, 0.0], [0.0, 1.0, 0.0, 1.0]])
    d = np.zeros((2, 2))
    return a, b, c, d


def simulate(n):
    """The N-by-4 record [u1 u2 y1 y2] of the recipe above (seed SEED)."""
    from scipy import signal

    a, b, c, d = true_system()
    rng = np.random.default_rng(SEED)
    u = rng.choice([-1.0, 1.0], size=(n, 2))
    y = np.zeros((n, 2))
    for j in range(2):
        num, den = signal.ss2tf(a, b, c, d, input=j)
        for i in range(2):
            y[:, i] += signal.lfilter(num[i], den, u[:, j])
    y += rng.normal(0.0, 0.1, size=(n, 2))
    return np.hstack([u, y])


def write_csv(data, path):
    """CSV with header u1,u2,y1,y2 and %.17g values (round-trips float64)."""
    np.savetxt(path, data, delimiter=",", header="u1,u2,y1,y2", comments="", fmt="%.17g")


def generate(n, path):
    write_csv(simulate(n), path)


def freq_error(model):
    a0, b0, c0, d0 = true_system()
    a, b, c, d = (np.array(model[k], dtype=float) for k in ("a", "b", "c", "d"))
    num = den = 0.0
    for w in np.linspace(0.0, np.pi, 256):
        z = np.exp(1j * w)
        g0 = c0 @ np.linalg.solve(z * np.eye(4) - a0, b0) + d0
        g = c @ np.linalg.solve(z * np.eye(a.shape[0]) - a, b) + d
        num += np.linalg.norm(g - g0) ** 2
        den += np.linalg.norm(g0) ** 2
    return float(np.sqrt(num / den))


def load_csv(path):
    import pandas as pd

    df = pd.read_csv(path)
    return df[["u1", "u2"]].to_numpy(), df[["y1", "y2"]].to_numpy()


def run_sippy(path):
    from sippy_unipi import OLSims_methods  # noqa: F401  (imported lazily by SIPPY: not timed)
    from sippy_unipi import system_identification

    u, y = load_csv(path)
    t0 = time.perf_counter()
    sys_id = system_identification(y.T, u.T, "N4SID", SS_f=BLOCK_ROWS, SS_p=BLOCK_ROWS,
                                   SS_fixed_order=ORDER)
    t = time.perf_counter() - t0
    return {"identify_s": t, "a": sys_id.A.tolist(), "b": sys_id.B.tolist(),
            "c": sys_id.C.tolist(), "d": sys_id.D.tolist()}


def run_nfoursid(path):
    import pandas as pd
    from nfoursid.nfoursid import NFourSID

    df = pd.read_csv(path)
    t0 = time.perf_counter()
    n4 = NFourSID(df, output_columns=["y1", "y2"], input_columns=["u1", "u2"],
                  num_block_rows=BLOCK_ROWS)
    n4.subspace_identification()
    ss, _ = n4.system_identification(rank=ORDER)
    t = time.perf_counter() - t0
    return {"identify_s": t, "a": ss.a.tolist(), "b": ss.b.tolist(), "c": ss.c.tolist(),
            "d": ss.d.tolist()}


def cli_model(doc):
    """(A, B, C, D) from a lifted model file (matrices as rows, or nalgebra's
    column-major {data, nrows, ncols} / [data, nrows, ncols])."""
    def mat(v):
        if isinstance(v, dict):
            return np.array(v["data"], dtype=float).reshape(v["ncols"], v["nrows"]).T
        if isinstance(v, list) and len(v) == 3 and isinstance(v[0], list) and \
                isinstance(v[1], int):
            return np.array(v[0], dtype=float).reshape(v[2], v[1]).T
        return np.atleast_2d(np.array(v, dtype=float))
    return {k: mat(doc[k]).tolist() for k in ("a", "b", "c", "d")}


def timed(cmd, timeout, env=None):
    """Runs cmd under /usr/bin/time -v (with environment `env`, default this
    process's); returns (stdout, stderr, wall s, peak MB, status), stdout None
    when the run failed or timed out."""
    t0 = time.perf_counter()
    try:
        p = subprocess.run(["/usr/bin/time", "-v"] + cmd, capture_output=True, text=True,
                           timeout=timeout, env=env)
    except subprocess.TimeoutExpired:
        return None, "", time.perf_counter() - t0, float("nan"), f"timeout {timeout:.0f} s"
    wall = time.perf_counter() - t0
    peak = float("nan")
    for line in p.stderr.splitlines():
        if "Maximum resident set size" in line:
            peak = int(line.split()[-1]) / 1024.0
    if p.returncode != 0:
        # The tool's own message, not the statistics of /usr/bin/time.
        lines = [x for x in p.stderr.strip().splitlines()
                 if x.strip() and not x.startswith(("\t", "Command exited"))]
        return None, p.stderr, wall, peak, f"exit {p.returncode}: {lines[0] if lines else ''}"
    return p.stdout, p.stderr, wall, peak, "ok"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--run", choices=["sippy", "nfoursid"], help=argparse.SUPPRESS)
    ap.add_argument("--csv", help=argparse.SUPPRESS)
    ap.add_argument("--lifted", help="path of the peer_lifted example binary")
    ap.add_argument("--cli", help="path of the lifted CLI binary (optional)")
    ap.add_argument("--data-dir", default="benches/peers/data")
    ap.add_argument("--nfoursid-max", type=int, default=10_000,
                    help="largest N for nfoursid (it needs O(N^2) memory: OOM at 1e5)")
    ap.add_argument("--timeout", type=float, default=900.0)
    ap.add_argument("sizes", nargs="*", type=int, default=[10_000, 100_000, 1_000_000])
    args = ap.parse_args()
    if args.run:
        out = run_sippy(args.csv) if args.run == "sippy" else run_nfoursid(args.csv)
        print(json.dumps(out))
        return
    os.makedirs(args.data_dir, exist_ok=True)
    me = os.path.abspath(__file__)
    rows = []
    for n in args.sizes:
        path = os.path.join(args.data_dir, f"peers_{n}.csv")
        if not os.path.exists(path):
            generate(n, path)
        tools = [("lifted (stream, 1 thread)", [args.lifted, path, "--stream", "--threads", "1"]),
                 ("lifted (stream, 2 threads)", [args.lifted, path, "--stream", "--threads", "2"]),
                 ("lifted (in memory, auto)", [args.lifted, path]),
                 ("lifted (in memory, QR)", [args.lifted, path, "--compression", "qr"]),
                 ("SIPPY N4SID", [sys.executable, me, "--run", "sippy", "--csv", path])]
        if n <= args.nfoursid_max:
            tools.append(("nfoursid", [sys.executable, me, "--run", "nfoursid", "--csv", path]))
        cli_out = os.path.join(args.data_dir, f"cli_model_{n}.json")
        if args.cli:
            tools.append(("lifted CLI (whole run)",
                          [args.cli, "identify", "--method", "n4sid", "--data", path,
                           "--inputs", "u1,u2", "--outputs", "y1,y2", "--ts", "1",
                           "--order", str(ORDER), "--horizon", str(BLOCK_ROWS),
                           "--out", cli_out]))
        base = None
        for name, cmd in tools:
            out, _, wall, peak, status = timed(cmd, args.timeout)
            ident, err = float("nan"), float("nan")
            if out is not None and name.startswith("lifted CLI"):
                try:
                    with open(cli_out) as fh:
                        res = cli_model(json.load(fh))
                    err = freq_error(res)
                except (OSError, ValueError, KeyError, IndexError, TypeError) as e:
                    status = f"unreadable model file: {e}"
            elif out is not None:
                try:
                    res = json.loads(out.strip().splitlines()[-1])
                    ident = res.get("identify_s", float("nan"))
                    if "a" in res:
                        err = freq_error(res)
                except (ValueError, KeyError, IndexError) as e:
                    status = f"unreadable output: {e}"
            row = {"n": n, "tool": name, "identify_s": ident, "wall_s": wall, "peak_mb": peak,
                   "fr_error": err, "status": status}
            if base is None:
                base = row
            rows.append(row)
            print(json.dumps(row), file=sys.stderr, flush=True)
    print(f"| N | tool | identify (s) | x lifted | wall (s) | peak RSS (MB) | x lifted | FR error | status |")
    print("|---|---|---|---|---|---|---|---|---|")
    base = {}
    for r in rows:
        b = base.setdefault(r["n"], r)
        print(f"| {r['n']:.0e} | {r['tool']} | {r['identify_s']:.4g} | "
              f"{r['identify_s'] / b['identify_s']:.3g} | {r['wall_s']:.3g} | {r['peak_mb']:.1f} | "
              f"{r['peak_mb'] / b['peak_mb']:.3g} | {r['fr_error']:.2e} | {r['status']} |")


if __name__ == "__main__":
    main()
