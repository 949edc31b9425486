#!/usr/bin/env python3
"""Checkpoints and resume, end to end through the hardrod binary.

  resume    run 2000 steps straight; run 1000 then `hardrod resume DIR --set run.steps=2000`:
            the same state_checksum, observables, time series, trajectory, Frank and angular
            accumulators. Then the same with the restart on other rank and thread counts.
  signals   kill a run with SIGTERM at random moments (several times) and resume each time:
            the final state equals the uninterrupted run's; after every kill (also SIGKILL)
            every checkpoint on disk is complete (sealed size and hash, readable by h5py).
  hostile   truncated, bit-flipped, wrong-version, NaN, wrong-N and wrong-shape checkpoints,
            checkpoints of another run, bad resume overrides, malformed scene files and
            values past the step limits: each exits 2 with a clear message, and no file of
            the run directory changes. A second process in a run directory, a missing newest
            checkpoint, a run without production samples.

Usage: check_checkpoint.py MODE HARDROD SOURCE_DIR [--mpirun MPIRUN]
Needs h5py (Debian python3-h5py), hence run by /usr/bin/python3.
"""
import argparse
import hashlib
import json
import os
import pathlib
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "scripts"))
from hardrod_bench import mpi  # noqa: E402  (the mpirun launcher shared with scripts/bench)

import h5py
import numpy as np

USER_BLOCK = 512
MASK = (1 << 64) - 1

# summary.json keys that depend on the run's history of processes rather than the physics.
NOT_PHYSICS = {
    "wall_seconds", "wall_seconds_total", "setup_seconds", "setup_seconds_total", "step_seconds",
    "seconds_per_step", "production_seconds_per_step", "particle_steps_per_second", "ns_per_particle_step",
    "timers", "timers_rank_max", "timers_rank_mean", "hardware_counters", "communication_per_rank", "placement", "binding",
    "topology", "threads", "ranks", "grid", "segments", "first_step",
    "narrow_phase_tests_per_step", "neighbor_list_builds", "status", "stopped_by", "detect_watched_share",
    "detect_near_share", "production_compute_seconds_per_step", "production_timers_per_step", "simulated_compute",
    "balance", "spanning_clusters", "command_line", "started_at",
    "exact",  # the exact method's work of this process (a cost diagnostic)
}


def content_hash(data: bytes) -> int:
    """The checkpoint's seal: runtime/checkpoint.cpp content_hash over data[512:]."""
    body = data[USER_BLOCK:]
    h = 0x9E3779B97F4A7C15 ^ len(body)
    full = len(body) // 8 * 8
    words = np.frombuffer(body[:full], dtype="<u8")
    for w in words.tolist():
        h = ((h ^ w) * 0xFF51AFD7ED558CCD) & MASK
        h ^= h >> 29
    tail = int.from_bytes(body[full:] + bytes(8 - (len(body) - full)), "little")
    h = ((h ^ tail ^ 0x8000000000000000) * 0xFF51AFD7ED558CCD) & MASK
    h ^= h >> 29
    return h


def reseal(path: pathlib.Path):
    """Rewrite the user block of a checkpoint edited with h5py (size and hash)."""
    data = path.read_bytes()
    block = f"hardrod checkpoint 1\nbytes {len(data)}\nhash {content_hash(data):016x}\n".encode()
    path.write_bytes(block + data[len(block):])


def check_sealed(path: pathlib.Path):
    """A checkpoint on disk must be complete: sealed size and hash match, h5py reads it."""
    data = path.read_bytes()
    lines = data[:USER_BLOCK].split(b"\n")
    assert lines[0] == b"hardrod checkpoint 1", f"{path}: header {lines[0]!r}"
    size = int(lines[1].split()[1])
    sealed = int(lines[2].split()[1], 16)
    assert size == len(data), f"{path}: partial, {len(data)} bytes of {size}"
    assert content_hash(data) == sealed, f"{path}: content hash differs from the seal"
    with h5py.File(path, "r") as f:
        n = int(f.attrs["n"])
        assert f["bodies/position"].shape == (n, 3)
        assert np.array_equal(f["bodies/id"][()], np.arange(n))


