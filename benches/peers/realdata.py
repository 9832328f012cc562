"""Real-data benchmark (issue 26): lifted beside SIPPY (and GNU Octave's control
package) on public real identification records of the DaISy database.

Not part of the test suite. Every tool gets the same data and is scored the same
way, by this script:

* the record (manifest benches/peers/realdata_records.json, files under
  $REALDATA_DIR, default /work/realdata) is split into estimation = first half and
  validation = second half; the estimation means are removed from both halves;
* each tool identifies (A, B, C, D) at a fixed order from the estimation half;
* the model is simulated on the validation half with x0 estimated by least squares
  on the validation data (y_hat = C A^t x0 + forced response from zero state);
* fit per output = 100 (1 - ||y - y_hat|| / ||y - mean(y)||), averaged over the
  outputs. A model with spectral radius >= 1 is reported as "unstable" (no fit),
  a failed or timed-out run as "failed" / "timeout".
* a second score, "fit_own", is the same on the validation half with its own
  means removed (as `detrend` on each data set before MATLAB's `compare`; lifted's
  operating point is then not used): where a process drifts between the halves, a
  model with a pole near 1 fits the validation half's offset through x0, and the
  first protocol rewards it (Octave's order-4 dryer model, pole 0.999: 90.7, and
  91.2 under the second). The summary counts both.

Tools:
* lifted: `$LIFTED_CLI identify --method {n4sid,moesp,cva} --order n` (CLI defaults:
  horizon, detrending — the means removed inside the identification, the model's
  operating point applied when it is scored, as `lifted validate` does;
  `--lifted-detrend-none` runs `--detrend none` on the centred file instead, the
  protocol of the tables before 2026-11-27): these three make the "best lifted" of
  the summary counts;
  `--method n4sid --refine pem` (time limited); `--method n4sid --order auto` (the
  chosen order is recorded). Two diagnostic variants, outside the counts: the three
  methods with the file given twice (`--data est.csv --data est.csv`: the CLI's
  in-memory route, (B, D, x0) by output-error least squares instead of the streamed
  route's Γ⊥ projection) and `--method n4sid --horizon 20` (SIPPY's f = p);
* SIPPY (sippy-unipi): N4SID, MOESP, CVA, PARSIM-K with SS_fixed_order = n,
  SS_f = SS_p = 20 (SIPPY's defaults; a record may set "sippy_horizon", SIPPY's
  f = p where its default is too long for the record; lifted always runs its own
  default horizon, which adapts to the record),
  other options at SIPPY's defaults (SS_D_required=False: D = 0);
* Octave (optional, if `octave-cli` with the control package is found):
  `n4sid(iddata(y, u, ts), n)` (SLICOT IB01AD/BD, default s = min(2n, n+10)).

Usage (from the repository root; benches/peers/realdata.sh sets up the venv):
  python benches/peers/realdata.py --lifted-cli PATH [--json out.json] [--md out.md]
"""

import argparse
import json
import math
import os
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
LIFTED_METHODS = ["n4sid", "moesp", "cva"]
# --lifted-detrend-none: lifted runs `--detrend none` (set by main()).
DETREND_NONE = False
SIPPY_METHODS = ["N4SID", "MOESP", "CVA", "PARSIM-K"]
THREAD_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1",
              "MKL_NUM_THREADS": "1", "RAYON_NUM_THREADS": "1"}


# ----------------------------------------------------------------------------- data

def load_record(rec, data_dir):
    d = np.loadtxt(os.path.join(data_dir, rec["file"]), ndmin=2)
    u = d[:, rec["inputs"]]
    y = d[:, rec["outputs"]]
    n = d.shape[0]
    h = n // 2
    ue, ye, uv, yv = u[:h], y[:h], u[h:], y[h:]
    mu, my = ue.mean(axis=0), ye.mean(axis=0)
    return (ue - mu, ye - my, uv - mu, yv - my), n


# -------------------------------------------------------------------------- scoring

def spectral_radius(a):
    if a.size == 0:
        return 0.0
    return float(np.max(np.abs(np.linalg.eigvals(a))))


