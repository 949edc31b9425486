"""`scripts/bench instructions`: what the time step executes, counted by callgrind.

Timings on a shared or throttled machine drift by tens of percent between runs, so a change
worth a few percent cannot be told from noise by the clock. The instructions a step executes
do not drift: this harness runs each system for a fixed number of steps under valgrind's
callgrind, from a relaxed state, counting only inside System::advance (not the set-up or
the output), and reports instructions per particle-step and the functions that execute them,
for one build or two (`--binary A --binary B`: B against A). With `--cache-sim` it adds
callgrind's simulated first-level and last-level data-cache read misses, which is where
memory-bound parts (the hard-sphere clusters) spend their time and instructions do not show.

Valgrind does not run AVX-512, so the builds counted are made for x86-64-v3 (AVX2) without
-march=native: by default build-callgrind/ (configured and built here when missing). Give
another checkout's build with --binary to compare two commits. Every run's state checksum
is reported: a change meant to keep the trajectory must keep it.
"""

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

from .common import (ROOT, common_arguments, g, make_outdir, markdown_table, relpath, report_header,
                     write_csv, write_json, write_text)
from .outputs import load_json

HELP = "instructions per particle-step under callgrind: no machine noise; A/B of two builds"
DESCRIPTION = ("Run the exact hard spheres (N = 32768), the exact nematic and the midpoint nematic "
               "(N = 2304) from relaxed states under valgrind's callgrind, counting inside the time "
               "steps only; report instructions (and with --cache-sim simulated cache misses) per "
               "particle-step and by function, for one build or two. Writes instructions.csv, "
               "functions.csv, instructions.json, report.md.")

DEFAULT_BUILD = ROOT / "build-callgrind"
# The time steps: the System's (and, for builds from before it, the Simulation's).
ADVANCE = ("hardrod::System::advance(long long)", "hardrod::Simulation::advance(long long)")

# name: scene, --set values, relaxation steps (a native run from the lattice, with the counted
# run's values but for RELAX's), counted steps. The nematic relaxes 40 tau, from the lattice's
# S = 0.93 to the equilibrium's ~0.77 (the midpoint system from the same exact run: its own
# method would need 400000 steps); the spheres 4 tau, past the melting of the lattice.
SYSTEMS = {
    "spheres": ("scenes/hard-spheres.toml",
                {"system.n": "32768", "init.lattice": "[32, 32, 32]", "run.method": '"exact"',
                 "run.dt": "2e-3", "run.skin": "0.3"}, 2000, 60),
    "nematic": ("scenes/everyday.toml",
                {"run.method": '"exact"', "run.dt": "1e-3", "run.skin": "1.0"}, 20000, 400),
    "midpoint": ("scenes/everyday.toml",
                 {"run.method": '"midpoint"', "run.dt": "1e-4"}, 20000, 1000),
}
RELAX = {"nematic": {"run.dt": "2e-3"},
         "midpoint": {"run.method": '"exact"', "run.dt": "2e-3", "run.skin": "1.0"}}


def add_arguments(sp):
    common_arguments(sp, jobs=False)
    sp.add_argument("--binary", action="append", default=[],
                    help="a hardrod built without AVX-512 (repeat for A/B; default "
                         "build-callgrind/hardrod, built when missing)")
    sp.add_argument("--systems", default=",".join(SYSTEMS),
                    help="comma list of " + ", ".join(SYSTEMS) + " (default: all)")
    sp.add_argument("--steps-scale", type=float, default=1.0,
                    help="scale the counted steps (default 1: 60 sphere, 400 and 1000 nematic steps)")
    sp.add_argument("--cache-sim", action="store_true",
                    help="also simulate the caches (D1 and LL read misses; about 2x slower)")
    sp.add_argument("--ll", default="4194304,16,64",
                    help="with --cache-sim, the cache counted as last level: size,ways,line in bytes "
                         "(default 4 MiB, 16-way, 64 B: a core's L2 here; valgrind models two levels)")
    sp.add_argument("--top", type=int, default=12, help="functions listed per system (default 12)")