class Runner:
    def __init__(self, hardrod, source, mpirun, work):
        self.hardrod = hardrod
        self.source = pathlib.Path(source)
        self.mpirun = mpirun
        self.work = pathlib.Path(work)
        self.scene = self.source / "tests/parallel/rods.toml"
        self.env = mpi.environment()

    def command(self, args, ranks=1, threads=1):
        cmd = [self.hardrod] + args + ["--quiet", "--threads", str(threads)]
        if ranks > 1:
            # exec: a signal to the process goes to mpirun itself, not to a shell around it.
            cmd = mpi.prefix(ranks, mpirun=self.mpirun) + cmd
        return cmd

    def run(self, args, ranks=1, threads=1, expect=0):
        p = subprocess.run(self.command(args, ranks, threads), env=self.env, capture_output=True,
                           text=True, timeout=600)
        if expect is not None and p.returncode != expect:
            sys.exit(f"FAIL: {' '.join(args)} exited {p.returncode}, expected {expect}\n"
                     f"{p.stdout}\n{p.stderr}")
        return p


def summary(d):
    return json.loads((pathlib.Path(d) / "summary.json").read_text())


def close_json(x, y, rtol):
    if isinstance(x, dict):
        return isinstance(y, dict) and x.keys() == y.keys() and all(
            close_json(x[k], y[k], rtol) for k in x)
    if isinstance(x, list):
        return isinstance(y, list) and len(x) == len(y) and all(
            close_json(u, v, rtol) for u, v in zip(x, y))
    if isinstance(x, float) and isinstance(y, (int, float)):
        return abs(x - y) <= rtol * max(abs(x), abs(y), 1e-300)
    return x == y


def compare_runs(a, b, trajectory=True, same_ranks=True):
    """Everything a user reads from run `b` equals run `a`, bit for bit; only the Fourier
    sums of the Frank accumulator may differ in round-off when the rank count changed."""
    a, b = pathlib.Path(a), pathlib.Path(b)
    sa, sb = summary(a), summary(b)
    problems = [f"summary.{k}: {sa.get(k)!r} vs {sb.get(k)!r}"
                for k in sorted(set(sa) | set(sb)) if k not in NOT_PHYSICS and sa.get(k) != sb.get(k)]
    for name in ("timeseries.csv", "angular.json", "frank.json"):
        if (a / name).exists() and (a / name).read_bytes() != (b / name).read_bytes():
            if name == "frank.json" and not same_ranks and close_json(
                    json.loads((a / name).read_text()), json.loads((b / name).read_text()), 1e-12):
                print(f"  {name}: equal to 1e-12 relative (Fourier sums over other rank counts)")
                continue
            problems.append(f"{name} differs")
    if trajectory:
        with h5py.File(a / "trajectory.h5", "r") as fa, h5py.File(b / "trajectory.h5", "r") as fb:
            keys = [f"particles/all/{element}/{series}"
                    for element in ("position", "velocity", "axis", "angular_velocity")
                    for series in ("step", "time", "value")]
            keys += ["particles/all/box/edges/value", "particles/wrapped/position/value",
                     "particles/wrapped/image/value"]
            steps = "particles/all/position/step"
            for key in keys:
                if not np.array_equal(fa[key][()], fb[key][()]):
                    problems.append(f"trajectory {key} differs "
                                    f"(steps {fa[steps][()]} vs {fb[steps][()]})")
    if problems:
        sys.exit("FAIL: " + str(b) + " differs from " + str(a) + ":\n  " + "\n  ".join(problems))
    print(f"ok: {b.name} equals {a.name} (state {sb['state_checksum']}, "
          f"P* {sb['pressure_star']['mean']:.6f}, S {sb['order_parameter']['mean']:.6f})")


# Frank accumulation and frames on, so that every accumulator and output is exercised.
EXTRA = ["--set", "observables.frank=true", "--set", "observables.fourier_kmax=3",
         "--set", "observables.fourier_interval=100", "--set", "output.snapshot_interval=300"]


