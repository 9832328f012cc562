#!/usr/bin/env python3
"""lifted, SLICOT (IB01AD/IB01BD) and SIPPY side by side, interleaved runs.

Run through ``benches/peers/slicot.sh`` (it installs gfortran/OpenBLAS, builds
SLICOT's ``libslicot.a``, the driver ``slicot_ib01`` and the lifted binaries).
Not part of the test suite.

Data: the recipe of ``peers.py`` (2 inputs, 2 outputs, order 4, random binary
inputs, output noise 0.1, seed ``peers.SEED``), simulated once per N and written
three ways into ``--data-dir``: CSV (lifted, SIPPY), raw little-endian float64
row-major N x 4 ``.bin`` (SLICOT driver) and ``.npy`` (lifted CLI, once it
reads .npy). Every tool identifies order 4 with 20 block rows.

Runs: ``--runs K`` rounds (default 5); in round r every tool runs once, always
in the same order, each in its own process under ``/usr/bin/time -v`` with
single-threaded BLAS (OPENBLAS_NUM_THREADS=1). A tool that fails or times out
is not run again at that N. Every model is scored with ``peers.freq_error``
against the true system; an FR error above ``--max-fr-error`` (1e-2) marks the
run as a failed identification (its time is shown but flagged, no ratio).

SLICOT runs under two OpenBLAS kernel choices: the default (what the
DYNAMIC_ARCH OpenBLAS detects) and a forced OPENBLAS_CORETYPE: SkylakeX (the
AVX-512 kernels) when /proc/cpuinfo has avx512f, otherwise Haswell (AVX2), and
the AVX-512 figure is reported as not measurable. The kernel actually used is
read from OPENBLAS_VERBOSE=2's "Core: ..." line.
"""
import argparse
import datetime
import json
import os
import platform
import statistics
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import peers  # noqa: E402  (the data recipe, freq_error, cli_model, SIPPY runner)

BASE_TOOL = "lifted (stream, 1 thread)"


def size_arg(text):
    """Accepts 10000, 1e4, 1_000_000."""
    return int(float(text.replace("_", "")))


def parse_args():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("sizes", nargs="*", type=size_arg, default=[10_000, 100_000, 1_000_000],
                    help="record lengths N (default 1e4 1e5 1e6)")
    ap.add_argument("--lifted", required=True, help="peer_lifted example binary")
    ap.add_argument("--cli", help="lifted CLI binary (rows skipped without it)")
    ap.add_argument("--slicot", help="slicot_ib01 driver (SLICOT rows skipped without it)")
    ap.add_argument("--slicot-src", help="SLICOT-Reference checkout (for its commit)")
    ap.add_argument("--slicot-note", default="",
                    help="why SLICOT is missing, printed instead of its rows")
    ap.add_argument("--runs", type=int, default=5, help="interleaved rounds (default 5)")
    ap.add_argument("--sippy-max", type=size_arg, default=1_000_000,
                    help="largest N for SIPPY (default 1e6)")
    ap.add_argument("--sippy-timeout", type=float, default=300.0,
                    help="seconds per SIPPY run before it is abandoned (default 300)")
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds per other run")
    ap.add_argument("--block", type=int, default=65536,
                    help="rows per SLICOT sequential batch (default 65536)")
    ap.add_argument("--forced-core", help="OPENBLAS_CORETYPE of the forced SLICOT rows "
                    "(default SkylakeX with avx512f, else Haswell)")
    ap.add_argument("--max-fr-error", type=float, default=1e-2,
                    help="FR error above which an identification counts as failed")
    ap.add_argument("--data-dir", default="benches/peers/data")
    ap.add_argument("--json", help="write every run and the summary to this file")
    return ap.parse_args()


# ---------------------------------------------------------------- environment

def sh(cmd):
    """stdout of a shell command, stripped ('' on failure)."""
    try:
        return subprocess.run(cmd, shell=True, capture_output=True, text=True,
                              timeout=30).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""


