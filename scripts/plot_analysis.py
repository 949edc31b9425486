#!/usr/bin/env python3
"""Figures of a hardrod analysis (called by `hardrod analyze`, or by hand).

  scripts/plot_analysis.py --out DIR RUN_DIR [RUN_DIR ...]

Reads DIR/analysis.json and each run's timeseries.csv and angular.json; writes
  DIR/order_parameter.png  S(t) from the lattice start (the paper's figure 2),
  DIR/frank_cuts.png       E_13 and E_23 along k1^2 and k3^2 with the planar and cubic fits
                           (the paper's figure 3),
  DIR/angular.png          distribution of axes around the director / isotropic (figure 1).
"""
import argparse
import csv
import json
import os
import pathlib
import sys


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
    path = pathlib.Path(run) / "timeseries.csv"
    if not path.exists():
        return None
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return rows


def evaluate(terms, x, y):
    return sum(a * (x ** i) * (y ** j) for i, j, a in terms)


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
        fr = analysis["frank"]
        fig, axes = plt.subplots(2, 2, figsize=(9, 7))
        for row, name in enumerate(("E13", "E23")):
            bins = [b for b in fr[name] if b[2] is not None]
            if not bins:
                continue
            k1 = sorted({round(b[0], 6) for b in bins})
            k3 = sorted({round(b[1], 6) for b in bins})
            key = "terms_" + name
            for col, (label, along) in enumerate(((r"$k_1^2$", 0), (r"$k_3^2$", 1))):
                a = axes[row][col]
                other = 1 - along
                # The cut: bins in the lowest occupied band of the other variable.
                lowest = min(b[other] for b in bins)
                band = [b for b in bins if b[other] <= lowest + 0.011 and b[along] <= args.max_k2]
                band.sort(key=lambda b: b[along])
                xs = [b[along] for b in band]
                a.errorbar(xs, [b[2] for b in band], yerr=[b[3] or 0 for b in band], fmt="o", ms=3,
                           lw=0.8, label="simulation")
                if xs:
                    fixed = sum(b[other] for b in band) / len(band)
                    grid = [min(xs) * (1 - f) + max(xs) * f for f in [i / 50 for i in range(51)]]
                    for model, style in (("planar", "--"), ("cubic", "-")):
                        terms = fr[model].get(key) or []
                        if terms:
                            ys = [evaluate(terms, g, fixed) if along == 0 else evaluate(terms, fixed, g)
                                  for g in grid]
                            a.plot(grid, ys, style, lw=1, label=f"{model} fit")
                a.set_xlabel(label)
                a.set_ylabel(r"$E_{%s}$" % name[1:])
                a.legend(fontsize=7)
        fig.suptitle("E_m3 = (9/4) S^2 V kT / <|Q_m3(k)|^2>: cuts along each axis")
        fig.tight_layout()
        fig.savefig(out / "frank_cuts.png", dpi=120)
        plt.close(fig)
        made.append("frank_cuts.png")

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
