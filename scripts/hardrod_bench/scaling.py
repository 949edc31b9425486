"""`scripts/bench scaling`: strong and weak scaling over ranks x threads, one run at a time.

Strong scaling of the paper scene (N = 18432) and weak scaling at 2304 rods per core, best
of several repeats with the configurations back to back in each repeat (so paired ratios
see the same machine load); the binding libgomp reports is recorded. Writes scaling.csv,
scaling.json, scaling.md and scaling.png.
"""

import datetime
import os
import re
import statistics
import subprocess
import sys

from . import mpi, simulate
from .common import (HARDROD, NPROC, busy_warning, common_arguments, ensure_built, g, invocation, machine_info,
                     make_outdir, markdown_table, parse_list, relpath, report_header, write_csv, write_json,
                     write_text)
from .references import cubic_side
from .runner import Run, file_start, print_dry_run, run_all

HELP = "strong and weak scaling over ranks x threads here, or (--simulate) on a simulated cluster"
DESCRIPTION = ("Strong scaling of scenes/paper.toml and weak scaling at 2304 rods per thread "
               "over 1..nproc threads, best of --repeat runs each, run one at a time. Pins with "
               "OMP_PROC_BIND=close OMP_PLACES=cores unless set in the environment; records "
               "the binding libgomp reports.")


def add_arguments(s):
    common_arguments(s, jobs=False)
    s.add_argument("--threads-list", default=None, help="comma list of thread counts (default 1..nproc)")
    s.add_argument("--steps", type=int, default=None,
                   help="time steps per run (default 2000; simulated: 200)")
    s.add_argument("--method", choices=["midpoint", "exact"], default="midpoint",
                   help="run.method of every run (default midpoint, the paper's)")
    s.add_argument("--dt", type=float, default=None,
                   help="time step (default 1e-4 for midpoint, 1e-3 for exact; the paper's is 2e-6)")
    s.add_argument("--repeat", type=int, default=3, help="repeats per point; the best is used (default 3)")
    s.add_argument("--modes", default="strong,weak", help="strong, weak or both (default)")
    s.add_argument("--weak-layout", choices=["replicate", "auto"], default="replicate",
                   help="weak-scaling box: the everyday box stacked along z (default) or init.lattice = \"auto\" in a "
                        "cubic box (auto finds no lattice for N = 4608 at rho* = 0.5)")
    s.add_argument("--ranks", type=int, default=1, help="MPI ranks for every --threads-list point (default 1)")
    s.add_argument("--start", default="", metavar="H5MD",
                   help="strong runs start from the last frame of this trajectory (N = 18432, e.g. a relaxed "
                        "paper scene) instead of the lattice, whose first steps have few contacts")
    s.add_argument("--configs", default="1x1,1x2,2x1",
                   help="comma list of RANKSxTHREADS points (default %(default)s; overrides --threads-list)")
    simulate.add_arguments(s)


AFFINITY_RE = re.compile(r"hardrod-affinity thread (\d+) cpus (\S+)")


def mpi_available():
    if not HARDROD.exists():
        return False
    try:
        text = subprocess.run([str(HARDROD), "info"], capture_output=True, text=True, timeout=30).stdout
    except (OSError, subprocess.SubprocessError):
        return False
    return re.search(r"\bMPI\b", text) is not None


def parse_configs(args):
    """(ranks, threads) pairs: --configs 1x1,1x2,2x1, or --threads-list with --ranks."""
    if args.configs:
        out = []
        for item in args.configs.split(","):
            try:
                r, t = (int(v) for v in item.lower().split("x"))
            except ValueError:
                sys.exit(f"bench scaling: --configs: '{item}' is not RANKSxTHREADS (e.g. 2x1)")
            if r < 1 or t < 1:
                sys.exit(f"bench scaling: --configs: '{item}' needs positive counts")
            out.append((r, t))
        return out
    threads_list = parse_list(args.threads_list, int) if args.threads_list else list(range(1, NPROC + 1))
    return [(args.ranks, t) for t in threads_list]


