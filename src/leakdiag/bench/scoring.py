"""Scores of the benchmark from the per-run table: ROC AUC, detection and false-alarm rates,
minimum detectable leak, onset error and detection delay.

Definitions (also in ``docs/detect.md``):

* per-run statistic: the largest CUSUM value after the burn-in (:attr:`Verdict.score_max`);
  held-out healthy runs give its null distribution, leaking runs of one size the alternative;
* false-alarm rate: fraction of held-out healthy runs with an alarm (**per run** of the suite's
  duration; also converted to alarms per hour of the monitored span, the run after its
  burn-in, assuming Poisson alarms, as the thresholds' targets are set:
  :func:`leakdiag.bench.run.per_run_target_per_hour`);
* detection: an alarm at or after the true onset (an alarm before it is a false alarm, not a
  detection);
* minimum detectable leak: the smallest leak size whose detection rate is >= 90 % and stays
  >= 90 % at every larger size of the suite (NaN if none);
* onset error: ``|onset estimate - true onset|`` over detected runs; delay: ``alarm - onset``.
"""

from __future__ import annotations

import numpy as np

from leakdiag.detect.rates import clopper_pearson

__all__ = ["roc_auc", "roc_curve", "summarise", "minimum_detectable", "RESULT_COLUMNS",
           "SUMMARY_COLUMNS", "DETECTION_RATE_REQUIRED"]

#: Burn-in of the benchmark's alarm (``Alarm().burn_in_s``, s): the default of
#: :func:`summarise`.
DEFAULT_BURN_IN_S = 5.0
#: Detection rate that defines the minimum detectable leak (issue 5).
DETECTION_RATE_REQUIRED = 0.9
#: Columns of results.csv (the contract), in order; extra columns follow.
RESULT_COLUMNS = ["method", "system", "leak_lpm", "n_runs", "auc", "detection_rate",
                  "false_alarm_rate", "onset_error_median_s", "onset_error_p90_s",
                  "detection_delay_median_s"]
#: Columns of summary.csv.
SUMMARY_COLUMNS = ["method", "system", "min_detectable_lpm", "min_detectable_pct_rated",
                   "rated_flow_lpm", "false_alarm_rate", "false_alarm_target", "n_test_healthy"]


def roc_auc(null, alt) -> float:
    """Area under the ROC curve: probability that a leaking run outscores a healthy one.

    Parameters
    ----------
    null : array_like
        Per-run statistic of healthy runs.
    alt : array_like
        Per-run statistic of leaking runs.

    Returns
    -------
    float
        Mann-Whitney estimate, ties counted one half; NaN if either set is empty.

    Examples
    --------
    >>> roc_auc([0.0, 1.0], [2.0, 3.0]), roc_auc([0.0, 1.0], [1.0, 0.0])
    (1.0, 0.5)
    """
    n = np.asarray(null, dtype=np.float64)
    a = np.asarray(alt, dtype=np.float64)
    if len(n) == 0 or len(a) == 0:
        return float("nan")
    greater = (a[:, None] > n[None, :]).sum()
    ties = (a[:, None] == n[None, :]).sum()
    return float((greater + 0.5 * ties) / (len(a) * len(n)))


def roc_curve(null, alt) -> tuple[np.ndarray, np.ndarray]:
    """False- and true-positive rates for every threshold (alarm when statistic >= threshold).

    Parameters
    ----------
    null, alt : array_like
        Per-run statistics of healthy and leaking runs.

    Returns
    -------
    fpr, tpr : numpy.ndarray
        From (0, 0) to (1, 1), non-decreasing.

    Examples
    --------
    >>> fpr, tpr = roc_curve([0.0, 1.0], [2.0, 3.0])
    >>> fpr.tolist(), tpr.tolist()
    ([0.0, 0.0, 0.0, 0.5, 1.0], [0.0, 0.5, 1.0, 1.0, 1.0])
    """
    n = np.asarray(null, dtype=np.float64)
    a = np.asarray(alt, dtype=np.float64)
    thr = np.unique(np.concatenate([n, a]))[::-1]
    fpr = np.array([0.0] + [(n >= t).mean() for t in thr])
    tpr = np.array([0.0] + [(a >= t).mean() for t in thr])
    return fpr, tpr


