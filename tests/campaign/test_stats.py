#!/usr/bin/python3
"""ctest campaign_stats: tools/campaigns/stats.py against independent references: numpy's quantile,
scipy's binomial distribution (the order-statistic interval's coverage) and beta quantiles (Clopper-Pearson).
Exit 77 (skipped) without numpy or scipy."""
import os
import random
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools"))
try:
    import numpy as np
    from scipy import stats as sp
except ImportError as e:
    print(f"SKIPPED: {e} (python3-numpy, python3-scipy)")
    sys.exit(77)
from campaigns import stats  # noqa: E402

failures = []
rng = random.Random(7)
for n in (1, 2, 3, 5, 10, 20, 57):
    values = [rng.gauss(1.0, 0.3) for _ in range(n)]
    for q in (0.05, 0.5, 0.95):
        if abs(stats.quantile(values, q) - float(np.quantile(values, q))) > 1e-12:
            failures.append(f"quantile n={n} q={q}")
        lo, hi = stats.quantile_interval(values, q)
        v = sorted(values)
        # Coverage of [X(l), X(u)] for the q-quantile: P(l <= B < u), B ~ Binomial(n, q); each tail <= 2.5 %,
        # and the interval is the narrowest such (one rank tighter breaks a tail).
        l = v.index(lo) + 1 if lo is not None else None
        u = v.index(hi) + 1 if hi is not None else None
        if l is not None and (sp.binom.cdf(l - 1, n, q) > 0.025 or (l < n and sp.binom.cdf(l, n, q) <= 0.025)):
            failures.append(f"lower order statistic n={n} q={q}: rank {l}")
        if u is not None and (sp.binom.sf(u - 1, n, q) > 0.025 or (u > 1 and sp.binom.sf(u - 2, n, q) <= 0.025)):
            failures.append(f"upper order statistic n={n} q={q}: rank {u}")
        if l is None and sp.binom.cdf(0, n, q) <= 0.025:
            failures.append(f"lower end missing n={n} q={q} although rank 1 qualifies")
        if u is None and sp.binom.sf(n - 1, n, q) <= 0.025:
            failures.append(f"upper end missing n={n} q={q} although rank n qualifies")
for k, n in ((0, 10), (1, 10), (5, 20), (20, 20), (3, 140)):
    lo, hi = stats.fraction_interval(k, n)
    ref_lo = 0.0 if k == 0 else sp.beta.ppf(0.025, k, n - k + 1)
    ref_hi = 1.0 if k == n else sp.beta.ppf(0.975, k + 1, n - k)
    if abs(lo - ref_lo) > 1e-9 or abs(hi - ref_hi) > 1e-9:
        failures.append(f"Clopper-Pearson {k}/{n}: ({lo}, {hi}) against ({ref_lo}, {ref_hi})")
agg = stats.aggregate([3.0, 1.0, 2.0], "higher")
if agg["worst"] != 1.0 or agg["median"] != 2.0:
    failures.append(f"aggregate, higher is better: {agg}")
for f in failures:
    print("FAIL:", f)
print(f"{len(failures)} failures")
sys.exit(1 if failures else 0)
