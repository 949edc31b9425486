"""`scripts/bench tradeoff`: speed against accuracy over the time step, the collision method and
the solver tolerance.

Sweeps dt for each collision method (run.method = "midpoint", the paper's, and "exact", the
collisions at their exact times within the step; each method with its own dt list and the
exact method with its own neighbour-list skin) and the solver tolerance at the midpoint
method's largest dt, on hard spheres and the L/D = 5 nematic at equal simulated time. P* (and
S) are extrapolated to dt -> 0 by a weighted linear fit of the midpoint sweep; every point's
bias is measured against that value and the reference. Recommends the largest dt within the
target per method and the cheaper method there. The runs and the analysis are here; the
report files are tradeoff_report.py, the Pareto plot tradeoff_plot.py.
"""

import math
import sys

from .common import (HARDROD, NPROC, common_arguments, ensure_built, finite, g, make_outdir, parse_list, pm,
                     relpath)
from .outputs import est
from .references import HS_ETA, NEMATIC_P_REF, NEMATIC_S_REF, carnahan_starling
from .runner import Run, file_start, print_dry_run, run_all
from .stats import linear_fit, normal_cdf
from .tradeoff_report import write_report

HELP = "dt, method and solver-tolerance sweep: cost against bias, Pareto plot, recommended dt per method"
DESCRIPTION = ("Sweep dt on hard spheres at eta = 0.45 and the L/D = 5 nematic for each collision method "
               "(midpoint: 2e-6 ... 1e-3; exact: 5e-4 ... 4e-3 for spheres, 3e-3 for rods, with its own skin), at equal simulated time "
               "at every dt, and the solver tolerance at the midpoint method's largest dt. Writes "
               "tradeoff.csv, tradeoff.json, tradeoff.md, pareto.png; prints the largest dt keeping P* "
               "within the target of the dt -> 0 value for each method, and the cheaper method there.")

METHODS = ("midpoint", "exact")


def add_arguments(t):
    common_arguments(t)
    mode = t.add_mutually_exclusive_group()
    mode.add_argument("--quick", action="store_true", help="no 2e-6 point, short runs: under ~10 minutes on 2 cores")
    mode.add_argument("--long", action="store_true", help="long runs incl. dt = 2e-6 (hours): nematic 100 + 50 tau")
    t.add_argument("--methods", default="midpoint,exact",
                   help="comma list of collision methods (run.method): midpoint, exact (default: both)")
    t.add_argument("--dts", default="", help="comma list of dt for the midpoint method (overrides the preset)")
    t.add_argument("--exact-dts", default="", help="comma list of dt for the exact method, every scene (overrides the preset's per-scene lists)")
    t.add_argument("--exact-skin", type=float, default=None, metavar="D",
                   help="run.skin of the exact method's runs, in D (default: 0.5 for spheres, 1.0 for rods; "
                        "the midpoint runs keep the scene's)")
    t.add_argument("--tolerances", default="1e-4,1e-8,1e-12",
                   help="solver tolerances at the midpoint method's largest dt")
    t.add_argument("--scenes", default="hard-spheres,nematic", help="comma list: hard-spheres, nematic")
    t.add_argument("--equil-tau", type=float, default=None, help="equilibration time, tau (overrides the preset)")
    t.add_argument("--prod-tau", type=float, default=None, help="production time, tau (overrides the preset)")
    t.add_argument("--fit-max-dt", type=float, default=1e-4,
                   help="largest midpoint dt in the linear dt -> 0 fit (default 1e-4)")
    t.add_argument("--target", type=float, default=0.5, help="P* tolerance in %% for the recommendation (default 0.5)")
    t.add_argument("--start", default="", metavar="H5MD",
                   help="start the nematic runs from the last frame of this trajectory (an equilibrated run's "
                        "trajectory.h5) instead of the lattice, so a short --equil-tau suffices")


# The exact method's dt lists are per scene: its clusters percolate on the rods at dt = 4e-3
# (events per step by the hundred thousand, the event cap's fallbacks: bench/tradeoff/README.md),
# on hard spheres at eta = 0.45 only at 8e-3.
EXACT_DTS = {"quick": {"hard-spheres": [1e-3, 2e-3, 4e-3], "nematic": [1e-3, 2e-3, 3e-3]},
             "full": {"hard-spheres": [5e-4, 1e-3, 2e-3, 4e-3], "nematic": [5e-4, 1e-3, 2e-3, 3e-3]}}
