"""The detection measure of thesis Sec. 5.2: RMS per chunk, mean RMS before/after, % change."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from leakdiag._validation import check_int
from leakdiag.features.registry import feature_names, feature_record
from leakdiag.features.series import FeatureSeries

__all__ = ["RMSChange", "TooFewChunksError", "rms_change", "pct_change", "chunk_rms",
           "chunks_in_words", "Decision", "decide_change", "EXPECTED_DIRECTION", "DECISIONS",
           "leak_direction", "smallest_p_value"]


class _Directions(Mapping):
    """Feature name -> expected direction, read from the feature registry when asked."""

    def _items(self) -> dict[str, str]:
        return {n: feature_record(n).direction for n in feature_names()
                if feature_record(n).direction is not None}

    def __getitem__(self, key: str) -> str:
        return self._items()[key]

    def __iter__(self):
        return iter(self._items())

    def __len__(self) -> int:
        return len(self._items())

    def __repr__(self) -> str:
        return repr(self._items())


#: Direction in which a leak moves each feature (``FeatureRecord.direction``, read from the
#: registry): the thesis sees the auto- and cross-correlations fall and the metric-length ratio
#: rise after a leak (Ch. 5, Tables 5-1 to 5-12); the moments have no stated direction. See
#: docs/measure.md, "Decisions".
EXPECTED_DIRECTION: Mapping[str, str] = _Directions()


def leak_direction(feature: str, system: str | None = None) -> str:
    """How a leak moves a feature's chunk RMS, as the Sec. 5.2 decision tests it.

    Parameters
    ----------
    feature : str
        Feature name (a registry name, e.g. ``"cross-correlation"``).
    system : {"vca", "eha"} or None
        The rig, when known.

    Returns
    -------
    str
        ``"down"`` or ``"up"`` (one-sided, :data:`EXPECTED_DIRECTION`) on the VCA and when the
        rig is not known; ``"both"`` (two-sided) on the EHA, and for a feature without a
        stated direction.

    Notes
    -----
    Decision (docs/measure.md, "The test"): the directions come from the VCA's tables (Ch. 5,
    Tables 5-1 to 5-12: 63 of 64 rows of the thesis's data move as stated). The EHA's tables
    (Ch. 6) disagree: its cross-correlations' RMS *rose* after the leak in 22 of 23 rows
    (Table 6-8: 0.470 -> 0.515; Table 6-12: 0.058 -> 0.076), its P2 autocorrelation rose and
    its P2 metric-length ratio fell (one row each), while this package's EHA simulator shows
    the cross-correlation of P1, P2 falling (-9.7 % at 1.2 L/min). With the sources disagreeing,
    an EHA's features are tested two-sided: a significant change either way reads "leak". An
    unknown rig keeps the one-sided test, whose opposite change reads "inconclusive" rather
    than "leak".

    Examples
    --------
    >>> leak_direction("cross-correlation", "vca"), leak_direction("cross-correlation", "eha")
    ('down', 'both')
    >>> leak_direction("metric-length"), leak_direction("moments", "vca")
    ('up', 'both')
    """
    if system is not None and str(system).lower() == "eha":
        return "both"
    return EXPECTED_DIRECTION.get(feature, "both")


#: The three decision words, as written in ``verdict.csv``.
DECISIONS = ("leak", "no-leak", "inconclusive")


@dataclass(frozen=True)
class RMSChange:
    """Result of :func:`rms_change` (thesis Sec. 5.2, Eq. 5-1 to 5-3).

    Attributes
    ----------
    mean_rms_before, mean_rms_after : float
        Mean of the chunk RMS values before and after the onset (Eq. 5-2): RMS_nl and RMS_l.
    pct_change : float
        ``|pct_change_signed|``, the percentage as the thesis prints it.
    pct_change_signed : float
        ``(RMS_l - RMS_nl) / RMS_nl * 100`` (Eq. 5-3); negative when the feature falls.
    n_chunks_before, n_chunks_after : int
        Chunks used on each side.
    n_chunks_straddling : int
        Chunks holding a window that is not wholly on one side of the onset (left out).
    n_chunks_empty : int
        Chunks whose feature values are all NaN (left out).
    n_windows : int
        Feature values (windows) in the series.
    n_windows_dropped : int
        Trailing values that do not fill a whole chunk (left out).
    n_nan_windows : int
        NaN feature values (zero-variance windows) skipped inside their chunk's RMS.
    chunk : int
        Chunk length in feature values.
    onset : float
        Onset time in seconds.
    chunk_time, chunk_rms : numpy.ndarray
        Time (of each chunk's last window) and RMS of every chunk, straddling ones included.
    chunk_side : numpy.ndarray
        Per chunk: -1 before, +1 after, 0 straddling, 2 empty (all NaN).
    """

    mean_rms_before: float
    mean_rms_after: float
    pct_change: float
    pct_change_signed: float
    n_chunks_before: int
    n_chunks_after: int
    n_chunks_straddling: int
    n_chunks_empty: int
    n_windows: int
    n_windows_dropped: int
    n_nan_windows: int
    chunk: int
    onset: float
    chunk_time: np.ndarray = field(repr=False)
    chunk_rms: np.ndarray = field(repr=False)
    chunk_side: np.ndarray = field(repr=False)

    def as_dict(self) -> dict:
        """Scalar fields as a plain dict (for tables).

        Returns
        -------
        dict
            Means, % changes, chunk and window counts, chunk length and onset.
        """
        return {k: getattr(self, k) for k in (
            "mean_rms_before", "mean_rms_after", "pct_change", "pct_change_signed",
            "n_chunks_before", "n_chunks_after", "n_chunks_straddling", "n_chunks_empty",
            "n_windows",
            "n_windows_dropped", "n_nan_windows", "chunk", "onset")}


class TooFewChunksError(ValueError):
    """No whole chunk on one side of the onset: :func:`rms_change` has no measure to give.

    Attributes
    ----------
    partial : RMSChange
        What :func:`rms_change` did find: the means and % changes are NaN, every count
        (``n_chunks_before``, ``n_chunks_after``, ``n_chunks_straddling``, ``n_chunks_empty``,
        ``n_windows``, ``n_windows_dropped``, ``n_nan_windows``) and the per-chunk arrays are
        as for a measured series. A table row of an unmeasurable setting takes its counts from
        here, so that they mean the same as in a measured row.
    """

    def __init__(self, message: str, partial: "RMSChange | None" = None) -> None:
        super().__init__(message)  # args = (message,): picklable across worker processes
        self.partial = partial


def chunks_in_words(n_windows: int, chunk: int, n_straddling: int = 0,
                    n_empty: int = 0) -> str:
    """How a feature series falls into chunks, in words (for messages).

    Parameters
    ----------
    n_windows : int
        Feature values (windows) in the series.
    chunk : int
        Chunk length in feature values.
    n_straddling, n_empty : int, default 0
        Whole chunks straddling the onset, and whole chunks of NaN values only.

    Returns
    -------
    str

    Examples
    --------
    >>> chunks_in_words(6, 10)
    '6 windows, fewer than one chunk of 10'
    >>> chunks_in_words(15, 10, n_straddling=1)
    '15 windows, 1 whole chunk of 10: 1 straddling the onset, 5 windows left over'
    """
    k = n_windows // chunk
    left = n_windows - k * chunk
    win = f"{n_windows} window{'' if n_windows == 1 else 's'}"
    if k == 0:
        return f"{win}, fewer than one chunk of {chunk}"
    notes = ([f"{n_straddling} straddling the onset"] if n_straddling else []) + (
        [f"{n_empty} of NaN values only (zero-variance windows)"] if n_empty else []) + (
        [f"{left} window{'' if left == 1 else 's'} left over"] if left else [])
    return (f"{win}, {k} whole chunk{'' if k == 1 else 's'} of {chunk}"
            + (f": {', '.join(notes)}" if notes else ""))


def pct_change(before, after):
    """Percentage change of Eq. 5-3, ``(after - before) / before * 100`` (signed).

    Parameters
    ----------
    before : float or array_like
        Mean RMS of the non-leaking part, RMS_nl.
    after : float or array_like
        Mean RMS of the leaking part, RMS_l.

    Returns
    -------
    float or numpy.ndarray
        Signed percentage; NaN where ``before`` is 0.

    References
    ----------
    Thesis Sec. 5.2, Eq. (5-3).

    Examples
    --------
    >>> round(pct_change(0.84864, 0.48778), 4)
    -42.5222
    """
    before = np.asarray(before, dtype=np.float64)
    after = np.asarray(after, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(before != 0, (after - before) / np.where(before != 0, before, 1.0) * 100.0,
                       np.nan)
    return float(out) if out.ndim == 0 else out


def chunk_rms(values, chunk: int) -> tuple[np.ndarray, np.ndarray]:
    """RMS of consecutive chunks of a feature series (Eq. 5-1), NaN values skipped.

    Parameters
    ----------
    values : array_like
        Feature values, shape ``(m,)``.
    chunk : int
        Chunk length in values (>= 1). A trailing partial chunk is left out.

    Returns
    -------
    rms : numpy.ndarray
        Shape ``(m // chunk,)``; NaN for a chunk whose values are all NaN.
    n_valid : numpy.ndarray
        Finite values per chunk.

    Examples
    --------
    >>> chunk_rms([3.0, 4.0, 1.0, 1.0, 9.0], 2)[0].round(4).tolist()
    [3.5355, 1.0]
    """
    v = np.asarray(values, dtype=np.float64)
    chunk = check_int(chunk, "chunk", 1)
    k = len(v) // chunk
    blocks = v[: k * chunk].reshape(k, chunk)
    finite = np.isfinite(blocks)
    n_valid = finite.sum(axis=1)
    sq = np.where(finite, blocks, 0.0) ** 2
    with np.errstate(invalid="ignore", divide="ignore"):
        rms = np.where(n_valid > 0, np.sqrt(sq.sum(axis=1) / np.maximum(n_valid, 1)), np.nan)
    return rms, n_valid


def rms_change(fs: FeatureSeries, onset: float, chunk: int = 10) -> RMSChange:
    """Sec. 5.2 measure: RMS per chunk, mean RMS before and after the onset, % change.

    The feature series is cut into consecutive chunks of ``chunk`` values (step 2 of Sec. 5.2),
    the RMS of each chunk is taken (Eq. 5-1), the chunk RMS values are averaged separately before
    and after the leak onset (Eq. 5-2) and compared (Eq. 5-3).

    Parameters
    ----------
    fs : FeatureSeries
        Feature series; its window geometry gives each window's first sample time
        (:attr:`FeatureSeries.window_start`; a series without a window has instantaneous values).
    onset : float
        Leak onset time in seconds (same time base as ``fs.time``).
    chunk : int, default 10
        Chunk length in feature values (the thesis does not state it; see ``docs/measure.md``).

    Returns
    -------
    RMSChange
        Means, signed and absolute % change, chunk counts.

    Raises
    ------
    TooFewChunksError
        A ``ValueError``: there is no whole chunk before or after the onset. The message gives
        the counts; its ``partial`` attribute holds them (and the chunk RMS values).

    Notes
    -----
    A window is *before* the onset if its last sample is earlier than ``onset`` and *after* if
    its first sample is at or later than ``onset``; a chunk is used only if all its windows are on
    one side. Chunks holding a window that spans the onset are left out and counted
    (``n_chunks_straddling``). NaN values (zero-variance windows) are skipped inside their chunk
    and counted.

    .. math:: RMS = \\sqrt{\\tfrac{1}{n}\\sum x_i^2}\\;(5\\text{-}1),\\quad
              \\%\\,change = \\frac{RMS_l - RMS_{nl}}{RMS_{nl}}\\times 100\\;(5\\text{-}3)

    References
    ----------
    Thesis Sec. 5.2, Eq. (5-1), (5-2), (5-3).

    Examples
    --------
    >>> t = np.arange(40, dtype=float)
    >>> v = np.where(t < 20, 1.0, 0.5)
    >>> res = rms_change(FeatureSeries(t, v, "demo", {}), onset=20.0, chunk=5)
    >>> res.mean_rms_before, res.mean_rms_after, res.pct_change_signed
    (1.0, 0.5, -50.0)
    """
    chunk = check_int(chunk, "chunk", 1)
    onset = float(onset)
    t_last = np.asarray(fs.time, dtype=np.float64)
    t_first = fs.window_start
    m = len(t_last)
    k = m // chunk
    rms, n_valid = chunk_rms(fs.values, chunk)
    before_w = (t_last < onset)[: k * chunk].reshape(k, chunk).all(axis=1)
    after_w = (t_first >= onset)[: k * chunk].reshape(k, chunk).all(axis=1)
    usable = n_valid > 0
    side = np.where(~usable, 2, np.where(before_w, -1, np.where(after_w, 1, 0))).astype(np.int8)
    nb, na = int((side == -1).sum()), int((side == 1).sum())
    ns, ne = int((side == 0).sum()), int((side == 2).sum())
    n_nan = int(np.count_nonzero(~np.isfinite(np.asarray(fs.values)[: k * chunk])))
    t_chunk = t_last[: k * chunk].reshape(k, chunk)[:, -1] if k else np.empty(0)
    counts = dict(n_chunks_before=nb, n_chunks_after=na, n_chunks_straddling=ns,
                  n_chunks_empty=ne, n_windows=m, n_windows_dropped=m - k * chunk,
                  n_nan_windows=n_nan, chunk=chunk, onset=onset, chunk_time=t_chunk,
                  chunk_rms=rms, chunk_side=side)
    if nb == 0 or na == 0:
        nan = float("nan")
        raise TooFewChunksError(
            f"the Sec. 5.2 measure needs at least one whole chunk on each side of the onset "
            f"({onset:g} s): got {nb} before and {na} after "
            f"({chunks_in_words(m, chunk, ns, ne)}); use a smaller chunk (--chunk), more "
            f"windows (a smaller window or a larger overlap), or check the onset (--onset)",
            RMSChange(mean_rms_before=nan, mean_rms_after=nan, pct_change=nan,
                      pct_change_signed=nan, **counts))
    before = float(rms[side == -1].mean())
    after = float(rms[side == 1].mean())
    signed = pct_change(before, after)
    return RMSChange(mean_rms_before=before, mean_rms_after=after, pct_change=abs(signed),
                     pct_change_signed=signed, **counts)


@dataclass(frozen=True)
class Decision:
    """A leak decision on one feature with its basis (see :func:`decide_change`).

    Attributes
    ----------
    decision : {"leak", "no-leak", "inconclusive"}
        The answer.
    basis : str
        ``"before-after"`` (chunks of the same recording before the onset are the reference) or
        ``"healthy"`` (chunks of healthy reference recordings).
    test : str
        The test, e.g. ``"Mann-Whitney U, one-sided (feature falls)"``.
    p_value : float
        p-value in the leak's expected direction (two-sided without one); NaN when not tested.
    false_alarm_rate : float
        Significance level alpha: the probability of "leak" on one healthy run, per feature.
    n_reference, n_test : int
        Chunk RMS values in the reference and in the tested (after-onset) part.
    chunk_autocorr : float
        Lag-1 autocorrelation of the reference chunk RMS values (the test assumes ~0).
    reason : str
        Why, in words.
    p_value_opposite : float
        One-sided p-value of a change opposite to the leak's (what made an ``inconclusive``
        "something else changed"); NaN when not tested.
    """

    decision: str
    basis: str
    test: str
    p_value: float
    false_alarm_rate: float
    n_reference: int
    n_test: int
    chunk_autocorr: float
    reason: str
    p_value_opposite: float = float("nan")

    def as_dict(self) -> dict:
        """Fields as a plain dict (for tables).

        Returns
        -------
        dict
        """
        return {k: getattr(self, k) for k in (
            "decision", "basis", "test", "p_value", "false_alarm_rate", "n_reference", "n_test",
            "chunk_autocorr", "reason", "p_value_opposite")}


def smallest_p_value(n_reference: int, n_test: int, two_sided: bool = False) -> float:
    """The smallest p-value the exact Mann-Whitney test can give with these counts.

    Parameters
    ----------
    n_reference, n_test : int
        Chunk RMS values on each side (at least one each).
    two_sided : bool, default False
        A two-sided test (the one-sided bound doubled, at most 1).

    Returns
    -------
    float
        ``1 / C(n_reference + n_test, n_test)``, doubled two-sided: no ordering of the values
        gives less, so a level at or below it cannot be reached.

    Examples
    --------
    >>> round(smallest_p_value(8, 2), 4), round(smallest_p_value(8, 2, two_sided=True), 4)
    (0.0222, 0.0444)
    """
    from math import comb

    return min(1.0, (2 if two_sided else 1) / comb(int(n_reference) + int(n_test), int(n_test)))


#: Largest number of ways to choose the tested chunks among all for which, with tied values,
#: the Mann-Whitney p-value is computed exactly by enumeration (:func:`_mann_whitney_p`).
EXACT_TIES_LIMIT = 50_000


def _mann_whitney_p(test: np.ndarray, reference: np.ndarray, alternative: str) -> float:
    """Mann-Whitney p-value of ``test`` against ``reference``.

    Without ties, SciPy's (exact for small samples, else the normal approximation). With tied
    values SciPy uses the normal approximation, which can fall below anything a permutation of
    the chunks can give (a statistics audit, 2026-11-27: one tested value below ten tied ones,
    p = 0.058 against 1/11 = 0.091; null size 0.057 at 0.05 with binary values); then, when at
    most :data:`EXACT_TIES_LIMIT` arrangements exist, the exact permutation p-value of the
    midrank statistic: the share of the ``C(n, n_test)`` choices of tested chunks whose rank
    sum is at least as extreme (two-sided: twice the smaller tail, at most 1).
    """
    from itertools import chain, combinations
    from math import comb

    from scipy.stats import mannwhitneyu, rankdata

    pooled = np.concatenate([test, reference])
    n, k = len(pooled), len(test)
    if len(np.unique(pooled)) == n or comb(n, k) > EXACT_TIES_LIMIT:
        return float(mannwhitneyu(test, reference, alternative=alternative).pvalue)
    ranks = 2.0 * rankdata(pooled)  # midranks, doubled: whole numbers
    observed = ranks[:k].sum()
    m = comb(n, k)  # every choice of the tested chunks' positions, one row each
    chosen = np.fromiter(chain.from_iterable(combinations(range(n), k)), np.int64, m * k)
    sums = ranks[chosen.reshape(m, k)].sum(axis=1)
    less, greater = float(np.mean(sums <= observed)), float(np.mean(sums >= observed))
    if alternative == "less":
        return less
    if alternative == "greater":
        return greater
    return min(1.0, 2.0 * min(less, greater))


def _lag1(x: np.ndarray) -> float:
    if len(x) < 3:  # checked first: the mean of an empty array is a numpy warning
        return float("nan")
    x = x - x.mean()
    den = float(x @ x)
    return float(x[1:] @ x[:-1]) / den if den > 0 else float("nan")


def decide_change(reference, test, *, false_alarm_rate: float = 0.01, direction: str = "both",
                  basis: str = "before-after") -> Decision:
    """LEAK / NO LEAK / INCONCLUSIVE from chunk RMS values: a Mann-Whitney U test.

    Parameters
    ----------
    reference : array_like
        Chunk RMS values of the healthy state (before the onset, or healthy recordings).
    test : array_like
        Chunk RMS values under suspicion (after the onset). NaN values are left out.
    false_alarm_rate : float, default 0.01
        Significance level alpha in (0, 0.5]: the chance that a healthy run reads "leak".
    direction : {"both", "down", "up"}, default "both"
        How a leak moves the feature (:data:`EXPECTED_DIRECTION`); ``"both"`` tests two-sided.
    basis : str, default "before-after"
        Recorded in the result (what ``reference`` is).

    Returns
    -------
    Decision

    Raises
    ------
    ValueError
        For an alpha outside (0, 0.5] or an unknown direction.

    Notes
    -----
    ``leak`` when the one-sided test in the expected direction gives ``p < alpha`` (two-sided for
    ``"both"``). ``inconclusive`` when a side has no finite value, when the chunk counts cannot
    reach alpha at all (the smallest exact p-value, ``1 / C(n_ref + n_test, n_test)``, doubled
    two-sided, is above alpha), or when
    the feature moved significantly (``p < alpha``) the *opposite* way to a leak's. Otherwise
    ``no-leak``. The test treats chunks as independent and exchangeable under no leak; the
    lag-1 autocorrelation of the reference chunks is reported to check it (docs/measure.md).

    Examples
    --------
    >>> before = np.linspace(1.0, 1.2, 20)
    >>> decide_change(before, before - 0.5, direction="down").decision
    'leak'
    >>> decide_change(before, before + 0.5, direction="down").decision
    'inconclusive'
    >>> decide_change(before[:2], before[:2] - 0.5, direction="down").decision
    'inconclusive'
    """
    alpha = float(false_alarm_rate)
    if not 0.0 < alpha <= 0.5:
        raise ValueError(f"false_alarm_rate={false_alarm_rate!r} must be in (0, 0.5]")
    if direction not in ("both", "down", "up"):
        raise ValueError(f"direction={direction!r} must be one of 'both', 'down', 'up'")
    ref = np.asarray(reference, dtype=np.float64)
    tst = np.asarray(test, dtype=np.float64)
    ref, tst = ref[np.isfinite(ref)], tst[np.isfinite(tst)]
    n1, n2 = len(ref), len(tst)
    name = {"down": "one-sided (feature falls)", "up": "one-sided (feature rises)",
            "both": "two-sided"}[direction]
    test_name = f"Mann-Whitney U, {name}"
    rho = _lag1(ref)
    if n1 == 0 or n2 == 0:
        return Decision("inconclusive", basis, test_name, float("nan"), alpha, n1, n2, rho,
                        f"nothing to test ({n1} reference, {n2} tested chunk RMS values): the "
                        "test needs at least one on each side (a chunk of NaN values only has "
                        "none)")
    min_p = smallest_p_value(n1, n2, two_sided=direction == "both")
    if min_p >= alpha:
        return Decision("inconclusive", basis, test_name, float("nan"), alpha, n1, n2, rho,
                        f"too few chunks ({n1} reference, {n2} tested): the smallest p-value the "
                        f"test can give, {min_p:.3g}, is not below the false-alarm rate {alpha:g}")
    if direction == "both":
        p = _mann_whitney_p(tst, ref, "two-sided")
        if p < alpha:
            return Decision("leak", basis, test_name, p, alpha, n1, n2, rho,
                            f"the feature changed: p={p:.3g} < {alpha:g}")
        return Decision("no-leak", basis, test_name, p, alpha, n1, n2, rho,
                        f"no significant change: p={p:.3g} >= {alpha:g}")
    leak_alt, other_alt = ("less", "greater") if direction == "down" else ("greater", "less")
    p = _mann_whitney_p(tst, ref, leak_alt)
    if p < alpha:
        return Decision("leak", basis, test_name, p, alpha, n1, n2, rho,
                        f"the feature's RMS {'fell' if direction == 'down' else 'rose'} as a "
                        f"leak makes it: p={p:.3g} < {alpha:g}")
    p_other = _mann_whitney_p(tst, ref, other_alt)
    if p_other < alpha:
        return Decision("inconclusive", basis, test_name, p, alpha, n1, n2, rho,
                        f"the feature's RMS {'rose' if direction == 'down' else 'fell'} "
                        "significantly "
                        f"(p={p_other:.3g}), the opposite of a leak's signature: something else "
                        "changed", p_other)
    return Decision("no-leak", basis, test_name, p, alpha, n1, n2, rho,
                    f"no significant change in a leak's direction: p={p:.3g} >= {alpha:g}")
