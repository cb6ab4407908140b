"""Scores of benchmark v5, with a 95 % Clopper-Pearson interval beside every rate.

* false-alarm rate: fraction of held-out healthy runs (test machines) with an alarm;
* detection within ``d`` s: an alarm at a time in ``[onset, onset + d]``; an alarm **before the
  onset is a false alarm** (counted in ``early_alarm_rate``), never a detection;
* minimum detectable leak per (method, rig, load, excitation) -- loads never pooled: the
  smallest size with detection rate >= 90 % within the deadline such that every larger size of
  the suite also reaches 90 % (NaN when none);
* onset error: ``|onset estimate - true onset|`` of runs detected within 10 s; per leak size
  its median, and in the summary the median of those per-size medians over the sizes at or
  above the 10-s minimum detectable leak (every size weighs alike; docs/detect.md section 5).
"""

from __future__ import annotations

import numpy as np

from leakdiag.detect.rates import clopper_pearson

__all__ = ["false_alarm_table", "detection_table", "size_table", "minimum_detectable_v5",
           "summary_v5", "rate_text", "GOALS", "REQUIRED_RATE"]

#: Detection rate that defines the minimum detectable leak.
REQUIRED_RATE = 0.9
#: Goals of issue 13 (L/min per rig; rates per run; seconds).
GOALS = {"mdl_lpm": {"vca": 0.02, "eha": 0.1}, "far": 0.01, "far_upper": 0.02,
         "onset_error_s": 5.0, "deadline_s": 10.0}
_GROUP = ["method", "system", "load", "excitation"]


def _rate(k: int, n: int) -> dict:
    lo, hi = clopper_pearson(k, n)
    return {"rate": k / n if n else float("nan"), "low": lo, "high": hi}


def rate_text(k, n) -> str:
    """A rate as printed: count, number of runs, rate and 95 % Clopper-Pearson interval.

    Parameters
    ----------
    k, n : int or float
        Events and runs; NaN or ``n = 0``: undefined.

    Returns
    -------
    str
        ``"k/n = rate [low, high]"`` (3 significant digits), or ``"--"`` when undefined.

    Examples
    --------
    >>> rate_text(3, 20), rate_text(0, 20), rate_text(0, 0)
    ('3/20 = 0.15 [0.0321, 0.379]', '0/20 = 0 [0, 0.168]', '--')
    """
    if k is None or n is None or not (np.isfinite(k) and np.isfinite(n)) or int(n) < 1:
        return "--"
    k, n = int(round(k)), int(n)
    lo, hi = clopper_pearson(k, n)
    return f"{k}/{n} = {k / n:.3g} [{lo:.3g}, {hi:.3g}]"


def false_alarm_table(runs):
    """False alarms of held-out healthy runs per method, rig, load and excitation.

    Parameters
    ----------
    runs : pandas.DataFrame
        Per-run table (``role``, ``alarm`` and the group columns).

    Returns
    -------
    pandas.DataFrame
        ``n_healthy, false_alarms, false_alarm_rate, far_low, far_high``, ``n_refused``
        (held-out healthy runs the method refused to judge: not in ``n_healthy``, neither a
        false alarm nor a NO LEAK), and ``not_clear``, ``not_clear_rate``, ``nc_low``,
        ``nc_high``: the healthy runs without a NO LEAK (false alarms plus refusals, over all
        held-out healthy runs; what ``detect`` shows as LEAK or INCONCLUSIVE: a benchmark
        audit, 2026-11-28, found each new refusal rule had taken one of the few false alarms
        out of the rate).

    Examples
    --------
    >>> import pandas as pd
    >>> runs = pd.DataFrame({"method": "m", "system": "vca", "load": "none",
    ...     "excitation": "operating", "role": "test_healthy", "alarm": [True] + [False] * 9})
    >>> r = false_alarm_table(runs).iloc[0]
    >>> int(r.false_alarms), float(r.false_alarm_rate), round(float(r.far_high), 4)
    (1, 0.1, 0.445)
    >>> int(r.not_clear), float(r.not_clear_rate)  # no refusal here: the same
    (1, 0.1)
    """
    import pandas as pd

    rows = []
    h = runs[runs.role == "test_healthy"]
    refused = _refused(runs, "test_healthy")
    for key, g in h.groupby(_GROUP, sort=False):
        k, n = int(g.alarm.astype(bool).sum()), len(g)
        r = _rate(k, n)
        nr = int(refused.get(key, 0))
        c = _rate(k + nr, n + nr)
        rows.append({**dict(zip(_GROUP, key)), "n_healthy": n, "false_alarms": k,
                     "false_alarm_rate": r["rate"], "far_low": r["low"], "far_high": r["high"],
                     "n_refused": nr, "not_clear": k + nr, "not_clear_rate": c["rate"],
                     "nc_low": c["low"], "nc_high": c["high"]})
    return pd.DataFrame(rows, columns=_GROUP + ["n_healthy", "false_alarms", "false_alarm_rate",
                                                "far_low", "far_high", "n_refused", "not_clear",
                                                "not_clear_rate", "nc_low", "nc_high"])


