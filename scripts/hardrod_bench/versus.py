"""`scripts/bench versus`: the exact method's cost, in turns with the build its speed goals were set on.

The exact method's speed goals were set against figures measured with the commit before the
exact method (654ed7a). The nematic: 0.05 ms of CPU per rod per tau on one core,
against 0.21 ms for that build's midpoint method at dt 1e-4, so a ratio of 0.24. Hard spheres
(N = 32768, packing fraction 0.45): event-driven MD's 23.5 us per particle per tau, against
113.6 us for that build's midpoint method at dt 1e-4, a ratio of 0.21. That one is a proxy:
event-driven MD itself is not part of this repository, and the two codes need not follow the
machine's drift alike (docs/performance.md sets hardrod against it in turns, by hand).
This machine's speed drifts by up to 1.5x within an hour, so an absolute figure taken on
another day cannot decide a goal; a ratio taken in turns can. The harness builds that commit
once (build-anchor-REV/, from `git archive`), relaxes the system with the exact method, then
runs, round after round, the anchor's midpoint method and the exact method at each --configs
dt:skin, every run from that state on one thread, and reports the cost per particle per tau,
each run's ratio to the anchor of its round, the medians, and the goal's ratio. Writes
versus.csv, versus.json and report.md.
"""

import os
import statistics
import subprocess
import sys
from pathlib import Path

from .common import (HARDROD, ROOT, common_arguments, ensure_built, g, make_outdir, markdown_table, relpath,
                     report_header, write_csv, write_json, write_text)
from .runner import Run, execute, file_start

HELP = "the exact method's speed goals: in turns with the midpoint build they were set on"
DESCRIPTION = ("Build the anchor commit (default 654ed7a, the midpoint method the goals were set "
               "against), relax the everyday nematic (or hard spheres, N = 32768) with the exact "
               "method, then run the anchor's midpoint method at dt 1e-4 and the exact method at "
               "each --configs in turns, one thread, from that state; report us of CPU per "
               "particle per tau, ratios to each round's anchor, their medians and the goal's "
               "ratio (--goal / --anchor-cost). Writes versus.csv, versus.json, report.md.")

RELAX_DT = 2e-3


# Per system: scene, --set values of every run, the relaxation's skin, and the defaults of
# --configs, --tau, --relax-tau, --goal and --anchor-cost (ms per particle per tau: the goals).
SYSTEMS = {
    "nematic": {"scene": "scenes/everyday.toml", "sets": {}, "relax_skin": 1.0,
                "configs": "1e-3:1.0,2e-3:1.0", "tau": 6.0, "relax_tau": 40.0,
                "goal": 0.05, "anchor_cost": 0.21},
    "spheres": {"scene": "scenes/hard-spheres.toml",
                "sets": {"system.n": "32768", "init.lattice": "[32, 32, 32]"}, "relax_skin": 0.3,
                "configs": "4e-3:0.5", "tau": 2.0, "relax_tau": 4.0,
                "goal": 0.0235, "anchor_cost": 0.1136},
}


def add_arguments(sp):
    common_arguments(sp, jobs=False)
    sp.add_argument("--system", default="nematic", choices=sorted(SYSTEMS),
                    help="the everyday nematic (default) or hard spheres at N = 32768")
    sp.add_argument("--anchor", default="654ed7a",
                    help="the commit whose midpoint method is the yardstick (default 654ed7a)")
    sp.add_argument("--anchor-binary", default="",
                    help="that commit's hardrod, already built (default: build-anchor-REV/hardrod, "
                         "built when missing)")
    sp.add_argument("--configs", default=None,
                    help="the exact method's dt:skin, comma-separated (default: nematic "
                         "1e-3:1.0,2e-3:1.0; spheres 4e-3:0.5, the cheapest against event-driven MD "
                         "on 2026-11-26)")
    sp.add_argument("--rounds", type=int, default=6, help="rounds in turns (default 6)")
    sp.add_argument("--tau", type=float, default=None,
                    help="simulated time of each run (default: nematic 6 tau, spheres 2 tau)")
    sp.add_argument("--relax-tau", type=float, default=None,
                    help="relaxation from the lattice, exact method, dt 2e-3 (default: nematic 40 "
                         "tau, spheres 4 tau)")
    sp.add_argument("--anchor-dt", type=float, default=1e-4, help="the anchor's dt (default 1e-4)")
    sp.add_argument("--goal", type=float, default=None,
                    help="the goal, ms per particle per tau (default: nematic 0.05, "
                         "spheres 0.0235)")
    sp.add_argument("--anchor-cost", type=float, default=None,
                    help="the anchor's cost when the goal was set, ms per particle per tau "
                         "(default: nematic 0.21, spheres 0.1136)")


