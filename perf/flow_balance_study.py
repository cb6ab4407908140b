"""Small study of the FlowBalanceDetector on virtual machines (issue 12, section 1).

Per system, load and machine: fit on ``n_fit`` healthy runs of the machine (nominal operating
conditions), then judge ``n_healthy`` held-out healthy runs and ``n_leak`` leaking runs per size,
all with randomised operating conditions (temperature rise 0-10 K, supply ripple 0-0.3 MPa on
the VCA; temperature rise 0-10 K on the EHA) and a random onset. A detection is an alarm within
10 s of the true onset; an alarm before the onset is a false alarm of that run. Rates carry
95 % Clopper-Pearson intervals (``scipy.stats.binomtest(...).proportion_ci("exact")``).

Run (heavy: use the shared lock)::

    flock /tmp/leakdiag-heavy.lock python perf/flow_balance_study.py --system vca \
        --out docs/flow_balance_study
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.stats import binomtest

import leakdiag as ld
from leakdiag.sim.eha.drive import EHAConditions

SIZES = {"vca": (0.002, 0.005, 0.01, 0.02, 0.05), "eha": (0.02, 0.05, 0.1, 0.2, 0.5)}
DEADLINE_S = 10.0


def _sim(system, machine, load, seed, leak, onset, duration, rng):
    if system == "vca":
        cond = ld.sim.OperatingConditions(temperature_rise_k=float(rng.uniform(0, 10)),
                                          supply_ripple_pa=float(rng.uniform(0, 0.3e6)))
        return ld.sim.simulate_vca(duration=duration, leak_lpm=leak, onset=onset, load=load,
                                   machine=machine, seed=seed, conditions=cond)
    cond = EHAConditions(temperature_rise_k=float(rng.uniform(0, 10)))
    return ld.sim.simulate_eha(duration=duration, leak_lpm=leak, onset=onset, load=load,
                               machine=machine, seed=seed, conditions=cond)


def run(system, machines, loads, n_fit, n_healthy, n_leak, duration, rate_per_hour):
    rows = []
    fits = []
    for load in loads:
        for m in machines:
            t0 = time.process_time()
            # fit data: nominal operating conditions
            if system == "vca":
                healthy = [ld.sim.simulate_vca(duration=duration, leak_lpm=0.0, load=load,
                                               machine=m, seed=s) for s in range(n_fit)]
            else:
                healthy = [ld.sim.simulate_eha(duration=duration, leak_lpm=0.0, load=load,
                                               machine=m, seed=s) for s in range(n_fit)]
            det = ld.detect.FlowBalanceDetector(system=system,
                                                false_alarms_per_hour=rate_per_hour)
            det.fit(healthy)
            fits.append({"system": system, "load": load, "machine": m,
                         "threshold": det.threshold_, "dispersion": det.dispersion_,
                         "healthy_alarms_in_fit": det.alarm_threshold_.healthy_alarms,
                         "fit_cpu_s": time.process_time() - t0,
                         **{f"model_{k}": float(v) for k, v in det.model_.to_dict().items()}})
            cases = [(0.0, 1000 + i) for i in range(n_healthy)]
            cases += [(q, 2000 + 100 * j + i) for j, q in enumerate(SIZES[system])
                      for i in range(n_leak)]
            for leak, seed in cases:
                rng = np.random.default_rng(seed + 7919 * m)
                onset = float(rng.uniform(0.35, 0.65) * duration) if leak else None
                t1 = time.process_time()
                rec = _sim(system, m, load, seed, leak, onset, duration, rng)
                t2 = time.process_time()
                v = det.predict(rec)
                alarm = v.alarm_time_s
                early = alarm is not None and onset is not None and alarm < onset
                rows.append({
                    "system": system, "load": load, "machine": m, "seed": seed,
                    "leak_lpm": leak, "leak_lpm_achieved": rec.meta["leak_lpm_achieved"],
                    "onset_true_s": onset, "alarm_time_s": alarm, "onset_est_s": v.onset_s,
                    "score_max": v.score_max, "threshold": v.threshold,
                    "false_alarm": bool(v.leak and (leak == 0 or early)),
                    "detected_10s": bool(leak and alarm is not None and not early
                                         and alarm - onset <= DEADLINE_S),
                    "detected_30s": bool(leak and alarm is not None and not early
                                         and alarm - onset <= 30.0),
                    "leak_lpm_est": v.leak_lpm,
                    "leak_lpm_low": v.leak_lpm_interval[0] if v.leak_lpm_interval else None,
                    "leak_lpm_high": v.leak_lpm_interval[1] if v.leak_lpm_interval else None,
                    "sim_cpu_s": t2 - t1, "predict_cpu_s": time.process_time() - t2,
                })
            print(f"{system} {load} machine {m}: done ({len(rows)} runs)", flush=True)
    return pd.DataFrame(rows), pd.DataFrame(fits)


def _ci(k, n):
    if n == 0:
        return (float("nan"), float("nan"))
    ci = binomtest(int(k), int(n)).proportion_ci(method="exact")
    return (ci.low, ci.high)


def summarise(df: pd.DataFrame) -> pd.DataFrame:
    out = []
    for (system, load), g in df.groupby(["system", "load"]):
        h = g[g.leak_lpm == 0]
        k, n = int(h.false_alarm.sum()), len(h)
        if n:  # --n-healthy 0: leaking runs only
            lo, hi = _ci(k, n)
            out.append({"system": system, "load": load, "leak_lpm": 0.0, "n": n,
                        "rate": k / n, "ci_low": lo, "ci_high": hi,
                        "what": "false alarm (healthy)"})
        for q, gq in g[g.leak_lpm > 0].groupby("leak_lpm"):
            n = len(gq)
            for col, what in (("detected_10s", "detected within 10 s"),
                              ("false_alarm", "alarm before onset")):
                k = int(gq[col].sum())
                lo, hi = _ci(k, n)
                out.append({"system": system, "load": load, "leak_lpm": q, "n": n, "rate": k / n,
                            "ci_low": lo, "ci_high": hi, "what": what})
            det = gq[gq.detected_10s]
            err = (det.onset_est_s - det.onset_true_s).abs()
            inside = ((det.leak_lpm_low <= det.leak_lpm_achieved)
                      & (det.leak_lpm_achieved <= det.leak_lpm_high))
            out.append({"system": system, "load": load, "leak_lpm": q, "n": len(det),
                        "rate": float(err.median()) if len(det) else float("nan"),
                        "ci_low": float("nan"), "ci_high": float("nan"),
                        "what": "median |onset error| s (detected)"})
            out.append({"system": system, "load": load, "leak_lpm": q, "n": len(det),
                        "rate": float((det.leak_lpm_est / det.leak_lpm_achieved).median())
                        if len(det) else float("nan"),
                        "ci_low": float(inside.mean()) if len(det) else float("nan"),
                        "ci_high": float("nan"),
                        "what": "median est/true size (ci_low: interval coverage)"})
    return pd.DataFrame(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--system", choices=("vca", "eha"), default="vca")
    ap.add_argument("--machines", type=int, nargs="+", default=[101, 102, 103, 104])
    ap.add_argument("--loads", nargs="+", default=["spring", "none"])
    ap.add_argument("--n-fit", type=int, default=10)
    ap.add_argument("--n-healthy", type=int, default=20)
    ap.add_argument("--n-leak", type=int, default=8)
    ap.add_argument("--duration", type=float, default=120.0)
    ap.add_argument("--rate-per-hour", type=float, default=0.3)
    ap.add_argument("--out", type=Path, default=Path("docs/flow_balance_study"))
    a = ap.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    df, fits = run(a.system, a.machines, a.loads, a.n_fit, a.n_healthy, a.n_leak, a.duration,
                   a.rate_per_hour)
    summ = summarise(df)
    df.to_csv(a.out / f"{a.system}_runs.csv", index=False)
    fits.to_csv(a.out / f"{a.system}_fits.csv", index=False)
    summ.to_csv(a.out / f"{a.system}_summary.csv", index=False)
    (a.out / f"{a.system}_config.json").write_text(json.dumps(
        {**{k: (str(v) if isinstance(v, Path) else v) for k, v in vars(a).items()},
         "wall_s": time.time() - t0, "leakdiag_version": ld.__version__}, indent=1))
    pd.set_option("display.width", 200)
    print(summ.to_string(index=False))
    print(f"wall {time.time() - t0:.0f} s")


if __name__ == "__main__":
    main()
