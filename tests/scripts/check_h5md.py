#!/usr/bin/env python3
"""Run a short scene, read its H5MD trajectory with h5py, and check it against the run.

The last frame must hash, byte for byte, to the run's state_checksum (FNV-1a over ids,
positions, axes, velocities and angular velocities in id order, as summary.json computes
it), and step, time, box, N and the H5MD layout must be what the run wrote.
"""
import json
import pathlib
import shutil
import struct
import subprocess
import sys
import tempfile

import h5py


def fnv1a(frame_fields, n):
    h = 1469598103934665603
    mask = (1 << 64) - 1
    pos, axis, vel, ang = frame_fields
    for i in range(n):
        data = struct.pack("<q", i)
        for arr in (pos, axis, vel, ang):
            data += struct.pack("<3d", *arr[i])
        # The run hashes x, y, z, ex, ey, ez, vx, vy, vz, wx, wy, wz in this order.
        for byte in data:
            h ^= byte
            h = (h * 1099511628211) & mask
    return f"{h:016x}"


def main():
    hardrod = sys.argv[1]
    source = pathlib.Path(sys.argv[2])
    out = pathlib.Path(tempfile.mkdtemp(prefix="hardrod-h5md-"))
    try:
        cmd = [hardrod, "run", str(source / "scenes/default.toml"), "--out", str(out / "run"),
               "--quiet", "--threads", "1", "--set", "run.equilibration_steps=200",
               "--set", "run.steps=600", "--set", "run.sample_interval=200",
               "--set", "output.snapshot_interval=400"]
        subprocess.run(cmd, check=True)
        summary = json.loads((out / "run/summary.json").read_text())
        with h5py.File(out / "run/trajectory.h5", "r") as f:
            assert tuple(f["h5md"].attrs["version"]) == (1, 1), "H5MD version"
            all_ = f["particles/all"]
            n = summary["n"]
            pos = all_["position/value"]
            assert pos.shape == (2, n, 3), f"position shape {pos.shape}"
            steps = list(all_["position/step"][:])
            assert steps == [400, 800], f"steps {steps}"
            times = list(all_["position/time"][:])
            assert abs(times[-1] - 800 * summary["dt"]) < 1e-12, f"time {times}"
            edges = list(all_["box/edges"][:])
            assert all(abs(a - b) < 1e-12 for a, b in zip(edges, summary["box"])), "box"
            assert list(all_["id/value"][:]) == list(range(n)), "ids"
            last = [all_[name + "/value"][-1] for name in ("position", "axis", "velocity",
                                                             "angular_velocity")]
            # Hash in the run's field order: x y z, e, v, w.
            got = fnv1a(last, n)
        if got != summary["state_checksum"]:
            print(f"FAILED: the last frame hashes to {got}, the run's checksum is "
                  f"{summary['state_checksum']}")
            return 1
        print(f"trajectory.h5: 2 frames of {n} bodies, last frame matches state_checksum {got}")
        return 0
    finally:
        shutil.rmtree(out, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