def fill_defaults(args):
    """The system's defaults for the options left unset."""
    system = SYSTEMS[args.system]
    for key in ("configs", "tau", "relax_tau", "goal", "anchor_cost"):
        if getattr(args, key) is None:
            setattr(args, key, system[key])
    return system


def parse_configs(text):
    """[(dt, skin)] from 'dt:skin,...'; exits naming a bad entry."""
    out = []
    for item in (t.strip() for t in text.split(",") if t.strip()):
        try:
            dt, skin = (float(x) for x in item.split(":"))
        except ValueError:
            sys.exit(f"bench versus: --configs entry '{item}': expected dt:skin, e.g. 1e-3:1.0")
        if not (dt > 0 and skin >= 0):
            sys.exit(f"bench versus: --configs entry '{item}': dt must be > 0 and skin >= 0")
        out.append((dt, skin))
    if not out:
        sys.exit("bench versus: --configs is empty")
    return out


def anchor_build(rev, dry_run):
    """build-anchor-REV/hardrod: the commit's source from `git archive`, built without tests."""
    base = ROOT / f"build-anchor-{rev}"
    binary = base / "build" / "hardrod"
    if binary.exists():
        return binary
    steps = [f"git -C {ROOT} archive {rev} | tar -x -C {base / 'src'}",
             f"cmake -S {base / 'src'} -B {base / 'build'} -DCMAKE_BUILD_TYPE=Release "
             "-DHARDROD_BUILD_TESTS=OFF -DHARDROD_BUILD_BENCH=OFF",
             f"cmake --build {base / 'build'} -j {os.cpu_count() or 1} --target hardrod"]
    if dry_run:
        print("(dry run) would build the anchor: " + " && ".join(steps))
        return binary
    print(f"bench versus: building {relpath(binary)} from {rev}", flush=True)
    (base / "src").mkdir(parents=True, exist_ok=True)
    for step in steps:
        if subprocess.run(step, shell=True, stdout=subprocess.DEVNULL).returncode != 0:
            sys.exit(f"bench versus: the anchor build failed at: {step}")
    return binary


def exact_sets(dt, skin, steps):
    return {"run.method": '"exact"', "run.dt": repr(dt), "run.skin": repr(skin),
            "run.steps": str(steps), "run.equilibration_steps": "0"}


def anchor_scene(anchor, scene):
    """The anchor's own scene where it was built from source (a later scene may hold keys it
    does not know), else this checkout's."""
    own = anchor.parent.parent / "src" / scene
    return str(own) if own.exists() else scene


def plan(args, system, configs, anchor, start, out):
    """The rounds' runs: the anchor first in each round, then each exact configuration."""
    scene, base = system["scene"], {**system["sets"], **file_start(start)}
    base.pop("init.lattice", None)
    runs = []
    for k in range(1, args.rounds + 1):
        anchor_sets = {**base, "run.dt": repr(args.anchor_dt),
                       "run.steps": str(round(args.tau / args.anchor_dt)), "run.equilibration_steps": "0"}
        runs.append(Run(f"round{k}-anchor", anchor_scene(anchor, scene), anchor_sets, 1,
                        out / "runs" / f"round{k}-anchor", binary=anchor,
                        meta={"round": k, "config": "anchor", "dt": args.anchor_dt}))
        for dt, skin in configs:
            name = f"round{k}-exact-dt{dt:g}-skin{skin:g}"
            runs.append(Run(name, scene, {**base, **exact_sets(dt, skin, round(args.tau / dt))},
                            1, out / "runs" / name, meta={"round": k, "config": f"exact dt {dt:g} skin {skin:g}",
                                                         "dt": dt}))
    return runs


def relax_run(args, system, out):
    steps = round(args.relax_tau / RELAX_DT)
    sets = {**system["sets"], **exact_sets(RELAX_DT, system["relax_skin"], steps),
            "output.snapshot_interval": str(steps)}
    return Run("relax", system["scene"], sets, os.cpu_count() or 1, out / "runs" / "relax")


def cost_us(result):
    """us of CPU per particle per tau: the run's wall time of the steps on one thread, over dt."""
    s = result.summary
    return s["ns_per_particle_step"] * 1e-3 / result.run.meta["dt"] if result.ok else None


