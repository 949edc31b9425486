"""`scripts/bench tradeoff`: speed against accuracy over the time step and the solver tolerance.

Sweeps dt (and the solver tolerance at the largest dt) on hard spheres and the L/D = 5
nematic at equal simulated time, extrapolates P* (and S) to dt -> 0 with a weighted linear
fit, and recommends the largest dt within the target; writes tradeoff.csv, tradeoff.json,
tradeoff.md and the Pareto plot (tradeoff_plot.py).
"""

import datetime
import math
import sys

from .common import (HARDROD, NPROC, busy_warning, common_arguments, ensure_built, finite, g, invocation,
                     machine_info, make_outdir, markdown_table, parse_list, pm, relpath, report_header, write_csv,
                     write_json, write_text)
from .outputs import est
from .references import HS_ETA, NEMATIC_P_REF, NEMATIC_S_REF, carnahan_starling
from .runner import Run, file_start, print_dry_run, run_all
from .stats import linear_fit, normal_cdf
from .tradeoff_plot import plot_pareto

HELP = "dt and solver-tolerance sweep: cost against bias, Pareto plot, recommended dt"
DESCRIPTION = ("Sweep dt (2e-6 ... 1e-3) on hard spheres at eta = 0.45 and the L/D = 5 nematic "
               "(lattice start, equal simulated time at every dt), and the solver tolerance at "
               "the largest dt. Writes tradeoff.csv, tradeoff.json, tradeoff.md, pareto.png; "
               "prints the largest dt keeping P* within the target of the dt -> 0 value.")


def add_arguments(t):
    common_arguments(t)
    mode = t.add_mutually_exclusive_group()
    mode.add_argument("--quick", action="store_true", help="no 2e-6 point, short runs: under ~5 minutes on 2 cores")
    mode.add_argument("--long", action="store_true", help="long runs incl. dt = 2e-6 (hours): nematic 100 + 50 tau")
    t.add_argument("--dts", default="", help="comma list of dt (overrides the preset)")
    t.add_argument("--tolerances", default="1e-4,1e-8,1e-12", help="solver tolerances at the largest dt")
    t.add_argument("--scenes", default="hard-spheres,nematic", help="comma list: hard-spheres, nematic")
    t.add_argument("--equil-tau", type=float, default=None, help="equilibration time, tau (overrides the preset)")
    t.add_argument("--prod-tau", type=float, default=None, help="production time, tau (overrides the preset)")
    t.add_argument("--fit-max-dt", type=float, default=1e-4, help="largest dt in the linear dt -> 0 fit (default 1e-4)")
    t.add_argument("--target", type=float, default=0.5, help="P* tolerance in %% for the recommendation (default 0.5)")
    t.add_argument("--start", default="", metavar="H5MD",
                   help="start the nematic runs from the last frame of this trajectory (an equilibrated run's "
                        "trajectory.h5) instead of the lattice, so a short --equil-tau suffices")


TRADEOFF_PRESETS = {
    # scene -> (equilibration tau, production tau, sample every tau)
    "quick": {"dts": [1e-5, 3e-5, 1e-4, 3e-4, 1e-3],
              "hard-spheres": (1.0, 10.0, 0.01), "nematic": (2.0, 4.0, 0.02)},
    "default": {"dts": [2e-6, 1e-5, 3e-5, 1e-4, 3e-4, 1e-3],
                "hard-spheres": (1.0, 10.0, 0.01), "nematic": (2.0, 8.0, 0.02)},
    "long": {"dts": [2e-6, 1e-5, 3e-5, 1e-4, 3e-4, 1e-3],
             "hard-spheres": (2.0, 50.0, 0.01), "nematic": (100.0, 50.0, 0.02)},
}
TRADEOFF_SCENES = {
    "hard-spheres": {"scene": "scenes/hard-spheres.toml", "n": 2197,
                     "p_ref": (HS_ETA * carnahan_starling(HS_ETA), 0.0), "s_ref": None,
                     "label": "hard spheres, eta = 0.45, N = 2197"},
    "nematic": {"scene": "scenes/everyday.toml", "n": 2304, "p_ref": NEMATIC_P_REF, "s_ref": NEMATIC_S_REF,
                "label": "L/D = 5, rho* = 0.5, N = 2304 (lattice start)"},
}


