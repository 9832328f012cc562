#!/usr/bin/env python3
"""Check `lifted analyze`, `lifted bode --omega` and `lifted lqr` against
python-control (and slycot where it is installed). Not part of the test suite
and not a CI dependency.

Usage (from the repository root, after `cargo build --release -p lifted-cli`):
    python3 benches/peers/analyze_check.py [--lifted target/release/lifted]
Needs numpy, scipy and control (`pip install numpy scipy control`; slycot is
optional: without it python-control's H-infinity norm, Gramians and
transmission zeros of MIMO models fall back to scipy, and the MIMO zeros are
skipped).

For a fixed set of models (discrete and continuous, SISO and MIMO, one with
feedthrough, one unstable, seeded random ones) it compares:
  * poles, transmission zeros (matched as multisets), DC gain;
  * H2 norm (control.norm(sys, 2)), H-infinity norm (control.norm(sys, 'inf'))
    and sigma_max(G) at lifted's peak frequency against the norm;
  * Hankel singular values (control.hsvd, or from scipy's Lyapunov solvers);
  * magnitude and phase (mod 360 degrees) at given frequencies
    (control.frequency_response);
  * the LQR gain, the Riccati solution and the closed-loop poles
    (control.dlqr).
Relative tolerances: 1e-8 for everything solved by direct factorisations
(poles, DC gain, H2, Hankel values, frequency response, DARE), 1e-6 for the
H-infinity norm against python-control 1e-5 (its scipy method bisects to
a relative 1e-6 and returns the upper end; lifted's iteration stops within a
relative 2e-8), and for the H-infinity norm also sigma_max(G) at lifted's
peak frequency equal to the norm to 1e-8 and no frequency of a 20001-point
grid above it; 1e-6 for zeros (simple zeros only).
Prints one line per check and exits 1 if any fails.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

try:
    import control
except ImportError:  # pragma: no cover - the script's only requirement
    sys.exit("analyze_check.py needs python-control: pip install numpy scipy control")

try:
    import slycot  # noqa: F401

    HAVE_SLYCOT = True
except ImportError:
    HAVE_SLYCOT = False

FAILURES = []


def check(name, ok, detail=""):
    print(f"{'ok  ' if ok else 'FAIL'} {name} {detail}")
    if not ok:
        FAILURES.append(name)


def rel(a, b):
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    return float(np.max(np.abs(a - b)) / max(1.0, float(np.max(np.abs(b)))))


def match_roots(got, want, tol):
    """Greedy match of two multisets of complex numbers; the largest distance."""
    got = list(got)
    if len(got) != len(want):
        return float("inf")
    worst = 0.0
    for w in sorted(want, key=lambda z: (abs(z), z.real, z.imag)):
        k = int(np.argmin([abs(g - w) for g in got]))
        worst = max(worst, abs(got[k] - w) / max(1.0, abs(w)))
        got.pop(k)
    return worst


def models():
    rng = np.random.default_rng(20261126)
    out = {}
    out["siso_discrete"] = (
        np.array([[1.5, -0.7], [1.0, 0.0]]),
        np.array([[1.0], [0.0]]),
        np.array([[0.5, 0.3]]),
        np.array([[0.0]]),
        0.1,
    )
    out["siso_continuous_first_order"] = (
        np.array([[-0.1]]),
        np.array([[1.0]]),
        np.array([[0.2]]),
        np.array([[0.0]]),
        None,
    )
    out["continuous_feedthrough"] = (
        np.array([[-1.0, 2.0], [-2.0, -1.0]]),
        np.array([[1.0], [0.5]]),
        np.array([[1.0, 0.0]]),
        np.array([[0.5]]),
        None,
    )
    out["unstable_discrete"] = (
        np.array([[1.2, 0.0], [0.0, 0.5]]),
        np.array([[1.0], [1.0]]),
        np.array([[1.0, 1.0]]),
        np.array([[0.0]]),
        1.0,
    )
    for n, m, p, ts, name in [(4, 2, 2, 0.5, "mimo_discrete"), (5, 2, 3, None, "mimo_continuous")]:
        a = rng.normal(size=(n, n))
        if ts is None:
            a = a - (np.max(np.linalg.eigvals(a).real) + 0.5) * np.eye(n)
        else:
            a = 0.9 * a / np.max(np.abs(np.linalg.eigvals(a)))
        b = rng.normal(size=(n, m))
        c = rng.normal(size=(p, n))
        d = np.zeros((p, m)) if ts is None else rng.normal(size=(p, m))
        out[name] = (a, b, c, d, ts)
    return out


def write_model(path, a, b, c, d, ts):
    with open(path, "w") as f:
        json.dump(
            {"kind": "state_space", "ts": ts, "a": a.tolist(), "b": b.tolist(),
             "c": c.tolist(), "d": d.tolist()},
            f,
        )


def run(lifted, *args):
    out = subprocess.run([lifted, *args], capture_output=True, text=True)
    if out.returncode != 0:
        raise RuntimeError(f"lifted {' '.join(args)}: {out.stderr.strip()}")
    return json.loads(out.stdout)


def hsv_reference(sys_, a, b, c, ts):
    try:
        return np.sort(np.asarray(control.hsvd(sys_)))[::-1]
    except Exception:  # noqa: BLE001 - python-control without slycot
        import scipy.linalg as sl

        if ts is None:
            p = sl.solve_continuous_lyapunov(a, -b @ b.T)
            q = sl.solve_continuous_lyapunov(a.T, -c.T @ c)
        else:
            p = sl.solve_discrete_lyapunov(a, b @ b.T)
            q = sl.solve_discrete_lyapunov(a.T, c.T @ c)
        return np.sort(np.sqrt(np.abs(np.linalg.eigvals(p @ q))))[::-1]


def check_model(lifted, tmp, name, a, b, c, d, ts):
    path = os.path.join(tmp, name + ".json")
    write_model(path, a, b, c, d, ts)
    sys_ = control.ss(a, b, c, d, ts) if ts is not None else control.ss(a, b, c, d)
    r = run(lifted, "analyze", "--model", path, "--json")
    poles = [complex(z["re"], z["im"]) for z in r["poles"]]
    check(f"{name}: poles", match_roots(poles, control.poles(sys_), 1e-8) < 1e-8)
    if r["zeros"] is not None and (HAVE_SLYCOT or b.shape[1] == c.shape[0] == 1):
        zeros = [complex(z["re"], z["im"]) for z in r["zeros"]]
        want = control.zeros(sys_)
        check(f"{name}: zeros", match_roots(zeros, want, 1e-6) < 1e-6,
              f"lifted {np.round(zeros, 6)} control {np.round(want, 6)}")
    stable = bool(np.all(np.abs(control.poles(sys_)) < 1)) if ts else bool(
        np.all(control.poles(sys_).real < 0))
    check(f"{name}: stability", r["stability"]["stable"] == stable)
    if r["dc_gain"] is not None:
        want = np.atleast_2d(control.dcgain(sys_)).reshape(c.shape[0], b.shape[1])
        check(f"{name}: DC gain", rel(r["dc_gain"], want) < 1e-8)
    if not stable:
        check(f"{name}: norms not defined when unstable",
              r["h2_norm"] is None and r["hinf_norm"] is None
              and "unstable" in r["notes"]["h2_norm"])
        return
    if ts is None and np.any(d != 0):
        check(f"{name}: H2 infinite with D != 0", r["h2_norm"] is None)
    else:
        want = control.norm(sys_, 2)
        check(f"{name}: H2 norm", rel(r["h2_norm"], want) < 1e-8,
              f"lifted {r['h2_norm']:.10g} control {want:.10g}")
    got = r["hinf_norm"]["norm"]
    try:
        want = control.norm(sys_, "inf")
    except ValueError as e:  # python-control 0.10's scipy method needs p = m
        want = None
        print(f"     {name}: control.norm(sys, 'inf') failed ({e}); grid check only")
    if want is not None:
        check(f"{name}: Hinf norm", abs(got - want) < 1e-5 * want,
              f"lifted {got:.10g} control {want:.10g}")
    w = r["hinf_norm"]["peak_frequency"]

    def sigma_max(x):
        g = sys_(np.exp(1j * x * ts)) if ts else sys_(1j * x)
        return np.linalg.svd(np.atleast_2d(g), compute_uv=False)[0]

    if w is not None:
        sv = sigma_max(w)
        check(f"{name}: sigma_max at the peak frequency {w:.6g} is the norm",
              abs(sv - got) < 1e-8 * got, f"{sv:.12g} vs {got:.12g}")
    top = np.pi / ts if ts else 1e4
    grid = np.concatenate([[0.0], np.logspace(-4, np.log10(top), 20000)])
    best = max(sigma_max(x) for x in grid)
    check(f"{name}: no frequency of a 20001-point grid exceeds the Hinf norm",
          best <= got * (1 + 1e-8), f"grid max {best:.12g}")
    want = hsv_reference(sys_, a, b, c, ts)
    check(f"{name}: Hankel singular values", rel(r["hankel_singular_values"], want) < 1e-8)
    # Bode at given frequencies, below Nyquist for discrete models.
    top = np.pi / ts if ts else 100.0
    omega = [0.01 * top, 0.1 * top, 0.37 * top, 0.9 * top]
    bo = run(lifted, "bode", "--model", path, "--omega", ",".join(f"{x!r}" for x in omega), "--json")
    resp = control.frequency_response(sys_, omega)
    fresp = np.asarray(getattr(resp, "frdata", None) if hasattr(resp, "frdata") else resp.fresp).reshape(c.shape[0], b.shape[1], len(omega))
    worst_mag, worst_phase = 0.0, 0.0
    for pair in bo["pairs"]:
        i = int(pair["output"][1:]) - 1
        j = int(pair["input"][1:]) - 1
        mag = np.abs(fresp[i, j])
        ph = np.degrees(np.angle(fresp[i, j]))
        worst_mag = max(worst_mag, rel(pair["magnitude"], mag))
        dphi = (np.asarray(pair["phase_deg"]) - ph + 180.0) % 360.0 - 180.0
        worst_phase = max(worst_phase, float(np.max(np.abs(dphi))))
    check(f"{name}: bode --omega magnitude", worst_mag < 1e-8, f"{worst_mag:.2e}")
    check(f"{name}: bode --omega phase", worst_phase < 1e-6, f"{worst_phase:.2e} deg")
    if ts is not None:
        n, m = b.shape
        q = np.eye(n)
        rr = np.eye(m)
        lq = run(lifted, "lqr", "--model", path, "--q", "1", "--r", "1", "--json")
        k, s, e = control.dlqr(a, b, q, rr)
        check(f"{name}: LQR gain", rel(lq["k"], k) < 1e-8)
        check(f"{name}: DARE solution", rel(lq["x"], s) < 1e-8)
        cl = [complex(z["re"], z["im"]) for z in lq["closed_loop_poles"]]
        check(f"{name}: closed-loop poles", match_roots(cl, e, 1e-8) < 1e-8)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lifted", default="target/release/lifted")
    args = ap.parse_args()
    print(f"python-control {control.__version__}, slycot: {HAVE_SLYCOT}")
    with tempfile.TemporaryDirectory() as tmp:
        for name, (a, b, c, d, ts) in models().items():
            check_model(args.lifted, tmp, name, a, b, c, d, ts)
    if FAILURES:
        print(f"{len(FAILURES)} check(s) failed: {', '.join(FAILURES)}")
        sys.exit(1)
    print("all checks passed")


if __name__ == "__main__":
    main()