def cpu_flags():
    """The flags of the first processor in /proc/cpuinfo."""
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("flags"):
                    return set(line.split(":", 1)[1].split())
    except OSError:
        pass
    return set()


def machine_info(args):
    """What the README section records about the machine and the builds."""
    flags = cpu_flags()
    info = {
        "date_utc": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "nproc": os.cpu_count(),
        "uptime_start": sh("uptime"),
        "cpu": sh("lscpu | sed -n 's/^Model name: *//p'") or platform.processor(),
        "avx2": "avx2" in flags,
        "avx512f": "avx512f" in flags,
        "gfortran": sh("gfortran --version | head -1"),
        "openblas": sh("dpkg-query -W -f='${Version}' libopenblas0-pthread 2>/dev/null") or
        sh("dpkg-query -W -f='${Version}' libopenblas0 2>/dev/null"),
        "python": platform.python_version(),
        "numpy": np.__version__,
    }
    try:
        from importlib.metadata import version
        info["sippy_unipi"] = version("sippy-unipi")
    except Exception:  # noqa: BLE001  (not installed: SIPPY rows fail and say so)
        info["sippy_unipi"] = None
    if args.slicot_src:
        info["slicot_commit"] = sh(f"git -C '{args.slicot_src}' rev-parse HEAD") or "unknown"
    return info


# ---------------------------------------------------------------- data

def make_data(n, data_dir):
    """Writes peers_N.csv, peers_N.bin and peers_N.npy once; returns their paths."""
    paths = {ext: os.path.join(data_dir, f"peers_{n}.{ext}") for ext in ("csv", "bin", "npy")}
    if all(os.path.exists(p) for p in paths.values()):
        return paths
    data = peers.simulate(n)
    peers.write_csv(data, paths["csv"])
    np.ascontiguousarray(data, dtype="<f8").tofile(paths["bin"])
    np.save(paths["npy"], np.ascontiguousarray(data, dtype=np.float64))
    return paths


# ---------------------------------------------------------------- tools

def tool_list(args, n, paths, forced_core):
    """(name, command, extra environment, kind, timeout) of every tool at this N."""
    lifted, tools = args.lifted, []
    csv = paths["csv"]
    tools.append((BASE_TOOL, [lifted, csv, "--stream", "--threads", "1"], {}, "json", args.timeout))
    tools.append(("lifted (stream, 2 threads)", [lifted, csv, "--stream", "--threads", "2"], {},
                  "json", args.timeout))
    tools.append(("lifted (in memory, auto)", [lifted, csv], {}, "json", args.timeout))
    # SLICOT's driver runs IB01BD with JOBCK='N' (no covariances, no Kalman
    # gain); this row skips lifted's noise model likewise.
    tools.append(("lifted (stream, 1 thread, no noise model)",
                  [lifted, csv, "--stream", "--threads", "1", "--no-noise-model"], {}, "json",
                  args.timeout))
    if args.cli:
        common = ["--inputs", "u1,u2", "--outputs", "y1,y2", "--ts", "1", "--order",
                  str(peers.ORDER), "--horizon", str(peers.BLOCK_ROWS)]
        for name, data, extra in (("lifted CLI (CSV, whole run)", csv, []),
                                  ("lifted CLI (.npy, whole run)", paths["npy"],
                                   ["--columns", "u1,u2,y1,y2"])):
            out = os.path.join(args.data_dir, f"cli_model_{n}_{'npy' if extra else 'csv'}.json")
            cmd = [args.cli, "identify", "--method", "n4sid", "--data", data] + extra + common + \
                ["--out", out]
            tools.append((name, cmd, {"MODEL_OUT": out}, "cli", args.timeout))
    if args.slicot:
        for alg in ("C", "Q"):
            for core in (None, forced_core):
                label = f"SLICOT IB01AD ALG='{alg}', seq. batches ({'default kernel' if core is None else 'OPENBLAS_CORETYPE=' + core})"
                env = {"OPENBLAS_VERBOSE": "2"}
                if core:
                    env["OPENBLAS_CORETYPE"] = core
                cmd = [args.slicot, paths["bin"], "--alg", alg, "--block", str(args.block)]
                tools.append((label, cmd, env, "json", args.timeout))
    if n <= args.sippy_max:
        tools.append(("SIPPY N4SID", [sys.executable, peers.__file__, "--run", "sippy",
                                      "--csv", csv], {}, "json", args.sippy_timeout))
    return tools


