"""`scripts/bench kernels`: the Google Benchmark kernels, summarised.

Runs build/bench/hardrod_bench_kernels with JSON output and writes kernels.csv, kernels.md,
kernels.json (medians over repetitions, the benchmarks' counters) and step_vs_floor.csv (the
full time step against the integration-only floor). It does not build the benchmarks.
"""

import datetime
import os
import re
import shlex
import statistics
import subprocess
import sys

from .common import (BENCH_KERNELS, ROOT, busy_warning, common_arguments, ensure_built, finite, g, invocation,
                     machine_info, make_outdir, markdown_table, relpath, report_header, write_csv, write_json,
                     write_text)
from .outputs import load_json

HELP = "Google Benchmark kernels: CSV, markdown, full step vs integration floor"
DESCRIPTION = ("Run build/bench/hardrod_bench_kernels with JSON output; write kernels.csv "
               "(name, ns per item, items/s, counters), kernels.md and the BM_TimeStep / "
               "BM_IntegrateOnly ratio. Extra arguments after -- go to the benchmark binary.")


def add_arguments(k):
    common_arguments(k, jobs=False)
    k.add_argument("--filter", default="", help="--benchmark_filter regex (default: all)")
    k.add_argument("--repetitions", type=int, default=3, help="repetitions per benchmark (min/median/max)")
    k.add_argument("--min-time", default="", help="--benchmark_min_time (seconds)")
    k.add_argument("--relax-tau", type=float, default=None, help="HARDROD_BENCH_RELAX_TAU (default: the binary's: BM_TimeStep 1 tau, BM_ExactStep the nematic 40 tau and the spheres 4 tau)")
    k.add_argument("benchmark_args", nargs="*", help="after --: passed to the benchmark binary")


GB_STANDARD_KEYS = {
    "name", "family_index", "per_family_instance_index", "run_name", "run_type", "repetitions",
    "repetition_index", "threads", "iterations", "real_time", "cpu_time", "time_unit",
    "items_per_second", "bytes_per_second", "aggregate_name", "aggregate_unit", "label",
    "error_occurred", "error_message", "big_o", "rms"}
TIME_UNIT_NS = {"ns": 1.0, "us": 1e3, "ms": 1e6, "s": 1e9}
PHASES = ["integrate", "neighbor_build", "detect", "resolve", "thermostat"]


def summarize_benchmarks(data):
    groups = {}
    for b in data.get("benchmarks", []):
        if b.get("run_type", "iteration") != "iteration":
            continue
        groups.setdefault(b.get("run_name", b["name"]), []).append(b)
    rows = []
    for name, reps in groups.items():
        errors = [b.get("error_message", "error") for b in reps if b.get("error_occurred")]
        reps = [b for b in reps if not b.get("error_occurred")]
        row = {"name": name, "repetitions": len(reps), "error": "; ".join(errors) or None}
        if reps:
            if all(finite(b.get("items_per_second")) and b["items_per_second"] > 0 for b in reps):
                per_item = [1e9 / b["items_per_second"] for b in reps]
                row["unit"] = "ns/item"
                row["items_per_second"] = statistics.median(b["items_per_second"] for b in reps)
            else:
                per_item = [b["cpu_time"] * TIME_UNIT_NS.get(b.get("time_unit", "ns"), 1.0) for b in reps]
                row["unit"] = "ns/iteration"
            row["ns_per_item"] = statistics.median(per_item)
            row["ns_per_item_min"] = min(per_item)
            row["ns_per_item_max"] = max(per_item)
            counters = {}
            for b in reps:
                for k, v in b.items():
                    if k not in GB_STANDARD_KEYS and finite(v):
                        counters.setdefault(k, []).append(v)
            row["counters"] = {k: statistics.median(v) for k, v in counters.items()}
        rows.append(row)
    return rows


def step_vs_floor(rows):
    """BM_TimeStep/<args> against the integration floor of a run of steps (BM_IntegrateFused, one pass per
    step) with the same halvings and threads; BM_IntegrateOnly (two passes) if the fused one is missing."""
    by_name = {r["name"]: r for r in rows}
    out = []
    for r in rows:
        m = re.match(r"BM_TimeStep/halvings:(\d+)/dt_1e-6:(\d+)(?:/threads:(\d+))?", r["name"])
        if not m or "ns_per_item" not in r:
            continue
        h, dt, threads = int(m.group(1)), int(m.group(2)) / 1e6, int(m.group(3) or 1)
        c = r["counters"]
        step = c.get("ns_per_particle_step", r["ns_per_item"])
        floor_row = (by_name.get(f"BM_IntegrateFused/halvings:{h}/threads:{threads}/real_time") or
                     by_name.get(f"BM_IntegrateOnly/halvings:{h}"))
        floor = None
        if floor_row and "ns_per_item" in floor_row:
            floor = floor_row["counters"].get("ns_per_particle_step", floor_row["ns_per_item"])
        n = (8 >> h) * (48 >> h) ** 2
        out.append({
            "benchmark": r["name"], "n": n, "dt": dt, "threads": threads, "ns_per_particle_step": step,
            **{f"{p}_ns": c.get(f"{p}_ns") for p in PHASES},
            "floor_ns": floor, "ratio": step / floor if floor else None,
            "cpu_ms_per_rod_tau": c["us_per_rod_tau"] / 1e3 if "us_per_rod_tau" in c else step * 1e-6 / dt,
            "contacts_per_step": c.get("contacts_per_step"),
            "narrow_tests_per_step": c.get("narrow_tests_per_step")})
    return out


