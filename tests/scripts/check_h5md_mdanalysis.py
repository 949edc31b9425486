#!/usr/bin/env python3
"""Run a short scene and load its trajectory.h5 with MDAnalysis (Debian's python3-mdanalysis,
2.4), as a user of that tool would, and compare every frame with what h5py reads.

MDAnalysis reads only a time-dependent box (box/edges/value[T][3][3]), and refuses any H5MD
`unit` it does not know (even with convert_units=False); hardrod's units are reduced (D, tau),
so the file names them in `reduced_unit` attributes and loads with convert_units=False. Positions (unwrapped), velocities, the box, times and steps must be
those of the file in every frame.

Usage: check_h5md_mdanalysis.py HARDROD SOURCE_DIR
"""
import json
import pathlib
import shutil
import subprocess
import sys
import tempfile

import h5py
import numpy as np

try:
    import MDAnalysis as mda
except ImportError:
    sys.exit("FAILED: MDAnalysis is missing (scripts/setup installs python3-mdanalysis)")


def main():
    hardrod, source = sys.argv[1], pathlib.Path(sys.argv[2])
    out = pathlib.Path(tempfile.mkdtemp(prefix="hardrod-mdanalysis-"))
    try:
        run = out / "run"
        subprocess.run([hardrod, "run", str(source / "scenes/default.toml"), "--out", str(run),
                        "--quiet", "--threads", "1", "--set", "run.equilibration_steps=0",
                        "--set", "run.steps=900", "--set", "run.sample_interval=300",
                        "--set", "output.snapshot_interval=300"], check=True)
        path = str(run / "trajectory.h5")
        summary = json.loads((run / "summary.json").read_text())
        n = summary["n"]
        u = mda.Universe.empty(n, trajectory=True)
        u.load_new(path, format="H5MD", convert_units=False)
        with h5py.File(path, "r") as f:
            all_ = f["particles/all"]
            pos = all_["position/value"][:]
            vel = all_["velocity/value"][:]
            steps = all_["position/step"][:]
            times = all_["position/time"][:]
            edges = all_["box/edges/value"][:]
        frames = len(u.trajectory)
        assert frames == len(pos) == 3, f"{frames} frames in MDAnalysis, {len(pos)} in the file"
        worst = 0.0
        for k, ts in enumerate(u.trajectory):
            # MDAnalysis keeps coordinates in float32.
            worst = max(worst, float(np.abs(ts.positions - pos[k]).max()))
            assert np.allclose(ts.positions, pos[k], rtol=1e-6, atol=1e-4), f"frame {k}: positions"
            assert np.allclose(ts.velocities, vel[k], rtol=1e-6, atol=1e-5), f"frame {k}: velocities"
            assert np.allclose(ts.dimensions[:3], np.diag(edges[k]), rtol=1e-6), f"frame {k}: box"
            assert np.allclose(ts.dimensions[3:], 90.0), f"frame {k}: box angles"
            assert abs(ts.time - times[k]) < 1e-6, f"frame {k}: time {ts.time} vs {times[k]}"
            assert ts.data["step"] == steps[k], f"frame {k}: step"
        assert list(steps) == [300, 600, 900], f"steps {list(steps)}"
        # Without SI units MDAnalysis cannot convert: the default load fails saying the file
        # needs readable units; convert_units=False is the documented way (docs/units.md).
        try:
            mda.Universe.empty(n, trajectory=True).load_new(path, format="H5MD")
            sys.exit("FAILED: MDAnalysis converted hardrod's reduced units")
        except ValueError as e:
            assert "must have readable units" in str(e), str(e)
        print(f"MDAnalysis {mda.__version__}: {frames} frames of {n} bodies equal h5py's "
              f"(largest position difference {worst:.2g} D, float32)")
        return 0
    finally:
        shutil.rmtree(out, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
