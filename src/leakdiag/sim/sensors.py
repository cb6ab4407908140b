"""Sensor models of the test rigs (thesis Sec. 2.2): pressure transducer + ADC, encoder, DAC.

Shared by the VCA and EHA simulators. The scalar functions are Numba-compiled so that a
closed-loop integrator can measure inside its loop (the controller sees the *measured*
position, as on the rig); the array functions apply the same models to whole channels.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numba
import numpy as np
from scipy.signal import butter, sosfilt, sosfilt_zi

from leakdiag._validation import check_int, check_positive

__all__ = [
    "PSI_PA",
    "SensorParams",
    "antialias_sos",
    "quantize",
    "adc_reading",
    "measure_pressure",
    "measure_position",
]

#: 1 psi in Pa.
PSI_PA = 6894.757293168
#: Pressure transducer range, 0-3000 psig (Sec. 2.2: "a range of 3000 Psig ... 21 MPa").
PRESSURE_FULL_SCALE_PA = 3000.0 * PSI_PA
#: DAS16F input-output board: 12-bit A/D and D/A converters (Keithley MetraByte DAS-16F data
#: sheet; the thesis names the board in Sec. 2.2 but not its resolution).
DAS16F_BITS = 12
#: Encoder accuracy, 0.03 mm linear displacement (Sec. 2.2, M5312 quadrature encoder card).
ENCODER_RESOLUTION_M = 0.03e-3
#: Order of the anti-alias low-pass (Butterworth) when ``antialias_cutoff_hz`` is set.
ANTIALIAS_ORDER = 2


@dataclass(frozen=True)
class SensorParams:
    """Sensor chain of the rig (Sec. 2.2).

    Parameters
    ----------
    pressure_full_scale_pa : float, default 3000 psi = 20.68 MPa
        Pressure transducer range (0 to full scale, gauge); readings are clipped to it.
    pressure_adc_bits : int, default 12
        ADC resolution over the transducer range (DAS16F, 12 bit): quantum
        ``full_scale / 2**bits`` = 5.05 kPa.
    pressure_noise_std_pa : float, default 10e3
        Standard deviation of white noise added before the ADC (about 0.05 % of full scale;
        the thesis does not state it, this is typical for a strain-gauge transducer and cable).
    position_resolution_m : float, default 0.03e-3
        Encoder quantum (Sec. 2.2, 0.03 mm).
    control_dac_bits : int, default 12
        D/A resolution of the control signal over ``[-control_limit, +control_limit]``.
    p1_offset_pa, p2_offset_pa : float, default 0
        Zero (offset) error of the P1 / P2 transducer in Pa, added before quantisation.
    p1_gain, p2_gain : float, default 1
        Span (gain) factor of the P1 / P2 transducer, > 0, applied before quantisation:
        reading ``= gain * p + offset + noise`` before the anti-alias filter and converter.
    antialias_cutoff_hz : float or None, default None
        -3 dB cutoff of the acquisition's anti-alias low-pass in Hz; ``None`` = no filter
        (the default, which leaves every reading bit-identical to the chain without it).

    Raises
    ------
    ValueError
        If a value is not positive (the noise and offsets may be 0 or any finite value).

    Examples
    --------
    >>> s = SensorParams()
    >>> round(s.pressure_quantum_pa)
    5050
    """

    pressure_full_scale_pa: float = PRESSURE_FULL_SCALE_PA
    pressure_adc_bits: int = DAS16F_BITS
    pressure_noise_std_pa: float = 10e3
    position_resolution_m: float = ENCODER_RESOLUTION_M
    control_dac_bits: int = DAS16F_BITS
    p1_offset_pa: float = 0.0
    p2_offset_pa: float = 0.0
    p1_gain: float = 1.0
    p2_gain: float = 1.0
    antialias_cutoff_hz: float | None = None

    def __post_init__(self) -> None:
        check_positive(self.pressure_full_scale_pa, "pressure_full_scale_pa")
        check_int(self.pressure_adc_bits, "pressure_adc_bits", 1, 33)
        check_int(self.control_dac_bits, "control_dac_bits", 1, 33)
        check_positive(self.position_resolution_m, "position_resolution_m")
        noise = float(self.pressure_noise_std_pa)
        if not np.isfinite(noise) or noise < 0:
            raise ValueError(f"pressure_noise_std_pa={self.pressure_noise_std_pa!r} must be >= 0")
        for name in ("p1_offset_pa", "p2_offset_pa"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating,
                                                                 np.integer)) \
                    or not np.isfinite(value):
                raise ValueError(f"{name}={value!r} must be a finite number")
        check_positive(self.p1_gain, "p1_gain")
        check_positive(self.p2_gain, "p2_gain")
        if self.antialias_cutoff_hz is not None:
            check_positive(self.antialias_cutoff_hz, "antialias_cutoff_hz")

    def transducer_error(self, channel: str) -> tuple[float, float]:
        """Gain and offset of one pressure channel.

        Parameters
        ----------
        channel : {"p1", "p2"}
            Pressure channel.

        Returns
        -------
        gain : float
            Span factor (1 = ideal).
        offset_pa : float
            Zero error in Pa.

        Raises
        ------
        ValueError
            If ``channel`` is not ``"p1"`` or ``"p2"``.

        Examples
        --------
        >>> SensorParams(p2_gain=1.01, p2_offset_pa=-2e3).transducer_error("p2")
        (1.01, -2000.0)
        """
        if channel == "p1":
            return float(self.p1_gain), float(self.p1_offset_pa)
        if channel == "p2":
            return float(self.p2_gain), float(self.p2_offset_pa)
        raise ValueError(f"channel={channel!r} must be 'p1' or 'p2'")

    @property
    def has_transducer_error(self) -> bool:
        """True if any offset differs from 0 or any gain from 1."""
        return (self.p1_offset_pa != 0.0 or self.p2_offset_pa != 0.0
                or self.p1_gain != 1.0 or self.p2_gain != 1.0)

    @property
    def pressure_quantum_pa(self) -> float:
        """ADC step in Pa, ``full_scale / 2**bits``."""
        return self.pressure_full_scale_pa / 2.0**self.pressure_adc_bits

    def to_dict(self) -> dict:
        """Field name -> value (for recording metadata).

        Returns
        -------
        dict
            One entry per field, SI units as in the field names.
        """
        return asdict(self)


@numba.njit(cache=True)
def quantize(value, step):
    """Round ``value`` to the nearest multiple of ``step`` (Numba-compiled scalar).

    Parameters
    ----------
    value : float
        Value to quantise.
    step : float
        Quantum, > 0.

    Returns
    -------
    float
        ``round(value / step) * step``.

    Examples
    --------
    >>> round(quantize(0.100e-3, 0.03e-3), 9)
    9e-05
    """
    return np.round(value / step) * step


@numba.njit(cache=True)
def adc_reading(value, noise, full_scale, quantum):
    """Reading of a unipolar transducer through an ADC (Numba-compiled scalar).

    Parameters
    ----------
    value : float
        True value (e.g. Pa gauge).
    noise : float
        Noise sample added before conversion (same unit).
    full_scale : float
        Upper end of the range; the reading is clipped to ``[0, full_scale - quantum]``.
    quantum : float
        ADC step.

    Returns
    -------
    float
        Quantised, clipped reading.

    Examples
    --------
    >>> adc_reading(1.26, 0.0, 10.0, 0.5)
    1.5
    >>> adc_reading(-3.0, 0.0, 10.0, 0.5)
    0.0
    """
    r = np.round((value + noise) / quantum) * quantum
    top = full_scale - quantum
    if r < 0.0:
        return 0.0
    if r > top:
        return top
    return r


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


def measure_pressure(pressure, sensors: SensorParams, rng: np.random.Generator, *,
                     channel: str | None = None, sample_rate: float | None = None) -> np.ndarray:
    """Pressure channel as recorded: transducer error, noise, anti-alias filter, ADC, clipping.

    The chain, in order: ``gain * p + offset`` (the channel's transducer error), additive
    white noise, the anti-alias low-pass (if ``antialias_cutoff_hz`` is set; causal, started
    at rest from the first value), rounding to the ADC quantum, clipping to the range.

    Parameters
    ----------
    pressure : array_like
        True gauge pressure in Pa.
    sensors : SensorParams
        Sensor chain.
    rng : numpy.random.Generator
        Source of the noise.
    channel : {"p1", "p2"}, optional
        Which transducer's gain and offset apply; required if any is not ideal.
    sample_rate : float, optional
        Sampling rate in Hz; required if the anti-alias filter is on.

    Returns
    -------
    numpy.ndarray
        Measured pressure in Pa, same shape.

    Raises
    ------
    ValueError
        If a transducer error is set without ``channel``, or the filter without
        ``sample_rate``.

    Examples
    --------
    >>> s = SensorParams(pressure_noise_std_pa=0.0)
    >>> measure_pressure([1e6, -5.0], s, np.random.default_rng(0)).tolist() == [
    ...     round(1e6 / s.pressure_quantum_pa) * s.pressure_quantum_pa, 0.0]
    True
    """
    p = np.ascontiguousarray(pressure, dtype=np.float64)
    q = sensors.pressure_quantum_pa
    if channel is not None or sensors.has_transducer_error:
        if channel is None:
            raise ValueError("channel must be 'p1' or 'p2' when the sensors have a transducer "
                             "offset or gain error")
        gain, offset = sensors.transducer_error(channel)
        if gain != 1.0 or offset != 0.0:
            p = gain * p + offset
    noisy = p + sensors.pressure_noise_std_pa * rng.standard_normal(p.shape)
    if sensors.antialias_cutoff_hz is not None:
        if sample_rate is None:
            raise ValueError("sample_rate is required when antialias_cutoff_hz="
                             f"{sensors.antialias_cutoff_hz!r} is set")
        if noisy.size:
            sos = antialias_sos(sensors.antialias_cutoff_hz, sample_rate)
            zi = sosfilt_zi(sos) * noisy.reshape(-1)[0]
            noisy = sosfilt(sos, noisy.reshape(-1), zi=zi)[0].reshape(noisy.shape)
    return np.clip(np.round(noisy / q) * q, 0.0, sensors.pressure_full_scale_pa - q)


def measure_position(position, sensors: SensorParams) -> np.ndarray:
    """Position channel as recorded: encoder quantisation (no noise; an encoder counts).

    Parameters
    ----------
    position : array_like
        True position in m.
    sensors : SensorParams
        Sensor chain.

    Returns
    -------
    numpy.ndarray
        Position rounded to ``position_resolution_m``.

    Examples
    --------
    >>> measure_position([0.0, 0.016e-3, -0.046e-3], SensorParams()).round(8).tolist()
    [0.0, 3e-05, -6e-05]
    """
    x = np.ascontiguousarray(position, dtype=np.float64)
    q = sensors.position_resolution_m
    return np.round(x / q) * q
