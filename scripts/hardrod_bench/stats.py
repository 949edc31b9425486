"""Time-series statistics of the bench harnesses: block averaging, equilibration, drift, fits.

`block_average` and `check_equilibration` are the program's own rules (kernels/block_average.cpp:
Flyvbjerg & Petersen blocking, Jonsson's lag-1 plateau test, the fallback to the largest error
over levels with at least 8 blocks), written with the same operations in the same order so
that they agree with the C++ to rounding (tests/scripts/check_statistics.py and
tests/kernels/test_block_average_fixture.cpp compare both against tests/fixtures/).
`conservative_block_error` is that fallback taken always: an upper bound when a series is too
short for a plateau. `mser_cut` (the MSER-5 equilibration cut), `drift_check` and
`linear_fit` are the harnesses' own tools; the program has no counterpart.

Pure Python, standard library only: the test scripts import it under any python3.
"""

import math
from dataclasses import dataclass

# Blocks needed at the chosen level for a converged estimate, and for a level to enter the
# fallback maximum (kernels/block_average.cpp: kConvergedBlocks, kFallbackBlocks).
CONVERGED_BLOCKS = 64
FALLBACK_BLOCKS = 8
EQUILIBRATION_MIN_SAMPLES = 16

# 99 % quantile of chi^2 with k degrees of freedom, k = 1..30; Wilson-Hilferty beyond.
_CHI2_99 = (6.634897, 9.210340, 11.344867, 13.276704, 15.086272, 16.811894, 18.475307, 20.090235,
            21.665994, 23.209251, 24.724970, 26.216967, 27.688250, 29.141238, 30.577914, 31.999927,
            33.408664, 34.805306, 36.190869, 37.566235, 38.932173, 40.289360, 41.638398, 42.979820,
            44.314105, 45.641683, 46.962942, 48.278236, 49.587884, 50.892181)


@dataclass
class Estimate:
    mean: float = 0.0
    error: float = 0.0       # standard error of the mean
    samples: int = 0
    block_size: int = 1      # samples per block at the level the error was taken from
    converged: bool = False  # plateau found at a level that still has >= 64 blocks


@dataclass
class Level:
    blocks: int    # n_l
    error: float   # naive standard error of the mean at this level
    lag1: float    # lag-1 autocorrelation of the block means (0 if they are all equal)


def chi2_quantile_99(k):
    if 1 <= k <= len(_CHI2_99):
        return _CHI2_99[k - 1]
    z = 2.3263478740408408  # standard normal 99 % quantile
    a = 2.0 / (9.0 * k)
    return k * (1.0 - a + z * math.sqrt(a)) ** 3


