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


def test_every_window_applies_the_fraction_rule_of_predict():
    """Audit 2026-11-27, finding 2: on a 3-s stream no span reaches the 10-s limit; with every
    judged window given, more than half undefined is blind, as Detector.predict refuses it."""
    nan = float("nan")
    t = 0.2 * np.arange(1, 16)
    v = np.r_[0.5, 0.6, np.full(13, nan)]
    b = BlindSpans(0.0, step_s=0.2, every_window=True)
    b.add_block(t, v)
    assert (b.judged, b.undefined, b.rule, b.blind) == (15, 13, "fraction", True)
    assert b.words("stuck.csv", "acf p1") == (
        "stuck.csv: the feature 'acf p1' was undefined in 13 of the 15 windows judged (more "
        "than half; the longest span 13 windows from 0.6 to 3 s: a channel it reads is constant "
        "there, a stuck sensor?), so the absence of an alarm rules nothing out: it rests on 2 "
        "defined window(s)")
    one = BlindSpans(0.0, step_s=0.2, every_window=True)
    for ti, vi in zip(t, v):
        one.add(ti, vi)
    assert (one.judged, one.undefined, one.rule) == (15, 13, "fraction")
    half = BlindSpans(0.0, step_s=0.2, every_window=True)
    half.add_block(t[:14], np.r_[np.zeros(7), np.full(7, nan)])
    assert not half.blind  # 7 of 14: not more than half
    # a caller that gives only the undefined windows: the span limit only
    partial = BlindSpans(0.0, step_s=0.2)
    partial.add_block(t[2:], v[2:])
    assert partial.rule is None and not partial.blind


def test_the_fraction_rule_follows_the_healthy_share_as_predict_does():
    """The same limit as ``Detector.predict`` (``undefined_limit``): 10 of 15 windows undefined
    in short spans refuse NO LEAK against healthy recordings that had none, not against ones
    that had 64 % (a review, 2026-11-27)."""
    import numpy as np

    from leakdiag.stream.blind import BlindSpans

    v = np.array([0.1, np.nan, np.nan, 0.0, np.nan, np.nan, 0.2, np.nan, np.nan, 0.0, np.nan,
                  np.nan, -0.1, np.nan, np.nan])
    t = np.arange(15) * 0.2
    for fraction, blind in ((0.0, True), (0.64, False)):
        b = BlindSpans(0.0, 0.2, every_window=True, healthy_fraction=fraction)
        for ti, vi in zip(t, v):
            b.add(float(ti), float(vi))
        assert (b.judged, b.undefined, b.blind) == (15, 10, blind)
    b = BlindSpans(0.0, 0.2, every_window=True, healthy_fraction=0.64)
    b.add_block(t, np.r_[0.1, 0.2, np.full(13, np.nan)])
    assert b.rule == "fraction" and "(more than 82%, the healthy recordings had at most 64%;" \
        in b.words("s.csv", "acf p1")
