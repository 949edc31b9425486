"""`scripts/bench ab`: two builds of hardrod compared side by side, one core each.

On a machine shared with other tenants the same run's time moves by up to 1.5x within minutes,
so runs taken one after the other cannot show a change of a few percent. Here the two builds
run at the same time, A pinned to one core and B to the other (taskset), from the same relaxed
state with the same settings, and they swap cores every round: the two runs of a round meet the
same load. Each run's regions are also reported over its own list-build time (the
`neighbor_build` timer), which most changes leave alone and which moves with the machine, so
that a change is seen in the region it touched. A change to the list build itself moves that
yardstick, so each region's own seconds are reported too: within a round the two runs meet the
same load, so their ratio still holds. Reports per round B's ratio to A of the step time, of
each region over the build time and of each region's seconds, their medians over the rounds,
and whether the two builds end in the same state (the checksum: a change meant to keep the
trajectory must).
On fewer than two cores the runs go in turns. Writes ab.csv, ab.json, report.md.
"""

import os
import statistics
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from .common import (HARDROD, common_arguments, ensure_built, g, make_outdir, markdown_table, relpath,
                     report_header, write_csv, write_json, write_text)
from .runner import Run, execute, file_start
from .versus import RELAX_DT, SYSTEMS, anchor_build, anchor_scene, exact_sets

HELP = "two builds side by side, one core each (A/B of a change on a noisy machine)"
DESCRIPTION = ("Run build A (--base REV, built from `git archive`, or --binary) and build B "
               "(build/hardrod, or a second --binary) at the same time on two cores, swapped each "
               "round, from one relaxed state (the everyday nematic or hard spheres at N = 32768), "
               "with either step method; "
               "report B/A of the step, of each region over its own list-build time and of each "
               "region's seconds, per round and as medians, and whether the checksums agree. "
               "Writes ab.csv, ab.json, report.md.")

REGIONS = ("detect", "resolve", "integrate")


def add_arguments(sp):
    common_arguments(sp, jobs=False)
    sp.add_argument("--base", default="",
                    help="build A from this commit (build-anchor-REV/, built when missing)")
    sp.add_argument("--binary", action="append", default=[],
                    help="a hardrod to run: the first is A (unless --base), the second B "
                         "(default B: build/hardrod)")
    sp.add_argument("--system", default="nematic", choices=sorted(SYSTEMS),
                    help="the everyday nematic (default) or hard spheres at N = 32768")
    sp.add_argument("--method", default="exact", choices=("exact", "midpoint"),
                    help="the step method both builds run (default exact)")
    sp.add_argument("--config", default="",
                    help="dt:skin (default: the exact method's nematic 1e-3:1.0, spheres 4e-3:0.5; "
                         "the midpoint method's 1e-4:0.3 for both)")
    sp.add_argument("--rounds", type=int, default=6, help="rounds (default 6)")
    sp.add_argument("--tau", type=float, default=None,
                    help="simulated time of each run (default: nematic 3 tau, spheres 1 tau; the "
                         "midpoint method a tenth of those)")
    sp.add_argument("--start", default="",
                    help="an H5MD trajectory to start from (default: relax the system first, as "
                         "`scripts/bench versus` does)")


def builds(args):
    """(A, B) paths from --base and --binary; exits naming what is missing."""
    given = [Path(b).resolve() for b in args.binary]
    if args.base:
        if len(given) > 1:
            sys.exit("bench ab: --base gives A; pass at most one --binary (B)")
        a, b = anchor_build(args.base, args.dry_run), (given[0] if given else HARDROD)
    else:
        if not given or len(given) > 2:
            sys.exit("bench ab: give A as --base REV or --binary PATH (and B as a second --binary)")
        a, b = given[0], (given[1] if len(given) > 1 else HARDROD)
    for name, path in (("A", a), ("B", b)):
        if not args.dry_run and not path.exists():
            sys.exit(f"bench ab: build {name}, {path}: no such file")
    return a, b


# The midpoint method's default dt:skin (its recommended dt) and its share of the exact method's
# default simulated time (its steps are ten times as many per tau).
MIDPOINT_CONFIG = "1e-4:0.3"
MIDPOINT_TAU_SHARE = 0.1


def method_sets(method, dt, skin, steps):
    """--set values of one run of `method`."""
    if method == "exact":
        return exact_sets(dt, skin, steps)
    return {"run.method": '"midpoint"', "run.dt": repr(dt), "run.skin": repr(skin),
            "run.steps": str(steps), "run.equilibration_steps": "0"}


def plan(args, system, a, b, start, out):
    """Per round the run of A and the run of B, with the cores they are pinned to."""
    default = system["configs"].split(",")[0] if args.method == "exact" else MIDPOINT_CONFIG
    dt, skin = (float(x) for x in (args.config or default).split(":"))
    tau = args.tau or ({"nematic": 3.0, "spheres": 1.0}[args.system] *
                       (1.0 if args.method == "exact" else MIDPOINT_TAU_SHARE))
    sets = {**system["sets"], **file_start(start), **method_sets(args.method, dt, skin, round(tau / dt))}
    sets.pop("init.lattice", None)
    side_by_side = (os.cpu_count() or 1) >= 2
    rounds = []
    for k in range(1, args.rounds + 1):
        cores = (0, 1) if k % 2 else (1, 0)
        pair = []
        for build, binary, core in (("A", a, cores[0]), ("B", b, cores[1])):
            name = f"round{k}-{build}"
            prefix = ["taskset", "-c", str(core)] if side_by_side else []
            scene = anchor_scene(binary, system["scene"]) if build == "A" and args.base else system["scene"]
            pair.append(Run(name, scene, sets, 1, out / "runs" / name, prefix=prefix,
                            binary=binary, meta={"round": k, "build": build, "dt": dt}))
        rounds.append(pair)
    return rounds, side_by_side