def _q(x, q):
    return float(np.quantile(x, q)) if len(x) else float("nan")


def summarise(runs, rated_flow_lpm: dict[str, float] | None = None,
              burn_in_s: float = DEFAULT_BURN_IN_S):
    """The results table (one row per method, system and leak size).

    Parameters
    ----------
    runs : pandas.DataFrame
        Per-run table with ``method, system, role, leak_lpm, score_max, alarm, alarm_time_s,
        onset_true_s, onset_est_s, duration_s`` (roles ``test_healthy`` and ``test_leak`` used;
        rows of role ``error``, a method that could not be fitted, are left out).
    rated_flow_lpm : dict, optional
        System -> rated flow (L/min) for the ``leak_pct_rated`` column.
    burn_in_s : float, default 5.0
        Leading seconds of each run not monitored (``Alarm.burn_in_s``): false alarms per hour
        are counted over ``duration_s - burn_in_s``, the span the thresholds were set for.

    Returns
    -------
    pandas.DataFrame
        :data:`RESULT_COLUMNS` then ``leak_pct_rated, false_alarms_per_hour, n_test_healthy,
        excitation``, the size-estimate scores, ``cpu_s_per_hour`` (median over the method's
        held-out runs of the rig and excitation of CPU seconds per hour of signal; NaN if the
        runs carry no timing) and the false alarms' count with their 95 % Clopper-Pearson
        interval, ``false_alarms, far_low, far_high``, that interval per hour
        (``far_per_hour_low, far_per_hour_high``) and the detections' count with theirs
        (``detections, detection_low, detection_high``); the size scores carry the covered
        count and its interval too (``n_covered, coverage_low, coverage_high``).

    Raises
    ------
    ValueError
        If every row is an error (no method could be fitted), naming the first one's method,
        group and reason.

    Examples
    --------
    >>> import pandas as pd
    >>> runs = pd.DataFrame({"method": "m", "system": "vca",
    ...     "role": ["test_healthy"] * 2 + ["test_leak"] * 2, "leak_lpm": [0, 0, 0.1, 0.1],
    ...     "score_max": [1.0, 2.0, 9.0, 1.5], "alarm": [False, True, True, False],
    ...     "alarm_time_s": [None, 5.0, 12.0, None], "onset_true_s": [None, None, 10.0, 10.0],
    ...     "onset_est_s": [None, 4.0, 10.5, None], "duration_s": 3600.0})
    >>> r = summarise(runs).iloc[0]
    >>> [float(r[c]) for c in ("auc", "detection_rate", "false_alarm_rate", "onset_error_median_s")]
    [0.75, 0.5, 0.5, 0.5]
    """
    import pandas as pd

    rated = rated_flow_lpm or {}
    rows = []
    if "role" in runs.columns and len(runs):
        errors = runs[runs.role == "error"]
        runs = runs[runs.role != "error"]
        if len(runs) == 0:  # no column of a judged run exists: say why instead of crashing
            e = errors.iloc[0]
            where = " ".join(str(e[c]) for c in ("system", "load", "noise_level", "excitation")
                             if c in e and isinstance(e[c], str))
            raise ValueError(
                f"summarise: no run was judged: all {len(errors)} row(s) are errors (a method "
                f"that could not be fitted on its group); first: {e.method} on {where}: "
                f"{e.get('error', '')}")
    if "excitation" not in runs.columns:
        runs = runs.assign(excitation="operating")
    for (method, system, excitation), g in runs.groupby(["method", "system", "excitation"],
                                                        sort=False):
        healthy = g[g.role == "test_healthy"]
        far = float(healthy.alarm.astype(bool).mean()) if len(healthy) else float("nan")
        n_fa = int(healthy.alarm.astype(bool).sum())
        far_lo, far_hi = clopper_pearson(n_fa, len(healthy))
        # hours monitored per run: after the burn-in; the per-run rate per hour as
        # per_run_target_per_hour sets the targets (one segment per run, linear; Poisson
        # until 2026-11-29, a statistics audit)
        hours = (float(healthy.duration_s.mean()) - burn_in_s) / 3600.0 if len(healthy) \
            else float("nan")
        far_h = far / hours if len(healthy) else float("nan")
        far_h_lo, far_h_hi = ((far_lo / hours, far_hi / hours) if len(healthy)
                              else (float("nan"), float("nan")))
        leak = g[g.role == "test_leak"]
        cpu_h = _cpu_per_hour(g)
        for q, lk in leak.groupby("leak_lpm", sort=True):
            alarm_t = pd.to_numeric(lk.alarm_time_s, errors="coerce")
            onset = pd.to_numeric(lk.onset_true_s, errors="coerce")
            est = pd.to_numeric(lk.onset_est_s, errors="coerce")
            det = lk.alarm.astype(bool).to_numpy() & (alarm_t >= onset).to_numpy()
            err = np.abs(est - onset).to_numpy()[det]
            delay = (alarm_t - onset).to_numpy()[det]
            det_lo, det_hi = clopper_pearson(int(det.sum()), len(lk))
            rows.append({
                "method": method, "system": system, "leak_lpm": float(q), "n_runs": len(lk),
                "auc": roc_auc(healthy.score_max, lk.score_max),
                "detection_rate": float(det.mean()), "false_alarm_rate": far,
                "onset_error_median_s": _q(err, 0.5), "onset_error_p90_s": _q(err, 0.9),
                "detection_delay_median_s": _q(delay, 0.5),
                "leak_pct_rated": (100.0 * q / rated[system]) if system in rated else float("nan"),
                "false_alarms_per_hour": far_h, "n_test_healthy": len(healthy),
                "excitation": excitation, **_size_scores(lk, det, q),
                "cpu_s_per_hour": cpu_h, "false_alarms": n_fa, "far_low": far_lo,
                "far_high": far_hi, "far_per_hour_low": far_h_lo, "far_per_hour_high": far_h_hi,
                "detections": int(det.sum()), "detection_low": det_lo, "detection_high": det_hi,
            })
    return pd.DataFrame(rows, columns=RESULT_COLUMNS + ["leak_pct_rated", "false_alarms_per_hour",
                                                        "n_test_healthy", "excitation",
                                                        *_SIZE_COLUMNS, "cpu_s_per_hour",
                                                        *_FAR_COLUMNS, *_RATE_CI_COLUMNS])


