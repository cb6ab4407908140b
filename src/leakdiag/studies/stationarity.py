"""Stationarity analysis of thesis Sec. 4.7: windowed moments plus ADF and KPSS tests.

The thesis judges stationarity by eye from the windowed mean, variance, skewness and kurtosis
(Eq. 4.11-4.14, window 400, overlap 50 %). We add two formal tests from statsmodels per signal:
the augmented Dickey-Fuller test (null: a unit root, i.e. non-stationary) and the KPSS test
(null: level stationary). Both run on the signal reduced to at most :data:`TEST_MAX_POINTS`
points by block means (an anti-aliased decimation), so that they stay fast on 400 000 samples;
the reduction is reported.
"""

from __future__ import annotations

import warnings

import numpy as np

from leakdiag.features.moments import to_frame
from leakdiag.features.spec import MethodSpec, compute_feature
from leakdiag.studies.grid import quiet_degenerate

__all__ = ["TEST_MAX_POINTS", "ALPHA", "decimate_mean", "stationarity_tests", "stationarity"]

#: Largest series handed to ADF/KPSS (decision, docs/studies.md).
TEST_MAX_POINTS = 4000
#: Significance level of the verdicts.
ALPHA = 0.05


def decimate_mean(x, max_points: int = TEST_MAX_POINTS) -> tuple[np.ndarray, int]:
    """Block means of ``x`` so that at most ``max_points`` remain.

    Parameters
    ----------
    x : array_like
        Signal.
    max_points : int, default TEST_MAX_POINTS
        Largest output length.

    Returns
    -------
    y : numpy.ndarray
        Means of consecutive blocks (a trailing partial block is dropped).
    factor : int
        Block length (1 = unchanged).

    Examples
    --------
    >>> y, f = decimate_mean(np.arange(10.0), 4)
    >>> y.tolist(), f
    ([1.0, 4.0, 7.0], 3)
    """
    x = np.asarray(x, dtype=np.float64)
    factor = max(1, int(np.ceil(len(x) / max_points)))
    k = len(x) // factor
    return x[: k * factor].reshape(k, factor).mean(axis=1), factor


def stationarity_tests(x, max_points: int = TEST_MAX_POINTS, alpha: float = ALPHA) -> dict:
    """ADF and KPSS tests of one signal, with a plain-words verdict.

    Parameters
    ----------
    x : array_like
        Signal.
    max_points : int, default TEST_MAX_POINTS
        Decimation target (see :func:`decimate_mean`).
    alpha : float, default ALPHA
        Significance level.

    Returns
    -------
    dict
        ``adf_stat``, ``adf_p``, ``kpss_stat``, ``kpss_p`` (KPSS p-values are clipped by
        statsmodels to [0.01, 0.1]; ``kpss_p_bound`` says so), ``decimation``, ``n_points`` and
        ``verdict``: ``"stationary"`` (ADF rejects, KPSS does not), ``"non-stationary"``
        (KPSS rejects, ADF does not), ``"trend/difference stationary?"`` (both reject) or
        ``"inconclusive"`` (neither rejects).

    Notes
    -----
    ADF: :func:`statsmodels.tsa.stattools.adfuller` with ``autolag="AIC"``; KPSS:
    :func:`statsmodels.tsa.stattools.kpss` with ``regression="c"``, ``nlags="auto"``.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> stationarity_tests(rng.normal(size=2000))["verdict"]
    'stationary'
    >>> stationarity_tests(np.cumsum(rng.normal(size=2000)))["verdict"]
    'non-stationary'
    """
    from statsmodels.tools.sm_exceptions import InterpolationWarning
    from statsmodels.tsa.stattools import adfuller, kpss
    from threadpoolctl import threadpool_limits

    y, factor = decimate_mean(x, max_points)
    if len(y) < 20 or np.ptp(y) == 0:
        return {"adf_stat": np.nan, "adf_p": np.nan, "kpss_stat": np.nan, "kpss_p": np.nan,
                "kpss_p_bound": "", "decimation": factor, "n_points": len(y),
                "verdict": "constant or too short"}
    # One BLAS thread: the many small least-squares fits of ADF's lag search are 30x slower
    # with oversubscribed threads on a busy machine, and the results do not depend on it.
    with threadpool_limits(1), warnings.catch_warnings(record=True) as caught:
        # statsmodels announces a change of adfuller's return type (FutureWarning); we only
        # read the first two items, which stay the statistic and the p-value.
        warnings.simplefilter("ignore", FutureWarning)
        warnings.simplefilter("always", InterpolationWarning)
        adf_stat, adf_p = adfuller(y, autolag="AIC")[:2]
        kpss_stat, kpss_p = kpss(y, regression="c", nlags="auto")[:2]
    bound = ""
    if any(issubclass(w.category, InterpolationWarning) for w in caught):
        bound = "<=" if kpss_p <= 0.01 else ">="
    adf_rej, kpss_rej = adf_p < alpha, kpss_p < alpha
    verdict = {(True, False): "stationary", (False, True): "non-stationary",
               (True, True): "trend/difference stationary?",
               (False, False): "inconclusive"}[(bool(adf_rej), bool(kpss_rej))]
    return {"adf_stat": float(adf_stat), "adf_p": float(adf_p), "kpss_stat": float(kpss_stat),
            "kpss_p": float(kpss_p), "kpss_p_bound": bound, "decimation": factor,
            "n_points": len(y), "verdict": verdict}


def stationarity(recording, channels=("p1", "p2", "x", "u"), window: int = 400,
                 overlap: float = 50.0) -> dict:
    """Sec. 4.7 on a recording: windowed moments and ADF/KPSS per signal, before the leak too.

    Parameters
    ----------
    recording : Recording
        The recording.
    channels : sequence of str, default ("p1", "p2", "x", "u")
        Signals analysed (those missing are skipped).
    window : int, default 400
        Moment window in samples (Sec. 4.7.1).
    overlap : float, default 50.0
        Moment window overlap in percent (Sec. 4.7.1).

    Returns
    -------
    dict
        ``moments``: channel -> DataFrame of windowed moments (Eq. 4.11-4.14);
        ``tests``: list of dict rows (channel, part ``"whole"`` / ``"before leak"``, test
        results of :func:`stationarity_tests`).
    """
    moments, tests = {}, []
    onset = recording.onset
    for ch in channels:
        if ch not in recording:
            continue
        with quiet_degenerate():  # zero-variance windows are NaN rows of the moments frame
            moments[ch] = to_frame(compute_feature(
                recording, MethodSpec("moments", (ch,), window=window, overlap=overlap)))
        parts = [("whole", recording[ch])]
        if onset is not None:
            i = int(round((onset - recording.start_time) * recording.sample_rate))
            parts.append(("before leak", recording[ch][:i]))
        for part, x in parts:
            tests.append({"channel": ch, "part": part, **stationarity_tests(x)})
    return {"moments": moments, "tests": tests}
