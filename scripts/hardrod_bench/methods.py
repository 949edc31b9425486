"""`scripts/bench methods`: the exact method against the midpoint method from the same states.

Runs: for each velocity seed, one exact run (dt 1e-3) of the paper's scene (N = 18432) from the
aligned lattice for --equil-tau (default 600 tau), its last frame written; then, from each
seed's last frame, one run per variant (--variants, default exact:1e-3,exact:2e-3,midpoint:1e-4)
of --prod-tau (default 100 tau), S and P* sampled every 0.02 tau, checkpoints every 10 tau. Two
runs at a time (one thread each) on two cores. Rerunning the command skips finished runs and
resumes interrupted ones from their checkpoints.

Analysis: each run's S and P* (summary.json's block averages over the whole run); per variant
the mean over the seeds with its error (the runs' errors carried, or the seeds' spread where
that is larger); the difference from the first variant, seed by seed
(the same start), with its verdict (within 2 sigma: agree); the seeds' P*-S relation, a
weighted line through every run's (S, P*); and with it the difference in P* at equal S. Writes methods.json and methods.md in --out.
"""

import json
import math
import os
import shlex
import sys
from dataclasses import dataclass, field
from pathlib import Path

from .common import HARDROD, ROOT, markdown_table, report_header, write_json, write_text
from .outputs import est, load_json
from . import paper
from .stats import linear_fit

SCENE = "scenes/paper.toml"
EQUIL_DT = 1e-3
DEFAULT_VARIANTS = "exact:1e-3,exact:2e-3,midpoint:1e-4"


@dataclass
class MethodRun:
    """One `hardrod run`, started or resumed as `scripts/bench paper`'s runs are."""
    kind: str          # "equilibration" or a variant's label
    seed: int
    out: Path
    method: str
    dt: float
    tau: float
    start: Path = None  # an H5MD trajectory whose last frame starts the run (None: the lattice)
    n: int = 18432
    extra: dict = field(default_factory=dict)

    @property
    def name(self):
        return f"seed{self.seed}/{self.kind}"

    @property
    def log(self):
        return self.out.parent / f"{self.out.name}.log"

    def steps(self, tau):
        return int(round(tau / self.dt))

    def sets(self):
        sets = {"init.seed": self.seed, "run.method": f'"{self.method}"', "run.dt": f"{self.dt:g}",
                "run.equilibration_steps": 0, "run.steps": self.steps(self.tau),
                "run.sample_interval": self.steps(paper.SAMPLE_TAU),
                "output.checkpoint_interval": self.steps(paper.CHECKPOINT_TAU), **self.extra}
        if self.start is not None:
            sets.update({"init.configuration": '"file"', "init.file": json.dumps(str(self.start))})
        return sets

    def run_argv(self):
        return paper.run_argv(SCENE, self.sets(), self.out)

    def resume_argv(self):
        return paper.resume_argv(self.out)

    def state(self):
        return paper.run_state(self)

    def same_settings(self):
        return paper.logged_settings(self)

    def cost(self):
        """Steps, an exact step counted as ten midpoint ones (about their ratio at N = 18432): the
        longest runs start first."""
        return self.tau / self.dt if self.method == "midpoint" else 10.0 * self.tau / self.dt


def parse_variants(text):
    """'method:dt,...' -> [(label, method, dt)]; ValueError on a bad entry."""
    out = []
    for item in str(text).split(","):
        method, _, dt = item.strip().partition(":")
        if method not in ("midpoint", "exact") or not dt:
            raise ValueError(item)
        value = float(dt)
        if not value > 0.0:
            raise ValueError(item)
        out.append((f"{method}-{value:g}", method, value))
    if not out or len({label for label, _, _ in out}) != len(out):
        raise ValueError(text)
    return out


def plan(args):
    """The equilibration runs, then the variants' runs (each from its seed's equilibrated frame)."""
    root = Path(args.out).resolve()
    equil, variants = [], []
    for seed in range(1, args.seeds + 1):
        e = MethodRun("equilibration", seed, root / f"seed{seed}" / "equilibration", "exact", EQUIL_DT,
                      args.equil_tau, extra={"output.snapshot_interval": int(round(args.equil_tau / EQUIL_DT))})
        equil.append(e)
        for label, method, dt in args.variants:
            variants.append(MethodRun(label, seed, root / f"seed{seed}" / label, method, dt, args.prod_tau,
                                      start=e.out / "trajectory.h5"))
    return equil, variants


