"""`scripts/bench balance`: load balancing on an uneven system, each --balance mode in turn.

A hard-sphere gas whose centres are squeezed into half the box (an H5MD start edited with
h5py) on several ranks, with --balance off, bodies and time back to back in each repeat:
wall time, imbalance, and the same final state. Writes balance.csv, balance.json, balance.md.
"""

import shutil
import statistics
import sys

from . import mpi
from .common import (HARDROD, common_arguments, ensure_built, g, invocation, make_outdir, markdown_table, relpath,
                     report_header, write_csv, write_json, write_text)
from .runner import Run, execute, run_all

HELP = "load balancing on an uneven gas: --balance off, bodies, time"
DESCRIPTION = ("A hard-sphere gas squeezed into half the box (an H5MD start written with h5py) "
               "on several ranks, with each --balance mode in turn: wall time, imbalance, "
               "and the same final state. Writes balance.csv, balance.json, balance.md.")


def add_arguments(ba):
    common_arguments(ba, jobs=False)
    ba.add_argument("--ranks", type=int, default=2, help="MPI ranks (default 2)")
    ba.add_argument("--per-side", type=int, default=20, help="lattice bodies per side (default 20: 8000 spheres)")
    ba.add_argument("--steps", type=int, default=4000, help="time steps (default 4000)")
    ba.add_argument("--temperature", type=float, default=100.0, help="kT of the start (default 100)")
    ba.add_argument("--interval", type=int, default=1000, help="--balance-interval (default 1000)")
    ba.add_argument("--repeat", type=int, default=3, help="repeats (default 3)")
    ba.add_argument("--method", default="midpoint", choices=("midpoint", "exact"),
                    help="the step method (default midpoint)")
    ba.add_argument("--dt", type=float, default=1e-4, help="the time step (default 1e-4)")


