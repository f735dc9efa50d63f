"""Aggregates over the seeds of a campaign and their 95 % confidence intervals, distribution-free.

Quantiles interpolate between order statistics (numpy's default, Hyndman-Fan type 7). A quantile's
interval is the pair of order statistics whose binomial coverage is at least 95 % with at most 2.5 % in
each tail (Hahn & Meeker, Statistical Intervals, sec. 5.2): with too few runs one end does not exist and
is reported as None. A fraction's interval is Clopper-Pearson's (exact binomial).
"""
import math

LEVEL = 0.95


def quantile(values, q):
    v = sorted(values)
    if not v:
        return None
    h = (len(v) - 1) * q
    lo = math.floor(h)
    return v[lo] + (h - lo) * (v[min(lo + 1, len(v) - 1)] - v[lo])


def _binom_cdf(k, n, p):
    """P(B <= k) for B ~ Binomial(n, p)."""
    if k < 0:
        return 0.0
    if k >= n:
        return 1.0
    return sum(math.comb(n, i) * p ** i * (1 - p) ** (n - i) for i in range(k + 1))


def quantile_interval(values, q, level=LEVEL):
    """(low, high) order statistics bracketing the q-quantile with the given coverage; None for a missing end."""
    v = sorted(values)
    n = len(v)
    if n == 0:
        return None, None
    tail = (1 - level) / 2
    # Ranks are 1-based: X(l) is below the quantile unless B < l, X(u) above it unless B >= u.
    lows = [r for r in range(1, n + 1) if _binom_cdf(r - 1, n, q) <= tail]
    highs = [r for r in range(1, n + 1) if 1 - _binom_cdf(r - 1, n, q) <= tail]
    return (v[max(lows) - 1] if lows else None), (v[min(highs) - 1] if highs else None)


def fraction_interval(k, n, level=LEVEL):
    """Clopper-Pearson interval of a fraction k / n."""
    if n == 0:
        return None, None
    tail = (1 - level) / 2

    def solve(f, target):  # f increasing in p on [0, 1]
        lo, hi = 0.0, 1.0
        for _ in range(60):
            mid = (lo + hi) / 2
            lo, hi = (mid, hi) if f(mid) < target else (lo, mid)
        return (lo + hi) / 2

    low = 0.0 if k == 0 else solve(lambda p: 1 - _binom_cdf(k - 1, n, p), tail)
    high = 1.0 if k == n else solve(lambda p: 1 - _binom_cdf(k, n, p), 1 - tail)
    return low, high


def aggregate(values, better):
    """median, p95 and worst (largest when lower is better) of the values, with intervals."""
    if not values:
        return None
    worst = max(values) if better == "lower" else min(values)
    q_tail = 0.95 if better == "lower" else 0.05
    return {
        "n": len(values),
        "median": quantile(values, 0.5), "median_ci": quantile_interval(values, 0.5),
        "p95": quantile(values, q_tail), "p95_ci": quantile_interval(values, q_tail),
        "worst": worst, "best": min(values) if better == "lower" else max(values),
    }


def within(value, bound, better):
    return value <= bound if better == "lower" else value >= bound