def tradeoff_runs(args, out):
    preset = TRADEOFF_PRESETS["quick" if args.quick else "long" if args.long else "default"]
    dts = parse_list(args.dts) if args.dts else preset["dts"]
    tolerances = parse_list(args.tolerances)
    runs = []
    for scene in args.scenes.split(","):
        if scene not in TRADEOFF_SCENES:
            sys.exit(f"bench tradeoff: unknown scene {scene!r} (choose from {', '.join(TRADEOFF_SCENES)})")
        eq_tau, prod_tau, sample_tau = preset[scene]
        eq_tau = args.equil_tau if args.equil_tau is not None else eq_tau
        prod_tau = args.prod_tau if args.prod_tau is not None else prod_tau
        points = [(dt, None) for dt in sorted(dts)] + [(max(dts), tol) for tol in tolerances]
        for dt, tol in points:
            sets = {"run.dt": repr(dt), "run.equilibration_steps": str(round(eq_tau / dt)),
                    "run.steps": str(round(prod_tau / dt)),
                    "run.sample_interval": str(max(1, round(sample_tau / dt)))}
            if tol is not None:
                sets["run.solver_tolerance"] = repr(tol)
            if args.seed is not None:
                sets["init.seed"] = str(args.seed)
            if args.start and scene == "nematic":
                sets.update(file_start(args.start))
            name = f"{scene}-dt{dt:g}" + (f"-tol{tol:g}" if tol is not None else "")
            run = Run(name, TRADEOFF_SCENES[scene]["scene"], sets, args.threads, out / "runs" / name,
                      meta={"scene": scene, "dt": dt, "tolerance": tol, "equilibration_tau": eq_tau,
                            "production_tau": prod_tau, "n": TRADEOFF_SCENES[scene]["n"]})
            runs.append(run)
    return runs


def extrapolate(rows, key, fit_max_dt):
    pts = [(r["dt"], r[key], r[key + "_error"]) for r in rows
           if r["kind"] == "dt" and r["ok"] and r["dt"] <= fit_max_dt * (1 + 1e-9)
           and finite(r.get(key)) and finite(r.get(key + "_error")) and r[key + "_error"] > 0]
    if len(pts) < 2:
        return None
    a, b, cov, chi2, dof = linear_fit(pts)
    return {"value": a, "error": math.sqrt(cov[0][0]), "slope": b, "slope_error": math.sqrt(cov[1][1]),
            "chi2": chi2, "dof": dof, "points": [p[0] for p in pts], "fit_max_dt": fit_max_dt}


def recommend(rows, fit, tol_rel):
    """Largest dt whose P* (and that of every smaller dt) is within tol_rel of the dt -> 0 value."""
    sweep = sorted((r for r in rows if r["kind"] == "dt"), key=lambda r: r["dt"])
    for r in sweep:
        rel, sig = r.get("p_bias_extrap_rel"), r.get("p_bias_extrap_rel_error")
        if rel is not None and sig:
            r["p_within_tolerance_probability"] = \
                normal_cdf((tol_rel - rel) / sig) - normal_cdf((-tol_rel - rel) / sig)
    best = None
    for r in sweep:
        if not r["ok"] or r.get("p_bias_extrap_rel") is None or abs(r["p_bias_extrap_rel"]) > tol_rel:
            break
        best = (r, r.get("p_within_tolerance_probability") or 0.0)
    if fit is None:
        return None, "no dt -> 0 extrapolation (fewer than 2 usable small-dt points)"
    p0 = fit["value"]
    text = ""
    if best is None:
        text = f"no dt in the sweep keeps P* within {100 * tol_rel:g} % of the dt -> 0 value"
    else:
        r, prob = best
        sure = ("sure" if prob >= 0.95 else "fairly sure" if prob >= 0.8 else "not sure: the error bars are comparable "
                "to the tolerance; run longer (default or --long)")
        text = (f"dt = {r['dt']:g}: P* bias {100 * r['p_bias_extrap_rel']:+.3f} % +/- "
                f"{100 * r['p_bias_extrap_rel_error']:.3f} % against the dt -> 0 value {pm(p0, fit['error'])}; "
                f"probability the true bias is within {100 * tol_rel:g} %: {100 * prob:.0f} % ({sure})")
    if fit["slope_error"] and abs(fit["slope"]) > 2 * fit["slope_error"]:
        dt_max = tol_rel * abs(p0) / abs(fit["slope"])
        text += (f"; the linear fit puts the {100 * tol_rel:g} % point at dt = {dt_max:.2g} "
                 f"(+/- {100 * fit['slope_error'] / abs(fit['slope']):.0f} %)")
    else:
        text += f"; the fitted slope dP*/ddt = {g(fit['slope'])} +/- {g(fit['slope_error'])} is not significant"
    return (best[0]["dt"] if best else None), text