def run_estimates(run):
    """(S, P*) estimates of one finished run: (mean, error) each, or None."""
    summary = load_json(run.out / "summary.json")
    if not summary or summary.get("status") != "completed":
        return None
    s, s_err, _ = est(summary, "order_parameter")
    p, p_err, _ = est(summary, "pressure_star")
    if s is None or p is None or s_err is None or p_err is None:
        return None
    return {"S": [s, s_err], "P": [p, p_err]}


def mean_of(values):
    """The mean of (mean, error) pairs and its error: the errors carried (independent), or the
    standard error of the values' spread where that is larger (from three values on). A run's
    block errors cannot see the director's slow modes, which move S and P* over hundreds of
    tau; the spread over seeds does."""
    n = len(values)
    mean = sum(v for v, _ in values) / n
    carried = math.sqrt(sum(e * e for _, e in values)) / n
    if n < 3:
        return [mean, carried]
    spread = math.sqrt(sum((v - mean) ** 2 for v, _ in values) / (n - 1) / n)
    return [mean, max(carried, spread)]


def compare(by_seed, labels, sigmas=2.0):
    """Per variant: S and P* over the seeds, and the difference from labels[0] seed by seed with
    its verdict. by_seed: seed -> label -> run_estimates. Only seeds with every variant count."""
    seeds = sorted(s for s, runs in by_seed.items() if all(runs.get(l) for l in labels))
    out = {"seeds": seeds, "variants": {}}
    if not seeds:
        return out
    ref = labels[0]
    for label in labels:
        row = {q: mean_of([by_seed[s][label][q] for s in seeds]) for q in ("S", "P")}
        if label != ref:
            for q in ("S", "P"):
                d = mean_of([[by_seed[s][label][q][0] - by_seed[s][ref][q][0],
                              math.hypot(by_seed[s][label][q][1], by_seed[s][ref][q][1])] for s in seeds])
                row[f"{q}_minus_{ref}"] = d
                row[f"{q}_agrees"] = abs(d[0]) <= sigmas * d[1]
        out["variants"][label] = row
    points = [(by_seed[s][l]["S"][0], by_seed[s][l]["P"][0], by_seed[s][l]["P"][1])
              for s in seeds for l in labels]
    if len(points) >= 3 and len({round(x, 12) for x, _, _ in points}) > 1:
        a, b, cov, chi2, dof = linear_fit(points)
        slope = [b, math.sqrt(cov[1][1])]
        out["p_s_relation"] = {"slope": slope, "intercept": a, "chi2": chi2, "dof": dof, "runs": len(points)}
        # A run's P* follows its S (the director's slow modes set both): the difference in P* at
        # the reference's S, dP - slope dS, with the slope's error carried.
        for label in labels[1:]:
            row = out["variants"][label]
            (dp, dp_err), (ds, ds_err) = row[f"P_minus_{ref}"], row[f"S_minus_{ref}"]
            err = math.sqrt(dp_err ** 2 + (slope[0] * ds_err) ** 2 + (ds * slope[1]) ** 2)
            row[f"P_at_equal_S_minus_{ref}"] = [dp - slope[0] * ds, err]
            row["P_at_equal_S_agrees"] = abs(dp - slope[0] * ds) <= sigmas * err
    return out


