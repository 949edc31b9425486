#!/usr/bin/env python3
"""Run one scene on R ranks x T threads and compare with a reference run, bit for bit.

Used by ctest (tests/CMakeLists.txt): the 1 x 1 run is a fixture that writes the reference;
every other configuration must reproduce its state_checksum and collision count.
"""
import argparse
import json
import pathlib
import shutil
import subprocess
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "scripts"))
from hardrod_bench import mpi  # noqa: E402  (the mpirun launcher shared with scripts/bench)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--hardrod", required=True)
    ap.add_argument("--scene", required=True)
    ap.add_argument("--ranks", type=int, default=1)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--out", required=True)
    ap.add_argument("--reference", help="directory of the 1 x 1 run to compare with")
    ap.add_argument("--verify", action="store_true", help="check bookkeeping every step")
    ap.add_argument("--set", action="append", default=[])
    ap.add_argument("--grid", help="MPI process grid, e.g. 3x3x3")
    ap.add_argument("--balance", help="load balancing mode (default: the program's)")
    ap.add_argument("--balance-interval", help="steps between balance checks (default: the program's)")
    ap.add_argument("--balance-threshold", help="imbalance that moves the cuts (default: the program's)")
    ap.add_argument("--min-shifts", type=int, default=0,
                    help="least moves of the cuts on more than one rank (the balancer must act)")
    ap.add_argument("--min-from-results", type=int, default=0,
                    help="least bodies that must have taken their velocities from the results "
                         "exchange (the run must exercise it)")
    ap.add_argument("--results-exchange", action="store_true",
                    help="resolve spanning clusters on one rank and send the results (the path "
                         "more than two ranks need); it must have carried some results")
    ap.add_argument("--min-watched", type=float, default=0.0,
                    help="least share of detections through the watches (the scene must use them)")
    ap.add_argument("--expect-checksum",
                    help="the state_checksum the run must end with (a golden trajectory: the "
                         "refactorings keep it bit for bit; a deliberate change of the dynamics "
                         "updates it in the same commit)")
    args = ap.parse_args()

    out = pathlib.Path(args.out)
    shutil.rmtree(out, ignore_errors=True)
    cmd = mpi.prefix(args.ranks)
    cmd += [args.hardrod, "run", args.scene, "--out", str(out), "--threads", str(args.threads),
            "--quiet", "--force"]
    if args.verify:
        cmd.append("--verify")
    if args.results_exchange:
        cmd.append("--results-exchange")
    if args.grid:
        cmd += ["--grid", args.grid]
    if args.balance:
        cmd += ["--balance", args.balance]
    if args.balance_interval:
        cmd += ["--balance-interval", args.balance_interval]
    if args.balance_threshold:
        cmd += ["--balance-threshold", args.balance_threshold]
    for s in args.set:
        cmd += ["--set", s]
    env = mpi.environment()
    print(" ".join(cmd), flush=True)
    proc = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    print(proc.stdout)
    if proc.returncode != 0:
        print(f"FAILED: exit status {proc.returncode}")
        return 1
    summary = json.loads((out / "summary.json").read_text())
    print(f"ranks {summary['ranks']} grid {summary['grid']} threads {summary['threads']}: "
          f"checksum {summary['state_checksum']}, collisions {summary['collisions']}")
    watched = summary["detect_watched_share"]
    print(f"detections through the watches: {100 * watched:.1f} %")
    if watched < args.min_watched:
        print(f"FAILED: the scene must detect through the watches in at least "
              f"{100 * args.min_watched:.0f} % of the steps")
        return 1
    if summary["ranks"] != args.ranks:
        print(f"FAILED: ran on {summary['ranks']} ranks, asked for {args.ranks}")
        return 1
    if args.expect_checksum and summary["state_checksum"] != args.expect_checksum:
        print(f"FAILED: state_checksum = {summary['state_checksum']}, the golden trajectory "
              f"ends at {args.expect_checksum}")
        return 1
    if args.reference:
        ref = json.loads((pathlib.Path(args.reference) / "summary.json").read_text())
        for key in ("state_checksum", "collisions", "steps_done"):
            if summary[key] != ref[key]:
                print(f"FAILED: {key} = {summary[key]}, the 1 x 1 run has {ref[key]}")
                return 1
        if "exact" in summary:
            # The exact method's candidates, and its clusters where both runs formed them
            # (one rank on one thread takes a step's events in one queue instead), are the same on any
            # ranks x threads, and each candidate, cluster and join is counted once.
            clustered = all(s["exact"].get("queued_steps", 0) == 0 for s in (summary, ref))
            keys = ("candidates", "apart") + (("clusters", "regrown", "largest_cluster")
                                              if clustered else ())
            for key in keys:
                if summary["exact"][key] != ref["exact"][key]:
                    print(f"FAILED: exact.{key} = {summary['exact'][key]}, the 1 x 1 run has "
                          f"{ref['exact'][key]}")
                    return 1
        if summary["collisions"] < 100:
            print("FAILED: too few collisions for a meaningful comparison")
            return 1
        print("same state as 1 x 1")
    if args.ranks > 1 and summary["balance"]["shifts"] < args.min_shifts:
        print(f"FAILED: the cuts moved {summary['balance']['shifts']} times, at least "
              f"{args.min_shifts} asked")
        return 1
    spanning = summary["spanning_clusters"]
    print(f"clusters across ranks: {spanning}")
    if (args.results_exchange and spanning["from_results"] == 0) or \
            spanning["from_results"] < args.min_from_results:
        print("FAILED: too few bodies took their velocities from another rank's results")
        return 1
    if args.ranks > 1 and summary.get("method") == "exact":
        # Every step sends its spanning clusters' pieces; some must have crossed.
        pieces = summary["communication_per_rank"]["exact_pieces"]["bytes_per_step"]
        print(f"exact method: {pieces:.0f} bytes of cluster pieces per step and rank")
        if not pieces > 0.0:
            print("FAILED: no cluster crossed a rank boundary")
            return 1
    elif args.ranks == 2 and args.reference:
        # One partner: the contact exchanges ran in the steps where a contact crossed the rank
        # boundary and were skipped in the others. Both paths must have been compared above.
        per_step = summary["communication_per_rank"]["contacts"]["messages_per_step"]
        print(f"contact exchanges in {100 * per_step:.1f} % of steps")
        if not 0.0 < per_step < 1.0:
            print("FAILED: the scene does not exercise both the exchange and the skipped exchange")
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
