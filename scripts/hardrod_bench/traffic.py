"""`scripts/bench traffic`: communication per rank per step under weak scaling.

2304 rods per rank on 1..64 ranks (oversubscribed: the counts are exact, the timings are
not), the messages and bytes of every communication step from summary.json; writes
traffic.csv, traffic.json and traffic.md.
"""

import sys

from . import mpi
from .common import (HARDROD, NPROC, common_arguments, ensure_built, g, invocation, make_outdir, markdown_table,
                     parse_list, relpath, report_header, write_csv, write_json, write_text)
from .references import cubic_side
from .runner import Run, print_dry_run, run_all

HELP = "weak-scaling communication: messages and bytes per rank per step"
DESCRIPTION = ("2304 rods per rank on 1..64 MPI ranks (oversubscribed), counting the messages "
               "and bytes of every communication step per rank per step (from summary.json). "
               "Writes traffic.csv, traffic.json, traffic.md.")


def add_arguments(tr):
    common_arguments(tr, jobs=False)
    tr.add_argument("--ranks-list", default="1,2,4,8,16,32,64", help="comma list of rank counts")
    tr.add_argument("--steps", type=int, default=400, help="time steps per run (default 400)")
    tr.add_argument("--dt", type=float, default=1e-4, help="time step (default 1e-4; the paper's is 2e-6)")


# The harness's own grids (passed with --grid): the everyday box replicated along each axis.
GRIDS = {1: (1, 1, 1), 2: (1, 2, 1), 4: (1, 2, 2), 8: (2, 2, 2), 16: (2, 4, 2), 32: (2, 4, 4),
         64: (4, 4, 4), 128: (4, 8, 4), 256: (4, 8, 8)}


def main(args):
    """Weak scaling of communication: messages and bytes per rank per step, 1..64 ranks."""
    ranks_list = parse_list(args.ranks_list, int)
    for r in ranks_list:
        if r not in GRIDS:
            sys.exit(f"bench traffic: --ranks-list: {r} ranks: no grid known (use one of {sorted(GRIDS)})")
    out = make_outdir(args, "traffic")
    env = dict(mpi.SHARED_CORES_ENV)
    side = cubic_side(2304, 0.5)
    runs = []
    for r in ranks_list:
        gx, gy, gz = GRIDS[r]
        sets = {"run.dt": repr(args.dt), "run.equilibration_steps": "0", "run.steps": str(args.steps),
                "run.sample_interval": str(max(1, args.steps // 2)), "system.n": str(2304 * r),
                "system.box": f"[{gx * side!r}, {gy * side!r}, {gz * side!r}]",
                "init.lattice": f"[{4 * gx}, {24 * gy}, {24 * gz}]"}
        runs.append(Run(f"ranks-{r}", "scenes/everyday.toml", sets, 1, out / "runs" / f"ranks-{r}", dict(env),
                        mpi.prefix(r), {"ranks": r, "grid": f"{gx}x{gy}x{gz}"},
                        # the model is of the even grid: no cuts moved by measured time
                        ["--grid", f"{gx}x{gy}x{gz}", "--balance", "off"]))
    if args.dry_run:
        print_dry_run(runs, 1, " (one at a time)")
        return 0
    ensure_built(args, [HARDROD])
    results = run_all(runs, 1, "traffic", longest_first=False)
    rows = []
    for res in results:
        row = {"ranks": res.run.meta["ranks"], "grid": res.run.meta["grid"], "status": res.status()}
        if res.ok:
            s = res.summary
            comm = s.get("communication_per_rank", {})
            row.update({"n": s["n"], "steps": s["steps_done"], "state_checksum": s["state_checksum"]})
            total_m = total_b = 0.0
            for name, c in comm.items():
                row[f"{name}_messages"] = c["messages_per_step"]
                row[f"{name}_bytes"] = c["bytes_per_step"]
                total_m += c["messages_per_step"]
                total_b += c["bytes_per_step"]
            row["messages_per_step"] = total_m
            row["bytes_per_step"] = total_b
        rows.append(row)
    columns = sorted({k for r in rows for k in r}, key=lambda k: (k not in ("ranks", "grid", "n", "steps"), k))
    write_csv(out / "traffic.csv", rows, columns)
    table = markdown_table(
        ["ranks", "grid", "N", "messages/step/rank", "bytes/step/rank", "agree", "contacts msgs", "contacts bytes",
         "results msgs", "results bytes", "shadows bytes", "migrate bytes"],
        [[r["ranks"], r["grid"], g(r.get("n")), g(r.get("messages_per_step"), 3), g(r.get("bytes_per_step"), 4),
          g(r.get("agree_messages"), 2), g(r.get("contacts_messages"), 3), g(r.get("contacts_bytes"), 4),
          g(r.get("results_messages"), 3), g(r.get("results_bytes"), 4),
          g(r.get("shadows_bytes"), 4), g(r.get("migrate_bytes"), 3)] for r in rows])
    notes = (f"Weak scaling: 2304 rods per rank (the everyday box per rank, rho* = 0.5, lattice start), "
             f"{args.steps} steps at dt = {g(args.dt, 3)}, ranks oversubscribed on {NPROC} cores (timings meaningless, "
             f"counts exact). Per step per rank, averaged over ranks and steps.")
    write_text(out / "traffic.md", report_header("Communication per rank per step") + table + "\n\n" + notes + "\n")
    write_json(out / "traffic.json", {"command": invocation(), "rows": rows, "notes": notes,
                                      "commands": [r.run.shell() for r in results]})
    print("\n" + table + "\n\n" + notes)
    print(f"results in {relpath(out)}/ (traffic.csv, traffic.json, traffic.md)")
    return 0 if all(r["status"] == "ok" for r in rows) else 1
