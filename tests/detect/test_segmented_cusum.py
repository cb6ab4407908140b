"""segmented_cusum: Page's CUSUM restarted at each healthy-segment boundary unless in alarm,
against a plain loop; the healthy maxima of fresh segments it gives."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from leakdiag.detect.cusum import cusum, segmented_cusum
from leakdiag.detect.threshold import segment_maxima


def _by_loop(z, seg, k, keep_above):
    up = dn = 0.0
    out_up, out_dn = [], []
    for i, v in enumerate(z):
        if i and seg[i] != seg[i - 1] and not (up > keep_above or dn > keep_above):
            up = dn = 0.0
        if v == v:  # NaN skipped
            up, dn = max(0.0, up + v - k), max(0.0, dn - v - k)
        out_up.append(up)
        out_dn.append(dn)
    return out_up, out_dn


@settings(max_examples=200, deadline=None)
@given(st.lists(st.one_of(st.floats(-4, 4), st.just(float("nan"))), min_size=1, max_size=60),
       st.lists(st.integers(0, 3), min_size=60, max_size=60),
       st.sampled_from([0.0, 0.5, 1.0]), st.sampled_from([np.inf, 2.0, 0.0]))
def test_segmented_cusum_equals_a_plain_loop(z, steps, k, keep_above):
    seg = np.cumsum(steps[:len(z)])
    up, dn = segmented_cusum(z, seg, k, "both", keep_above)
    ref_up, ref_dn = _by_loop(z, seg, k, keep_above)
    np.testing.assert_allclose(up, ref_up)
    np.testing.assert_allclose(dn, ref_dn)
    if len(set(seg)) == 1:  # one segment: Page's CUSUM
        np.testing.assert_array_equal(up, cusum(z, k)[0])


def test_healthy_maxima_are_those_of_fresh_segments():
    """A healthy run of two segments: the second maximum is that of its own CUSUM from 0 (it
    was the carried-over one until 2026-11-27)."""
    z = np.array([2.0, 2.0, 2.0, 0.6, 0.6, -5.0])
    t = np.arange(1.0, 7.0)  # 3-s segments from t0 = 0.5: t = 1, 2, 3 | 4, 5, 6
    got = segment_maxima(z, t, 3.0, 0.5, 6.0, drift=0.5, direction="up")
    np.testing.assert_allclose(got, [4.5, 0.2])  # carried over, the second would be 4.7