def mode_resume(r: Runner):
    straight = r.work / "straight"
    r.run(["run", str(r.scene), "--out", str(straight), "--set", "run.steps=2000"] + EXTRA)
    # With equilibration, stopped (by the step target) inside it and resumed across its end:
    # the time series keeps its equilibration rows and the production intervals line up.
    eq = ["--set", "run.equilibration_steps=700", "--set", "run.sample_interval=300"]
    eq_straight = r.work / "eq-straight"
    r.run(["run", str(r.scene), "--out", str(eq_straight), "--set", "run.steps=1300"] + eq)
    rows = (eq_straight / "timeseries.csv").read_text().splitlines()
    assert sum(",equilibration," in x for x in rows) == 3, rows  # steps 100, 400, 700
    d = r.work / "eq-resumed"
    r.run(["run", str(r.scene), "--out", str(d), "--set", "run.steps=0"] + eq)
    r.run(["resume", str(d), "--set", "run.steps=1300"])
    compare_runs(eq_straight, d)
    cases = [("1x1-then-1x1", 1, 1, 1, 1), ("1x1-then-1x2", 1, 1, 1, 2),
             ("2x1-then-3x1", 2, 1, 3, 1), ("3x1-then-1x1", 3, 1, 1, 1)]
    if not r.mpirun:
        cases = cases[:2]
    for name, ranks_a, threads_a, ranks_b, threads_b in cases:
        same_ranks = ranks_a == 1 and ranks_b == 1
        d = r.work / name
        r.run(["run", str(r.scene), "--out", str(d), "--set", "run.steps=1000"] + EXTRA,
              ranks_a, threads_a)
        s = summary(d)
        assert s["steps_done"] == 1000 and s["status"] == "completed", s["status"]
        check_sealed(d / "checkpoint.h5")
        r.run(["resume", str(d), "--set", "run.steps=2000"], ranks_b, threads_b)
        compare_runs(straight, d, same_ranks=same_ranks)
    # A resume with nothing left to do reproduces the same results.
    d = r.work / "1x1-then-1x1"
    r.run(["resume", str(d)])
    compare_runs(straight, d)
    # The exact method keeps no state between steps beyond the bodies: stopped, resumed on
    # other threads and ranks, the same bits as straight through.
    exact = ["--set", "run.method=exact", "--set", "run.dt=1e-3"]
    exact_straight = r.work / "exact-straight"
    r.run(["run", str(r.scene), "--out", str(exact_straight), "--set", "run.steps=600"] + exact + EXTRA)
    exact_cases = [("exact-1x1-then-1x2", 1, 1, 1, 2), ("exact-1x1-then-3x1", 1, 1, 3, 1),
                   ("exact-2x1-then-1x1", 2, 1, 1, 1)]
    for name, ranks_a, threads_a, ranks_b, threads_b in exact_cases[:None if r.mpirun else 1]:
        d = r.work / name
        r.run(["run", str(r.scene), "--out", str(d), "--set", "run.steps=300"] + exact + EXTRA,
              ranks_a, threads_a)
        r.run(["resume", str(d), "--set", "run.steps=600"], ranks_b, threads_b)
        compare_runs(exact_straight, d, same_ranks=ranks_a == 1 and ranks_b == 1)