def main(args):
    if args.steps is None:
        args.steps = 200 if args.simulate else 2000
    if args.simulate:
        return simulate.main(args)
    if args.dt is None:
        args.dt = 1e-3 if args.method == "exact" else 1e-4
    configs = parse_configs(args)
    if any(r > 1 for r, _ in configs):
        if args.dry_run and not HARDROD.exists():
            print("(dry run) ranks > 1 need an MPI build; build/hardrod is missing, so this cannot be checked")
        elif not args.dry_run and not mpi_available():
            sys.exit("bench scaling: ranks > 1: `build/hardrod info` does not mention MPI")
    out = make_outdir(args, "scaling")
    env = {"OMP_PROC_BIND": os.environ.get("OMP_PROC_BIND", "close"),
           "OMP_PLACES": os.environ.get("OMP_PLACES", "cores"), **mpi.ROOT_ENV,
           "OMP_DISPLAY_AFFINITY": "TRUE", "OMP_AFFINITY_FORMAT": "hardrod-affinity thread %n cpus %A"}
    runs = scaling_runs(args, out, configs, env)
    if args.dry_run:
        print_dry_run(runs, 1, f" (one at a time: timing runs; best of {args.repeat} repeats)")
        print(f"and write {relpath(out)}/scaling.csv, scaling.json, scaling.md, scaling.png")
        return 0
    ensure_built(args, [HARDROD])
    if args.threads_list is None and NPROC == 1:
        print("scaling: one hardware thread: the sweep has a single point")
    topo = ""
    try:
        topo = subprocess.run(["lstopo-no-graphics", "--of", "console"], capture_output=True, text=True,
                              timeout=30).stdout
        write_text(out / "topology.txt", topo)
    except (OSError, subprocess.SubprocessError):
        pass
    # runs one at a time, strictly in thread order: concurrent runs would spoil the timings
    results = run_all(runs, 1, "scaling", longest_first=False)
    rows = scaling_rows(results, env)
    add_speedups(rows)
    return write_report(args, out, rows, env, results)


