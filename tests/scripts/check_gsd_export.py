#!/usr/bin/env python3
"""Export a short run's H5MD trajectory as GSD and extended XYZ, and read both with the tools
users have: gsd (python3-gsd, HOOMD's schema), MDAnalysis and ASE where installed, and a small
extended-XYZ parser here. Checks against the H5MD file (h5py): frames, N, box, steps, wrapped
positions + image * L == unwrapped positions, quaternions that turn +z onto the axes (1e-6),
velocities, angular momenta, shapes; then a run started from the GSD file, and bad input.
"""
import json
import pathlib
import shlex
import shutil
import subprocess
import sys
import tempfile

import h5py
import numpy as np

import gsd.fl
import gsd.hoomd


def rotate(q, v):
    """q (0, v) q* for unit quaternions q = (s, x, y, z), rows of arrays."""
    s, u = q[:, :1], q[:, 1:]
    return v + 2 * s * np.cross(u, v) + 2 * np.cross(u, np.cross(u, v))


def quaternion_product(a, b):
    s = a[:, 0] * b[:, 0] - np.sum(a[:, 1:] * b[:, 1:], axis=1)
    v = a[:, :1] * b[:, 1:] + b[:, :1] * a[:, 1:] + np.cross(a[:, 1:], b[:, 1:])
    return np.column_stack([s, v])


def box_edges(h5):
    """The box edges: a fixed dataset, or the last frame of a time-dependent one (H5MD allows
    both; hardrod writes a diagonal 3 x 3 matrix per frame, the form MDAnalysis reads)."""
    edges = h5["particles/all/box/edges"]
    if not isinstance(edges, h5py.Group):
        return np.array(edges[:])
    last = np.array(edges["value"][-1])
    return np.diag(last) if last.ndim == 2 else last  # a 3 x 3 matrix per frame, or 3 edges


def parse_extended_xyz(text):
    """Frames as (n, info dict, properties [(name, type, count)], rows of strings)."""
    lines = text.splitlines()
    frames, at = [], 0
    while at < len(lines):
        n = int(lines[at])
        comment = shlex.split(lines[at + 1])  # key="quoted value" pairs
        info = dict(item.split("=", 1) for item in comment)
        spec = info["Properties"].split(":")
        props = [(spec[k], spec[k + 1], int(spec[k + 2])) for k in range(0, len(spec), 3)]
        rows = [line.split() for line in lines[at + 2:at + 2 + n]]
        assert len(rows) == n and all(len(r) == sum(c for _, _, c in props) for r in rows)
        frames.append((n, info, props, rows))
        at += 2 + n
    return frames


def columns(props, rows, name):
    start = 0
    for pname, ptype, count in props:
        if pname == name:
            cast = float if ptype == "R" else (int if ptype == "I" else str)
            return np.array([[cast(r[start + c]) for c in range(count)] for r in rows])
        start += count
    raise KeyError(name)


