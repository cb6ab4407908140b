"""The degenerate-window rule: NaN for that window plus ONE counted warning per call."""

from __future__ import annotations

import warnings

__all__ = ["DegenerateWindowWarning", "warn_degenerate"]


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