def mode_signals(r: Runner):
    rng = random.Random(int(os.environ.get("HARDROD_TEST_SEED", time.time_ns() % 100000)))
    steps = ["--set", "run.steps=16000", "--set", "output.checkpoint_interval=250"]
    straight = r.work / "straight"
    start = time.time()
    r.run(["run", str(r.scene), "--out", str(straight)] + steps)
    duration = time.time() - start
    d = r.work / "killed"
    # SIGTERM to single processes and SIGUSR1 to mpirun, which forwards it to its ranks (on
    # SIGTERM mpirun itself ends the job, SIGKILL after odls_base_sigkill_timeout = 1 s);
    # SIGKILL only to single processes (an orphaned rank would keep writing).
    kills = [(signal.SIGTERM, 1), (signal.SIGUSR1, 2), (signal.SIGKILL, 1), (signal.SIGTERM, 1),
             (signal.SIGUSR1, 2), (signal.SIGKILL, 1), (signal.SIGTERM, 1), (signal.SIGUSR1, 2)]
    first = True
    for sig, ranks in kills:
        if ranks > 1 and not r.mpirun:
            ranks = 1
        if first:
            args = ["run", str(r.scene), "--out", str(d)] + steps
        elif not (d / "checkpoint.h5").exists() and (d / "checkpoint.prev.h5").exists():
            args = ["resume", str(d), "--checkpoint", str(d / "checkpoint.prev.h5")]
        elif not (d / "checkpoint.h5").exists():
            args = ["run", str(r.scene), "--out", str(d), "--force"] + steps
        else:
            args = ["resume", str(d)]
        first = False
        delay = rng.uniform(0.05, 0.5) * duration
        p = subprocess.Popen(r.command(args, ranks=ranks), env=r.env, stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
        time.sleep(delay)
        p.send_signal(sig)
        out, err = p.communicate(timeout=300)
        name = f"{signal.Signals(sig).name} to {'mpirun -np 2' if ranks > 1 else 'hardrod'}"
        if sig != signal.SIGKILL:
            sig_name = signal.Signals(sig).name
            if p.returncode == 0:
                print(f"{name} after {delay:.2f} s: the run had finished")
            elif ranks > 1 and "stopped by" not in err:
                # mpirun ends a job it is still launching without forwarding the signal.
                print(f"{name} after {delay:.2f} s: mpirun ended the job during launch "
                      f"(exit {p.returncode})")
            else:
                # hardrod exits 4; mpirun passes it on or reports 1.
                assert p.returncode in ((4,) if ranks == 1 else (1, 4)), \
                    f"{name}: exit {p.returncode}\n{err}"
                assert f"stopped by {sig_name}" in err and "hardrod resume" in err, err
                s = summary(d)
                assert s["status"] == "interrupted" and s["stopped_by"] == sig_name, s["status"]
                print(f"{name} after {delay:.2f} s: stopped at step {s['steps_done']}, "
                      f"exit {p.returncode}")
        else:
            print(f"{name} after {delay:.2f} s: exit {p.returncode}")
        for ckpt in ("checkpoint.h5", "checkpoint.prev.h5"):
            if (d / ckpt).exists():
                check_sealed(d / ckpt)
        if p.returncode == 0:
            break
    # Finish the run.
    if summary(d)["status"] != "completed" or summary(d)["steps_done"] != 16000:
        r.run(["resume", str(d)])
    # A SIGKILL during a frame may leave the trajectory unreadable; it is then kept aside and
    # restarted, so compare the trajectory only when no kill was of that kind.
    compare_runs(straight, d, trajectory=not list(d.glob("trajectory.h5.before-step-*")))


def file_hashes(d):
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(d.iterdir())}


