"""Conformal thresholds and Clopper-Pearson intervals: guarantees that can fail."""

import math

import numpy as np
import pytest
from scipy.stats import binomtest

from leakdiag.detect.rates import clopper_pearson
from leakdiag.detect.threshold import (InsufficientHealthyDataError,
                                       InsufficientHealthyDataWarning, ReferenceMaxima,
                                       conditional_rank, conformal_threshold, min_maxima,
                                       segment_maxima)


# ---------------------------------------------------------------- Clopper-Pearson
@pytest.mark.parametrize("k,n,lo,hi", [
    # hand values: k = 0 -> (0, 1 - (alpha/2)^(1/n)); k = n -> ((alpha/2)^(1/n), 1)
    (0, 10, 0.0, 1 - 0.025 ** (1 / 10)),
    (10, 10, 0.025 ** (1 / 10), 1.0),
    (0, 1000, 0.0, 1 - 0.025 ** (1 / 1000)),
    # k = 1, n = 2: (1 - 0.975^(1/2), 0.975^(1/2)) by symmetry of the two beta quantiles
    (1, 2, 1 - 0.975 ** 0.5, 0.975 ** 0.5),
])
def test_clopper_pearson_closed_forms(k, n, lo, hi):
    got = clopper_pearson(k, n)
    assert got[0] == pytest.approx(lo, rel=1e-10, abs=1e-14)
    assert got[1] == pytest.approx(hi, rel=1e-10)


def test_clopper_pearson_published_values_and_scipy():
    # 5 of 10, 95 %: (0.1871, 0.8129) (Clopper & Pearson's tables; e.g. Agresti & Coull 1998)
    lo, hi = clopper_pearson(5, 10)
    assert (round(lo, 4), round(hi, 4)) == (0.1871, 0.8129)
    for k, n, level in [(3, 300, 0.95), (17, 1000, 0.9), (49, 50, 0.99)]:
        ref = binomtest(k, n).proportion_ci(level, method="exact")
        assert clopper_pearson(k, n, level) == pytest.approx((ref.low, ref.high), rel=1e-9)


def test_clopper_pearson_rejects_bad_input():
    with pytest.raises(ValueError, match="k <= n"):
        clopper_pearson(5, 3)
    with pytest.raises(ValueError, match="level"):
        clopper_pearson(1, 3, level=1.0)
    assert all(math.isnan(v) for v in clopper_pearson(0, 0))


# ---------------------------------------------------------------- conformal threshold
def test_rank_and_bound_by_hand():
    b = conformal_threshold([3.0, 1.0, 2.0, 5.0, 4.0], 0.4, segment_s=60.0)
    assert (b.k, b.threshold, b.n) == (2, 4.0, 5)
    assert b.bound_per_segment == pytest.approx(2 / 6)
    assert b.bound_per_hour == pytest.approx(2 / 6 * 60)
    # p-values: (1 + #{>= s}) / (n + 1)
    assert b.p_value(4.5) == pytest.approx(2 / 6) and b.p_value(10.0) == pytest.approx(1 / 6)
    assert b.p_value(0.0) == 1.0 and b.p_value(4.5, n_segments=2) == pytest.approx(4 / 6)
    # the floor: a score above every maximum gets n_segments / (n + 1) however far above
    assert [b.at_floor(s) for s in (4.5, 5.0, 5.01, 1e9)] == [False, False, True, True]
    assert b.p_value(5.01, 3) == b.p_value(1e9, 3) == pytest.approx(3 / 6)


def test_a_verdict_at_the_p_value_floor_says_so():
    from leakdiag.detect.base import Verdict

    args = (True, 10.0, 11.0, 0.5, None, None, None, 66.4, 3.3, None, "cusum", "x")
    assert "p-value 0.5 (the smallest the healthy reference resolves for this span: the " \
        "score is above every healthy maximum it holds)" in str(Verdict(*args, confidence_floor=True))
    assert str(Verdict(*args)).endswith("p-value 0.5")
    assert Verdict(*args, confidence_floor=True).as_dict()["confidence_floor"] is True