def score(model, u, y, marginal=False):
    """Validation simulation fit (mean over outputs) with x0 by least squares.

    A model with rho >= 1 is refused ("unstable") unless `marginal` (an
    integrating plant's model is simulated, as benches/peers/emps.py does).
    Returns (fit or None, per-output fits or None, status, spectral radius)."""
    a, b, c, d = (np.atleast_2d(np.asarray(m, dtype=float)) for m in model)
    n = a.shape[0]
    p = y.shape[1]
    if not all(np.all(np.isfinite(m)) for m in (a, b, c, d)):
        return None, None, "non-finite", None
    rho = spectral_radius(a)
    if rho >= 1.0 and not marginal:
        return None, None, "unstable", rho
    N = u.shape[0]
    # forced response from x = 0 and the free-response regressor C A^t
    x = np.zeros(n)
    forced = np.empty((N, p))
    phi = np.empty((N, p, n))
    ca = c.copy()
    for t in range(N):
        forced[t] = c @ x + d @ u[t]
        x = a @ x + b @ u[t]
        phi[t] = ca
        ca = ca @ a
    resid = (y - forced).reshape(-1)
    if n > 0:
        x0, *_ = np.linalg.lstsq(phi.reshape(N * p, n), resid, rcond=None)
        yhat = forced + (phi @ x0)
    else:
        yhat = forced
    fits = []
    for k in range(p):
        den = np.linalg.norm(y[:, k] - y[:, k].mean())
        fits.append(100.0 * (1.0 - np.linalg.norm(y[:, k] - yhat[:, k]) / den))
    return float(np.mean(fits)), [float(f) for f in fits], "ok", rho


# The validation half of the record being scored with its own means removed
# (set per record by main(); the "fit_own" protocol).
VALIDATION_OWN = None


def scored(model, u, y, extra=None):
    fit, fits, status, rho = score(model, u, y)
    r = {"fit": fit, "fits": fits, "status": status, "rho": rho,
         "order": int(np.atleast_2d(model[0]).shape[0])}
    if VALIDATION_OWN is not None:
        r["fit_own"] = score(model, *VALIDATION_OWN)[0]
    if extra:
        r.update(extra)
    return r


# --------------------------------------------------------------------------- lifted

def write_csv(path, u, y, ts):
    N = u.shape[0]
    t = np.arange(N) * ts
    names = ["t"] + [f"u{i + 1}" for i in range(u.shape[1])] + [f"y{i + 1}" for i in range(y.shape[1])]
    np.savetxt(path, np.column_stack([t, u, y]), delimiter=",", header=",".join(names),
               comments="", fmt="%.17g")


def read_model(path):
    with open(path) as f:
        m = json.load(f)
    mats = [np.array(m[k], dtype=float) for k in ("a", "b", "c", "d")]
    op = m.get("operating_point")
    return mats, m.get("diagnostics"), op


def validation_fit(path, u, y):
    """(order, fit) of the model file at `path` on the half (u, y), its
    operating point applied (fit None: not scored)."""
    mats, _, op = read_model(path)
    if op:
        u, y = u - np.asarray(op["u0"]), y - np.asarray(op["y0"])
    return len(mats[0]), score(mats, u, y)[0]


def manifest_records(data_dir, manifests=("realdata_records.json", "holdout_records.json")):
    """(manifest, record, (ue, ye, uv, yv)) for every record of the manifests."""
    here = os.path.dirname(os.path.abspath(__file__))
    for manifest in manifests:
        with open(os.path.join(here, manifest)) as f:
            records = json.load(f)["records"]
        for rec in records:
            yield manifest, rec, load_record(rec, data_dir)[0]


