#!/usr/bin/env python3
"""Process models with dead time on the real records (issue 49): lifted's
``procest`` structures (P1D, P2D, P2DZ, P2DU) with a zero-order hold and with a
first-order hold between the input samples, beside lifted's OE [2 2 1] at the
same protocol. No peer: SIPPY has no process models and MATLAB's ``procest``
is not on this machine.

Not part of the test suite. Protocol (realdata.py's): estimation = first half
of the record, validation = second half, the estimation means removed from
both; the model is fitted on the estimation half and its simulation scored on
the validation half with x0 by least squares (fit = 100 (1 - ||y - y_hat|| /
||y - mean y||), mean over the outputs; "unstable" for rho >= 1). Records with
one output (several inputs allowed: one process model per input-output pair).

    benches/peers/.venv-real/bin/python benches/peers/process_real.py \\
        [--records dryer,heating_system] [--kinds p1d,p2d] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import realdata  # noqa: E402  (the records, the split and the score)

KINDS = ["p1d", "p2d", "p2dz", "p2du"]


def state_space(fit) -> tuple:
    m = fit.model
    return tuple(np.atleast_2d(np.asarray(x, dtype=float)) for x in (m.A, m.B, m.C, m.D))


def run(fitter, uv, yv) -> dict:
    t0 = time.perf_counter()
    try:
        fit = fitter()
        seconds = time.perf_counter() - t0
        f, _, status, rho = realdata.score(state_space(fit), uv, yv)
        return {"fit": f, "status": status, "rho": rho, "seconds": seconds}
    except Exception as e:  # noqa: BLE001 - a failed fit is a data point
        return {"fit": None, "status": f"failed: {type(e).__name__}: {str(e)[:100]}",
                "seconds": time.perf_counter() - t0}


def cell(r: dict) -> str:
    if r["fit"] is not None:
        return f"{r['fit']:.1f}"
    return "unstable" if r["status"] == "unstable" else "failed"


def main() -> None:
    import lifted

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--manifest", default=os.path.join(realdata.HERE, "realdata_records.json"))
    ap.add_argument("--data-dir", default=os.environ.get("REALDATA_DIR", "/work/realdata"))
    ap.add_argument("--records")
    ap.add_argument("--kinds", default=",".join(KINDS))
    ap.add_argument("--json")
    args = ap.parse_args()
    recs = [r for r in json.load(open(args.manifest))["records"] if len(r["outputs"]) == 1]
    if args.records:
        keep = set(args.records.split(","))
        recs = [r for r in recs if r["name"] in keep]
    kinds = args.kinds.split(",")
    rows = []
    for rec in recs:
        (ue, ye, uv, yv), _ = realdata.load_record(rec, args.data_dir)
        ts = float(rec.get("ts", 1.0))
        oe = run(lambda: lifted.oe(ue, ye, [2, 2, 1], dt=ts), uv, yv)
        for kind in kinds:
            row = {"record": rec["name"], "kind": kind, "oe": oe}
            for hold in ("zoh", "foh"):
                row[hold] = run(lambda: lifted.procest(ue, ye, kind, dt=ts, intersample=hold), uv, yv)
            rows.append(row)
            print(json.dumps({"record": rec["name"], "kind": kind, "zoh": cell(row["zoh"]),
                              "foh": cell(row["foh"]), "oe": cell(oe)}), flush=True)
    print("\n| record | structure | ZOH | FOH | FOH − ZOH | OE [2 2 1] |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        z, f = r["zoh"]["fit"], r["foh"]["fit"]
        diff = f"{f - z:+.1f}" if z is not None and f is not None else ""
        print(f"| {r['record']} | {r['kind'].upper()} | {cell(r['zoh'])} | {cell(r['foh'])} | {diff} | {cell(r['oe'])} |")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
