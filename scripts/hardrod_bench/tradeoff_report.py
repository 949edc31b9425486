"""The report of `scripts/bench tradeoff`: tradeoff.csv, tradeoff.md, tradeoff.json and the table printed.

Formatting only: the rows and the analysis (fits, biases, recommendations per method) come from
tradeoff.py, the Pareto plot from tradeoff_plot.py.
"""

import datetime

from .common import busy_warning, g, invocation, machine_info, markdown_table, pm, relpath, report_header, \
    write_csv, write_json, write_text
from .tradeoff_plot import plot_pareto

CSV_COLUMNS = [
    "scene", "method", "kind", "dt", "skin", "solver_tolerance", "status", "n", "equilibration_tau",
    "production_tau", "steps_done", "simulated_time", "wall_seconds", "threads", "cost_cpu_s_per_tau_per_particle",
    "ns_per_particle_step", "pressure_star", "pressure_star_error", "pressure_converged", "p_extrapolated",
    "p_bias_extrap", "p_bias_extrap_error", "p_bias_extrap_rel", "p_bias_extrap_sigma",
    "p_within_tolerance_probability", "p_bias_ref", "p_bias_ref_rel", "p_bias_ref_sigma", "order_parameter",
    "order_parameter_error", "s_bias_extrap", "s_bias_extrap_error", "s_bias_ref", "s_bias_ref_error",
    "compressibility_factor", "compressibility_factor_error", "equilibrated", "energy_drift", "max_overlap",
    "contacts_per_step", "multi_contact_bodies_per_step", "collision_rate", "solver_iterations_max",
    "solver_energy_change", "solver_unconverged", "neighbor_list_builds", "exact_collisions_per_step",
    "exact_searches_per_step", "exact_candidates_per_step", "exact_root_iterations_per_search", "exact_events_per_step",
    "exact_repredictions_per_step", "exact_largest_cluster", "exact_fallbacks", "exact_unconverged_searches",
    "exact_rebuilt_in_step", "load_average_1min", "error", "run_dir"]


def pct(x):
    return "-" if x is None else f"{100 * x:+.2f} %"


def sd(x):
    return "" if x is None else f" ({x:+.1f} sd)"


def main_table(rows):
    """Every point: method, dt, cost, P* and S with their biases, the midpoint solver's work."""
    table_rows = []
    for r in rows:
        tol = ("default" if r["kind"] == "dt" else g(r["solver_tolerance"])) if r["method"] == "midpoint" else "-"
        table_rows.append([
            r["scene"], r["method"], g(r["dt"]), tol,
            r["status"] if not r["ok"] else g(r["cost_cpu_s_per_tau_per_particle"], 3),
            pm(r["pressure_star"], r["pressure_star_error"]),
            pct(r.get("p_bias_extrap_rel")) + sd(r.get("p_bias_extrap_sigma")),
            pct(r.get("p_bias_ref_rel")) + sd(r.get("p_bias_ref_sigma")),
            pm(r["order_parameter"], r["order_parameter_error"]) if r["order_parameter"] is not None else "-",
            g(r.get("s_bias_extrap"), 3),
            g(r["energy_drift"], 2), g(r["max_overlap"], 3),
            # the exact method counts its candidate pairs there: its own table has them
            g(r["contacts_per_step"], 3) if r["method"] == "midpoint" else "-",
            g(r["multi_contact_bodies_per_step"], 3) if r["method"] == "midpoint" else "-"])
    return markdown_table(
        ["scene", "method", "dt", "solver tol", "cost (CPU s/tau/particle)", "P*", "P* bias vs dt->0",
         "P* vs SPEC", "S", "S bias vs dt->0", "energy drift /tau", "max overlap (D)", "contacts/step",
         "multi-contact bodies/step"], table_rows)


def exact_table(rows):
    """The exact method's work per step, or "" without exact points."""
    exact = [r for r in rows if r["method"] == "exact"]
    if not exact:
        return ""
    table_rows = [[r["scene"], g(r["dt"]), g(r["skin"]), r["status"] if not r["ok"] else g(r["ns_per_particle_step"], 3),
                   g(r.get("exact_collisions_per_step"), 4), g(r.get("exact_candidates_per_step"), 4),
                   g(r.get("exact_searches_per_step"), 4),
                   g(r.get("exact_root_iterations_per_search"), 3), g(r.get("exact_largest_cluster")),
                   g(r.get("exact_fallbacks")), g(r.get("neighbor_list_builds"))] for r in exact]
    return markdown_table(
        ["scene", "dt", "skin (D)", "ns/particle-step", "collisions/step", "candidate pairs/step", "root searches/step",
         "root iterations/search", "largest cluster", "fallbacks", "list builds"], table_rows)


