#!/usr/bin/env python3
"""Simulation throughput: lifted-sim against scipy, python-control, SLICOT and numpy.

Run through ``benches/peers/sim_run.sh`` (it builds the venv and the lifted
example). Not part of the test suite.

Case (crates/sim/benches/sim.rs, the lifted side is benches/examples/peer_sim.rs):
  * plant G: 6 states, 2 inputs, 2 outputs, discrete at T = 1, D = 0,
    A lower bidiagonal (diagonal 0.95 - 0.05 i, sub-diagonal 0.1),
    B[i, j] = 0.1 if i % 2 == j else 0.02, C[i, j] = 1 if j % 2 == i else 0.3;
  * decentralised PI pair K1(z) = (0.6 z - 0.5)/(z - 1) on (u1, y1),
    K2(z) = (0.4 z - 0.3)/(z - 1) on (u2, y2), negative feedback,
    u = r2 + K (r1 - y), y = G u + v;
  * output noise v_j = 0.1/(1 - 0.9 z^-1) e_j, e white with std 1;
  * r1 = r2 = r, r_j(k) = 1 if (k // 7 + j) % 3 == 0 else -1.

The peers simulate the whole loop as ONE discrete state-space model built here
by hand: state [x_G (6); x_K (2, PI integrators); s (2, noise filters)],
inputs w = [r1 (2); r2 (2); e (2)], outputs [y (2); u (2)] (10 states, 6
inputs, 4 outputs):
    v   = 0.9 s + 0.1 e,            s+  = 0.9 s + 0.1 e
    y   = C_G x_G + v
    u   = r2 + 0.1 x_K + D_K (r1 - y),  D_K = diag(0.6, 0.4)
    x_G+ = A_G x_G + B_G u,         x_K+ = x_K + (r1 - y)
(K_i(z) = b0 + (b0 + b1)/(z - 1), so C_K = diag(0.1, 0.1)).

Agreement (before any time counts): each peer simulates (a) the noise-free
loop (e = 0) and (b) the noisy loop driven by e recovered from lifted's
output noise v by the inverse filter e(k) = (v(k) - 0.9 v(k-1))/0.1 (exact
for any initial filter state; lifted starts its filter in stationarity), and
its [y; u] must match lifted's (CSV from peer_sim --csv) to a relative
max-abs error <= TOL.

Timing: best (and median) wall clock of k runs in this process, after one
untimed run. The machine may be shared, so at each N lifted runs (k runs per
variant, in its own process) just before and just after the peers, and its
figures pool both calls (2k runs); the two calls' best times are printed to
show the load drift. The timed region of a peer is what lifted's `simulate` does:
generate the white noise (numpy default_rng(1).standard_normal), assemble the
inputs and simulate; r is built outside the timing, as in lifted. Slow peers
get fewer repetitions or are skipped at a size when one run is predicted to
take longer than --budget seconds (said so in the output).
"""
import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

TOL = 1e-9
N_STATES = 10


def closed_loop():
    """(A, B, C, D) of the loop described in the module docstring."""
    ag = np.zeros((6, 6))
    for i in range(6):
        ag[i, i] = 0.95 - 0.05 * i
        if i >= 1:
            ag[i, i - 1] = 0.1
    bg = np.array([[0.1 if i % 2 == j else 0.02 for j in range(2)] for i in range(6)])
    cg = np.array([[1.0 if j % 2 == i else 0.3 for j in range(6)] for i in range(2)])
    dk = np.diag([0.6, 0.4])
    ck = np.diag([0.6 - 0.5, 0.4 - 0.3])
    i2 = np.eye(2)
    z2 = np.zeros((2, 2))
    # y = M_y [x_G; x_K; s] + N_y [r1; r2; e]
    my = np.hstack([cg, z2, 0.9 * i2])
    ny = np.hstack([z2, z2, 0.1 * i2])
    # e_loop = r1 - y
    me = -my
    ne = np.hstack([i2, z2, z2]) - ny
    # u = r2 + C_K x_K + D_K e_loop
    mu = np.hstack([np.zeros((2, 6)), ck, z2]) + dk @ me
    nu = np.hstack([z2, i2, z2]) + dk @ ne
    a = np.zeros((N_STATES, N_STATES))
    b = np.zeros((N_STATES, 6))
    a[:6, :6] = ag
    a[:6] += bg @ mu
    b[:6] = bg @ nu
    a[6:8, 6:8] = i2
    a[6:8] += me
    b[6:8] = ne
    a[8:, 8:] = 0.9 * i2
    b[8:, 4:] = 0.1 * i2
    c = np.vstack([my, mu])
    d = np.vstack([ny, nu])
    return a, b, c, d


