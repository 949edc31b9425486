#!/usr/bin/env python3
"""scripts/beside_paper.py on made-up summaries: a run near the paper's values is within two
combined errors, one far from them is OUTSIDE, another system is not compared, and a missing
summary is an error naming the file."""

import json
import pathlib
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "scripts" / "beside_paper.py"


def run(summary):
    d = pathlib.Path(tempfile.mkdtemp(prefix="hardrod-beside-"))
    if summary is not None:
        (d / "summary.json").write_text(json.dumps(summary))
    return subprocess.run([sys.executable, str(SCRIPT), str(d)], capture_output=True, text=True)


def summary(S, P, rho=0.5):
    return {"n": 2304, "aspect_ratio": 5.0, "reduced_density": rho,
            "order_parameter": {"mean": S, "error": 0.004}, "pressure_star": {"mean": P, "error": 0.006}}


def main():
    near = run(summary(0.7230, 6.0226))
    assert near.returncode == 0 and near.stdout.count("within 2") == 2, near.stdout
    far = run(summary(0.80, 6.2))
    assert far.stdout.count("OUTSIDE 2") == 2, far.stdout
    other = run(summary(0.3, 1.0, rho=0.3))
    assert "not the paper's system" in other.stdout and "OUTSIDE" not in other.stdout, other.stdout
    missing = run(None)
    assert missing.returncode == 2 and "summary.json" in missing.stderr, missing.stderr
    print("beside_paper: near within, far outside, other system skipped, missing file named")
    return 0


if __name__ == "__main__":
    sys.exit(main())
