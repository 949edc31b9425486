"""Running `hardrod run` from a harness: one run, many runs on a pool, reuse of earlier runs.

A Run is the command (scene, --set values, threads, mpirun prefix, environment); a Result is
what came back (exit status, summary.json, wall time, the error message of a failed run).
Each run writes its command as the first line of its hardrod.log, which is how `--reuse`
recognises the same settings later. Nothing here reads timeseries or judges physics.
"""

import json
import os
import shlex
import subprocess
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path

from .common import HARDROD, ROOT, relpath
from .outputs import load_json


@dataclass
class Run:
    name: str
    scene: str                         # path relative to the repository root
    sets: dict                         # scene key -> TOML value text
    threads: int
    out: Path
    env: dict = field(default_factory=dict)
    prefix: list = field(default_factory=list)   # e.g. mpirun -np R (mpi.prefix)
    meta: dict = field(default_factory=dict)
    extra_args: list = field(default_factory=list)  # more `hardrod run` flags, e.g. --grid
    binary: Path = None                # another build's hardrod (default build/hardrod)

    def argv(self):
        cmd = [*self.prefix, relpath(self.binary or HARDROD), "run", self.scene]
        for k, v in self.sets.items():
            cmd += ["--set", f"{k}={v}"]
        return cmd + ["--out", relpath(self.out), "--force", "--threads", str(self.threads), *self.extra_args]

    def shell(self):
        env = " ".join(f"{k}={shlex.quote(str(v))}" for k, v in self.env.items())
        return (env + " " if env else "") + shlex.join(self.argv())

    def work(self):
        """Rough cost, for starting the longest runs first."""
        n = float(self.meta.get("n", self.sets.get("system.n", 2300)))
        return n * (float(self.sets.get("run.equilibration_steps", 0)) + float(self.sets.get("run.steps", 1)))


@dataclass
class Result:
    run: Run
    returncode: int
    summary: dict
    wall: float
    error: str = ""
    load_before: float = None  # 1-minute load average when the run started

    @property
    def ok(self):
        return self.returncode == 0 and self.summary is not None and self.summary.get("status") == "completed"

    def status(self):
        if self.ok:
            return "ok"
        meaning = {1: "bad command line", 2: "bad scene", 3: "physics broke"}.get(self.returncode, "failed")
        return f"exit {self.returncode} ({meaning})"


def execute(run):
    run.out.mkdir(parents=True, exist_ok=True)
    log = run.out / "hardrod.log"
    load_before = os.getloadavg()[0]
    start = time.monotonic()
    with open(log, "w") as f:
        f.write("$ " + run.shell() + "\n")
        f.flush()
        try:
            rc = subprocess.run(run.argv(), cwd=ROOT, stdout=f, stderr=subprocess.STDOUT,
                                env={**os.environ, **{k: str(v) for k, v in run.env.items()}}).returncode
        except OSError as e:
            f.write(f"bench: cannot start: {e}\n")
            rc = 127
    wall = time.monotonic() - start
    summary = load_json(run.out / "summary.json")
    error = ""
    if rc != 0 or summary is None:
        lines = [l for l in log.read_text(errors="replace").splitlines()[1:] if l.strip()]
        start = max((i for i, l in enumerate(lines) if l.startswith("hardrod: error") or
                     l.startswith("hardrod: the run stopped")), default=max(0, len(lines) - 3))
        error = " ".join(l.strip() for l in lines[start:start + 6])[-500:]
        if summary is not None and summary.get("error"):
            error = summary["error"]
    return Result(run, rc, summary, wall, error, load_before)


def reused(run, reuse_dir):
    """The same run in an earlier results directory (same scene and --set values), or None."""
    old = Path(reuse_dir) / "runs" / run.name
    summary = load_json(old / "summary.json")
    try:
        first = (old / "hardrod.log").read_text(errors="replace").splitlines()[0]
    except (OSError, IndexError):
        return None
    argv = shlex.split(first[2:]) if first.startswith("$ ") else []
    wanted = run.argv()
    same = (summary is not None and run.scene in argv and all(
        f"{k}={v}" in argv for k, v in run.sets.items()) and
        sum(a == "--set" for a in argv) == len(run.sets) and
        argv[argv.index("--threads") + 1] == wanted[wanted.index("--threads") + 1])
    if not same:
        return None
    run.out = old
    rc = 0 if summary.get("status") == "completed" else 3
    return Result(run, rc, summary, summary.get("wall_seconds", 0.0), summary.get("error", ""))


def run_all(runs, jobs, label, longest_first=True, reuse_dir=None):
    """Runs on `jobs` workers (longest first unless told otherwise); results in the order given.
    With reuse_dir, a run already done there with the same settings is read, not repeated."""
    results = [None] * len(runs)
    if reuse_dir:
        for i, r in enumerate(runs):
            results[i] = reused(r, reuse_dir)
        kept = sum(r is not None for r in results)
        print(f"{label}: reusing {kept} of {len(runs)} runs from {relpath(reuse_dir)}", flush=True)
    todo = [i for i in range(len(runs)) if results[i] is None]
    print(f"{label}: {len(todo)} runs, {jobs} at a time", flush=True)
    order = list(todo)
    if longest_first:
        order.sort(key=lambda i: -runs[i].work())
    t0 = time.monotonic()
    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        futures = {pool.submit(execute, runs[i]): i for i in order}
        for done, fut in enumerate(as_completed(futures), 1):
            i = futures[fut]
            r = fut.result()
            results[i] = r
            extra = "" if r.ok else f"  <- {r.error}"
            print(f"  [{done}/{len(todo)}] {runs[i].name:<28} {r.status():<26} {r.wall:7.1f} s"
                  f"   (elapsed {time.monotonic() - t0:.0f} s){extra}", flush=True)
    return results


def print_dry_run(runs, jobs, note=""):
    print(f"(dry run) {len(runs)} runs, {jobs} at a time{note}:")
    for r in runs:
        print("  " + r.shell())


def file_start(h5md):
    """--set values that start a run from the last frame of an H5MD trajectory."""
    return {"init.configuration": '"file"', "init.file": json.dumps(str(Path(h5md).resolve()))}
