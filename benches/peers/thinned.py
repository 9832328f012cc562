#!/usr/bin/env python3
"""Multirate identification on real records thinned as a lab analyser delivers them.

Each record's estimation half keeps its outputs every P-th sample only (empty
CSV cells between); the model is scored on the full-rate validation half
(simulation fit, x0 by least squares, estimation means removed: the scoring of
realdata.py). Three runs of `lifted identify` per (record, order):

  multirate     the thinned record as it is (the multirate route)
  interpolated  the thinned outputs interpolated linearly (held at the ends),
                then the single-rate route: what a user without a multirate
                tool does
  full          the full-rate estimation half (what the analyser hides)

Usage:
  thinned.py --cli target/release/lifted --period 5 --orders 2,3,4,5,6 \
      --records debutanizer,sru [--daisy robot_arm,...] --json out.json
  (--extra "--method armax --a-structure full" --extra-on multirate,interpolated
  gives every route the same model structure)

Industrial records (files in $REALDATA_DIR/industrial or --industrial-dir):
  debutanizer  debutanizer column (Fortuna et al. 2007, "Soft sensors for
               monitoring and control of industrial processes"): 7 process
               inputs, butane content, 2394 samples (debutanizer_data.txt)
  sru          sulfur recovery unit (same source): 5 inputs, 2 outputs,
               10081 samples (SRU_data.txt)
DaISy records by name from realdata_records.json / holdout_records.json.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import realdata  # noqa: E402

INDUSTRIAL = {
    "debutanizer": {"file": "debutanizer_data.txt", "inputs": list(range(7)), "outputs": [7],
                    "skip": 2, "ts": 1.0},
    "sru": {"file": "SRU_data.txt", "inputs": list(range(5)), "outputs": [5, 6],
            "skip": 1, "ts": 1.0},
}


def halves(u, y):
    h = u.shape[0] // 2
    ue, ye, uv, yv = u[:h], y[:h], u[h:], y[h:]
    mu, my = ue.mean(axis=0), ye.mean(axis=0)
    return ue - mu, ye - my, uv - mu, yv - my


def load(name, industrial_dir, data_dir):
    if name in INDUSTRIAL:
        r = INDUSTRIAL[name]
        d = np.loadtxt(os.path.join(industrial_dir, r["file"]), skiprows=r["skip"], ndmin=2)
        return halves(d[:, r["inputs"]], d[:, r["outputs"]]), r["ts"]
    for manifest in ("realdata_records.json", "holdout_records.json"):
        with open(os.path.join(HERE, manifest)) as f:
            for rec in json.load(f)["records"]:
                if rec["name"] == name:
                    (ue, ye, uv, yv), _ = realdata.load_record(rec, data_dir)
                    return (ue, ye, uv, yv), rec.get("ts", 1.0)
    raise SystemExit(f"unknown record {name}")


def thin(y, period):
    out = np.full_like(y, np.nan)
    out[::period] = y[::period]
    return out


def interpolate(y):
    t = np.arange(y.shape[0])
    out = np.empty_like(y)
    for j in range(y.shape[1]):
        k = np.isfinite(y[:, j])
        out[:, j] = np.interp(t, t[k], y[k, j])
    return out


def write_csv(path, u, y, ts):
    names = ["t"] + [f"u{i + 1}" for i in range(u.shape[1])] + [f"y{i + 1}" for i in range(y.shape[1])]
    with open(path, "w") as f:
        f.write(",".join(names) + "\n")
        for k in range(u.shape[0]):
            cells = [repr(k * ts)] + [repr(float(v)) for v in u[k]]
            cells += ["" if not np.isfinite(v) else repr(float(v)) for v in y[k]]
            f.write(",".join(cells) + "\n")


def run(cli, csv, m, p, order, out, extra, uv, yv, period=None):
    cmd = [cli, "identify", "--data", csv,
           "--inputs", ",".join(f"u{i + 1}" for i in range(m)),
           "--outputs", ",".join(f"y{i + 1}" for i in range(p)),
           "--out", out] + extra
    if order != "auto":
        cmd += ["--order", str(order)]
    if period:
        for j in range(p):
            cmd += ["--output-period", f"y{j + 1}={period}"]
    r = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, **realdata.THREAD_ENV})
    if r.returncode != 0:
        return {"fit": None, "status": "failed", "error": (r.stderr or r.stdout).strip()[-300:]}
    mats, diag, op = realdata.read_model(out)
    u0 = np.asarray(op["u0"]) if op else 0.0
    y0 = np.asarray(op["y0"]) if op else 0.0
    res = realdata.scored(mats, uv - u0, yv - y0)
    d = diag or {}
    res["route"] = d.get("route")
    res["kept_start"] = (d.get("multirate_start") or {}).get("kept")
    res["check"] = (d.get("multirate_check") or {}).get("kept")
    res["check_folds"] = (d.get("multirate_check") or {}).get("per_fold")
    res["d_max"] = float(np.max(np.abs(mats[3]))) if mats[3].size else 0.0
    return res


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cli", required=True)
    ap.add_argument("--period", type=int, default=5)
    ap.add_argument("--orders", default="2,3,4,5,6")
    ap.add_argument("--records", default="debutanizer,sru")
    ap.add_argument("--industrial-dir", default=os.path.join(os.environ.get("REALDATA_DIR", "/work/realdata"), "industrial"))
    ap.add_argument("--data-dir", default=os.environ.get("REALDATA_DIR", "/work/realdata"))
    ap.add_argument("--extra", default="", help="extra lifted flags for the multirate runs (space-separated)")
    ap.add_argument("--extra-on", default="multirate",
                    help="routes the --extra flags go to (comma-separated; default multirate)")
    ap.add_argument("--routes", default="multirate,interpolated,full")
    ap.add_argument("--json")
    a = ap.parse_args()
    orders = [o if o == "auto" else int(o) for o in a.orders.split(",")]
    routes = a.routes.split(",")
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in a.records.split(","):
            (ue, ye, uv, yv), ts = load(name, a.industrial_dir, a.data_dir)
            m, p = ue.shape[1], ye.shape[1]
            yt = thin(ye, a.period)
            csvs = {"multirate": os.path.join(tmp, f"{name}_thin.csv"),
                    "interpolated": os.path.join(tmp, f"{name}_interp.csv"),
                    "full": os.path.join(tmp, f"{name}_full.csv")}
            write_csv(csvs["multirate"], ue, yt, ts)
            write_csv(csvs["interpolated"], ue, interpolate(yt), ts)
            write_csv(csvs["full"], ue, ye, ts)
            for order in orders:
                row = {"record": name, "order": order}
                for route in routes:
                    extra = a.extra.split() if (route in a.extra_on.split(",") and a.extra) else []
                    out = os.path.join(tmp, f"{name}_{route}_{order}.json")
                    row[route] = run(a.cli, csvs[route], m, p, order, out, extra, uv, yv,
                                     a.period if route == "multirate" else None)
                results.append(row)
                cells = "  ".join(
                    f"{r} {row[r]['fit']:.1f}" if row[r]["fit"] is not None else f"{r} {row[r]['status']}"
                    for r in routes)
                extra = row.get("multirate", {})
                print(f"{name:12s} n={order!s:4s} {cells}   (multirate: rho {extra.get('rho')}, start {extra.get('kept_start')}, check kept {extra.get('check')}, max|D| {extra.get('d_max')})", flush=True)
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"period": a.period, "results": results}, f, indent=1, default=str)


if __name__ == "__main__":
    main()
