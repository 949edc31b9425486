"""`scripts/bench validate`: the physics against its references, with a verdict per quantity.

Hard spheres against Carnahan-Starling, the L/D = 5 isotropic state against the random-axes
bound on S, the nematic against the paper's S and P* (docs/physics.md section 8); a short
version for the test suite and a long one. Each quantity is judged on the program's block
error and the harness's drift check (PASS, FAIL, NOT CONVERGED, INCONCLUSIVE); the report is
validation.json and validation.md. It runs hardrod; it does not re-average what hardrod
averaged.
"""

import datetime
import math

from .common import (HARDROD, NPROC, common_arguments, ensure_built, g, invocation, machine_info, make_outdir,
                     markdown_table, pm, relpath, report_header, write_json, write_text)
from .outputs import est, production_series
from .references import ISO_S_LIMIT, NEMATIC_P_REF, NEMATIC_S_REF, carnahan_starling
from .runner import Run, print_dry_run, run_all
from .stats import drift_check

HELP = "physics against docs/physics.md section 8, pass/fail (exit 1 on failure)"
DESCRIPTION = ("Hard spheres (eta 0.30, 0.45) against Carnahan-Starling (0.5 %), L/D = 5 "
               "isotropic at rho* = 0.3 (S < 3/sqrt(N)) and nematic at rho* = 0.5 (S = 0.73 "
               "+/- 0.02, P* within 2 % of 6.0). Short version: a few minutes on 2 cores; "
               "its nematic is too short to relax from the lattice and says NOT CONVERGED. "
               "Writes validation.json and validation.md. Exit 1 if a case fails (with --long "
               "or --strict also if one is not converged or inconclusive).")


def add_arguments(v):
    common_arguments(v)
    v.add_argument("--long", action="store_true", help="full lengths: nematic 150 tau equilibration + 150 tau production")
    v.add_argument("--strict", action="store_true", help="NOT CONVERGED and INCONCLUSIVE also fail (implied by --long)")
    v.add_argument("--cases", default="", help="comma list of case names or prefixes (hard, isotropic, nematic)")


VERDICT_RANK = {"PASS": 0, "INCONCLUSIVE": 1, "NOT CONVERGED": 2, "FAIL": 3, "ERROR": 4}


def validation_cases(args):
    """Each case: one run and the quantities judged on it (docs/physics.md section 8)."""
    long = args.long
    cases = []
    for eta in (0.30, 0.45):
        steps = 1_000_000 if long else 200_000
        cases.append({
            "name": f"hard-spheres-eta{eta:.2f}",
            "title": f"hard spheres, N = 2197, eta = {eta:.2f}",
            "scene": "scenes/hard-spheres.toml",
            "sets": {"system.packing_fraction": eta, "run.dt": 2e-4, "run.equilibration_steps": 10_000,
                     "run.steps": steps, "run.sample_interval": 250, "run.thermostat_interval": 200},
            "relax_tau": 1.0,  # a dense fluid forgets the simple cubic lattice within ~0.5 tau
            "quantities": [{
                "name": "Z", "key": "compressibility_factor",
                "reference": carnahan_starling(eta), "reference_error": 0.0,
                "reference_text": f"Carnahan-Starling {carnahan_starling(eta):.4f}",
                "center": carnahan_starling(eta), "tolerance": 0.005 * carnahan_starling(eta),
                "tolerance_text": "0.5 %"}]})
    n_rods = 2304
    limit = ISO_S_LIMIT / math.sqrt(n_rods)
    cases.append({
        "name": "isotropic-rho0.30",
        "title": "L/D = 5, rho* = 0.30, N = 2304 (isotropic)",
        "scene": "scenes/everyday.toml",
        "sets": {"system.reduced_density": 0.3, "run.dt": 2e-4,
                 "run.equilibration_steps": 250_000 if long else 125_000,
                 "run.steps": 250_000 if long else 50_000, "run.sample_interval": 250},
        "relax_tau": 20.0,  # measured: S falls from 1 to ~0.03 in ~20 tau from the aligned lattice
        "quantities": [
            {"name": "S", "key": "order_parameter", "reference": limit, "reference_error": 0.0,
             "reference_text": f"< 3/sqrt(N) = {limit:.4f}", "center": 0.0, "tolerance": limit,
             "tolerance_text": f"S < {limit:.4f}", "one_sided": True},
            {"name": "P*", "key": "pressure_star", "info_only": True,
             "reference_text": "(no reference in docs/physics.md; reported)"}]})
    cases.append({
        "name": "nematic-rho0.50",
        "title": "L/D = 5, rho* = 0.50, N = 2304 (nematic)",
        "scene": "scenes/everyday.toml",
        "sets": {"run.dt": 1e-4, "run.equilibration_steps": 1_500_000 if long else 400_000,
                 "run.steps": 1_500_000 if long else 200_000,
                 "run.sample_interval": 1000 if long else 500},
        "relax_tau": 100.0,  # from S = 1 the nematic relaxes over ~100 tau (paper, figure 2)
        "quantities": [
            {"name": "S", "key": "order_parameter", "reference": NEMATIC_S_REF[0],
             "reference_error": NEMATIC_S_REF[1], "reference_text": "0.727 +/- 0.002 (paper)",
             "center": 0.73, "tolerance": 0.02, "tolerance_text": "0.73 +/- 0.02"},
            {"name": "P*", "key": "pressure_star", "reference": NEMATIC_P_REF[0],
             "reference_error": NEMATIC_P_REF[1], "reference_text": "6.015 +/- 0.020 (paper)",
             "center": 6.0, "tolerance": 0.12, "tolerance_text": "6.0 +/- 2 %"}]})
    if args.cases:
        wanted = set(args.cases.split(","))
        cases = [c for c in cases if c["name"] in wanted or c["name"].split("-")[0] in wanted]
    for c in cases:
        c["sets"] = {k: repr(v) if isinstance(v, float) else str(v) for k, v in c["sets"].items()}
        if args.seed is not None:
            c["sets"]["init.seed"] = str(args.seed)
    return cases


