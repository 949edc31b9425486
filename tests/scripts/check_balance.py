#!/usr/bin/env python3
"""Load balancing through the binary: moving cuts never change the trajectory.

A hard-sphere gas starts squeezed into the lower half of the box along x (an H5MD start
file written with h5py), so on three ranks cut evenly along x one rank would hold most
bodies, one about a third and one none. Then:
  - `--balance bodies` (deterministic) must start from cuts that share the bodies out
    (imbalance at the first check far below the even grid's), keep moving them as the gas
    spreads (forced rebuilds), keep every id owned once and every shadow equal to its owner
    after every step (--verify), and end in the 1 x 1 state bit for bit;
  - the same in a hot gas on four ranks checked every 200 steps, where one rebuild moves a
    cut further than the partner reach, so the bodies migrate in stages;
  - `--balance time` (whatever the machine's timing does) and `--balance off` must end in
    the same state as 1 x 1;
  - the exact method (run.method = "exact") the same: its cuts follow the bodies under
    `--balance bodies`, and every mode ends in its own 1 x 1 state;
  - a bad `--balance` or `--balance-interval` value is refused with exit status 1, naming it.
"""
import json
import pathlib
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "scripts"))
from hardrod_bench import mpi  # noqa: E402  (the mpirun launcher shared with scripts/bench)

import h5py


def run(hardrod, scene, out, ranks, extra):
    cmd = mpi.prefix(ranks)
    cmd += [hardrod, "run", str(scene), "--out", str(out), "--quiet", "--force", "--threads", "1",
            *extra]
    env = mpi.environment()
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
            side = f["particles/all/box/edges/value"][-1][0][0]  # the last frame's box, x edge
            frame = pos[-1]
            frame[:, 0] = (frame[:, 0] % side) * 0.5
            pos[-1] = frame
            # An edited frame: its checksum goes, and so do its velocities, drawn afresh at
            # each case's init.temperature (an H5MD start takes a frame's velocities if any).
            del f["observables/state_checksum"]
            for name in ("velocity", "angular_velocity"):
                f[f"particles/all/{name}/value"][-1] = 0.0
        common = ["--set", "init.configuration=\"file\"", "--set", f"init.file=\"{start}\"",
                  "--set", "run.steps=1000", "--set", "run.sample_interval=250"]
        mild = common + ["--set", "init.temperature=100.0", "--balance-interval", "50"]
        hot = common + ["--set", "init.temperature=2500.0", "--balance-interval", "200"]
        exact = mild + ["--set", "run.method=exact"]
        failures = []
        refs = {}
        for name, opts in (("mild", mild), ("hot", hot), ("exact", exact)):
            refs[name] = run(hardrod, scene, tmp / f"1x1-{name}", 1, opts)
            r = refs[name]
            print(f"1 x 1 {name}: checksum {r['state_checksum']}, collisions {r['collisions']}")
            if r["collisions"] < 100:
                failures.append(f"{name}: too few collisions for a meaningful comparison")

        # The hot gas on 4 ranks in a row (slabs 0 and 2 are not partners): a cut moves
        # further than the partner reach in one rebuild, which then moves it in stages,
        # migrating after each, checked by --verify.
        cases = (("mild", "bodies", True, 3), ("hot", "bodies", True, 4),
                 ("mild", "time", False, 3), ("mild", "off", False, 3),
                 ("exact", "bodies", True, 3), ("exact", "time", False, 3),
                 ("exact", "off", False, 3))
        for gas, mode, verify, ranks in cases:
            opts = {"mild": mild, "exact": exact}.get(gas, hot + ["--grid", "4x1x1"])
            s = run(hardrod, scene, tmp / f"{ranks}x1-{gas}-{mode}", ranks,
                    opts + ["--balance", mode] + (["--verify"] if verify else []))
            ref = refs[gas]
            b = s["balance"]
            label = f"{gas} gas, --balance {mode}" if gas != "exact" else f"mild gas, exact method, --balance {mode}"
            print(f"{ranks} x 1, {label}: grid {s['grid']}, checksum {s['state_checksum']}, "
                  f"collisions {s['collisions']}; {b['checks']} checks, {b['shifts']} shifts "
                  f"({b['forced_rebuilds']} forced, largest {b['largest_shift']:.2f} D, partner "
                  f"reach {b['partner_reach']:.2f} D), imbalance {b['first_imbalance']:.3f} -> "
                  f"{b['last_imbalance']:.3f}, cuts x {[round(c, 3) for c in b['cuts'][0]]}")
            for key in ("state_checksum", "collisions", "steps_done"):
                if s[key] != ref[key]:
                    failures.append(f"{label}: {key} = {s[key]}, 1 x 1 has {ref[key]}")
            if s["grid"] != [ranks, 1, 1]:
                failures.append(f"{label}: grid {s['grid']}, expected cuts along x")
            widths = [hi - lo for lo, hi in zip(b["cuts"][0], b["cuts"][0][1:])]
            # The even grid starts with ~90 % (3 ranks) or ~100 % (4) imbalance here.
            if mode == "bodies":
                # The even grid starts with ~90 % imbalance here (one rank has most bodies).
                if not b["first_imbalance"] < 0.3:
                    failures.append(f"{label}: the start cuts did not share the bodies out "
                                    f"({b['first_imbalance']:.3f})")
                if b["shifts"] < 1 or b["forced_rebuilds"] < 1:
                    failures.append(f"{label}: the cuts did not move during the run")
                if not b["last_imbalance"] < 0.25:
                    failures.append(f"{label}: still unbalanced at the end ({b['last_imbalance']:.3f})")
                if not widths[0] < widths[-1]:
                    failures.append(f"{label}: the crowded slab is not the thinnest {widths}")
                if gas == "hot" and not b["largest_shift"] > b["partner_reach"]:
                    failures.append(f"{label}: no cut moved far enough to need stages "
                                    f"({b['largest_shift']:.2f} D)")
            if mode == "off" and (b["shifts"] != 0 or b["checks"] != 0 or len(set(
                    round(w, 9) for w in widths)) != 1):
                failures.append(f"{label}: the cuts moved {widths}")

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