def build_default(dry_run):
    """Configure and build build-callgrind/ (x86-64-v3 where the CPU has AVX2, else baseline)."""
    flags = "-march=x86-64-v3" if "avx2" in Path("/proc/cpuinfo").read_text() else ""
    configure = ["cmake", "-S", str(ROOT), "-B", str(DEFAULT_BUILD), "-DCMAKE_BUILD_TYPE=Release",
                 "-DHARDROD_NATIVE=OFF", f"-DCMAKE_CXX_FLAGS={flags}", "-DHARDROD_BUILD_TESTS=OFF",
                 "-DHARDROD_BUILD_BENCH=OFF"]
    build = ["cmake", "--build", str(DEFAULT_BUILD), "-j", str(os.cpu_count() or 1), "--target",
             "hardrod"]
    if dry_run:
        print("(dry run) would build: " + " ".join(configure) + " && " + " ".join(build))
        return
    print(f"bench instructions: building {relpath(DEFAULT_BUILD)} ({flags or 'baseline x86-64'})",
          flush=True)
    subprocess.run(configure, check=True, stdout=subprocess.DEVNULL)
    subprocess.run(build, check=True, stdout=subprocess.DEVNULL)


def hardrod_argv(binary, system, out, steps, start):
    scene, sets, _, _ = SYSTEMS[system]
    sets = dict(sets, **{"run.steps": str(steps), "run.equilibration_steps": "0"})
    if start:
        sets.update({"init.configuration": '"file"', "init.file": json.dumps(str(start))})
        sets.pop("init.lattice", None)
    else:
        sets.update(RELAX.get(system, {}))
        sets["output.snapshot_interval"] = str(steps)
    argv = [str(binary), "run", str(ROOT / scene)]
    for k, v in sets.items():
        argv += ["--set", f"{k}={v}"]
    return argv + ["--out", str(out), "--force", "--threads", "1", "--quiet"]


def run_logged(argv, log):
    log.parent.mkdir(parents=True, exist_ok=True)
    with open(log, "w") as f:
        f.write("$ " + " ".join(argv) + "\n")
        f.flush()
        return subprocess.run(argv, stdout=f, stderr=subprocess.STDOUT).returncode


def relax(binary, system, out):
    """A native run from the lattice; its last snapshot starts every counted run."""
    steps = SYSTEMS[system][2]
    rc = run_logged(hardrod_argv(binary, system, out, steps, None), out / "hardrod.log")
    trajectory = out / "trajectory.h5"
    if rc != 0 or not trajectory.exists():
        sys.exit(f"bench instructions: the relaxation of {system} failed (see {relpath(out)}/hardrod.log)")
    return trajectory


COST = re.compile(r"\s*(?:([\d,]+)(?: \(\s*[\d.]+%\))?|\.)(?=\s)")


def parse_annotate(text):
    """callgrind_annotate's totals and per-function self costs: (events, totals, [(name, costs)]).
    A line is one cost per event ("1,234 (5.6%)", "0" or "." for none), then the name."""
    events, totals, functions = [], None, []
    for line in text.splitlines():
        if line.startswith("Events shown:"):
            events = line.split(":", 1)[1].split()
            continue
        if not events or not re.match(r"^\s*[\d,]+ \(", line):
            continue
        costs, at = [], 0
        for _ in events:
            m = COST.match(line, at)
            if not m:
                break
            costs.append(int(m.group(1).replace(",", "")) if m.group(1) else 0)
            at = m.end()
        if len(costs) != len(events):
            continue
        name = line[at:].strip()
        if name == "PROGRAM TOTALS":
            totals = costs
        else:
            functions.append((short_name(name), costs))
    return events, totals, functions


def short_name(name):
    """'???:void hardrod::(anonymous namespace)::due_distances<true>(...) [clone .isra.0] [/path]'
    -> 'due_distances' (clones of one function then add up)."""
    name = re.sub(r"\s*\[/[^\]]*\]$", "", name)  # the object file
    name = re.sub(r"^(\?\?\?|[^ :]*\.[A-Za-z]+):", "", name)  # the source file, if any
    name = name.replace("(anonymous namespace)::", "").replace("hardrod::", "")
    name = re.sub(r"\s*\[clone [^\]]*\]", "", name)
    depth, out = 0, []
    for ch in name:  # drop the parameter lists and template arguments
        depth += ch in "(<"
        if depth == 0:
            out.append(ch)
        depth -= ch in ")>"
    short = [w for w in "".join(out).split() if w not in ("const", "noexcept")]
    return short[-1] if short else name