def run_lifted(cli, workdir, csv, m, p, method, order, extra_args, timeout, u, y, base_args=(),
               in_memory=False):
    tag = "_".join(extra_args) or "plain"
    out = os.path.join(workdir, f"m_{method}_{order}_{tag}{'_mem' if in_memory else ''}.json")
    if "--horizon" not in extra_args:
        extra_args = list(base_args) + list(extra_args)
    if os.path.exists(out):
        os.remove(out)
    # The CLI streams a single CSV file (B, D from the Γ⊥ projection, no records
    # kept); given the same file twice it takes the in-memory route instead
    # ((B, D, x0) by output-error least squares on the records), with the same
    # subspace: a diagnostic of which step loses the fit.
    data = ["--data", csv, "--data", csv] if in_memory else ["--data", csv]
    cmd = [cli, "identify", "--method", method] + data + [
           "--inputs", ",".join(f"u{i + 1}" for i in range(m)),
           "--outputs", ",".join(f"y{i + 1}" for i in range(p)),
           "--order", str(order)] + (["--detrend", "none"] if DETREND_NONE else []) + [
           "--out", out] + extra_args
    t0 = time.perf_counter()
    try:
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout,
                           env={**os.environ, **THREAD_ENV})
    except subprocess.TimeoutExpired:
        return {"fit": None, "status": "timeout", "seconds": timeout, "cmd": cmd[1:]}
    secs = time.perf_counter() - t0
    if r.returncode != 0 or not os.path.exists(out):
        return {"fit": None, "status": "failed", "seconds": secs,
                "error": (r.stderr or r.stdout).strip()[-600:]}
    mats, diag, op = read_model(out)
    if op:
        # The model is of deviations from its operating point (the default
        # detrending): scored as `lifted validate` scores it, u − u0 in, y0 added.
        res = scored(mats, u - np.asarray(op["u0"], dtype=float),
                     y - np.asarray(op["y0"], dtype=float), {"seconds": secs})
        res["operating_point"] = op
    else:
        res = scored(mats, u, y, {"seconds": secs})
    res["diagnostics"] = diag
    if r.stderr.strip():
        res["stderr"] = r.stderr.strip()[-600:]
    return res


# ---------------------------------------------------------------------------- SIPPY

class _Timeout(Exception):
    pass


def _alarm(signum, frame):
    raise _Timeout()


def sippy_worker(npz, orders, horizon, cap):
    """Runs in its own process: every SIPPY method at every order, one JSON line each."""
    try:
        from sippy_unipi import system_identification
    except ImportError:  # older SIPPY releases install the module as `sippy`
        from sippy import system_identification
    import warnings
    warnings.filterwarnings("ignore")
    z = np.load(npz)
    ue, ye = z["ue"], z["ye"]
    signal.signal(signal.SIGALRM, _alarm)
    for order in orders:
        for meth in SIPPY_METHODS:
            t0 = time.perf_counter()
            signal.alarm(cap)
            try:
                s = system_identification(ye.T, ue.T, meth, SS_fixed_order=order,
                                          SS_f=horizon, SS_p=horizon)
                signal.alarm(0)
                out = {"order": order, "method": meth, "status": "ok",
                       "seconds": time.perf_counter() - t0,
                       "a": np.asarray(s.A).tolist(), "b": np.asarray(s.B).tolist(),
                       "c": np.asarray(s.C).tolist(), "d": np.asarray(s.D).tolist()}
            except _Timeout:
                out = {"order": order, "method": meth, "status": "timeout", "seconds": cap}
            except Exception as e:  # noqa: BLE001  a peer failure is a result
                signal.alarm(0)
                out = {"order": order, "method": meth, "status": "failed",
                       "seconds": time.perf_counter() - t0, "error": repr(e)[:300]}
            print(json.dumps(out), flush=True)


def run_sippy(workdir, ue, ye, orders, horizon, cap):
    npz = os.path.join(workdir, "est.npz")
    np.savez(npz, ue=ue, ye=ye)
    cmd = [sys.executable, os.path.abspath(__file__), "--sippy-worker", npz,
           "--orders", ",".join(map(str, orders)), "--horizon", str(horizon), "--cap", str(cap)]
    budget = cap * len(orders) * len(SIPPY_METHODS) + 60
    try:
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=budget,
                           env={**os.environ, **THREAD_ENV})
        lines = r.stdout
        err = r.stderr
    except subprocess.TimeoutExpired as e:
        lines = e.stdout.decode() if isinstance(e.stdout, bytes) else (e.stdout or "")
        err = "worker timeout"
    out = {}
    for line in lines.splitlines():
        try:
            o = json.loads(line)
        except json.JSONDecodeError:
            continue
        out[(o["order"], o["method"])] = o
    return out, err


