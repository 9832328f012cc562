"""One-step prediction against simulation on the real records (issue 26,
session 20: "A Kalman gain that predicts"): for every record of both
manifests, `lifted identify` with its defaults on the estimation half, then
`lifted validate` on the estimation and on the validation half (halves and
scoring as `realdata.py`: estimation means removed). Prints per record how
many outputs predict one step ahead worse than the model's simulation, and
the (simulation, one-step) fits. Not part of the test suite.

Usage (from the repository root, after `benches/peers/realdata.sh` has made
the venv):
    benches/peers/.venv-real/bin/python benches/peers/realdata_gain.py \
        target/release/lifted
"""
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from realdata import load_record, write_csv  # noqa: E402


def fits(cli, model, data):
    out = subprocess.run([cli, "validate", "--model", model, "--data", data],
                         capture_output=True, text=True).stdout.splitlines()
    rows = [line.split() for line in out if line.startswith("y") and "n/a" not in line]
    return [(float(r[1]), float(r[2])) for r in rows]


def main():
    cli = sys.argv[1]
    data_dir = os.environ.get("REALDATA_DIR", "/work/realdata")
    with tempfile.TemporaryDirectory(prefix="realdata_gain_") as wd:
        for manifest in ("realdata_records.json", "holdout_records.json"):
            with open(os.path.join(HERE, manifest)) as f:
                records = json.load(f)["records"]
            for rec in records:
                (ue, ye, uv, yv), _ = load_record(rec, data_dir)
                m, p = ue.shape[1], ye.shape[1]
                est = os.path.join(wd, f"{rec['name']}_est.csv")
                val = os.path.join(wd, f"{rec['name']}_val.csv")
                write_csv(est, ue, ye, rec["ts"])
                write_csv(val, uv, yv, rec["ts"])
                model = os.path.join(wd, f"{rec['name']}.json")
                r = subprocess.run([cli, "identify", "--data", est, "--out", model,
                                    "--inputs", ",".join(f"u{i + 1}" for i in range(m)),
                                    "--outputs", ",".join(f"y{i + 1}" for i in range(p))],
                                   capture_output=True, text=True)
                if r.returncode:
                    print(rec["name"], "failed", r.stderr.strip()[-200:])
                    continue
                e, v = fits(cli, model, est), fits(cli, model, val)
                below = lambda fs: sum(1 for s, o in fs if o < s)  # noqa: E731
                fmt = lambda fs: [(round(s, 1), round(o, 1)) for s, o in fs]  # noqa: E731
                print(f"{rec['name']:18s} {p}: one-step below simulation on est {below(e)}, "
                      f"val {below(v)}  est {fmt(e)} val {fmt(v)}", flush=True)


if __name__ == "__main__":
    main()
