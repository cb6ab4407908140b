"""The degenerate-window rule: NaN for that window plus ONE counted warning per call."""

from __future__ import annotations

import warnings

import numpy as np

__all__ = ["DegenerateWindowWarning", "warn_degenerate", "check_magnitude"]

#: float64's usable range for the features' window sums: a value ``v`` of a sum of ``N`` powers
#: ``x^p`` must stay within ``[1e-300, 1e300]`` (normal numbers, away from overflow).
_SUM_RANGE = (1e-300, 1e300)


class DegenerateWindowWarning(RuntimeWarning):
    """Some windows had a zero denominator (zero variance, or zero metric length in Eq. 4.3).

    Their feature values are NaN. One warning is issued per call, with the count.
    """


def warn_degenerate(n_bad: int, n_windows: int, what: str, stacklevel: int = 3) -> None:
    """Warn once, with the count, if ``n_bad > 0`` windows out of ``n_windows`` are degenerate.

    Parameters
    ----------
    n_bad : int
        Number of degenerate windows (their values are NaN).
    n_windows : int
        Number of windows computed.
    what : str
        The reason, e.g. ``"zero variance"``.
    stacklevel : int
        Passed to :func:`warnings.warn` so the warning points at the user's call.
    """
    if n_bad:
        warnings.warn(
            f"{int(n_bad)} of {int(n_windows)} windows have {what}; their values are NaN",
            DegenerateWindowWarning,
            stacklevel=stacklevel,
        )


def check_magnitude(values, n_bad: int, signals, names, power: int, window: int) -> None:
    """Refuse a signal too large or too small for the feature's sums in float64.

    A window sum of ``N`` powers ``x^p`` (``p`` = 2 for the correlations' variances, 4 for the
    kurtosis) overflows when ``|x|`` passes ``(1e300 / N)^(1/p)`` (1e75 for the kurtosis, 1e148
    for a correlation over 200 samples) and underflows below ``1e-300^(1/p)``: the result is
    then NaN or inf, or a variance read as zero, where the data have a perfectly defined value.
    Looked at only when a result holds a NaN or inf (a degenerate window, or such a number), so
    the common path costs nothing; a channel of zeros (``max |x| = 0``) is degenerate, not out
    of range.

    Parameters
    ----------
    values : numpy.ndarray
        The kernel's results.
    n_bad : int
        Windows it counted as degenerate.
    signals : sequence of numpy.ndarray
        The signals it read.
    names : sequence of str
        Their names, for the message.
    power : int
        Highest power of a sample in the feature's sums.
    window : int
        Window size N.

    Raises
    ------
    ValueError
        Naming the signal, its largest magnitude and the range it must lie in.

    Examples
    --------
    >>> x = np.array([1.0, 2.0, 3.0, 10.0])
    >>> check_magnitude(np.array([0.04]), 0, [x], ["x"], 2, 4)
    >>> check_magnitude(np.array([np.nan]), 1, [x * 1e160], ["x"], 2, 4)
    Traceback (most recent call last):
    ...
    ValueError: x: its largest magnitude, 1e+161, is beyond what float64 sums of squares ...
    """
    if not n_bad and bool(np.isfinite(values).all()):
        return
    lo = _SUM_RANGE[0] ** (1.0 / power)
    hi = (_SUM_RANGE[1] / window) ** (1.0 / power)
    what = {2: "squares", 3: "cubes", 4: "fourth powers"}.get(power, f"powers {power}")
    for x, name in zip(signals, names):
        big = float(np.max(np.abs(x))) if len(x) else 0.0
        if big > hi or 0.0 < big < lo:
            raise ValueError(f"{name}: its largest magnitude, {big:.3g}, is beyond what float64 "
                             f"sums of {what} over {window} samples hold (magnitudes in "
                             f"[{lo:.3g}, {hi:.3g}]); rescale it (other units)")
