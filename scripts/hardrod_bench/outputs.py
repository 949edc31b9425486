"""Reading what hardrod writes in a run directory: summary.json, timeseries.csv, analysis.json.

One place for the file names and the column and key names the harnesses rely on. It reads;
it does not judge (stats.py) or run anything but `hardrod analyze` (analyze_runs).
"""

import csv
import json
import subprocess
from pathlib import Path

from .common import ROOT, finite


def load_json(path):
    """A JSON file's content, or None if it is missing or incomplete."""
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def summary(run_dir):
    return load_json(Path(run_dir) / "summary.json")


def est(summary, key):
    """(mean, error, converged) of a block-averaged estimate in summary.json."""
    e = (summary or {}).get(key) or {}
    err = e.get("error")
    return e.get("mean"), (err if finite(err) else None), bool(e.get("converged"))


def timeseries_rows(run_dir):
    """timeseries.csv as a list of dicts (column name -> text)."""
    with open(Path(run_dir) / "timeseries.csv") as f:
        return list(csv.DictReader(f))


def production_series(run_dir, key, eta):
    """One production column of timeseries.csv (Z is P*/eta); [] if unreadable."""
    column = "pressure_star" if key == "compressibility_factor" else key
    try:
        vals = [float(r[column]) for r in timeseries_rows(run_dir) if r.get("phase") == "production"]
    except (OSError, KeyError, ValueError):
        return []
    return [v / eta for v in vals] if key == "compressibility_factor" and eta else vals


def production_t_s_p(run_dir):
    """(time, S, P*) of the production samples."""
    rows = [r for r in timeseries_rows(run_dir) if r.get("phase") == "production"]
    return ([float(r["time"]) for r in rows], [float(r["order_parameter"]) for r in rows],
            [float(r["pressure_star"]) for r in rows])


def order_parameter_series(run_dir):
    """(time, phase, S) of every sample, equilibration included."""
    rows = timeseries_rows(run_dir)
    return ([float(r["time"]) for r in rows], [r["phase"] for r in rows],
            [float(r["order_parameter"]) for r in rows])


def analyze_runs(hardrod, dirs, out):
    """`hardrod analyze DIRS --out OUT`, its output in OUT/analyze.log; OUT/analysis.json read back."""
    out.mkdir(parents=True, exist_ok=True)
    argv = [str(hardrod), "analyze", *map(str, dirs), "--out", str(out)]
    proc = subprocess.run(argv, cwd=ROOT, capture_output=True, text=True)
    (out / "analyze.log").write_text("$ " + " ".join(argv) + "\n" + proc.stdout + proc.stderr)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(argv)} failed (exit {proc.returncode}); see {out / 'analyze.log'}")
    return json.loads((out / "analysis.json").read_text())
