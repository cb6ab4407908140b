"""Unit table and SI conversion: hand-computed factors and physics identities."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from leakdiag.io.units import UNITS, known_units, to_si, unit_factor, unit_quantity


@pytest.mark.parametrize(
    "unit, factor",
    [
        ("Pa", 1.0), ("kPa", 1e3), ("MPa", 1e6), ("bar", 1e5),
        ("psi", 6894.757293168361),  # 1 lbf/in^2 = 4.4482216152605 N / 6.4516e-4 m^2
        ("m", 1.0), ("mm", 1e-3), ("um", 1e-6), ("in", 0.0254),
        ("V", 1.0), ("mV", 1e-3),
        ("m^3/s", 1.0), ("L/min", 1.0 / 60000.0), ("L/s", 1e-3),
        ("s", 1.0), ("ms", 1e-3), ("us", 1e-6), ("deg", np.pi / 180),
    ],
)
def test_factor_table(unit, factor):
    assert unit_factor(unit) == pytest.approx(factor, rel=1e-15)


def test_psi_from_definition():
    lbf_n = 0.45359237 * 9.80665
    assert unit_factor("psi") == pytest.approx(lbf_n / 0.0254**2, rel=1e-15)
    # 3000 psi is the classic aircraft supply pressure: 20.684 MPa
    assert to_si([3000.0], "psi", channel="p1")[0][0] == pytest.approx(20.684271879e6, rel=1e-9)


def test_leak_flow_lpm():
    values, unit = to_si([0.1, 1.2], "L/min", channel="leak_flow")
    assert unit == "m^3/s"
    np.testing.assert_allclose(values, [0.1e-3 / 60, 1.2e-3 / 60], rtol=1e-15)


def test_counts_kept_without_gain():
    values, unit = to_si(np.array([0, 16383], dtype=np.int16), "counts", channel="p1")
    assert unit == "counts"
    assert values.dtype == np.float64
    assert values.tolist() == [0.0, 16383.0]


def test_counts_with_gain_and_offset_give_si():
    values, unit = to_si([8192, 16383], "counts", gain=1000.0, offset=8192, channel="p2")
    assert unit == "Pa"
    assert values.tolist() == [0.0, 8191000.0]


def test_gain_then_unit_factor():
    # (raw - offset) * gain is in the given unit, then converted: (12 - 2) * 0.5 bar = 5e5 Pa
    values, unit = to_si([12.0], "bar", gain=0.5, offset=2.0, channel="p1")
    assert (values.tolist(), unit) == ([5e5], "Pa")


def test_none_unit_is_si_for_standard_channel_and_unknown_otherwise():
    assert to_si([1.0], None, channel="x")[1] == "m"
    assert to_si([1.0], None, channel="angle")[1] is None


def test_counts_gain_on_custom_channel_needs_si_unit():
    with pytest.raises(ValueError, match="channel 'angle': counts with a gain .* with si_unit"):
        to_si([1.0], "counts", gain=2.0, channel="angle")
    values, unit = to_si([1.0], "counts", gain=2.0, channel="angle", si_unit="rad")
    assert (values.tolist(), unit) == ([2.0], "rad")
    with pytest.raises(ValueError, match="does not match"):
        to_si([1.0], "counts", gain=2.0, channel="p1", si_unit="m")


def test_unknown_unit_lists_known_ones():
    with pytest.raises(ValueError, match=r"channel 'p1': unknown unit 'atm'; known units: Pa, kPa"):
        to_si([1.0], "atm", channel="p1")
    with pytest.raises(ValueError, match="unknown unit 'furlong'"):
        unit_factor("furlong")
    with pytest.raises(ValueError, match="known units: .*psi.*counts"):
        unit_quantity("furlong")


def test_wrong_quantity_for_channel():
    with pytest.raises(ValueError, match=r"unit 'mm' measures position, but the channel is a "
                                         r"pressure \(SI unit 'Pa'\)"):
        to_si([1.0], "mm", channel="p1")


def test_counts_offset_without_gain_is_an_error():
    with pytest.raises(ValueError, match="offset but no gain"):
        to_si([1.0], "counts", offset=3.0, channel="p1")


def test_non_finite_gain():
    with pytest.raises(ValueError, match="gain=inf must be finite"):
        to_si([1.0], "bar", gain=float("inf"))


def test_known_units_complete():
    assert set(known_units()) == set(UNITS) | {"counts"}
    assert unit_factor.__doc__ and unit_quantity("counts") == "counts"


@settings(max_examples=40, deadline=None)
@given(st.sampled_from([u for u, (q, _) in UNITS.items() if q == "pressure"]),
       st.floats(-1e6, 1e6, allow_nan=False))
def test_conversion_is_linear(unit, value):
    (a, b), _ = to_si([value, 2 * value], unit, channel="p1")
    assert b == pytest.approx(2 * a, rel=1e-12, abs=1e-300)
    assert a == pytest.approx(value * unit_factor(unit), rel=1e-15, abs=1e-300)


def test_import_io_is_light():
    import subprocess
    import sys

    code = ("import sys, leakdiag.io; heavy = [m for m in ('pandas', 'pyarrow', 'h5py', "
            "'scipy.io', 'matplotlib') if m in sys.modules]; print(','.join(heavy))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "", f"import leakdiag.io pulls in {out.stdout.strip()}"


@pytest.mark.parametrize("make", [
    lambda a: a[::2],                                  # strided view
    lambda a: np.asarray(a, dtype=np.float32),         # single precision
    lambda a: a.astype(np.int64),                      # integers
    lambda a: __import__("pandas").Series(a),          # pandas Series
])
def test_to_si_accepts_array_likes(make):
    base = np.arange(8.0)
    base.setflags(write=False)                         # read-only input
    arr = make(base)
    values, unit = to_si(arr, "kPa", channel="p1")
    assert unit == "Pa" and values.dtype == np.float64
    np.testing.assert_array_equal(values, np.asarray(arr, dtype=np.float64) * 1e3)


def test_speed_channel_in_rad_per_s_and_rpm():
    # 1200 rpm = 1200 * 2 pi / 60 = 40 pi rad/s (the EHA pump peak at 3 V, Sec. 4.6)
    values, unit = to_si([1200.0, -60.0], "rpm", channel="speed")
    assert unit == "rad/s"
    np.testing.assert_allclose(values, [40 * np.pi, -2 * np.pi], rtol=1e-15)
    assert to_si([3.0], "rad/s", channel="speed") == (pytest.approx([3.0]), "rad/s")
    assert to_si([3.0], None, channel="speed")[1] == "rad/s"
    with pytest.raises(ValueError, match="unit 'rad' measures angle, but the channel is a "
                                         "angular_speed .*rad/s, rpm"):
        to_si([1.0], "rad", channel="speed")