def main(args):
    ensure_built(args, [BENCH_KERNELS])
    out = make_outdir(args, "kernels", with_runs=False)
    raw = out / "benchmark.json.partial"
    argv = [relpath(BENCH_KERNELS), f"--benchmark_out={relpath(raw)}", "--benchmark_out_format=json",
            f"--benchmark_repetitions={args.repetitions}"]
    if args.filter:
        argv.append(f"--benchmark_filter={args.filter}")
    if args.min_time:
        argv.append(f"--benchmark_min_time={args.min_time}")
    argv += args.benchmark_args
    env = {"OMP_NUM_THREADS": "1"}
    if args.relax_tau is not None:
        env["HARDROD_BENCH_RELAX_TAU"] = str(args.relax_tau)
    shell = " ".join(f"{k}={v}" for k, v in env.items()) + " " + shlex.join(argv)
    if args.dry_run:
        print("(dry run) would run:\n  " + shell + f"\nand write {relpath(out)}/kernels.{{json,csv,md}}")
        return 0

    print(f"kernels: {shell}", flush=True)
    log = out / "benchmark.log"
    with open(log, "w") as f:
        f.write("$ " + shell + "\n")
        proc = subprocess.Popen(argv, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                env={**os.environ, **env})
        for line in proc.stdout:
            f.write(line)
            sys.stdout.write("  " + line)
        rc = proc.wait()
    data = load_json(raw)
    report = {"command": invocation(), "benchmark_command": shell, "returncode": rc,
              "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
              "machine": machine_info()}
    if data is None:
        report["error"] = f"benchmark exited {rc} without a complete JSON report (see {relpath(log)})"
        write_json(out / "kernels.json", report)
        print(f"kernels: FAILED: {report['error']}\nresults in {relpath(out)}")
        return 1
    raw.unlink()
    write_json(out / "benchmark.json", data)  # Google Benchmark's own report, complete
    rows = summarize_benchmarks(data)
    steps = step_vs_floor(rows)
    report.update({"context": data.get("context"), "benchmarks": rows, "step_vs_floor": steps})
    write_json(out / "kernels.json", report)

    counter_keys = sorted({k for r in rows for k in r.get("counters", {})})
    columns = ["name", "repetitions", "unit", "ns_per_item", "ns_per_item_min", "ns_per_item_max",
               "items_per_second", *counter_keys, "error"]
    write_csv(out / "kernels.csv", [{**r, **r.get("counters", {})} for r in rows], columns)
    write_csv(out / "step_vs_floor.csv", steps, list(steps[0].keys()) if steps else ["benchmark"])

    shown = lambda k: not (k.endswith("_ns") or k in ("ns_per_particle_step", "time_per_pair"))  # noqa: E731
    t1 = markdown_table(
        ["benchmark", "reps", "ns/item median", "min", "max", "items/s", "counters (median)"],
        [[r["name"], r["repetitions"],
          g(r.get("ns_per_item")) + ("" if r.get("unit") == "ns/item" else " (per iteration)"),
          g(r.get("ns_per_item_min")), g(r.get("ns_per_item_max")), g(r.get("items_per_second")),
          r["error"] or ", ".join(f"{k}={g(v)}" for k, v in r.get("counters", {}).items() if shown(k))]
         for r in rows])
    t2 = markdown_table(
        ["scene (N)", "dt", "threads", "ns/particle-step", *PHASES, "integration floor", "full step / floor",
         "CPU ms per rod per tau"],
        [[s["n"], g(s["dt"]), s["threads"], g(s["ns_per_particle_step"]), *(g(s[f"{p}_ns"], 3) for p in PHASES),
          g(s["floor_ns"]), g(s["ratio"], 3), g(s["cpu_ms_per_rod_tau"], 3)] for s in steps])
    busy = busy_warning((data.get("context") or {}).get("load_avg", [None])[:1])
    text = report_header("Kernel micro-benchmarks (build/bench/hardrod_bench_kernels)") + (busy + "\n\n" if busy else "")
    text += f"Google Benchmark, {args.repetitions} repetitions, one thread unless the name says threads:2 " \
            "(those use wall time); ns/item = time per item (pair or particle-step), median with min and max " \
            "over repetitions.\n\n" + t1 + "\n"
    if steps:
        text += "\n## Full time step against the integration-only floor (BM_TimeStep / BM_IntegrateFused, same " \
                "halvings and threads)\n\n" \
                "Phase columns: ns per particle-step in each region.\n\n" + t2 + "\n"
    write_text(out / "kernels.md", text)
    print("\n" + t1)
    if steps:
        print("\nfull step vs integration-only floor (same halvings and threads):\n" + t2)
    if busy:
        print("\n" + busy)
    print(f"\nresults in {relpath(out)}/ (kernels.csv, kernels.md, kernels.json, benchmark.json)")
    return 0 if rc == 0 else 1


