"""The report of `scripts/bench paper`: table1.md, table1.json and the figures.

For each system size: `hardrod analyze` over the finished seeds (OUT/nN/analysis.json, its
figures and its printed table in OUT/nN/analyze.log), the equilibration judged from each run's
S(t) (`equilibration_verdict`), then one table beside the paper's Table 1 and the literature.
"""

import json
import math
import sys
from pathlib import Path

from .common import HARDROD, ROOT, relpath
from .outputs import analyze_runs, order_parameter_series
from .stats import drift_check, mser

# The paper's Table 1 (N = 18432, rho* = 0.5, L/D = 5) and the rows it compares with; K in
# units of kT / D. Allen & Frenkel's K are rescaled by 9/4 as in the paper.
PAPER = {"P": (6.015, 0.020), "S": (0.727, 0.002),
         "planar": {"K1": (0.763, 0.045), "K2": (0.348, 0.024), "K3": (1.226, 0.045)},
         "cubic": {"K1": (0.812, 0.019), "K2": (0.352, 0.016), "K3": (1.583, 0.027)}}
LITERATURE = [
    ("Frenkel (MC)", "5.942", "", "", "", ""),
    ("Bolhuis & Frenkel (MC)", "5.995 +/- 0.059", "", "", "", ""),
    ("McGrother et al. (MC, rho* 0.497)", "5.94", "0.728 +/- 0.017", "", "", ""),
    ("McGrother et al. (MC, rho* 0.507)", "6.20", "0.754 +/- 0.020", "", "", ""),
    ("Allen & Frenkel (MC, x 9/4)", "", "0.73", "0.83 +/- 0.25", "0.59 +/- 0.07", "1.10 +/- 0.11"),
    ("Poniewierski & Stecki (DFT)", "", "0.728", "0.513", "0.239", "1.526"),
    ("Somoza & Tarazona (DFT)", "", "0.791", "0.630", "0.297", "2.403"),
    ("Lee (DFT, rho* 0.482)", "", "0.729", "1.322", "0.441", "6.447"),
]
FITS = ("cubic", "planar", "background")
CONSTANTS = ("K1", "K2", "K3", "K3_from_E13", "K3_from_E23")


def run_equilibration(run_dir):
    """One run's S(t) from the lattice start: the MSER-5 cut (White 1997, at most half the
    series) and the production's drift, mean S of the last third minus the first third."""
    t, phase, S = order_parameter_series(run_dir)
    cut, at_cap = mser(S)
    t_cut = t[cut] if cut < len(t) else float("nan")
    t_prod = next((ti for ti, p in zip(t, phase) if p == "production"), float("nan"))
    prod = [s for s, p in zip(S, phase) if p == "production"]
    return {"run": relpath(run_dir), "mser_cut_tau": t_cut, "cut_at_cap": bool(at_cap),
            "production_starts_tau": t_prod,
            "cut_inside_equilibration": bool(t_cut < t_prod and not at_cap), "drift": drift_check(prod)}


def mean_series_cut(runs):
    """The MSER-5 cut of S(t) averaged over the seeds (same sampling times): the relaxation from
    the lattice is common to all seeds, their slow fluctuations average down."""
    series_ = [order_parameter_series(ROOT / r["run"]) for r in runs]
    n = min(len(t) for t, _, _ in series_)
    if n == 0:
        return float("nan"), False
    mean = [sum(S[i] for _, _, S in series_) / len(series_) for i in range(n)]
    cut, at_cap = mser(mean)
    return (series_[0][0][cut] if cut < n else float("nan")), at_cap


def equilibration_verdict(runs):
    """Equilibrated when the MSER-5 cut of the seed-averaged S(t) falls inside the
    equilibration and the production drift, averaged over the seeds, is zero within 3 errors.
    The error is the seeds' spread: a run's own block error cannot see director modes slower
    than a third of the production (tens of tau), and a relaxation still under way would drift
    every seed the same way. With fewer than three seeds, each run's block error is used."""
    drifts = [r["drift"] for r in runs if r["drift"]]
    mean_cut, mean_at_cap = mean_series_cut(runs)
    # A cut at the search's cap is no cut: the series was still moving over its first half.
    cuts_ok = mean_cut < runs[0]["production_starts_tau"] and not mean_at_cap
    if len(drifts) >= 3:
        d = [x["drift"] for x in drifts]
        mean = sum(d) / len(d)
        error = math.sqrt(sum((x - mean) ** 2 for x in d) / (len(d) - 1) / len(d))
        how = f"mean over {len(d)} seeds, error from their spread"
    elif drifts:
        mean = sum(x["drift"] for x in drifts) / len(drifts)
        error = math.sqrt(sum(x["drift_error"] ** 2 for x in drifts)) / len(drifts)
        how = "block errors of the runs"
    else:
        return {"equilibrated": False, "why": "production too short for a drift check", "runs": runs}
    ok = cuts_ok and abs(mean) <= 3.0 * error
    return {"equilibrated": bool(ok), "drift": mean, "drift_error": error, "drift_error_from": how,
            "mean_series_cut_tau": mean_cut, "mean_series_cut_at_cap": bool(mean_at_cap),
            "cut_inside_equilibration": cuts_ok, "runs": runs}


