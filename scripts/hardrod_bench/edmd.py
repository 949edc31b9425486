"""`scripts/bench edmd`: hardrod's exact method against event-driven MD, side by side.

The hard-sphere speed goal: at packing fraction 0.45 on one core, CPU per particle per tau at
most that of event-driven MD. The anchor is Smallenburg's public event-driven code (Eur.
Phys. J. E 45, 22 (2022); its `Single` variant: mdSingle.c, mdSingle.h, mt19937ar.c), which is
not part of this repository: --source names a copy of it. Its settings are globals in the
source; this harness sets them in a copy (an fcc start, packing fraction 0.45, N = 32000, and
the run's length as MAXTIME) and builds it with its own Makefile's flags.

The protocol: each code runs from its lattice to a short time and, separately, to a long one
(5 and 25 tau); its cost is the CPU time of the long run less the short one's, over the time
between and its N, so that the start drops out. The two codes run at the same time, one per
core (taskset), and swap cores each round: the two runs of a round meet the same load, and a
round's ratio is taken from its own pair. Writes edmd.csv, edmd.json, report.md.
"""

import os
import re
import shutil
import statistics
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from .common import (HARDROD, ROOT, common_arguments, ensure_built, g, make_outdir, markdown_table,
                     relpath, report_header, write_csv, write_json, write_text)

HELP = "hard spheres against event-driven MD, side by side (the hard-sphere speed goal)"
DESCRIPTION = ("Build Smallenburg's event-driven MD (--source: its Single variant) for a short "
               "and a long run, and run it and hardrod's exact method on hard spheres at packing "
               "fraction 0.45 at the same time, one core each, swapped each round; report each "
               "code's CPU per particle per tau (long run less short) and their ratio per round "
               "and as medians. Writes edmd.csv, edmd.json, report.md.")

SOURCES = ("mdSingle.c", "mdSingle.h", "mt19937ar.c")
EDMD_N, HARDROD_N, LATTICE = 32000, 32768, 32
PACKING = 0.45
# The globals set in the copy of mdSingle.c: (what, pattern, replacement).
SETTINGS = (
    ("the run's length", r"^double maxtime = [^;]+;", "double maxtime = MAXTIME;"),
    ("an fcc start", r"^int initialconfig = [^;]+;", "int initialconfig = 1;"),
    ("the packing fraction", r"^double packfrac = [^;]+;", f"double packfrac = {PACKING};"),
    ("N", r"^int N = [^;]+;", f"int N = {EDMD_N};"),
)
CFLAGS = ["-Wall", "-Ofast", "-funroll-loops", "-march=native"]  # its Makefile's


def add_arguments(sp):
    common_arguments(sp, jobs=False)
    sp.add_argument("--source", required=True,
                    help="a directory with the event-driven code's mdSingle.c, mdSingle.h, mt19937ar.c")
    sp.add_argument("--binary", default=str(HARDROD), help="the hardrod to run (default build/hardrod)")
    sp.add_argument("--rounds", type=int, default=8, help="rounds (default 8)")
    sp.add_argument("--dt", type=float, default=4e-3, help="hardrod's run.dt (default 4e-3)")
    sp.add_argument("--skin", type=float, default=0.5, help="hardrod's run.skin (default 0.5)")
    sp.add_argument("--short", type=float, default=5.0, help="the short runs' length in tau (default 5)")
    sp.add_argument("--long", type=float, default=25.0, help="the long runs' length in tau (default 25)")


def patched_source(text):
    """mdSingle.c with the harness's settings; exits naming a setting it cannot find once."""
    for what, pattern, replacement in SETTINGS:
        text, count = re.subn(pattern, replacement, text, flags=re.MULTILINE)
        if count != 1:
            sys.exit(f"bench edmd: mdSingle.c: {what} ({pattern}) found {count} times, expected once")
    return text


def compile_commands(src, tau_short, tau_long):
    """The two builds of the event-driven code: (name, command)."""
    return [(f"edmd-{name}", ["gcc", *CFLAGS, f"-DMAXTIME={tau:g}", str(src / "mdSingle.c"),
                              "-o", str(src / f"edmd-{name}"), "-lm"])
            for name, tau in (("short", tau_short), ("long", tau_long))]