TRADEOFF_PRESETS = {
    # dts per method (exact: per scene); scene -> (equilibration tau, production tau, sample every tau)
    "quick": {"dts": {"midpoint": [1e-5, 3e-5, 1e-4, 3e-4, 1e-3], "exact": EXACT_DTS["quick"]},
              "hard-spheres": (1.0, 10.0, 0.01), "nematic": (2.0, 4.0, 0.02)},
    "default": {"dts": {"midpoint": [2e-6, 1e-5, 3e-5, 1e-4, 3e-4, 1e-3], "exact": EXACT_DTS["full"]},
                "hard-spheres": (1.0, 10.0, 0.01), "nematic": (2.0, 8.0, 0.02)},
    "long": {"dts": {"midpoint": [2e-6, 1e-5, 3e-5, 1e-4, 3e-4, 1e-3], "exact": EXACT_DTS["full"]},
             "hard-spheres": (2.0, 50.0, 0.01), "nematic": (100.0, 50.0, 0.02)},
}
# exact_skin: the exact method's bounds grow with the step's flight, so at its large dt a
# wider skin (fewer rebuilds) is cheaper; it never changes the trajectory (bench/tradeoff/README.md).
TRADEOFF_SCENES = {
    "hard-spheres": {"scene": "scenes/hard-spheres.toml", "n": 2197,
                     "p_ref": (HS_ETA * carnahan_starling(HS_ETA), 0.0), "s_ref": None, "exact_skin": 0.5,
                     "label": "hard spheres, eta = 0.45, N = 2197"},
    "nematic": {"scene": "scenes/everyday.toml", "n": 2304, "p_ref": NEMATIC_P_REF, "s_ref": NEMATIC_S_REF,
                "exact_skin": 1.0, "label": "L/D = 5, rho* = 0.5, N = 2304"},
}
# |bias| / sd beyond which an exact point is called inconsistent with the dt -> 0 value.
CONSISTENT_SIGMA = 2.0


def fail(message):
    sys.exit(f"bench tradeoff: {message}")


def positive_list(flag, text):
    """The comma list of a flag as positive finite floats, or exit naming the flag and the value."""
    try:
        values = parse_list(text)
    except ValueError:
        fail(f"{flag} {text!r}: not a comma list of numbers")
    if not values or not all(finite(v) and v > 0 for v in values):
        fail(f"{flag} {text!r}: every value must be a positive finite number")
    return values


def sweep_settings(args):
    """(methods, {(method, scene): dts}, tolerances, scenes) from the flags and the preset; exits on bad
    values."""
    preset = TRADEOFF_PRESETS["quick" if args.quick else "long" if args.long else "default"]
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    bad = [m for m in methods if m not in METHODS]
    if not methods or bad or len(set(methods)) != len(methods):
        fail(f"--methods {args.methods!r}: give each of {', '.join(METHODS)} at most once")
    midpoint = positive_list("--dts", args.dts) if args.dts else preset["dts"]["midpoint"]
    exact = positive_list("--exact-dts", args.exact_dts) if args.exact_dts else None
    if args.exact_skin is not None and not (finite(args.exact_skin) and args.exact_skin > 0):
        fail(f"--exact-skin {args.exact_skin!r}: must be a positive finite number (in D)")
    tolerances = positive_list("--tolerances", args.tolerances) if args.tolerances.strip() else []
    scenes = [s for s in args.scenes.split(",") if s]
    for scene in scenes:
        if scene not in TRADEOFF_SCENES:
            fail(f"unknown scene {scene!r} in --scenes (choose from {', '.join(TRADEOFF_SCENES)})")
    dts = {("midpoint", s): sorted(midpoint) for s in scenes}
    dts.update({("exact", s): sorted(exact or preset["dts"]["exact"][s]) for s in scenes})
    return methods, dts, tolerances, scenes


def exact_skin(args, scene):
    return args.exact_skin if args.exact_skin is not None else TRADEOFF_SCENES[scene]["exact_skin"]