def pm(e, digits=3):
    if not e or e.get("mean") is None:
        return "not determined"
    if e.get("error") is None:
        return f"{e['mean']:.{digits}f}"
    return f"{e['mean']:.{digits}f} +/- {e['error']:.{digits}f}"


def size_row(n, a, verdict, production_tau):
    fit = a.get("frank_recommended_fit")
    row = {"N": n, "runs": a["runs"], "fourier_samples": a.get("fourier_samples"),
           "production_tau": production_tau, "P": a["pressure_star"], "S": a["order_parameter"],
           "equilibrated": verdict["equilibrated"], "equilibration": verdict,
           "director_modes": a.get("director_modes"), "production_halves": a.get("production_halves"),
           "recommended_fit": fit, "recommended_fit_verdict": a.get("frank_fits", {}).get(fit)}
    for fit in FITS:
        row[fit] = {k: a[k][fit] for k in CONSTANTS if k in a}
    return row


def markdown(rows, args):
    lines = ["# The paper's Table 1 reproduced (`scripts/bench paper`)", "",
             f"rho* = 0.5, L/D = 5, {getattr(args, 'method', 'midpoint')} method, dt = {args.dt:g}, "
             f"{args.equil_tau:g} tau equilibration from the aligned "
             "lattice; K* = beta D K. Errors: S and P*, the larger of the runs' combined block errors and "
             "the seeds' spread; K, the larger of the fit's (bin variances from the spread over seeds, "
             "inflated by sqrt(chi2/dof) when above 1) and the spread of the seeds' own fits "
             "(docs/frank.md).", "",
             "| source | fit | P* | S | K1 | K2 | K3 | K3 (E13) | K3 (E23) | chi2/dof |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        who = f"hardrod N = {r['N']} ({r['runs']} seeds)"
        for i, fit in enumerate(FITS):
            f = r[fit]
            lines.append(f"| {who if i == 0 else ''} | {fit} | {pm(r['P']) if i == 0 else ''} | "
                         f"{pm(r['S'], 4) if i == 0 else ''} | {pm(f.get('K1'))} | {pm(f.get('K2'))} | "
                         f"{pm(f.get('K3'))} | {pm(f.get('K3_from_E13'))} | {pm(f.get('K3_from_E23'))} | "
                         f"{chi2(f.get('K3'))} |")
    for i, fit in enumerate(("cubic", "planar")):
        k = PAPER[fit]
        lines.append(f"| {'paper, N = 18432' if i == 0 else ''} | {fit} | "
                     f"{'%.3f +/- %.3f' % PAPER['P'] if i == 0 else ''} | {'%.3f +/- %.3f' % PAPER['S'] if i == 0 else ''} | "
                     + " | ".join("%.3f +/- %.3f" % k[c] for c in ("K1", "K2", "K3")) + " | | | |")
    for name, P, S, K1, K2, K3 in LITERATURE:
        lines.append(f"| {name} | | {P} | {S} | {K1} | {K2} | {K3} | | | |")
    lines += ["", "Equilibration, judged from S(t) sampled from t = 0: the MSER-5 cut of the seed-averaged "
              "S(t) inside the equilibration and below the search's cap (half the series), and the "
              "production drift (mean S of the last third - the first third), averaged over the seeds, "
              "zero within 3 errors (error from the seeds' spread):", ""]
    for r in rows:
        e = r["equilibration"]
        if "drift" in e:
            lines.append(f"- N = {r['N']}: cut of the mean S(t) at {e['mean_series_cut_tau']:.1f} tau "
                         + ("(at the search's cap: S(t) never settled), " if e.get("mean_series_cut_at_cap") else
                            f"({'inside' if e['cut_inside_equilibration'] else 'AFTER'} the equilibration), ")
                         + f"drift {e['drift']:+.4f} +/- {e['drift_error']:.4f} ({e['drift_error_from']}): "
                         + ("equilibrated" if e["equilibrated"] else "NOT EQUILIBRATED"))
        else:
            lines.append(f"- N = {r['N']}: NOT JUDGED ({e['why']})")
        for v in e["runs"]:
            d = v["drift"] or {}
            lines.append(f"  - {Path(v['run']).name}: MSER-5 cut at {v['mser_cut_tau']:.1f} tau"
                         f"{' (at the cap)' if v.get('cut_at_cap') else ''}, drift "
                         f"{d.get('drift', float('nan')):+.4f} (block error {d.get('drift_error', float('nan')):.4f})")
    lines += ["", "The Frank fits' input (`hardrod analyze`, docs/frank.md): the slowest director mode's "
              "lifetime (from its bins' spread over the seeds) against the equilibration, and the "
              "recommended fit on each half of the production:", ""]
    for r in rows:
        lines += frank_input_lines(r)
    return "\n".join(lines) + "\n"


def frank_input_lines(r):
    """One size's slowest director mode, the recommended fit on each production half, and its verdict."""
    lines, fit = [], r.get("recommended_fit")
    modes = r.get("director_modes") or {}
    slow = modes.get("slowest")
    if slow:
        relaxed = modes.get("relaxed_fraction")
        lines.append(f"- N = {r['N']}: slowest mode {slow['component']} = {slow['E']:.4f} lives "
                     f"{'>= ' if slow.get('lifetime_at_least') else '~'}{slow['lifetime_tau']:.0f} tau"
                     + (f", relaxed to {100 * relaxed:.1f} % by the production" if relaxed is not None else ""))
    h = (r.get("production_halves") or {}).get(fit)
    if h and h.get("max_pull") is not None:
        first, second = (", ".join(f"{k} {pm(h[half][k])}" for k in ("K1", "K2", "K3")) for half in ("first", "second"))
        lines.append(f"  - {fit} fit, first half: {first}; second half: {second}; "
                     f"largest pull {h['max_pull']:.1f} ({h['max_pull_in']})")
    elif h:
        lines.append(f"  - {fit} fit: halves not determined")
    v = r.get("recommended_fit_verdict")
    if v:
        lines.append(f"  - {fit} fit: " + ("trusted" if v["trusted"] else f"NOT TRUSTED: {v['reason']}"))
    return lines


def chi2(e):
    return f"{e['chi2_dof']:.2f}" if e and e.get("chi2_dof") is not None else "-"


def plot_order_parameter(rows, out):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return None
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for r in rows:
        runs = r["equilibration"]["runs"]
        for v in runs:
            t, _, S = order_parameter_series(ROOT / v["run"])
            ax.plot(t, S, lw=0.5, label=f"N = {r['N']}" if v is runs[0] else None,
                    color="C0" if r["N"] == 18432 else "C1")
        ax.axvline(runs[0]["production_starts_tau"], color="grey", lw=0.8, ls="--")
    ax.axhspan(PAPER["S"][0] - PAPER["S"][1], PAPER["S"][0] + PAPER["S"][1], color="k", alpha=0.15,
               label="paper, N = 18432")
    ax.set_xlabel("t / tau")
    ax.set_ylabel("S")
    ax.set_ylim(0.6, 1.0)
    ax.legend()
    path = out / "order_parameter.png"
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def difference(a, b):
    if a.get("mean") is None or b.get("mean") is None:
        return None
    return {"mean": a["mean"] - b["mean"], "error": math.hypot(a.get("error") or 0.0, b.get("error") or 0.0)}


def report(args, runs):
    out = Path(args.out)
    rows = []
    for n in args.sizes:
        done = [r.out for r in runs if r.n == n and r.state() == "done"]
        if not done:
            print(f"bench paper: no finished run at N = {n}", file=sys.stderr)
            continue
        a = analyze_runs(HARDROD, done, out / f"n{n}")
        production = next(r.prod_tau for r in runs if r.n == n)
        rows.append(size_row(n, a, equilibration_verdict([run_equilibration(d) for d in done]), production))
    if not rows:
        return 1
    result = {"method": getattr(args, "method", "midpoint"), "dt": args.dt, "equilibration_tau": args.equil_tau,
              "fourier_tau": getattr(args, "fourier_tau", None), "sizes": rows, "paper": PAPER}
    by_n = {r["N"]: r for r in rows}
    if 2304 in by_n and 18432 in by_n:
        result["S_2304_minus_S_18432"] = difference(by_n[2304]["S"], by_n[18432]["S"])
    (out / "table1.json").write_text(json.dumps(result, indent=2) + "\n")
    text = markdown(rows, args)
    if "S_2304_minus_S_18432" in result and result["S_2304_minus_S_18432"]:
        d = result["S_2304_minus_S_18432"]
        text += f"\nFinite size: S(2304) - S(18432) = {d['mean']:+.4f} +/- {d['error']:.4f}\n"
    (out / "table1.md").write_text(text)
    figure = plot_order_parameter(rows, out)
    print(text)
    print(f"written: {out / 'table1.md'}, {out / 'table1.json'}" + (f", {figure}" if figure else "")
          + "; per size: analysis.json, analyze.log and the fit figures in " + ", ".join(
              str(out / f"n{r['N']}") for r in rows))
    return 0 if all(r["equilibrated"] for r in rows) else 1
