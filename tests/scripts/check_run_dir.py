#!/usr/bin/env python3
"""A run directory holds the files of one run, and a failed write says what is true:
- `run --force` removes the earlier run's files (frank.json, checkpoint.prev.h5, ...) and says
  which, and leaves files that are not a run's;
- `resume` without scene.toml identifies the run by its own checkpoint or summary.json, and a
  directory holding a run's outputs and neither is refused, nothing changed; a resume that
  fails on a damaged file leaves scene.toml as it was;
- a full disk (a small tmpfs; skipped without root or mount) stops the run with one line
  naming the file, no HDF5 error stack, exit status 2, advice that is true, and trajectory.h5
  readable up to its last whole frame;
- an H5MD start takes the frame's velocities (the state checksum goes on unchanged) and refuses
  a frame that does not hash to its stored checksum;
- an isotropic start that cannot reach its density shows its progress and names the key that
  sets the sweeps.
Usage: check_run_dir.py HARDROD SOURCE_DIR"""
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile

import h5py

QUICK = ["--quiet", "--threads", "1", "--set", "run.equilibration_steps=0", "--set",
         "run.sample_interval=10"]


def run(hardrod, scene, out, *args, steps=40):
    return subprocess.run([hardrod, "run", str(scene), "--out", str(out), *QUICK, "--set",
                           f"run.steps={steps}", *args], capture_output=True, text=True,
                          timeout=300)


def expect(ok, what, p=None):
    if not ok:
        detail = f"\nexit {p.returncode}\nstdout: {p.stdout[-1500:]}\nstderr: {p.stderr[-1500:]}" if p else ""
        sys.exit(f"FAILED: {what}{detail}")
    print(f"ok: {what}")


def force_clears(hardrod, scene, work):
    d = work / "force"
    p = run(hardrod, scene, d, "--set", "observables.frank=true", "--set",
            "output.checkpoint_interval=10")
    expect(p.returncode == 0 and (d / "frank.json").exists() and (d / "checkpoint.prev.h5").exists(),
           "a run with frank = true and two checkpoints", p)
    (d / "notes.txt").write_text("mine\n")
    p = run(hardrod, scene, d, "--force", "--set", "init.seed=7")
    expect(p.returncode == 0, "run --force", p)
    expect(not (d / "frank.json").exists() and not (d / "checkpoint.prev.h5").exists(),
           "--force leaves no frank.json or checkpoint.prev.h5 of the earlier run", p)
    expect("removed the earlier run's" in p.stderr and "frank.json" in p.stderr,
           "--force says which files it removed", p)
    expect((d / "notes.txt").read_text() == "mine\n", "--force leaves a file that is not a run's")
    expect(json.loads((d / "summary.json").read_text())["seed"] == 7, "the directory holds the new run")


def resume_identity(hardrod, scene, work):
    a, b = work / "a", work / "b"
    for d, seed in ((a, 1), (b, 2)):
        p = run(hardrod, scene, d, "--set", f"init.seed={seed}")
        expect(p.returncode == 0, f"run seed {seed}", p)
    (a / "scene.toml").unlink()
    before = (a / "timeseries.csv").read_bytes()

    def resume(*args):
        return subprocess.run([hardrod, "resume", str(a), "--quiet", "--threads", "1", "--set",
                               "run.steps=60", *args], capture_output=True, text=True, timeout=300)

    other = str(b / "checkpoint.h5")
    p = resume("--checkpoint", other)
    expect(p.returncode == 2 and "belongs to another run" in p.stderr and "init.seed" in p.stderr,
           "without scene.toml the run's own checkpoint refuses another run's", p)
    for f in ("checkpoint.h5", "checkpoint.prev.h5"):
        (a / f).unlink(missing_ok=True)
    p = resume("--checkpoint", other)
    expect(p.returncode == 2 and "belongs to another run" in p.stderr and "summary.json" in p.stderr,
           "without scene.toml or checkpoint, summary.json refuses another run's", p)
    (a / "summary.json").unlink()
    p = resume("--checkpoint", other)
    expect(p.returncode == 2 and "no scene.toml, checkpoint or summary.json" in p.stderr,
           "a directory holding outputs and nothing that names its run is refused", p)
    expect((a / "timeseries.csv").read_bytes() == before and not (a / "scene.toml").exists(),
           "the refused resumes changed nothing")
    # A resume that fails on a damaged file leaves scene.toml as it was.
    scene_text = (b / "scene.toml").read_bytes()
    (b / "timeseries.csv").unlink()
    (b / "timeseries.csv").mkdir()
    p = subprocess.run([hardrod, "resume", str(b), "--quiet", "--threads", "1", "--set",
                        "run.steps=60"], capture_output=True, text=True, timeout=300)
    expect(p.returncode == 2 and "not a regular file" in p.stderr, "resume refuses a directory as timeseries.csv", p)
    expect((b / "scene.toml").read_bytes() == scene_text, "the failed resume left scene.toml as it was")


