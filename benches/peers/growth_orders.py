"""The automatic order of PBSID, SSARX, IV and N4SID as the record grows
(issue 26, session 18): a 2x2 plant of order 4 (poles 0.9 ± 0.2j, 0.7, 0.5),
binary inputs, output noise of 10 % (AR(1) 0.8), N = 1e4, 1e5, 1e6; the
chosen order, the frequency-response error against the truth and the wall
time of `lifted identify` (PBSID/SSARX with --feedthrough: the plant is
open loop). Not part of the test suite. Usage (repository root):
    benches/peers/.venv-real/bin/python benches/peers/growth_orders.py target/release/lifted
"""
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
from scipy.signal import dlsim, lfilter

A = np.array([[0.9, 0.2, 0, 0], [-0.2, 0.9, 0, 0], [0, 0, 0.7, 0], [0, 0, 0, 0.5]])
B = np.array([[1, 0.2], [0.3, 0.8], [0.5, -0.6], [0.4, 1.0]])
C = np.array([[1, 0, 0.6, 0.3], [0.2, 0.7, -0.4, 0.9]])
D = np.zeros((2, 2))


def fr(a, b, c, d, w):
    n = a.shape[0]
    return np.array([c @ np.linalg.solve(np.exp(1j * x) * np.eye(n) - a, b) + d for x in w])


def main():
    cli = sys.argv[1]
    w = np.linspace(0.001, np.pi, 200)
    truth = fr(A, B, C, D, w)
    rng = np.random.default_rng(0)
    with tempfile.TemporaryDirectory(prefix="growth_orders_") as wd:
        csv, out = os.path.join(wd, "g.csv"), os.path.join(wd, "g.json")
        for n in (10_000, 100_000, 1_000_000):
            u = np.sign(rng.normal(size=(n, 2)))
            _, y, _ = dlsim((A, B, C, D, 1), u)
            v = lfilter([1], [1, -0.8], rng.normal(size=(n, 2)), axis=0)
            y = y + 0.1 * y.std(0) * v / v.std(0)
            np.savetxt(csv, np.column_stack([u, y]), delimiter=",", header="u1,u2,y1,y2",
                       comments="", fmt="%.10g")
            for method in ("pbsid", "ssarx", "pbsid-rowwise", "iv", "n4sid"):
                extra = ["--feedthrough"] if method in ("pbsid", "ssarx", "pbsid-rowwise") else []
                t0 = time.time()
                r = subprocess.run([cli, "identify", "--method", method, "--data", csv,
                                    "--inputs", "u1,u2", "--outputs", "y1,y2", "--ts", "1",
                                    "--out", out] + extra, capture_output=True, text=True)
                dt = time.time() - t0
                if r.returncode:
                    print(n, method, "refused:", r.stderr.strip()[-150:], flush=True)
                    continue
                with open(out) as f:
                    m = json.load(f)
                mats = [np.atleast_2d(np.array(m[k], float)) for k in "abcd"]
                err = np.sqrt(np.sum(abs(fr(*mats, w) - truth) ** 2) / np.sum(abs(truth) ** 2))
                print(n, method, "order", len(m["a"]), "FR %.4f" % err, "%.1f s" % dt, flush=True)


if __name__ == "__main__":
    main()