# --------------------------------------------------------------------------- Octave

def octave_available():
    exe = shutil.which("octave-cli") or shutil.which("octave")
    if not exe:
        return None
    try:
        r = subprocess.run([exe, "--no-gui", "--quiet", "--eval", "pkg load control; disp(exist('n4sid'))"],
                           capture_output=True, text=True, timeout=120)
    except (subprocess.TimeoutExpired, OSError):
        return None
    return exe if r.returncode == 0 and r.stdout.strip().endswith("2") else None


def run_octave(exe, workdir, ue, ye, ts, orders, cap):
    np.savetxt(os.path.join(workdir, "oct_u.txt"), ue, fmt="%.17g")
    np.savetxt(os.path.join(workdir, "oct_y.txt"), ye, fmt="%.17g")
    lines = ["pkg load control;", "u = load('oct_u.txt'); y = load('oct_y.txt');",
             "if rows(u) == 1, u = u'; end", "if rows(y) == 1, y = y'; end",
             f"dat = iddata(y, u, {ts!r});"]
    for n in orders:
        lines += [
            "try",
            "  tic;",
            f"  sys = n4sid(dat, {n});",
            "  secs = toc;",
            "  [a, b, c, d] = ssdata(sys);",
            f"  f = fopen('oct_{n}.txt', 'w');",
            "  fprintf(f, '%d %d %d %d %.6f\\n', rows(a), columns(b), rows(c), 0, secs);",
            "  fprintf(f, '%.17g ', a'); fprintf(f, '\\n');",
            "  fprintf(f, '%.17g ', b'); fprintf(f, '\\n');",
            "  fprintf(f, '%.17g ', c'); fprintf(f, '\\n');",
            "  fprintf(f, '%.17g ', d'); fprintf(f, '\\n');",
            "  fclose(f);",
            "catch err",
            f"  f = fopen('oct_{n}.err', 'w'); fprintf(f, '%s', err.message); fclose(f);",
            "end",
        ]
    with open(os.path.join(workdir, "run_n4sid.m"), "w") as f:
        f.write("\n".join(lines) + "\n")
    try:
        subprocess.run([exe, "--no-gui", "--quiet", "run_n4sid.m"], cwd=workdir, capture_output=True,
                       text=True, timeout=cap * len(orders) + 60, env={**os.environ, **THREAD_ENV})
    except subprocess.TimeoutExpired:
        pass
    m, p = ue.shape[1], ye.shape[1]
    out = {}
    for n in orders:
        ok, er = os.path.join(workdir, f"oct_{n}.txt"), os.path.join(workdir, f"oct_{n}.err")
        if os.path.exists(ok):
            rows = open(ok).read().split("\n")
            hdr = rows[0].split()
            nn, secs = int(hdr[0]), float(hdr[4])
            vals = [np.array([float(v) for v in r.split()]) for r in rows[1:5]]
            mats = [vals[0].reshape(nn, nn), vals[1].reshape(nn, -1)[:, :m],
                    vals[2].reshape(p, nn), vals[3].reshape(p, -1)[:, :m]]
            out[n] = {"status": "ok", "seconds": secs, "model": mats}
        elif os.path.exists(er):
            out[n] = {"status": "failed", "error": open(er).read()[:300]}
        else:
            out[n] = {"status": "timeout"}
    return out


# ------------------------------------------------------------------------- the table

def cell(r):
    if r is None:
        return "–"
    if r.get("fit") is not None:
        return f"{r['fit']:.1f}"
    return r.get("status", "–")