def measure(result):
    """The run's us per particle per tau and its regions over its own list-build time."""
    s = result.summary or {}
    if not result.ok:
        return {"error": result.error or result.status()}
    timers = s.get("timers", {})
    build = timers.get("neighbor_build") or 0.0
    row = {"us_per_particle_tau": s["ns_per_particle_step"] * 1e-3 / result.run.meta["dt"],
           "checksum": s.get("state_checksum"), "error": None,
           "step_over_build": s["wall_seconds"] / build if build > 0 else None}
    for region in REGIONS:
        row[f"{region}_over_build"] = timers.get(region, 0.0) / build if build > 0 else None
    for region in SECONDS:
        row[f"{region}_seconds"] = timers.get(region)
    return row


def run_rounds(rounds, side_by_side):
    rows = []
    for pair in rounds:
        if side_by_side:
            with ThreadPoolExecutor(max_workers=2) as pool:
                results = list(pool.map(execute, pair))
        else:
            results = [execute(r) for r in pair]
        for r in results:
            rows.append({"round": r.run.meta["round"], "build": r.run.meta["build"], **measure(r)})
        a, b = rows[-2], rows[-1]
        print(f"  round {a['round']}: A {g(a.get('us_per_particle_tau'))}, B {g(b.get('us_per_particle_tau'))} "
              f"us per particle per tau; step/build {g(a.get('step_over_build'))} / {g(b.get('step_over_build'))}",
              flush=True)
    return rows


SECONDS = ("neighbor_build", *REGIONS)
COLUMNS = ["us_per_particle_tau", "step_over_build", *[f"{r}_over_build" for r in REGIONS],
           *[f"{r}_seconds" for r in SECONDS]]


def analyse(rows):
    """Per measure: A's and B's medians, and the median over rounds of B / A."""
    by_round = {}
    for r in rows:
        by_round.setdefault(r["round"], {})[r["build"]] = r
    out = []
    for col in COLUMNS:
        a = [p["A"][col] for p in by_round.values() if p.get("A", {}).get(col)]
        b = [p["B"][col] for p in by_round.values() if p.get("B", {}).get(col)]
        ratios = [p["B"][col] / p["A"][col] for p in by_round.values()
                  if p.get("A", {}).get(col) and p.get("B", {}).get(col)]
        out.append({"measure": col, "median_a": statistics.median(a) if a else None,
                    "median_b": statistics.median(b) if b else None,
                    "median_ratio": statistics.median(ratios) if ratios else None,
                    "b_lower": sum(x < 1.0 for x in ratios), "rounds": len(ratios)})
    checks = {r["checksum"] for r in rows if r.get("checksum")}
    return out, len(checks) == 1


def report(args, out, rows, summary, same, a, b, side_by_side):
    write_csv(out / "ab.csv", rows, ["round", "build", *COLUMNS, "checksum", "error"])
    write_json(out / "ab.json", {"system": args.system, "method": args.method, "a": str(a), "b": str(b), "side_by_side": side_by_side,
                                 "same_checksum": same, "rows": rows, "summary": summary})
    table = markdown_table(["measure", "A (median)", "B (median)", "B / A (median of rounds)", "rounds B lower"],
                           [[s["measure"], g(s["median_a"]), g(s["median_b"]), g(s["median_ratio"]),
                             f"{s['b_lower']} of {s['rounds']}"] for s in summary])
    how = ("side by side, one core each, swapped each round" if side_by_side else
           "in turns (fewer than two cores)")
    text = (f"{args.system}, {args.method} method: A = {relpath(a)}, B = {relpath(b)}, {args.rounds} rounds {how}. "
            f"The checksums {'agree' if same else 'differ'}.")
    write_text(out / "report.md", "\n".join([report_header("Two builds side by side"), text, "", table, ""]))
    print(table)
    print(f"\n{text}\nbench ab: wrote {relpath(out)}/report.md")
    return 1 if any(r.get("error") for r in rows) else 0


def main(args):
    system = SYSTEMS[args.system]
    if args.rounds < 1 or (args.tau is not None and args.tau <= 0):
        sys.exit("bench ab: --rounds must be >= 1 and --tau > 0")
    if args.config and len(args.config.split(":")) != 2:
        sys.exit(f"bench ab: --config '{args.config}': expected dt:skin, e.g. 1e-3:1.0")
    if args.start and not Path(args.start).exists():
        sys.exit(f"bench ab: --start {args.start}: no such file")
    ensure_built(args, [HARDROD])
    a, b = builds(args)
    out = make_outdir(args, "ab")
    relax = None
    if not args.start:
        steps = round(system["relax_tau"] / RELAX_DT)
        relax = Run("relax", system["scene"],
                    {**system["sets"], **exact_sets(RELAX_DT, system["relax_skin"], steps),
                     "output.snapshot_interval": str(steps)}, os.cpu_count() or 1, out / "runs" / "relax")
    start = Path(args.start).resolve() if args.start else relax.out / "trajectory.h5"
    rounds, side_by_side = plan(args, system, a, b, start, out)
    if args.dry_run:
        for r in ([relax] if relax else []) + [r for pair in rounds for r in pair]:
            print("(dry run) " + r.shell())
        return 0
    if relax:
        print(f"bench ab: relaxing {system['relax_tau']:g} tau", flush=True)
        if not execute(relax).ok:
            sys.exit(f"bench ab: the relaxation failed (see {relpath(relax.out)}/hardrod.log)")
    rows = run_rounds(rounds, side_by_side)
    summary, same = analyse(rows)
    return report(args, out, rows, summary, same, a, b, side_by_side)