def _cpu_per_hour(g) -> float:
    """Median CPU seconds per hour of signal over a method's held-out runs (NaN if unmeasured)."""
    import pandas as pd

    if "cpu_s_per_hour" not in g:
        return float("nan")
    return _q(pd.to_numeric(g.cpu_s_per_hour, errors="coerce").dropna().to_numpy(), 0.5)


#: False alarms of the held-out healthy runs: count and 95 % Clopper-Pearson interval.
_FAR_COLUMNS = ("false_alarms", "far_low", "far_high")
#: Leak-size estimation columns of the results (detected runs with a calibration): the
#: coverage of the true size with its count and 95 % Clopper-Pearson interval.
_SIZE_COLUMNS = ("leak_lpm_est_median", "leak_interval_coverage", "n_size_estimates",
                 "n_covered", "coverage_low", "coverage_high")
#: 95 % Clopper-Pearson intervals of the per-hour false-alarm rate (the per-run interval over
#: the hours monitored per run) and of the detection rate, with its count (a statistics audit,
#: 2026-11-30: the v4 results gave these rates bare).
_RATE_CI_COLUMNS = ("far_per_hour_low", "far_per_hour_high", "detections", "detection_low",
                    "detection_high")


def _size_scores(lk, det, q) -> dict:
    """Median size estimate and interval coverage of the true size over detected runs."""
    import pandas as pd

    nan = float("nan")
    if "leak_lpm_est" not in lk:
        return {"leak_lpm_est_median": nan, "leak_interval_coverage": nan,
                "n_size_estimates": 0, "n_covered": 0, "coverage_low": nan,
                "coverage_high": nan}
    est = pd.to_numeric(lk.leak_lpm_est, errors="coerce").to_numpy()[det]
    lo = pd.to_numeric(lk.leak_lpm_low, errors="coerce").to_numpy()[det]
    hi = pd.to_numeric(lk.leak_lpm_high, errors="coerce").to_numpy()[det]
    ok = np.isfinite(est)
    covered = int(((lo[ok] <= q) & (q <= hi[ok])).sum())
    cover = covered / int(ok.sum()) if ok.any() else nan
    c_lo, c_hi = clopper_pearson(covered, int(ok.sum()))  # NaN without an estimate
    return {"leak_lpm_est_median": _q(est[ok], 0.5), "leak_interval_coverage": float(cover),
            "n_size_estimates": int(ok.sum()), "n_covered": covered, "coverage_low": c_lo,
            "coverage_high": c_hi}


