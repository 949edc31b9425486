"""`scripts/bench paper`: the paper's Table 1 protocol as one resumable command.

Runs: for each system size (N = 18432, the paper's 8 x 48 x 48 lattice; N = 2304, the everyday
4 x 24 x 24 lattice) and each velocity seed, one `hardrod run` from the aligned lattice with
`run.equilibration_steps` for the equilibration and `run.steps` of production, S and P* sampled
every 0.02 tau from t = 0, the Fourier order tensor every 0.02 tau in production (--fourier-tau),
checkpoints every 10 tau. Two runs at a time (one thread each) on two cores. Rerunning the
command skips finished runs and resumes interrupted ones from their checkpoints.

Analysis: `hardrod analyze` over the seeds of each size (S, P*, Frank constants with their
errors and chi^2 per fit), the equilibration judged from S (see `equilibration_verdict`), then
table1.md / table1.json beside the paper's and the literature rows, and the figures.
"""

import os
import shlex
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path

from .common import DEFAULT_DT, HARDROD, ROOT
from .outputs import load_json

# The two systems of the paper's finite-size study that fit on a workstation. kmax reaches the
# cubic fit's range (k1^2 <= 2, k3^2 <= 1 D^-2) in each box; production is longer in the small
# box, which has 8x fewer modes per bin and costs 8x less per tau.
SIZES = {
    18432: {"scene": "scenes/paper.toml", "kmax": 10, "prod_tau": 60.0},
    2304: {"scene": "scenes/everyday.toml", "kmax": 6, "prod_tau": 240.0},
}
CHECKPOINT_TAU = 10.0
SAMPLE_TAU = 0.02


@dataclass
class PaperRun:
    n: int
    seed: int
    out: Path
    dt: float
    equil_tau: float
    prod_tau: float
    kmax: int
    scene: str
    method: str = "midpoint"
    fourier_tau: float = SAMPLE_TAU

    @property
    def name(self):
        return f"n{self.n}/seed{self.seed}"

    def steps(self, tau):
        return int(round(tau / self.dt))

    def sets(self):
        every = self.steps(SAMPLE_TAU)
        return {"init.seed": self.seed, "run.dt": f"{self.dt:g}",
                "run.equilibration_steps": self.steps(self.equil_tau),
                "run.steps": self.steps(self.prod_tau), "run.sample_interval": every,
                "observables.frank": "true", "observables.fourier_kmax": self.kmax,
                "observables.fourier_interval": self.steps(self.fourier_tau),
                "output.checkpoint_interval": self.steps(CHECKPOINT_TAU),
                **({"run.method": '"exact"'} if self.method == "exact" else {})}

    def run_argv(self):
        return run_argv(self.scene, self.sets(), self.out)

    def resume_argv(self):
        return resume_argv(self.out)

    @property
    def log(self):
        return self.out.parent / f"seed{self.seed}.log"

    def state(self):
        return run_state(self)

    def same_settings(self):
        return logged_settings(self)

    def cost(self):
        return self.n * (self.equil_tau + self.prod_tau)


def run_argv(scene, sets, out):
    """One thread, unbound, quiet: the harnesses' long runs, two at a time on two cores."""
    argv = [str(HARDROD.relative_to(ROOT)), "run", scene]
    for k, v in sets.items():
        argv += ["--set", f"{k}={v}"]
    return argv + ["--out", str(out), "--force", "--threads", "1", "--no-bind", "--quiet"]


def resume_argv(out):
    return [str(HARDROD.relative_to(ROOT)), "resume", str(out), "--threads", "1", "--no-bind", "--quiet"]


def run_state(run):
    """'done', 'resume' (a checkpoint of these settings exists) or 'start', for a run with `out`,
    `log` and `run_argv()` (this module's runs and `scripts/bench methods`')."""
    summary = load_json(run.out / "summary.json")
    if summary and summary.get("status") == "completed" and run.same_settings():
        return "done"
    if (run.out / "checkpoint.h5").exists() and run.same_settings():
        return "resume"
    return "start"


def logged_settings(run):
    """Whether the run's log opens with its `hardrod run` command: the same settings."""
    try:
        first = run.log.read_text(errors="replace").splitlines()[0]
    except (OSError, IndexError):
        return False
    return first == "$ " + shlex.join(run.run_argv())


def plan(args):
    runs = []
    for n in args.sizes:
        spec = SIZES[n]
        prod = args.prod_tau if args.prod_tau else spec["prod_tau"]
        for seed in range(1, args.seeds[n] + 1):
            runs.append(PaperRun(n, seed, Path(args.out).resolve() / f"n{n}" / f"seed{seed}", args.dt, args.equil_tau,
                                 prod, spec["kmax"], spec["scene"], args.method, args.fourier_tau))
    return runs