def main(args):
    jobs = args.jobs or max(1, NPROC // args.threads)
    out = make_outdir(args, "tradeoff")
    runs = tradeoff_runs(args, out)
    if args.dry_run:
        preset = "quick" if args.quick else "long" if args.long else "default"
        start = f"nematic from {args.start}" if args.start else "lattice starts"
        print_dry_run(runs, jobs, f" ({preset} preset; equal simulated time at every dt; {start})")
        print(f"and write {relpath(out)}/tradeoff.csv, tradeoff.json, tradeoff.md, pareto.png")
        return 0
    ensure_built(args, [HARDROD])
    results = run_all(runs, jobs, "tradeoff", reuse_dir=args.reuse)

    rows = [point_row(res) for res in results]
    analysis = analyse(rows, args)
    return write_report(args, out, rows, analysis, results)


def point_row(res):
    """One run's line of tradeoff.csv: its settings, cost and estimates."""
    m, s = res.run.meta, res.summary or {}
    p, p_err, p_conv = est(s, "pressure_star")
    S, S_err, _ = est(s, "order_parameter")
    Z, Z_err, _ = est(s, "compressibility_factor")
    if not res.ok:  # a stopped run's averages are of whatever it did before it stopped: not data
        p = p_err = S = S_err = Z = Z_err = None
    n, steps_done, sim_t = s.get("n"), s.get("steps_done") or 0, s.get("simulated_time")
    wall, threads = s.get("wall_seconds"), s.get("threads", res.run.threads)
    cost = wall * threads / (sim_t * n) if res.ok and sim_t and n and wall else None
    return {
        "scene": m["scene"], "kind": "dt" if m["tolerance"] is None else "tolerance", "dt": m["dt"],
        "solver_tolerance": m["tolerance"] if m["tolerance"] is not None else "scene default",
        "ok": res.ok, "status": res.status(), "error": res.error or None, "n": n,
        "equilibration_tau": m["equilibration_tau"], "production_tau": m["production_tau"],
        "steps_done": steps_done, "simulated_time": sim_t, "wall_seconds": wall, "threads": threads,
        "cost_cpu_s_per_tau_per_particle": cost, "ns_per_particle_step": s.get("ns_per_particle_step"),
        "pressure_star": p, "pressure_star_error": p_err, "pressure_converged": p_conv,
        "order_parameter": S if m["scene"] != "hard-spheres" else None,
        "order_parameter_error": S_err if m["scene"] != "hard-spheres" else None,
        "compressibility_factor": Z, "compressibility_factor_error": Z_err,
        "equilibrated": s.get("equilibrated"), "energy_drift": s.get("energy_drift"),
        "max_overlap": s.get("max_overlap"), "contacts_per_step": s.get("contacts_per_step"),
        "multi_contact_bodies_per_step": s["multi_contact_bodies"] / steps_done
        if steps_done and "multi_contact_bodies" in s else None,
        "collision_rate": s.get("collision_rate"), "solver_iterations_max": s.get("solver_iterations_max"),
        "solver_energy_change": s.get("solver_energy_change"),
        "solver_unconverged": s.get("solver_unconverged"), "load_average_1min": res.load_before,
        "run_dir": relpath(res.run.out)}


def analyse(rows, args):
    """Per scene: the dt -> 0 fits, each point's bias against them and the references, the
    recommended dt. Adds the bias columns to rows; returns the analysis by scene."""
    tol_rel = args.target / 100.0
    analysis = {}
    for scene in dict.fromkeys(r["scene"] for r in rows):
        srows = [r for r in rows if r["scene"] == scene]
        info = TRADEOFF_SCENES[scene]
        fit_p = extrapolate(srows, "pressure_star", args.fit_max_dt)
        fit_s = extrapolate(srows, "order_parameter", args.fit_max_dt) if info["s_ref"] else None
        for r in srows:
            p, pe = r["pressure_star"], r["pressure_star_error"]
            if finite(p) and fit_p:
                sig = math.hypot(pe or 0.0, fit_p["error"])
                r["p_extrapolated"] = fit_p["value"]
                r["p_bias_extrap"] = p - fit_p["value"]
                r["p_bias_extrap_error"] = sig
                r["p_bias_extrap_rel"] = (p - fit_p["value"]) / fit_p["value"]
                r["p_bias_extrap_rel_error"] = sig / fit_p["value"]
                r["p_bias_extrap_sigma"] = (p - fit_p["value"]) / sig if sig else None
            if finite(p):
                ref, ref_e = info["p_ref"]
                sig = math.hypot(pe or 0.0, ref_e)
                r["p_bias_ref"] = p - ref
                r["p_bias_ref_rel"] = (p - ref) / ref
                r["p_bias_ref_sigma"] = (p - ref) / sig if sig else None
            S, Se = r["order_parameter"], r["order_parameter_error"]
            if finite(S) and fit_s:
                r["s_bias_extrap"] = S - fit_s["value"]
                r["s_bias_extrap_error"] = math.hypot(Se or 0.0, fit_s["error"])
            if finite(S) and info["s_ref"]:
                r["s_bias_ref"] = S - info["s_ref"][0]
                r["s_bias_ref_error"] = math.hypot(Se or 0.0, info["s_ref"][1])
        dt_rec, text = recommend(srows, fit_p, tol_rel)
        analysis[scene] = {"label": info["label"], "fit_pressure_star": fit_p, "fit_order_parameter": fit_s,
                           "recommended_dt": dt_rec, "recommendation": text}
    return analysis


def write_report(args, out, rows, analysis, results):
    """tradeoff.csv, tradeoff.md, tradeoff.json and pareto.png; the table printed."""
    columns = ["scene", "kind", "dt", "solver_tolerance", "status", "n", "equilibration_tau", "production_tau",
               "steps_done", "simulated_time", "wall_seconds", "threads", "cost_cpu_s_per_tau_per_particle",
               "ns_per_particle_step", "pressure_star", "pressure_star_error", "pressure_converged",
               "p_extrapolated", "p_bias_extrap", "p_bias_extrap_error", "p_bias_extrap_rel",
               "p_bias_extrap_sigma", "p_within_tolerance_probability", "p_bias_ref", "p_bias_ref_rel",
               "p_bias_ref_sigma", "order_parameter", "order_parameter_error", "s_bias_extrap",
               "s_bias_extrap_error", "s_bias_ref", "s_bias_ref_error", "compressibility_factor",
               "compressibility_factor_error", "equilibrated", "energy_drift", "max_overlap", "contacts_per_step",
               "multi_contact_bodies_per_step", "collision_rate", "solver_iterations_max", "solver_energy_change",
               "solver_unconverged", "load_average_1min", "error", "run_dir"]
    write_csv(out / "tradeoff.csv", rows, columns)

    def pct(x):
        return "-" if x is None else f"{100 * x:+.2f} %"

    table_rows = []
    for r in rows:
        table_rows.append([
            r["scene"], g(r["dt"]), "default" if r["kind"] == "dt" else g(r["solver_tolerance"]),
            r["status"] if not r["ok"] else g(r["cost_cpu_s_per_tau_per_particle"], 3),
            pm(r["pressure_star"], r["pressure_star_error"]),
            pct(r.get("p_bias_extrap_rel")) + ("" if r.get("p_bias_extrap_sigma") is None
                                              else f" ({r['p_bias_extrap_sigma']:+.1f} sd)"),
            pct(r.get("p_bias_ref_rel")),
            pm(r["order_parameter"], r["order_parameter_error"]) if r["order_parameter"] is not None else "-",
            g(r.get("s_bias_extrap"), 3),
            g(r["energy_drift"], 2), g(r["max_overlap"], 3), g(r["contacts_per_step"], 3),
            g(r["multi_contact_bodies_per_step"], 3)])
    table = markdown_table(
        ["scene", "dt", "solver tol", "cost (CPU s/tau/particle)", "P*", "P* bias vs dt->0", "P* vs SPEC",
         "S", "S bias vs dt->0", "energy drift /tau", "max overlap (D)", "contacts/step",
         "multi-contact bodies/step"], table_rows)
    recs = []
    for scene, a in analysis.items():
        fp = a["fit_pressure_star"]
        fit_txt = (f"P*(dt -> 0) = {pm(fp['value'], fp['error'])} from a weighted linear fit over dt = "
                   f"{', '.join(g(x) for x in fp['points'])} (chi2 = {fp['chi2']:.2f} for {fp['dof']} dof)"
                   if fp else "no dt -> 0 fit")
        fs = a["fit_order_parameter"]
        if fs:
            fit_txt += f"; S(dt -> 0) = {pm(fs['value'], fs['error'])}"
        recs.append(f"- {scene} ({a['label']}): {fit_txt}.\n  Recommended (largest dt keeping P* within "
                    f"{args.target:g} % of dt -> 0): {a['recommendation']}.")
    if "nematic" in analysis and args.start:
        caveat = (f"The nematic starts at every dt from the last frame of {args.start} (an equilibrated run), "
                  f"with fresh velocities and {args.equil_tau if args.equil_tau is not None else 'the preset'} "
                  f"tau of equilibration at its own dt before production. ")
    elif "nematic" in analysis:
        caveat = ("The nematic starts from the aligned lattice (S = 1) at every dt, with the same simulated "
                  "equilibration time for all dt (pass --start RUN/trajectory.h5 for an equilibrated start): "
                  "its P* and S are averages over the same stretch of the relaxation, so they compare dt "
                  "against dt, not against the equilibrium reference (the 'vs SPEC' column). ")
    else:
        caveat = ""
    caveat += ("Every dt starts from the same configuration and velocities (same seed), so short runs are correlated "
               "across dt and the bias errors, which treat them as independent, are if anything too large. Errors are block-averaged standard errors; the "
              "bias error combines the point's error with the extrapolation's. Cost = wall x threads / "
              "(simulated time x N), equilibration included.")
    busy = busy_warning([r["load_average_1min"] for r in rows])
    if busy:
        caveat += " " + busy
    png = out / "pareto.png"
    plot_note = plot_pareto(rows, analysis, png, args.target)
    text = report_header("Speed against accuracy (dt and solver tolerance sweep)") + table + "\n\n" + \
        "\n".join(recs) + "\n\n" + caveat + "\n\n" + ("![Pareto plot](pareto.png)\n" if not plot_note else plot_note + "\n")
    write_text(out / "tradeoff.md", text)
    write_json(out / "tradeoff.json", {
        "command": invocation(), "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        "machine": machine_info(), "target_percent": args.target, "fit_max_dt": args.fit_max_dt,
        "points": rows, "analysis": analysis, "caveat": caveat,
        "commands": [r.run.shell() for r in results]})
    print("\n" + table + "\n\n" + "\n".join(recs) + "\n\n" + caveat)
    if plot_note:
        print(plot_note)
    print(f"results in {relpath(out)}/ (tradeoff.csv, tradeoff.json, tradeoff.md, pareto.png, runs/)")
    return 0 if all(r["ok"] for r in rows) else 1