def val(r, key="fit"):
    return r[key] if r is not None and r.get(key) is not None else -math.inf


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--lifted-cli", default=os.environ.get("LIFTED_CLI"),
                    help="lifted binary (default: $LIFTED_CLI)")
    ap.add_argument("--manifest", default=os.path.join(HERE, "realdata_records.json"))
    ap.add_argument("--data-dir", default=os.environ.get("REALDATA_DIR", "/work/realdata"))
    ap.add_argument("--json", help="write every number to this JSON file")
    ap.add_argument("--md", help="also write the markdown table to this file")
    ap.add_argument("--records", help="comma-separated subset of record names")
    ap.add_argument("--all-orders", type=int, metavar="K",
                    help="run every tool at every order 1..K instead of the manifest's orders "
                         "(benches/results/real-records.md, 'Every order 1-10 beside the peers': K = 10)")
    ap.add_argument("--lifted-timeout", type=int, default=120, help="seconds per lifted subspace run")
    ap.add_argument("--pem-timeout", type=int, default=120, help="seconds per lifted --refine pem run")
    ap.add_argument("--no-pem", action="store_true", help="skip the --refine pem variant")
    ap.add_argument("--no-in-memory", action="store_true",
                    help="skip the diagnostic in-memory route (data file given twice)")
    ap.add_argument("--horizon-variant", type=int, default=20,
                    help="also run lifted N4SID with --horizon H (SIPPY's f = p); 0 disables")
    ap.add_argument("--sippy-cap", type=int, default=120, help="seconds per SIPPY (method, order) run")
    ap.add_argument("--octave-cap", type=int, default=120, help="seconds per Octave n4sid run")
    ap.add_argument("--no-octave", action="store_true")
    ap.add_argument("--lifted-detrend-none", action="store_true",
                    help="run lifted with --detrend none on the centred file (the protocol before 2026-11-27)")
    ap.add_argument("--from-json", help="print the table of a saved --json run instead of running")
    ap.add_argument("--no-sippy", action="store_true")
    ap.add_argument("--methods", default="n4sid,moesp,cva",
                    help="lifted methods run at each order (default n4sid,moesp,cva; e.g. n4sid,pbsid,ssarx "
                         "to compare the closed-loop methods)")
    ap.add_argument("--lifted-args", default="",
                    help="extra arguments for every lifted run but the horizon variant, e.g. "
                         "'--feedthrough false' (a variant of the CLI's defaults)")
    # internal: the SIPPY worker process
    ap.add_argument("--sippy-worker", help=argparse.SUPPRESS)
    ap.add_argument("--orders", help=argparse.SUPPRESS)
    ap.add_argument("--horizon", type=int, default=20, help=argparse.SUPPRESS)
    ap.add_argument("--cap", type=int, default=120, help=argparse.SUPPRESS)
    args = ap.parse_args()
    LIFTED_METHODS[:] = [m for m in args.methods.split(",") if m]
    global DETREND_NONE
    DETREND_NONE = args.lifted_detrend_none

    if args.sippy_worker:
        sippy_worker(args.sippy_worker, [int(o) for o in args.orders.split(",")], args.horizon, args.cap)
        return
    if args.from_json:
        with open(args.from_json) as f:
            saved = json.load(f)
        res, meta = saved["results"], saved["meta"]
        lk = set().union(*(r["lifted"].keys() for r in res)) if res else set()
        print(table(res, saved["auto"], meta, bool(meta.get("octave")), "n4sid+pem" in lk,
                    meta.get("horizon_variant", 20) if "n4sid_h" in lk else 0, "n4sid_mem" in lk))
        return
    if not args.lifted_cli or not os.path.exists(args.lifted_cli):
        ap.error("give the lifted binary with --lifted-cli or LIFTED_CLI")

    with open(args.manifest) as f:
        records = json.load(f)["records"]
    if args.records:
        keep = set(args.records.split(","))
        records = [r for r in records if r["name"] in keep]

    octave = None if args.no_octave else octave_available()
    version = subprocess.run([args.lifted_cli, "--version"], capture_output=True, text=True).stdout.strip()
    meta = {"date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "lifted_cli": args.lifted_cli,
            "lifted_detrend": "none" if DETREND_NONE else "default (means removed inside, operating point scored)",
            "lifted_version": version, "octave": octave, "numpy": np.__version__,
            "sippy_horizon_default": 20, "pem_timeout": args.pem_timeout, "sippy_cap": args.sippy_cap,
            "horizon_variant": args.horizon_variant}
    try:
        from importlib.metadata import version as pkg_version
        meta["sippy_unipi"] = pkg_version("sippy-unipi")
    except Exception:  # noqa: BLE001
        meta["sippy_unipi"] = None
    print(f"# {meta['date']}  lifted: {version} ({args.lifted_cli})  SIPPY: {meta['sippy_unipi']}  "
          f"Octave: {'yes' if octave else 'no'}", file=sys.stderr)

    results = []
    autos = []
    for rec in records:
        (ue, ye, uv, yv), N = load_record(rec, args.data_dir)
        global VALIDATION_OWN
        VALIDATION_OWN = (uv - uv.mean(axis=0), yv - yv.mean(axis=0))
        m, p = ue.shape[1], ye.shape[1]
        orders = list(range(1, args.all_orders + 1)) if args.all_orders else rec["orders"]
        horizon = rec.get("sippy_horizon", 20)
        base = shlex.split(args.lifted_args)
        print(f"## {rec['name']}  {m}x{p}  N={N}  orders {orders}", file=sys.stderr)
        with tempfile.TemporaryDirectory(prefix=f"realdata_{rec['name']}_") as wd:
            csv = os.path.join(wd, "est.csv")
            write_csv(csv, ue, ye, rec["ts"])
            sippy, sippy_err = ({}, "skipped") if args.no_sippy else \
                run_sippy(wd, ue, ye, orders, horizon, args.sippy_cap)
            oct_res = run_octave(octave, wd, ue, ye, rec["ts"], orders, args.octave_cap) if octave else {}
            for order in orders:
                row = {"record": rec["name"], "m": m, "p": p, "N": N, "order": order,
                       "sippy_horizon": horizon, "lifted_horizon": "default", "lifted": {}, "sippy": {}, "octave": None}
                for meth in LIFTED_METHODS:
                    row["lifted"][meth] = run_lifted(args.lifted_cli, wd, csv, m, p, meth, order, [],
                                                     args.lifted_timeout, uv, yv, base)
                if not args.no_in_memory:
                    for meth in LIFTED_METHODS:
                        row["lifted"][meth + "_mem"] = run_lifted(args.lifted_cli, wd, csv, m, p, meth, order, [],
                                                                  args.lifted_timeout, uv, yv, base, True)
                if args.horizon_variant:
                    row["lifted"]["n4sid_h"] = run_lifted(args.lifted_cli, wd, csv, m, p, "n4sid", order,
                                                          ["--horizon", str(args.horizon_variant)],
                                                          args.lifted_timeout, uv, yv)
                if not args.no_pem:
                    row["lifted"]["n4sid+pem"] = run_lifted(args.lifted_cli, wd, csv, m, p, "n4sid", order,
                                                            ["--refine", "pem"], args.pem_timeout, uv, yv, base)
                for meth in SIPPY_METHODS:
                    o = sippy.get((order, meth))
                    if o is None:
                        row["sippy"][meth] = {"fit": None, "status": "timeout" if sippy_err else "failed",
                                              "error": (sippy_err or "")[-300:]}
                    elif o["status"] != "ok":
                        row["sippy"][meth] = {k: v for k, v in o.items() if k not in ("order", "method")}
                        row["sippy"][meth]["fit"] = None
                    else:
                        mats = [np.array(o[k], dtype=float) for k in ("a", "b", "c", "d")]
                        row["sippy"][meth] = scored(mats, uv, yv, {"seconds": o["seconds"]})
                if octave:
                    o = oct_res.get(order, {"status": "failed"})
                    if o["status"] == "ok":
                        row["octave"] = scored(o["model"], uv, yv, {"seconds": o["seconds"]})
                    else:
                        row["octave"] = {"fit": None, **o}
                results.append(row)
                print("   n=%d  lifted %s  mem %s  i=H %s  pem %s  SIPPY %s  Octave %s" % (
                    order, " ".join(cell(row["lifted"][k]) for k in LIFTED_METHODS),
                    " ".join(cell(row["lifted"].get(k + "_mem")) for k in LIFTED_METHODS),
                    cell(row["lifted"].get("n4sid_h")),
                    cell(row["lifted"].get("n4sid+pem")),
                    " ".join(cell(row["sippy"][k]) for k in SIPPY_METHODS), cell(row["octave"])),
                    file=sys.stderr)
            auto = run_lifted(args.lifted_cli, wd, csv, m, p, "n4sid", "auto", [], args.lifted_timeout, uv, yv, base)
            best_fixed = max((r for r in results if r["record"] == rec["name"]),
                             key=lambda r: val(r["lifted"]["n4sid"]))
            best_own = max((r for r in results if r["record"] == rec["name"]),
                           key=lambda r: val(r["lifted"]["n4sid"], "fit_own"))
            autos.append({"record": rec["name"], "auto": auto, "chosen_order": auto.get("order"),
                          "best_fixed_order": best_fixed["order"],
                          "best_fixed_fit": best_fixed["lifted"]["n4sid"].get("fit"),
                          "best_fixed_fit_own": best_own["lifted"]["n4sid"].get("fit_own")})
            print(f"   auto: order {auto.get('order')} fit {cell(auto)}", file=sys.stderr)

    md = table(results, autos, meta, bool(octave), not args.no_pem, args.horizon_variant, not args.no_in_memory)
    print(md)
    if args.md:
        with open(args.md, "w") as f:
            f.write(md + "\n")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"meta": meta, "results": results, "auto": autos}, f, indent=1,
                      default=lambda o: o.tolist() if isinstance(o, np.ndarray) else str(o))


