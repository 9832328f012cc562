"""Automatic order against every fixed order 1..10 of one lifted method on the
real records (issue 26, session 18): for each record of the two manifests,
`lifted identify --method M --order auto` and `--order k`, each model scored on
the validation half as `realdata.py` scores it (x0 by least squares, the model's
operating point applied). Not part of the test suite.

Usage (from the repository root, after `benches/peers/realdata.sh` has made the
venv; the records' CSV halves are written to a temporary directory):
    benches/peers/.venv-real/bin/python benches/peers/realdata_orders.py \
        target/release/lifted pbsid [extra lifted arguments]
Prints one line per record: the automatic (order, fit), the best fixed fit, and
the fit of every fixed order (None: unstable, F: refused).
"""
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from realdata import load_record, read_model, score, write_csv  # noqa: E402


def main():
    cli, method, extra = sys.argv[1], sys.argv[2], sys.argv[3:]
    data_dir = os.environ.get("REALDATA_DIR", "/work/realdata")
    records = []
    for manifest in ("realdata_records.json", "holdout_records.json"):
        with open(os.path.join(HERE, manifest)) as f:
            records += json.load(f)["records"]
    with tempfile.TemporaryDirectory(prefix="realdata_orders_") as wd:
        for rec in records:
            (ue, ye, uv, yv), _ = load_record(rec, data_dir)
            m, p = ue.shape[1], ye.shape[1]
            csv = os.path.join(wd, f"{rec['name']}_est.csv")
            write_csv(csv, ue, ye, rec["ts"])
            row = {}
            for order in ["auto"] + [str(k) for k in range(1, 11)]:
                out = os.path.join(wd, f"{rec['name']}_{order}.json")
                r = subprocess.run(
                    [cli, "identify", "--method", method, "--data", csv,
                     "--inputs", ",".join(f"u{i + 1}" for i in range(m)),
                     "--outputs", ",".join(f"y{i + 1}" for i in range(p)),
                     "--order", order, "--out", out] + extra,
                    capture_output=True, text=True)
                if r.returncode:
                    row[order] = None
                    continue
                mats, _, op = read_model(out)
                if op:
                    fit = score(mats, uv - np.asarray(op["u0"]), yv - np.asarray(op["y0"]))[0]
                else:
                    fit = score(mats, uv, yv)[0]
                row[order] = (len(mats[0]), None if fit is None else round(fit, 1))
            fixed = [v[1] for o, v in row.items() if o != "auto" and v and v[1] is not None]
            best = max(fixed) if fixed else None
            print(rec["name"], "auto", row["auto"], "best fixed", best,
                  " ".join(f"{o}:{v[1] if v else 'F'}" for o, v in row.items() if o != "auto"),
                  flush=True)


if __name__ == "__main__":
    main()
