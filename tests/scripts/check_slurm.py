#!/usr/bin/env python3
"""scripts/slurm/ without Slurm: the sbatch template and the sweep helper checked by bash -n,
their dry runs (the commands they would give Slurm: binding, threads, the job array and the
analysis after it), a real local run of the template that gets SIGUSR1 mid-run, checkpoints,
"requeues" (a fake scontrol) and resumes to completion, and a real local sweep over two seeds
followed by `hardrod analyze`.

Usage: check_slurm.py HARDROD SOURCE_DIR
"""
import json
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import tempfile
import time


def sh(cmd, env=None, check=True):
    r = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if check and r.returncode != 0:
        sys.exit(f"FAILED: {' '.join(map(str, cmd))} exited {r.returncode}\n{r.stdout}\n{r.stderr}")
    return r


def expect(text, *parts):
    for p in parts:
        if p not in text:
            sys.exit(f"FAILED: {p!r} not in:\n{text}")


def main():
    hardrod, source = sys.argv[1], pathlib.Path(sys.argv[2])
    sbatch = source / "scripts/slurm/hardrod.sbatch"
    sweep = source / "scripts/slurm/sweep"
    scene = source / "scenes/default.toml"
    tmp = pathlib.Path(tempfile.mkdtemp(prefix="hardrod-slurm-"))
    base = {k: v for k, v in os.environ.items() if not k.startswith("SLURM_")}
    base["HARDROD"] = hardrod
    try:
        for script in (sbatch, sweep):
            sh(["bash", "-n", str(script)])

        # Dry run inside a (pretended) Slurm job: srun binds the ranks, OpenMP the threads.
        env = dict(base, SLURM_JOB_ID="12", SLURM_CPUS_PER_TASK="4", HARDROD_DRY_RUN="1")
        out = sh([str(sbatch), str(scene), str(tmp / "dry"), "--set", "run.steps=10"], env).stdout
        expect(out, "OMP_NUM_THREADS=4", "OMP_PLACES=cores", "OMP_PROC_BIND=close",
               "srun --cpu-bind=cores --cpus-per-task=4",
               f"{hardrod} run {scene} --out {tmp / 'dry'} --threads 4 --set run.steps=10")
        out = sh([str(sbatch), str(scene), str(tmp / "dry")],
                 dict(env, HARDROD_LAUNCHER="mpirun", SLURM_NTASKS_PER_NODE="2")).stdout
        expect(out, "mpirun --bind-to core --map-by ppr:2:node:pe=4")
        out = sh([str(sweep), str(scene), "system.reduced_density", "0.3", "0.4", "0.5",
                  "--out", str(tmp / "dens"), "--dry-run", "--sbatch",
                  "--time=1:00:00 --partition=debug -A proj"], base).stdout
        expect(out, "sbatch --parsable --array=0-2 --time=1:00:00 --partition=debug -A proj",
               f"--sweep {tmp / 'dens'}/sweep.tsv",
               # the analysis gets the site's placement, not the array's time limit
               "--dependency=afterok:JOBID --job-name=hardrod-analyze --partition=debug -A proj --wrap",
               f"analyze {tmp}/dens/reduced_density-0.3 {tmp}/dens/reduced_density-0.4 "
               f"{tmp}/dens/reduced_density-0.5 --out {tmp / 'dens'}")
        table = (tmp / "dens/sweep.tsv").read_text().splitlines()
        assert table[1] == f"{tmp}/dens/reduced_density-0.4\tsystem.reduced_density=0.4", table

        # A real run, signalled before its end: checkpoint, requeue (fake scontrol), resume.
        fake_bin = tmp / "bin"
        fake_bin.mkdir()
        (fake_bin / "scontrol").write_text(f"#!/bin/sh\necho \"$@\" >> {tmp}/scontrol.log\n")
        (fake_bin / "scontrol").chmod(0o755)
        env = dict(base, PATH=f"{fake_bin}:{base['PATH']}", SLURM_JOB_ID="77",
                   HARDROD_LAUNCHER="none", OMP_NUM_THREADS="1")
        job = tmp / "job"
        cmd = [str(sbatch), str(scene), str(job), "--quiet", "--set", "run.equilibration_steps=0",
               "--set", "run.steps=40000", "--set", "run.sample_interval=1000"]
        p = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                             text=True)
        deadline = time.time() + 60
        while not (job / "timeseries.csv").exists() and time.time() < deadline:
            time.sleep(0.05)
        time.sleep(0.5)
        p.send_signal(signal.SIGUSR1)
        text, _ = p.communicate(timeout=120)
        if p.returncode != 0 or "requeueing job 77" not in text:
            sys.exit(f"FAILED: signalled job exited {p.returncode}:\n{text}")
        assert (tmp / "scontrol.log").read_text().split() == ["requeue", "77"]
        first = json.loads((job / "summary.json").read_text())
        assert first["status"] == "interrupted", first["status"]
        out = sh(cmd, env).stdout  # the requeued job
        second = json.loads((job / "summary.json").read_text())
        assert second["status"] == "completed" and second["segments"] == 2, second["status"]
        assert second["first_step"] == first["steps_done"] and second["steps_done"] == 40000
        expect(sh(cmd, env).stdout, "has completed; nothing to do")
        print(f"template: signalled at step {first['steps_done']}, requeued, resumed to 40000")

        # A real local sweep over two seeds, then the analysis of both runs.
        root = tmp / "seeds"
        sh([str(sweep), str(scene), "init.seed", "1", "2", "--out", str(root), "--local", "--",
            "--quiet", "--set", "run.equilibration_steps=0", "--set", "run.steps=2000",
            "--set", "run.sample_interval=200"], dict(base, OMP_NUM_THREADS="1"))
        seeds = [json.loads((root / f"seed-{s}/summary.json").read_text())["seed"] for s in (1, 2)]
        assert seeds == [1, 2], seeds
        analysis = json.loads((root / "analysis.json").read_text())
        assert analysis["runs"] == 2, analysis["runs"]
        print("sweep: two seeds run locally and analysed together")
        return 0
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
