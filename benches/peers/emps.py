"""EMPS drive record (issue 46, "Integrators kept"): lifted's default, `--refine pem` and
`--stable` on a position-controlled electro-mechanical drive, a double integrator.

Not part of the test suite; the data are never committed. The record is the public
nonlinear system identification benchmark "Electro-Mechanical Positioning System"
(A. Janot, M. Gautier, M. Brunot, "Data Set and Reference Models of EMPS", 2019
Workshop on Nonlinear System Identification Benchmarks, Eindhoven; nonlinearbenchmark.org).
A GitHub copy: forgi86/sysid-neural-continuous, examples/EMPS/data/DATA_EMPS.mat.

The record: `DATA_EMPS.mat` (24 841 samples at 1 kHz): input the motor force
gtau * vir (N; vir the controller's output voltage, gtau the drive gain), output the
measured position qm (m), under the drive's own position controller (closed loop).
Protocol of benches/peers/realdata.py: estimation = first half (12 420 samples),
validation = second half, the estimation means removed from both; the model
simulated on the validation half with x0 by least squares; fit = 100 (1 - |y - yhat| /
|y - mean y|). Unlike realdata.py a model with spectral radius >= 1 is scored too (the
plant is a double integrator: a model with poles on the unit circle is the right one;
over 12 420 samples a pole at 1 + 2e-5 grows by 1.3, so the simulation is meaningful),
and its spectral radius is printed beside the fit.

Usage (from the repository root; needs numpy and scipy, e.g. the venv of realdata.sh):
  python benches/peers/emps.py --mat /path/to/DATA_EMPS.mat --lifted-cli target/release/lifted \
      [--orders 2,3,4] [--json out.json]
"""

import argparse
import json
import os
import sys
import tempfile

import numpy as np
import scipy.io

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import realdata  # noqa: E402  (write_csv, read_model, the CLI runner)

VARIANTS = [
    ("default", []),
    ("refine pem", ["--refine", "pem"]),
    ("stable", ["--stable"]),
    ("stable + refine pem", ["--stable", "--refine", "pem"]),
]


def load(path):
    d = scipy.io.loadmat(path)
    u = (d["vir"].ravel() * float(np.ravel(d["gtau"])[0]))[:, None]
    y = d["qm"].ravel()[:, None]
    n = u.shape[0]
    h = n // 2
    ue, ye, uv, yv = u[:h], y[:h], u[h:], y[h:]
    mu, my = ue.mean(axis=0), ye.mean(axis=0)
    return ue - mu, ye - my, uv - mu, yv - my


def score(model, u, y):
    """realdata.score without its refusal of rho >= 1 (a marginal model is simulated)."""
    fit, _, _, rho = realdata.score(model, u, y, marginal=True)
    return fit, rho


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mat", required=True, help="DATA_EMPS.mat (fetched; never committed)")
    ap.add_argument("--lifted-cli", default=os.environ.get("LIFTED_CLI"))
    ap.add_argument("--orders", default="2,3,4")
    ap.add_argument("--extra", default="", help="extra arguments for every lifted run")
    ap.add_argument("--json", help="write the results to this file")
    ap.add_argument("--csv", help="also write the estimation half as a CSV here (t,u1,y1)")
    args = ap.parse_args()
    ue, ye, uv, yv = load(args.mat)
    results = []
    with tempfile.TemporaryDirectory() as work:
        csv = args.csv or os.path.join(work, "emps_est.csv")
        realdata.write_csv(csv, ue, ye, 1e-3)
        for order in [int(o) for o in args.orders.split(",")]:
            for name, extra in VARIANTS:
                out = os.path.join(work, "m.json")
                cmd = [args.lifted_cli, "identify", "--method", "n4sid", "--data", csv,
                       "--inputs", "u1", "--outputs", "y1", "--order", str(order), "--out", out]
                cmd += extra + args.extra.split()
                import subprocess
                r = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, **realdata.THREAD_ENV})
                row = {"order": order, "variant": name, "args": extra}
                if r.returncode != 0 or not os.path.exists(out):
                    row.update(status="failed", error=(r.stderr or r.stdout).strip()[-400:])
                else:
                    mats, diag, op = realdata.read_model(out)
                    u, y = uv, yv
                    if op:
                        u = u - np.asarray(op["u0"], dtype=float)
                        y = y - np.asarray(op["y0"], dtype=float)
                    fit, rho = score(mats, u, y)
                    est, _ = score(mats, ue - (np.asarray(op["u0"]) if op else 0),
                                   ye - (np.asarray(op["y0"]) if op else 0))
                    ref = (diag or {}).get("refinement") or {}
                    row.update(status="ok", fit=fit, estimation_fit=est, rho=rho,
                               integrators=(diag or {}).get("integrators"),
                               refinement={k: ref.get(k) for k in ("kept", "judged", "method")},
                               judge=((diag or {}).get("refinement_judge") or {}).get("decided_by"),
                               stable_route=(diag or {}).get("stable_route"),
                               stderr=r.stderr.strip()[-600:])
                    os.remove(out)
                results.append(row)
                fit = row.get("fit")
                print(f"order {order:2d}  {name:22s} "
                      + (f"validation fit {fit:7.2f} %  estimation fit {row['estimation_fit']:7.2f} %  "
                         f"rho {row['rho']:.6f}" if fit is not None else row["status"]), flush=True)
                if row.get("refinement", {}).get("kept"):
                    print(f"    refinement: {row['refinement']}, judged by {row['judge']}", flush=True)
                if row.get("stderr"):
                    print("    " + row["stderr"].replace("\n", "\n    "), flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1)


if __name__ == "__main__":
    main()
