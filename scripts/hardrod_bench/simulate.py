"""`scripts/bench scaling --simulate PLATFORM`: scaling on a simulated cluster (SimGrid's SMPI).

hardrod built for SMPI (`scripts/build --smpi`, build-smpi/hardrod) runs every rank of a run in
one process here, under smpirun on the platform file (bench/platforms/): each rank's
computation runs and is timed for real, one rank at a time on one core, and the network (links,
switches, the nodes' shared interfaces) is modelled. hardrod's clocks read the simulated time
there (perf/clock.hpp), so summary.json's step time, region timers and per-communication
seconds are the simulated platform's.

Weak scaling: --per-rank rods per rank (2304: the everyday nematic's 4 x 24 x 24 cell per rank;
18432: the paper's 8 x 48 x 48), the cells tiled over the rank grid, one cell a rank. Strong
scaling: --n rods (147456 = 16 x 96 x 96, 1179648 = 32 x 192 x 192), on the grid hardrod
chooses. Every run starts from the aligned lattice (the rods' S = 1, a nematic's first steps).
Per rank count: the simulated time of a step, its compute (free flight, detection, resolution
and list builds, less the communication inside them) and its communication by kind (agree, the
contact or piece exchanges, the rebuilds' migration and shadows, the balance), messages and
bytes per rank and step, the load imbalance (the slowest rank's compute over the mean), and the
final state checksum: strong scaling must end in one state for every rank count, and each weak
system is run once more on one rank to the same checksum. Writes scaling.json (`efficiency` per
row), scaling.csv, scaling.md and scaling.png.
"""

import datetime
import json
import os
import shlex
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

from . import simulate_real
from .common import (HARDROD, ROOT, g, invocation, machine_info, make_outdir, markdown_table, parse_list, relpath,
                     report_header, write_csv, write_json, write_text)

SMPI_HARDROD = ROOT / "build-smpi" / "hardrod"
# The everyday nematic's cell: 4 x 24 x 24 rods of L/D = 5 at rho* = 0.5 in a cube of this side.
CELL = (4, 24, 24)
CELL_RODS = 2304
CELL_SIDE = 28.525630783706616

# Steps before the timed ones: the first list build, one-time set-up of the scratch.
WARMUP = 20

COMPUTE = ("integrate", "detect", "resolve", "neighbor_build", "thermostat")
EXCHANGES = ("contacts", "results", "exact_pieces", "exact_results")
AGREEMENT = ("agree", "exact_round")
REBUILD = ("migrate", "shadows")
# The step's own communication: what the messages and bytes per rank-step count (not the
# observables' reductions or the checkpoints).
STEP_TRAFFIC = AGREEMENT + EXCHANGES + REBUILD + ("balance",)


def add_arguments(s):
    s.add_argument("--simulate", default="", metavar="PLATFORM",
                   help="run on this SimGrid platform (bench/platforms/*.xml) with the SMPI build")
    s.add_argument("--ranks-list", default="1,8,64,512,1024",
                   help="simulated rank counts (default %(default)s)")
    s.add_argument("--per-rank", default="2304", help="weak scaling: rods per rank, 2304 x k^3 (comma list)")
    s.add_argument("--n", default="147456", help="strong scaling: rods, 2304 x k^3 (comma list)")
    s.add_argument("--smpi-binary", default=str(SMPI_HARDROD),
                   help="hardrod built for SMPI (default build-smpi/hardrod: scripts/build --smpi)")
    s.add_argument("--machine-noise", choices=("filter", "keep"), default="filter",
                   help="filter (default): each stretch of computation is charged at most 1.2 x the median "
                        "of the recent ones between the same two places on any rank + 1 us, which takes this machine's stalls off; keep: as measured")
    s.add_argument("--against-real", type=int, default=0, metavar="ROUNDS",
                   help="also run the first --per-rank's weak system on 1 and 2 ranks for real (build/hardrod) "
                        "and simulated, in turns, ROUNDS times each, and compare (default 0: not)")
    s.add_argument("--timeout", type=float, default=7200, help="seconds one simulation may take (default 7200)")


def cube_multiple(n, what):
    """k with n = 2304 k^3, or exit naming the value."""
    k = round((n / CELL_RODS) ** (1 / 3))
    if k < 1 or CELL_RODS * k ** 3 != n:
        sys.exit(f"bench scaling: {what} {n}: must be 2304 k^3 (2304, 18432, 62208, 147456, ...)")
    return k