def check_gsd(path, h5):
    pos_h5 = h5["particles/all/position/value"][:]
    axis_h5 = h5["particles/all/axis/value"][:]
    vel_h5 = h5["particles/all/velocity/value"][:]
    ang_h5 = h5["particles/all/angular_velocity/value"][:]
    steps_h5 = list(h5["particles/all/position/step"][:])
    edges = box_edges(h5)
    length, diameter = h5["parameters"].attrs["aspect_ratio"], h5["parameters"].attrs["diameter"]
    with gsd.fl.open(name=str(path), mode="rb") as f:
        assert f.schema == "hoomd" and f.schema_version == (1, 4), (f.schema, f.schema_version)
        assert f.gsd_version == (2, 0), f.gsd_version
    traj = gsd.hoomd.open(str(path), "rb")
    assert len(traj) == len(steps_h5), (len(traj), len(steps_h5))
    worst = {"unwrap": 0.0, "axis": 0.0, "velocity": 0.0, "angular": 0.0}
    for k, frame in enumerate(traj):
        p = frame.particles
        assert p.N == pos_h5.shape[1], p.N
        assert frame.configuration.step == steps_h5[k]
        box = frame.configuration.box
        assert np.array_equal(box, np.array([*edges, 0, 0, 0], dtype=np.float32)), box
        half = box[:3] / 2
        assert np.all(p.position >= -half) and np.all(p.position < half), "positions wrapped"
        unwrapped = p.position.astype(np.float64) + p.image * edges
        worst["unwrap"] = max(worst["unwrap"], np.abs(unwrapped - pos_h5[k]).max())
        q = p.orientation.astype(np.float64)
        assert np.allclose(np.linalg.norm(q, axis=1), 1, atol=1e-6), "unit quaternions"
        z = np.tile([0.0, 0.0, 1.0], (p.N, 1))
        worst["axis"] = max(worst["axis"], np.abs(rotate(q, z) - axis_h5[k]).max())
        worst["velocity"] = max(worst["velocity"], np.abs(p.velocity - vel_h5[k]).max())
        # HOOMD: S = 1/2 Im(q* P) in the body frame; w = q (S / I) q*.
        qc = q * np.array([1, -1, -1, -1])
        s = 0.5 * quaternion_product(qc, p.angmom.astype(np.float64))[:, 1:]
        inertia = p.moment_inertia.astype(np.float64)
        assert np.all(inertia[:, 2] == 0) and np.all(inertia[:, 0] > 0), "moments (I, I, 0)"
        assert np.abs(s[:, 2]).max() < 1e-5, "no angular momentum about the rod's axis"
        w = rotate(q, np.column_stack([s[:, 0] / inertia[:, 0], s[:, 1] / inertia[:, 1], 0 * s[:, 2]]))
        worst["angular"] = max(worst["angular"], np.abs(w - ang_h5[k]).max())
        assert p.types == ["rod"], p.types
        assert np.all(p.typeid == 0)
        assert np.allclose(p.diameter, diameter) and np.allclose(p.mass, 1.0)
        assert p.type_shapes == [{"type": "ConvexPolyhedron", "rounding_radius": diameter / 2,
                                  "vertices": [[0, 0, -length / 2], [0, 0, length / 2]]}], \
            p.type_shapes
    traj.close()
    # float32 positions: half an ulp of L/2 (~1e-6 D); axes, velocities to float precision
    assert worst["unwrap"] < 2e-6 * edges.max() / 28, worst
    assert worst["axis"] < 1e-6 and worst["velocity"] < 1e-5 and worst["angular"] < 1e-5, worst
    print("gsd: frames", len(steps_h5), "worst", {k: f"{v:.2g}" for k, v in worst.items()})
    return pos_h5, axis_h5


def check_mdanalysis(path, pos_h5):
    try:
        import MDAnalysis
    except ImportError:
        print("MDAnalysis not installed: skipped")
        return
    u = MDAnalysis.Universe(str(path))
    assert len(u.trajectory) == pos_h5.shape[0] and len(u.atoms) == pos_h5.shape[1]
    with gsd.hoomd.open(str(path), "rb") as traj:
        for ts, frame in zip(u.trajectory, traj):
            assert np.allclose(ts.positions, frame.particles.position, atol=1e-5)
    print("MDAnalysis", MDAnalysis.__version__, "reads", len(u.trajectory), "frames")