def blocking_levels(series):
    """Every blocking level with at least two blocks; level l + 1 averages pairs of level l
    (a trailing odd block is dropped)."""
    levels, blocks = [], [float(v) for v in series]
    while len(blocks) >= 2:
        n = len(blocks)
        total = 0.0
        for y in blocks:
            total += y
        mean = total / n
        sq = lag = 0.0
        for i in range(n):
            d = blocks[i] - mean
            sq += d * d
            if i + 1 < n:
                lag += d * (blocks[i + 1] - mean)
        levels.append(Level(n, math.sqrt(sq / (n * (n - 1.0))), lag / sq if sq > 0.0 else 0.0))
        blocks = [0.5 * (blocks[2 * i] + blocks[2 * i + 1]) for i in range(n // 2)]
    return levels


def decorrelated_level(levels):
    """Jonsson's test: the first level from which on no lag-1 correlation is detected."""
    count = len(levels)
    tail = [0.0] * (count + 1)  # tail[l] = sum over k >= l of n_k r_k^2
    for k in range(count - 1, -1, -1):
        tail[k] = tail[k + 1] + levels[k].blocks * levels[k].lag1 * levels[k].lag1
    for level in range(count):
        if tail[level] < chi2_quantile_99(count - level):
            return level
    return count - 1


def block_average(series):
    """Mean and standard error of a correlated series: the program's Estimate."""
    est = Estimate(samples=len(series))
    if not series:
        est.error = math.inf
        return est
    if not all(math.isfinite(v) for v in series):
        est.mean = est.error = math.nan
        return est
    total = 0.0
    for v in series:
        total += v
    est.mean = total / len(series)
    if len(series) == 1:
        est.error = math.inf
        return est
    if min(series) == max(series):
        est.mean, est.error, est.converged = float(series[0]), 0.0, True
        return est
    levels = blocking_levels(series)
    chosen = decorrelated_level(levels)
    at = levels[chosen]
    lag1_unbiased = at.lag1 + 1.0 / at.blocks
    if at.blocks >= CONVERGED_BLOCKS:
        est.error = at.error * math.sqrt(max(0.0, 1.0 + 2.0 * lag1_unbiased))
        est.block_size, est.converged = 1 << chosen, True
        return est
    worst = 0  # too few decorrelated blocks: the largest error over levels that still have a few
    for level in range(1, len(levels)):
        if levels[level].blocks >= FALLBACK_BLOCKS and levels[level].error > levels[worst].error:
            worst = level
    est.error, est.block_size = levels[worst].error, 1 << worst
    return est


def check_equilibration(series):
    """The program's `equilibrated`: first and last thirds converged and equal within 3 errors."""
    third = len(series) // 3
    first = block_average(series[:third])
    last = block_average(series[len(series) - third:])
    tolerance = 3.0 * math.hypot(first.error, last.error)
    ok = (len(series) >= EQUILIBRATION_MIN_SAMPLES and first.converged and last.converged
          and abs(first.mean - last.mean) <= tolerance)
    return {"first_mean": first.mean, "first_error": first.error, "last_mean": last.mean,
            "last_error": last.error, "equilibrated": bool(ok)}


def conservative_block_error(x):
    """Largest naive standard error of the mean over blocking levels with >= 8 blocks (the
    program's fallback, taken whatever the plateau test says); None below 8 samples."""
    if len(x) < FALLBACK_BLOCKS:
        return None
    return max(level.error for level in blocking_levels(x) if level.blocks >= FALLBACK_BLOCKS)


def mser(x, batch=5):
    """MSER-5 (White 1997): the cut d (in batches of 5, at most half the series) minimising the
    squared standard error of the rest, var / (n - d). Returns (samples to drop, at_cap): a cut
    at the search's cap (half the series) means the series never settled, not a cut."""
    m = len(x) // batch
    if m < 8:
        return 0, False
    y = [sum(x[i * batch:(i + 1) * batch]) / batch for i in range(m)]
    best, best_d = None, 0
    for d in range(0, m // 2 + 1):
        rest = y[d:]
        mean = sum(rest) / len(rest)
        score = sum((v - mean) ** 2 for v in rest) / len(rest) ** 2
        if best is None or score < best:
            best, best_d = score, d
    return best_d * batch, best_d == m // 2


def mser_cut(x, batch=5):
    """Samples to drop as equilibration by MSER-5 (`mser`), the cap not told apart."""
    return mser(x, batch)[0]


def drift_check(series):
    """Mean of the last third minus the first third of production, with its error."""
    k = len(series) // 3
    if k < 8:
        return None
    first, last = series[:k], series[-k:]
    e1, e2 = conservative_block_error(first), conservative_block_error(last)
    return {"first_third": sum(first) / k, "last_third": sum(last) / k, "drift": sum(last) / k - sum(first) / k,
            "drift_error": math.hypot(e1, e2)}


def normal_cdf(z):
    return 0.5 * (1.0 + math.erf(z / math.sqrt(2.0)))


def linear_fit(points):
    """Weighted least squares y = a + b x; points (x, y, sigma). Returns a, b, cov, chi2, dof."""
    w = [1.0 / s ** 2 for _, _, s in points]
    sw = sum(w)
    sx = sum(wi * x for wi, (x, _, _) in zip(w, points))
    sy = sum(wi * y for wi, (_, y, _) in zip(w, points))
    sxx = sum(wi * x * x for wi, (x, _, _) in zip(w, points))
    sxy = sum(wi * x * y for wi, (x, y, _) in zip(w, points))
    det = sw * sxx - sx * sx
    a = (sxx * sy - sx * sxy) / det
    b = (sw * sxy - sx * sy) / det
    cov = [[sxx / det, -sx / det], [-sx / det, sw / det]]
    chi2 = sum(wi * (y - a - b * x) ** 2 for wi, (x, y, _) in zip(w, points))
    return a, b, cov, chi2, len(points) - 2