def execute(run):
    """One run to completion: start it, or resume it from its checkpoint. The log's first line is
    the `hardrod run` command (how a later invocation recognises the settings)."""
    log = run.log
    state = run.state()
    if state == "done":
        return run, 0, 0.0
    run.out.parent.mkdir(parents=True, exist_ok=True)
    start = time.monotonic()
    if state == "start":
        with open(log, "w") as f:
            f.write("$ " + shlex.join(run.run_argv()) + "\n")
        argv = run.run_argv()
    else:
        with open(log, "a") as f:
            f.write("$ " + shlex.join(run.resume_argv()) + "\n")
        argv = run.resume_argv()
    with open(log, "a") as f:
        rc = subprocess.run(argv, cwd=ROOT, stdout=f, stderr=subprocess.STDOUT).returncode
    return run, rc, time.monotonic() - start


def run_phase(args, runs, label="paper"):
    todo = [r for r in runs if r.state() != "done"]
    print(f"bench {label}: {len(runs)} runs, {len(runs) - len(todo)} finished, {len(todo)} to do, "
          f"{args.jobs} at a time", flush=True)
    failed = []
    t0 = time.monotonic()
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        futures = [pool.submit(execute, r) for r in sorted(todo, key=lambda r: -r.cost())]
        for i, fut in enumerate(as_completed(futures), 1):
            run, rc, wall = fut.result()
            status = "ok" if rc == 0 else f"exit {rc} (see {run.log})"
            print(f"  [{i}/{len(todo)}] {run.name:<16} {status:<12} {wall:7.0f} s "
                  f"(elapsed {time.monotonic() - t0:.0f} s)", flush=True)
            if rc != 0:
                failed.append(run)
    return failed


HELP = "the paper's Table 1 at N = 18432 and 2304: six seeds, S, P*, K1..K3, figures"
DESCRIPTION = __doc__


def add_arguments(sp):
    sp.add_argument("--dry-run", action="store_true", help="print one hardrod command per run, run nothing")
    sp.add_argument("--out", default=None,
                    help="where the runs, table1.md/json and figures go (default results/paper, with --method "
                         "exact results/paper-exact; rerun to continue)")
    sp.add_argument("--method", default="midpoint", choices=["midpoint", "exact"],
                    help="run.method (default midpoint, the paper's; exact: collisions at their exact times, "
                         "no dt bias, at dt 1e-3 about two thirds of the midpoint method's cost at 1e-4)")
    sp.add_argument("--sizes", default="18432,2304", help="comma list of N among 18432, 2304 (default both)")
    sp.add_argument("--seeds", default="6",
                    help="velocity seeds per size (default 6), or one count per --sizes entry (4,6)")
    sp.add_argument("--dt", type=float, default=None,
                    help="time step (default 1e-4 for the midpoint method, the trade-off harness's choice: P* "
                         "-0.22 %% against dt -> 0; 1e-3 for the exact method)")
    sp.add_argument("--equil-tau", type=float, default=150.0, help="equilibration, tau (default 150)")
    sp.add_argument("--prod-tau", type=float, default=0.0,
                    help="production, tau (default 60 at N = 18432, 240 at N = 2304)")
    sp.add_argument("--fourier-tau", type=float, default=SAMPLE_TAU,
                    help="Fourier samples every this many tau in production (default 0.02; one sample at N = 18432 "
                         "costs about as much as 20 exact steps, so long runs take 0.1)")
    sp.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="runs at a time (default: cores)")
    sp.add_argument("--analyze-only", action="store_true", help="do not run; analyse the finished runs")


def main(args):
    if args.dt is None:
        args.dt = DEFAULT_DT[args.method]
    if args.out is None:
        args.out = str(ROOT / "results" / ("paper-exact" if args.method == "exact" else "paper"))
    args.sizes = [int(s) for s in str(args.sizes).split(",") if s.strip()]
    bad = [n for n in args.sizes if n not in SIZES]
    if bad:
        print(f"bench paper: --sizes: {bad} not among {sorted(SIZES)}", file=sys.stderr)
        return 2
    try:
        counts = [int(c) for c in str(args.seeds).split(",")]
        if len(counts) == 1:
            counts *= len(args.sizes)
        if len(counts) != len(args.sizes) or min(counts) < 1:
            raise ValueError
    except ValueError:
        print(f"bench paper: --seeds {args.seeds!r}: one count >= 1, or one per --sizes entry "
              f"({len(args.sizes)})", file=sys.stderr)
        return 2
    args.seeds = dict(zip(args.sizes, counts))
    runs = plan(args)
    if args.dry_run:
        print(f"(dry run) {len(runs)} runs, {args.jobs} at a time; a finished run is skipped, an interrupted one "
              f"continues with `hardrod resume DIR --threads 1 --no-bind --quiet`:")
        for r in runs:
            print(("# done: " if r.state() == "done" else "") + shlex.join(r.run_argv()))
        return 0
    if not HARDROD.exists():
        print("bench paper: build/hardrod missing: run scripts/build first", file=sys.stderr)
        return 2
    if not args.analyze_only:
        failed = run_phase(args, runs)
        if failed:
            print(f"bench paper: {len(failed)} runs failed; rerun the command to retry them", file=sys.stderr)
            return 1
    from . import paper_report
    return paper_report.report(args, runs)