def judge(q, summary, run_dir, relaxed_enough):
    """Verdict for one quantity. The program's own `equilibrated` flag needs about 64 independent
    blocks in each third of production, which slow order-parameter fluctuations rarely give in a
    run of validation length; the harness instead checks that the drift across production is
    either insignificant or too small to change the verdict."""
    mean, err, converged = est(summary, q["key"])
    out = {"quantity": q["name"], "measured": mean, "error": err, "error_plateau": converged,
           "reference": q.get("reference"), "reference_error": q.get("reference_error"),
           "reference_text": q.get("reference_text"), "tolerance": q.get("tolerance"),
           "tolerance_text": q.get("tolerance_text", "")}
    if mean is None:
        return {**out, "verdict": "ERROR", "reason": "no estimate in summary.json"}
    drift = drift_check(production_series(run_dir, q["key"], summary.get("packing_fraction")))
    out["drift"] = drift
    if q.get("info_only"):
        return {**out, "verdict": "INFO", "reason": ""}
    dev = mean - q["center"]
    out["deviation"] = mean - q["reference"]
    out["deviation_relative"] = None if q.get("one_sided") else out["deviation"] / q["reference"]
    combined = math.hypot(err, q["reference_error"]) if err is not None else None
    out["deviation_sigma"] = out["deviation"] / combined if combined else None
    tol = q["tolerance"]
    d = 0.0
    drifting = False
    if drift:
        d = drift["drift"]
        if q.get("one_sided"):
            d = max(d, 0.0)  # an isotropic S still falling only moves further inside the limit
        drifting = abs(d) > 3 * drift["drift_error"]
    if err is None:
        verdict, reason = "INCONCLUSIVE", "no error bar (too few samples)"
    elif drift is None:
        verdict, reason = "INCONCLUSIVE", "production too short for a drift check (< 24 samples)"
    elif not relaxed_enough[0]:
        verdict, reason = "NOT CONVERGED", relaxed_enough[1]
    elif abs(dev) <= tol and 2 * err <= tol and (not drifting or abs(dev) + abs(d) <= tol):
        verdict, reason = "PASS", ("" if not drifting else
                                   f"still drifting ({d:+.4g} first to last third), but inside the tolerance even "
                                   "if the drift continued as far again")
    elif drifting:
        verdict, reason = "NOT CONVERGED", (f"drifts by {d:+.4g} +/- {drift['drift_error']:.2g} from the first to "
                                            "the last third of production: run longer")
    elif abs(dev) - 2 * err > tol:
        verdict, reason = "FAIL", f"outside {q['tolerance_text']} by more than 2 error bars"
    elif abs(dev) > tol:
        verdict, reason = "INCONCLUSIVE", "outside the tolerance, but within 2 error bars of its edge: run longer"
    else:
        verdict, reason = "INCONCLUSIVE", "inside the tolerance, but the error bar is too large to tell: run longer"
    if verdict in ("PASS", "FAIL") and not converged:
        reason = (reason + "; " if reason else "") + "error bar is the conservative bound (no blocking plateau)"
    return {**out, "verdict": verdict, "reason": reason}


