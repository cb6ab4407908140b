"""False alarms at the run's level and at other ranks of the same reference maxima (per unit).

Usage: python ranks.py runs.csv.gz refs   (refs/: the run's reference maxima, <work-dir>/refs)

Per rig and load: held-out healthy GLR maxima above the k-th largest of the 300 reference
maxima (k = 1 is the level at 95 % confidence the run used; k = 3 the marginal rank
floor(0.01 x 301)); pooled counts with Clopper-Pearson intervals, and, under exchangeability
(each group's rate Beta(k, 301 - k), its count Binomial(its held-out runs)), the chance of a pooled count at
least as large (200,000 draws).
"""
import glob, sys
import joblib, numpy as np, pandas as pd
from leakdiag.detect.rates import clopper_pearson
runs = pd.read_csv(sys.argv[1]); refs = {}
for f in glob.glob(f"{sys.argv[2]}/*.joblib"):
    for r in joblib.load(f)["refs"].values():
        refs[r.source] = np.sort(r.maxima)[::-1]
h = runs[runs.role == "test_healthy"]
tot = {}
for (sy, lo), g in h.groupby(["system", "load"]):
    ref = refs[[s for s in refs if f" {sy} {lo} " in s][0]]
    t = g.score_max.to_numpy()
    row = [sy, lo, len(ref), len(t), int(g.alarm.sum())]
    for k in (1, 2, 3):
        c = int((t > ref[k - 1]).sum())
        tot[k] = tot.get(k, 0) + c
        row.append(f"{c} (level {ref[k-1]:.2f})")
    print(" | ".join(map(str, row)))
n = len(h)
for k in (1, 2, 3):
    lo, hi = clopper_pearson(tot[k], n)
    print(f"k={k} of 300: {tot[k]}/{n} = {tot[k]/n:.2%} [{lo:.2%}, {hi:.2%}]")
print("alarms (recorded):", int(h.alarm.sum()), "/", n, [f"{x:.2%}" for x in clopper_pearson(int(h.alarm.sum()), n)])
# under exchangeability: per group rate Beta(k, 301-k), count Binomial(n per group, rate), sum of 4 groups
rng = np.random.default_rng(0)
ng = h.groupby(["system", "load"]).ngroups; nt = n // ng
for k in (1, 3):
    r = rng.beta(k, 301 - k, size=(200_000, ng)); c = rng.binomial(nt, r).sum(1)
    print(f"k={k}: expected {n*k/301:.1f}, P(count >= {tot[k]}) = {(c >= tot[k]).mean():.3f}")