def analyse(rows, configs_order, goal_ratio):
    """Per configuration: the costs, the ratios to the anchor of the same round, their medians."""
    anchor = {r["round"]: r["us_per_particle_tau"] for r in rows if r["config"] == "anchor"}
    summary = []
    for config in configs_order:
        mine = [r for r in rows if r["config"] == config and r["us_per_particle_tau"] is not None]
        ratios = [r["us_per_particle_tau"] / anchor[r["round"]] for r in mine
                  if anchor.get(r["round"]) and config != "anchor"]
        costs = [r["us_per_particle_tau"] for r in mine]
        entry = {"config": config, "runs": len(mine),
                 "median_us_per_particle_tau": statistics.median(costs) if costs else None,
                 "min_us": min(costs, default=None), "max_us": max(costs, default=None)}
        if config != "anchor":
            med = statistics.median(ratios) if ratios else None
            entry.update({"median_ratio": med, "min_ratio": min(ratios, default=None),
                          "max_ratio": max(ratios, default=None),
                          "goal_met": None if med is None else med <= goal_ratio})
        summary.append(entry)
    return summary


def report(args, out, rows, summary, goal_ratio):
    columns = ["round", "config", "us_per_particle_tau", "ratio", "pressure", "checksum", "error"]
    write_csv(out / "versus.csv", rows, columns)
    write_json(out / "versus.json", {"system": args.system, "goal_ratio": goal_ratio, "anchor": args.anchor,
                                     "rows": rows, "summary": summary})
    table = markdown_table(
        ["configuration", "runs", "us per particle per tau (median, range)", "ratio to the anchor (median, range)",
         "goal met"],
        [[s["config"], str(s["runs"]), f"{g(s['median_us_per_particle_tau'])} ({g(s['min_us'])}-{g(s['max_us'])})",
          "" if s["config"] == "anchor" else f"{g(s['median_ratio'])} ({g(s['min_ratio'])}-{g(s['max_ratio'])})",
          "" if s["config"] == "anchor" else {True: "yes", False: "no", None: "?"}[s["goal_met"]]]
         for s in summary])
    text = (f"{args.system}: the goal is {args.goal} ms per particle per tau against {args.anchor_cost} ms for {args.anchor}'s "
            f"midpoint method at dt {args.anchor_dt:g}, a ratio of {goal_ratio:.3f}. In the anchor's "
            f"terms the exact method's median ratio r costs r x {args.anchor_cost} ms.")
    if args.system == "spheres":
        text += (" A proxy: event-driven MD itself is not run here, and the two codes need not follow "
                 "this machine's drift alike; docs/performance.md sets hardrod against it in turns.")
    write_text(out / "report.md", "\n".join([report_header("The exact method in turns with the anchor"),
                                             text, "", table, ""]))
    print(table)
    print(f"\n{text}\nbench versus: wrote {relpath(out)}/report.md")
    return 1 if any(r.get("error") for r in rows) else 0


def run_rounds(runs):
    """Every run in the order given, one at a time (the ratios need the same machine state):
    its cost, and its ratio to the anchor of its round."""
    rows = []
    for run in runs:
        r = execute(run)
        summary = r.summary or {}
        row = {"round": run.meta["round"], "config": run.meta["config"], "us_per_particle_tau": cost_us(r),
               "pressure": (summary.get("pressure_star") or {}).get("mean"),
               "checksum": summary.get("state_checksum"), "error": None if r.ok else r.error}
        rows.append(row)
        print(f"  {run.name:<34} {g(row['us_per_particle_tau'])} us per particle per tau", flush=True)
    anchor_of = {r["round"]: r["us_per_particle_tau"] for r in rows if r["config"] == "anchor"}
    for r in rows:
        a, mine = anchor_of.get(r["round"]), r["us_per_particle_tau"]
        r["ratio"] = mine / a if a and mine and r["config"] != "anchor" else None
    return rows


def main(args):
    system = fill_defaults(args)
    configs = parse_configs(args.configs)
    if args.rounds < 1 or args.tau <= 0 or args.relax_tau <= 0:
        sys.exit("bench versus: --rounds must be >= 1, --tau and --relax-tau > 0")
    anchor = Path(args.anchor_binary).resolve() if args.anchor_binary else None
    if anchor is not None and not anchor.exists():
        sys.exit(f"bench versus: --anchor-binary {anchor}: no such file")
    ensure_built(args, [HARDROD])
    anchor = anchor or anchor_build(args.anchor, args.dry_run)
    out = make_outdir(args, "versus")
    relax = relax_run(args, system, out)
    runs = plan(args, system, configs, anchor, relax.out / "trajectory.h5", out)
    if args.dry_run:
        for r in [relax, *runs]:
            print("(dry run) " + r.shell())
        return 0
    print(f"bench versus: relaxing {args.relax_tau:g} tau", flush=True)
    if not execute(relax).ok:
        sys.exit(f"bench versus: the relaxation failed (see {relpath(relax.out)}/hardrod.log)")
    rows = run_rounds(runs)
    goal_ratio = args.goal / args.anchor_cost
    order = ["anchor", *[f"exact dt {dt:g} skin {skin:g}" for dt, skin in configs]]
    return report(args, out, rows, analyse(rows, order, goal_ratio), goal_ratio)
