#!/usr/bin/env python3
"""The bench's block averaging (scripts/hardrod_bench/stats.py) against the shared fixture.

tests/fixtures/block_average_series.txt holds a few series (AR(1) at several correlations,
white noise, a trend, a constant, a very short one); tests/fixtures/block_average_expected.txt
the Estimate and the equilibration check of each, as stats.py computes them. This script
checks that stats.py still gives those numbers (to 1e-12); the GoogleTest
tests/kernels/test_block_average_fixture.cpp checks that the C++ (kernels/block_average.cpp)
gives them too, so the two implementations agree.

  check_statistics.py            compare (ctest: statistics.python_fixture)
  check_statistics.py --write    regenerate both fixture files (seeded, deterministic)
"""

import math
import pathlib
import random
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "scripts"))
from hardrod_bench.stats import block_average, check_equilibration  # noqa: E402

SERIES = ROOT / "tests" / "fixtures" / "block_average_series.txt"
EXPECTED = ROOT / "tests" / "fixtures" / "block_average_expected.txt"
TOLERANCE = 1e-12
SEED = 2026


def ar1(rng, phi, n, mean=0.0, trend=0.0):
    """x_{i+1} = phi x_i + sqrt(1 - phi^2) e_i (unit variance), plus mean + trend * i."""
    x, out = rng.gauss(0.0, 1.0), []
    for i in range(n):
        out.append(mean + trend * i + x)
        x = phi * x + math.sqrt(1.0 - phi * phi) * rng.gauss(0.0, 1.0)
    return out


def generate():
    rng = random.Random(SEED)
    series = {
        "ar1_phi0.5_n2048": ar1(rng, 0.5, 2048, mean=6.0),         # plateau with >= 64 blocks
        "ar1_phi0.95_n1024": ar1(rng, 0.95, 1024, mean=0.73),      # too correlated: the fallback
        "white_n1000": ar1(rng, 0.0, 1000, mean=-1.0),
        "ar1_phi0.9_n300": ar1(rng, 0.9, 300),
        "trend_n512": ar1(rng, 0.3, 512, trend=0.01),              # not equilibrated
        "short_n5": ar1(rng, 0.0, 5),
        "constant_n10": [0.7] * 10,
    }
    # 12 significant digits: both readers parse the same text into the same doubles.
    return {k: [float(f"{v:.12g}") for v in vs] for k, vs in series.items()}


def read_series(path):
    tokens = [t for line in path.read_text().splitlines() if not line.startswith("#") for t in line.split()]
    series, i = {}, 0
    while i < len(tokens):
        name, n = tokens[i], int(tokens[i + 1])
        series[name] = [float(v) for v in tokens[i + 2:i + 2 + n]]
        i += 2 + n
    return series


def results(values):
    e = block_average(values)
    q = check_equilibration(values)
    return [e.mean, e.error, e.samples, e.block_size, int(e.converged), q["first_mean"], q["first_error"],
            q["last_mean"], q["last_error"], int(q["equilibrated"])]


COLUMNS = ("name mean error samples block_size converged first_mean first_error last_mean last_error "
           "equilibrated")


def write(series):
    lines = [f"# Series for the block-averaging fixture: random.Random({SEED}).gauss, written by",
             "# tests/scripts/check_statistics.py --write. Format: NAME COUNT, then COUNT values."]
    for name, values in series.items():
        lines.append(f"{name} {len(values)}")
        lines += [" ".join(f"{v:.12g}" for v in values[i:i + 8]) for i in range(0, len(values), 8)]
    SERIES.parent.mkdir(exist_ok=True)
    SERIES.write_text("\n".join(lines) + "\n")
    out = ["# block_average and check_equilibration of each series in block_average_series.txt, as",
           "# scripts/hardrod_bench/stats.py computes them (check_statistics.py --write).", "# " + COLUMNS]
    for name, values in series.items():
        out.append(name + " " + " ".join(repr(float(v)) if isinstance(v, float) else str(v)
                                         for v in results(values)))
    EXPECTED.write_text("\n".join(out) + "\n")
    print(f"wrote {SERIES} and {EXPECTED}")


def close(a, b):
    if math.isnan(b):
        return math.isnan(a)
    if math.isinf(b):
        return a == b
    return abs(a - b) <= TOLERANCE * max(1.0, abs(b))


def compare(series):
    expected = {}
    for line in EXPECTED.read_text().splitlines():
        if line and not line.startswith("#"):
            name, *values = line.split()
            expected[name] = [float(v) for v in values]
    failures = 0
    for name, values in series.items():
        got, want = results(values), expected.get(name)
        if want is None:
            print(f"FAIL: {name}: not in {EXPECTED.name}")
            failures += 1
            continue
        bad = [f"{c}: {g!r} != {w!r}" for c, g, w in zip(COLUMNS.split()[1:], got, want) if not close(g, w)]
        print(f"{name}: mean {got[0]:.6g} error {got[1]:.4g} block {got[3]} converged {bool(got[4])} "
              f"equilibrated {bool(got[9])}" + ("" if not bad else "  FAIL " + "; ".join(bad)))
        failures += bool(bad)
    converged = {bool(v[4]) for v in expected.values()}
    if converged != {True, False}:
        print("FAIL: the fixture must have both a converged and a fallback series")
        failures += 1
    return 1 if failures else 0


def main():
    if "--write" in sys.argv[1:]:
        write(generate())
        return 0
    return compare(read_series(SERIES))


if __name__ == "__main__":
    sys.exit(main())