def tradeoff_runs(args, out):
    preset = TRADEOFF_PRESETS["quick" if args.quick else "long" if args.long else "default"]
    methods, dts, tolerances, scenes = sweep_settings(args)
    runs = []
    for scene in scenes:
        eq_tau, prod_tau, sample_tau = preset[scene]
        eq_tau = args.equil_tau if args.equil_tau is not None else eq_tau
        prod_tau = args.prod_tau if args.prod_tau is not None else prod_tau
        points = []
        for method in methods:
            points += [(method, dt, None) for dt in dts[method, scene]]
            if method == "midpoint":  # the solver exists only in the midpoint method
                points += [(method, max(dts[method, scene]), tol) for tol in tolerances]
        for method, dt, tol in points:
            sets = {"run.dt": repr(dt), "run.equilibration_steps": str(round(eq_tau / dt)),
                    "run.steps": str(round(prod_tau / dt)),
                    "run.sample_interval": str(max(1, round(sample_tau / dt)))}
            skin = None
            if method == "exact":
                skin = exact_skin(args, scene)
                sets["run.method"] = '"exact"'
                sets["run.skin"] = repr(skin)
            if tol is not None:
                sets["run.solver_tolerance"] = repr(tol)
            if args.seed is not None:
                sets["init.seed"] = str(args.seed)
            if args.start and scene == "nematic":
                sets.update(file_start(args.start))
            # midpoint names unchanged, so --reuse still finds results made before the exact method
            name = (f"{scene}-" + ("exact-" if method == "exact" else "") + f"dt{dt:g}"
                    + (f"-tol{tol:g}" if tol is not None else ""))
            run = Run(name, TRADEOFF_SCENES[scene]["scene"], sets, args.threads, out / "runs" / name,
                      meta={"scene": scene, "method": method, "dt": dt, "tolerance": tol, "skin": skin,
                            "equilibration_tau": eq_tau, "production_tau": prod_tau,
                            "n": TRADEOFF_SCENES[scene]["n"]})
            runs.append(run)
    return runs


def extrapolate(rows, key, fit_max_dt):
    """Weighted linear fit of the midpoint sweep's key over dt <= fit_max_dt: the dt -> 0 value."""
    pts = [(r["dt"], r[key], r[key + "_error"]) for r in rows
           if r["kind"] == "dt" and r["method"] == "midpoint" and r["ok"] and r["dt"] <= fit_max_dt * (1 + 1e-9)
           and finite(r.get(key)) and finite(r.get(key + "_error")) and r[key + "_error"] > 0]
    if len(pts) < 2:
        return None
    a, b, cov, chi2, dof = linear_fit(pts)
    return {"value": a, "error": math.sqrt(cov[0][0]), "slope": b, "slope_error": math.sqrt(cov[1][1]),
            "chi2": chi2, "dof": dof, "points": [p[0] for p in pts], "fit_max_dt": fit_max_dt}


def recommend(rows, fit, tol_rel, method="midpoint"):
    """Largest dt of one method's sweep whose P* (and that of every smaller dt) is within tol_rel of
    the dt -> 0 value; (dt or None, text). The fitted slope's 0.5 % point is the midpoint's only."""
    sweep = sorted((r for r in rows if r["kind"] == "dt" and r["method"] == method), key=lambda r: r["dt"])
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
        return None, "no dt -> 0 extrapolation (fewer than 2 usable small-dt midpoint points)"
    if not sweep:
        return None, f"no {method} runs"
    p0 = fit["value"]
    if best is None:
        text = f"no dt in the sweep keeps P* within {100 * tol_rel:g} % of the dt -> 0 value"
    else:
        r, prob = best
        sure = ("sure" if prob >= 0.95 else "fairly sure" if prob >= 0.8 else "not sure: the error bars are comparable "
                "to the tolerance; run longer (default or --long)")
        text = (f"dt = {r['dt']:g}: P* bias {100 * r['p_bias_extrap_rel']:+.3f} % +/- "
                f"{100 * r['p_bias_extrap_rel_error']:.3f} % against the dt -> 0 value {pm(p0, fit['error'])}; "
                f"probability the true bias is within {100 * tol_rel:g} %: {100 * prob:.0f} % ({sure})")
        if r is sweep[-1] and method == "exact":
            text += "; the sweep's largest dt: a larger one may do too"
    if method != "midpoint":
        return (best[0]["dt"] if best else None), text
    if fit["slope_error"] and abs(fit["slope"]) > 2 * fit["slope_error"]:
        dt_max = tol_rel * abs(p0) / abs(fit["slope"])
        text += (f"; the linear fit puts the {100 * tol_rel:g} % point at dt = {dt_max:.2g} "
                 f"(+/- {100 * fit['slope_error'] / abs(fit['slope']):.0f} %)")
    else:
        text += f"; the fitted slope dP*/ddt = {g(fit['slope'])} +/- {g(fit['slope_error'])} is not significant"
    return (best[0]["dt"] if best else None), text


