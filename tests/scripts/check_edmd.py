#!/usr/bin/env python3
"""`scripts/bench edmd` without running either code.

1. A --source without the event-driven code's three files, and bad lengths or rounds, are
   refused, naming what is wrong.
2. The copy of mdSingle.c gets the harness's settings (the run's length as MAXTIME, an fcc
   start, packing fraction 0.45, N = 32000), each found exactly once; a setting it cannot find
   is named.
3. The dry run lists the two builds (MAXTIME 5 and 25, the code's own flags), then per round
   the short pair and the long pair, the two codes on different cores, swapped from one round
   to the next; hardrod's exact method on spheres at N = 32768 from its lattice, one thread, for
   the same simulated time as the event-driven run.
4. The analysis: a code's cost is its long run's CPU less its short run's, over the time
   between and its N; the medians of the costs and of the rounds' ratios.
"""

import pathlib
import tempfile

from bench_cli import check, run_cli
from hardrod_bench import edmd

SOURCE = """#include "mdSingle.h"
double maxtime = 10;           //Simulation stops at this time
int initialconfig = 0;    //= 0 load from file, 1 = FCC crystal
double packfrac = 0.49;                     //Packing fraction (for initialconfig = 1)
int N = 4000;             //Number of particles (for FCC)
int main() { return 0; }
"""


def fake_source(directory, text=SOURCE):
    directory.mkdir()
    (directory / "mdSingle.c").write_text(text)
    for f in ("mdSingle.h", "mt19937ar.c"):
        (directory / f).write_text("")
    return directory


def flags(tmp):
    results = ["--results", str(tmp / "results")]
    status, _ = run_cli(["edmd", "--dry-run", "--source", str(tmp / "none"), *results])
    check(isinstance(status, str) and "mdSingle.c" in status and "none" in status,
          f"a source without the code is named ({status})")
    src = fake_source(tmp / "src")
    for bad in (["--rounds", "0"], ["--short", "30"], ["--short", "0"], ["--dt", "0"], ["--skin", "-1"]):
        status, _ = run_cli(["edmd", "--dry-run", "--source", str(src), *bad, *results])
        check(isinstance(status, str) and f"{bad[0]} {bad[1]}" in status, f"{' '.join(bad)} is refused, named ({status})")
    broken = fake_source(tmp / "broken", SOURCE.replace("int N = 4000;", ""))
    status, _ = run_cli(["edmd", "--dry-run", "--source", str(broken), *results])
    check(isinstance(status, str) and "N" in status and "0 times" in status, f"a missing setting is named ({status})")
    return src


def patch():
    text = edmd.patched_source(SOURCE)
    for line in ("double maxtime = MAXTIME;", "int initialconfig = 1;", "double packfrac = 0.45;",
                 "int N = 32000;"):
        check(line in text, f"the copy sets `{line}`")
    check("= 10;" not in text and "0.49" not in text and "4000" not in text, "the shipped values are gone")


def dry_run(src, tmp):
    status, text = run_cli(["edmd", "--dry-run", "--source", str(src), "--rounds", "2",
                            "--results", str(tmp / "results")])
    lines = [l for l in text.splitlines() if l.startswith("(dry run)")]
    check(status == 0 and len(lines) == 2 + 2 * 4, f"two builds, then four runs a round ({len(lines)})")
    check("-DMAXTIME=5 " in lines[0] and "-DMAXTIME=25 " in lines[1] and
          all(f in lines[0] for f in ("-Ofast", "-funroll-loops", "-march=native", "-lm")),
          "built for 5 and 25 tau with the code's own flags")
    runs = lines[2:]
    check([l.split("]")[0].split("[")[1].split(",")[0] for l in runs] ==
          ["edmd short", "hardrod short", "edmd long", "hardrod long"] * 2,
          "per round the short pair, then the long pair")
    if "taskset" in runs[0]:
        core = lambda l: l.split("taskset -c ")[1].split()[0]  # noqa: E731
        check(core(runs[0]) != core(runs[1]) and core(runs[0]) == core(runs[2]) and
              core(runs[4]) == core(runs[1]), "one core each, swapped in the next round")
    hardrod = [l for l in runs if l.startswith("(dry run) [hardrod")]
    check(all("system.n=32768" in l and "init.lattice=[32,32,32]" in l and "run.method=exact" in l and
              "run.dt=0.004" in l and "run.skin=0.5" in l and "--threads 1" in l for l in hardrod),
          "hardrod: spheres at N = 32768 from the lattice, exact, dt 4e-3, skin 0.5, one thread")
    check("run.steps=1250" in hardrod[0] and "run.steps=6250" in hardrod[1], "for 5 and 25 tau")
    check(not (tmp / "results").exists() or not any((tmp / "results").iterdir()), "the dry run writes nothing")


def analysis():
    # 20 tau between the runs: 32000 particles at 24 s and 40 s (25 us), 32768 at 22.6 s and 39 s.
    e = edmd.per_particle_tau(24.0, 40.0, 5.0, 25.0, 32000)
    h = edmd.per_particle_tau(22.6, 39.0, 5.0, 25.0, 32768)
    check(abs(e - 25.0) < 1e-9 and abs(h - 16.4 / 20 / 32768 * 1e6) < 1e-9, "cost = (long - short) / time / N")
    check(edmd.per_particle_tau(None, 40.0, 5.0, 25.0, 32000) is None, "a failed run gives no cost")
    rows = [{"edmd_us": 20.0, "hardrod_us": 22.0, "ratio": 1.1}, {"edmd_us": 30.0, "hardrod_us": 27.0, "ratio": 0.9},
            {"edmd_us": 24.0, "hardrod_us": 24.0, "ratio": 1.0}, {"edmd_us": None, "hardrod_us": 5.0, "ratio": None}]
    s = edmd.analyse(rows)
    check(s["rounds"] == 3 and s["edmd_us"] == 24.0 and s["hardrod_us"] == 24.0 and s["median_ratio"] == 1.0 and
          s["hardrod_at_or_below"] == 2 and s["ratio_low"] == 0.9 and s["ratio_high"] == 1.1,
          "medians over the completed rounds; rounds at or below 1")


def main():
    with tempfile.TemporaryDirectory() as t:
        tmp = pathlib.Path(t)
        src = flags(tmp)
        patch()
        dry_run(src, tmp)
        analysis()


if __name__ == "__main__":
    main()