def main(args):
    """Load balancing on an uneven system: a hard-sphere gas squeezed into half the box."""
    n_side = args.per_side
    n = n_side ** 3
    if args.dry_run:
        print(f"(dry run) a one-step seed run of {n} spheres, its last frame squeezed into x < L/2, then "
              f"{args.repeat} x (--balance off, bodies, time) on {args.ranks} ranks, {args.steps} steps each, "
              f"method {args.method}, dt {args.dt:g}")
        return 0
    out = make_outdir(args, "balance")
    ensure_built(args, [HARDROD])
    scene = "tests/parallel/gas.toml"
    base = {"system.n": str(n), "init.lattice": f"[{n_side}, {n_side}, {n_side}]"}
    seed = Run("seed", scene, {**base, "run.steps": "1", "output.snapshot_interval": "1"}, 1, out / "runs" / "seed")
    res = execute(seed)
    if not res.ok:
        sys.exit(f"bench balance: the seed run failed: {res.error}")
    try:
        import h5py
    except ImportError:
        sys.exit("bench balance: needs h5py (scripts/setup installs python3-h5py)")
    start = out / "squeezed.h5"
    shutil.copy(seed.out / "trajectory.h5", start)
    with h5py.File(start, "r+") as f:  # every centre's x folded into the lower half
        pos = f["particles/all/position/value"]
        side = f["particles/all/box/edges/value"][-1][0][0]  # the last frame's box, x edge
        frame = pos[-1]
        frame[:, 0] = (frame[:, 0] % side) * 0.5
        pos[-1] = frame
        # An edited frame: no checksum, and no velocities, so they are drawn at --temperature.
        del f["observables/state_checksum"]
        for name in ("velocity", "angular_velocity"):
            f[f"particles/all/{name}/value"][-1] = 0.0
    env = dict(mpi.ROOT_ENV)
    sets = {**base, "init.configuration": '"file"', "init.file": f'"{start.resolve()}"',
            "init.temperature": repr(args.temperature), "run.steps": str(args.steps),
            "run.sample_interval": str(max(1, args.steps // 4)),
            "run.method": f'"{args.method}"', "run.dt": repr(args.dt)}
    prefix = mpi.prefix(args.ranks, bind=True, always=True)
    modes = ["off", "bodies", "time"]
    runs = [Run(f"{m}-r{rep}", scene, sets, 1, out / "runs" / f"{m}-r{rep}", env, prefix, {"mode": m, "n": n},
                ["--balance", m, "--balance-interval", str(args.interval)])
            for rep in range(args.repeat) for m in modes]  # repeats outermost, modes alternate
    results = run_all(runs, 1, "balance", longest_first=False)
    rows = []
    for m in modes:
        mine = [r for r in results if r.run.meta["mode"] == m]
        ok = [r for r in mine if r.ok]
        row = {"mode": m, "runs": len(mine), "ok": len(ok)}
        if ok:
            walls = sorted(r.summary["wall_seconds"] for r in ok)
            b = ok[0].summary["balance"]
            row.update({"wall_best": walls[0], "wall_median": statistics.median(walls),
                        "checks": b["checks"], "shifts": b["shifts"], "forced_rebuilds": b["forced_rebuilds"],
                        "first_imbalance": statistics.median(r.summary["balance"]["first_imbalance"] for r in ok),
                        "last_imbalance": statistics.median(r.summary["balance"]["last_imbalance"] for r in ok),
                        "agree_rank_mean": statistics.median(r.summary["timers_rank_mean"]["agree"] for r in ok),
                        "checksums": sorted({r.summary["state_checksum"] for r in ok})})
        rows.append(row)
    off = next((r for r in rows if r["mode"] == "off" and "wall_median" in r), None)
    for r in rows:
        if off and "wall_median" in r:
            r["speedup_median"] = off["wall_median"] / r["wall_median"]
    write_csv(out / "balance.csv", rows, ["mode", "runs", "ok", "wall_best", "wall_median", "speedup_median",
                                         "checks", "shifts", "forced_rebuilds", "first_imbalance",
                                         "last_imbalance", "agree_rank_mean", "checksums"])
    table = markdown_table(
        ["--balance", "wall s (best)", "median", "speed-up (medians)", "checks", "shifts (forced)",
         "imbalance first -> last", "agree s (rank mean)"],
        [[r["mode"], g(r.get("wall_best"), 3), g(r.get("wall_median"), 3), g(r.get("speedup_median"), 3),
          r.get("checks", "-"), f"{r.get('shifts', '-')} ({r.get('forced_rebuilds', '-')})",
          (f"{100 * r['first_imbalance']:.0f} % -> {100 * r['last_imbalance']:.0f} %" if "first_imbalance" in r else "-"),
          g(r.get("agree_rank_mean"), 3)] for r in rows])
    checksums = sorted({c for r in rows for c in r.get("checksums", [])})
    same = (f"final states: identical checksums over all modes ({checksums[0]})" if len(checksums) == 1
            else f"final states DIFFER: {checksums}")
    notes = (f"{n} hard spheres (tests/parallel/gas.toml at kT = {g(args.temperature, 3)}), every centre squeezed into "
             f"x < L/2 at the start, {args.steps} steps of the {args.method} method at dt = {g(args.dt, 3)} on "
             f"{args.ranks} ranks cut along x; load checked "
             f"every {args.interval} steps. {args.repeat} repeats, the three modes back to back in each. Imbalance: "
             f"the busiest rank's load above the mean at the first and the last check (advanced bodies for "
             f"'bodies', compute time for 'time'; off: not measured).")
    write_text(out / "balance.md", report_header("Load balancing") + table + "\n\n" + notes + "\n\n" + same + "\n")
    write_json(out / "balance.json", {"command": invocation(), "rows": rows, "notes": notes, "determinism": same,
                                      "commands": [r.run.shell() for r in results]})
    print("\n" + table + "\n\n" + notes + "\n" + same)
    print(f"results in {relpath(out)}/ (balance.csv, balance.json, balance.md, runs/)")
    return 0 if len(checksums) == 1 and all(r["ok"] == r["runs"] for r in rows) else 1
