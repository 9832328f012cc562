#!/usr/bin/env python3
"""Scale-out benchmark of issue 29: one 2x2 record, order 4, stored as .npy
shards of 6.25e6 samples (u1, u2, y1, y2), identified by

  * the single-process CLI on the same shards (`lifted identify --data ...
    --concat`, the streamed two-pass route on all cores), and
  * lifted.dask.identify on a LocalCluster of 1 and of 2 worker processes
    (one thread each) on 127.0.0.1,

with the whole-run wall time of each and the peak resident memory of each
worker (getrusage), for 4 shards (2.5e7 samples) and 16 shards (1e8):
memory per worker stays that of one shard whatever the number of shards.

  benches/peers/dask_scale.py --dir /work/dask-bench --cli target/release/lifted \
      [--shards 4,16] [--json out.json] [--cli-only] [--repeat 3]

Beside the CLI's whole run it prints each pass's cost per sample (from
the model file's profile) against two bounds measured in the same run on
the same bytes: reading the shards once from the page cache (no parsing)
and copying them in memory, so the distance to the machine's limit is a
ratio ("whole / 2 reads": the two-pass route reads the bytes twice).

Shards are written once (seeded) and reused. Needs numpy, lifted (the
wheel) and dask[distributed].
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import resource
import subprocess
import time

import numpy as np

import lifted
import lifted.dask

SHARD = 6_250_000


def plant() -> lifted.StateSpace:
    a = np.diag([0.9, 0.5, 0.0, 0.0])
    r, th = 0.8, 0.6
    a[2:, 2:] = [[r * np.cos(th), -r * np.sin(th)], [r * np.sin(th), r * np.cos(th)]]
    t = np.array([[2.0, 0.3, -0.2, 0.1], [0.1, 1.5, 0.4, 0.0], [0.0, 0.2, 1.8, -0.3], [0.3, 0.0, 0.1, 1.2]])
    ti = np.linalg.inv(t)
    b = t @ np.array([[1.0, 0.2], [-0.5, 1.0], [0.3, 0.7], [0.8, -0.4]])
    c = np.array([[1.0, 0.5, -0.3, 0.2], [0.0, 0.7, 0.4, -1.0]]) @ ti
    return lifted.StateSpace(t @ a @ ti, b, c, np.array([[0.1, 0.0], [0.0, 0.2]]), 1.0)


def write_shards(folder: pathlib.Path, count: int) -> list[pathlib.Path]:
    folder.mkdir(parents=True, exist_ok=True)
    g = plant()
    rng = np.random.default_rng(29)
    x = np.zeros(4)
    paths = []
    for k in range(count):
        p = folder / f"hist-{k:03d}.npy"
        paths.append(p)
        u = np.where(rng.random((SHARD, 2)) < 0.5, -1.0, 1.0) + 0.3
        noise = 0.05 * rng.standard_normal((SHARD, 2))
        if p.exists():
            continue
        y, xs = lifted.simulate(g, u, x)
        x = np.asarray(g.A) @ xs[-1] + np.asarray(g.B) @ u[-1]
        np.save(p, np.hstack([u, y + noise + 2.0]))
    return paths


def read_bound(paths: list[pathlib.Path]) -> float:
    """Seconds to read the shards' bytes once from the page cache into one
    reused 4 MiB buffer (readinto: the kernel's copy, no parsing), the
    best of three: the floor under one pass over the files on this
    machine."""
    buf = bytearray(4 << 20)
    view = memoryview(buf)
    best = float("inf")
    for _ in range(3):
        t0 = time.perf_counter()
        for p in paths:
            with open(p, "rb", buffering=0) as f:
                while f.readinto(view):
                    pass
        best = min(best, time.perf_counter() - t0)
    return best


def memcpy_bound(nbytes: int) -> float:
    """Seconds to copy `nbytes` in memory (numpy, 200 MB at a time, best
    of three): the machine's memory bandwidth for the same bytes."""
    chunk = min(nbytes, 200_000_000)
    src = np.ones(chunk // 8)
    dst = np.empty_like(src)
    best = float("inf")
    for _ in range(3):
        t0 = time.perf_counter()
        done = 0
        while done < nbytes:
            np.copyto(dst, src)
            done += chunk
        best = min(best, time.perf_counter() - t0)
    return best


def cli_passes(out: pathlib.Path) -> tuple[float, float]:
    """The CLI run's first pass (reading and compression) and second pass
    (the (B, D, x0) regression) from the model file's profile."""
    prof = json.loads(out.read_text())["diagnostics"].get("profile", {})
    return float(prof.get("read_s", float("nan"))), float(prof.get("second_pass_s", float("nan")))


def cli_run(cli: str, paths: list[pathlib.Path], out: pathlib.Path) -> tuple[float, float]:
    """Wall time and peak resident memory (MB) of one CLI run. The peak is
    GNU time's (%M) when /usr/bin/time exists: the rusage of a child that
    Python forks counts the pages of the forked interpreter before exec."""
    cmd = [cli, "identify", "--method", "n4sid", "--order", "4", "--horizon", "10", "--concat",
           "--columns", "u1,u2,y1,y2", "--inputs", "u1,u2", "--outputs", "y1,y2", "--ts", "1", "--out", str(out)]
    for p in paths:
        cmd += ["--data", str(p)]
    timed = os.path.exists("/usr/bin/time")
    if timed:
        cmd = ["/usr/bin/time", "-f", "peak-kb %M"] + cmd
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    err = proc.stderr.read().decode() if proc.stderr else ""
    if status != 0:
        raise RuntimeError(f"{cmd}: {err or status}")
    peak = [ln for ln in err.splitlines() if ln.startswith("peak-kb ")]
    if timed and peak:
        return wall, float(peak[-1].split()[1]) / 1024
    return wall, usage.ru_maxrss / 1024


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def dask_run(paths: list[pathlib.Path], workers: int) -> tuple[float, list[float], dict]:
    from dask.distributed import Client, LocalCluster

    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                      host="127.0.0.1", dashboard_address=None) as cluster, Client(cluster) as client:
        t0 = time.perf_counter()
        fit = lifted.dask.identify(paths, inputs=[0, 1], outputs=[2, 3], order=4,
                                   past=10, future=10, client=client)
        wall = time.perf_counter() - t0
        rss = list(client.run(peak_rss_mb).values())
    return wall, rss, fit


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--dir", default="/work/dask-bench")
    ap.add_argument("--cli", default="target/release/lifted")
    ap.add_argument("--shards", default="4,16")
    ap.add_argument("--json")
    ap.add_argument("--cli-only", action="store_true",
                    help="time the CLI and the bounds only (no Dask)")
    ap.add_argument("--repeat", type=int, default=1,
                    help="CLI runs per size; the fastest is reported")
    args = ap.parse_args()
    rows = []
    for count in [int(s) for s in args.shards.split(",")]:
        paths = write_shards(pathlib.Path(args.dir), count)[:count]
        n = count * SHARD
        out = pathlib.Path(args.dir) / "cli-model.json"
        runs = []
        for _ in range(max(1, args.repeat)):
            wall, rss = cli_run(args.cli, paths, out)
            runs.append((wall, rss, *cli_passes(out)))
        cli_wall, cli_rss, first_s, second_s = min(runs)
        nbytes = sum(p.stat().st_size for p in paths)
        read_s, copy_s = read_bound(paths), memcpy_bound(nbytes)
        row = {"samples": n, "shards": count, "cli_s": cli_wall, "cli_peak_mb": cli_rss,
               "first_pass_s": first_s, "second_pass_s": second_s,
               "read_bound_s": read_s, "memcpy_bound_s": copy_s}
        ns = 1e9 / n
        print(f"{n:.2e} samples, {nbytes / 1e9:.2f} GB: whole {cli_wall * ns:.1f} ns/sample "
              f"(first pass {first_s * ns:.1f}, second {second_s * ns:.1f}); "
              f"reading the bytes once {read_s * ns:.1f} ns/sample, copying them {copy_s * ns:.1f}; "
              f"whole run / two reads of the bytes = {cli_wall / (2 * read_s):.1f}x")
        if args.cli_only:
            rows.append(row)
            continue
        for w in (1, 2):
            wall, rss, fit = dask_run(paths, w)
            row[f"dask{w}_s"] = wall
            row[f"dask{w}_worker_peak_mb"] = max(rss)
            poles = np.sort_complex(np.linalg.eigvals(np.asarray(fit.model.A) if hasattr(fit, "model") else np.asarray(fit["model"].A)))
            row[f"dask{w}_poles"] = [str(p) for p in poles]
        rows.append(row)
        print(json.dumps(row))
    cpu = os.cpu_count()
    print(f"\n| samples | CLI whole (ns/sample) | first pass | second pass | read of the bytes | copy of the bytes | whole / 2 reads | CLI peak MB |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        ns = 1e9 / r["samples"]
        print(f"| {r['samples']:.2e} | {r['cli_s']:.2f} s ({r['cli_s'] * ns:.0f}) | {r['first_pass_s']:.2f} s "
              f"| {r['second_pass_s']:.2f} s | {r['read_bound_s']:.2f} s | {r['memcpy_bound_s']:.2f} s "
              f"| {r['cli_s'] / (2 * r['read_bound_s']):.1f} | {r['cli_peak_mb']:.0f} |")
    if args.cli_only:
        if args.json:
            pathlib.Path(args.json).write_text(json.dumps(rows, indent=1))
        return
    print(f"\n| samples | shards | CLI (1 process, {cpu} cores) | Dask 1 worker | Dask 2 workers | peak MB per worker (1 / 2 workers) | CLI peak MB |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['samples']:.2e} | {r['shards']} | {r['cli_s']:.1f} s | {r['dask1_s']:.1f} s | {r['dask2_s']:.1f} s "
              f"| {r['dask1_worker_peak_mb']:.0f} / {r['dask2_worker_peak_mb']:.0f} | {r['cli_peak_mb']:.0f} |")
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