def table(results, autos, meta, octave, pem, hvar, mem):
    head = ["record", "n_u×n_y", "N", "order", "lifted N4SID", "lifted MOESP", "lifted CVA"]
    if mem:
        head.append("lifted in-memory N4SID / MOESP / CVA")
    if hvar:
        head.append(f"lifted N4SID i={hvar}")
    if pem:
        head.append("lifted N4SID+PEM")
    head += [f"SIPPY {m}" for m in SIPPY_METHODS]
    head.append("Octave n4sid" if octave else "Octave n4sid (not run)")
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    within_best = within_n4sid = within_mem = both_fail = 0
    lifted_ahead = 0
    for r in results:
        cells = [r["record"], f"{r['m']}×{r['p']}", str(r["N"]), str(r["order"])]
        cells += [cell(r["lifted"][k]) for k in LIFTED_METHODS]
        if mem:
            cells.append(" / ".join(cell(r["lifted"].get(k + "_mem")) for k in LIFTED_METHODS))
        if hvar:
            cells.append(cell(r["lifted"].get("n4sid_h")))
        if pem:
            cells.append(cell(r["lifted"].get("n4sid+pem")))
        cells += [cell(r["sippy"][k]) for k in SIPPY_METHODS]
        cells.append(cell(r["octave"]) if octave else "–")
        out.append("| " + " | ".join(cells) + " |")
        lb = max(val(r["lifted"][k]) for k in LIFTED_METHODS)
        ln = val(r["lifted"]["n4sid"])
        sb = max(val(r["sippy"][k]) for k in SIPPY_METHODS)
        r["best_lifted_subspace"] = lb if lb > -math.inf else None
        r["best_sippy_subspace"] = sb if sb > -math.inf else None
        if lb == -math.inf and sb == -math.inf:
            both_fail += 1
        if lb >= sb - 1.0:
            within_best += 1
        if ln >= sb - 1.0:
            within_n4sid += 1
        if lb > sb + 1.0:
            lifted_ahead += 1
        if mem and max(val(r["lifted"].get(k + "_mem")) for k in LIFTED_METHODS) >= sb - 1.0:
            within_mem += 1
    n = len(results)
    summary = (f"Summary: best lifted subspace method within 1 point of (or above) the best SIPPY subspace "
               f"method on {within_best}/{n} (record, order) pairs (more than 1 point above on {lifted_ahead}); "
               f"lifted default N4SID within 1 point on {within_n4sid}/{n}"
               + (f" ({both_fail} pairs with no stable model from either tool count as within)" if both_fail else "")
               + "."
               + (f" Diagnostic: the best lifted method on the in-memory route (file given twice) is within 1 point "
                  f"on {within_mem}/{n}." if mem else ""))
    out += ["", summary, "", "Auto order (lifted `--method n4sid --order auto`, default rule `--order-criterion validation`, max order 10) "
            "against the best of the fixed orders tested (lifted N4SID):", "",
            "| record | auto order | auto fit | best fixed order | best fixed fit | difference |",
            "|---|---|---|---|---|---|"]
    near = near2 = 0
    for a in autos:
        af, bf = a["auto"].get("fit"), a["best_fixed_fit"]
        diff = f"{af - bf:+.1f}" if af is not None and bf is not None else "–"
        if af is not None and bf is not None and af >= bf - 1.0:
            near += 1
        if af is not None and bf is not None and af >= bf - 2.0:
            near2 += 1
        bfs = f"{bf:.1f}" if bf is not None else "–"
        bfo = a["best_fixed_order"] if bf is not None else "–"
        out.append(f"| {a['record']} | {a['chosen_order'] if a['chosen_order'] is not None else '–'} | "
                   f"{cell(a['auto'])} | {bfo} | {bfs} | {diff} |")
    out += ["", f"Auto order within 1 point of the best fixed order on {near}/{len(autos)} records, "
            f"within 2 points on {near2}/{len(autos)}."]
    meta["summary"] = summary
    meta["auto_summary"] = f"{near}/{len(autos)} (2 points: {near2}/{len(autos)})"
    out += ["", *protocol_counts(results, autos, pem)]
    return "\n".join(out)


