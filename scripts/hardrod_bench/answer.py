"""`scripts/bench answer`: time to answer, from a fresh start to S and P* with target errors.

The everyday nematic from the aligned lattice and from a compressed isotropic state, sampled
from t = 0: the equilibration cut (MSER-5), the production after which both block errors
stay within the targets, the core-minutes to get there, and whether the two starts agree.
Writes answer.json, answer.md and answer.png; `--analyze` re-reads an earlier result.
"""

import math
from pathlib import Path

from .common import (DEFAULT_DT, HARDROD, NPROC, busy_warning, common_arguments, ensure_built, g, has_plotting, make_outdir,
                     markdown_table, pm, relpath, report_header, write_json, write_text)
from .outputs import load_json, production_t_s_p
from .runner import Result, Run, print_dry_run, run_all
from .stats import conservative_block_error, mser_cut

HELP = "time to answer: core-minutes to S and P* with target errors, from both sides"
DESCRIPTION = ("The everyday nematic (N = 2304, rho* = 0.5) from the aligned lattice and from a "
               "compressed isotropic state, sampled from t = 0; the equilibration cut by MSER-5, "
               "the production needed for the target errors, the core-minutes to get there, "
               "and whether the two starts agree. Writes answer.json, answer.md, answer.png. "
               "Exit 1 if they disagree.")


def add_arguments(an):
    common_arguments(an)
    an.add_argument("--tau", type=float, default=400.0, help="simulated time per run (default 400 tau)")
    an.add_argument("--method", default="midpoint", choices=["midpoint", "exact"],
                    help="run.method (default midpoint, the paper's; exact: no dt bias)")
    an.add_argument("--dt", type=float, default=None,
                    help="time step (default 1e-4 for the midpoint method, 1e-3 for the exact method)")
    an.add_argument("--sample-interval", type=int, default=None,
                    help="steps per sample (default: every 0.1 tau, 1000 steps at dt 1e-4)")
    an.add_argument("--s-error", type=float, default=0.002, help="target error of S (default 0.002)")
    an.add_argument("--p-error", type=float, default=0.02, help="target error of P* (default 0.02)")
    an.add_argument("--analyze", default="", metavar="RESULTS_DIR",
                    help="analyse the runs of an earlier `bench answer` (e.g. after extending them with "
                         "`hardrod resume DIR/runs/NAME --set run.steps=N`) instead of running")


