#!/usr/bin/env python3
"""`scripts/bench answer` without running hardrod: the dry run of both collision methods.

The midpoint method (the default) keeps its commands (dt 1e-4, a sample every 1000 steps, no
run.method key, so `--reuse` still finds earlier runs); --method exact adds run.method, takes
dt 1e-3 and keeps a sample every 0.1 tau (100 steps); an explicit --sample-interval is kept.
"""

import tempfile

from bench_cli import check, run_cli


def commands(argv, tmp):
    status, text = run_cli(["answer", "--dry-run", "--tau", "10", "--results", tmp, *argv])
    return status, [l for l in text.splitlines() if "hardrod run" in l]


def main():
    with tempfile.TemporaryDirectory() as tmp:
        status, lines = commands([], tmp)
        check(status == 0 and len(lines) == 2 and all(
            "run.dt=0.0001" in l and "run.sample_interval=1000 " in l and "run.steps=100000 " in l
            and "run.method" not in l for l in lines), f"midpoint: the commands as before ({lines})")
        status, lines = commands(["--method", "exact"], tmp)
        check(status == 0 and len(lines) == 2 and all(
            "run.dt=0.001" in l and "run.sample_interval=100 " in l and "run.steps=10000 " in l
            and 'run.method="exact"' in l for l in lines), f"exact: dt 1e-3, 0.1 tau samples ({lines})")
        check("isotropic" in lines[1], "both starts, the isotropic one second")
        status, lines = commands(["--method", "exact", "--sample-interval", "7"], tmp)
        check(status == 0 and all("run.sample_interval=7 " in l for l in lines),
              "an explicit --sample-interval is kept")


if __name__ == "__main__":
    main()
    print("all checks passed")
