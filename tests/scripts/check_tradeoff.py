#!/usr/bin/env python3
"""`scripts/bench tradeoff` without running hardrod: both collision methods in one sweep.

1. The dry run of the quick preset: every run carries its method (the exact ones
   run.method = "exact" and the exact method's own run.skin, per scene), the solver-tolerance
   points are midpoint-only, every point runs the same simulated time, and with --start the
   nematic runs (and only they) start from that file.
2. Bad --methods, --exact-dts and --exact-skin values are refused, naming the flag and the value.
3. The analysis on fake runs: a results directory of synthetic summary.json files (a midpoint
   P* falling linearly with dt, an exact P* flat in dt, except a biased nematic point at 3e-3) read through `--reuse`, so the whole harness runs as a user runs it. Checked:
   the method column of tradeoff.csv, the dt -> 0 value fitted from the midpoint sweep only,
   the recommended dt per method, the exact method's consistency (in sd) and the cheaper method
   at the target, the exact method's work in the report, and the Pareto plot's series: both
   methods for both scenes, the tolerance points midpoint-only, and pareto.png written; and
   with --methods exact alone (no midpoint sweep to fit), no recommendation, saying why.
"""

import csv
import json
import math
import pathlib
import tempfile

from bench_cli import check, run_cli
from hardrod_bench import cli, tradeoff, tradeoff_plot

START = "/nonexistent/equilibrated/trajectory.h5"  # never opened: nothing runs
P0 = {"hard-spheres": 4.2234, "nematic": 6.015}
REL_ERROR = 0.001   # every point's P* error, relative
MIDPOINT_SLOPE = -10.0  # relative P* bias per unit dt: -0.3 % at 3e-4, -1 % at 1e-3


def dry_run():
    status, text = run_cli(["tradeoff", "--quick", "--dry-run", "--start", START, "--jobs", "1"])
    check(status == 0, "the quick dry run succeeds")
    lines = [l for l in text.splitlines() if "build/hardrod run" in l]
    exact = [l for l in lines if "run.method=" in l]
    check(len(lines) == 2 * (5 + 3 + 3) and len(exact) == 2 * 3,
          f"quick preset: per scene 5 midpoint dt + 3 tolerances + 3 exact dt ({len(lines)} runs, {len(exact)} exact)")
    check(all("'run.method=\"exact\"'" in l for l in exact), "the exact runs set run.method = \"exact\"")
    check(all("run.skin=0.5" in l for l in exact if "hard-spheres" in l)
          and all("run.skin=1.0" in l for l in exact if "everyday" in l),
          "the exact runs carry their own skin: 0.5 D for spheres, 1.0 D for rods")
    check(not any("run.skin" in l or "run.method" in l for l in lines if l not in exact),
          "the midpoint runs keep the scene's method and skin")
    check(not any("solver_tolerance" in l for l in exact), "the solver-tolerance points are midpoint-only")
    for l in lines:
        words = dict(w.split("=", 1) for w in l.split() if w.startswith("run."))
        tau = float(words["run.dt"]) * (int(words["run.steps"]) + int(words["run.equilibration_steps"]))
        want = 11.0 if "hard-spheres" in l else 6.0
        if abs(tau - want) > 1e-3 * want:
            check(False, f"equal simulated time at every dt: {tau} tau instead of {want} in {l}")
    check(True, "every point runs the same simulated time (11 tau spheres, 6 tau nematic)")
    check(all(("init.file" in l) == ("everyday" in l) for l in lines),
          "with --start the nematic runs (and only they) start from the given file")
    check("exact method's run.skin: hard-spheres 0.5 D, nematic 1 D" in text, "the dry run states the exact skin")


def refusals():
    for argv, names in ((["--methods", "midpoint,eventdriven"], "--methods 'midpoint,eventdriven'"),
                        (["--methods", ""], "--methods ''"),
                        (["--exact-dts", "1e-3,-2e-3"], "--exact-dts '1e-3,-2e-3'"),
                        (["--exact-dts", "1e-3,fast"], "--exact-dts '1e-3,fast'"),
                        (["--exact-skin", "nan"], "--exact-skin nan"),
                        (["--exact-skin", "0"], "--exact-skin 0.0")):
        status, _ = run_cli(["tradeoff", "--dry-run", *argv])
        check(isinstance(status, str) and names in status, f"refused, naming the flag and value: {status}")


