"""Validation helpers shared by all public functions.

Every message names the offending value, e.g. ``lag=250 must be in [1, window=200)``.
User input is checked with ``ValueError``/``TypeError``, never ``assert``.
"""

from __future__ import annotations

import numbers

import numpy as np

__all__ = [
    "as_1d_float",
    "as_2d_float",
    "check_int",
    "check_positive",
    "check_overlap",
    "check_finite",
    "parse_lag_ratio",
    "check_length",
]


def _refuse_complex(x, name: str) -> None:
    """A signal is real: complex values would lose their imaginary part in float64."""
    if np.iscomplexobj(x):
        raise TypeError(f"{name} must be real numbers, got complex values (their imaginary "
                        "part would be dropped)")


def as_1d_float(x, name: str = "x") -> np.ndarray:
    """Coerce ``x`` (array-like or pandas Series) to a C-contiguous 1-D float64 array.

    Parameters
    ----------
    x : array_like
        Input signal.
    name : str
        Name used in error messages.

    Returns
    -------
    numpy.ndarray
        C-contiguous float64 copy or view, shape ``(n,)``.

    Raises
    ------
    TypeError
        If ``x`` is not numeric, or complex.
    ValueError
        If ``x`` is not one-dimensional.

    Examples
    --------
    >>> as_1d_float([1, 2, 3]).dtype
    dtype('float64')
    """
    _refuse_complex(x, name)
    try:
        arr = np.ascontiguousarray(np.asarray(x, dtype=np.float64))
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be numeric: {exc}") from None
    if arr.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {arr.shape}")
    return arr


def as_2d_float(x, name: str = "x") -> np.ndarray:
    """Coerce ``x`` to a C-contiguous 2-D float64 array of shape ``(samples, channels)``.

    A 1-D input becomes one column.

    Parameters
    ----------
    x : array_like
        Input signal(s), samples along axis 0.
    name : str
        Name used in error messages.

    Returns
    -------
    numpy.ndarray
        Shape ``(n, c)``, float64, C-contiguous.

    Raises
    ------
    TypeError
        If ``x`` is not numeric, or complex.
    ValueError
        If ``x`` has more than two dimensions.

    Examples
    --------
    >>> as_2d_float([1.0, 2.0]).shape
    (2, 1)
    """
    _refuse_complex(x, name)
    try:
        arr = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be numeric: {exc}") from None
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2:
        raise ValueError(f"{name} must be 1-D or 2-D (samples x channels), got shape {arr.shape}")
    return np.ascontiguousarray(arr)