def _refused(runs, role: str, extra=()) -> dict:
    """Held-out runs of ``role`` a method refused to judge (error rows), per group key."""
    if "refused_role" not in runs or not len(runs):
        return {}
    r = runs[(runs.role == "error") & (runs.refused_role == role)]
    return r.groupby(_GROUP + list(extra), sort=False).size().to_dict() if len(r) else {}


def _at_deadline(g, d: float, whole: np.ndarray) -> np.ndarray:
    """Detected by ``d`` s: a whole-recording detector's verdict on the run cut at onset + d
    (``alarm_by_<d>s``, :func:`leakdiag.bench.v5_common.deadline_alarms`) where the run has
    one, else ``whole`` (the alarm time of the whole run's verdict in the window)."""
    col = f"alarm_by_{d:g}s"
    if col not in g:
        return whole
    cut = g[col].to_numpy(dtype=object)
    known = np.array([x is not None and x == x for x in cut], dtype=bool)
    return np.where(known, np.array([bool(x) if k else False for x, k in zip(cut, known)],
                                    dtype=bool), whole)


def detection_table(runs, deadlines=(5.0, 10.0, 30.0)):
    """Detection within each deadline, early alarms and onset error per leak size.

    Parameters
    ----------
    runs : pandas.DataFrame
        Per-run table with ``leak_lpm, onset_true_s, alarm, alarm_time_s, onset_est_s``.
    deadlines : sequence of float
        Seconds after the true onset.

    Returns
    -------
    pandas.DataFrame
        Per group and size: ``n_leak`` (a run the method refused to judge counts, as not
        detected: the user gets no LEAK), ``n_refused`` (of them), ``early_alarms``,
        ``early_alarm_rate`` (+ interval),
        for each deadline ``d``: ``detected_<d>s``, ``detection_rate_<d>s``, ``det_low_<d>s``,
        ``det_high_<d>s``; ``onset_error_median_s`` and ``delay_median_s`` (runs detected
        within 10 s). A whole-recording detector's run is detected by ``d`` when its verdict on
        the run cut at onset + ``d`` is a LEAK (``alarm_by_<d>s``; audit 2026-11-28): what
        the user knows then; the onset error is the whole run's estimate.

    Examples
    --------
    >>> import pandas as pd
    >>> runs = pd.DataFrame({"method": "m", "system": "vca", "load": "none",
    ...     "excitation": "operating", "role": "test_leak", "leak_lpm": 0.1,
    ...     "onset_true_s": 20.0, "alarm": [True, True, True, False],
    ...     "alarm_time_s": [15.0, 24.0, 45.0, None], "onset_est_s": [14.0, 21.0, 30.0, None]})
    >>> r = detection_table(runs).iloc[0]
    >>> int(r.early_alarms), float(r["detection_rate_10s"]), float(r["detection_rate_30s"])
    (1, 0.25, 0.5)
    >>> float(r.onset_error_median_s)
    1.0
    """
    import pandas as pd

    lk = runs[runs.role == "test_leak"]
    if "refused_role" in runs:  # a leaking run a method refused to judge was not detected
        lk = pd.concat([lk, runs[(runs.role == "error") & (runs.refused_role == "test_leak")]
                        .assign(alarm=False)])
    refused = _refused(runs, "test_leak", ["leak_lpm"])
    rows = []
    for key, g in lk.groupby(_GROUP + ["leak_lpm"], sort=True):
        onset = pd.to_numeric(g.onset_true_s, errors="coerce").to_numpy()
        t = pd.to_numeric(g.alarm_time_s, errors="coerce").to_numpy()
        est = pd.to_numeric(g.onset_est_s, errors="coerce").to_numpy()
        alarm = g.alarm.astype(bool).to_numpy()
        n = len(g)
        early = alarm & (t < onset)
        row = {**dict(zip(_GROUP + ["leak_lpm"], key)), "n_leak": n,
               "n_refused": int(refused.get(key, 0)), "early_alarms": int(early.sum())}
        r = _rate(int(early.sum()), n)
        row.update(early_alarm_rate=r["rate"], early_low=r["low"], early_high=r["high"])
        for d in deadlines:
            det = alarm & (t >= onset) & (t <= onset + d)
            det = _at_deadline(g, d, det)
            r = _rate(int(det.sum()), n)
            tag = f"{d:g}s"
            row.update({f"detected_{tag}": int(det.sum()), f"detection_rate_{tag}": r["rate"],
                        f"det_low_{tag}": r["low"], f"det_high_{tag}": r["high"]})
        det10 = _at_deadline(g, 10.0, alarm & (t >= onset) & (t <= onset + 10.0))
        err = np.abs(est - onset)[det10]
        row["onset_error_median_s"] = float(np.median(err)) if err.size else float("nan")
        dl = (t - onset)[det10]
        row["delay_median_s"] = float(np.median(dl)) if dl.size else float("nan")
        rows.append(row)
    return pd.DataFrame(rows)


