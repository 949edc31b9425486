#!/usr/bin/env python3
"""Figures of a hardrod analysis (called by `hardrod analyze`, or by hand).

  scripts/plot_analysis.py --out DIR RUN_DIR [RUN_DIR ...]

Reads DIR/analysis.json and each run's timeseries.csv and angular.json; writes
  DIR/order_parameter.png  S(t) from the lattice start (the paper's figure 2),
  DIR/frank_cuts.png       E_13 and E_23 along k1^2 and k3^2 with the planar, cubic and
                           background fits (the paper's figure 3),
  DIR/frank_surfaces.png   E_13 and E_23 over (k1^2, k3^2) with the cubic fit (figure 4),
  DIR/angular.png          distribution of axes around the director / isotropic (figure 1).
"""
import argparse
import json
import os
import pathlib
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from hardrod_bench.outputs import timeseries_rows  # noqa: E402


def matplotlib_or_reexec():
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        return plt
    except ImportError:
        # Debian's python3-matplotlib lives in /usr/bin/python3's site-packages; a python3
        # earlier on PATH (pyenv) may not see it.
        if os.path.realpath(sys.executable) != os.path.realpath("/usr/bin/python3") and \
                os.path.exists("/usr/bin/python3"):
            os.execv("/usr/bin/python3", ["/usr/bin/python3", *sys.argv])
        sys.exit("plot_analysis: matplotlib is missing (apt-get install python3-matplotlib)")


def read_series(run):
    """A run's timeseries.csv rows, or None if it has none."""
    if not (pathlib.Path(run) / "timeseries.csv").exists():
        return None
    return timeseries_rows(run)


def evaluate(terms, x, y):
    return sum(a * (x ** i) * (y ** j) for i, j, a in terms)


def model_value(fit, name, x, y):
    """E of a fit at (k1^2, k3^2): the polynomial P, or P / (1 + b P) for the background model."""
    terms = fit.get("terms_" + name) or []
    if not terms:
        return None
    P = evaluate(terms, x, y)
    b = (fit.get("background_" + name) or {}).get("value")
    return P / (1.0 + b * P) if b is not None else P


def strip_means(bins, along, edges):
    """Inverse-variance means of E over intervals of k_along^2 (bins with a usable error only)."""
    out = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        pts = [b for b in bins if lo <= b[along] < hi]
        if not pts:
            continue
        w = [1.0 / b[3] ** 2 for b in pts]
        W = sum(w)
        out.append((sum(wi * b[along] for wi, b in zip(w, pts)) / W,
                    sum(wi * b[2] for wi, b in zip(w, pts)) / W, W ** -0.5))
    return out