def test_per_run_target_round_trip_keeps_its_rank():
    # 1 % per run with 299 maxima: alpha (n + 1) = 3 exactly; a per-hour round trip must not
    # turn it into 2.999999 (k = 2)
    seg = 55.0
    alpha = (0.01 * 3600.0 / seg) * seg / 3600.0
    b = conformal_threshold(np.arange(299.0), alpha, segment_s=seg)
    assert b.k == 3 and b.threshold == 296.0


def test_achieved_rate_on_fresh_healthy_maxima_inside_its_interval():
    # exchangeable healthy maxima (exponential): the exact exceedance probability of the fitted
    # threshold, exp(-h), must lie inside the Clopper-Pearson interval of the rate measured on
    # 10 000 fresh healthy maxima, and below the calibration-conditional 95 % bound in most
    # calibrations; averaged over calibrations it equals k / (n + 1) (Beta(k, n + 1 - k) mean).
    rng = np.random.default_rng(2026)
    b = conformal_threshold(rng.exponential(size=300), 0.01, segment_s=60.0)
    assert b.k == 3
    fresh = rng.exponential(size=10_000)
    alarms = int(np.count_nonzero(fresh > b.threshold))
    lo, hi = clopper_pearson(alarms, fresh.size)
    assert lo <= math.exp(-b.threshold) <= hi
    rates = np.array([math.exp(-conformal_threshold(rng.exponential(size=300), 0.01,
                                                    segment_s=60.0).threshold)
                      for _ in range(2000)])
    assert rates.mean() == pytest.approx(3 / 301, rel=0.05)  # sd of the mean ~ 1.2 %
    assert rates.mean() <= 0.01 * 1.05
    assert (rates <= b.conditional_upper_95).mean() == pytest.approx(0.95, abs=0.015)


def test_too_little_healthy_data_says_so():
    with pytest.raises(InsufficientHealthyDataError, match=r"needs at least 99 maxima"):
        conformal_threshold(np.ones(50), 0.01, segment_s=60.0)
    with pytest.warns(InsufficientHealthyDataWarning, match="unsupported"):
        b = conformal_threshold(np.arange(50.0), 0.01, segment_s=60.0, on_insufficient="warn")
    assert not b.supported and b.k == 0 and b.threshold == 49.0
    assert b.bound_per_segment == pytest.approx(1 / 51) and b.min_n_for_target == 99


# ---------------------------------------------------------------- calibration-conditional rank
@pytest.mark.parametrize("n", [1, 10, 98, 299, 300, 458, 1000, 5000])
@pytest.mark.parametrize("alpha,conf", [(0.01, 0.95), (0.01, 0.9), (0.05, 0.5), (0.001, 0.99)])
def test_conditional_rank_is_the_largest_beta_quantile_below_the_target(n, alpha, conf):
    # defined through the binomial; checked against the rate's own law, Beta(k, n + 1 - k):
    # P(rate > alpha) <= 1 - conf for k, and > 1 - conf for k + 1
    from scipy.stats import beta

    k = conditional_rank(n, alpha, conf)
    if k >= 1:
        assert beta.sf(alpha, k, n + 1 - k) <= (1 - conf) * (1 + 1e-9)
    else:
        assert (1 - alpha) ** n > 1 - conf  # even the largest maximum is not enough
        assert n < min_maxima(alpha, conf)
    if k < n:
        assert beta.sf(alpha, k + 1, n - k) > 1 - conf
    # never looser than the marginal rank at the confidences offered (the mean of the rate's
    # law, k / (n + 1), lies below its 90 % quantile)
    if conf >= 0.9:
        assert k <= math.floor(alpha * (n + 1) + 1e-9)


def test_conditional_rank_by_hand():
    # k = 1 needs (1 - alpha)^n <= 1 - c: 0.99^298 = 0.0500 > 0.05, 0.99^299 = 0.0495
    assert conditional_rank(298, 0.01, 0.95) == 0 and conditional_rank(299, 0.01, 0.95) == 1
    assert min_maxima(0.01, 0.95) == 299 and min_maxima(0.01) == 99
    # n = 1000, alpha = 1 %: P(Bin <= 4) = 0.0287, P(Bin <= 5) = 0.0661
    assert conditional_rank(1000, 0.01, 0.95) == 5 and conditional_rank(1000, 0.01, 0.9) == 6


