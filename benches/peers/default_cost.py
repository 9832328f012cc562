#!/usr/bin/env python3
"""The default's cost against N (issue 50): `lifted identify` at its defaults
(automatic order and horizon, default refinement) on prefixes of one seeded
2x2 record, wall time per N with where it went, and the model's
frequency-response error against the true plant.

    python3 benches/peers/default_cost.py --cli target/release/lifted \
        [--dir /tmp/default-cost] [--sizes 1e4,2e4,...] [--repeat 1] [--json out.json]
        [--extra "--judge-iterations 100"]

The record is the peer system of ``csv_data.py`` (2 inputs, 2 outputs, order 4,
random binary inputs, output noise of standard deviation 0.1; columns
t,u1,u2,y1,y2), written once as a .npy file of the largest N (no numpy needed:
the rows of ``csv_data.py``) and cut into prefixes, so every N sees the
same first samples. Records up to 16 MiB are identified in memory; larger
files take the streamed two-pass route (``diagnostics.route``). Per N the
script prints the best wall time of ``--repeat`` runs, the phases of
``--profile`` over 0.05 s, what the default refinement decided and the
relative frequency-response error ||G - G0|| / ||G0|| over 200 frequencies
(pure Python: 4x4 complex solves).
"""

from __future__ import annotations

import argparse
import cmath
import json
import math
import os
import pathlib
import subprocess
import sys
import tempfile
import time

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import csv_data  # noqa: E402  (the record's recipe and .npy header)

SIZES = "1e4,2e4,5e4,1e5,1.5e5,1.9e5,2.1e5,3e5,4e5,5e5,1e6,3e6"
ROW = 5 * 8


def write_record(path: pathlib.Path, n: int) -> None:
    """The first n rows of csv_data.py's record as .npy (its CSV discarded)."""
    saved = sys.argv
    try:
        sys.argv = ["csv_data.py", str(n), os.devnull, str(path)]
        csv_data.main()
    finally:
        sys.argv = saved


def prefix(full: pathlib.Path, n: int, out: pathlib.Path) -> None:
    """The first n rows of the .npy file `full` (C order, 5 float64 columns)."""
    with open(full, "rb") as f:
        head = f.read(10)
        hlen = int.from_bytes(head[8:10], "little")
        f.seek(10 + hlen)
        body = f.read(n * ROW)
    with open(out, "wb") as g:
        g.write(csv_data.npy_header(n, 5))
        g.write(body)


def solve(m: list[list[complex]], b: list[list[complex]]) -> list[list[complex]]:
    """m^-1 b by Gaussian elimination with partial pivoting."""
    n = len(m)
    a = [row[:] + bb[:] for row, bb in zip(m, b)]
    for k in range(n):
        p = max(range(k, n), key=lambda i: abs(a[i][k]))
        a[k], a[p] = a[p], a[k]
        for i in range(k + 1, n):
            f = a[i][k] / a[k][k]
            for j in range(k, len(a[i])):
                a[i][j] -= f * a[k][j]
    x = [[0j] * len(b[0]) for _ in range(n)]
    for i in reversed(range(n)):
        for c in range(len(b[0])):
            s = a[i][n + c] - sum(a[i][j] * x[j][c] for j in range(i + 1, n))
            x[i][c] = s / a[i][i]
    return x


def response(a, b, c, d, w):
    n = len(a)
    z = cmath.exp(1j * w)
    m = [[(z if i == j else 0) - a[i][j] for j in range(n)] for i in range(n)]
    x = solve(m, [[complex(v) for v in row] for row in b]) if n else []
    rows, cols = len(c), len(b[0]) if n else len(d[0])
    return [
        [d[i][j] + sum(c[i][k] * x[k][j] for k in range(n)) for j in range(cols)]
        for i in range(rows)
    ]


def fr_error(model: dict) -> float:
    a0 = csv_data.A
    b0 = csv_data.B
    c0 = csv_data.C
    d0 = [[0.0, 0.0], [0.0, 0.0]]
    num = den = 0.0
    for k in range(200):
        w = 0.001 + (math.pi - 0.001) * k / 199
        g0 = response(a0, b0, c0, d0, w)
        g = response(model["a"], model["b"], model["c"], model["d"], w)
        for i in range(2):
            for j in range(2):
                num += abs(g[i][j] - g0[i][j]) ** 2
                den += abs(g0[i][j]) ** 2
    return math.sqrt(num / den)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cli", required=True, help="the lifted binary")
    ap.add_argument("--dir", default=None, help="where the records go (default: a temporary folder)")
    ap.add_argument("--sizes", default=SIZES)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--json", default=None)
    ap.add_argument("--extra", default="", help="more `lifted identify` arguments, e.g. \"--judge-iterations 100\"")
    args = ap.parse_args()
    sizes = [int(float(s)) for s in args.sizes.split(",")]
    folder = pathlib.Path(args.dir or tempfile.mkdtemp(prefix="default-cost-"))
    folder.mkdir(parents=True, exist_ok=True)
    full = folder / f"record_{max(sizes)}.npy"
    if not full.exists():
        write_record(full, max(sizes))
    rows = []
    print(f"{'N':>9} {'wall s':>7} {'route':>9} {'FR error':>9}  phases over 0.05 s; refinement")
    for n in sizes:
        path = folder / f"p_{n}.npy"
        if not path.exists():
            prefix(full, n, path)
        out = folder / f"m_{n}.json"
        best = math.inf
        for _ in range(args.repeat):
            t = time.perf_counter()
            subprocess.run(
                [args.cli, "identify", "--data", str(path), "--columns", "t,u1,u2,y1,y2",
                 "--inputs", "u1,u2", "--outputs", "y1,y2", "--ts", "1", "--out", str(out)]
                + args.extra.split(),
                check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            )
            best = min(best, time.perf_counter() - t)
        m = json.loads(out.read_text())
        dg = m.get("diagnostics", {})
        phases = {k[:-2]: round(v, 2) for k, v in (dg.get("profile") or {}).items()
                  if k != "identify_s" and v > 0.05}
        route = "streamed" if "stream" in str(dg.get("route", "")) else "memory"
        err = fr_error(m)
        decision = str(dg.get("refinement_decision", ""))
        rows.append({"samples": n, "wall_s": best, "route": route, "fr_error": err,
                     "phases": phases, "refinement": decision})
        print(f"{n:>9} {best:>7.2f} {route:>9} {err:>9.5f}  {phases}; {decision[:60]}")
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