def hardrod_command(binary, dt, skin, tau, out):
    return [str(binary), "run", str(ROOT / "scenes" / "hard-spheres.toml"),
            "--set", f"system.n={HARDROD_N}", "--set", f"init.lattice=[{LATTICE},{LATTICE},{LATTICE}]",
            "--set", "run.method=exact", "--set", f"run.dt={dt:g}", "--set", f"run.skin={skin:g}",
            "--set", "run.equilibration_steps=0", "--set", f"run.steps={round(tau / dt)}",
            "--threads", "1", "--quiet", "--force", "--out", str(out)]


def plan(args, src, out):
    """Per round two pairs (short, then long), each an event-driven and a hardrod run with the
    cores they are pinned to: (code, length, core, command, working directory, log)."""
    side_by_side = (os.cpu_count() or 1) >= 2
    rounds = []
    for k in range(1, args.rounds + 1):
        cores = (0, 1) if k % 2 else (1, 0)
        pairs = []
        for length, tau in (("short", args.short), ("long", args.long)):
            where = out / "runs" / f"round{k}-{length}"
            pin = lambda core: ["taskset", "-c", str(core)] if side_by_side else []  # noqa: E731
            pairs.append([
                ("edmd", length, cores[0], [*pin(cores[0]), str(src / f"edmd-{length}")], where / "edmd",
                 where / "edmd.log"),
                ("hardrod", length, cores[1],
                 [*pin(cores[1]), *hardrod_command(args.binary, args.dt, args.skin, tau, where / "hardrod")],
                 where, where / "hardrod.log"),
            ])
        rounds.append(pairs)
    return rounds, side_by_side


def cpu_seconds(command, cwd, log):
    """Run `command` in `cwd`; its user + system CPU seconds (None if it failed)."""
    cwd.mkdir(parents=True, exist_ok=True)
    with open(log, "w") as f:
        proc = subprocess.Popen(command, cwd=cwd, stdout=f, stderr=subprocess.STDOUT)
        _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    return usage.ru_utime + usage.ru_stime if proc.returncode == 0 else None


def run_pair(pair):
    with ThreadPoolExecutor(max_workers=2) as pool:
        return list(pool.map(lambda r: cpu_seconds(*r[3:]), pair))


def per_particle_tau(short, long, tau_short, tau_long, n):
    """us of CPU per particle per tau between the short run's end and the long run's."""
    if short is None or long is None:
        return None
    return (long - short) / (tau_long - tau_short) / n * 1e6


def analyse(rows):
    """Medians of each code's cost and of the rounds' ratios, and the ratio of the medians."""
    done = [r for r in rows if r["ratio"] is not None]
    if not done:
        return {"rounds": 0}
    edmd = statistics.median(r["edmd_us"] for r in done)
    hardrod = statistics.median(r["hardrod_us"] for r in done)
    return {"rounds": len(done), "edmd_us": edmd, "hardrod_us": hardrod,
            "median_ratio": statistics.median(r["ratio"] for r in done),
            "ratio_of_medians": hardrod / edmd, "hardrod_at_or_below": sum(r["ratio"] <= 1.0 for r in done),
            "ratio_low": min(r["ratio"] for r in done), "ratio_high": max(r["ratio"] for r in done)}


def prepare(args, out):
    """The patched copy of the event-driven code in out/edmd, built twice."""
    source = Path(args.source)
    missing = [f for f in SOURCES if not (source / f).is_file()]
    if missing:
        sys.exit(f"bench edmd: --source {args.source}: no {', '.join(missing)}")
    src = out / "edmd"
    commands = compile_commands(src, args.short, args.long)
    if args.dry_run:
        patched_source((source / "mdSingle.c").read_text())  # its settings found, or named
        for _, command in commands:
            print("(dry run) " + " ".join(command))
        return src
    src.mkdir(parents=True)
    for f in SOURCES:
        shutil.copy(source / f, src / f)
    (src / "mdSingle.c").write_text(patched_source((source / "mdSingle.c").read_text()))
    for name, command in commands:
        built = subprocess.run(command, capture_output=True, text=True)
        if built.returncode != 0:
            sys.exit(f"bench edmd: building {name} failed:\n{built.stderr}")
    return src


