#!/usr/bin/env python3
"""`scripts/bench methods` without running hardrod: its runs, its refusals and its verdict.

1. The dry run: per seed one exact equilibration (dt 1e-3) from the lattice that writes its last
   frame, then one run per variant from that frame, each sampled every 0.02 tau.
2. A bad --variants entry or a non-positive length is refused, naming it.
3. The comparison: a variant whose P* differs from the reference by five of its errors is
   flagged, one within its errors agrees; seeds missing a variant are left out; the P*-S line
   through runs near a known line recovers its slope, and P* at equal S takes it off.
"""

import contextlib
import io
import sys
import tempfile
from pathlib import Path

from bench_cli import check, run_cli

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "scripts"))
from hardrod_bench import methods  # noqa: E402


def dry_run():
    with tempfile.TemporaryDirectory() as out:  # a dry run writes nothing there
        status, text = run_cli(["methods", "--dry-run", "--seeds", "2", "--out", out])
    lines = [l for l in text.splitlines() if "hardrod run" in l]
    check(status == 0 and len(lines) == 8, f"2 equilibrations and 2 x 3 variants listed ({len(lines)})")
    equil = lines[0]
    check("run.method=\"exact\"" in equil and "run.dt=0.001" in equil and "run.steps=600000" in equil
          and "output.snapshot_interval=600000" in equil and "init.file" not in equil
          and "seed1/equilibration" in equil, f"the equilibration from the lattice ({equil})")
    variants = [l for l in lines if "init.file" in l]
    check(len(variants) == 6 and all("equilibration/trajectory.h5" in l for l in variants),
          "every variant starts from its seed's equilibrated frame")
    midpoint = [l for l in variants if "run.method=\"midpoint\"" in l]
    check(len(midpoint) == 2 and all("run.dt=0.0001" in l and "run.steps=1000000" in l
                                     and "run.sample_interval=200 " in l for l in midpoint),
          f"the midpoint variant at dt 1e-4 for 100 tau ({midpoint})")


def refusals():
    for argv, word in ((["--variants", "exact:1e-3,leapfrog:1e-3"], "leapfrog"),
                       (["--variants", "exact:1e-3,exact:1e-3"], "exact:1e-3"),
                       (["--prod-tau", "0"], "--prod-tau")):
        err = io.StringIO()
        with contextlib.redirect_stderr(err):
            status, _ = run_cli(["methods", "--dry-run", *argv])
        text = err.getvalue()
        check(status == 2 and word in text, f"{argv} refused naming {word} ({status}: {text.strip()[:200]})")


def verdict():
    def runs(s, p, p_err=0.002):
        return {"S": [s, 0.001], "P": [p, p_err]}
    labels = ["exact-0.001", "exact-0.002", "midpoint-0.0001"]
    by_seed = {}
    for seed in range(1, 5):
        s = 0.72 + 0.002 * seed
        p = 6.0 + 1.5 * (s - 0.72)  # every run on the line P* = 6 + 1.5 (S - 0.72)
        by_seed[seed] = {labels[0]: runs(s, p), labels[1]: runs(s + 0.0005, p + 0.001 + 1.5 * 0.0005),
                         labels[2]: runs(s + 0.002, p + 0.005 + 1.5 * 0.002)}
    by_seed[5] = {labels[0]: runs(0.7, 6.0), labels[1]: None, labels[2]: runs(0.7, 6.0)}
    out = methods.compare(by_seed, labels)
    check(out["seeds"] == [1, 2, 3, 4], f"the seed without every variant is left out ({out['seeds']})")
    near, far = out["variants"][labels[1]], out["variants"][labels[2]]
    check(near["P_agrees"] and abs(near["P_minus_exact-0.001"][0] - 0.00175) < 1e-9,
          f"within its errors: agrees ({near})")
    check(not far["P_agrees"] and abs(far["P_minus_exact-0.001"][0] - 0.008) < 1e-9
          and abs(far["P_minus_exact-0.001"][1] - 0.002 * 2 ** 0.5 / 2) < 1e-12,
          f"five errors apart: differs ({far})")
    rel = out["p_s_relation"]
    check(abs(rel["slope"][0] - 1.5) < 0.6 and rel["runs"] == 12, f"the P*-S line ({rel})")
    # At equal S the offsets off the line remain: 0.001 (agrees) and 0.005 (differs), less what
    # the fitted slope takes of their S differences.
    b = rel["slope"][0]
    check(abs(near["P_at_equal_S_minus_exact-0.001"][0] - (0.00175 - b * 0.0005)) < 1e-9
          and abs(far["P_at_equal_S_minus_exact-0.001"][0] - (0.008 - b * 0.002)) < 1e-9
          and near["P_at_equal_S_agrees"], f"P* at equal S ({near}, {far})")


def main():
    dry_run()
    refusals()
    verdict()


if __name__ == "__main__":
    main()
    print("all checks passed")
