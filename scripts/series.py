"""Time-series statistics shared by the bench scripts: equilibration cut, block errors, drift."""

import math


def mser_cut(x, batch=5):
    """Samples to drop as equilibration: MSER-5 (White 1997), the cut d (in batches of 5, at most
    half the series) minimising the squared standard error of the rest, var / (n - d)."""
    m = len(x) // batch
    if m < 8:
        return 0
    y = [sum(x[i * batch:(i + 1) * batch]) / batch for i in range(m)]
    best, best_d = None, 0
    for d in range(0, m // 2 + 1):
        rest = y[d:]
        mean = sum(rest) / len(rest)
        score = sum((v - mean) ** 2 for v in rest) / len(rest) ** 2
        if best is None or score < best:
            best, best_d = score, d
    return best_d * batch


def conservative_block_error(x):
    """Largest naive standard error of the mean over blocking levels with >= 8 blocks: an upper
    bound when the series is too short for a plateau (the same fallback the program uses)."""
    best, y = 0.0, list(x)
    while len(y) >= 8:
        m = sum(y) / len(y)
        best = max(best, math.sqrt(sum((v - m) ** 2 for v in y) / (len(y) - 1) / len(y)))
        y = [(y[2 * i] + y[2 * i + 1]) / 2 for i in range(len(y) // 2)]
    return best if len(x) >= 8 else None


def drift_check(series):
    """Mean of the last third minus the first third of production, with its error."""
    k = len(series) // 3
    if k < 8:
        return None
    first, last = series[:k], series[-k:]
    e1, e2 = conservative_block_error(first), conservative_block_error(last)
    return {"first_third": sum(first) / k, "last_third": sum(last) / k, "drift": sum(last) / k - sum(first) / k,
            "drift_error": math.hypot(e1, e2)}