def size_table(runs, deadline: float = 10.0):
    """Leak-size estimates against the simulated leak, per leak size (runs detected in time).

    The truth is the run's achieved mean leak flow after the onset
    (``leak_lpm_achieved``, the thesis's definition); the estimate is the verdict's
    ``leak_lpm`` with its interval ``leak_lpm_low`` .. ``leak_lpm_high``. Only runs detected
    within ``deadline`` of the onset with a finite estimate count.

    Parameters
    ----------
    runs : pandas.DataFrame
        Per-run table with ``leak_lpm, leak_lpm_achieved, onset_true_s, alarm,
        alarm_time_s, leak_lpm_est, leak_lpm_low, leak_lpm_high``.
    deadline : float, default 10.0
        Seconds after the true onset.

    Returns
    -------
    pandas.DataFrame
        Per group and size: ``n_sized``; ``ratio_median``, ``ratio_p10``, ``ratio_p90`` of
        estimate / truth; ``covered`` (intervals holding the truth), ``coverage`` with its
        95 % Clopper-Pearson ``coverage_low`` / ``coverage_high``. Empty without size columns.

    Examples
    --------
    >>> import pandas as pd
    >>> runs = pd.DataFrame({"method": "m", "system": "vca", "load": "none",
    ...     "excitation": "operating", "role": "test_leak", "leak_lpm": 0.1,
    ...     "leak_lpm_achieved": 0.1, "onset_true_s": 20.0, "alarm": True,
    ...     "alarm_time_s": [21.0, 22.0, 50.0], "leak_lpm_est": [0.09, 0.12, 0.1],
    ...     "leak_lpm_low": [0.08, 0.105, 0.09], "leak_lpm_high": [0.11, 0.13, 0.11]})
    >>> r = size_table(runs).iloc[0]
    >>> int(r.n_sized), int(r.covered), round(float(r.ratio_median), 3)
    (2, 1, 1.05)
    """
    import pandas as pd

    cols = _GROUP + ["leak_lpm", "n_sized", "ratio_median", "ratio_p10", "ratio_p90",
                     "covered", "coverage", "coverage_low", "coverage_high"]
    need = {"leak_lpm_est", "leak_lpm_low", "leak_lpm_high", "leak_lpm_achieved"}
    if not need <= set(runs.columns):
        return pd.DataFrame(columns=cols)
    lk = runs[runs.role == "test_leak"]
    rows = []
    for key, g in lk.groupby(_GROUP + ["leak_lpm"], sort=True):
        num = {c: pd.to_numeric(g[c], errors="coerce").to_numpy(dtype=float)
               for c in ("onset_true_s", "alarm_time_s", "leak_lpm_achieved", "leak_lpm_est",
                         "leak_lpm_low", "leak_lpm_high")}
        on, t = num["onset_true_s"], num["alarm_time_s"]
        with np.errstate(invalid="ignore"):
            ok = (g.alarm.astype(bool).to_numpy() & (t >= on) & (t <= on + deadline)
                  & np.isfinite(num["leak_lpm_est"]) & (num["leak_lpm_achieved"] > 0))
        truth, est = num["leak_lpm_achieved"][ok], num["leak_lpm_est"][ok]
        lo, hi = num["leak_lpm_low"][ok], num["leak_lpm_high"][ok]
        n = int(ok.sum())
        ratio = est / truth
        cov = int(np.sum((lo <= truth) & (truth <= hi)))
        r = _rate(cov, n)
        q = (lambda p: float(np.quantile(ratio, p)) if n else float("nan"))
        rows.append({**dict(zip(_GROUP + ["leak_lpm"], key)), "n_sized": n,
                     "ratio_median": q(0.5), "ratio_p10": q(0.1), "ratio_p90": q(0.9),
                     "covered": cov, "coverage": r["rate"], "coverage_low": r["low"],
                     "coverage_high": r["high"]})
    return pd.DataFrame(rows, columns=cols)