def frank_cuts(plt, fr, path, max_k2, strip=0.03):
    """E_13 and E_23 along k1^2 (k3^2 < strip) and along k3^2 (k1^2 < strip): every bin faint,
    their inverse-variance means over intervals of k^2 with errors, and the three fits."""
    fig, axes = plt.subplots(2, 2, figsize=(9, 7))
    edges = [i * max_k2 / 24 for i in range(25)]
    for row, name in enumerate(("E13", "E23")):
        bins = [b for b in fr[name] if b[2] is not None and b[3] is not None and b[3] > 0 and b[2] > 0]
        for col, (label, along) in enumerate(((r"$k_1^2$", 0), (r"$k_3^2$", 1))):
            a = axes[row][col]
            other = 1 - along
            band = [b for b in bins if b[other] < strip and b[along] <= max_k2]
            if not band:
                continue
            a.plot([b[along] for b in band], [b[2] for b in band], ".", color="0.75", ms=2, label="bins")
            means = strip_means(band, along, edges)
            a.errorbar([m[0] for m in means], [m[1] for m in means], yerr=[m[2] for m in means], fmt="o",
                       ms=3, lw=0.8, color="k", label="simulation")
            fixed = sum(b[other] for b in band) / len(band)
            grid = [max_k2 * i / 60 for i in range(1, 61)]
            for model, style in (("planar", ":"), ("cubic", "-"), ("background", "--")):
                fit = fr.get(model) or {}
                ys = [model_value(fit, name, g, fixed) if along == 0 else model_value(fit, name, fixed, g)
                      for g in grid]
                if all(y is not None for y in ys):
                    r = fr["ranges"]  # each fit drawn over the range it was fitted on
                    lim = 2 * r["planar_max_k2"] if model == "planar" else \
                        r["cubic_max_k1sq"] if along == 0 else r["cubic_max_k3sq"]
                    xs = [g for g in grid if g <= lim]
                    a.plot(xs, ys[:len(xs)], style, lw=1, label=f"{model} fit")
            top = max(m[1] + m[2] for m in means) if means else 1.0
            a.set_ylim(0.0, 1.3 * top)
            a.set_xlabel(label)
            a.set_ylabel(r"$E_{%s}$" % name[1:])
            a.legend(fontsize=7)
    fig.suptitle("E_m3 = (9/4) S^2 V kT / <|Q_m3(k)|^2>: cuts along each axis (other k^2 < %g)" % strip)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def frank_surfaces(plt, fr, path):
    """E_13 and E_23 over (k1^2, k3^2) in the cubic fit's range: the bins as points, the cubic
    fit as a wire surface (the paper's figure 4)."""
    import numpy as np
    r = fr["ranges"]
    xmax, ymax = r["cubic_max_k1sq"], r["cubic_max_k3sq"]
    fig = plt.figure(figsize=(10, 4.5))
    for col, name in enumerate(("E13", "E23")):
        a = fig.add_subplot(1, 2, col + 1, projection="3d")
        bins = [b for b in fr[name] if b[2] is not None and b[0] <= xmax and b[1] <= ymax]
        if not bins:
            continue
        zs = sorted(b[2] for b in bins)
        ztop = 1.3 * zs[int(0.98 * (len(zs) - 1))]  # the few noisiest bins would flatten the rest
        bins = [b for b in bins if b[2] <= ztop]
        a.scatter([b[0] for b in bins], [b[1] for b in bins], [b[2] for b in bins], s=2, c="k", alpha=0.4)
        fit = fr.get("cubic") or {}
        if fit.get("terms_" + name):
            nx = 16
            X = [[xmax * i / nx for i in range(nx + 1)] for _ in range(nx + 1)]
            Y = [[ymax * j / nx] * (nx + 1) for j in range(nx + 1)]
            Z = [[model_value(fit, name, x, y) for x, y in zip(xr, yr)] for xr, yr in zip(X, Y)]
            a.plot_wireframe(np.array(X), np.array(Y), np.array(Z), color="C1", lw=0.6)
        a.set_xlabel(r"$k_1^2$")
        a.set_ylabel(r"$k_3^2$")
        a.set_zlabel(r"$E_{%s}$" % name[1:])
        a.set_zlim(0.0, ztop)
        a.view_init(elev=20, azim=-130)
    fig.suptitle("E_m3 over the cubic fit's range: bins (points) and the cubic fit (wire)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True)
    ap.add_argument("--max-k2", type=float, default=2.0, help="largest k^2 drawn in the cuts (default 2)")
    ap.add_argument("runs", nargs="+")
    args = ap.parse_args()
    plt = matplotlib_or_reexec()
    out = pathlib.Path(args.out)
    analysis = json.loads((out / "analysis.json").read_text())
    made = []

    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for run in args.runs:
        rows = read_series(run)
        if not rows:
            continue
        t = [float(r["time"]) for r in rows]
        s = [float(r["order_parameter"]) for r in rows]
        ax.plot(t, s, lw=1, label=pathlib.Path(run).name)
        prod = [float(r["time"]) for r in rows if r["phase"] == "production"]
        if prod:
            ax.axvline(prod[0], color="0.6", ls=":", lw=1)
    ax.set_xlabel(r"time / $\tau$")
    ax.set_ylabel("order parameter S")
    ax.set_title("relaxation from the aligned lattice (dotted: production starts)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "order_parameter.png", dpi=120)
    plt.close(fig)
    made.append("order_parameter.png")

    if "frank" in analysis:
        frank_cuts(plt, analysis["frank"], out / "frank_cuts.png", args.max_k2)
        frank_surfaces(plt, analysis["frank"], out / "frank_surfaces.png")
        made += ["frank_cuts.png", "frank_surfaces.png"]

    curves = []
    for run in args.runs:
        p = pathlib.Path(run) / "angular.json"
        if p.exists():
            curves.append(json.loads(p.read_text())["normalised"])
    if curves:
        n = len(curves[0])
        mean = [sum(c[i] for c in curves) / len(curves) for i in range(n)]
        centres = [(i + 0.5) / n for i in range(n)]
        fig, ax = plt.subplots(figsize=(6.4, 4.0))
        ax.plot(centres, mean, "o-", ms=3, lw=1)
        ax.axhline(1.0, color="0.6", ls=":", lw=1, label="isotropic")
        ax.set_xlabel(r"$|\cos\theta|$ to the director")
        ax.set_ylabel(r"$f(\cos\theta)$ / isotropic")
        ax.set_yscale("log")
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(out / "angular.png", dpi=120)
        plt.close(fig)
        made.append("angular.png")
    print("  plots               " + ", ".join(str(out / m) for m in made))


if __name__ == "__main__":
    main()
