"""The judge's fold refinements at their default limit against 100 iterations
(issue 50, session 49): for each record of the two manifests, `lifted identify`
at its defaults and with `--judge-iterations 100`, interleaved per record, each
model scored on the validation half as `realdata.py` scores it (x0 by least
squares, the model's operating point applied), with the wall time of each run.
Not part of the test suite.

Usage (from the repository root; numpy is all it needs):
    python3 benches/peers/judge_iterations.py target/release/lifted
Prints one line per record: samples, then (order, validation fit, seconds) for
the default and for 100 iterations, and the totals.
"""
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from realdata import manifest_records, validation_fit, write_csv  # noqa: E402


def run(cli, csv, m, p, out, extra):
    t0 = time.time()
    r = subprocess.run(
        [cli, "identify", "--data", csv,
         "--inputs", ",".join(f"u{i + 1}" for i in range(m)),
         "--outputs", ",".join(f"y{i + 1}" for i in range(p)),
         "--out", out] + extra,
        capture_output=True, text=True)
    return r.returncode, time.time() - t0


def main():
    cli = sys.argv[1]
    data_dir = os.environ.get("REALDATA_DIR", "/work/realdata")
    totals = [0.0, 0.0]
    with tempfile.TemporaryDirectory(prefix="judge_iterations_") as wd:
        for manifest, rec, (ue, ye, uv, yv) in manifest_records(data_dir):
            m, p = ue.shape[1], ye.shape[1]
            csv = os.path.join(wd, "est.csv")
            write_csv(csv, ue, ye, rec["ts"])
            row = []
            for k, extra in enumerate([[], ["--judge-iterations", "100"]]):
                out = os.path.join(wd, f"m{k}.json")
                rc, dt = run(cli, csv, m, p, out, extra)
                totals[k] += dt
                if rc:
                    row.append(("refused", round(dt, 2)))
                    continue
                order, fit = validation_fit(out, uv, yv)
                row.append((order, None if fit is None else round(fit, 2), round(dt, 2)))
            print(manifest.split("_")[0], rec["name"], len(ue), "default", row[0],
                  "100", row[1], flush=True)
    print(f"total: default {totals[0]:.1f} s, 100 iterations {totals[1]:.1f} s")


if __name__ == "__main__":
    main()