def minimum_detectable_v5(det, deadline: float = 10.0):
    """Minimum detectable leak per method, rig, load and excitation ("every larger size too").

    Parameters
    ----------
    det : pandas.DataFrame
        Output of :func:`detection_table`.
    deadline : float, default 10.0
        Deadline whose detection rate is used.

    Returns
    -------
    pandas.DataFrame
        ``min_detectable_lpm`` (NaN: not reached), ``mdl_detection_rate`` and its interval
        ``mdl_det_low``, ``mdl_det_high`` at that size, ``largest_size_rate``.

    Examples
    --------
    >>> import pandas as pd
    >>> det = pd.DataFrame({"method": "m", "system": "vca", "load": "none",
    ...     "excitation": "operating", "leak_lpm": [0.01, 0.02, 0.05, 0.1],
    ...     "detection_rate_10s": [0.95, 0.5, 0.92, 1.0], "det_low_10s": 0.0,
    ...     "det_high_10s": 1.0})
    >>> float(minimum_detectable_v5(det).min_detectable_lpm.iloc[0])
    0.05
    """
    import pandas as pd

    tag = f"{deadline:g}s"
    rows = []
    for key, g in det.groupby(_GROUP, sort=False):
        g = g.sort_values("leak_lpm")
        ok = (g[f"detection_rate_{tag}"] >= REQUIRED_RATE).to_numpy()
        tail = np.flip(np.logical_and.accumulate(np.flip(ok)))
        i = int(np.argmax(tail)) if tail.any() else None
        rows.append({**dict(zip(_GROUP, key)), "deadline_s": deadline,
                     "min_detectable_lpm": float(g.leak_lpm.iloc[i]) if i is not None else np.nan,
                     "mdl_detection_rate": float(g[f"detection_rate_{tag}"].iloc[i])
                     if i is not None else np.nan,
                     "mdl_det_low": float(g[f"det_low_{tag}"].iloc[i]) if i is not None else np.nan,
                     "mdl_det_high": float(g[f"det_high_{tag}"].iloc[i]) if i is not None else np.nan,
                     "largest_size_rate": float(g[f"detection_rate_{tag}"].iloc[-1])})
    return pd.DataFrame(rows)


def summary_v5(runs, deadlines=(5.0, 10.0, 30.0)):
    """The comparison table: per method, rig, load, excitation -- false alarms with interval,
    minimum detectable leak at each deadline, onset error and goal flags.

    Parameters
    ----------
    runs : pandas.DataFrame
        Per-run table.
    deadlines : sequence of float
        Deadlines (s).

    Returns
    -------
    summary, detection : pandas.DataFrame
        The summary and :func:`detection_table`.
    """
    far = false_alarm_table(runs)
    det = detection_table(runs, deadlines)
    out = far
    for d in deadlines:
        m = minimum_detectable_v5(det, d)
        tag = f"{d:g}s"
        m = m.rename(columns={c: f"{c}_{tag}" for c in m.columns if c not in _GROUP})
        out = out.merge(m.drop(columns=[f"deadline_s_{tag}"]), on=_GROUP, how="left")
    # onset error of runs detected within 10 s, at sizes >= the 10-s minimum detectable leak
    errs = []
    for _, r in out.iterrows():
        g = det[(det.method == r.method) & (det.system == r.system) & (det.load == r.load)
                & (det.excitation == r.excitation)]
        mdl = r["min_detectable_lpm_10s"]
        sel = g[g.leak_lpm >= mdl] if np.isfinite(mdl) else g.iloc[0:0]
        errs.append(float(np.nanmedian(sel.onset_error_median_s)) if len(sel)
                    and np.isfinite(sel.onset_error_median_s).any() else np.nan)
    out["onset_error_median_s"] = errs
    goal = out.system.map(GOALS["mdl_lpm"])
    out["goal_mdl_lpm"] = goal
    out["goal_met"] = ((out["min_detectable_lpm_10s"] <= goal)
                       & (out.false_alarm_rate <= GOALS["far"])
                       & (out.far_high <= GOALS["far_upper"])
                       & (out.onset_error_median_s <= GOALS["onset_error_s"]))
    return out, det
