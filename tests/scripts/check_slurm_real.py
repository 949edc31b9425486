#!/usr/bin/env python3
"""scripts/slurm/ on a real one-node Slurm: munged, slurmctld and slurmd started here, in a
temporary directory, on free ports, with their own key, socket, state, spool and logs.

- The sbatch template runs a scene on two ranks (srun, one core each) to the state checksum of
  the same run made outside Slurm on one rank.
- A run with a one-minute limit gets Slurm's SIGUSR1 (`--signal=B:USR1@...`), checkpoints,
  requeues itself and resumes, to the checksum of an uninterrupted run.
- scripts/slurm/sweep runs a job array over three seeds and `hardrod analyze` of them as a job
  that depends on the array; the analysis has three runs.

Exit 77 (skipped, with the reason) where the daemons cannot start: not root, no munged or Slurm
binaries, or a cluster that does not come up. Every daemon and job it started is stopped, by
process id, whatever happens, and the directory removed.

Usage: check_slurm_real.py HARDROD SOURCE_DIR
"""
import ctypes
import datetime
import json
import os
import pathlib
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time

SKIP = 77
DEADLINE_S = 480  # below the ctest TIMEOUT, so that the clean-up always runs
FINAL_STATES = {"COMPLETED", "FAILED", "CANCELLED", "TIMEOUT", "NODE_FAIL", "PREEMPTED",
                "BOOT_FAIL", "DEADLINE", "OUT_OF_MEMORY"}
# slurmctld checks time limits (and sends --signal) every 30 s from its start; at debug2 it
# logs each check.
TICK = "Testing job time limits"
CONTROLLER_UP = "Running as primary controller"
TICK_PERIOD_S = 30
SIGNAL_SETS = ["run.equilibration_steps=0", "run.steps=40000", "run.sample_interval=1000"]
REFERENCES = []  # the runs outside Slurm, ended with the cluster


class Failed(Exception):
    pass


class Skipped(Exception):
    pass


class Stop(Exception):
    """SIGTERM, SIGINT or the deadline: unwind so that the daemons are stopped."""


def stop_on_signal(signum, _frame):
    raise Stop(f"stopped by signal {signum}")


def die_with_parent():
    """In a daemon's child before exec: SIGTERM to it when this script dies, even by SIGKILL."""
    ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def run(cmd, env, check=True, timeout=60, cwd=None):
    r = subprocess.run([str(c) for c in cmd], env=env, cwd=cwd, capture_output=True, text=True,
                       timeout=timeout)
    if check and r.returncode != 0:
        raise Failed(f"{' '.join(map(str, cmd))} exited {r.returncode}\n{r.stdout}{r.stderr}")
    return r