def time_to_answer(run_dir, summary, s_target, p_target, threads):
    """From a run that samples S and P* from t = 0: the equilibration cut (MSER-5 on S and P*), the
    shortest production after it from which on both block errors stay within the targets, and
    the core-minutes to get there (steps at the run's measured cost, plus its set-up)."""
    t, S, P = production_t_s_p(run_dir)
    n = len(S)
    cut = max(mser_cut(S), mser_cut(P))
    found = None
    alone = {"S": None, "P": None}  # each quantity on its own
    for length in range(16, n - cut + 1, max(1, (n - cut) // 200)):
        eS = conservative_block_error(S[cut:cut + length])
        eP = conservative_block_error(P[cut:cut + length])
        okS = eS is not None and eS <= s_target
        okP = eP is not None and eP <= p_target
        for key, ok in (("S", okS), ("P", okP)):
            if ok and alone[key] is None:
                alone[key] = length
            elif not ok:
                alone[key] = None  # must hold from there on
        if okS and okP and found is None:
            found = (length, eS, eP)
        elif not (okS and okP):
            found = None
    steps = summary["steps_done"]
    # All segments of a run continued with `hardrod resume` (wall_seconds is the last one's).
    wall = summary.get("wall_seconds_total", summary["wall_seconds"])
    threads = summary.get("threads", threads)
    core_s_per_step = wall * threads / steps
    sample_steps = steps / n if n else 0
    setup = summary.get("setup_seconds_total", summary.get("setup_seconds", 0.0)) * threads
    out = {"samples": n, "tau_per_sample": t[0] if t else None, "cut_samples": cut,
           "cut_tau": t[cut - 1] if cut else 0.0, "core_seconds_per_step": core_s_per_step,
           "setup_core_seconds": setup}
    rest_S, rest_P = S[cut:], P[cut:]
    out["S"] = {"mean": sum(rest_S) / len(rest_S), "error": conservative_block_error(rest_S), "samples": len(rest_S)}
    out["P"] = {"mean": sum(rest_P) / len(rest_P), "error": conservative_block_error(rest_P), "samples": len(rest_P)}
    for key, length in alone.items():
        if length:
            k = cut + length
            out[f"{key}_alone_tau"] = t[k - 1]
            out[f"{key}_alone_core_minutes"] = (k * sample_steps * core_s_per_step + setup) / 60.0
    # A target not reached: the production it would take if the error kept falling as
    # 1/sqrt(length) from the whole run's value (an extrapolation, labelled as such).
    for key, rest, target in (("S", rest_S, s_target), ("P", rest_P, p_target)):
        e = out[key]["error"]
        if not alone[key] and e and e > target:
            length = len(rest) * (e / target) ** 2
            out[f"{key}_extrapolated_tau"] = (cut + length) * (t[0] if t else 0.0)
            out[f"{key}_extrapolated_core_minutes"] = ((cut + length) * sample_steps * core_s_per_step
                                                       + setup) / 60.0
    if found:
        length, eS, eP = found
        k = cut + length
        out.update({"answer_samples": k, "answer_tau": t[k - 1],
                    "answer_core_minutes": (k * sample_steps * core_s_per_step + setup) / 60.0,
                    "S_at_answer": {"mean": sum(S[cut:k]) / length, "error": eS},
                    "P_at_answer": {"mean": sum(P[cut:k]) / length, "error": eP}})
    return out, (t, S, P)


def main(args):
    """Time to answer: core-minutes from a fresh start to S and P* with target errors, from both
    sides (the aligned lattice and a compressed isotropic state), and whether the two agree."""
    if args.analyze:  # the runs of an earlier `bench answer`, possibly continued with resume
        out = Path(args.analyze).resolve()
        results = []
        for name in ("lattice", "isotropic"):
            d = out / "runs" / name
            summary = load_json(d / "summary.json")
            run = Run(name, "scenes/everyday.toml", {}, args.threads, d, meta={"start": name})
            rc = 0 if summary and summary.get("status") == "completed" else 2
            results.append(Result(run, rc, summary, (summary or {}).get("wall_seconds_total", 0.0),
                                  "" if summary else f"no summary.json in {relpath(d)}"))
        return answer_report(args, out, results)
    if args.dt is None:
        args.dt = DEFAULT_DT[args.method]
    if args.sample_interval is None:
        args.sample_interval = max(1, int(round(0.1 / args.dt)))
    out = make_outdir(args, "answer")
    steps = int(round(args.tau / args.dt))
    starts = [("lattice", {}), ("isotropic", {"init.configuration": '"isotropic"'})]
    runs = []
    for name, extra in starts:
        sets = {"run.dt": repr(args.dt), "run.equilibration_steps": "0", "run.steps": str(steps),
                "run.sample_interval": str(args.sample_interval), **extra,
                **({"run.method": '"exact"'} if args.method == "exact" else {})}
        if args.seed is not None:
            sets["init.seed"] = str(args.seed)
        runs.append(Run(f"{name}", "scenes/everyday.toml", sets, args.threads, out / "runs" / name,
                        {"OMP_WAIT_POLICY": "passive"}, meta={"start": name}))
    jobs = args.jobs or max(1, NPROC // args.threads)
    if args.dry_run:
        print_dry_run(runs, jobs)
        return 0
    ensure_built(args, [HARDROD])
    results = run_all(runs, jobs, "answer", reuse_dir=args.reuse)
    return answer_report(args, out, results)


def alone_text(a, key):
    if f"{key}_alone_core_minutes" in a:
        return g(a[f"{key}_alone_core_minutes"], 3)
    if f"{key}_extrapolated_core_minutes" in a:
        return f"not reached; ~{g(a[f'{key}_extrapolated_core_minutes'], 2)} extrapolated"
    return "not reached"


def answer_report(args, out, results):
    rows, report, series = [], {}, {}
    for res in results:
        name = res.run.meta["start"]
        if not res.ok:
            rows.append([name, res.status(), res.error[:80]] + [""] * 9)
            report[name] = {"status": res.status(), "error": res.error}
            continue
        a, ser = time_to_answer(res.run.out, res.summary, args.s_error, args.p_error, args.threads)
        series[name] = (ser, a)
        report[name] = a
        rows.append([name, g(a["cut_tau"], 4), pm(a["S"]["mean"], a["S"]["error"]),
                     pm(a["P"]["mean"], a["P"]["error"]), a["S"]["samples"],
                     g(a.get("answer_tau"), 4) if "answer_tau" in a else "not reached",
                     g(a.get("answer_core_minutes"), 3) if "answer_core_minutes" in a else "-",
                     alone_text(a, "P"), alone_text(a, "S"),
                     g(a["setup_core_seconds"], 3), g(1e9 * a["core_seconds_per_step"] / 2304, 3)])
    agree = None
    if all(k in series for k in ("lattice", "isotropic")):
        la, iso = report["lattice"], report["isotropic"]
        dS = iso["S"]["mean"] - la["S"]["mean"]
        dP = iso["P"]["mean"] - la["P"]["mean"]
        eS = math.hypot(la["S"]["error"] or 0, iso["S"]["error"] or 0)
        eP = math.hypot(la["P"]["error"] or 0, iso["P"]["error"] or 0)
        agree = {"dS": dS, "dS_error": eS, "dP": dP, "dP_error": eP,
                 "agree": abs(dS) <= 2 * eS and abs(dP) <= 2 * eP}
        report["agreement"] = agree
    report["targets"] = {"S_error": args.s_error, "P_error": args.p_error}
    write_json(out / "answer.json", report)
    table = markdown_table(["start", "equilibration cut (tau)", "S after cut", "P* after cut", "samples",
                            "both targets at (tau)", "core-minutes to both", "core-minutes to P* alone",
                            "core-minutes to S alone", "set-up core-s", "ns/particle-step"],
                           rows)
    text = report_header("Time to answer: S and P* at rho* = 0.5, N = 2304, from both sides")
    lengths = ", ".join(f"{r.run.meta['start']} {g(r.summary.get('simulated_time'), 4)} tau "
                        f"({r.summary.get('segments', 1)} segment(s))" for r in results if r.summary)
    text += (f"Targets: error of S <= {args.s_error}, of P* <= {args.p_error} (conservative block errors, "
             f"which must stay within the targets from the answer on). Equilibration cut: MSER-5 on the S and "
             f"P* series (the later of the two). Cost: the run's own wall time per step (all segments) x "
             f"threads, plus its set-up (the isotropic compression). A target not reached in the run is "
             f"extrapolated from the whole run's error, assuming it keeps falling as 1/sqrt(production "
             f"length): an estimate, not a measurement. Runs: {lengths}.\n\n")
    text += table + "\n"
    if agree:
        text += (f"\nThe two starts: S differs by {agree['dS']:+.4f} +/- {agree['dS_error']:.4f}, P* by "
                 f"{agree['dP']:+.4f} +/- {agree['dP_error']:.4f}: "
                 f"{'they agree (within 2 sigma)' if agree['agree'] else 'they DISAGREE: not converged'}.\n")
    warn = busy_warning([r.load_before for r in results])
    if warn:
        text += "\n" + warn + "\n"
    write_text(out / "answer.md", text)
    if series and has_plotting():
        plot_answer(series, out / "answer.png")
    print(text)
    print(f"bench answer: wrote {relpath(out)}")
    return 0 if agree and agree["agree"] else 1


def plot_answer(series, path):
    """S(t) and P*(t) of both starts with their cuts and answers."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    for name, ((t, S, P), a) in series.items():
        for ax, y in zip(axes, (S, P)):
            line, = ax.plot(t, y, lw=0.6, label=name)
            ax.axvline(a["cut_tau"], color=line.get_color(), ls=":", lw=1)
            if "answer_tau" in a:
                ax.axvline(a["answer_tau"], color=line.get_color(), ls="--", lw=1)
    axes[0].set_ylabel("S")
    axes[1].set_ylabel("P* (interval)")
    axes[1].set_xlabel("t / tau")
    axes[0].legend(title="start (dotted: cut, dashed: answer)", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
