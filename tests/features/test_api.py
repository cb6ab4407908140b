"""API hygiene of leakdiag.features: __all__, numpydoc sections, equation numbers."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

import leakdiag.features as features
from leakdiag.features import autocorrelation

PUBLIC_FUNCTIONS = ["autocorrelation", "cross_correlation", "metric_length_ratio", "moments",
                    "autocorrelation_at", "cross_correlation_at", "metric_length_ratio_at",
                    "moments_at"]


def test_all_lists_public_api():
    for name in PUBLIC_FUNCTIONS + ["FeatureSeries", "DegenerateWindowWarning"]:
        assert name in features.__all__
        assert hasattr(features, name)
    assert len(set(features.__all__)) == len(features.__all__)


@pytest.mark.parametrize("name", PUBLIC_FUNCTIONS)
def test_numpydoc_sections(name):
    doc = inspect.getdoc(getattr(features, name))
    for section in ("Parameters", "Returns", "Raises", "Examples"):
        assert f"\n{section}\n{'-' * len(section)}\n" in doc, (name, section)
    # every parameter is documented
    for param in inspect.signature(getattr(features, name)).parameters:
        assert param in doc, (name, param)


@pytest.mark.parametrize("name,eq", [("autocorrelation", "4.1"), ("cross_correlation", "4.2"),
                                     ("metric_length_ratio", "4.3"), ("moments", "4.11")])
def test_main_functions_cite_their_equation(name, eq):
    doc = inspect.getdoc(getattr(features, name))
    assert "Notes\n-----" in doc and "References\n----------" in doc
    assert f"Eq. {eq}" in doc


def test_contract_signatures():
    sig = inspect.signature(features.autocorrelation)
    assert list(sig.parameters) == ["x", "lag", "window", "overlap", "sample_rate", "start_time"]
    assert sig.parameters["sample_rate"].default == 1.0
    sig = inspect.signature(features.cross_correlation)
    assert list(sig.parameters)[:2] == ["y", "x"]
    sig = inspect.signature(features.metric_length_ratio)
    assert list(sig.parameters)[:2] == ["x", "lag_ratio"]


@pytest.mark.parametrize("kwargs, error, match", [
    ({"x": np.arange(100) + 1j}, TypeError, "x must be real numbers, got complex values"),
    ({"overlap": True}, TypeError, r"overlap=True must be a number \(percent\)"),
    ({"overlap": np.bool_(False)}, TypeError, r"overlap=np.False_ must be a number"),
])
def test_a_complex_signal_or_a_bool_overlap_is_refused(kwargs, error, match):
    """An audit: complex input lost its imaginary part with only NumPy's ComplexWarning, and
    overlap=True was taken as 1 %."""
    args = {"x": np.random.default_rng(0).normal(size=100), "lag": 1, "window": 10,
            "overlap": 5.0, **kwargs}
    with pytest.raises(error, match=match):
        autocorrelation(**args)
