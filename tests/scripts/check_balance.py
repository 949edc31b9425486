#!/usr/bin/env python3
"""Load balancing through the binary: moving cuts never change the trajectory.

A hard-sphere gas starts squeezed into the lower half of the box along x (an H5MD start
file written with h5py), so on three ranks cut along x one rank holds most bodies, one
about a third and one none. Then:
  - `--balance bodies` (deterministic) must move the cuts (forced rebuilds), bring the
    busiest rank's load near the mean, keep every id owned once and every shadow equal to
    its owner after every step (--verify), and end in the 1 x 1 state bit for bit;
  - `--balance time` (whatever the machine's timing does) and `--balance off` must end in
    the same state;
  - a bad `--balance` or `--balance-interval` value is refused with exit status 1, naming it.
"""
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile

import h5py


def run(hardrod, scene, out, ranks, extra):
    cmd = ["mpirun", "--oversubscribe", "-np", str(ranks)] if ranks > 1 else []
    cmd += [hardrod, "run", str(scene), "--out", str(out), "--quiet", "--force", "--threads", "1",
            *extra]
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMPI_MCA_rmaps_base_oversubscribe="1", OMPI_MCA_mpi_yield_when_idle="1",
               OMP_WAIT_POLICY="passive")
    print("$", " ".join(cmd), flush=True)
    proc = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if proc.returncode != 0:
        print(proc.stdout)
        raise SystemExit(f"FAILED: exit status {proc.returncode}")
    return json.loads((out / "summary.json").read_text())


def main():
    hardrod = sys.argv[1]
    source = pathlib.Path(sys.argv[2])
    scene = source / "tests/parallel/gas.toml"
    tmp = pathlib.Path(tempfile.mkdtemp(prefix="hardrod-balance-"))
    try:
        # A frame of the gas, then squeezed into x < L/2 (lattice spacing 2.2 D -> 1.1 D).
        run(hardrod, scene, tmp / "seed", 1, ["--set", "run.steps=1",
                                              "--set", "output.snapshot_interval=1"])
        start = tmp / "squeezed.h5"
        shutil.copy(tmp / "seed/trajectory.h5", start)
        with h5py.File(start, "r+") as f:
            pos = f["particles/all/position/value"]
            side = f["particles/all/box/edges"][0]
            frame = pos[-1]
            frame[:, 0] = (frame[:, 0] % side) * 0.5
            pos[-1] = frame
        common = ["--set", "init.configuration=\"file\"", "--set", f"init.file=\"{start}\"",
                  "--set", "init.temperature=100.0", "--set", "run.steps=1000",
                  "--set", "run.sample_interval=250", "--balance-interval", "50"]
        ref = run(hardrod, scene, tmp / "1x1", 1, common)
        print(f"1 x 1: checksum {ref['state_checksum']}, collisions {ref['collisions']}")
        if ref["collisions"] < 100:
            raise SystemExit("FAILED: too few collisions for a meaningful comparison")

        failures = []
        for mode, verify in (("bodies", True), ("time", False), ("off", False)):
            s = run(hardrod, scene, tmp / f"3x1-{mode}", 3,
                    common + ["--balance", mode] + (["--verify"] if verify else []))
            b = s["balance"]
            print(f"3 x 1, --balance {mode}: grid {s['grid']}, checksum {s['state_checksum']}, "
                  f"collisions {s['collisions']}; {b['checks']} checks, {b['shifts']} shifts "
                  f"({b['forced_rebuilds']} forced), imbalance {b['first_imbalance']:.3f} -> "
                  f"{b['last_imbalance']:.3f}, cuts x {[round(c, 3) for c in b['cuts'][0]]}")
            for key in ("state_checksum", "collisions", "steps_done"):
                if s[key] != ref[key]:
                    failures.append(f"--balance {mode}: {key} = {s[key]}, 1 x 1 has {ref[key]}")
            if s["grid"] != [3, 1, 1]:
                failures.append(f"--balance {mode}: grid {s['grid']}, expected cuts along x")
            if mode == "bodies":
                if b["shifts"] < 2 or b["forced_rebuilds"] < 1:
                    failures.append("--balance bodies: the cuts did not move")
                if not b["first_imbalance"] > 0.8:
                    failures.append(f"--balance bodies: the start is not unbalanced "
                                    f"({b['first_imbalance']:.3f})")
                if not b["last_imbalance"] < 0.25:
                    failures.append(f"--balance bodies: still unbalanced at the end "
                                    f"({b['last_imbalance']:.3f})")
                widths = [hi - lo for lo, hi in zip(b["cuts"][0], b["cuts"][0][1:])]
                if not widths[0] < widths[2]:
                    failures.append(f"--balance bodies: the crowded slab did not shrink {widths}")
            if mode == "off" and (b["shifts"] != 0 or b["checks"] != 0):
                failures.append("--balance off: the cuts moved")

        for flag, value in (("--balance", "fast"), ("--balance-interval", "0"),
                            ("--balance-interval", "ten")):
            bad = subprocess.run([hardrod, "run", str(scene), flag, value, "--out", str(tmp / "bad")],
                                 stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
            # Exit status 1 (bad command line, README.md), the message naming flag and value.
            if bad.returncode != 1 or flag not in bad.stdout or f"'{value}'" not in bad.stdout:
                failures.append(f"{flag} {value}: not refused by name with exit status 1 "
                                f"({bad.returncode}): {bad.stdout.strip()}")
            if (tmp / "bad").exists():
                failures.append(f"{flag} {value}: wrote output")
        for f in failures:
            print("FAILED:", f)
        if failures:
            return 1
        print("same state for every balance mode; the cuts followed the bodies")
        return 0
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
