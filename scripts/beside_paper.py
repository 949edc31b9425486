#!/usr/bin/env python3
"""A run's S and P* beside the paper's Table 1 (L/D = 5, rho* = 0.5, N = 18432): the
difference with the two errors combined, and whether it lies within two of them.

  scripts/beside_paper.py RUN_DIR
"""

import json
import math
import pathlib
import sys

PAPER = {"order_parameter": ("S", 0.727, 0.002), "pressure_star": ("P*", 6.015, 0.020)}


def main():
    if len(sys.argv) != 2:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    path = pathlib.Path(sys.argv[1]) / "summary.json"
    try:
        summary = json.loads(path.read_text())
    except (OSError, ValueError) as e:
        print(f"beside_paper: {path}: {e}", file=sys.stderr)
        return 2
    rho, aspect = summary.get("reduced_density"), summary.get("aspect_ratio")
    if rho is None or aspect is None or not (math.isclose(rho, 0.5, rel_tol=1e-6)
                                             and math.isclose(aspect, 5.0, rel_tol=1e-9)):
        print(f"beside_paper: {path}: not the paper's system (L/D = 5, rho* = 0.5); nothing to compare")
        return 0
    print("\nbeside the paper's Table 1 (N = 18432; this run N = {}):".format(summary.get("n")))
    for key, (name, value, error) in PAPER.items():
        e = summary.get(key) or {}
        mean, own = e.get("mean"), e.get("error")
        if mean is None or own is None:
            print(f"  {name:<4} not determined in this run")
            continue
        combined = math.hypot(own, error)
        sd = (mean - value) / combined
        verdict = "within" if abs(sd) <= 2.0 else "OUTSIDE"
        print(f"  {name:<4} {mean:.4f} +/- {own:.4f}   paper {value:.3f} +/- {error:.3f}   "
              f"difference {mean - value:+.4f} ({sd:+.1f} combined errors: {verdict} 2)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