def fake_summary(run, index):
    """A completed run's summary.json: P* on the model line, cost falling with dt."""
    m = run.meta
    scene, method, dt = m["scene"], m["method"], m["dt"]
    if method == "midpoint":
        rel = MIDPOINT_SLOPE * dt * (1.5 if m["tolerance"] == 1e-4 else 1.0)
        ns = 8.0 * (1e-4 / dt) ** 0.25  # ns per particle-step: the list rebuilds dominate at large dt
    else:
        rel = 0.0004 * (-1) ** index  # noise well within its error bar
        if scene == "nematic" and dt == 3e-3:
            rel = 0.01  # too large a step for the rods: +1 %, 7 sd
        ns = 60.0
    n, tau = m["n"], m["equilibration_tau"] + m["production_tau"]
    steps = round(tau / dt)
    p = P0[scene] * (1 + rel)
    est = lambda mean, err: {"mean": mean, "error": err, "samples": 500, "converged": True}  # noqa: E731
    summary = {"status": "completed", "n": n, "steps_done": steps, "simulated_time": tau, "threads": 1,
               "wall_seconds": ns * 1e-9 * n * steps, "ns_per_particle_step": ns,
               "pressure_star": est(p, REL_ERROR * P0[scene]), "compressibility_factor": est(p / 0.45, 0.01),
               "order_parameter": est(0.73 + rel, 0.002), "energy_drift": 0.0, "max_overlap": 1e-3,
               "contacts_per_step": 3.0, "multi_contact_bodies": 10, "neighbor_list_builds": 100,
               "method": method}
    if method == "exact":
        summary["exact"] = {"steps": steps, "collisions": 40 * steps, "searches": 300 * steps,
                            "candidates": 360 * steps, "root_iterations_per_search": 1.27, "largest_cluster": 23,
                            "fallbacks": 0, "collisions_per_step": 40.0}
    return summary


def fake_results(tmp):
    """A results directory of completed fake runs of the quick preset, as `--reuse` reads them."""
    args = cli.parser().parse_args(["tradeoff", "--quick", "--start", START])
    fake = tmp / "fake"
    runs = tradeoff.tradeoff_runs(args, fake)
    for i, run in enumerate(runs):
        run.out.mkdir(parents=True)
        (run.out / "summary.json").write_text(json.dumps(fake_summary(run, i)))
        (run.out / "hardrod.log").write_text("$ " + run.shell() + "\n")
    return fake


def analysis(tmp):
    fake = fake_results(tmp)
    tradeoff.ensure_built = lambda *a: None  # nothing runs: every run is reused
    status, text = run_cli(["tradeoff", "--quick", "--start", START, "--jobs", "1", "--reuse", str(fake),
                            "--results", str(tmp / "out")])
    check(status == 0, f"the harness analyses the fake runs (exit status {status})")
    out = next((tmp / "out").glob("tradeoff-*"))
    with open(out / "tradeoff.csv") as f:
        rows = list(csv.DictReader(f))
    check({r["method"] for r in rows} == {"midpoint", "exact"} and len(rows) == 22,
          "tradeoff.csv: one row per run, each with its method")
    check(all(r["method"] == "midpoint" for r in rows if r["kind"] == "tolerance"),
          "tradeoff.csv: the tolerance rows are midpoint rows")
    check(all(r["exact_searches_per_step"] == "300.0" for r in rows if r["method"] == "exact"),
          "tradeoff.csv: the exact method's searches per step")
    report = json.loads((out / "tradeoff.json").read_text())
    a = report["analysis"]
    for scene in P0:
        fit = a[scene]["fit_pressure_star"]
        check(math.isclose(fit["value"], P0[scene], rel_tol=1e-9) and fit["points"] == [1e-5, 3e-5, 1e-4],
              f"{scene}: P*(dt -> 0) = {fit['value']:.5f} from the midpoint sweep only")
        check(a[scene]["methods"]["midpoint"]["recommended_dt"] == 3e-4,
              f"{scene}: midpoint recommended dt 3e-4 (-0.3 %; 1e-3 is -1 %)")
        check(a[scene]["recommended_dt"] == 3e-4, f"{scene}: the midpoint recommendation kept at its old key")
    hs, nem = a["hard-spheres"], a["nematic"]
    check(hs["methods"]["exact"]["recommended_dt"] == 4e-3, "hard spheres: exact recommended dt 4e-3")
    check(nem["methods"]["exact"]["recommended_dt"] == 2e-3, "nematic: exact recommended dt 2e-3 (3e-3 is +1 %)")
    check(hs["exact_consistency"]["consistent"] is True and nem["exact_consistency"]["consistent"] is False,
          "exact consistency with dt -> 0: yes for the spheres, no for the nematic")
    sd = [p["sigma_extrapolated"] for p in nem["exact_consistency"]["points"]]
    check(sd[-1] > 5 and all(abs(x) < 1 for x in sd[:-1]),
          f"nematic exact bias in sd at 1e-3, 2e-3, 3e-3: {', '.join(f'{x:+.1f}' for x in sd)}")
    # cost per particle per tau = ns / dt (to the rounding of the step counts): midpoint 8 (1e-4/3e-4)^0.25 / 3e-4, exact 60 / dt
    want = {"hard-spheres": ("exact", (8.0 * (1 / 3) ** 0.25 / 3e-4) / (60.0 / 4e-3)),
            "nematic": ("midpoint", (60.0 / 2e-3) / (8.0 * (1 / 3) ** 0.25 / 3e-4))}
    for scene, (method, ratio) in want.items():
        c = a[scene]["cheaper_at_target"]
        check(c["method"] == method and math.isclose(c["ratio"], ratio, rel_tol=1e-4),
              f"{scene}: cheaper at the target: {c['method']} by {c['ratio']:.3f}x ({ratio:.3f}x expected)")
    md = (out / "tradeoff.md").read_text()
    check("| scene        | method   |" in md and "root iterations/search" in md and "largest cluster" in md,
          "tradeoff.md: the method column and the exact method's work table")
    check("Recommended exact dt" in md and "Recommended midpoint dt" in md and "Cheaper at the 0.5 % target" in md,
          "tradeoff.md: the recommendation per method and the cheaper one")
    check("run.skin = 1 D" in md and "run.skin = 0.5 D" in md, "tradeoff.md: the exact method's skin stated")
    plot(report["points"], a, out)
    exact_only(tmp, fake)


