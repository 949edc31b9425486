#!/usr/bin/env python3
"""`scripts/bench ab` without running hardrod.

1. A missing build, a bad --config, zero rounds and a missing --start are refused, naming the
   value.
2. The dry run lists per round A's run and B's, each pinned to its own core (swapped from one
   round to the next), with the same settings from the same start on one thread; it writes
   nothing. Without --start the relaxation comes first.
3. The analysis: per measure the medians of A and B, the median over rounds of B / A (each
   round's ratio from its own pair), how many rounds B was lower, and whether the checksums
   agree.
"""

import pathlib
import tempfile

from bench_cli import check, run_cli
from hardrod_bench import ab


def flags():
    with tempfile.TemporaryDirectory() as tmp:
        results = ["--results", tmp]
        a, b = pathlib.Path(tmp) / "hardrod-a", pathlib.Path(tmp) / "hardrod-b"
        start = pathlib.Path(tmp) / "start.h5"
        for f in (a, b, start):
            f.write_text("")
        builds = ["--binary", str(a), "--binary", str(b)]
        status, _ = run_cli(["ab", "--dry-run", *results])
        check(isinstance(status, str) and "--base" in status and "--binary" in status,
              f"no build A is refused ({status})")
        status, _ = run_cli(["ab", "--binary", f"{tmp}/none", "--start", str(start), *results])
        check(isinstance(status, str) and f"{tmp}/none" in status, f"a missing build is named ({status})")
        status, _ = run_cli(["ab", "--dry-run", "--config", "1e-3", *builds, *results])
        check(isinstance(status, str) and "1e-3" in status, f"a bad --config is named ({status})")
        status, _ = run_cli(["ab", "--dry-run", "--rounds", "0", *builds, *results])
        check(isinstance(status, str) and "--rounds" in status, f"zero rounds are refused ({status})")
        status, _ = run_cli(["ab", "--dry-run", "--start", f"{tmp}/none.h5", *builds, *results])
        check(isinstance(status, str) and "none.h5" in status, f"a missing start is named ({status})")

        status, text = run_cli(["ab", "--dry-run", "--rounds", "2", "--start", str(start), *builds, *results])
        lines = [l for l in text.splitlines() if l.startswith("(dry run)")]
        check(status == 0 and len(lines) == 4, f"two runs a round, no relaxation with --start ({len(lines)})")
        check(str(a) in lines[0] and str(b) in lines[1] and str(a) in lines[2] and str(b) in lines[3],
              "A, then B, in each round")
        if "taskset" in lines[0]:
            check("taskset -c 0" in lines[0] and "taskset -c 1" in lines[1] and
                  "taskset -c 1" in lines[2] and "taskset -c 0" in lines[3],
                  "one core each, swapped in the next round")
        strip = lambda l, binary: l.split(str(binary))[1].split("--out")[0]  # noqa: E731
        check(strip(lines[0], a) == strip(lines[1], b), "A and B with the same settings")
        check(all("--threads 1" in l and str(start) in l and "run.dt=0.001" in l and "run.steps=3000" in l
                  for l in lines), "one thread, from the start, the nematic's dt 1e-3 for 3 tau")
        status, text = run_cli(["ab", "--dry-run", "--rounds", "1", "--system", "spheres", *builds, *results])
        lines = [l for l in text.splitlines() if l.startswith("(dry run)")]
        check(status == 0 and len(lines) == 3 and "runs/relax" in lines[0] and "init.lattice" in lines[0],
              f"without --start the relaxation from the lattice comes first ({len(lines)})")
        check(all("system.n=32768" in l for l in lines) and "run.dt=0.004" in lines[1] and
              "run.skin=0.5" in lines[1] and "relax/trajectory.h5" in lines[1],
              "spheres at N = 32768, dt 4e-3, skin 0.5, from the relaxed state")
        status, text = run_cli(["ab", "--dry-run", "--rounds", "1", "--method", "midpoint", "--start", str(start),
                                *builds, *results])
        lines = [l for l in text.splitlines() if l.startswith("(dry run)")]
        check(status == 0 and len(lines) == 2 and all("run.method=\"midpoint\"" in l or "run.method=midpoint" in l
                                                       for l in lines),
              f"--method midpoint runs the midpoint method in both builds ({lines})")
        check(all("run.dt=0.0001" in l and "run.steps=3000" in l for l in lines),
              "the midpoint method at its dt 1e-4 for a tenth of the time (0.3 tau)")
        check(not any(pathlib.Path(tmp).glob("ab-*")), "the dry run writes nothing")


def analysis():
    def row(k, build, us, build_time_ratio, checksum="c1"):
        return {"round": k, "build": build, "us_per_particle_tau": us, "step_over_build": build_time_ratio,
                "detect_over_build": None, "resolve_over_build": 1.0, "integrate_over_build": 1.0,
                "checksum": checksum}
    rows = [row(1, "A", 100.0, 5.0), row(1, "B", 90.0, 4.0),
            row(2, "A", 200.0, 5.0), row(2, "B", 220.0, 5.5),
            row(3, "A", 100.0, 4.0), row(3, "B", 80.0, 4.0)]
    summary, same = ab.analyse(rows)
    s = {x["measure"]: x for x in summary}
    us = s["us_per_particle_tau"]
    check(abs(us["median_ratio"] - 0.9) < 1e-12 and us["b_lower"] == 2 and us["rounds"] == 3,
          f"each round's B / A (0.9, 1.1, 0.8), their median and how often B was lower ({us})")
    check(us["median_a"] == 100.0 and us["median_b"] == 90.0, "the builds' own medians")
    check(abs(s["step_over_build"]["median_ratio"] - 1.0) < 1e-12, "ratios of the normalised step too")
    check(s["detect_over_build"]["rounds"] == 0 and s["detect_over_build"]["median_ratio"] is None,
          "a measure no run has is left empty")
    for r, seconds in zip(rows, [2.0, 1.5, 4.0, 3.6, 2.0, 1.6]):
        r["neighbor_build_seconds"] = seconds
    build = {x["measure"]: x for x in ab.analyse(rows)[0]}["neighbor_build_seconds"]
    check(abs(build["median_ratio"] - 0.8) < 1e-12 and build["b_lower"] == 3,
          f"the regions' own seconds, B / A within each round (0.75, 0.9, 0.8): {build}")
    check(same, "one checksum: the same trajectory")
    rows[-1]["checksum"] = "c2"
    check(not ab.analyse(rows)[1], "two checksums are told")


if __name__ == "__main__":
    flags()
    analysis()
    print("all checks passed")
