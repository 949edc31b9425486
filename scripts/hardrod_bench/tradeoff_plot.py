"""The Pareto plot of `scripts/bench tradeoff`: |bias| against cost for both collision methods.

One panel for P* (|bias| against the dt -> 0 value, in %) and, for the nematic, one for S
(absolute); a colour per scene, a marker and line style per method (midpoint: circles, solid;
exact: squares, dashed), each dt-sweep point labelled with its dt, the midpoint method's
solver-tolerance points hollow. Error bars are the bias's 1 sd; a |bias| below the panel's
floor (a tenth of its smallest error bar) is drawn on the floor. Plotting only (matplotlib,
imported when called); the numbers come from tradeoff.py.
"""

import os

SCENE_COLORS = {"hard-spheres": "tab:blue", "nematic": "tab:red"}
METHOD_STYLES = {"midpoint": {"marker": "o", "ls": "-"}, "exact": {"marker": "s", "ls": "--"}}
TOLERANCE_MARKERS = ["^", "v", "D", "P", "X"]


def readable_log_axes(ax):
    """Plain numbers on log axes, labelled at 1, 2, 5 (or every integer) when the span is small."""
    from matplotlib import ticker
    for axis, (lo, hi) in ((ax.xaxis, ax.get_xlim()), (ax.yaxis, ax.get_ylim())):
        span = hi / lo
        subs = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0] if span < 3 else [1.0, 2.0, 5.0] if span < 100 else [1.0]
        axis.set_major_locator(ticker.LogLocator(base=10, subs=subs))
        axis.set_major_formatter(ticker.FuncFormatter(lambda v, _: f"{v:.3g}"))
        axis.set_minor_formatter(ticker.NullFormatter())


def bias_of(r, panel):
    """(|bias|, its 1 sd) of a row in the panel's unit (P*: %, S: absolute), or None."""
    if panel == "p" and r.get("p_bias_extrap_rel") is not None:
        return abs(100 * r["p_bias_extrap_rel"]), 100 * (r.get("p_bias_extrap_rel_error") or 0.0)
    if panel == "s" and r.get("s_bias_extrap") is not None:
        return abs(r["s_bias_extrap"]), r.get("s_bias_extrap_error") or 0.0
    return None


def pareto_series(rows, panel):
    """{(scene, method, tolerance or None): [(cost, |bias|, sd, row)]}, dt sweeps sorted by dt: what
    one panel draws (the plot test reads this rather than the picture)."""
    series = {}
    for r in rows:
        cost, b = r.get("cost_cpu_s_per_tau_per_particle"), bias_of(r, panel)
        if not r["ok"] or cost is None or b is None:
            continue
        tol = r["solver_tolerance"] if r["kind"] == "tolerance" else None
        series.setdefault((r["scene"], r["method"], tol), []).append((cost, b[0], b[1], r))
    for pts in series.values():
        pts.sort(key=lambda p: p[3]["dt"])
    return series


def draw_panel(ax, series, panel, target):
    errors = [p[2] for pts in series.values() for p in pts if p[2] > 0]
    floor = 0.1 * min(errors) if errors else 1e-4
    tol_rank = {t: k for k, t in enumerate(sorted({k[2] for k in series if k[2] is not None}, reverse=True))}
    for (scene, method, tol), pts in series.items():
        color, style = SCENE_COLORS.get(scene), METHOD_STYLES.get(method, {"marker": "x", "ls": ":"})
        xs = [p[0] for p in pts]
        ys = [max(p[1], floor) for p in pts]
        lower = [y - max(y - p[2], 0.5 * floor) for y, p in zip(ys, pts)]
        upper = [p[2] for p in pts]
        if tol is None:
            ax.errorbar(xs, ys, yerr=[lower, upper], color=color, marker=style["marker"], ls=style["ls"],
                        capsize=2, elinewidth=0.8, label=f"{scene}: {method}, dt sweep")
            for x, y, p in zip(xs, ys, pts):
                ax.annotate(f"{p[3]['dt']:g}", (x, y), textcoords="offset points", xytext=(4, 5), fontsize=8,
                            color=color)
        else:
            ax.errorbar(xs, ys, yerr=[lower, upper], color=color, ls="none", mfc="none", ms=8, capsize=2,
                        marker=TOLERANCE_MARKERS[tol_rank[tol] % len(TOLERANCE_MARKERS)],
                        label=f"{scene}: midpoint, solver tol {tol:g}, dt {pts[0][3]['dt']:g}")
    if panel == "p":
        ax.axhline(target, color="gray", ls=":", lw=1, label=f"{target:g} % target")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("cost: CPU seconds per simulated tau per particle")
    ax.set_ylabel("|P* bias| against dt -> 0  (%)" if panel == "p" else "|S bias| against dt -> 0  (absolute)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7.5, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2, frameon=False)
    readable_log_axes(ax)


def plot_pareto(rows, analysis, path, target):
    """pareto.png; "" when drawn, else why not."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return "no plot: matplotlib is not available (scripts/setup installs python3-matplotlib)"
    panels = [("p", pareto_series(rows, "p"))]
    s_series = pareto_series(rows, "s")
    if s_series:
        panels.append(("s", s_series))
    if not panels[0][1]:
        return "no plot: no point has both a cost and a P* bias (is there a dt -> 0 fit?)"
    fig, axes = plt.subplots(1, len(panels), figsize=(7.5 * len(panels), 7.0), squeeze=False)
    for (panel, series), ax in zip(panels, axes[0]):
        draw_panel(ax, series, panel, target)
    axes[0][0].set_title("P*: |bias| (1 sd bars) against cost, labels: dt; lower left is better", fontsize=10)
    if len(panels) > 1:
        axes[0][1].set_title("S (nematic): |bias| (1 sd bars) against cost", fontsize=10)
    fig.suptitle("; ".join(a["label"] for a in analysis.values()), fontsize=9)
    fig.tight_layout()
    tmp = path.with_name("tmp-" + path.name)
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    os.replace(tmp, path)
    return ""