def mount_tmpfs(path, size):
    path.mkdir()
    return subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)],
                          capture_output=True).returncode == 0


def full_disk(hardrod, scene, work):
    if os.geteuid() != 0 or not mount_tmpfs(work / "probe", "64k"):
        print("skipped: full disk (needs root and mount -t tmpfs)")
        return
    subprocess.run(["umount", str(work / "probe")])
    cases = [  # (size, extra settings, what the one line says, frames readable or None)
        ("56k", [], "a run needs at least", None),
        ("1200k", ["--set", "output.snapshot_interval=100", "--set", "output.checkpoint_interval=0"],
         "no checkpoint was written", 3),
        ("1600k", ["--set", "output.snapshot_interval=100", "--set", "output.checkpoint_interval=300"],
         "the checkpoint of step 300 is on disk", 3),
        ("1100k", ["--set", "run.sample_interval=1", "--set", "output.snapshot_interval=0",
                   "--set", "output.checkpoint_interval=0"], "timeseries.csv: cannot write", 0),
    ]
    for k, (size, extra, says, frames) in enumerate(cases):
        mnt = work / f"disk{k}"
        expect(mount_tmpfs(mnt, size), f"tmpfs of {size}")
        try:
            d = mnt / "r"
            p = run(hardrod, scene, d, *extra, steps=30000)
            lines = p.stderr.strip().splitlines()
            expect(p.returncode == 2 and says in p.stderr and "HDF5-DIAG" not in p.stderr and
                   len(lines) <= 2, f"{size} disk: exit 2, one message ({says!r})", p)
            if frames is not None:
                with h5py.File(d / "trajectory.h5", "r") as f:
                    got = f["particles/all/position/value"].shape[0]
                expect(got == frames, f"{size} disk: trajectory.h5 readable with {frames} whole frames")
            if (d / "timeseries.csv").exists():
                expect((d / "timeseries.csv").read_bytes().endswith(b"\n"),
                       f"{size} disk: timeseries.csv ends with a whole row")
        finally:
            subprocess.run(["umount", str(mnt)])


def h5md_start(hardrod, scene, work):
    a, b = work / "h5-a", work / "h5-b"
    p = run(hardrod, scene, a)
    expect(p.returncode == 0, "a run to start from", p)
    start = ["--set", 'init.configuration="file"', "--set", f'init.file="{a / "trajectory.h5"}"']
    p = run(hardrod, scene, b, *start, steps=0)
    expect(p.returncode == 0, "a start from its last H5MD frame", p)
    ours = json.loads((b / "summary.json").read_text())["state_checksum"]
    theirs = json.loads((a / "summary.json").read_text())["state_checksum"]
    expect(ours == theirs, "the H5MD start takes the frame's velocities (same state checksum)")
    with h5py.File(a / "trajectory.h5", "r+") as f:
        f["particles/all/velocity/value"][-1, 0, 0] += 1e-9
    p = run(hardrod, scene, work / "h5-c", *start, steps=0)
    expect(p.returncode == 2 and "damaged" in p.stderr and "init.file" in p.stderr,
           "a frame that does not hash to its checksum is refused", p)


def isotropic_way_out(hardrod, scene, work):
    p = subprocess.run([hardrod, "run", str(scene), "--out", str(work / "iso"), "--threads", "1",
                        "--set", "system.n=256", "--set", 'init.lattice="auto"', "--set",
                        "system.reduced_density=0.6", "--set", 'init.configuration="isotropic"',
                        "--set", "init.isotropic_sweeps=15000"],
                       capture_output=True, text=True, timeout=300)
    expect(p.returncode == 2 and "init.isotropic_sweeps = 15000" in p.stderr and
           'init.configuration = "lattice"' in p.stderr, "a dense isotropic start names its way out", p)
    expect("isotropic start:" in p.stdout and "sweeps" in p.stdout,
           "the compression shows its progress", p)


def main():
    hardrod, source = os.path.abspath(sys.argv[1]), pathlib.Path(sys.argv[2]).resolve()
    scene = source / "scenes/everyday.toml"
    work = pathlib.Path(tempfile.mkdtemp(prefix="hardrod-rundir-"))
    try:
        force_clears(hardrod, scene, work)
        resume_identity(hardrod, scene, work)
        h5md_start(hardrod, scene, work)
        isotropic_way_out(hardrod, scene, work)
        full_disk(hardrod, scene, work)
    finally:
        for m in work.glob("disk*"):
            subprocess.run(["umount", str(m)], capture_output=True)
        shutil.rmtree(work, ignore_errors=True)
    print("all run-directory checks passed")


if __name__ == "__main__":
    main()