def exact_consistency(rows):
    """Is the exact method's P* consistent with the dt -> 0 value (within CONSISTENT_SIGMA sd) at every
    dt? {consistent, points: [(dt, sd vs dt -> 0, sd vs reference)], text}, or None without exact rows."""
    sweep = sorted((r for r in rows if r["kind"] == "dt" and r["method"] == "exact"), key=lambda r: r["dt"])
    if not sweep:
        return None
    points = [{"dt": r["dt"], "sigma_extrapolated": r.get("p_bias_extrap_sigma"),
               "sigma_reference": r.get("p_bias_ref_sigma"), "ok": r["ok"]} for r in sweep]
    usable = [p for p in points if p["ok"] and p["sigma_extrapolated"] is not None]
    listed = ", ".join(f"{p['dt']:g}: {p['sigma_extrapolated']:+.1f}" for p in usable)
    failed = [p["dt"] for p in points if not p["ok"]]
    off = [p for p in usable if abs(p["sigma_extrapolated"]) > CONSISTENT_SIGMA]
    if not usable:
        consistent, text = None, "exact method: no point to compare with the dt -> 0 value"
    elif off or failed:
        consistent = False
        text = (f"exact method: P* NOT consistent with the dt -> 0 value at every dt (bias in sd at dt = {listed}"
                + (f"; failed at dt = {', '.join(f'{d:g}' for d in failed)}" if failed else "") + ")")
    else:
        consistent = True
        text = (f"exact method: P* consistent with the dt -> 0 value at every dt (|bias| <= "
                f"{CONSISTENT_SIGMA:g} sd; bias in sd at dt = {listed})")
    return {"consistent": consistent, "points": points, "threshold_sigma": CONSISTENT_SIGMA, "text": text}


def cheaper_at_target(by_method, rows, tol_pct):
    """The cheaper method at its recommended dt: {method, ratio, text}."""
    costs = {}
    for method, rec in by_method.items():
        row = next((r for r in rows if r["kind"] == "dt" and r["method"] == method
                    and r["dt"] == rec["recommended_dt"]), None)
        rec["cost_at_recommended"] = row["cost_cpu_s_per_tau_per_particle"] if row else None
        if finite(rec["cost_at_recommended"]):
            costs[method] = rec["cost_at_recommended"]
    if not costs:
        return {"method": None, "ratio": None, "text": f"no method keeps P* within {tol_pct:g} %"}
    best = min(costs, key=costs.get)
    at = f"{best} at dt = {by_method[best]['recommended_dt']:g} ({g(costs[best], 3)} CPU s/tau/particle)"
    others = [m for m in by_method if m != best]
    if not others:
        return {"method": best, "ratio": None, "text": f"only {at} was swept"}
    other = others[0]
    if other not in costs:
        return {"method": best, "ratio": None,
                "text": f"{at}; {other} keeps P* within {tol_pct:g} % at no dt of its sweep"}
    ratio = costs[other] / costs[best]
    return {"method": best, "ratio": ratio,
            "text": f"{at}, {ratio:.2g}x cheaper than {other} at dt = {by_method[other]['recommended_dt']:g} "
                    f"({g(costs[other], 3)})"}


