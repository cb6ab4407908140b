"""TimeAxis.check_block against a plain reference: the print resolution of a block's times is
looked for only when an interval exceeds the tolerance without it (the allowance with it is
never smaller), and the outcome (passes, or the row and words of the error) is the same as
when it is always looked for."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from leakdiag.io.checks import RecordingError, print_resolution
from leakdiag.stream.chunks import TimeAxis


def _reference(axis: TimeAxis, t: np.ndarray, row0: int) -> None:
    """check_block as it was: the resolution found in every block."""
    full = t if axis.prev is None else np.concatenate(([axis.prev], t))
    off = 0 if axis.prev is None else 1
    back = np.flatnonzero(np.diff(full) <= 0)  # time not increasing: first (finding 9 of
    if len(back):                                # the streams audit, 2026-11-27)
        i = int(back[0]) + 1
        raise axis._error(float(full[i]), float(full[i - 1]), row=row0 + i - off)
    q = axis.resolution if axis.resolution is not None else print_resolution(full)
    dev = np.flatnonzero(np.abs(np.diff(full) - axis.dt) > axis._allowance(q))
    if len(dev):
        i = int(dev[0]) + 1
        raise axis._error(float(full[i]), float(full[i - 1]), row=row0 + i - off)
    axis.prev = float(t[-1])


def _outcome(fn, axis, t, row0):
    try:
        fn(axis, t, row0)
    except RecordingError as exc:
        return str(exc)
    return None


@settings(max_examples=300, deadline=None)
@given(st.sampled_from([100.0, 200.0, 1000.0, 3000.0]), st.integers(0, 6),
       st.lists(st.floats(-0.6, 0.6), min_size=2, max_size=40),
       st.integers(1, 4), st.sampled_from([None, 1e-3, 1e-6]))
def test_check_block_equals_the_reference(fs, decimals, jitter, cuts, resolution):
    n = len(jitter)
    t = np.arange(n) / fs + np.asarray(jitter) * 0.02 / fs  # up to 1.2 % of an interval
    t = np.round(t, decimals) if decimals else t  # printed at 10^-decimals s (0: binary)
    new = TimeAxis(fs, "f.csv", resolution=resolution)
    ref = TimeAxis(fs, "f.csv", resolution=resolution)
    step = max(1, n // cuts)
    for i in range(0, n, step):
        got = _outcome(TimeAxis.check_block, new, t[i:i + step], i)
        want = _outcome(_reference, ref, t[i:i + step], i)
        assert got == want
        if want is not None:
            break
