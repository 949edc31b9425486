#!/usr/bin/env python3
"""Run a short scene, read its H5MD trajectory with h5py, and check it against the run.

The last frame must hash, byte for byte, to the run's state_checksum (FNV-1a over ids,
positions, axes, velocities and angular velocities in id order, as summary.json computes
it), and step, time, box, N, the units, the wrapped positions with their image counts, the
provenance and the H5MD layout must be what the run wrote.
"""
import json
import pathlib
import shutil
import struct
import subprocess
import sys
import tempfile

import h5py
import numpy as np


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
            # The box is time-dependent (MDAnalysis reads only that): a diagonal matrix per
            # frame, sharing position's step and time.
            box = all_["box/edges/value"]
            assert box.shape == (2, 3, 3), f"box shape {box.shape}"
            for frame in box[:]:
                expected = [[summary["box"][r] if r == c else 0.0 for c in range(3)]
                            for r in range(3)]
                assert (frame == expected).all(), f"box {frame}"
            assert list(all_["box/edges/step"][:]) == steps, "box steps"
            # Units: reduced (docs/units.md), as reduced_unit; no H5MD `unit`, which
            # MDAnalysis rejects unless it knows it.
            units = {name: all_[name + "/value"].attrs.get("reduced_unit")
                     for name in ("position", "velocity", "axis", "angular_velocity")}
            units["time"] = all_["position/time"].attrs.get("reduced_unit")
            units["box"] = all_["box/edges/value"].attrs.get("reduced_unit")
            expected_units = {"position": "D", "velocity": "D tau-1", "axis": None,
                              "angular_velocity": "tau-1", "time": "tau", "box": "D"}
            decoded = {k: v.decode() if isinstance(v, bytes) else v for k, v in units.items()}
            assert decoded == expected_units, f"units {decoded}"
            assert "unit" not in all_["position/value"].attrs, "an H5MD unit MDAnalysis rejects"
            assert f["h5md/modules/units"].attrs["system"].startswith("reduced: length D")
            # Wrapped positions and image counts give the unwrapped ones back.
            wrapped = f["particles/wrapped/position/value"][:]
            image = f["particles/wrapped/image/value"][:]
            side = np.array(summary["box"])
            assert ((wrapped >= 0) & (wrapped < side)).all(), "wrapped positions outside the box"
            assert np.allclose(wrapped + image * side, pos[:], rtol=0, atol=1e-9), "image counts"
            assert list(f["particles/wrapped/position/step"][:]) == steps, "wrapped steps"
            # Provenance: the same as summary.json's.
            params = f["parameters"].attrs
            for key in ("version", "git_commit", "command_line", "started_at", "host"):
                value = params[key]
                value = value.decode() if isinstance(value, bytes) else value
                assert value == summary[key], f"parameters {key}: {value!r} vs {summary[key]!r}"
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