def main(args):
    jobs = args.jobs or max(1, NPROC // args.threads)
    out = make_outdir(args, "tradeoff")
    runs = tradeoff_runs(args, out)
    if args.dry_run:
        preset = "quick" if args.quick else "long" if args.long else "default"
        start = f"nematic from {args.start}" if args.start else "lattice starts"
        skins = ", ".join(f"{s} {exact_skin(args, s):g} D" for s in dict.fromkeys(r.meta["scene"] for r in runs))
        print_dry_run(runs, jobs, f" ({preset} preset; equal simulated time at every dt; {start}; "
                                  f"exact method's run.skin: {skins})")
        print(f"and write {relpath(out)}/tradeoff.csv, tradeoff.json, tradeoff.md, pareto.png")
        return 0
    ensure_built(args, [HARDROD])
    results = run_all(runs, jobs, "tradeoff", reuse_dir=args.reuse)

    rows = [point_row(res) for res in results]
    analysis = analyse(rows, args)
    return write_report(args, out, rows, analysis, results)


def exact_work(s, steps):
    """The exact method's work per step from summary.json's "exact" object (None for midpoint)."""
    e = s.get("exact")
    if not isinstance(e, dict):
        return {}
    per = e.get("steps") or steps
    return {"collisions_per_step": e.get("collisions_per_step"),
            "searches_per_step": e["searches"] / per if per and "searches" in e else None,
            "candidates_per_step": e["candidates"] / per if per and "candidates" in e else None,
            "root_iterations_per_search": e.get("root_iterations_per_search"),
            "events_per_step": e.get("events_per_step"), "repredictions_per_step": e.get("repredictions_per_step"),
            # None ("-") where every step took its events in one queue: no clusters formed.
            "largest_cluster": None if per and e.get("queued_steps", 0) >= per else e.get("largest_cluster"),
            "fallbacks": e.get("fallbacks"),
            "unconverged_searches": e.get("unconverged_searches"), "rebuilt_in_step": e.get("rebuilt_in_step")}


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
    method = m.get("method", "midpoint")
    return {
        "scene": m["scene"], "method": method, "kind": "dt" if m["tolerance"] is None else "tolerance",
        "dt": m["dt"], "skin": m.get("skin") if m.get("skin") is not None else "scene default",
        "solver_tolerance": m["tolerance"] if m["tolerance"] is not None else
        ("scene default" if method == "midpoint" else "-"),
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
        "solver_unconverged": s.get("solver_unconverged"), "neighbor_list_builds": s.get("neighbor_list_builds"),
        **{"exact_" + k: v for k, v in exact_work(s, steps_done).items()},
        "load_average_1min": res.load_before, "run_dir": relpath(res.run.out)}


def add_biases(r, fit_p, fit_s, info):
    """The row's P* and S bias columns against the dt -> 0 fits and the references."""
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


def analyse(rows, args):
    """Per scene: the dt -> 0 fits (midpoint sweep), each point's bias against them and the
    references, the recommended dt per method, the exact method's consistency and the cheaper
    method at the target. Adds the bias columns to rows; returns the analysis by scene."""
    tol_rel = args.target / 100.0
    analysis = {}
    for scene in dict.fromkeys(r["scene"] for r in rows):
        srows = [r for r in rows if r["scene"] == scene]
        info = TRADEOFF_SCENES[scene]
        fit_p = extrapolate(srows, "pressure_star", args.fit_max_dt)
        fit_s = extrapolate(srows, "order_parameter", args.fit_max_dt) if info["s_ref"] else None
        for r in srows:
            add_biases(r, fit_p, fit_s, info)
        by_method = {}
        for method in dict.fromkeys(r["method"] for r in srows):
            dt_rec, text = recommend(srows, fit_p, tol_rel, method)
            by_method[method] = {"recommended_dt": dt_rec, "recommendation": text}
        cheaper = (cheaper_at_target(by_method, srows, args.target) if fit_p else
                   {"method": None, "ratio": None, "text": "no dt -> 0 fit to measure the biases against"})
        label = info["label"] + (" (equilibrated start)" if scene == "nematic" and args.start else
                                 " (lattice start)" if scene == "nematic" else "")
        analysis[scene] = {"label": label, "fit_pressure_star": fit_p, "fit_order_parameter": fit_s,
                           "recommended_dt": by_method.get("midpoint", {}).get("recommended_dt"),
                           "recommendation": by_method.get("midpoint", {}).get("recommendation"),
                           "methods": by_method, "cheaper_at_target": cheaper,
                           "exact_consistency": exact_consistency(srows),
                           "exact_skin": exact_skin(args, scene) if "exact" in by_method else None}
    return analysis