def recommendations(analysis, target):
    """Per scene: the dt -> 0 fit, the recommended dt per method, the exact method's consistency
    and the cheaper method at the target, as markdown list items."""
    out = []
    for scene, a in analysis.items():
        fp = a["fit_pressure_star"]
        fit_txt = (f"P*(dt -> 0) = {pm(fp['value'], fp['error'])} from a weighted linear fit of the midpoint "
                   f"sweep over dt = {', '.join(g(x) for x in fp['points'])} (chi2 = {fp['chi2']:.2f} for "
                   f"{fp['dof']} dof)" if fp else "no dt -> 0 fit (it needs two midpoint dt <= --fit-max-dt)")
        fs = a["fit_order_parameter"]
        if fs:
            fit_txt += f"; S(dt -> 0) = {pm(fs['value'], fs['error'])}"
        lines = [f"- {scene} ({a['label']}): {fit_txt}."]
        for method, rec in a["methods"].items():
            skin = f", run.skin = {a['exact_skin']:g} D" if method == "exact" else ""
            lines.append(f"  - Recommended {method} dt (largest keeping P* within {target:g} % of dt -> 0{skin}): "
                         f"{rec['recommendation']}.")
        if a["exact_consistency"]:
            lines.append(f"  - {a['exact_consistency']['text']}.")
        if len(a["methods"]) > 1:
            lines.append(f"  - Cheaper at the {target:g} % target: {a['cheaper_at_target']['text']}.")
        out.append("\n".join(lines))
    return "\n".join(out)


def caveats(args, rows, analysis):
    if "nematic" in analysis and args.start:
        text = (f"The nematic starts at every dt from the last frame of {args.start} (an equilibrated run), "
                f"with fresh velocities and {args.equil_tau if args.equil_tau is not None else 'the preset'} "
                f"tau of equilibration at its own dt and method before production. ")
    elif "nematic" in analysis:
        text = ("The nematic starts from the aligned lattice (S = 1) at every dt, with the same simulated "
                "equilibration time for all dt (pass --start RUN/trajectory.h5 for an equilibrated start): "
                "its P* and S are averages over the same stretch of the relaxation, so they compare dt "
                "against dt, not against the equilibrium reference (the 'vs SPEC' column). ")
    else:
        text = ""
    text += ("Every dt starts from the same configuration and velocities (same seed), so short runs are correlated "
             "across dt and the bias errors, which treat them as independent, are if anything too large. Errors are "
             "block-averaged standard errors; the bias error combines the point's error with the extrapolation's. "
             "The dt -> 0 value is a fit of the midpoint sweep only; the exact method's points are measured against "
             "it, not fitted. Cost = wall x threads / (simulated time x N), equilibration included.")
    if any(r["method"] == "exact" for r in rows):
        # Why the exact points are not a dt trend: one dynamics, sampled again and again.
        text += (" The exact method's dynamics do not depend on dt (every collision at its exact time; only "
                 "round-off and the thermostat's rescaling differ), so its points at different dt start as the same "
                 "trajectory and part within a few tau only through round-off's chaotic growth: they are repeated "
                 "samples of one dynamics, and any spread among them beyond their error bars is sampling noise the "
                 "block errors missed, not a dt effect.")
    busy = busy_warning([r["load_average_1min"] for r in rows])
    return text + (" " + busy if busy else "")


def write_report(args, out, rows, analysis, results):
    """tradeoff.csv, tradeoff.md, tradeoff.json and pareto.png; the tables printed."""
    write_csv(out / "tradeoff.csv", rows, CSV_COLUMNS)
    table, work = main_table(rows), exact_table(rows)
    if work:
        table += "\n\nThe exact method's work per step:\n\n" + work
    recs, caveat = recommendations(analysis, args.target), caveats(args, rows, analysis)
    png = out / "pareto.png"
    plot_note = plot_pareto(rows, analysis, png, args.target)
    text = (report_header("Speed against accuracy (dt, collision method and solver tolerance sweep)") + table
            + "\n\n" + recs + "\n\n" + caveat + "\n\n"
            + ("![Pareto plot](pareto.png)\n" if not plot_note else plot_note + "\n"))
    write_text(out / "tradeoff.md", text)
    write_json(out / "tradeoff.json", {
        "command": invocation(), "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        "machine": machine_info(), "target_percent": args.target, "fit_max_dt": args.fit_max_dt,
        "points": rows, "analysis": analysis, "caveat": caveat,
        "commands": [r.run.shell() for r in results]})
    print("\n" + table + "\n\n" + recs + "\n\n" + caveat)
    if plot_note:
        print(plot_note)
    print(f"results in {relpath(out)}/ (tradeoff.csv, tradeoff.json, tradeoff.md, pareto.png, runs/)")
    return 0 if all(r["ok"] for r in rows) else 1
