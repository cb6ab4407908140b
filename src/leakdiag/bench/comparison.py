"""The literature comparison: literature and thesis methods side by side under both excitations.

:func:`comparison_suite` is a mid-size VCA suite (both excitations, leak sizes from 0.02 to
1 L/min) built from the benchmark's :class:`~leakdiag.bench.suite.SystemSuite`;
:func:`run_comparison` checks that its fitting runs support the false-alarm target, runs it
and scores it; :func:`comparison_table` is the table of ``docs/literature.md``, which
:func:`write_comparison` (``leakdiag benchmark --suite comparison -o OUT``) writes;
:func:`compute_seconds_per_hour` measures one method's feature cost.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

from leakdiag._validation import check_int
from leakdiag.bench.outputs import prepare_folder
from leakdiag.bench.registry import make_detector
from leakdiag.bench.suite import EXCITATIONS, SystemSuite
from leakdiag.detect.base import Alarm
from leakdiag.runtime.cache import resolve_cache_dir

__all__ = ["comparison_suite", "compute_seconds_per_hour", "COMPARISON_METHODS",
           "COMPARISON_FAR", "check_comparison_target", "run_comparison", "ComparisonResult",
           "comparison_table", "table_markdown", "write_comparison"]

#: Methods compared in ``docs/literature.md`` (benchmark registry names).
COMPARISON_METHODS = ("acf-p1", "ccf-p1p2", "ccf-ux", "mlr-p1", "combined", "wavelet-p1",
                      "wavelet-p1p2", "fft-p1", "emd-p1", "ekf")
#: Default false-alarm target per healthy run (leakdiag choice): what the default 19 fitting
#: runs per excitation support (a conformal threshold from n maxima promises at best
#: 1 / (n + 1) per run; 1 % would need 99 runs of 100 s per excitation).
COMPARISON_FAR = 0.05
#: Default fitting runs per excitation: the fewest that support :data:`COMPARISON_FAR`.
COMPARISON_N_FIT = 19


def comparison_suite(duration_s: float = 100.0, n_fit: int = COMPARISON_N_FIT,
                     n_test_healthy: int = 10, n_test_leak: int = 5):
    """The VCA suite of the comparison: no load, low noise, both excitations.

    Parameters
    ----------
    duration_s : float, default 100.0
        Run length in s; onsets uniform in the middle fifth.
    n_fit : int, default 19
        Healthy fitting runs per excitation (19 support a 5 % per-run target,
        :func:`check_comparison_target`).
    n_test_healthy, n_test_leak : int, default 10, 5
        Held-out healthy runs, held-out leaking runs per leak size (per excitation).

    Returns
    -------
    dict
        ``{"vca": SystemSuite}`` for :func:`leakdiag.bench.run.run_suite`.

    Raises
    ------
    ValueError
        If ``n_fit`` is not an integer >= 1.

    Examples
    --------
    >>> s = comparison_suite()["vca"]
    >>> s.excitations, s.leak_lpm, s.n_fit
    (('operating', 'structured'), (0.02, 0.05, 0.1, 0.2, 0.5, 1.0), 19)
    >>> comparison_suite(n_fit=0)
    Traceback (most recent call last):
    ...
    ValueError: n_fit=0 must be >= 1
    """
    n_fit = check_int(n_fit, "n_fit", 1)  # no healthy run supports no threshold
    return {"vca": SystemSuite(
        system="vca", leak_lpm=(0.02, 0.05, 0.1, 0.2, 0.5, 1.0), loads=("none",),
        noise_levels={"low": 10e3}, duration_s=float(duration_s),
        onset_range_s=(0.4 * duration_s, 0.6 * duration_s), n_fit=n_fit, n_cal=0,
        n_test_healthy=n_test_healthy, n_test_leak=n_test_leak, base_seed=5_000_000,
        excitations=EXCITATIONS)}


def check_comparison_target(suites, methods, per_run: float, burn_in_s: float = 5.0) -> None:
    """Refuse, before any simulation, a false-alarm target the fitting runs cannot support.

    A detector with the common fit (:meth:`leakdiag.detect.base.Detector.fit`, which sets the
    threshold from one healthy CUSUM maximum per fitting run: the thesis features, wavelet,
    FFT, EMD and the EKF) needs ``min_maxima(per_run)`` fitting runs (one segment per run), as
    :func:`leakdiag.bench.benchmark.check_target_supported` requires for the benchmark.

    Parameters
    ----------
    suites : dict
        Rig -> :class:`~leakdiag.bench.suite.SystemSuite` (:func:`comparison_suite`).
    methods : sequence of str
        Registry names.
    per_run : float
        Target false-alarm probability per healthy run, in (0, 1).
    burn_in_s : float, default 5.0
        Leading seconds of a run not monitored.

    Raises
    ------
    ValueError
        Naming the fitting runs, the smallest target they support and the fitting runs the
        target needs.

    Examples
    --------
    >>> check_comparison_target(comparison_suite(), ["acf-p1"], 0.05)
    >>> check_comparison_target(comparison_suite(n_fit=5), ["fft-p1"], 0.01)
    Traceback (most recent call last):
    ...
    ValueError: the comparison fits fft-p1's threshold on n_fit=5 healthy runs per excitation \
(vca), one CUSUM maximum each: they support a false-alarm target of at least 0.167 per run, \
and false_alarm_per_run=0.01 needs n_fit=99; give n_fit=99 or false_alarm_per_run >= 0.17
    """
    from leakdiag.bench.benchmark import unsupported_target

    if not 0.0 < per_run < 1.0:
        raise ValueError(f"false_alarm_per_run={per_run!r} must be in (0, 1)")
    for name, s in suites.items():
        short = unsupported_target(name, s, methods, per_run, burn_in_s)
        if short is None:
            continue
        method, need, low, give = short
        raise ValueError(
            f"the comparison fits {method}'s threshold on n_fit={s.n_fit} healthy runs per "
            f"excitation ({name}), one CUSUM maximum each: they support a false-alarm target "
            f"of at least {low:.3g} per run, and false_alarm_per_run={per_run:g} needs "
            f"n_fit={need}; give n_fit={need} or false_alarm_per_run >= {give:.2f}")


@dataclass
class ComparisonResult:
    """Output of :func:`run_comparison`.

    Attributes
    ----------
    runs : pandas.DataFrame
        One row per method and held-out run (:func:`leakdiag.bench.run.run_suite`), error
        rows included.
    results : pandas.DataFrame
        :func:`~leakdiag.bench.scoring.summarise` of the judged runs.
    summary : pandas.DataFrame
        :func:`~leakdiag.bench.scoring.minimum_detectable` of ``results``.
    settings : dict
        The suite, methods, target and alarm.
    """

    runs: Any
    results: Any
    summary: Any
    settings: dict = field(default_factory=dict)


def run_comparison(methods=COMPARISON_METHODS, *, false_alarm_per_run: float = COMPARISON_FAR,
                   duration_s: float = 100.0, n_fit: int = COMPARISON_N_FIT,
                   n_test_healthy: int = 10, n_test_leak: int = 5, alarm: Alarm | None = None,
                   scheduler: str = "serial", n_workers: int | None = None,
                   cache_dir: str | None = None, progress: bool = True) -> ComparisonResult:
    """Run and score the comparison of ``docs/literature.md``.

    Parameters
    ----------
    methods : sequence of str, default COMPARISON_METHODS
        Registry names.
    false_alarm_per_run : float, default 0.05
        Target false-alarm probability per healthy run; checked against ``n_fit`` before any
        simulation (:func:`check_comparison_target`).
    duration_s, n_fit, n_test_healthy, n_test_leak
        The suite (:func:`comparison_suite`).
    alarm : Alarm, optional
        Other search settings (default ``Alarm()``: binseg onsets, 5-s burn-in).
    scheduler : str, default "serial"
        ``"serial"``, ``"local"`` (Dask) or a scheduler address.
    n_workers : int, optional
        Dask workers.
    cache_dir : str, optional
        Simulation cache folder.
    progress : bool, default True
        Progress bars.

    Returns
    -------
    ComparisonResult

    Raises
    ------
    ValueError
        An unsupported target (before any work); no method judged on any group (every fit an
        error: :func:`~leakdiag.bench.scoring.summarise` names the first reason).
    """
    from leakdiag.bench.run import run_suite
    from leakdiag.bench.scoring import minimum_detectable, summarise

    alarm = alarm if alarm is not None else Alarm()
    suites = comparison_suite(duration_s, n_fit, n_test_healthy, n_test_leak)
    check_comparison_target(suites, methods, false_alarm_per_run, alarm.burn_in_s)
    sr = run_suite(suites, list(methods), false_alarm_per_run=false_alarm_per_run, alarm=alarm,
                   scheduler=scheduler, n_workers=n_workers, cache_dir=cache_dir,
                   progress=progress)
    results = summarise(sr.runs, sr.rated_flow_lpm, burn_in_s=alarm.burn_in_s)
    summary = minimum_detectable(results, sr.rated_flow_lpm, false_alarm_per_run)
    settings = {**sr.settings, "duration_s": duration_s, "n_fit": n_fit,
                "n_test_healthy": n_test_healthy, "n_test_leak": n_test_leak}
    return ComparisonResult(sr.runs, results, summary, settings)


def comparison_table(results, summary):
    """The table of ``docs/literature.md``: one row per method and excitation.

    Parameters
    ----------
    results, summary : pandas.DataFrame
        :attr:`ComparisonResult.results` and :attr:`ComparisonResult.summary`.

    Returns
    -------
    pandas.DataFrame
        ``method, excitation``, the minimum detectable leak (L/min), the ROC AUC at 0.05, 0.2
        and 1.0 L/min, the detection rate at 0.2 and 1.0 L/min, the median onset error and
        detection delay at 1.0 L/min (s), the false alarms of the held-out healthy runs (count
        of n) and the median CPU seconds per hour of signal of ``predict``.

    Examples
    --------
    >>> import pandas as pd
    >>> res = pd.DataFrame({"method": "m", "excitation": "operating", "leak_lpm": [0.2, 1.0],
    ...     "auc": [0.5, 1.0], "detection_rate": [0.2, 1.0], "onset_error_median_s": [3.0, 1.0],
    ...     "detection_delay_median_s": [9.0, 2.0], "n_runs": 10, "detections": [2, 10]})
    >>> summ = pd.DataFrame({"method": ["m"], "excitation": ["operating"],
    ...     "min_detectable_lpm": [1.0], "false_alarms": [1], "n_test_healthy": [10],
    ...     "cpu_s_per_hour": [0.04]})
    >>> print(table_markdown(comparison_table(res, summ)))
    | method | excitation | MDL L/min | AUC 0.05 | AUC 0.2 | AUC 1.0 | det 0.2 [95 % CI] | det 1.0 [95 % CI] | onset err 1.0 (s) | delay 1.0 (s) | false alarms [95 % CI] | CPU s / h |
    |---|---|---|---|---|---|---|---|---|---|---|---|
    | m | operating | 1 |  | 0.5 | 1 | 2/10 = 0.2 [0.0252, 0.556] | 10/10 = 1 [0.692, 1] | 1 | 2 | 1/10 = 0.1 [0.00253, 0.445] | 0.04 |
    """
    import pandas as pd

    from leakdiag.bench.v5_scoring import rate_text

    rows = []
    for _, s in summary.iterrows():
        g = results[(results.method == s.method) & (results.excitation == s.excitation)]

        def at(col, q, g=g):
            v = g.loc[(g.leak_lpm - q).abs() < 1e-12, col]
            return float(v.iloc[0]) if len(v) else float("nan")

        def det_at(q, g=g):  # runs detected of n, the rate and its Clopper-Pearson interval
            row = g.loc[(g.leak_lpm - q).abs() < 1e-12]
            if not len(row):
                return float("nan")
            n = int(row.n_runs.iloc[0])  # a column of every summarise result
            k = (row.detections.iloc[0] if "detections" in row else
                 round(float(row.detection_rate.iloc[0]) * n))  # results before the count
            return rate_text(k, n)

        rows.append({
            "method": s.method, "excitation": s.excitation,
            "MDL L/min": float(s.min_detectable_lpm),
            "AUC 0.05": at("auc", 0.05), "AUC 0.2": at("auc", 0.2), "AUC 1.0": at("auc", 1.0),
            "det 0.2 [95 % CI]": det_at(0.2), "det 1.0 [95 % CI]": det_at(1.0),
            "onset err 1.0 (s)": at("onset_error_median_s", 1.0),
            "delay 1.0 (s)": at("detection_delay_median_s", 1.0),
            "false alarms [95 % CI]": rate_text(s.false_alarms, s.n_test_healthy),
            "CPU s / h": float(s.cpu_s_per_hour)})
    return pd.DataFrame(rows)


def table_markdown(table) -> str:
    """A table as Markdown, numbers to 3 significant digits, NaN as an empty cell.

    Parameters
    ----------
    table : pandas.DataFrame
        E.g. :func:`comparison_table`.

    Returns
    -------
    str
        Header, separator and one line per row.
    """
    def cell(v):
        if isinstance(v, float):
            return "" if math.isnan(v) else f"{v:.3g}"
        return str(v)

    lines = ["| " + " | ".join(map(str, table.columns)) + " |",
             "|" + "---|" * len(table.columns)]
    lines += ["| " + " | ".join(cell(v) for v in row) + " |"
              for row in table.itertuples(index=False)]
    return "\n".join(lines)


def compute_seconds_per_hour(method: str, recording, system: str = "vca",
                             repeats: int = 1) -> float:
    """CPU seconds one method's feature takes per hour of signal (process time).

    Parameters
    ----------
    method : str
        Benchmark registry name (e.g. ``"emd-p1"``).
    recording : Recording
        Signal to process (its duration sets the scale).
    system : {"vca", "eha"}, default "vca"
        Rig passed to the factory.
    repeats : int, default 1
        Timed repetitions after one warm-up call (Numba compilation excluded); the minimum is
        kept.

    Returns
    -------
    float
        CPU seconds per hour of signal.

    Raises
    ------
    ValueError
        If ``repeats < 1``, the method is unknown, or its feature needs a fitted detector
        (``"combined"``).

    Examples
    --------
    >>> import numpy as np
    >>> from leakdiag.io.recording import Recording
    >>> rec = Recording({"p1": np.random.default_rng(0).standard_normal(20000)}, 1000.0)
    >>> compute_seconds_per_hour("fft-p1", rec) < 60
    True
    """
    repeats = check_int(repeats, "repeats", 1)
    det = make_detector(method, system, Alarm())
    det._feature_series(recording)  # warm-up: imports, Numba compilation
    best = float("inf")
    for _ in range(repeats):
        t0 = time.process_time()
        det._feature_series(recording)
        best = min(best, time.process_time() - t0)
    return best * 3600.0 / recording.duration


def write_comparison(out_dir, *, false_alarm_per_run: float = COMPARISON_FAR,
                     n_fit: int = COMPARISON_N_FIT, scheduler: str = "serial",
                     n_workers: int | None = None, cache_dir: str | None = None,
                     progress: bool = True):
    """Run the comparison with its defaults and write its files (``leakdiag benchmark --suite
    comparison``).

    The false-alarm target is checked against ``n_fit`` before any folder is made
    (:func:`check_comparison_target`); then ``out_dir`` and the simulation cache are created
    and checked writable (:func:`leakdiag.bench.outputs.prepare_folder`), and
    :func:`run_comparison` runs. ``out_dir`` receives ``runs.csv``, ``results.csv``,
    ``summary.csv`` (:class:`ComparisonResult`) and ``table.md`` (:func:`comparison_table` as
    :func:`table_markdown`, the table of ``docs/literature.md``); other files there are left
    alone.

    Parameters
    ----------
    out_dir : str or path-like
        Output folder (created with its parents).
    false_alarm_per_run : float, default 0.05
        Target false-alarm probability per healthy run.
    n_fit : int, default 19
        Healthy fitting runs per excitation (:func:`comparison_suite`).
    scheduler : str, default "serial"
        ``"serial"``, ``"local"`` (Dask) or a scheduler address.
    n_workers : int, optional
        Dask workers.
    cache_dir : str, optional
        Simulation cache folder (default: :func:`leakdiag.runtime.cache.resolve_cache_dir`).
    progress : bool, default True
        Progress bars.

    Returns
    -------
    pandas.DataFrame
        The table written to ``table.md`` (:func:`comparison_table`).

    Raises
    ------
    ValueError
        An unsupported target or ``n_fit`` (before any folder is made or work done), a folder
        that cannot be written (before any work), no method judged on any group
        (:func:`run_comparison`).
    """
    check_comparison_target(comparison_suite(n_fit=n_fit), COMPARISON_METHODS,
                            false_alarm_per_run)
    out = prepare_folder(out_dir, "--out")
    prepare_folder(resolve_cache_dir(cache_dir),
                   "--cache-dir" if cache_dir else "simulation cache")
    r = run_comparison(false_alarm_per_run=false_alarm_per_run, n_fit=n_fit,
                       scheduler=scheduler, n_workers=n_workers, cache_dir=cache_dir,
                       progress=progress)
    for name, df in (("runs", r.runs), ("results", r.results), ("summary", r.summary)):
        df.to_csv(out / f"{name}.csv", index=False)
    table = comparison_table(r.results, r.summary)
    (out / "table.md").write_text(table_markdown(table) + "\n", encoding="utf-8")
    return table
