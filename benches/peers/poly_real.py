#!/usr/bin/env python3
"""Polynomial models on real records beside SIPPY (issue 49): ARX, ARMAX, OE
and BJ of lifted and of SIPPY (sippy-unipi) at the same orders on the DaISy
records of benches/peers/realdata.py, scored the same way.

Not part of the test suite. Protocol (realdata.py's): estimation = first half
of the record, validation = second half, the estimation means removed from
both; each tool estimates the structure from the estimation half; the plant
part G (B/A for ARX and ARMAX, B/F for OE and BJ), as a state-space
realisation, is simulated on the validation half with x0 by least squares;
fit = 100 (1 - ||y - y_hat|| / ||y - mean y||), the mean over the outputs; a
plant with a pole on or outside the unit circle is "unstable".

Structures, the same for every input-output pair, nk = 1 (SIPPY's delay
theta = 0): ARX [n n 1], ARMAX [n n n 1], OE [n n 1], BJ [n n n n 1], for
n in --orders. lifted: `lifted.arx / armax / oe / bj` (the Python package of
this tree: MIMO ARX, and per-output MISO ARMAX (one A per output), OE and BJ
(one F per input-output pair, MATLAB's structure; SIPPY's has one F per
output); ``--oe-common`` / ``--bj-common`` add lifted's OE / BJ with one F
per output, SIPPY's structure; ``--a-structure diagonal``: lifted's
MIMO ARX with A diagonal, SIPPY's structure); SIPPY: `system_identification` with
the same orders (ARMAX and OE in their OPT mode, SIPPY's prediction-error
optimisation; ARX by least squares), each fit capped at --cap seconds.

    benches/peers/.venv-real/bin/python benches/peers/poly_real.py \\
        [--manifest benches/peers/realdata_records.json] [--orders 2,4] \\
        [--records a,b] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import realdata  # noqa: E402  (the records, the split and the score)

FAMILIES = ["arx", "armax", "oe", "bj"]


class Timeout(Exception):
    pass


def _alarm(signum, frame):
    raise Timeout()


def orders_of(family: str, n: int) -> list[int]:
    return {"arx": [n, n, 1], "armax": [n, n, n, 1], "oe": [n, n, 1], "bj": [n, n, n, n, 1]}[family]


#: lifted's ARX A pattern for several outputs (--a-structure): "full" (its
#: default, MATLAB's arx) or "diagonal" (one MISO model per output, SIPPY's).
A_STRUCTURE = "full"
#: lifted's ARMAX A pattern for several outputs: "diagonal" (its default,
#: SIPPY's) or "full" (MATLAB's multi-output armax); --armax-full adds a
#: "lifted, A full" column beside the default.
ARMAX_A = "diagonal"


def lifted_model(family: str, n: int, u: np.ndarray, y: np.ndarray):
    import lifted

    extra = {}
    if family == "arx" and y.shape[1] > 1:
        extra = {"a_structure": A_STRUCTURE}
    elif family == "armax-full":
        family, extra = "armax", {"a_structure": "full"}
    elif family in ("oe-common", "bj-common"):
        family, extra = family[:2], {"f_structure": "common"}
    fit = getattr(lifted, family)(u, y, orders_of(family, n), **extra)
    m = fit.model
    return tuple(np.atleast_2d(np.asarray(x, dtype=float)) for x in (m.A, m.B, m.C, m.D))


def realise(num, den, nu: int, ny: int):
    """Block-diagonal state-space realisation of the transfer matrix whose
    (i, j) entry is num[i][j](z) / den[i][j](z) (descending powers of z)."""
    from scipy.signal import tf2ss

    blocks = []
    d = np.zeros((ny, nu))
    for i in range(ny):
        for j in range(nu):
            b = np.atleast_1d(np.asarray(num[i][j], dtype=float)).ravel()
            a = np.atleast_1d(np.asarray(den[i][j], dtype=float)).ravel()
            if b.size == 0 or not np.any(b):
                continue
            aa, bb, cc, dd = tf2ss(b, a)
            blocks.append((i, j, aa, bb, cc))
            d[i, j] = float(np.atleast_2d(dd)[0, 0])
    n = sum(blk[2].shape[0] for blk in blocks)
    A, B, C = np.zeros((n, n)), np.zeros((n, nu)), np.zeros((ny, n))
    k = 0
    for i, j, aa, bb, cc in blocks:
        s = aa.shape[0]
        A[k:k + s, k:k + s] = aa
        B[k:k + s, j] = bb[:, 0]
        C[i, k:k + s] = cc[0]
        k += s
    return A, B, C, d


def sippy_model(family: str, n: int, u: np.ndarray, y: np.ndarray):
    from sippy_unipi import system_identification

    ny, nu = y.shape[1], u.shape[1]
    yy, uu = (y.T, u.T) if ny > 1 or nu > 1 else (y[:, 0], u[:, 0])
    vec = [n] * ny
    mat = [[n] * nu for _ in range(ny)]
    theta = [[0] * nu for _ in range(ny)]
    siso = ny == 1 and nu == 1
    o = (lambda v: v[0]) if siso else (lambda v: v)
    om = (lambda v: v[0][0]) if siso else (lambda v: v)
    if family == "arx":
        s = system_identification(yy, uu, "ARX", ARX_orders=[o(vec), om(mat), om(theta)])
    elif family == "armax":
        s = system_identification(yy, uu, "ARMAX", ARMAX_orders=[o(vec), om(mat), o(vec), om(theta)],
                                  ARMAX_mod="OPT")
    elif family == "oe":
        # SIPPY's OE and BJ take one F per output (nf a vector).
        s = system_identification(yy, uu, "OE", OE_orders=[om(mat), o(vec), om(theta)], OE_mod="OPT")
    else:
        s = system_identification(yy, uu, "BJ", BJ_orders=[om(mat), o(vec), o(vec), o(vec), om(theta)])
    num, den = s.NUMERATOR, s.DENOMINATOR
    if siso:
        num, den = [[num]] if np.ndim(num) == 1 else num, [[den]] if np.ndim(den) == 1 else den
    return realise(num, den, nu, ny)


def sysidentpy_model(family: str, n: int, u: np.ndarray, y: np.ndarray):
    """sysidentpy's linear ARX (FROLS with every term of degree 1: ylag n,
    xlag n per input, and the constant, i.e. least squares), one MISO model
    per output (A diagonal, as SIPPY's MIMO ARX); ARX only."""
    from sysidentpy.basis_function import Polynomial
    from sysidentpy.model_structure_selection import FROLS
    from sysidentpy.parameter_estimation import LeastSquares

    if family != "arx":
        raise ValueError("sysidentpy: linear ARX only")
    ny, nu = y.shape[1], u.shape[1]
    num = [[None] * nu for _ in range(ny)]
    den = [[None] * nu for _ in range(ny)]
    for i in range(ny):
        xlag = n if nu == 1 else [list(range(1, n + 1))] * nu
        m = FROLS(order_selection=False, n_terms=n + n * nu + 1, ylag=n, xlag=xlag,
                  basis_function=Polynomial(degree=1), estimator=LeastSquares())
        m.fit(X=u, y=y[:, i:i + 1])
        a = np.zeros(n + 1)
        a[0] = 1.0
        b = np.zeros((nu, n + 1))
        for code, th in zip(np.asarray(m.final_model).ravel(), np.asarray(m.theta).ravel()):
            code = int(code)
            if code == 0:
                continue  # the constant (the data are centred)
            var, lag = divmod(code, 1000)
            if var == 1:
                a[lag] = -th
            else:
                b[var - 2, lag] = th
        for j in range(nu):
            num[i][j], den[i][j] = b[j], a
    return realise(num, den, nu, ny)


def run(tool: str, family: str, n: int, ue, ye, uv, yv, cap: int) -> dict:
    signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(cap)
    t0 = time.perf_counter()
    try:
        fitter = {"lifted": lifted_model, "sippy": sippy_model, "sysidentpy": sysidentpy_model}[tool]
        model = fitter(family, n, ue, ye)
        signal.alarm(0)
        fit, fits, status, rho = realdata.score(model, uv, yv)
        return {"fit": fit, "status": status, "rho": rho, "seconds": time.perf_counter() - t0}
    except Timeout:
        return {"fit": None, "status": "timeout", "seconds": cap}
    except (Exception, SystemExit) as e:  # noqa: BLE001 - a failed run is a data point (SIPPY exits on bad orders)
        signal.alarm(0)
        return {"fit": None, "status": f"failed: {type(e).__name__}: {str(e)[:120]}",
                "seconds": time.perf_counter() - t0}


def cell(r: dict) -> str:
    if r["fit"] is not None:
        return f"{r['fit']:.1f}"
    s = r["status"]
    return "unstable" if s == "unstable" else ("timeout" if s == "timeout" else "failed")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--manifest", default=os.path.join(realdata.HERE, "realdata_records.json"))
    ap.add_argument("--data-dir", default=os.environ.get("REALDATA_DIR", "/work/realdata"))
    ap.add_argument("--orders", default="2,4")
    ap.add_argument("--records")
    ap.add_argument("--families", default=",".join(FAMILIES))
    ap.add_argument("--cap", type=int, default=60, help="seconds per fit")
    ap.add_argument("--sysidentpy", action="store_true",
                    help="also sysidentpy's linear ARX (FROLS, every term) in the ARX rows")
    ap.add_argument("--a-structure", choices=["full", "diagonal"], default="full",
                    help="lifted's MIMO ARX: full A (its default) or diagonal (SIPPY's structure)")
    ap.add_argument("--armax-full", action="store_true",
                    help="also lifted's ARMAX with a coupled A (a_structure='full') on records of several outputs")
    ap.add_argument("--oe-common", action="store_true",
                    help="also lifted's OE with one F per output (f_structure='common', SIPPY's structure) on records of several inputs")
    ap.add_argument("--bj-common", action="store_true",
                    help="also lifted's BJ with one F per output (f_structure='common', SIPPY's structure) on records of several inputs")
    ap.add_argument("--json")
    args = ap.parse_args()
    global A_STRUCTURE
    A_STRUCTURE = args.a_structure
    recs = json.load(open(args.manifest))["records"]
    if args.records:
        keep = set(args.records.split(","))
        recs = [r for r in recs if r["name"] in keep]
    orders = [int(s) for s in args.orders.split(",")]
    families = args.families.split(",")
    rows = []
    for rec in recs:
        (ue, ye, uv, yv), n_rows = realdata.load_record(rec, args.data_dir)
        for fam in families:
            for n in orders:
                row = {"record": rec["name"], "family": fam, "n": n,
                       "lifted": run("lifted", fam, n, ue, ye, uv, yv, args.cap),
                       "sippy": run("sippy", fam, n, ue, ye, uv, yv, args.cap)}
                if fam == "arx" and args.sysidentpy:
                    row["sysidentpy"] = run("sysidentpy", fam, n, ue, ye, uv, yv, args.cap)
                if fam == "armax" and args.armax_full and ye.shape[1] > 1:
                    row["lifted_full"] = run("lifted", "armax-full", n, ue, ye, uv, yv, args.cap)
                if fam == "oe" and args.oe_common and ue.shape[1] > 1:
                    row["lifted_common"] = run("lifted", "oe-common", n, ue, ye, uv, yv, args.cap)
                if fam == "bj" and args.bj_common and ue.shape[1] > 1:
                    row["lifted_common"] = run("lifted", "bj-common", n, ue, ye, uv, yv, args.cap)
                rows.append(row)
                print(json.dumps({k: row[k] for k in ("record", "family", "n")}
                                 | {t: cell(row[t]) for t in ("lifted", "sippy", "sysidentpy", "lifted_full", "lifted_common")
                                    if t in row}),
                      flush=True)
    print("\n| record | structure | lifted | SIPPY | lifted − SIPPY |")
    print("|---|---|---|---|---|")
    better = worse = within = 0
    for r in rows:
        lf, sf = r["lifted"]["fit"], r["sippy"]["fit"]
        diff = ""
        if lf is not None and sf is not None:
            d = lf - sf
            diff = f"{d:+.1f}"
            within += abs(d) <= 1.0
            better += d > 1.0
            worse += d < -1.0
        elif lf is not None:
            better += 1
            diff = "lifted only"
        elif sf is not None:
            worse += 1
            diff = "SIPPY only"
        fam = r["family"].upper()
        o = " ".join(str(v) for v in orders_of(r["family"], r["n"]))
        extra = f" (sysidentpy {cell(r['sysidentpy'])})" if "sysidentpy" in r else ""
        if "lifted_full" in r:
            extra += f" (lifted, A full: {cell(r['lifted_full'])})"
        if "lifted_common" in r:
            extra += f" (lifted, common F: {cell(r['lifted_common'])})"
        print(f"| {r['record']} | {fam} [{o}] | {cell(r['lifted'])} | {cell(r['sippy'])}{extra} | {diff} |")
    print(f"\ncells: lifted better by > 1 point {better}, within a point {within}, worse by > 1 point {worse}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