def timed(cmd, env, timeout):
    """peers.timed with single-threaded BLAS and the tool's extra environment."""
    full_env = dict(os.environ, OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1",
                    OMP_NUM_THREADS="1", **{k: v for k, v in env.items() if k != "MODEL_OUT"})
    return peers.timed(cmd, timeout, full_env)


def run_once(tool, max_fr):
    """One run of one tool: a dict with the times, peak RSS, FR error, kernel, status."""
    name, cmd, env, kind, timeout = tool
    out, err, wall, peak, status = timed(cmd, env, timeout)
    row = {"tool": name, "identify_s": None, "wall_s": wall, "peak_mb": peak,
           "fr_error": None, "kernel": None, "status": status}
    if out is None and kind == "cli" and "--columns" in cmd and \
            ("unexpected argument" in err or "--columns" in err):
        row["status"] = "skipped: this CLI rejects --columns (no .npy input yet)"
    for line in err.splitlines():
        if line.startswith("Core:"):
            row["kernel"] = line.split(":", 1)[1].strip()
    if out is None:
        return row
    try:
        if kind == "cli":
            with open(env["MODEL_OUT"]) as fh:
                model = peers.cli_model(json.load(fh))
        else:
            model = json.loads(out.strip().splitlines()[-1])
            if "error" in model:
                row["status"] = f"error: {model['error']}"
                return row
            row["identify_s"] = model.get("identify_s")
            row["read_s"] = model.get("read_s")
            for k in ("iwarn_ib01ad", "iwarn_ib01ad_any", "iwarn_ib01bd", "blocks", "block_rows",
                      "ldwork", "ldwork_opt_ib01ad", "ldwork_opt_ib01bd"):
                if k in model:
                    row[k] = model[k]
        row["fr_error"] = peers.freq_error(model)
    except (OSError, ValueError, KeyError, IndexError, TypeError, np.linalg.LinAlgError) as e:
        row["status"] = f"unreadable model: {e}"
        return row
    if not row["fr_error"] <= max_fr:
        row["status"] = f"FAILED identification (FR error {row['fr_error']:.2e} > {max_fr:g})"
    return row


# ---------------------------------------------------------------- summary

def summarise(n, runs, tools):
    """Per tool: min/median identify and wall, max peak RSS, FR error, kernel, status."""
    out = []
    for name, *_ in tools:
        rs = [r for r in runs if r["tool"] == name]
        # failed identifications keep their times (flagged, no ratio)
        ok = [r for r in rs if r["status"] == "ok" or r["status"].startswith("FAILED")]
        ident = [r["identify_s"] for r in ok if r["identify_s"] is not None]
        walls = [r["wall_s"] for r in ok]
        frs = sorted({round(r["fr_error"], 14) for r in rs if r["fr_error"] is not None})
        kernels = sorted({r["kernel"] for r in rs if r["kernel"]})
        bad = [r["status"] for r in rs if r["status"] != "ok"]
        out.append({
            "n": n, "tool": name, "runs": len(ok), "attempts": len(rs),
            "identify_min": min(ident) if ident else None,
            "identify_median": statistics.median(ident) if ident else None,
            "wall_min": min(walls) if walls else None,
            "wall_median": statistics.median(walls) if walls else None,
            "peak_mb": max((r["peak_mb"] for r in ok), default=None),
            "fr_error": frs[0] if len(frs) == 1 else (frs or None),
            "kernel": ", ".join(kernels) or None,
            "status": "ok" if not bad else bad[0],
        })
    return out


def fmt(x, spec=".3g"):
    return "–" if x is None else format(x, spec)