def test_conditional_threshold_holds_its_rate_in_the_stated_share_of_calibrations():
    # exponential maxima: the exact rate of a threshold h is exp(-h). Over 4000 calibrations of
    # 299 maxima the share whose own rate exceeds 1 % must be at most 5 % (it is 0.99^299 =
    # 4.95 % here, k = 1); the marginal rank (k = 3) exceeds 1 % in P(Bin(299, .01) <= 2) = 42 %.
    rng = np.random.default_rng(7)
    m = rng.exponential(size=(4000, 299))
    cond = conformal_threshold(m[0], 0.01, segment_s=60.0, confidence=0.95)
    marg = conformal_threshold(m[0], 0.01, segment_s=60.0)
    assert (cond.k, marg.k) == (1, 3)
    top = -np.sort(-m, axis=1)
    over_cond = (np.exp(-top[:, 0]) > 0.01).mean()
    over_marg = (np.exp(-top[:, 2]) > 0.01).mean()
    sd = math.sqrt(0.0495 * 0.9505 / 4000)
    assert over_cond == pytest.approx(0.99 ** 299, abs=4 * sd)
    assert over_marg == pytest.approx(0.4218, abs=0.04)
    assert cond.conditional_upper_95 <= 0.01 < marg.conditional_upper_95


def test_conditional_basis_says_what_it_promises():
    # 600 maxima at 1 %: P(Bin <= 1) = 0.0171, P(Bin <= 2) = 0.0611 -> k = 2 (marginal: 6)
    b = conformal_threshold(np.arange(600.0), 0.01, segment_s=55.0, confidence=0.95)
    assert (b.k, b.threshold, b.confidence, b.conditional) == (2, 598.0, 0.95, True)
    text = str(b)
    assert "with probability 95 % over the healthy data" in text and "2nd largest" in text
    assert b.as_dict()["confidence"] == 0.95
    assert not conformal_threshold(np.arange(400.0), 0.01, segment_s=55.0).conditional
    with pytest.raises(InsufficientHealthyDataError, match=r"at 95 % confidence needs at least "
                                                           r"299 maxima"):
        conformal_threshold(np.arange(298.0), 0.01, segment_s=55.0, confidence=0.95)
    with pytest.raises(ValueError, match="confidence"):
        conformal_threshold(np.arange(400.0), 0.01, segment_s=55.0, confidence=1.0)


def test_reference_maxima_pooled_and_checked():
    ref = ReferenceMaxima(np.arange(100.0), segment_s=60.0, drift=0.5, direction="both",
                          burn_in_s=5.0, source="virtual machines", n_units=100)
    b = conformal_threshold(np.arange(100.0, 199.0), 0.01, segment_s=60.0, reference=ref)
    assert (b.n, b.n_own, b.n_reference, b.k) == (199, 99, 100, 2)
    assert b.threshold == 197.0 and b.reference_source == "virtual machines"
    with pytest.raises(ValueError, match="segment_s"):
        ref.check_compatible(30.0, 0.5, "both", 5.0)
    with pytest.raises(ValueError, match="direction"):
        ref.check_compatible(60.0, 0.5, "up", 5.0)


def test_segment_maxima_by_hand_and_incomplete_segment_left_out():
    z = [2.0, 2.0, -3.0, 0.0, 5.0]
    t = [1.0, 2.0, 3.0, 4.0, 5.0]
    # CUSUM (k = 0.5): up 1.5 3 0 0 4.5; down 0 0 2.5 2 0 -> max 1.5 3 2.5 2 4.5
    assert segment_maxima(z, t, 2.0, 0.5, 4.6).tolist() == [3.0, 2.5]  # 5th in partial segment
    assert segment_maxima(z, t, 2.0, 0.5, 5.999).tolist() == [3.0, 2.5, 4.5]  # tolerance
    assert segment_maxima(z, t, 10.0, 0.5, 4.6).size == 0