def report(args, out, rows, summary, side_by_side):
    columns = ["round", "edmd_short_s", "edmd_long_s", "hardrod_short_s", "hardrod_long_s",
               "edmd_us", "hardrod_us", "ratio"]
    write_csv(out / "edmd.csv", rows, columns)
    write_json(out / "edmd.json", {"dt": args.dt, "skin": args.skin, "short_tau": args.short,
                                   "long_tau": args.long, "edmd_n": EDMD_N, "hardrod_n": HARDROD_N,
                                   "side_by_side": side_by_side, "rows": rows, "summary": summary})
    table = markdown_table(["round", "event-driven MD (us)", "hardrod (us)", "hardrod / event-driven"],
                           [[r["round"], g(r["edmd_us"]), g(r["hardrod_us"]), g(r["ratio"])] for r in rows])
    how = "side by side, one core each, swapped each round" if side_by_side else "in turns"
    if summary["rounds"]:
        text = (f"CPU per particle per tau, {args.long:g} tau less {args.short:g}, {how}; hardrod exact at dt "
                f"{args.dt:g}, skin {args.skin:g} (N = {HARDROD_N}), event-driven MD N = {EDMD_N}. Medians: "
                f"event-driven MD {g(summary['edmd_us'])} us, hardrod {g(summary['hardrod_us'])} us; the rounds' "
                f"ratio {g(summary['median_ratio'])} ({g(summary['ratio_low'])}-{g(summary['ratio_high'])}), "
                f"hardrod at or below in {summary['hardrod_at_or_below']} of {summary['rounds']}; the ratio of "
                f"the medians {g(summary['ratio_of_medians'])}.")
    else:
        text = "No round completed (see the runs' logs)."
    write_text(out / "report.md", "\n".join([report_header("Hard spheres against event-driven MD"), text, "",
                                             table, ""]))
    print(table)
    print(f"\n{text}\nbench edmd: wrote {relpath(out)}/report.md")
    return 0 if summary["rounds"] == args.rounds else 1


def main(args):
    for bad, what in ((args.rounds < 1, f"--rounds {args.rounds}: at least 1"),
                      (not 0 < args.short < args.long,
                       f"--short {args.short:g} --long {args.long:g}: 0 < short < long"),
                      (not args.dt > 0, f"--dt {args.dt:g}: above 0"),
                      (not args.skin > 0, f"--skin {args.skin:g}: above 0")):
        if bad:
            sys.exit(f"bench edmd: {what}")
    if not args.dry_run:
        if Path(args.binary).resolve() == HARDROD:
            ensure_built(args, [HARDROD])  # the project's own build, made if missing
        elif not Path(args.binary).exists():
            sys.exit(f"bench edmd: --binary {args.binary}: no such file")
    out = make_outdir(args, "edmd")
    src = prepare(args, out)
    rounds, side_by_side = plan(args, src, out)
    if args.dry_run:
        for pairs in rounds:
            for pair in pairs:
                for code, length, _, command, where, _ in pair:
                    print(f"(dry run) [{code} {length}, in {relpath(where)}] " + " ".join(command))
        return 0
    rows = []
    for k, (short_pair, long_pair) in enumerate(rounds, start=1):
        if side_by_side:
            (es, hs), (el, hl) = run_pair(short_pair), run_pair(long_pair)
        else:
            es, hs, el, hl = (cpu_seconds(*r[3:]) for r in (*short_pair, *long_pair))
        e = per_particle_tau(es, el, args.short, args.long, EDMD_N)
        h = per_particle_tau(hs, hl, args.short, args.long, HARDROD_N)
        rows.append({"round": k, "edmd_short_s": es, "edmd_long_s": el, "hardrod_short_s": hs,
                     "hardrod_long_s": hl, "edmd_us": e, "hardrod_us": h,
                     "ratio": h / e if e and h else None})
        print(f"  round {k}: event-driven MD {g(e)} us, hardrod {g(h)} us, ratio {g(rows[-1]['ratio'])}", flush=True)
    return report(args, out, rows, analyse(rows), side_by_side)