def table(summary, slicot_note=""):
    """Markdown table of one N."""
    base = next((s for s in summary if s["tool"] == BASE_TOOL and s["runs"]), None)
    lines = ["| tool | runs | identify min (s) | identify median (s) | × lifted (identify) | "
             "wall min (s) | wall median (s) | × lifted (wall) | peak RSS (MB) | FR error | "
             "OpenBLAS core | notes |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for s in summary:
        ratio = wratio = None
        if base and s["runs"] and s["status"] == "ok":
            if s["identify_min"] is not None and base["identify_min"]:
                ratio = s["identify_min"] / base["identify_min"]
            if base["wall_min"]:
                wratio = s["wall_min"] / base["wall_min"]
        fr = s["fr_error"]
        fr = fmt(fr, ".2e") if not isinstance(fr, list) else " / ".join(f"{x:.2e}" for x in fr)
        note = "" if s["status"] == "ok" else s["status"]
        if s["runs"] < s["attempts"] and s["status"] == "ok":
            note = f"{s['attempts'] - s['runs']} run(s) failed"
        lines.append(
            f"| {s['tool']} | {s['runs']} | {fmt(s['identify_min'], '.4g')} | "
            f"{fmt(s['identify_median'], '.4g')} | {fmt(ratio, '.3g')} | {fmt(s['wall_min'])} | "
            f"{fmt(s['wall_median'])} | {fmt(wratio, '.3g')} | {fmt(s['peak_mb'], '.1f')} | {fr} | "
            f"{s['kernel'] or ''} | {note.replace('|', '/')} |")
    if slicot_note:
        lines.append(f"| SLICOT IB01AD/IB01BD | 0 | – | – | – | – | – | – | – | – | | {slicot_note} |")
    return "\n".join(lines)


def main():
    args = parse_args()
    os.makedirs(args.data_dir, exist_ok=True)
    info = machine_info(args)
    forced = args.forced_core or ("SkylakeX" if info["avx512f"] else "Haswell")
    info["forced_core"] = forced
    print(f"date: {info['date_utc']}  nproc: {info['nproc']}  uptime: {info['uptime_start']}")
    print(f"CPU: {info['cpu']}  avx2: {info['avx2']}  avx512f: {info['avx512f']}")
    print(f"{info['gfortran']}  OpenBLAS {info['openblas']}  SLICOT "
          f"{info.get('slicot_commit', '-')}  sippy-unipi {info['sippy_unipi']}")
    if not info["avx512f"] and forced != "SkylakeX":
        print("note: this CPU has no AVX-512 (no avx512f in /proc/cpuinfo): the SkylakeX "
              f"(AVX-512) OpenBLAS kernels cannot run here; forced kernel = {forced}.")
    all_runs, all_summary, tables = [], [], []
    for n in args.sizes:
        paths = make_data(n, args.data_dir)
        tools = tool_list(args, n, paths, forced)
        dead = set()
        runs = []
        for r in range(1, args.runs + 1):
            for tool in tools:
                if tool[0] in dead:
                    continue
                row = run_once(tool, args.max_fr_error)
                row.update(n=n, round=r)
                runs.append(row)
                print(json.dumps(row), file=sys.stderr, flush=True)
                if row["status"] != "ok" and not row["status"].startswith("FAILED"):
                    dead.add(tool[0])
        summary = summarise(n, runs, tools)
        all_runs += runs
        all_summary += summary
        text = f"N = {n:.0e} ({n} samples), {args.runs} interleaved rounds\n\n" + \
            table(summary, "" if args.slicot else args.slicot_note)
        tables.append(text)
        print("\n" + text + "\n", flush=True)
    info["uptime_end"] = sh("uptime")
    print(f"uptime at the end: {info['uptime_end']}")
    if not info["avx512f"]:
        print(f"AVX-512 (OPENBLAS_CORETYPE=SkylakeX) not measured: this CPU ({info['cpu']}) "
              "has no avx512f.")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"info": info, "args": vars(args), "summary": all_summary,
                       "runs": all_runs}, fh, indent=1)


if __name__ == "__main__":
    main()
