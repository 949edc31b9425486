#!/usr/bin/env python3
"""`scripts/bench versus` without running hardrod.

1. Bad --configs entries, rounds and a missing --anchor-binary are refused, naming the value.
2. The dry run lists the relaxation, then per round the anchor's run first and one exact run
   per configuration, every one from the relaxed state on one thread; it writes nothing. The
   spheres' runs are at N = 32768 with their own defaults.
3. The analysis: each exact run's ratio is to the anchor of its own round, the medians are of
   those ratios, and the goal is judged on the median.
"""

import pathlib
import tempfile

from bench_cli import check, run_cli
from hardrod_bench import versus


def flags():
    with tempfile.TemporaryDirectory() as tmp:
        results = ["--results", tmp]
        fake = pathlib.Path(tmp) / "hardrod-anchor"
        fake.write_text("")
        anchor = ["--anchor-binary", str(fake)]
        for bad in ("1e-3", "1e-3:x", "-1e-3:1.0", ""):
            status, _ = run_cli(["versus", "--dry-run", f"--configs={bad}", *anchor, *results])
            check(isinstance(status, str) and "--configs" in status and (bad == "" or bad in status),
                  f"--configs '{bad}' is refused by name ({status})")
        status, _ = run_cli(["versus", "--dry-run", "--rounds", "0", *anchor, *results])
        check(isinstance(status, str) and "--rounds" in status, f"zero rounds are refused ({status})")
        status, _ = run_cli(["versus", "--dry-run", "--anchor-binary", f"{tmp}/none", *results])
        check(isinstance(status, str) and f"{tmp}/none" in status, f"a missing anchor is named ({status})")
        status, text = run_cli(["versus", "--dry-run", "--rounds", "2", "--configs", "1e-3:1.0,2e-3:0.6",
                                *anchor, *results])
        lines = [l for l in text.splitlines() if l.startswith("(dry run)")]
        check(status == 0 and len(lines) == 1 + 2 * 3, f"relaxation plus 2 x 3 runs ({len(lines)})")
        check("runs/relax" in lines[0] and "run.steps=20000" in lines[0], "the relaxation comes first")
        check(str(fake) in lines[1] and "run.dt=0.0001" in lines[1] and "run.method" not in lines[1],
              "each round starts with the anchor's midpoint run")
        check(all("--threads 1" in l and "relax/trajectory.h5" in l for l in lines[1:]),
              "every timed run is on one thread, from the relaxed state")
        check("run.dt=0.002" in lines[3] and "run.skin=0.6" in lines[3] and '"exact"' in lines[3],
              "the exact runs follow, one per configuration")
        status, text = run_cli(["versus", "--dry-run", "--system", "spheres", "--rounds", "1", *anchor, *results])
        lines = [l for l in text.splitlines() if l.startswith("(dry run)")]
        check(status == 0 and len(lines) == 3 and all("hard-spheres.toml" in l and "system.n=32768" in l
                                                      for l in lines),
              f"spheres: the relaxation, the anchor and one exact run, all at N = 32768 ({len(lines)})")
        check("init.lattice" in lines[0] and not any("init.lattice" in l for l in lines[1:]) and
              "run.dt=0.004" in lines[2] and "run.skin=0.5" in lines[2] and "run.steps=500" in lines[2],
              "spheres: the lattice only for the relaxation; dt 4e-3, skin 0.5, 2 tau by default")
        check(not any(pathlib.Path(tmp).glob("versus-*")), "the dry run writes nothing")


def analysis():
    rows = [{"round": 1, "config": "anchor", "us_per_particle_tau": 200.0},
            {"round": 1, "config": "exact", "us_per_particle_tau": 100.0},
            {"round": 2, "config": "anchor", "us_per_particle_tau": 400.0},
            {"round": 2, "config": "exact", "us_per_particle_tau": 100.0},
            {"round": 3, "config": "anchor", "us_per_particle_tau": 300.0},
            {"round": 3, "config": "exact", "us_per_particle_tau": 60.0}]
    summary = {s["config"]: s for s in versus.analyse(rows, ["anchor", "exact"], 0.24)}
    e = summary["exact"]
    check(abs(e["median_ratio"] - 0.25) < 1e-12 and abs(e["min_ratio"] - 0.2) < 1e-12,
          f"ratios to each round's anchor, their median ({e})")
    check(e["goal_met"] is False, "the goal is judged on the median ratio (0.25 > 0.24)")
    check(summary["anchor"]["median_us_per_particle_tau"] == 300.0 and "median_ratio" not in summary["anchor"],
          "the anchor's own costs, without a ratio")


if __name__ == "__main__":
    flags()
    analysis()
    print("all checks passed")
