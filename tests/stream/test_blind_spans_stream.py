"""BlindSpans: a block of windows at once (the live board) equals one window at a time (the
monitor), whatever the split."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from leakdiag.stream.blind import BlindSpans


def _state(b):
    return (b.windows, b.longest[0], b.current_blind, b.blind,
            None if math.isnan(b.since) else b.since,
            None if math.isnan(b.longest[1]) else b.longest[1:], list(b.ended))


@settings(max_examples=200, deadline=None)
@given(st.lists(st.booleans(), min_size=1, max_size=60), st.lists(st.integers(1, 60), max_size=8))
def test_blocks_equal_single_windows(undefined, cuts):
    t = np.arange(1.0, len(undefined) + 1.0)
    v = np.where(undefined, np.nan, 1.0)
    one, blocks = BlindSpans(1.0, step_s=1.0), BlindSpans(1.0, step_s=1.0)  # limit 10 s
    for ti, vi in zip(t, v):
        one.add(ti, vi)
    edges = sorted({0, len(t), *[c for c in cuts if c < len(t)]})
    for a, b in zip(edges[:-1], edges[1:]):
        blocks.add_block(t[a:b], v[a:b])
    assert _state(blocks) == _state(one)
    # ended spans by hand: runs of more than 10 undefined windows (of 1 s; limit 10 s) that a
    # defined window ends, as (first window's time, the defined window's time)
    ended, run = [], 0
    for i, u in enumerate(undefined):
        if u:
            run += 1
        else:
            if run > 10:
                ended.append((t[i - run], t[i]))
            run = 0
    assert list(one.ended) == ended