def minimum_detectable(results, rated_flow_lpm: dict[str, float] | None = None,
                       false_alarm_target: float = float("nan")):
    """Minimum detectable leak per method and system.

    Parameters
    ----------
    results : pandas.DataFrame
        Output of :func:`summarise`.
    rated_flow_lpm : dict, optional
        System -> rated flow (L/min).
    false_alarm_target : float, optional
        The per-run false-alarm target the thresholds were set for (reported).

    Returns
    -------
    pandas.DataFrame
        :data:`SUMMARY_COLUMNS` then ``excitation``, ``auc_max_leak`` (AUC at the largest
        leak size), ``onset_error_median_s`` and ``detection_delay_median_s`` (medians over
        the leak sizes of the per-size medians), ``cpu_s_per_hour`` and, when ``results``
        has them, ``false_alarms, far_low, far_high`` (count and 95 % interval): the one
        comparison table of issue 6.

    Examples
    --------
    >>> import pandas as pd
    >>> res = pd.DataFrame({"method": "m", "system": "vca", "leak_lpm": [0.01, 0.05, 0.1, 0.5],
    ...     "detection_rate": [0.95, 0.5, 0.9, 1.0], "false_alarm_rate": 0.0, "n_test_healthy": 20})
    >>> float(minimum_detectable(res).min_detectable_lpm.iloc[0])
    0.1
    """
    import pandas as pd

    rated = rated_flow_lpm or {}
    rows = []
    if "excitation" not in results.columns:
        results = results.assign(excitation="operating")
    for (method, system, excitation), g in results.groupby(["method", "system", "excitation"],
                                                           sort=False):
        g = g.sort_values("leak_lpm")
        ok = (g.detection_rate >= DETECTION_RATE_REQUIRED).to_numpy()
        tail_ok = np.flip(np.logical_and.accumulate(np.flip(ok)))
        mdl = float(g.leak_lpm.to_numpy()[tail_ok][0]) if tail_ok.any() else float("nan")
        rf = rated.get(system, float("nan"))
        rows.append({"method": method, "system": system, "min_detectable_lpm": mdl,
                     "min_detectable_pct_rated": 100.0 * mdl / rf,
                     "rated_flow_lpm": rf, "false_alarm_rate": float(g.false_alarm_rate.iloc[0]),
                     "false_alarm_target": false_alarm_target,
                     "n_test_healthy": int(g.n_test_healthy.iloc[0]), "excitation": excitation,
                     "auc_max_leak": float(g.auc.iloc[-1]) if "auc" in g else float("nan"),
                     "onset_error_median_s": _median_col(g, "onset_error_median_s"),
                     "detection_delay_median_s": _median_col(g, "detection_delay_median_s"),
                     "cpu_s_per_hour": _median_col(g, "cpu_s_per_hour"),
                     **{c: g[c].iloc[0] for c in _FAR_COLUMNS if c in g}})
    far_cols = [c for c in _FAR_COLUMNS if c in results]
    return pd.DataFrame(rows, columns=SUMMARY_COLUMNS + [
        "excitation", "auc_max_leak", "onset_error_median_s", "detection_delay_median_s",
        "cpu_s_per_hour", *far_cols])


def _median_col(g, col: str) -> float:
    """Median of a results column over leak sizes (NaN if absent or empty)."""
    import pandas as pd

    if col not in g:
        return float("nan")
    return _q(pd.to_numeric(g[col], errors="coerce").dropna().to_numpy(), 0.5)