def protocol_counts(results, autos, pem):
    """The summary counts under both scoring protocols ("fit": estimation means;
    "fit_own": the validation half's own means), from the saved cells (runs before
    fit_own was recorded give "–")."""
    lines = ["| count | validation half, estimation means removed | validation half, own means removed |",
             "|---|---|---|"]
    records = list(dict.fromkeys(r["record"] for r in results))

    def peers(r):
        return list(r["sippy"].values()) + ([r["octave"]] if r.get("octave") else [])

    def counts(key):
        n4 = sum(val(r["lifted"]["n4sid"], key) >= max(val(c, key) for c in r["sippy"].values()) - 1.0
                 for r in results)
        auto2 = sum(val(a["auto"], key) >= (a.get("best_fixed_" + key) if a.get("best_fixed_" + key) is not None
                                            else math.inf) - 2.0 for a in autos)
        pem_ok = misses = None
        if pem:
            pem_ok, misses = 0, []
            for rec in records:
                rows = [r for r in results if r["record"] == rec]
                lp = max(val(r["lifted"].get("n4sid+pem"), key) for r in rows)
                bp = max(val(c, key) for r in rows for c in peers(r))
                if lp >= bp - 1.0:
                    pem_ok += 1
                else:
                    misses.append(f"{rec} {lp:.1f}/{bp:.1f}")
        return n4, auto2, pem_ok, misses

    have_own = any(r["lifted"]["n4sid"].get("fit_own") is not None for r in results)
    a, b = counts("fit"), counts("fit_own") if have_own else None
    cell2 = (lambda c, i, tot: f"{c[i]}/{tot}" if c is not None else "–")
    lines.append(f"| default N4SID within 1 point of SIPPY's best at the order | {cell2(a, 0, len(results))} | "
                 f"{cell2(b, 0, len(results))} |")
    lines.append(f"| automatic order within 2 points of the best fixed order | {cell2(a, 1, len(autos))} | "
                 f"{cell2(b, 1, len(autos))} |")
    if pem:
        def pm(c):
            return "–" if c is None else f"{c[2]}/{len(records)}" + (f" (misses: {', '.join(c[3])})" if c[3] else "")
        lines.append(f"| `--refine pem`, best order, within 1 point of the best peer at any order | {pm(a)} | {pm(b)} |")
    return lines


if __name__ == "__main__":
    main()