def scaling_runs(args, out, configs, env):
    """Strong and weak runs for every (ranks, threads) point, repeats outermost."""
    common = {"run.method": args.method, "run.dt": repr(args.dt), "run.equilibration_steps": "0",
              "run.steps": str(args.steps), "run.sample_interval": str(max(1, args.steps // 4))}
    runs = []
    side = cubic_side(2304, 0.5)
    for rep in range(args.repeat):  # repeats outermost: a change in the machine's load hits every point
        for r, t in configs:
            tag = f"{r}x{t}"
            prefix = mpi.prefix(r, bind=True)
            if "strong" in args.modes:
                strong = dict(common, **(file_start(args.start) if args.start else {}))
                runs.append(Run(f"strong-{tag}-r{rep}", "scenes/paper.toml", strong, t,
                                out / "runs" / f"strong-{tag}-r{rep}", env, prefix,
                                {"mode": "strong", "threads": t, "ranks": r, "rep": rep,
                                 "layout": "paper, " + ("relaxed start" if args.start else "8 x 48 x 48 lattice")}))
            if "weak" in args.modes:
                k = t * r
                n = 2304 * k
                sets = dict(common, **{"system.n": str(n)})
                if args.weak_layout == "auto":
                    sets.update({"system.reduced_density": "0.5", "init.lattice": "auto"})
                    layout = "auto lattice, cubic box"
                else:  # the everyday box stacked along z: same density, same lattice spacings
                    sets.update({"system.box": f"[{side!r}, {side!r}, {k * side!r}]",
                                 "init.lattice": f"[4, 24, {24 * k}]"})
                    layout = f"everyday box x{k} along z"
                runs.append(Run(f"weak-{tag}-r{rep}", "scenes/everyday.toml", sets, t,
                                out / "runs" / f"weak-{tag}-r{rep}", env, prefix,
                                {"mode": "weak", "threads": t, "ranks": r, "rep": rep, "layout": layout}))
    return runs


def scaling_rows(results, env):
    """One row per (mode, ranks, threads): the best of its repeats, and every repeat's throughput."""
    groups = {}
    for res in results:
        m = res.run.meta
        groups.setdefault((m["mode"], m["ranks"], m["threads"]), []).append(res)
    rows = []
    for (mode, ranks, t), rs in groups.items():
        good = [r for r in rs if r.ok]
        row = {"mode": mode, "threads": t, "ranks": ranks, "cores": ranks * t, "repeats": len(rs),
               "layout": rs[0].run.meta["layout"],
               "OMP_PROC_BIND": env["OMP_PROC_BIND"], "OMP_PLACES": env["OMP_PLACES"]}
        if not good:
            row.update({"status": rs[0].status(), "error": rs[0].error})
            rows.append(row)
            continue
        best = min(good, key=lambda r: r.summary["wall_seconds"])
        s = best.summary
        walls = [r.summary["wall_seconds"] for r in good]
        aff = AFFINITY_RE.findall((best.run.out / "hardrod.log").read_text(errors="replace"))
        row.update({
            "status": "ok" if len(good) == len(rs) else f"{len(rs) - len(good)} of {len(rs)} repeats failed",
            "n": s["n"], "steps": s["steps_done"], "wall": s["wall_seconds"], "wall_median": statistics.median(walls),
            "wall_max": max(walls), "particle_steps_per_second": s["particle_steps_per_second"],
            "ns_per_particle_step": s["ns_per_particle_step"], "threads_reported": s.get("threads"),
            "affinity": ";".join(f"{th}:{cpus}" for th, cpus in sorted(set(aff), key=lambda x: int(x[0])))
            or ("not reported (libgomp prints none for 1 thread)" if t == 1 else None),
            "state_checksum": s.get("state_checksum"), "load_average_1min": best.load_before,
            "checksums_agree_over_repeats": len({r.summary.get("state_checksum") for r in good}) == 1,
            "_throughput_by_rep": {r.run.meta["rep"]: r.summary["particle_steps_per_second"] for r in good},
            **{f"timer_{k}": v for k, v in (s.get("timers") or {}).items()},
            **{f"timer_rank_max_{k}": v for k, v in (s.get("timers_rank_max") or {}).items()}})
        rows.append(row)
    return rows


def add_speedups(rows):
    """Speed-up and efficiency of each row against the 1-core row of its mode."""
    for mode in ("strong", "weak"):
        mrows = sorted((r for r in rows if r["mode"] == mode and "wall" in r),
                       key=lambda r: (r["cores"], r["ranks"]))
        base = next((r for r in mrows if r["cores"] == 1), mrows[0] if mrows else None)
        for r in mrows:
            # throughput ratio against 1 x 1: wall(1)/wall(p) for strong scaling, scaled for weak
            r["speedup"] = r["particle_steps_per_second"] / base["particle_steps_per_second"] * base["cores"]
            r["efficiency"] = r["speedup"] / r["cores"]
            r["baseline_threads"] = base["threads"]
            # The same ratio repeat by repeat: each repeat ran every configuration back to back, so
            # a paired ratio sees the machine's load of that moment on both sides.
            mine, theirs = r["_throughput_by_rep"], base["_throughput_by_rep"]
            paired = sorted(mine[k] / theirs[k] * base["cores"] / r["cores"] for k in mine if k in theirs)
            if paired:
                r["efficiency_paired_median"] = statistics.median(paired)
                r["efficiency_paired_min"], r["efficiency_paired_max"] = paired[0], paired[-1]
    for r in rows:
        r.pop("_throughput_by_rep", None)


def write_report(args, out, rows, env, results):
    """scaling.csv, scaling.md, scaling.json and scaling.png; the table printed."""
    strong_sums = {r["state_checksum"] for r in rows if r["mode"] == "strong" and r.get("state_checksum")}
    columns = ["mode", "threads", "ranks", "n", "steps", "wall", "wall_median", "wall_max",
               "particle_steps_per_second", "ns_per_particle_step", "speedup", "efficiency",
               "efficiency_paired_median", "efficiency_paired_min", "efficiency_paired_max", "baseline_threads",
               "OMP_PROC_BIND", "OMP_PLACES", "affinity", "layout", "repeats", "load_average_1min", "state_checksum",
               "checksums_agree_over_repeats", "status", "error"] + \
        sorted({k for r in rows for k in r if k.startswith("timer_")})
    rows.sort(key=lambda r: (r["mode"] != "strong", r["cores"], r["ranks"]))
    write_csv(out / "scaling.csv", rows, columns)
    table = markdown_table(
        ["mode", "threads", "ranks", "N", "wall s (best)", "median", "particle-steps/s", "ns/particle-step",
         "speed-up", "efficiency", "paired efficiency: median (range)", "binding (thread:cpus)", "status"],
        [[r["mode"], r["threads"], r["ranks"], g(r.get("n")), g(r.get("wall"), 3), g(r.get("wall_median"), 3),
          g(r.get("particle_steps_per_second"), 3), g(r.get("ns_per_particle_step"), 3), g(r.get("speedup"), 3),
          g(r.get("efficiency"), 3),
          (f"{g(r['efficiency_paired_median'], 3)} ({g(r['efficiency_paired_min'], 3)}-"
           f"{g(r['efficiency_paired_max'], 3)})" if "efficiency_paired_median" in r else "-"),
          r.get("affinity") or "-", r["status"]] for r in rows])
    det = (f"strong-scaling final states: {'identical' if len(strong_sums) == 1 else 'DIFFERENT'} checksums over "
           f"thread counts ({', '.join(sorted(strong_sums))})" if strong_sums else "")
    start = f"from {args.start} (its last frame)" if args.start else "from the lattice"
    weak_rows = [r for r in rows if r["mode"] == "weak"]
    notes = (f"Method {args.method}. Strong: scenes/paper.toml (N = 18432), {args.steps} steps at dt = "
             f"{args.dt:g} {start}, no equilibration. " +
             (f"Weak: 2304 rods per core at rho* = 0.5 ({weak_rows[0]['layout']}). " if weak_rows else "") +
             f"Best wall of {args.repeat} repeats (the machine is shared); speed-up = throughput ratio against "
             f"1 thread, efficiency = speed-up / threads (best against best); paired efficiency: the same ratio "
             f"within each repeat (every repeat runs all configurations back to back), median and range. OMP_PROC_BIND={env['OMP_PROC_BIND']} "
             f"OMP_PLACES={env['OMP_PLACES']}; the binding column is what libgomp reported (OMP_DISPLAY_AFFINITY).")
    loads = [r["load_average_1min"] for r in rows if r.get("load_average_1min") is not None]
    if busy_warning(loads):
        notes += " " + busy_warning(loads)
    png = out / "scaling.png"
    plot_note = plot_scaling(rows, png, max(loads) if loads else None)
    write_text(out / "scaling.md", report_header("Thread scaling") + table + "\n\n" + notes + "\n\n" + det + "\n\n" +
               ("![scaling](scaling.png)\n" if not plot_note else plot_note + "\n"))
    write_json(out / "scaling.json", {
        "command": invocation(), "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        "machine": machine_info(), "env": env, "rows": rows, "notes": notes, "determinism": det,
        "commands": [r.run.shell() for r in results]})
    print("\n" + table + "\n\n" + notes + ("\n" + det if det else ""))
    if plot_note:
        print(plot_note)
    print(f"results in {relpath(out)}/ (scaling.csv, scaling.json, scaling.md, scaling.png, runs/)")
    return 0 if all(r["status"] == "ok" for r in rows) else 1


def plot_scaling(rows, path, load=None):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return "no plot: matplotlib is not available (scripts/setup installs python3-matplotlib)"
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.5))
    tmax = max([r["threads"] for r in rows] + [1])
    styles = {"strong": ("o-", "tab:blue", "strong, N = 18432"), "weak": ("s-", "tab:orange", "weak, 2304 per thread")}
    for mode, (st, c, label) in styles.items():
        pts = sorted((r for r in rows if r["mode"] == mode and r.get("speedup") is not None), key=lambda r: r["threads"])
        if pts:
            a1.plot([r["threads"] for r in pts], [r["speedup"] for r in pts], st, color=c, label=label)
            a2.plot([r["threads"] for r in pts], [r["efficiency"] for r in pts], st, color=c, label=label)
    a1.plot([1, tmax], [1, tmax], "k--", lw=1, label="ideal")
    a2.axhline(1.0, color="k", ls="--", lw=1, label="ideal")
    for ax, yl in ((a1, "speed-up (throughput / 1 thread)"), (a2, "parallel efficiency")):
        ax.set_xlabel("OpenMP threads")
        ax.set_ylabel(yl)
        ax.set_xticks(range(1, tmax + 1))
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    a2.set_ylim(0, 1.15)
    a1.set_ylim(0, tmax * 1.1)
    fig.suptitle("hardrod thread scaling (best of repeats)" +
                 (f"; load average up to {load:.1f} on {NPROC} hardware threads" if load is not None else ""), fontsize=11)
    fig.tight_layout()
    tmp = path.with_name("tmp-" + path.name)
    fig.savefig(tmp, dpi=120)
    plt.close(fig)
    os.replace(tmp, path)
    return ""


# ---- time to answer ------------------------------------------------------------------------