def check_xyz(path, h5, pos_h5, axis_h5):
    edges = box_edges(h5)
    frames = parse_extended_xyz(path.read_text())
    assert len(frames) == pos_h5.shape[0], len(frames)
    for k, (n, info, props, rows) in enumerate(frames):
        assert n == pos_h5.shape[1]
        assert np.allclose([float(x) for x in info["Lattice"].split()],
                           np.diag(edges).ravel(), rtol=1e-15), info["Lattice"]
        assert info["pbc"] == "T T T" and int(info["step"]) == h5["particles/all/position/step"][k]
        assert [p[:2] for p in props] == [("species", "S"), ("pos", "R"), ("orientation", "R"),
                                         ("aspherical_shape", "R"), ("id", "I")], props
        assert set(r[0] for r in rows) == {"X"}
        folded = np.mod(pos_h5[k], edges)
        d = np.abs(columns(props, rows, "pos") - folded)
        assert np.minimum(d, edges - d).max() < 1e-9
        xyzw = columns(props, rows, "orientation")  # OVITO's order: scalar last
        q = np.column_stack([xyzw[:, 3], xyzw[:, :3]])
        z = np.tile([0.0, 0.0, 1.0], (n, 1))
        assert np.abs(rotate(q, z) - axis_h5[k]).max() < 1e-9
        assert np.array_equal(columns(props, rows, "id")[:, 0], np.arange(n))
    try:
        import ase.io
    except ImportError:
        print("ASE not installed: read by the parser here only")
        return
    atoms = ase.io.read(str(path), index=":")
    assert len(atoms) == len(frames)
    last = atoms[-1]
    assert set(last.get_chemical_symbols()) == {"X"} and all(last.pbc)
    assert np.allclose(last.cell.lengths(), edges) and last.arrays["orientation"].shape[1] == 4
    print("ASE reads", len(atoms), "frames")


def write_with_gsd_library(path, h5, inertia, with_velocities):
    """The H5MD file's last frame written by python3-gsd's own writer, as HOOMD would."""
    edges = box_edges(h5)
    pos = h5["particles/all/position/value"][-1]
    axis = h5["particles/all/axis/value"][-1]
    image = np.floor(pos / edges + 0.5)
    s = 1 + axis[:, 2]  # the nematic has no axis near -z
    q = np.column_stack([s, -axis[:, 1], axis[:, 0], 0 * s])
    q /= np.linalg.norm(q, axis=1)[:, None]
    snap = gsd.hoomd.Snapshot()
    snap.configuration.box = [*edges, 0, 0, 0]
    snap.configuration.step = int(h5["particles/all/position/step"][-1])
    snap.particles.N = len(pos)
    snap.particles.types = ["A"]
    snap.particles.position = pos - image * edges
    snap.particles.image = image.astype(np.int32)
    snap.particles.orientation = q
    if with_velocities:
        w = h5["particles/all/angular_velocity/value"][-1]
        snap.particles.velocity = h5["particles/all/velocity/value"][-1]
        snap.particles.moment_inertia = np.tile([inertia, inertia, 0.0], (len(pos), 1))
        snap.particles.angmom = 2 * quaternion_product(
            np.column_stack([0 * s, inertia * w]), q)
    with gsd.hoomd.open(str(path), "wb") as f:
        f.append(snap)


def check_start_from_gsd_library(hardrod, run, out, h5path):
    """Runs of 0 steps from files python3-gsd wrote: the start is the file's state."""
    with h5py.File(h5path, "r") as h5:
        with gsd.hoomd.open(str(out / "t.gsd"), "rb") as ours:
            inertia = float(ours[0].particles.moment_inertia[0, 0])
        edges = box_edges(h5)
        for with_velocities in (True, False):
            name = f"lib-{int(with_velocities)}"
            write_with_gsd_library(out / f"{name}.gsd", h5, inertia, with_velocities)
            subprocess.run(run + ["--out", str(out / name), "--set", "run.equilibration_steps=0",
                                  "--set", "run.steps=0", "--set", "init.configuration=\"file\"",
                                  "--set", f"init.file=\"{out / name}.gsd\""], check=True)
            with h5py.File(out / name / "trajectory.h5", "r") as start:
                got = {k: start[f"particles/all/{k}/value"][0]
                       for k in ("position", "axis", "velocity", "angular_velocity")}
            want = {k: h5[f"particles/all/{k}/value"][-1] for k in got}
            assert np.abs(got["position"] - want["position"]).max() < 2e-6 * edges.max() / 28
            assert np.abs(got["axis"] - want["axis"]).max() < 1e-6
            moved = np.abs(got["velocity"] - want["velocity"]).max()
            if with_velocities:
                assert moved < 1e-5, moved
                assert np.abs(got["angular_velocity"] - want["angular_velocity"]).max() < 1e-5
            else:  # no velocities in the file: fresh ones at init.temperature
                assert moved > 0.1 and np.abs(got["velocity"]).max() > 0, moved
    print("runs start from files python3-gsd wrote, with and without velocities")


