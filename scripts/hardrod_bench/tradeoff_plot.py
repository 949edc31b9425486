"""The Pareto plot of `scripts/bench tradeoff`: error against cost, one curve per scene.

Plotting only (matplotlib, imported when called); the numbers come from tradeoff.py.
"""

import math
import os


def readable_log_axes(ax):
    """Plain numbers on log axes, labelled at 1, 2, 5 (or every integer) when the span is small."""
    from matplotlib import ticker
    for axis, (lo, hi) in ((ax.xaxis, ax.get_xlim()), (ax.yaxis, ax.get_ylim())):
        span = hi / lo
        subs = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0] if span < 3 else [1.0, 2.0, 5.0] if span < 100 else [1.0]
        axis.set_major_locator(ticker.LogLocator(base=10, subs=subs))
        axis.set_major_formatter(ticker.FuncFormatter(lambda v, _: f"{v:.3g}"))
        axis.set_minor_formatter(ticker.NullFormatter())


def plot_pareto(rows, analysis, path, target):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return "no plot: matplotlib is not available (scripts/setup installs python3-matplotlib)"
    has_s = any(r.get("s_bias_extrap") is not None for r in rows)
    fig, axes = plt.subplots(1, 2 if has_s else 1, figsize=(14 if has_s else 7.5, 6.4), squeeze=False)
    colors = {"hard-spheres": "tab:blue", "nematic": "tab:red"}
    tol_markers = ["s", "^", "v", "D", "P"]
    panels = [("p", "P* error against dt -> 0  (%)", axes[0][0])]
    if has_s:
        panels.append(("s", "S error against dt -> 0  (absolute)", axes[0][1]))
    for kind, ylabel, ax in panels:
        for scene in dict.fromkeys(r["scene"] for r in rows):
            pts = []
            for r in rows:
                if r["scene"] != scene or not r["ok"] or r["cost_cpu_s_per_tau_per_particle"] is None:
                    continue
                if kind == "p" and r.get("p_bias_extrap_rel") is not None:
                    # bias and statistical error in quadrature: what a user of that point would see
                    y = 100 * math.hypot(r["p_bias_extrap_rel"], (r["pressure_star_error"] or 0) / r["pressure_star"])
                elif kind == "s" and r.get("s_bias_extrap") is not None:
                    y = math.hypot(r["s_bias_extrap"], r["order_parameter_error"] or 0)
                else:
                    continue
                pts.append((r["cost_cpu_s_per_tau_per_particle"], y, r))
            sweep = sorted((p for p in pts if p[2]["kind"] == "dt"), key=lambda p: p[2]["dt"])
            c = colors.get(scene, None)
            if sweep:
                ax.plot([p[0] for p in sweep], [p[1] for p in sweep], "o-", color=c,
                        label=f"{analysis[scene]['label']}: dt sweep")
                for x, y, r in sweep:
                    ax.annotate(f"{r['dt']:g}", (x, y), textcoords="offset points", xytext=(4, 5), fontsize=8,
                                color=c)
            tols = sorted({p[2]["solver_tolerance"] for p in pts if p[2]["kind"] == "tolerance"}, reverse=True)
            for k, tol in enumerate(tols):
                tp = [p for p in pts if p[2]["kind"] == "tolerance" and p[2]["solver_tolerance"] == tol]
                ax.plot([p[0] for p in tp], [p[1] for p in tp], tol_markers[k % len(tol_markers)], mfc="none",
                        ms=8, color=c, label=f"{scene}: solver tolerance {tol:g} at dt = {tp[0][2]['dt']:g}")
        if kind == "p":
            ax.axhline(target, color="gray", ls="--", lw=1, label=f"{target:g} % target")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("cost: CPU seconds per simulated tau per particle")
        ax.set_ylabel(ylabel)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, frameon=False)
        readable_log_axes(ax)
    axes[0][0].set_title("P*: sqrt(bias^2 + error^2) against cost (labels: dt); lower left is better", fontsize=10)
    if has_s:
        axes[0][1].set_title("S (nematic): sqrt(bias^2 + error^2) against cost", fontsize=10)
    fig.tight_layout()
    tmp = path.with_name("tmp-" + path.name)
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    os.replace(tmp, path)
    return ""


