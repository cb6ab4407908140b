"""The pressure channel's signal chain (issue 14): transducer error and bandwidth, electrical
noise, anti-alias filter, converter.

:func:`pressure_chain` applies a :class:`~leakdiag.sim.sensors.SensorParams` to a true pressure
with a given noise sequence; :func:`~leakdiag.sim.sensors.measure_pressure` draws the noise and
calls it. The filters are :func:`antialias_sos` (Butterworth) and :func:`transducer_ba` (first
order). Sources of every value: docs/models.md, "Sensor chain".
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from scipy.signal import butter, lfilter, lfilter_zi, sosfilt, sosfilt_zi

from leakdiag._validation import check_int, check_positive

if TYPE_CHECKING:  # annotation only: sensors.py imports this module
    from leakdiag.sim.sensors import SensorParams

__all__ = ["antialias_sos", "transducer_ba", "pressure_chain"]

#: Order of the anti-alias low-pass (Butterworth) when ``antialias_cutoff_hz`` is set.
ANTIALIAS_ORDER = 2


def antialias_sos(cutoff_hz: float, sample_rate: float, order: int = ANTIALIAS_ORDER) -> np.ndarray:
    """Second-order sections of the anti-alias low-pass (Butterworth, -3 dB at the cutoff).

    Parameters
    ----------
    cutoff_hz : float
        -3 dB frequency in Hz, below the Nyquist frequency ``sample_rate / 2``.
    sample_rate : float
        Sampling rate in Hz.
    order : int, default :data:`ANTIALIAS_ORDER`
        Filter order.

    Returns
    -------
    numpy.ndarray, shape (ceil(order / 2), 6)
        Digital (bilinear, pre-warped) sections for :func:`scipy.signal.sosfilt`.

    Raises
    ------
    ValueError
        If the cutoff is not in ``(0, sample_rate / 2)``.

    Examples
    --------
    >>> sos = antialias_sos(100.0, 1000.0)
    >>> from scipy.signal import sosfreqz
    >>> _, h = sosfreqz(sos, worN=[100.0], fs=1000.0)
    >>> round(float(20 * np.log10(abs(h[0]))), 2)
    -3.01
    """
    fs = check_positive(sample_rate, "sample_rate")
    fc = check_positive(cutoff_hz, "cutoff_hz")
    if fc >= fs / 2:
        raise ValueError(f"cutoff_hz={cutoff_hz!r} must be below the Nyquist frequency "
                         f"{fs / 2:g} Hz")
    return butter(check_int(order, "order", 1, 12), fc, btype="low", output="sos", fs=fs)


def transducer_ba(bandwidth_hz: float, sample_rate: float) -> tuple[np.ndarray, np.ndarray]:
    r"""Digital first-order low-pass of the transducer (matched pole, unit DC gain).

    The continuous :math:`H(s) = 1 / (1 + s / \omega_c)` sampled by pole matching:
    :math:`y_k = a\,y_{k-1} + (1 - a)\,x_k`, :math:`a = e^{-\omega_c / f_s}`.

    Parameters
    ----------
    bandwidth_hz : float
        -3 dB frequency of the continuous filter, Hz.
    sample_rate : float
        Sampling rate, Hz.

    Returns
    -------
    b, a : numpy.ndarray
        Coefficients for :func:`scipy.signal.lfilter`.

    Examples
    --------
    >>> b, a = transducer_ba(350.0, 1000.0)
    >>> round(float(b[0] / (a[0] + a[1])), 12)  # DC gain
    1.0
    """
    fs = check_positive(sample_rate, "sample_rate")
    wc = 2.0 * np.pi * check_positive(bandwidth_hz, "bandwidth_hz")
    pole = float(np.exp(-wc / fs))
    return np.array([1.0 - pole]), np.array([1.0, -pole])


def _filter_from_rest(b, a, x: np.ndarray) -> np.ndarray:
    """``lfilter`` started in the steady state of the first sample (no start-up transient)."""
    if x.size == 0:
        return x
    return lfilter(b, a, x, zi=lfilter_zi(b, a) * x[0])[0]


def pressure_chain(pressure, noise, sensors: SensorParams, *, channel: str | None = None,
                   sample_rate: float | None = None) -> np.ndarray:
    """Pressure channel through the sensor chain, with a given noise sequence.

    In order: the channel's transducer error ``gain * p + offset``; the transducer's
    bandwidth (first-order, :func:`transducer_ba`); the electrical noise (``noise``, Pa
    referred); the acquisition's anti-alias filter (:func:`antialias_sos`); rounding to the
    ADC quantum; clipping to ``[0, full_scale - quantum]``. Filters are causal and start in
    the steady state of the first sample.

    Parameters
    ----------
    pressure : array_like, 1-D
        True gauge pressure in Pa.
    noise : array_like, 1-D
        Noise in Pa, same length (already scaled by ``pressure_noise_std_pa``).
    sensors : SensorParams
        Sensor chain.
    channel : {"p1", "p2"}, optional
        Which transducer's gain and offset apply; required if any is not ideal.
    sample_rate : float, optional
        Sampling rate in Hz; required if a filter is on.

    Returns
    -------
    numpy.ndarray
        Measured pressure in Pa.

    Raises
    ------
    ValueError
        If a transducer error is set without ``channel``, a filter without ``sample_rate``,
        or the lengths differ.

    Examples
    --------
    >>> from leakdiag.sim.sensors import SensorParams
    >>> s = SensorParams()
    >>> q = s.pressure_quantum_pa
    >>> pressure_chain([1e6], [0.4 * q], s).tolist() == [round(1e6 / q + 0.4) * q]
    True
    """
    p = np.array(pressure, dtype=np.float64).reshape(-1)
    e = np.ascontiguousarray(noise, dtype=np.float64).reshape(-1)
    if e.shape != p.shape:
        raise ValueError(f"noise has {e.size} samples, pressure {p.size}")
    if channel is not None or sensors.has_transducer_error:
        if channel is None:
            raise ValueError("channel must be 'p1' or 'p2' when the sensors have a transducer "
                             "offset or gain error")
        gain, offset = sensors.transducer_error(channel)
        if gain != 1.0 or offset != 0.0:
            p = gain * p + offset
    if sensors.filters_pressure and sample_rate is None:
        raise ValueError("sample_rate is required when the sensor chain filters "
                         f"(transducer_bandwidth_hz={sensors.transducer_bandwidth_hz!r}, "
                         f"antialias_cutoff_hz={sensors.antialias_cutoff_hz!r})")
    if sensors.transducer_bandwidth_hz is not None:
        p = _filter_from_rest(*transducer_ba(sensors.transducer_bandwidth_hz, sample_rate), p)
    noisy = p + e
    if sensors.antialias_cutoff_hz is not None and noisy.size:
        sos = antialias_sos(sensors.antialias_cutoff_hz, sample_rate, sensors.antialias_order)
        noisy = sosfilt(sos, noisy, zi=sosfilt_zi(sos) * noisy[0])[0]
    q = sensors.pressure_quantum_pa
    return np.clip(np.round(noisy / q) * q, 0.0, sensors.pressure_full_scale_pa - q)