def expect_failure(cmd, code, words):
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == code and all(w in r.stderr for w in words), (cmd, r.returncode, r.stderr)


def check_damaged_frame(hardrod, h5path, out):
    """Every frame carries its state checksum (the last is summary.json's); one flipped bit in
    a position that stays finite is refused by export, and the other frames still export."""
    summary = json.loads((h5path.parent / "summary.json").read_text())
    with h5py.File(h5path, "r") as h5:
        sums = h5["observables/state_checksum/value"][:]
        assert len(sums) == h5["particles/all/position/value"].shape[0]
        assert f"{int(sums[-1]):016x}" == summary["state_checksum"], (sums[-1], summary)
    damaged = out / "damaged.h5"
    shutil.copy(h5path, damaged)
    with h5py.File(damaged, "r+") as h5:
        v = h5["particles/all/position/value"]
        x = np.array(v[0, 7, 2])
        x.view(np.uint64)[...] ^= np.uint64(1 << 30)  # a finite, plausible, wrong coordinate
        v[0, 7, 2] = x
    for fmt in ("gsd", "xyz"):
        target = out / f"damaged.{fmt}"
        expect_failure([hardrod, "export", str(damaged), "--out", str(target)], 2,
                       ["frame 0 is damaged", "state_checksum"])
        assert not target.exists() and not pathlib.Path(str(target) + ".tmp").exists()
    subprocess.run([hardrod, "export", str(damaged), "--frame", "-1", "--out",
                    str(out / "last.xyz")], check=True)


def main():
    hardrod, source = sys.argv[1], pathlib.Path(sys.argv[2])
    out = pathlib.Path(tempfile.mkdtemp(prefix="hardrod-gsd-"))
    try:
        run = [hardrod, "run", str(source / "scenes/default.toml"), "--quiet", "--threads", "1",
               "--set", "run.equilibration_steps=200", "--set", "run.steps=600",
               "--set", "run.sample_interval=200", "--set", "output.snapshot_interval=400"]
        subprocess.run(run + ["--out", str(out / "run")], check=True)
        h5path = out / "run/trajectory.h5"
        subprocess.run([hardrod, "export", str(h5path), "--out", str(out / "t.gsd")], check=True)
        subprocess.run([hardrod, "export", str(h5path), "--out", str(out / "t.xyz")], check=True)
        with h5py.File(h5path, "r") as h5:
            pos_h5, axis_h5 = check_gsd(out / "t.gsd", h5)
            check_mdanalysis(out / "t.gsd", pos_h5)
            check_xyz(out / "t.xyz", h5, pos_h5, axis_h5)
        # A run starts from the GSD's last frame (its velocities) and from its first.
        for frame in ("-1", "0"):
            subprocess.run(run + ["--out", str(out / f"from-gsd{frame}"), "--set",
                                  "init.configuration=\"file\"", "--set",
                                  f"init.file=\"{out / 't.gsd'}\"", "--set", f"init.frame={frame}"],
                           check=True)
        check_start_from_gsd_library(hardrod, run, out, h5path)
        # Bad input: named, and nothing written over.
        expect_failure([hardrod, "export", str(h5path), "--format", "pdb"], 1, ["--format"])
        expect_failure([hardrod, "export", str(h5path), "--format", "gsd"], 2, ["--out"])
        before = (out / "t.gsd").read_bytes()
        expect_failure([hardrod, "export", str(h5path), "--frame", "9", "--out", str(out / "t.gsd")],
                       2, ["frame 9 requested"])
        assert (out / "t.gsd").read_bytes() == before and not (out / "t.gsd.tmp").exists()
        expect_failure(run + ["--out", str(out / "bad"), "--set", "system.n=2000", "--set",
                              "init.configuration=\"file\"", "--set", f"init.file=\"{out / 't.gsd'}\""],
                       2, ["init.file", "t.gsd", "2304", "2000"])
        check_damaged_frame(hardrod, h5path, out)
        print("check_gsd_export: ok")
    finally:
        shutil.rmtree(out, ignore_errors=True)


if __name__ == "__main__":
    main()