def merged(functions):
    """Costs of the same short name (a function's clones) added up, largest first."""
    total = {}
    for name, costs in functions:
        total[name] = [a + b for a, b in zip(total[name], costs)] if name in total else list(costs)
    return sorted(total.items(), key=lambda kv: -kv[1][0])


def count(binary, system, out, steps, start, cache_sim, ll):
    profile = out / "callgrind.out"
    argv = ["valgrind", "--tool=callgrind", *[f"--toggle-collect={name}" for name in ADVANCE],
            f"--callgrind-out-file={profile}"]
    if cache_sim:
        argv += ["--cache-sim=yes", f"--LL={ll}"]
    rc = run_logged(argv + hardrod_argv(binary, system, out, steps, start), out / "hardrod.log")
    summary = load_json(out / "summary.json")
    if rc != 0 or summary is None or not profile.exists():
        tail = (out / "hardrod.log").read_text(errors="replace").splitlines()[-3:]
        hint = " (an AVX-512 build? valgrind needs one made without -march=native)" \
            if any("Illegal" in l or "unhandled instruction" in l for l in tail) else ""
        return {"error": f"exit {rc}{hint}: " + " ".join(tail)[-300:]}
    text = subprocess.run(["callgrind_annotate", "--threshold=100", str(profile)],
                          capture_output=True, text=True).stdout
    events, totals, functions = parse_annotate(text)
    if totals is None or not totals[0]:
        return {"error": f"nothing counted: {ADVANCE[0]} is not in this build (inlined, as link-time "
                         "optimisation does; count a build without it)"}
    per = float(summary["n"]) * float(summary["steps_done"])
    return {"events": events, "per_particle_step": {e: t / per for e, t in zip(events, totals)},
            "functions": [(name, {e: c / per for e, c in zip(events, costs)})
                          for name, costs in merged(functions)],
            "checksum": summary.get("state_checksum"), "steps": summary["steps_done"],
            "n": summary["n"], "builds": summary.get("neighbor_list_builds")}


def main(args):
    systems = [s for s in args.systems.split(",") if s]
    unknown = [s for s in systems if s not in SYSTEMS]
    if unknown:
        sys.exit(f"bench instructions: --systems: unknown {', '.join(unknown)} "
                 f"(use {', '.join(SYSTEMS)})")
    binaries = [Path(b).resolve() for b in args.binary] or [DEFAULT_BUILD / "hardrod"]
    missing = [b for b in binaries if args.binary and not b.exists()]
    if missing:
        sys.exit(f"bench instructions: --binary {', '.join(map(str, missing))}: no such file")
    for tool in ("valgrind", "callgrind_annotate"):
        if not args.dry_run and shutil.which(tool) is None:
            sys.exit(f"bench instructions: {tool} not found (Debian: apt-get install valgrind)")
    if not args.binary and not binaries[0].exists():
        build_default(args.dry_run)
    out = make_outdir(args, "instructions")
    plan = [(s, k, max(1, round(SYSTEMS[s][3] * args.steps_scale))) for s in systems
            for k in range(len(binaries))]
    if args.dry_run:
        for s, k, steps in plan:
            print(f"(dry run) {s}: {steps} steps of {binaries[k]} under callgrind")
        return 0
    starts = {s: relax(binaries[0], s, out / "runs" / f"{s}-start") for s in systems}
    results = {}
    for s, k, steps in plan:
        print(f"bench instructions: {s}, build {label(k)} {relpath(binaries[k])}, {steps} steps",
              flush=True)
        results[(s, k)] = count(binaries[k], s, out / "runs" / f"{s}-{k}", steps, starts[s],
                                args.cache_sim, args.ll)
    return report(args, out, systems, binaries, results)


def label(k):
    """Build k's name in the tables: A, B, C, ..."""
    return chr(ord("A") + k)


