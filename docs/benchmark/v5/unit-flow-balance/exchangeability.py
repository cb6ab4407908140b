"""Are held-out healthy GLR maxima exchangeable with the reference maxima? (benchmark v5, per unit)

Usage: python exchangeability.py RUNS_CSV_GZ REFS_DIR

For each rig and load: the reference maxima (training units, each fitted on its 2 own runs,
scored on its calibration run) against the held-out healthy runs' maxima (each unit fitted on
its 2 own runs, scored on a held-out run). Under exchangeability, the fraction of held-out
maxima at or above the j-th largest of n = 100 reference maxima is Beta(j, n + 1 - j)
distributed per calibration (mean j / (n + 1)); the pooled count over the four groups is
compared with that law by simulation (200,000 draws), and a two-sample KS test per group.
"""
import glob
import sys

import joblib
import numpy as np
import pandas as pd
from scipy.stats import ks_2samp

runs = pd.read_csv(sys.argv[1])
refs = {}
for f in glob.glob(f"{sys.argv[2]}/*.joblib"):
    for r in joblib.load(f)["refs"].values():
        refs[r.source] = np.sort(r.maxima)[::-1]
h = runs[runs.role == "test_healthy"]
js = (1, 2, 3, 5, 10, 20, 50)
pooled = dict.fromkeys(js, 0)
n_groups = 0
print("| rig | load | n ref | n test | basis (k of n) | alarms | test >= j-th largest ref, j = "
      + ", ".join(map(str, js)) + " | KS p | median ref / test |")
print("|---|---|---|---|---|---|---|---|---|")
for (sy, lo), g in h.groupby(["system", "load"]):
    ref = refs[[s for s in refs if f" {sy} {lo} " in s][0]]
    t = g.score_max.to_numpy()
    ex = [int((t >= ref[j - 1]).sum()) for j in js]
    for j, e in zip(js, ex):
        pooled[j] += e
    n_groups += 1
    basis = g.groupby(["threshold_method", "threshold_k", "threshold_n"]).size()
    btxt = "; ".join(f"{m} {int(k)} of {int(n)}: {c}" for (m, k, n), c in basis.items())
    print(f"| {sy} | {lo} | {len(ref)} | {len(t)} | {btxt} | {int(g.alarm.sum())} | "
          f"{' / '.join(map(str, ex))} | {ks_2samp(ref, t).pvalue:.2f} | "
          f"{np.median(ref):.2f} / {np.median(t):.2f} |")
n_test = len(h) // n_groups
n_ref = 100
rng = np.random.default_rng(0)
print()
print("| j | pooled count | expected | P(count >= observed) under exchangeability |")
print("|---|---|---|---|")
for j in js:
    r = rng.beta(j, n_ref + 1 - j, size=(200_000, n_groups))
    c = rng.binomial(n_test, r).sum(1)
    print(f"| {j} | {pooled[j]} | {n_groups * n_test * j / (n_ref + 1):.1f} | "
          f"{(c >= pooled[j]).mean():.3f} |")
