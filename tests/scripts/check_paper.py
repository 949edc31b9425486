#!/usr/bin/env python3
"""`scripts/bench paper` without running hardrod: the dry run of both collision methods.

1. The midpoint method (the default) keeps the commands of the paper's protocol as they were
   (dt 1e-4, no run.method key, results/paper), so runs made before are still recognised.
2. --method exact adds run.method, takes dt 1e-3 and keeps the sampling every 0.02 tau and the
   checkpoints every 10 tau in steps of that dt, in its own results/paper-exact.
3. An explicit --dt and --out are kept.
"""

import tempfile

from bench_cli import check, run_cli


def commands(argv):
    status, text = run_cli(["paper", "--dry-run", "--sizes", "2304", "--seeds", "1", *argv])
    return status, [l for l in text.splitlines() if "hardrod run" in l]


def main():
    status, lines = commands([])
    check(status == 0 and len(lines) == 1, f"one run listed ({lines})")
    line = lines[0]
    check("run.dt=0.0001" in line and "run.method" not in line and "run.sample_interval=200" in line
          and "/results/paper/n2304/seed1" in line, f"midpoint: the protocol's command as before ({line})")
    status, lines = commands(["--method", "exact"])
    line = lines[0] if lines else ""
    check(status == 0 and "run.method=\"exact\"" in line and "run.dt=0.001" in line
          and "run.sample_interval=20 " in line and "output.checkpoint_interval=10000" in line
          and "/results/paper-exact/n2304/seed1" in line, f"exact: its dt, sampling and directory ({line})")
    with tempfile.TemporaryDirectory() as tmp:
        status, lines = commands(["--method", "exact", "--dt", "2e-3", "--out", tmp])
        line = lines[0] if lines else ""
        check(status == 0 and "run.dt=0.002" in line and "run.sample_interval=10 " in line
              and f"{tmp}/n2304/seed1" in line, f"an explicit --dt and --out are kept ({line})")


if __name__ == "__main__":
    main()
    print("all checks passed")