class Cluster:
    """One node, one partition; every path inside `root`, every client pointed at it by
    SLURM_CONF."""

    def __init__(self, root):
        self.root = root
        self.node = socket.gethostname().split(".")[0]
        self.conf = root / "slurm.conf"
        self.munge_socket = root / "munge/socket"
        self.ctld_log = root / "log/slurmctld.log"
        self.daemons = []  # (name, Popen), in start order
        self.env = {k: v for k, v in os.environ.items() if not k.startswith("SLURM_")}
        self.env["SLURM_CONF"] = str(self.conf)

    def start(self):
        for d in ("munge", "state", "spool", "log"):
            (self.root / d).mkdir()
        # munged wants its key private and every directory above its socket searchable.
        self.root.chmod(0o755)
        (self.root / "munge").chmod(0o755)
        key = self.root / "munge/munge.key"
        key.write_bytes(os.urandom(1024))
        key.chmod(0o600)
        m = self.root / "munge"
        self.spawn("munged", ["munged", "--foreground", f"--socket={self.munge_socket}",
                              f"--key-file={key}", f"--pid-file={m}/munged.pid",
                              f"--log-file={m}/munged.log", f"--seed-file={m}/munged.seed"])
        self.wait_for(lambda: self.munge_works(), 10, "munged did not answer on its socket")
        self.write_conf()
        self.spawn("slurmctld", ["slurmctld", "-D", "-f", self.conf])
        self.spawn("slurmd", ["slurmd", "-D", "-f", self.conf, "-N", self.node])
        self.wait_for(lambda: self.node_state() == "idle", 30, "the node did not become idle")

    def spawn(self, name, cmd):
        log = open(self.root / f"log/{name}.out", "w")
        p = subprocess.Popen([str(c) for c in cmd], env=self.env, stdout=log,
                             stderr=subprocess.STDOUT, preexec_fn=die_with_parent)
        log.close()
        self.daemons.append((name, p))

    def wait_for(self, ready, timeout, what):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for name, p in self.daemons:
                if p.poll() is not None:
                    raise Skipped(f"{name} exited {p.returncode} at start:\n{self.log_tail(name)}")
            if ready():
                return
            time.sleep(0.2)
        raise Skipped(f"{what} within {timeout} s:\n"
                      + "\n".join(self.log_tail(n) for n, _ in self.daemons))

    def log_tail(self, name, lines=15):
        path = self.root / f"log/{name}.out"
        text = path.read_text(errors="replace").splitlines() if path.exists() else []
        return f"--- {name}\n" + "\n".join(text[-lines:])

    def munge_works(self):
        sock = f"--socket={self.munge_socket}"
        if not self.munge_socket.exists():
            return False
        cred = subprocess.run(["munge", sock, "--no-input"], capture_output=True, text=True)
        return cred.returncode == 0 and subprocess.run(
            ["unmunge", sock], input=cred.stdout, capture_output=True, text=True).returncode == 0

    def node_state(self):
        r = subprocess.run(["sinfo", "-h", "-n", self.node, "-o", "%T"], env=self.env,
                           capture_output=True, text=True)
        return r.stdout.strip() if r.returncode == 0 else ""

    def write_conf(self):
        # The node as slurmd sees it (CPUs, sockets, cores, threads, memory), under our name.
        hw = subprocess.run(["slurmd", "-C"], capture_output=True, text=True).stdout
        line = next((ln for ln in hw.splitlines() if ln.startswith("NodeName=")), "")
        if not line:
            raise Skipped(f"slurmd -C printed no NodeName line:\n{hw}")
        hw_fields = " ".join(f for f in line.split()[1:] if not f.startswith("UpTime"))
        self.cpus = int(re.search(r"CPUs=(\d+)", line).group(1))
        r = self.root
        (r / "plugstack.conf").write_text("")  # none of the system's SPANK plugins
        self.conf.write_text(f"""\
ClusterName=hardrodtest
SlurmctldHost={self.node}(127.0.0.1)
SlurmctldPort={free_port()}
SlurmdPort={free_port()}
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
# cred_expire also holds a requeued job back before it may start again (default 120 s).
AuthInfo=socket={self.munge_socket},cred_expire=5
StateSaveLocation={r}/state
SlurmdSpoolDir={r}/spool
SlurmctldPidFile={r}/slurmctld.pid
SlurmdPidFile={r}/slurmd.pid
SlurmctldLogFile={self.ctld_log}
SlurmdLogFile={r}/log/slurmd.log
SlurmctldDebug=debug2
SlurmdDebug=info
PlugStackConfig={r}/plugstack.conf
ProctrackType=proctrack/linuxproc
TaskPlugin=task/affinity
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
# Start a job as soon as it may (a requeued one, one whose dependency is met), not a minute on.
SchedulerParameters=sched_interval=2,bf_interval=2
MpiDefault=none
JobRequeue=1
ReturnToService=2
# Finished jobs stay listed, for their state, until the cluster is taken down.
MinJobAge=600
KillWait=5
InactiveLimit=0
NodeName={self.node} NodeAddr=127.0.0.1 {hw_fields}
PartitionName=test Nodes={self.node} Default=YES MaxTime=INFINITE State=UP
""")

    def jobs(self, job):
        """The records of a job (every task of an array) as dicts of scontrol's fields."""
        out = run(["scontrol", "-o", "show", "job", job], self.env).stdout
        return [dict(f.split("=", 1) for f in ln.split() if "=" in f)
                for ln in out.splitlines() if ln.strip()]

    def wait_jobs(self, job, timeout, what):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            records = self.jobs(job)
            for rec in records:
                if rec.get("Reason") == "DependencyNeverSatisfied":
                    raise Failed(f"{what}: job {rec['JobId']} waits on a dependency that failed")
            if records and all(rec["JobState"] in FINAL_STATES for rec in records):
                bad = [rec for rec in records if rec["JobState"] != "COMPLETED"
                       or rec["ExitCode"] != "0:0"]
                if bad:
                    raise Failed(f"{what}: " + "; ".join(
                        f"job {b['JobId']} {b['JobState']} exit {b['ExitCode']}" for b in bad))
                return records
            time.sleep(0.5)
        raise Failed(f"{what}: not done in {timeout} s: "
                     + "; ".join(f"{r['JobId']} {r['JobState']} {r.get('Reason')}"
                                 for r in self.jobs(job)))

    def ticks(self):
        """The times (epoch seconds) of slurmctld's start and its time-limit checks so far."""
        if not self.ctld_log.exists():
            return []
        times = []
        for ln in self.ctld_log.read_text(errors="replace").splitlines():
            if TICK in ln or CONTROLLER_UP in ln:
                stamp = ln[1:ln.index("]")]
                times.append(datetime.datetime.fromisoformat(stamp).timestamp())
        return times

    def cancel_jobs(self):
        ids = run(["squeue", "-h", "-o", "%A"], self.env, check=False, timeout=20).stdout.split()
        if not ids:
            return
        run(["scancel", *ids], self.env, check=False, timeout=20)
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and run(
                ["squeue", "-h", "-t", "running,completing", "-o", "%A"], self.env,
                check=False, timeout=20).stdout.strip():
            time.sleep(0.5)

    def stop(self):
        """Cancel every job, stop the daemons by pid, then end whatever they left running (the
        step daemons and job processes, known by our SLURM_CONF in their environment)."""
        try:
            if any(p.poll() is None for n, p in self.daemons if n == "slurmctld"):
                self.cancel_jobs()
        except (OSError, subprocess.TimeoutExpired):
            pass  # what is left is ended below
        for name, p in reversed(self.daemons):
            if p.poll() is None:
                p.terminate()
                try:
                    p.wait(timeout=15)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait()
        marker = f"SLURM_CONF={self.conf}".encode()
        for pid in [int(d) for d in os.listdir("/proc") if d.isdigit()]:
            if pid == os.getpid():
                continue
            try:
                environ = pathlib.Path(f"/proc/{pid}/environ").read_bytes()
            except OSError:
                continue
            if marker in environ.split(b"\0"):
                try:
                    os.kill(pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass


def preconditions():
    if os.geteuid() != 0:
        return "not root (the test cluster runs its daemons as root)"
    for tool in ("munged", "munge", "unmunge", "slurmctld", "slurmd", "sbatch", "scontrol",
                 "squeue", "sinfo", "srun", "scancel"):
        if shutil.which(tool) is None:
            return f"{tool} not found (Debian: munge, slurmctld, slurmd, slurm-client)"
    return None


def summary(run_dir):
    return json.loads((run_dir / "summary.json").read_text())


def finish(proc, out):
    """The checksum of a reference run, once it has ended."""
    text, _ = proc.communicate(timeout=300)
    if proc.returncode != 0:
        raise Failed(f"reference run {out} exited {proc.returncode}:\n{text}")
    return summary(out)["state_checksum"]


def sets_of(sets):
    return [w for s in sets for w in ("--set", s)]


class Checks:
    """The three checks, in the order that keeps the two cores busy but not oversubscribed."""

    def __init__(self, hardrod, source, tmp, cluster, started):
        self.hardrod, self.tmp, self.cluster, self.started = hardrod, tmp, cluster, started
        self.sbatch = source / "scripts/slurm/hardrod.sbatch"
        self.sweep = source / "scripts/slurm/sweep"
        self.scene = source / "scenes/default.toml"
        self.outside = {k: v for k, v in os.environ.items() if not k.startswith("SLURM_")}
        self.outside["OMP_NUM_THREADS"] = "1"
        # Open MPI's ranks under srun need Slurm's PMIx: where MpiDefault is not pmix, a job
        # asks for it so (README, cluster use). The cores are shared with the runs outside
        # Slurm and other work: a waiting rank gives its core away instead of spinning.
        self.env = dict(cluster.env, HARDROD=str(hardrod), SLURM_MPI_TYPE="pmix",
                        OMPI_MCA_mpi_yield_when_idle="1")

    def say(self, text):
        print(f"[{time.monotonic() - self.started:3.0f} s] {text}", flush=True)

    def reference(self, name, sets):
        """The same run outside Slurm, one rank, one thread, started in the background."""
        out = self.tmp / name
        cmd = [self.hardrod, "run", self.scene, "--out", out, "--threads", "1", "--quiet",
               *sets_of(sets)]
        p = subprocess.Popen([str(c) for c in cmd], env=self.outside, stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT, text=True)
        REFERENCES.append(p)
        return p, out

    def submit(self, options, args):
        out = run(["sbatch", "--parsable", *options, *args], self.env, cwd=self.tmp).stdout
        return out.strip().split(";")[0]

    def all(self):
        plain_sets = ["run.equilibration_steps=0", "run.steps=2000", "run.sample_interval=500"]
        ref_plain = self.reference("ref-plain", plain_sets)  # while the daemons start
        self.cluster.start()
        self.say(f"cluster: node {self.cluster.node} ({self.cluster.cpus} CPUs) idle")
        ranks = min(2, self.cluster.cpus)
        finish(*ref_plain)
        plain = self.submit([f"--ntasks-per-node={ranks}", "--cpus-per-task=1",
                             f"--output={self.tmp}/plain.out"],
                            [self.sbatch, self.scene, self.tmp / "plain", *sets_of(plain_sets)])
        self.check_plain(plain, ranks, ref_plain)
        # The signalled run first, for the core it must start on at once; the sweep's jobs
        # take the other core, beside the uninterrupted run.
        signalled = self.submit_signalled()
        array, analyze = self.submit_sweep()
        self.check_sweep(array, analyze)
        self.check_signalled(*signalled)

    def check_plain(self, job, ranks, ref):
        """The template as users submit it, on `ranks` ranks of one core each."""
        self.cluster.wait_jobs(job, 120, "the plain run")
        got = summary(self.tmp / "plain")
        want = finish(*ref)
        if got["status"] != "completed" or got["ranks"] != ranks or got["state_checksum"] != want:
            raise Failed(f"plain run: {got['status']} on {got['ranks']} ranks, checksum "
                         f"{got['state_checksum']}, outside Slurm {want}")
        text = (self.tmp / "plain.out").read_text()
        cores = set(re.findall(r"rank \d+: thread 0 -> PU \d+ \(core (\d+)\)", text))
        if ranks > 1 and len(cores) != ranks:
            raise Failed(f"plain run: {ranks} ranks not on {ranks} cores:\n{text[:3000]}")
        self.say(f"plain: {ranks} ranks under srun on cores {', '.join(sorted(cores))}, "
                 f"checksum {got['state_checksum']} = outside Slurm")

    def submit_sweep(self):
        """scripts/slurm/sweep over three seeds: a job array, then analyze after it."""
        r = run([self.sweep, self.scene, "init.seed", "1", "2", "3", "--out", self.tmp / "seeds",
                 "--sbatch", "--ntasks-per-node=1 --cpus-per-task=1", "--", "--quiet",
                 "--set", "run.equilibration_steps=0", "--set", "run.steps=2000",
                 "--set", "run.sample_interval=200"], self.env, cwd=self.tmp)
        array = re.search(r"job array (\d+)", r.stdout)
        analyze = re.search(r"Submitted batch job (\d+)", r.stdout)
        if not (array and analyze):
            raise Failed(f"sweep printed no job ids:\n{r.stdout}{r.stderr}")
        return array.group(1), analyze.group(1)

    def check_sweep(self, array, analyze):
        root = self.tmp / "seeds"
        tasks = self.cluster.wait_jobs(array, 120, "the sweep's job array")
        self.cluster.wait_jobs(analyze, 60, "the sweep's analysis")
        seeds = [summary(root / f"seed-{s}")["seed"] for s in (1, 2, 3)]
        runs = json.loads((root / "analysis.json").read_text())["runs"]
        if len(tasks) != 3 or seeds != [1, 2, 3] or runs != 3:
            raise Failed(f"sweep: {len(tasks)} tasks, seeds {seeds}, analysis of {runs} runs")
        self.say(f"sweep: job array {array} over seeds 1 2 3, then analysis job {analyze} of "
                 f"{runs} runs")

    def submit_signalled(self):
        """Signalled before the limit: checkpoint, requeue, resume, the uninterrupted state.
        Slurm sends --signal at the first of its time-limit checks (every 30 s) that finds it
        due within 30 s: with --time=1 and @50, the first check after the start. Submitting
        ~20 s after a check puts the signal ~10 s into the run, which lasts ~20 s on one core.
        The resumed job has a limit of 1 min too, and may be signalled and resume again."""
        deadline = time.time() + TICK_PERIOD_S + 15
        while not (ticks := self.cluster.ticks()) or time.time() > ticks[-1] + TICK_PERIOD_S - 12:
            if time.time() > deadline:
                raise Failed(f"slurmctld logged no time-limit check ('{TICK}')")
            time.sleep(0.2)
        time.sleep(max(0.0, ticks[-1] + TICK_PERIOD_S - 10 - time.time()))
        ref = self.reference("ref-signal", SIGNAL_SETS)
        job = self.submit(["--ntasks-per-node=1", "--cpus-per-task=1", "--time=1",
                           "--signal=B:USR1@50", f"--output={self.tmp}/signal.out"],
                          [self.sbatch, self.scene, self.tmp / "signal", "--quiet",
                           *sets_of(SIGNAL_SETS)])
        self.say(f"signal: job {job} submitted, about 10 s before slurmctld's next time-limit "
                 "check")
        return job, ref

    def check_signalled(self, job, ref):
        (rec,) = self.cluster.wait_jobs(job, 240, "the signalled run")
        got = summary(self.tmp / "signal")
        want = finish(*ref)
        text = (self.tmp / "signal.out").read_text()
        stopped = re.search(r"stopped by SIGUSR1 at step (\d+)", text)
        if int(rec["Restarts"]) < 1 or got["segments"] < 2 or not stopped \
                or "requeueing job" not in text:
            raise Failed(f"signalled run: {rec['Restarts']} restarts, {got['segments']} "
                         f"segments:\n{text}")
        if got["status"] != "completed" or got["state_checksum"] != want:
            raise Failed(f"signalled run: {got['status']}, checksum {got['state_checksum']}, "
                         f"uninterrupted {want}")
        self.say(f"signal: SIGUSR1 from Slurm at step {stopped.group(1)} of {got['steps']}, "
                 f"checkpoint, {rec['Restarts']} requeue(s), {got['segments']} segments, "
                 f"checksum {got['state_checksum']} = uninterrupted")


def main():
    hardrod = pathlib.Path(sys.argv[1]).resolve()
    source = pathlib.Path(sys.argv[2]).resolve()
    reason = preconditions()
    if reason:
        print(f"SKIPPED: {reason}")
        return SKIP
    for s in (signal.SIGTERM, signal.SIGINT, signal.SIGALRM):
        signal.signal(s, stop_on_signal)
    signal.alarm(DEADLINE_S)
    started = time.monotonic()
    tmp = pathlib.Path(tempfile.mkdtemp(prefix="hardrod-slurm-real-"))
    cluster = Cluster(tmp)
    try:
        Checks(hardrod, source, tmp, cluster, started).all()
        print(f"all checks passed in {time.monotonic() - started:.0f} s")
        return 0
    except Skipped as e:
        print(f"SKIPPED: the test cluster did not start: {e}")
        return SKIP
    except (Failed, Stop, subprocess.TimeoutExpired) as e:
        print(f"FAILED: {e}")
        for name in ("slurmctld", "slurmd"):
            print(cluster.log_tail(name, 25))
        return 1
    finally:
        signal.alarm(0)
        for s in (signal.SIGTERM, signal.SIGINT):
            signal.signal(s, signal.SIG_IGN)  # a second signal must not cut the clean-up short
        cluster.stop()
        for p in REFERENCES:
            if p.poll() is None:
                p.kill()
                p.wait()
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