def tabulate(systems, binaries, results, top):
    """A row per system and build, and the top functions of build A with the others' ratios."""
    labels = [label(k) for k in range(len(binaries))]
    rows, function_rows = [], []
    for s in systems:
        for k, tag in enumerate(labels):
            r = results[(s, k)]
            row = {"system": s, "build": tag, "binary": str(binaries[k]), "error": r.get("error")}
            if "error" not in r:
                row.update({"checksum": r["checksum"], "steps": r["steps"], "n": r["n"],
                            "builds": r["builds"],
                            **{f"{e}_per_particle_step": v for e, v in r["per_particle_step"].items()}})
            rows.append(row)
        base = results[(s, 0)]
        if "error" in base:
            continue
        for name, costs in base["functions"][:top]:
            frow = {"system": s, "function": name, "A_Ir": costs["Ir"]}
            for k in range(1, len(binaries)):
                other = dict(results[(s, k)].get("functions", []))
                if name in other:
                    frow[f"{labels[k]}_Ir"] = other[name]["Ir"]
                    frow[f"{labels[k]}/A"] = other[name]["Ir"] / costs["Ir"] if costs["Ir"] else None
            function_rows.append(frow)
    return rows, function_rows


def report(args, out, systems, binaries, results):
    labels = [label(k) for k in range(len(binaries))]
    rows, function_rows = tabulate(systems, binaries, results, args.top)
    events = next((r["events"] for r in results.values() if "events" in r), ["Ir"])
    columns = ["system", "build", "checksum", "steps", "n", "builds",
               *[f"{e}_per_particle_step" for e in events], "binary", "error"]
    write_csv(out / "instructions.csv", rows, columns)
    write_csv(out / "functions.csv", function_rows,
              ["system", "function", "A_Ir", *[f"{l}_Ir" for l in labels[1:]],
               *[f"{l}/A" for l in labels[1:]]])
    write_json(out / "instructions.json", {"rows": rows, "functions": function_rows})
    shown = [e for e in ("Ir", "D1mr", "DLmr") if e in events]
    table = markdown_table(
        ["system", "build", *[f"{e} per particle-step" for e in shown], "vs A", "checksum"],
        [[r["system"], r["build"], *[g(r.get(f"{e}_per_particle_step"), 5) for e in shown],
          g(ratio(rows, r)), r.get("checksum") or r.get("error")] for r in rows])
    ftable = markdown_table(
        ["system", "function", "A Ir per particle-step", *[f"{l} / A" for l in labels[1:]]],
        [[f["system"], f["function"], g(f["A_Ir"], 4), *[g(f.get(f"{l}/A"), 4) for l in labels[1:]]]
         for f in function_rows])
    dtable = markdown_table(["system", "function", "B - A Ir per particle-step"],
                            differences(systems, results)) if len(binaries) == 2 else ""
    lines = [report_header("Instructions per particle-step (callgrind)"),
             "Builds: " + ", ".join(f"{l} = `{relpath(b)}`" for l, b in zip(labels, binaries)) + "\n",
             table, "", "Functions by their own instructions (build A), per particle-step. The "
             "compiler may inline a function into another in one build and not in the other: "
             "the totals above are the measure, these say where.", "", ftable, ""]
    if dtable:
        lines += ["The largest differences, B - A, per particle-step:", "", dtable, ""]
    write_text(out / "report.md", "\n".join(lines))
    print(table)
    print()
    print(ftable)
    if dtable:
        print()
        print(dtable)
    print(f"\nbench instructions: wrote {relpath(out)}/report.md")
    return 1 if any(r.get("error") for r in rows) else 0


def differences(systems, results, count=6):
    """Per system, the functions whose own instructions changed most between builds A and B."""
    out = []
    for s in systems:
        a, b = results[(s, 0)], results[(s, 1)]
        if "error" in a or "error" in b:
            continue
        fa = {n: c["Ir"] for n, c in a["functions"]}
        fb = {n: c["Ir"] for n, c in b["functions"]}
        diffs = sorted(((fb.get(n, 0.0) - fa.get(n, 0.0), n) for n in set(fa) | set(fb)),
                       key=lambda d: -abs(d[0]))
        out += [[s, n, f"{d:+.4g}"] for d, n in diffs[:count] if d]
    return out


def ratio(rows, row):
    """Instructions of this row against build A of the same system."""
    base = next((r for r in rows if r["system"] == row["system"] and r["build"] == "A"), None)
    a, b = (base or {}).get("Ir_per_particle_step"), row.get("Ir_per_particle_step")
    return b / a if a and b else None