def reference(n):
    k = np.arange(n)
    return np.stack([np.where((k // 7 + j) % 3 == 0, 1.0, -1.0) for j in range(2)], axis=1)


def inputs(r, e):
    return np.hstack([r, r, e])


# ---------------------------------------------------------------- the peers
# Each takes the system and the N x 6 input w and returns [y, u] as N x 4.


def peer_scipy(sys_, w):
    from scipy import signal

    a, b, c, d = sys_
    _, y, _ = signal.dlsim((a, b, c, d, 1.0), w)
    return y


def make_control(sys_):
    import control

    g = control.ss(*sys_, 1.0)

    def run(_sys, w):
        return control.forced_response(g, U=w.T).outputs.T

    return run


def peer_slycot(sys_, w):
    from slycot import tf01md

    a, b, c, d = sys_
    n = w.shape[0]
    _, y = tf01md(N_STATES, 6, 4, n, a, b, c, d, np.asfortranarray(w.T), np.zeros(N_STATES))
    return y.T


def peer_numpy(sys_, w):
    """Python loop over the state recursion only; B w and D w vectorised."""
    a, b, c, d = sys_
    n = w.shape[0]
    bw = w @ b.T
    x = np.empty((n, N_STATES))
    xk = np.zeros(N_STATES)
    for k in range(n):
        x[k] = xk
        xk = a @ xk + bw[k]
    return x @ c.T + w @ d.T


# ------------------------------------------------------------------ driver


def rel_err(y, ref):
    return float(np.max(np.abs(y - ref)) / np.max(np.abs(ref)))


def run_lifted(binary, sizes, reps, csv_dir):
    args = [binary, *[str(n) for n in sizes], "--reps", str(reps)]
    if csv_dir:
        args += ["--csv", csv_dir]
    out = subprocess.run(args, check=True, capture_output=True, text=True).stdout
    return json.loads(out)["results"]


def time_peer(fn, sys_, r, reps):
    def once():
        e = np.random.default_rng(1).standard_normal((r.shape[0], 2))
        return fn(sys_, inputs(r, e))

    once()
    times = []
    for _ in range(reps):
        t0 = time.perf_counter()
        once()
        times.append(time.perf_counter() - t0)
    return times


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sizes", nargs="*", type=float, default=[1e4, 1e5, 1e6])
    ap.add_argument("--lifted", required=True, help="target/release/examples/peer_sim")
    ap.add_argument("--data", default="benches/peers/data", help="CSV directory")
    ap.add_argument("--reps", type=int, default=7, help="timed runs of lifted and fast peers")
    ap.add_argument("--budget", type=float, default=60.0,
                    help="seconds one peer may spend timing one size (runs are cut to fit; "
                         "a size whose single run is predicted above it is skipped)")
    ap.add_argument("--json", help="write all results to this file")
    args = ap.parse_args()
    sizes = [int(n) for n in args.sizes]
    os.makedirs(args.data, exist_ok=True)

    import control
    import scipy
    try:
        import slycot
        slycot_info = f"slycot {slycot.__version__}, tf01md: {hasattr(slycot, 'tf01md')}"
    except ImportError:
        slycot = None
        slycot_info = "slycot not installed"
    info = {
        "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "nproc": os.cpu_count(),
        "load_before": os.getloadavg(),
        "versions": f"numpy {np.__version__}, scipy {scipy.__version__}, "
                    f"control {control.__version__}, {slycot_info}, python {sys.version.split()[0]}",
    }
    print(json.dumps(info))

    sys_ = closed_loop()
    poles = np.abs(np.linalg.eigvals(sys_[0]))
    print(f"closed loop: {N_STATES} states, spectral radius {poles.max():.6f}")

    peers = [("scipy.signal.dlsim", peer_scipy), ("control.forced_response", make_control(sys_))]
    if slycot is not None and hasattr(slycot, "tf01md"):
        peers.append(("slycot.tf01md (SLICOT TF01MD)", peer_slycot))
    peers.append(("numpy loop (state recursion only)", peer_numpy))

    rows = []
    per_sample = {}  # last measured seconds per sample of each peer
    lifted_calls = []
    for n in sizes:
        before = run_lifted(args.lifted, [n], args.reps, args.data)
        ref = np.loadtxt(os.path.join(args.data, f"sim_{n}.csv"), delimiter=",", skiprows=1)
        r = reference(n)
        w_clean = inputs(r, np.zeros((n, 2)))
        v = ref[:, 4:6]
        e_eff = (v - 0.9 * np.vstack([np.zeros((1, 2)), v[:-1]])) / 0.1
        w_noisy = inputs(r, e_eff)
        lifted_at = len(rows)
        # what every peer's timed region spends before simulating
        prep = sorted(time_peer(lambda _s, w: w, sys_, r, args.reps))
        rows.append({"n": n, "tool": "(numpy noise + input assembly, inside every peer's time)",
                     "best_s": prep[0], "median_s": float(np.median(prep)), "reps": args.reps,
                     "err_clean": None, "err_noisy": None})
        for name, fn in peers:
            predicted = per_sample.get(name, 0.0) * n
            if predicted > args.budget:
                rows.append({"n": n, "tool": name, "skipped": f"one run predicted {predicted:.0f} s > budget {args.budget:.0f} s"})
                print(f"N={n} {name}: skipped ({rows[-1]['skipped']})", flush=True)
                continue
            t0 = time.perf_counter()
            err_clean = rel_err(fn(sys_, w_clean), ref[:, 0:4])
            one = time.perf_counter() - t0
            err_noisy = rel_err(fn(sys_, w_noisy), ref[:, 6:10])
            row = {"n": n, "tool": name, "err_clean": err_clean, "err_noisy": err_noisy}
            if not (err_clean <= TOL and err_noisy <= TOL):
                row["skipped"] = f"disagrees with lifted (rel. error {err_clean:.2e} / {err_noisy:.2e} > {TOL:g})"
                rows.append(row)
                print(f"N={n} {name}: {row['skipped']}", flush=True)
                continue
            reps = max(1, min(args.reps, int(args.budget / max(one, 1e-9)) - 1))
            times = sorted(time_peer(fn, sys_, r, reps))
            per_sample[name] = times[0] / n
            row.update(best_s=times[0], median_s=float(np.median(times)), reps=reps)
            rows.append(row)
            print(f"N={n} {name}: best {times[0]:.4g} s ({n / times[0]:.3g} samples/s), "
                  f"agreement {err_clean:.1e} (noise-free) {err_noisy:.1e} (noisy)", flush=True)

        after = run_lifted(args.lifted, [n], args.reps, None)
        lifted_calls += [before, after]
        lifted_rows = []
        for a, b in zip(before, after):
            times = sorted(a["times_s"] + b["times_s"])
            lifted_rows.append({
                "n": n, "tool": f"lifted {a['method']}" + ("" if a["noise"] else " (noise-free)"),
                "best_s": times[0], "median_s": float(np.median(times)), "reps": len(times),
                "best_before_s": a["best_s"], "best_after_s": b["best_s"],
                "err_clean": None, "err_noisy": None})
        rows[lifted_at:lifted_at] = lifted_rows
    info["load_after"] = os.getloadavg()

    print()
    print(f"date {info['date']}  nproc {info['nproc']}  load before {info['load_before']}  "
          f"after {info['load_after']}")
    print(info["versions"])
    print()
    print("| N | tool | reps | best (s) | median (s) | samples/s (best) | peer time / lifted simulate | "
          "peer time / lifted simulate_into | agreement (noise-free / noisy) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for n in sizes:
        base = {row["tool"]: row["best_s"] for row in rows if row["n"] == n and "best_s" in row}
        for row in (x for x in rows if x["n"] == n):
            if "best_s" not in row:
                print(f"| {n:.0e} | {row['tool']} | | {row['skipped']} | | | | | |")
                continue
            agree = "" if row["err_clean"] is None else f"{row['err_clean']:.1e} / {row['err_noisy']:.1e}"
            ratio = ""
            if not row["tool"].startswith(("lifted", "(")):
                ratio = (f"{row['best_s'] / base['lifted simulate']:.3g} | "
                         f"{row['best_s'] / base['lifted simulate_into']:.3g}")
            else:
                ratio = " | "
            print(f"| {n:.0e} | {row['tool']} | {row['reps']} | {row['best_s']:.4g} | {row['median_s']:.4g} | "
                  f"{n / row['best_s']:.3g} | {ratio} | {agree} |")
    print()
    print("lifted best before / after the peers at each N (load drift):")
    for row in rows:
        if "best_before_s" in row:
            print(f"  N={row['n']:.0e} {row['tool']}: {row['best_before_s']:.4g} s / {row['best_after_s']:.4g} s")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"info": info, "rows": rows, "lifted_calls": lifted_calls}, f, indent=1)


if __name__ == "__main__":
    main()