def main(args):
    args.strict = args.strict or args.long
    threads = args.threads
    jobs = args.jobs or max(1, NPROC // threads)
    cases = validation_cases(args)
    out = make_outdir(args, "validate")
    runs = [Run(c["name"], c["scene"], c["sets"], threads, out / "runs" / c["name"]) for c in cases]
    if args.dry_run:
        print_dry_run(runs, jobs, f" ({'long' if args.long else 'short'} version)")
        print(f"and write {relpath(out)}/validation.json, validation.md")
        return 0
    ensure_built(args, [HARDROD])
    results = run_all(runs, jobs, f"validate ({'long' if args.long else 'short'} version)", reuse_dir=args.reuse)

    report_cases, rows = [], []
    for c, r in zip(cases, results):
        s = r.summary or {}
        dt = float(c["sets"]["run.dt"])
        eq_tau = int(c["sets"]["run.equilibration_steps"]) * dt
        prod_tau = int(c["sets"]["run.steps"]) * dt
        relaxed = (eq_tau >= c["relax_tau"],
                   f"equilibration {eq_tau:g} tau is shorter than the ~{c['relax_tau']:g} tau this start "
                   f"needs to relax (the long version runs it)")
        if r.ok:
            qs = [judge(q, s, r.run.out, relaxed) for q in c["quantities"]]
        else:
            qs = [{"quantity": q["name"], "verdict": "ERROR", "reason": f"run {r.status()}: {r.error}"}
                  for q in c["quantities"]]
        judged = [q["verdict"] for q in qs if q["verdict"] != "INFO"]
        verdict = max(judged, key=VERDICT_RANK.get) if judged else "INFO"
        report_cases.append({
            "name": c["name"], "title": c["title"], "verdict": verdict, "command": r.run.shell(),
            "run_dir": relpath(r.run.out), "status": r.status(), "returncode": r.returncode,
            "dt": dt, "equilibration_tau": eq_tau, "production_tau": prod_tau,
            "relaxation_needed_tau": c["relax_tau"], "equilibrated": s.get("equilibrated"),
            "wall_seconds": s.get("wall_seconds", r.wall), "threads": threads,
            "max_overlap": s.get("max_overlap"), "energy_drift": s.get("energy_drift"),
            "quantities": qs})
        for q in qs:
            rel = q.get("deviation_relative")
            rows.append([c["name"], q["quantity"], pm(q.get("measured"), q.get("error")),
                         q.get("reference_text") or "-", q.get("tolerance_text") or "-",
                         "-" if rel is None else f"{100 * rel:+.3f} %",
                         "-" if q.get("deviation_sigma") is None else f"{q['deviation_sigma']:+.2f}",
                         "-" if not q.get("drift") else pm(q["drift"]["drift"], q["drift"]["drift_error"]),
                         q["verdict"]])

    worst = [c["verdict"] for c in report_cases]
    failed = any(v in ("FAIL", "ERROR") for v in worst)
    unsure = any(v in ("NOT CONVERGED", "INCONCLUSIVE") for v in worst)
    overall = "FAIL" if failed else ("NOT CONVERGED / INCONCLUSIVE" if unsure else "PASS")
    exit_code = 1 if failed or (unsure and args.strict) else 0
    table = markdown_table(["case", "quantity", "measured", "reference", "tolerance", "deviation",
                            "dev / combined error", "drift (last - first third)", "verdict"], rows)
    notes = []
    for c in report_cases:
        notes.append(f"- {c['name']}: {c['title']}; dt = {c['dt']:g}, {c['equilibration_tau']:g} tau equilibration "
                     f"+ {c['production_tau']:g} tau production, {g(c['wall_seconds'], 3)} s wall on {threads} thread(s); "
                     f"run says equilibrated: {g(c['equilibrated'])}; max overlap {g(c['max_overlap'], 3)} D.")
        for q in c["quantities"]:
            if q.get("reason"):
                notes.append(f"  - {q['quantity']}: {q['verdict']}: {q['reason']}")
    legend = ("Deviation: measured against the reference (relative). dev / combined error: "
              "(measured - reference) / sqrt(error^2 + reference error^2); Carnahan-Starling is exact as a "
              "formula but itself 0.1-0.3 % below simulation at these densities (docs/physics.md section 8). Isotropic S: "
              "criterion S < 3/sqrt(N); N independent random axes give <S> = 0.81/sqrt(N) (99.9th percentile "
              "1.76/sqrt(N)), and the factor of 3 leaves room for the short-range orientational correlations "
              "of the dense fluid; dev / error there is (S - limit) / error. Drift: mean of the last third of "
              "production minus the first third, with its error. PASS: inside the tolerance, 2 error bars no "
              "wider than it, and either no significant drift (< 3 errors) or still inside if the drift went on "
              "as far again. FAIL: outside by more than 2 error bars and not drifting. NOT CONVERGED: the start "
              "has not had the stated relaxation time, or it drifts and is not clearly inside: no verdict on "
              "the physics. INCONCLUSIVE: error bars too large for the tolerance. The program's own "
              "`equilibrated` flag is reported, not used: it needs ~64 independent blocks per third of "
              "production, which S rarely gives in runs of this length.")
    verdict_line = f"overall: {overall}" + ("" if exit_code == 0 else f" (exit {exit_code})") + \
        ("" if args.strict or not unsure else
         " (short version: not-converged cases do not fail it; --long or --strict makes them fail)")
    text = report_header(f"Physics validation ({'long' if args.long else 'short'} version)") + table + \
        "\n\n" + "\n".join(notes) + "\n\n" + legend + "\n\n" + verdict_line + "\n"
    write_json(out / "validation.json", {
        "command": invocation(), "version": "long" if args.long else "short", "strict": args.strict,
        "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        "machine": machine_info(), "overall": overall, "exit_code": exit_code, "criteria": legend,
        "cases": report_cases})
    write_text(out / "validation.md", text)
    print("\n" + table + "\n\n" + "\n".join(notes) + "\n\n" + verdict_line)
    print(f"results in {relpath(out)}/ (validation.json, validation.md, runs/)")
    return exit_code