def balanced_dims(p):
    """Three factors of p, as even as can be, ascending (the fewest cuts along the rods, x)."""
    best = None
    for a in range(1, p + 1):
        if p % a:
            continue
        for b in range(a, p // a + 1):
            if (p // a) % b:
                continue
            c = p // (a * b)
            if c < b:
                continue
            key = (c - a, c - b)
            if best is None or key < best[0]:
                best = (key, (a, b, c))
    return best[1]


def hostfile(platform, out, write=True):
    """The platform's cluster hosts, each with its cores as slots (ranks fill a node first)."""
    lines = []
    for cluster in ET.parse(platform).getroot().iter("cluster"):
        prefix, suffix = cluster.get("prefix", ""), cluster.get("suffix", "")
        cores = cluster.get("core", "1")
        for part in cluster.get("radical", "0").split(","):
            lo, _, hi = part.partition("-")
            for i in range(int(lo), int(hi or lo) + 1):
                lines.append(f"{prefix}{i}{suffix}:{cores}")
    if not lines:
        sys.exit(f"bench scaling: {platform}: no <cluster> to place the ranks on")
    path = out / "hostfile"
    if write:
        path.write_text("\n".join(lines) + "\n")
    slots = sum(int(line.rsplit(":", 1)[1]) for line in lines)
    return path, slots


def system_sets(mode, size, ranks):
    """--set values and extra flags of one weak (size rods per rank) or strong (size rods) run."""
    if mode == "weak":
        k = cube_multiple(size, "--per-rank")
        dims = balanced_dims(ranks)
        lattice = [CELL[a] * k * dims[a] for a in range(3)]
        box = [CELL_SIDE * k * dims[a] for a in range(3)]
        grid = ["--grid", "x".join(str(d) for d in dims)]
        n = size * ranks
    else:
        k = cube_multiple(size, "--n")
        lattice = [c * k for c in CELL]
        box = [CELL_SIDE * k] * 3
        grid = []
        n = size
    sets = {"system.n": str(n), "system.box": "[" + ",".join(repr(b) for b in box) + "]",
            "init.lattice": "[" + ",".join(str(x) for x in lattice) + "]"}
    return n, sets, grid


NOISE_MODES = {"filter": "filtered", "keep": "measured"}


def hardrod_argv(binary, sets, extra, out):
    """`hardrod run` of the everyday scene with these --set values, one thread, into out."""
    argv = [str(binary), "run", str(ROOT / "scenes" / "everyday.toml")]
    for k, v in sets.items():
        argv += ["--set", f"{k}={v}"]
    return argv + ["--out", str(out), "--force", "--quiet", "--threads", "1", "--no-bind", *extra]


def smpirun_argv(args, platform, hosts, ranks, sets, extra, out):
    # hardrod charges its computation itself (perf/simulated_compute.hpp), SMPI does not time it.
    return (["smpirun", "-np", str(ranks), "-no-privatize", "-platform", str(platform), "-hostfile", str(hosts),
             "--cfg=smpi/simulate-computation:no"] + hardrod_argv(args.smpi_binary, sets, extra, out))


def simulated_env(args):
    return {**os.environ, "OMP_NUM_THREADS": "1", "HARDROD_SMPI_COMPUTE": NOISE_MODES[args.machine_noise]}


def run_sets(args, sets):
    """The system's --set values with the run's: method, dt, steps, warm-up, no checkpoints."""
    return {**sets, "run.method": f'"{args.method}"', "run.dt": repr(args.dt), "run.steps": str(args.steps),
            "run.equilibration_steps": str(WARMUP), "run.sample_interval": str(max(1, args.steps // 2)),
            "output.checkpoint_interval": "0"}


def per_step(summary, names, key="production_seconds_per_step"):
    traffic = summary.get("communication_per_rank", {})
    return sum(traffic.get(n, {}).get(key, 0.0) for n in names)


def row_of(mode, size, ranks, summary, real_seconds):
    steps = max(1, summary["steps_done"])
    # The list builds (with the rebuilds' migration and shadows) in the production steps alone.
    production = summary.get("production_timers_per_step", {}).get("rank_mean", {})
    step = summary["production_seconds_per_step"]
    agree = per_step(summary, AGREEMENT)
    exchanges = per_step(summary, EXCHANGES)
    rebuild_comm = per_step(summary, REBUILD)
    balance = per_step(summary, ("balance",))
    traffic = summary.get("communication_per_rank", {})
    messages = per_step(summary, STEP_TRAFFIC, "messages_per_step")
    bytes_ = per_step(summary, STEP_TRAFFIC, "bytes_per_step")
    charged = summary.get("simulated_compute", {})
    measured = charged.get("charged_seconds", 0.0) + charged.get("clipped_seconds", 0.0)
    # Compute: a production step less the communication inside it, mean over ranks; the
    # imbalance: the slowest rank's over that.
    work = summary.get("production_compute_seconds_per_step", {})
    compute, compute_max = work.get("rank_mean", 0.0), work.get("rank_max", 0.0)
    return {"mode": mode, "size": size, "ranks": ranks, "n": summary["n"], "steps": steps,
            "step_us": 1e6 * step, "compute_us": 1e6 * compute, "agree_us": 1e6 * agree,
            "exchanges_us": 1e6 * exchanges, "rebuild_us": 1e6 * production.get("neighbor_build", 0.0),
            "rebuild_comm_us": 1e6 * rebuild_comm, "balance_us": 1e6 * balance,
            "messages_per_step": messages, "bytes_per_step": bytes_,
            "imbalance": (compute_max / compute - 1.0) if compute > 0 else None,
            "noise_filtered": charged.get("clipped_seconds", 0.0) / measured if measured > 0 else None,
            "state_checksum": summary["state_checksum"], "real_seconds": real_seconds,
            "method": summary.get("method"), "dt": summary.get("dt")}


def add_efficiencies(rows):
    """Weak: t(1 rank) / t(P); strong: P0 t(P0) / (P t(P)) against the smallest rank count."""
    for key in {(r["mode"], r["size"]) for r in rows}:
        mine = sorted((r for r in rows if (r["mode"], r["size"]) == key and r.get("step_us")),
                      key=lambda r: r["ranks"])
        if not mine:
            continue
        base = mine[0]
        for r in mine:
            if key[0] == "weak":
                r["efficiency"] = base["step_us"] / r["step_us"]
            else:
                r["efficiency"] = base["ranks"] * base["step_us"] / (r["ranks"] * r["step_us"])
            r["baseline_ranks"] = base["ranks"]


def run_simulations(args, out, platform, hosts, plan):
    rows, failures = [], []
    for mode, size, ranks, check in plan:
        n, sets, extra = system_sets(mode, size, ranks)
        sets = run_sets(args, sets)
        run_ranks = 1 if check else ranks
        tag = f"{mode}-{size}-{ranks}" + ("-on-1" if check else "")
        run_out = out / "runs" / tag
        argv = smpirun_argv(args, platform, hosts, run_ranks, sets, extra if not check else [], run_out)
        if args.dry_run:
            print(f"(dry run) OMP_NUM_THREADS=1 HARDROD_SMPI_COMPUTE={NOISE_MODES[args.machine_noise]} "
                  + shlex.join(argv))
            continue
        run_out.mkdir(parents=True, exist_ok=True)
        print(f"  {tag}: N = {n} on {run_ranks} simulated rank(s) ...", flush=True)
        start = time.time()
        with open(run_out / "smpirun.log", "w") as log:
            log.write(shlex.join(argv) + "\n")
            log.flush()
            try:
                rc = subprocess.run(argv, stdout=log, stderr=subprocess.STDOUT, timeout=args.timeout,
                                    env=simulated_env(args), cwd=out).returncode
            except subprocess.TimeoutExpired:
                rc = "timeout"
        real = time.time() - start
        summary_path = run_out / "summary.json"
        if rc != 0 or not summary_path.exists():
            failures.append(f"{tag}: smpirun {rc} (see {relpath(run_out)}/smpirun.log)")
            print(f"    failed: {failures[-1]}", flush=True)
            continue
        summary = json.loads(summary_path.read_text())
        row = row_of(mode, size, ranks, summary, real)
        row["check_on_one_rank"] = check
        rows.append(row)
        print(f"    {g(row['step_us'], 4)} us per step (compute {g(row['compute_us'], 3)}, agree "
              f"{g(row['agree_us'], 3)}, exchanges {g(row['exchanges_us'], 3)}); {real:.0f} s to simulate; "
              f"checksum {row['state_checksum']}", flush=True)
    return rows, failures


def determinism(rows):
    """Strong: one checksum over the rank counts; weak: each checked system's two runs agree."""
    lines, ok = [], True
    for size in sorted({r["size"] for r in rows if r["mode"] == "strong"}):
        sums = {r["state_checksum"] for r in rows if r["mode"] == "strong" and r["size"] == size}
        ok = ok and len(sums) == 1
        lines.append(f"strong N = {size}: {'one final state' if len(sums) == 1 else 'DIFFERENT final states'} "
                     f"over the rank counts ({', '.join(sorted(sums))})")
    for r in rows:
        if r["mode"] != "weak" or not r.get("check_on_one_rank"):
            continue
        twin = next((x for x in rows if x["mode"] == "weak" and x["size"] == r["size"] and x["ranks"] == r["ranks"]
                     and not x.get("check_on_one_rank")), None)
        same = twin is not None and twin["state_checksum"] == r["state_checksum"]
        ok = ok and same
        lines.append(f"weak {r['size']} per rank, the {r['ranks']}-rank system on one rank: "
                     f"{'the same state' if same else 'a DIFFERENT state'} ({r['state_checksum']})")
    return ok, lines


def plot(rows, path):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return "no plot: matplotlib is not available (scripts/setup installs python3-matplotlib)"
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.5))
    for key in sorted({(r["mode"], r["size"]) for r in rows}):
        pts = sorted((r for r in rows if (r["mode"], r["size"]) == key and "efficiency" in r
                      and not r.get("check_on_one_rank")), key=lambda r: r["ranks"])
        if not pts:
            continue
        label = f"{key[0]}, {key[1]} {'per rank' if key[0] == 'weak' else 'rods'}"
        a1.plot([r["ranks"] for r in pts], [r["efficiency"] for r in pts], "o-", label=label)
        a2.plot([r["ranks"] for r in pts], [r["step_us"] for r in pts], "o-", label=label)
    a1.axhline(1.0, color="k", ls="--", lw=1)
    a1.set_ylim(0, 1.1)
    a1.set_ylabel("parallel efficiency")
    a2.set_ylabel("simulated time per step (us)")
    a2.set_yscale("log")
    for ax in (a1, a2):
        ax.set_xscale("log", base=2)
        ax.set_xlabel("simulated ranks (one thread each)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    tmp = path.with_name("tmp-" + path.name)
    fig.savefig(tmp, dpi=120)
    plt.close(fig)
    os.replace(tmp, path)
    return ""


COLUMNS = ["mode", "size", "ranks", "n", "steps", "step_us", "efficiency", "baseline_ranks", "compute_us",
           "agree_us", "exchanges_us", "rebuild_us", "rebuild_comm_us", "balance_us", "messages_per_step",
           "bytes_per_step", "imbalance", "noise_filtered", "state_checksum", "check_on_one_rank", "real_seconds", "method", "dt"]


def report(args, out, platform, rows, failures, against):
    add_efficiencies([r for r in rows if not r.get("check_on_one_rank")])
    ok, det = determinism(rows)
    rows.sort(key=lambda r: (r["mode"], r["size"], r["ranks"], bool(r.get("check_on_one_rank"))))
    write_csv(out / "scaling.csv", rows, COLUMNS)
    shown = [r for r in rows if not r.get("check_on_one_rank")]
    table = markdown_table(
        ["mode", "size", "ranks", "us per step", "efficiency", "compute", "agree", "exchanges", "rebuild (comm)",
         "balance", "messages / bytes per rank-step", "imbalance", "noise filtered", "checksum", "simulated in"],
        [[r["mode"], r["size"], r["ranks"], g(r["step_us"], 4), g(r.get("efficiency"), 3), g(r["compute_us"], 3),
          g(r["agree_us"], 3), g(r["exchanges_us"], 3), f"{g(r['rebuild_us'], 3)} ({g(r['rebuild_comm_us'], 3)})",
          g(r["balance_us"], 2), f"{g(r['messages_per_step'], 3)} / {g(r['bytes_per_step'], 3)}",
          g(r.get("imbalance"), 2), g(r.get("noise_filtered"), 2), r["state_checksum"], f"{r['real_seconds']:.0f} s"] for r in shown])
    notes = (f"Simulated with SimGrid's SMPI on {relpath(platform)} (its header states the model). Method "
             f"{args.method}, dt {args.dt:g}, {args.steps} steps from the aligned lattice, one thread per rank. "
             f"Times are simulated microseconds per step (after {WARMUP} steps of warm-up), per rank (means "
             "over ranks): the step (its slowest rank); its communication: agree (the step's reductions, the wait "
             "for the slowest rank included), exchanges (the contact or piece exchanges, waits included), the "
             "rebuilds' migration and shadows (in brackets), balance; compute, a rank's step less its "
             "communication; rebuild, the list builds' share of the step (with the rebuilds' migration and shadows, over the timed steps); imbalance, the slowest rank's compute "
             "over the mean, less 1; noise filtered, the share of the measured computation the filter took off "
             f"(--machine-noise {args.machine_noise}). Weak efficiency: t(smallest) / t(P); strong: "
             "P0 t(P0) / (P t(P)).")
    png = out / "scaling.png"
    plot_note = plot(shown, png)
    text = (report_header("Scaling on a simulated cluster") + table + "\n\n" + notes + "\n\n" + "\n".join(det) + "\n\n"
            + ("\n".join(f"FAILED: {f}" for f in failures) + "\n\n" if failures else "")
            + ("![scaling](scaling.png)\n" if not plot_note else plot_note + "\n"))
    if against is not None:
        text += "\n" + simulate_real.table(against[0]) + "\n\n" + simulate_real.note(*against) + "\n"
    write_text(out / "scaling.md", text)
    write_json(out / "scaling.json", {
        "command": invocation(), "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        "machine": machine_info(), "platform": relpath(platform), "method": args.method, "dt": args.dt,
        "steps": args.steps, "machine_noise": args.machine_noise, "rows": rows, "notes": notes, "determinism": det, "failures": failures,
        **({"against_real": against[0], "against_real_tolerance": simulate_real.TOLERANCE} if against else {})})
    print("\n" + table + "\n\n" + notes + "\n" + "\n".join(det))
    if plot_note:
        print(plot_note)
    if against is not None:
        print("\n" + simulate_real.table(against[0]) + "\n" + simulate_real.note(*against))
    print(f"results in {relpath(out)}/ (scaling.csv, scaling.json, scaling.md, scaling.png, runs/)")
    return 0 if ok and not failures and (against is None or against[1]) else 1


def main(args):
    platform = Path(args.simulate).resolve()
    if not platform.exists():
        sys.exit(f"bench scaling: --simulate {args.simulate}: no such platform file")
    if args.dt is None:
        args.dt = 1e-3 if args.method == "exact" else 1e-4
    ranks_list = parse_list(args.ranks_list, int)
    if not ranks_list or min(ranks_list) < 1:
        sys.exit(f"bench scaling: --ranks-list {args.ranks_list}: positive rank counts")
    modes = [m for m in args.modes.split(",") if m]
    if any(m not in ("weak", "strong") for m in modes):
        sys.exit(f"bench scaling: --modes {args.modes}: weak, strong or both")
    plan = []
    if "weak" in modes:
        for size in parse_list(args.per_rank, int):
            cube_multiple(size, "--per-rank")
            plan += [("weak", size, r, False) for r in ranks_list]
            checked = sorted(r for r in ranks_list if r > 1)
            if checked:
                plan.append(("weak", size, checked[0], True))
    if "strong" in modes:
        for size in parse_list(args.n, int):
            cube_multiple(size, "--n")
            plan += [("strong", size, r, False) for r in ranks_list]
    # smpirun loads the program with dlopen, which searches the library path for a name
    # without a slash: a relative --smpi-binary is made absolute.
    args.smpi_binary = str(Path(args.smpi_binary).absolute())
    if not args.dry_run:
        missing = [p for p in (args.smpi_binary,) if not Path(p).exists()]
        if missing:
            sys.exit(f"bench scaling: {missing[0]}: no such file (scripts/build --smpi builds it)")
        if subprocess.run(["which", "smpirun"], capture_output=True).returncode != 0:
            sys.exit("bench scaling: smpirun not found (scripts/setup installs libsimgrid-dev)")
    out = make_outdir(args, "scaling") if not args.dry_run else Path(args.results) / "scaling-DATE"
    hosts, slots = hostfile(platform, out, write=not args.dry_run)
    if max(ranks_list) > slots:
        sys.exit(f"bench scaling: {max(ranks_list)} ranks: {relpath(platform)} has {slots} cores")
    rows, failures = run_simulations(args, out, platform, hosts, plan)
    if args.dry_run:
        return 0
    against = None
    if args.against_real > 0:
        if not HARDROD.exists():
            sys.exit(f"bench scaling: --against-real: {relpath(HARDROD)}: no such file (scripts/build builds it)")
        print(f"  against real: {args.against_real} round(s) on 1 and 2 ranks ...", flush=True)
        against = simulate_real.check(args, out, platform, hosts, sys.modules[__name__])
    return report(args, out, platform, rows, failures, against)