def mode_hostile(r: Runner):
    d = r.work / "run"
    r.run(["run", str(r.scene), "--out", str(d), "--set", "run.steps=600"])
    good = (d / "checkpoint.h5").read_bytes()
    pristine = r.work / "pristine.h5"
    pristine.write_bytes(good)
    rng = random.Random(7)

    def expect_rejected(label, data, words, args=None):
        (d / "checkpoint.h5").write_bytes(data)
        before = file_hashes(d)
        p = r.run(args or ["resume", str(d), "--set", "run.steps=1200"], expect=None)
        after = file_hashes(d)
        if p.returncode != 2:
            sys.exit(f"FAIL {label}: exit {p.returncode}, expected 2\n{p.stdout}\n{p.stderr}")
        if not any(w in p.stderr for w in words):
            sys.exit(f"FAIL {label}: message lacks {words}: {p.stderr}")
        if before != after:
            sys.exit(f"FAIL {label}: files changed: "
                     f"{[k for k in before if before.get(k) != after.get(k)]}")
        print(f"ok: {label}: {p.stderr.strip().splitlines()[-1][:150]}")

    for size in (0, 100, USER_BLOCK - 1, USER_BLOCK + 10, len(good) // 2, len(good) - 1):
        expect_rejected(f"truncated to {size} bytes", good[:size], ["truncated", "not a hardrod"])
    for k in range(24):
        pos = rng.randrange(USER_BLOCK, len(good))
        bad = bytearray(good)
        bad[pos] ^= 1 << rng.randrange(8)
        expect_rejected(f"bit flip at byte {pos}", bytes(bad), ["corrupted"])
    bad = bytearray(good)
    bad[5] ^= 0x20  # inside the header line
    expect_rejected("bit flip in the header", bytes(bad), ["not a hardrod checkpoint"])
    expect_rejected("version 7", good.replace(b"hardrod checkpoint 1", b"hardrod checkpoint 7", 1),
                    ["version 7"])

    def edited(label, edit, words):
        work = r.work / "edit.h5"
        work.write_bytes(good)
        with h5py.File(work, "r+") as f:
            edit(f)
        reseal(work)
        expect_rejected(label, work.read_bytes(), words)

    def nan_inside(f):
        f["bodies/velocity"][17, 1] = np.nan

    def wrong_n(f):
        f.attrs["n"] = np.int64(2303)

    def wrong_shape(f):
        del f["bodies/axis"]
        f["bodies/axis"] = np.zeros((2304, 2))

    def wrong_format_version(f):
        f.attrs["version"] = np.int64(2)

    def missing(f):
        del f["bodies/angular_velocity"]

    def moved(f):
        f["bodies/position"][3, 0] += 1e-9  # no longer hashes to the stored state checksum

    def scene_n(f):
        text = bytes(f["scene"][()]).decode().replace("n = 2304", "n = 2000")
        del f["scene"]
        f["scene"] = np.frombuffer(text.encode(), dtype=np.int8)

    def run_state_without(key):
        def edit(f):
            state = json.loads(bytes(f["run_state"][()]).decode())
            del state["run"][key]
            del f["run_state"]
            f["run_state"] = np.frombuffer(json.dumps(state).encode(), dtype=np.int8)
        return edit

    edited("NaN inside", nan_inside, ["not finite"])
    edited("run_state without a physics series", run_state_without("s_series"), ["s_series"])
    edited("wrong N", wrong_n, ["expected [2303]"])
    edited("wrong shape", wrong_shape, ["shape [2304, 2]"])
    edited("wrong version attribute", wrong_format_version, ["version 2"])
    edited("missing dataset", missing, ["angular_velocity is missing"])
    edited("bodies edited", moved, ["hash to"])
    edited("scene with another n", scene_n, ["n = 2000", "lattice"])

    def other_seed(f):  # a checkpoint of another run of the same system: only the seed differs
        text = bytes(f["scene"][()]).decode().replace("seed = 11", "seed = 12")
        del f["scene"]
        f["scene"] = np.frombuffer(text.encode(), dtype=np.int8)

    edited("checkpoint of another run (other seed)", other_seed,
           ["belongs to another run (init.seed = 12 in the checkpoint, 11 in"])
    foreign = r.work / "foreign.h5"
    foreign.write_bytes((r.work / "edit.h5").read_bytes())
    expect_rejected("resume --checkpoint of another run", good, ["belongs to another run"],
                    ["resume", str(d), "--checkpoint", str(foreign), "--set", "run.steps=1200"])

    # Bad resume requests: the checkpoint is good, the request is not.
    expect_rejected("resume --set run.dt", good, ["cannot be changed on resume"],
                    ["resume", str(d), "--set", "run.dt=1e-3"])
    expect_rejected("resume below the checkpoint", good,
                    ["at step 600 already (equilibration 0 + production 600 steps)"],
                    ["resume", str(d), "--set", "run.steps=100"])
    expect_rejected("resume --set run.steps=-5", good, ["run.steps"],
                    ["resume", str(d), "--set", "run.steps=-5"])
    # Malformed scenes, even with --force onto the existing run: nothing is touched.
    scenes = {
        "syntax": ("[system\nn = 10\n", ["expected ']'"]),
        "negative n": ("[system]\nn = -4\nreduced_density = 0.3\n[run]\nsteps = 10\n",
                       ["system.n = -4"]),
        "nan dt": ("[system]\nn = 100\nreduced_density = 0.3\n[run]\nsteps = 10\ndt = nan\n",
                   ["run.dt = nan"]),
        "unknown key": ("[system]\nn = 100\nreduced_density = 0.3\n[run]\nsteps = 10\n"
                        "steppes = 10\n", ["run.steppes"]),
        "string for number": ("[system]\nn = \"many\"\nreduced_density = 0.3\n[run]\n"
                              "steps = 10\n", ["system.n = \"many\""]),
    }
    for label, (text, words) in scenes.items():
        path = r.work / "bad.toml"
        path.write_text(text)
        expect_rejected(f"scene: {label}", good, words,
                        ["run", str(path), "--out", str(d), "--force"])
    # Values that once hung the run (an interval of 2^63 - 1 overflowed the next-event step),
    # ended it at once as "completed" (steps + equilibration overflowed) or crashed it: refused
    # in seconds by name, with nothing created (a rerun needs no --force).
    huge = str(2**63 - 1)
    overrides = {
        "output.snapshot_interval": (huge, ["must be at most 1000000000000000"]),
        "output.checkpoint_interval": (huge, ["must be at most 1000000000000000"]),
        "run.steps": (huge, ["must be at most 1000000000000000"]),
        "init.temperature": ("1e-30", ["init.temperature = 1e-30: must be in"]),
        "system.box": ("[1e9,20,20]", ["system.box = [1e+09, 20, 20]: the box holds"]),
    }
    for key, (value, words) in overrides.items():
        fresh = r.work / "never-made"
        start = time.monotonic()
        p = r.run(["run", str(r.scene), "--out", str(fresh), "--set", f"{key}={value}"],
                  expect=None)
        if p.returncode != 2 or not any(w in p.stderr for w in words) or fresh.exists():
            sys.exit(f"FAIL --set {key}={value}: exit {p.returncode}, directory made: "
                     f"{fresh.exists()}\n{p.stderr}")
        print(f"ok: --set {key}={value} refused in {time.monotonic() - start:.1f} s: "
              f"{p.stderr.strip().splitlines()[-1][:150]}")
    # And the untouched checkpoint still resumes.
    (d / "checkpoint.h5").write_bytes(good)
    r.run(["resume", str(d), "--set", "run.steps=1200"])
    print("ok: the good checkpoint resumes after all that")
    # A checkpoint of an earlier build, whose run_state lacks a bookkeeping key added since
    # (setup_seconds), resumes to the same state.
    older = r.work / "older-build"
    shutil.copytree(d, older)
    (older / "checkpoint.h5").write_bytes(good)
    with h5py.File(older / "checkpoint.h5", "r+") as f:
        run_state_without("setup_seconds")(f)
    reseal(older / "checkpoint.h5")
    r.run(["resume", str(older), "--set", "run.steps=1200"])
    assert summary(older)["state_checksum"] == summary(d)["state_checksum"]
    print("ok: a checkpoint without setup_seconds (earlier build) resumes to the same state")
    hostile_directories(r, d)


def hostile_directories(r: Runner, d: pathlib.Path):
    """One process per run directory; a missing newest checkpoint; a run without results."""
    target = summary(d)["state_checksum"]  # d: 0 -> 600 -> 1200
    # A second resume while one runs is refused with the holder's pid; once the holder is
    # killed (kill -9: the lock file stays), the directory resumes to the same state.
    locked = r.work / "locked"
    shutil.copytree(d, locked)
    (locked / "checkpoint.h5").write_bytes((locked / "checkpoint.prev.h5").read_bytes())
    holder = subprocess.Popen(r.command(["resume", str(locked), "--set", "run.steps=100000000"]),
                              env=r.env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    lock = locked / "hardrod.lock"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not (
            lock.exists() and lock.read_text().strip() == str(holder.pid)):
        time.sleep(0.1)
    p = r.run(["resume", str(locked), "--set", "run.steps=1200"], expect=None)
    holder.kill()
    holder.wait()
    if p.returncode != 2 or f"in use by another hardrod process (pid {holder.pid}" not in p.stderr:
        sys.exit(f"FAIL second resume: exit {p.returncode}\n{p.stderr}")
    print(f"ok: a second resume is refused: {p.stderr.strip().splitlines()[-1][:150]}")
    r.run(["resume", str(locked), "--set", "run.steps=1200"])
    assert summary(locked)["state_checksum"] == target
    print("ok: after kill -9 of the holder the directory resumes to the same state")
    # Killed between the checkpoint's two renames: only checkpoint.prev.h5 (step 600) is left;
    # resume takes it by itself, says so, and reaches the same state.
    renamed = r.work / "renamed"
    shutil.copytree(d, renamed)
    (renamed / "checkpoint.h5").unlink()
    p = r.run(["resume", str(renamed), "--set", "run.steps=1200"])
    assert "resuming from the previous one" in p.stderr, p.stderr
    assert summary(renamed)["state_checksum"] == target
    print("ok: a missing checkpoint.h5 falls back to checkpoint.prev.h5 with a note")
    # No production samples: no S or P* written as results, and analyze refuses the run.
    empty = r.work / "no-production"
    r.run(["run", str(r.scene), "--out", str(empty), "--set", "run.steps=0",
           "--set", "run.equilibration_steps=100"])
    s = summary(empty)
    assert s["order_parameter"]["mean"] is None and s["pressure_star"]["mean"] is None, s
    p = subprocess.run([r.hardrod, "analyze", str(empty), "--no-plots"], capture_output=True,
                       text=True, timeout=60)
    assert p.returncode != 0 and "no production samples" in p.stderr, (p.returncode, p.stderr)
    print(f"ok: no production samples: null results; analyze: {p.stderr.strip()[:150]}")
    full_disk(r, d, target)


def full_disk(r: Runner, d: pathlib.Path, target: str):
    """A disk that fills up before a checkpoint: one line naming "No space left on device",
    summary.json with status failed, no checkpoint.h5.tmp, the previous checkpoint intact;
    with room again the run resumes to the uninterrupted state. Needs a small tmpfs (root)."""
    mount = r.work / "small-disk"
    mount.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=4M", "tmpfs", str(mount)],
                      capture_output=True).returncode != 0:
        print("skip: full disk: cannot mount a tmpfs here (needs root)")
        return
    try:
        run = mount / "run"
        shutil.copytree(d, run, ignore=shutil.ignore_patterns("checkpoint.h5"))
        (run / "checkpoint.h5").write_bytes((d / "checkpoint.prev.h5").read_bytes())  # step 600
        (run / "checkpoint.prev.h5").unlink()
        kept = (run / "checkpoint.h5").read_bytes()
        filler = mount / "filler"

        def fill(leave):
            filler.unlink(missing_ok=True)
            filler.write_bytes(b"\0" * max(0, shutil.disk_usage(mount).free - leave))

        # A disk with no room at all: nothing written is cut short (no file renamed over a
        # good one from a short temporary), no temporary is left, the checkpoint is kept.
        before = {f: (run / f).read_bytes()
                  for f in ("scene.toml", "angular.json", "summary.json")}
        fill(0)
        p = r.run(["resume", str(run), "--set", "run.steps=1200"], expect=None)
        assert p.returncode == 2 and "No space left on device" in p.stderr, (p.returncode, p.stderr)
        assert not list(run.glob("*.tmp")), list(run.glob("*.tmp"))
        assert all((run / f).read_bytes() == b for f, b in before.items())
        assert (run / "checkpoint.h5").read_bytes() == kept
        print(f"ok: no room at all: {p.stderr.strip().splitlines()[-1][:150]}")
        # A checkpoint that does not fit (room for the rows, not the checkpoint).
        fill(120 * 1024)
        p = r.run(["resume", str(run), "--set", "run.steps=1200"], expect=None)
        lines = p.stderr.strip().splitlines()
        assert p.returncode == 2 and len(lines) == 1 and "No space left on device" in lines[0], \
            (p.returncode, p.stderr)
        assert not list(run.glob("*.tmp")), list(run.glob("*.tmp"))
        assert (run / "checkpoint.h5").read_bytes() == kept
        s = summary(run)
        assert s["status"] == "failed" and "No space left on device" in s["error"], s.get("error")
        print(f"ok: full disk: {lines[0][:150]}")
        filler.unlink()
        r.run(["resume", str(run), "--set", "run.steps=1200"])
        assert summary(run)["state_checksum"] == target
        print("ok: with room again the run resumes to the uninterrupted state")
    finally:
        subprocess.run(["umount", str(mount)], check=False)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("mode", choices=["resume", "signals", "hostile"])
    ap.add_argument("hardrod")
    ap.add_argument("source")
    ap.add_argument("--mpirun", default=shutil.which("mpirun"))
    ap.add_argument("--keep", action="store_true")
    a = ap.parse_args()
    work = tempfile.mkdtemp(prefix=f"hardrod-checkpoint-{a.mode}-")
    try:
        r = Runner(a.hardrod, a.source, a.mpirun, work)
        {"resume": mode_resume, "signals": mode_signals, "hostile": mode_hostile}[a.mode](r)
    finally:
        if not a.keep:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