def check_int(value, name: str, low: int | None = None, high: int | None = None) -> int:
    """Check that ``value`` is an integer in ``[low, high)`` and return it as ``int``.

    Parameters
    ----------
    value : int
        Value to check.
    name : str
        Name used in error messages.
    low, high : int, optional
        Inclusive lower and exclusive upper bounds.

    Returns
    -------
    int
        The value.

    Raises
    ------
    TypeError
        If ``value`` is not an integer.
    ValueError
        If ``value`` is out of bounds.

    Examples
    --------
    >>> check_int(3, "lag", 1, 10)
    3
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        else:
            raise TypeError(f"{name}={value!r} must be an integer")
    value = int(value)
    if low is not None and value < low:
        bound = f"be in [{low}, {high})" if high is not None else f"be >= {low}"
        raise ValueError(f"{name}={value} must {bound}")
    if high is not None and value >= high:
        raise ValueError(f"{name}={value} must be in [{low if low is not None else '-inf'}, {high})")
    return value


def _real(value, name: str, what: str, text: bool) -> float:
    """``value`` as a float: a bool is refused (``float(True)`` is 1.0: a flag is no number),
    and text too unless ``text`` (``check_positive`` has always taken ``"5"``)."""
    if isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name}={value!r} must be {what}, not a bool")
    if not text and not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name}={value!r} must be {what}")
    try:
        return float(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name}={value!r} must be {what}") from None


def check_positive(value, name: str) -> float:
    """Check that ``value`` is a finite number > 0.

    Parameters
    ----------
    value : float
        Value to check.
    name : str
        Name used in error messages.

    Returns
    -------
    float
        The value.

    Raises
    ------
    ValueError
        If not finite and positive.

    Examples
    --------
    >>> check_positive(1000, "sample_rate")
    1000.0
    """
    v = _real(value, name, "a number", text=True)
    if not np.isfinite(v) or v <= 0:
        raise ValueError(f"{name}={value!r} must be a finite number > 0")
    return v


def check_number(value, name: str, low: float | None = None, what: str = "a number") -> float:
    """Check that ``value`` is a finite real number (numpy scalars included; bools and text
    are not numbers), at least ``low`` when given.

    Parameters
    ----------
    value : float
        Value to check.
    name : str
        Name used in error messages.
    low : float, optional
        Smallest value allowed.
    what : str, default "a number"
        What the messages say the value must be (e.g. ``"a number of seconds or None"``).

    Returns
    -------
    float
        The value.

    Raises
    ------
    TypeError
        For a bool or anything that is not a real number.
    ValueError
        If not finite, or below ``low``.

    Examples
    --------
    >>> check_number(np.float32(2.0), "temperature_rise_k"), check_number(0, "drift", low=0.0)
    (2.0, 0.0)
    >>> check_number("5", "drift")
    Traceback (most recent call last):
    ...
    TypeError: drift='5' must be a number
    """
    v = _real(value, name, what, text=False)
    if not np.isfinite(v):
        raise ValueError(f"{name}={value!r} must be finite")
    if low is not None and v < low:
        raise ValueError(f"{name}={value!r} must be >= {low:g}")
    return v


def check_overlap(overlap) -> float:
    """Check an overlap in percent, ``0 <= overlap < 100`` (Sec. 4.4).

    Parameters
    ----------
    overlap : float
        Overlap between consecutive windows in percent.

    Returns
    -------
    float
        The overlap.

    Raises
    ------
    TypeError
        If not a number (a bool, ``True`` reading as 1 %, included).
    ValueError
        If outside ``[0, 100)``.

    Examples
    --------
    >>> check_overlap(5)
    5.0
    """
    if isinstance(overlap, (bool, np.bool_)):  # float(True) is 1.0: not an overlap
        raise TypeError(f"overlap={overlap!r} must be a number (percent)")
    try:
        v = float(overlap)
    except (TypeError, ValueError):
        raise TypeError(f"overlap={overlap!r} must be a number (percent)") from None
    if not (0.0 <= v < 100.0):
        raise ValueError(f"overlap={overlap!r} must be in [0, 100) percent")
    return v


def check_finite(x: np.ndarray, name: str = "x") -> None:
    """Raise if ``x`` holds NaN or inf, naming the first bad sample.

    Parameters
    ----------
    x : numpy.ndarray
        Array to check.
    name : str
        Name used in the message (e.g. the channel).

    Raises
    ------
    ValueError
        If any element is not finite.

    Examples
    --------
    >>> check_finite(np.array([1.0, 2.0]))
    """
    bad = ~np.isfinite(x)
    if bad.any():
        idx = int(np.flatnonzero(bad.reshape(len(x), -1).any(axis=1))[0]) if x.ndim else 0
        kind = "NaN" if np.isnan(x).any() else "inf"
        raise ValueError(
            f"{name} holds {int(bad.sum())} non-finite value(s) ({kind}); first at sample {idx}"
        )


def parse_lag_ratio(lag_ratio, window: int | None = None) -> tuple[int, int]:
    """Parse a metric-length lag ratio ``"l:k"`` (thesis notation, Eq. 4.3) into ``(l, k)``.

    Parameters
    ----------
    lag_ratio : str or pair of int
        ``"83:3"`` (spaces allowed) or ``(83, 3)``: ``l`` the long step, ``k`` the short one,
        ``l > k >= 1``.
    window : int, optional
        Window size in samples; ``l < window`` is then required.

    Returns
    -------
    tuple of int
        ``(l, k)``.

    Raises
    ------
    ValueError
        If the string is malformed, ``l > k >= 1`` fails, or ``l >= window``.
    TypeError
        If it is neither a string nor a pair of integers.

    Examples
    --------
    >>> parse_lag_ratio("83:3"), parse_lag_ratio((43, 3), window=400)
    ((83, 3), (43, 3))
    """
    if isinstance(lag_ratio, str):
        parts = lag_ratio.split(":")
        try:
            if len(parts) != 2:
                raise ValueError
            l_step, k_step = int(parts[0].strip()), int(parts[1].strip())
        except ValueError:
            raise ValueError(f"lag_ratio={lag_ratio!r} must look like 'l:k', e.g. '83:3'") from None
    else:
        try:
            l_raw, k_raw = lag_ratio
        except (TypeError, ValueError):
            raise TypeError(f"lag_ratio={lag_ratio!r} must be 'l:k' or a pair (l, k)") from None
        for v in (l_raw, k_raw):
            if isinstance(v, bool) or not isinstance(v, numbers.Integral):
                raise TypeError(f"lag_ratio={lag_ratio!r} must hold integers")
        l_step, k_step = int(l_raw), int(k_raw)
    if not l_step > k_step >= 1:
        raise ValueError(f"lag_ratio={lag_ratio!r} needs l > k >= 1, got l={l_step}, k={k_step}")
    if window is not None and l_step >= window:
        raise ValueError(f"lag_ratio={lag_ratio!r}: l={l_step} must be < window={window}")
    return l_step, k_step


def check_length(n_samples: int, window: int, name: str = "signal",
                 sample_rate: float | None = None) -> None:
    """Raise if a signal is shorter than one window (the only "shorter than one window" check).

    Parameters
    ----------
    n_samples : int
        Samples in the signal.
    window : int
        Window size in samples.
    name : str, default "signal"
        What is too short, as the message names it (``io`` passes file and channel).
    sample_rate : float, optional
        Sample rate in Hz; the message then also gives the duration.

    Raises
    ------
    ValueError
        ``"<name> has <n> samples [(<t> s)], shorter than one window (window=<N>)"``.

    Examples
    --------
    >>> check_length(10, 11)
    Traceback (most recent call last):
    ...
    ValueError: signal has 10 samples, shorter than one window (window=11)
    """
    if n_samples < window:
        dur = f" ({n_samples / sample_rate:g} s)" if sample_rate else ""
        raise ValueError(f"{name} has {n_samples} samples{dur}, shorter than one window "
                         f"(window={window})")