def report(args, equil, variants):
    labels = [label for label, _, _ in args.variants]
    by_seed = {}
    for r in variants:
        by_seed.setdefault(r.seed, {})[r.kind] = run_estimates(r)
    result = compare(by_seed, labels)
    result.update({"n": 18432, "equilibration_tau": args.equil_tau, "production_tau": args.prod_tau,
                   "equilibration": {"method": "exact", "dt": EQUIL_DT},
                   "runs": {str(s): runs for s, runs in sorted(by_seed.items())}})
    out = Path(args.out)
    write_json(out / "methods.json", result)
    rows = []
    for label in labels:
        v = result["variants"].get(label)
        if not v:
            continue
        cell = lambda q: f"{v[q][0]:.4f} +/- {v[q][1]:.4f}"  # noqa: E731
        diff = lambda q: (f"{v[q + '_minus_' + labels[0]][0]:+.4f} +/- {v[q + '_minus_' + labels[0]][1]:.4f} "  # noqa: E731
                          f"({'agrees' if v[q + '_agrees'] else 'differs'})") if label != labels[0] else "-"
        at_s = v.get(f"P_at_equal_S_minus_{labels[0]}")
        rows.append([label, cell("S"), cell("P"), diff("S"), diff("P"),
                     f"{at_s[0]:+.4f} +/- {at_s[1]:.4f} ({'agrees' if v['P_at_equal_S_agrees'] else 'differs'})"
                     if at_s else "-"])
    text = report_header("The exact method against the midpoint method from the same states")
    text += (f"N = 18432, {len(result['seeds'])} seeds, each equilibrated {args.equil_tau:g} tau (exact, dt "
             f"{EQUIL_DT:g}) from the aligned lattice, then {args.prod_tau:g} tau per variant from that state.\n\n")
    text += markdown_table(["variant", "S", "P*", f"S - {labels[0]}", f"P* - {labels[0]}",
                            f"P* - {labels[0]} at equal S"], rows) + "\n"
    rel = result.get("p_s_relation")
    if rel:
        text += (f"\nThe runs' P*-S relation: dP*/dS = {rel['slope'][0]:.2f} +/- {rel['slope'][1]:.2f} "
                 f"(chi2 {rel['chi2']:.1f} for {rel['dof']} dof, {rel['runs']} runs)\n")
    write_text(out / "methods.md", text)
    print(text)
    print(f"bench methods: {out}/methods.json, methods.md")
    return 0


HELP = "the exact method against the midpoint method from the same equilibrated N = 18432 states"
DESCRIPTION = __doc__


def add_arguments(sp):
    sp.add_argument("--dry-run", action="store_true", help="print one hardrod command per run, run nothing")
    sp.add_argument("--out", default=str(ROOT / "results" / "methods"),
                    help="where the runs and methods.json/md go (default results/methods; rerun to continue)")
    sp.add_argument("--seeds", type=int, default=6, help="velocity seeds (default 6)")
    sp.add_argument("--variants", default=DEFAULT_VARIANTS,
                    help=f"method:dt list, the first the reference (default {DEFAULT_VARIANTS})")
    sp.add_argument("--equil-tau", type=float, default=600.0, help="equilibration from the lattice, tau (default 600)")
    sp.add_argument("--prod-tau", type=float, default=100.0, help="each variant's run, tau (default 100)")
    sp.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="runs at a time (default: cores)")
    sp.add_argument("--analyze-only", action="store_true", help="do not run; analyse the finished runs")


def main(args):
    try:
        args.variants = parse_variants(args.variants)
    except ValueError as e:
        print(f"bench methods: --variants: {e} is not method:dt (method midpoint or exact, dt > 0), "
              "each once", file=sys.stderr)
        return 2
    for key in ("seeds", "equil_tau", "prod_tau"):
        if not getattr(args, key) > 0:
            print(f"bench methods: --{key.replace('_', '-')} must be positive, got {getattr(args, key)}",
                  file=sys.stderr)
            return 2
    equil, variants = plan(args)
    if args.dry_run:
        print(f"(dry run) {len(equil) + len(variants)} runs, {args.jobs} at a time; the variants start from "
              "their seed's equilibrated frame; a finished run is skipped, an interrupted one resumes:")
        for r in equil + variants:
            print(("# done: " if r.state() == "done" else "") + shlex.join(r.run_argv()))
        return 0
    if not HARDROD.exists():
        print("bench methods: build/hardrod missing: run scripts/build first", file=sys.stderr)
        return 2
    if not args.analyze_only:
        for phase in (equil, variants):
            failed = paper.run_phase(args, phase, "methods")
            if failed:
                print(f"bench methods: {len(failed)} runs failed; rerun the command to retry them",
                      file=sys.stderr)
                return 1
    return report(args, equil, variants)
