"""ARMAX, OE and BJ beside SIPPY (issue 49): the error of the estimated plant
against the truth, over seeded records of growing length.

Not part of the test suite. For each structure a SISO truth is simulated
(numpy, seeded): white input (sd 1), noise e (sd 0.3 for ARMAX/BJ, 0.2 for
OE). Each tool estimates the true structure; the score is the plant's
frequency-response error max_w |G_hat - G| / max_w |G| over 64 frequencies in
(0, pi) (parameter orderings differ between tools, the response does not),
as the median over the seeds. Tools:

* lifted: `lifted.armax / oe / bj` (the Python package of this tree);
* SIPPY (sippy-unipi): ARMAX in its three modes (ILLS, RLLS, OPT), OE (OPT,
  RLLS), BJ (OPT), `max_iterations` at its default (200); SIPPY's delay
  theta is nk - 1.

    python benches/peers/poly_peers.py [--sizes 500,2000,8000] [--seeds 10]
        [--json out.json] [--no-sippy]

`--no-sippy` runs lifted alone (the 1e4 -> 1e6 growth: SIPPY takes minutes
per fit there).
"""

import argparse
import json
import time

import numpy as np

W = np.linspace(0.01, np.pi - 0.01, 64)
Z = np.exp(1j * W)


def poly_q(c, nk=0):
    """sum_j c_j z^-(j + nk) at Z."""
    return sum(cj * Z ** (-(j + nk)) for j, cj in enumerate(c))


# (a, b, nk, c, d, f): A y = B/F u + C/D e, polynomials in q^-1.
CASES = {
    "armax": dict(a=[1, -1.5, 0.7], b=[1.0, 0.5], nk=1, c=[1, 0.5], d=[1], f=[1], sd=0.3),
    "oe": dict(a=[1], b=[0.5, 0.3], nk=2, c=[1], d=[1], f=[1, -1.2, 0.5], sd=0.2),
    "bj": dict(a=[1], b=[0.5, 0.3], nk=2, c=[1, 0.4], d=[1, -0.8], f=[1, -1.2, 0.5], sd=0.3),
}


def truth_g(k):
    c = CASES[k]
    return poly_q(c["b"], c["nk"]) / (poly_q(c["a"]) * poly_q(c["f"]))


def lfilter(b, a, x):
    """y = (b/a) x, polynomials in q^-1, zero initial conditions."""
    y = np.zeros_like(x)
    for t in range(len(x)):
        v = sum(b[j] * x[t - j] for j in range(len(b)) if t >= j)
        v -= sum(a[j] * y[t - j] for j in range(1, len(a)) if t >= j)
        y[t] = v / a[0]
    return y


def simulate(k, n, seed):
    c = CASES[k]
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(n)
    e = c["sd"] * rng.standard_normal(n)
    bu = np.concatenate([np.zeros(c["nk"]), u])[:n]
    plant = lfilter(c["b"], np.convolve(c["a"], c["f"]), bu)
    noise = lfilter(c["c"], np.convolve(c["a"], c["d"]), e)
    return u, plant + noise


def fr_error(g):
    t = truth_g(KIND)
    return float(np.max(np.abs(g - t)) / np.max(np.abs(t)))


def lifted_fit(k, u, y):
    import lifted
    c = CASES[k]
    if k == "armax":
        f = lifted.armax(u, y, [2, 2, 1, c["nk"]])
    elif k == "oe":
        f = lifted.oe(u, y, [2, 2, c["nk"]])
    else:
        f = lifted.bj(u, y, [2, 1, 1, 2, c["nk"]])
    p = f.polynomial
    return poly_q(p.b[0][0], p.nk[0][0]) / (poly_q(p.a[0][0]) * poly_q(p.f[0][0]))


def sippy_fit(k, mode, u, y):
    from sippy_unipi import system_identification
    c = CASES[k]
    th = c["nk"] - 1
    if k == "armax":
        s = system_identification(y, u, "ARMAX", ARMAX_orders=[2, 2, 1, th], ARMAX_mod=mode)
    elif k == "oe":
        s = system_identification(y, u, "OE", OE_orders=[2, 2, th], OE_mod=mode)
    else:
        s = system_identification(y, u, "BJ", BJ_orders=[2, 1, 1, 2, th])
    num = np.atleast_1d(np.asarray(s.NUMERATOR[0][0], dtype=float)).ravel()
    den = np.atleast_1d(np.asarray(s.DENOMINATOR[0][0], dtype=float)).ravel()
    # Descending powers of z.
    return np.polyval(num, Z) / np.polyval(den, Z)


KIND = "armax"


def main():
    global KIND
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="500,2000,8000")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--json")
    ap.add_argument("--no-sippy", action="store_true")
    args = ap.parse_args()
    modes = {"armax": ["ILLS", "RLLS", "OPT"], "oe": ["OPT", "RLLS"], "bj": ["OPT"]}
    if args.no_sippy:
        modes = {k: [] for k in modes}
    rows = []
    for k in ("armax", "oe", "bj"):
        KIND = k
        for n in [int(float(s)) for s in args.sizes.split(",")]:
            errs = {"lifted": []}
            for m in modes[k]:
                errs["sippy " + m] = []
            times = {key: 0.0 for key in errs}
            for seed in range(args.seeds):
                u, y = simulate(k, n, 100 + seed)
                t = time.perf_counter()
                errs["lifted"].append(fr_error(lifted_fit(k, u, y)))
                times["lifted"] += time.perf_counter() - t
                for m in modes[k]:
                    t = time.perf_counter()
                    try:
                        errs["sippy " + m].append(fr_error(sippy_fit(k, m, u, y)))
                    except Exception:  # noqa: BLE001 - a failed peer run is a data point
                        errs["sippy " + m].append(float("nan"))
                    times["sippy " + m] += time.perf_counter() - t
            row = {"structure": k, "n": n,
                   "median_fr_error": {key: float(np.nanmedian(v)) for key, v in errs.items()},
                   "seconds_per_fit": {key: v / args.seeds for key, v in times.items()}}
            rows.append(row)
            print(json.dumps(row))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