def exact_only(tmp, fake):
    """--methods exact alone: no dt -> 0 fit, so no recommendation, said so; the references still."""
    status, text = run_cli(["tradeoff", "--quick", "--start", START, "--jobs", "1", "--methods", "exact",
                            "--reuse", str(fake), "--results", str(tmp / "exact-only")])
    out = next((tmp / "exact-only").glob("tradeoff-*"))
    a = json.loads((out / "tradeoff.json").read_text())["analysis"]
    check(status == 0 and set(a["nematic"]["methods"]) == {"exact"}
          and a["nematic"]["methods"]["exact"]["recommended_dt"] is None
          and a["nematic"]["cheaper_at_target"]["text"] == "no dt -> 0 fit to measure the biases against",
          "--methods exact alone: no fit, no recommendation, and the report says why")
    with open(out / "tradeoff.csv") as f:
        rows = list(csv.DictReader(f))
    check(len(rows) == 6 and all(r["method"] == "exact" and abs(float(r["p_bias_ref_rel"])) <= 0.0101 for r in rows),
          "--methods exact alone: six exact rows, each with its bias against the reference")


def plot(rows, analysis, out):
    for panel, scenes in (("p", {"hard-spheres", "nematic"}), ("s", {"nematic"})):
        series = tradeoff_plot.pareto_series(rows, panel)
        sweeps = {(s, m) for s, m, tol in series if tol is None}
        check(sweeps == {(s, m) for s in scenes for m in ("midpoint", "exact")},
              f"Pareto panel {panel}: a dt sweep per scene and method: {sorted(sweeps)}")
        check({m for _, m, tol in series if tol is not None} == {"midpoint"},
              f"Pareto panel {panel}: the tolerance points are midpoint-only")
        exact = series[("nematic", "exact", None)]
        check([p[3]["dt"] for p in exact] == [1e-3, 2e-3, 3e-3] and all(p[1] >= 0 for p in exact),
              f"Pareto panel {panel}: the exact sweep in dt order with |bias|")
    png = out / "pareto.png"
    check(png.exists() and png.stat().st_size > 10000 and png.read_bytes()[:4] == b"\x89PNG",
          f"pareto.png written ({png.stat().st_size} bytes)")


def exact_work():
    """A run whose every step took its events in one queue formed no clusters: its largest
    cluster is shown as "-", not as 0; a run by cluster keeps its own."""
    queued = tradeoff.exact_work({"exact": {"steps": 10, "queued_steps": 10, "largest_cluster": 0}}, 10)
    check(queued["largest_cluster"] is None, "one queue: no largest cluster")
    clustered = tradeoff.exact_work({"exact": {"steps": 10, "queued_steps": 0, "largest_cluster": 7}}, 10)
    check(clustered["largest_cluster"] == 7, "by cluster: the largest cluster as counted")


def main():
    dry_run()
    refusals()
    exact_work()
    with tempfile.TemporaryDirectory(prefix="hardrod-tradeoff-") as tmp:
        analysis(pathlib.Path(tmp))
    print("all tradeoff harness checks passed")


if __name__ == "__main__":
    main()
