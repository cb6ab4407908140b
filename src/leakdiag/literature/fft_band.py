"""FFT method: RMS of the chamber pressure within a band around the hydraulic natural frequency.

Goharrizi & Sepehri (2010) and Goharrizi (2011) take the Fourier transform of the pressure and
track the RMS of the frequency components near the hydraulic natural frequency, where internal
leakage lowers the Bode magnitude of pressure over valve input (Sec. 1.2, item 5).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from leakdiag._validation import as_1d_float, check_int, check_overlap, check_positive
from leakdiag.features.series import FeatureSeries
from leakdiag.features.windowing import window_starts
from leakdiag.literature._physics import DEFAULT_NATURAL_FREQUENCY_HZ
from leakdiag.literature._windowed import channel_rms_feature, check_channels

__all__ = ["FFTBandParams", "fft_band_rms", "fft_band_feature"]

BAND_LOW_FACTOR = 0.5  # assumption: band from 0.5 f_n ...
BAND_HIGH_FACTOR = 1.5  # ... to 1.5 f_n (papers give no band edges)
_BLOCK_VALUES = 4_000_000  # samples per FFT block: bounds memory to ~100 MB on long records


def fft_band_rms(x, sample_rate: float, window: int, overlap: float, band_hz: tuple[float, float]
                 ) -> np.ndarray:
    """RMS of the part of ``x`` inside a frequency band, per window, from each window's FFT.

    Parameters
    ----------
    x : array_like
        Signal (a chamber pressure in Pa), shape ``(n,)``.
    sample_rate : float
        Sample rate in Hz.
    window : int
        Window size N in samples (>= 2).
    overlap : float
        Overlap in percent, ``[0, 100)``.
    band_hz : (float, float)
        Band edges ``(low, high)`` in Hz, ``0 <= low < high <= sample_rate / 2``; bins with
        ``low <= f <= high`` count. At least one FFT bin must fall in the band.

    Returns
    -------
    numpy.ndarray
        Band RMS per window (unit of ``x``), shape ``(n_windows,)``.

    Raises
    ------
    ValueError
        If the band is empty or inverted, reaches above the Nyquist frequency (the spectrum
        has no bin there: part of the band would be dropped silently), or holds no FFT bin at
        this window size.

    Notes
    -----
    With the rectangular window and the one-sided spectrum :math:`X_k` of a window of
    :math:`N` samples, Parseval's theorem gives the band RMS

    .. math:: \\mathrm{RMS}_{band} = \\frac{1}{N}\\sqrt{\\sum_{k:\\,f_k \\in band} c_k |X_k|^2},
              \\quad c_k = 1 \\text{ for } k = 0, N/2, \\quad c_k = 2 \\text{ otherwise},

    so a sine of amplitude :math:`a` with a whole number of periods in the window and its
    frequency in the band gives :math:`a / \\sqrt{2}` exactly. Windows are processed in blocks
    with ``scipy.fft.rfft`` (an STFT with hop ``step`` and no taper), so memory stays bounded
    on long recordings.

    Examples
    --------
    >>> t = np.arange(2000) / 1000.0
    >>> x = 3.0 * np.sin(2 * np.pi * 70 * t) + 5.0 * np.sin(2 * np.pi * 200 * t)
    >>> np.round(fft_band_rms(x, 1000.0, 1000, 50, (35.0, 105.0)), 6).tolist()
    [2.12132, 2.12132, 2.12132]
    """
    import scipy.fft

    x = as_1d_float(x)
    fs = check_positive(sample_rate, "sample_rate")
    window = check_int(window, "window", 2)
    low, high = (float(b) for b in band_hz)
    if not (0.0 <= low < high):
        raise ValueError(f"band_hz={band_hz!r} must satisfy 0 <= low < high")
    if high > fs / 2:
        raise ValueError(f"band_hz=({low:g}, {high:g}) must lie below the Nyquist frequency "
                         f"{fs / 2:g} Hz (sample_rate={fs:g} Hz): the spectrum ends there, so "
                         f"{max(low, fs / 2):g}-{high:g} Hz of the band would not be computed")
    freqs = np.fft.rfftfreq(window, 1.0 / fs)
    sel = (freqs >= low) & (freqs <= high)
    if not sel.any():
        raise ValueError(
            f"band_hz={band_hz!r} holds no FFT bin for window={window} at {fs} Hz "
            f"(bin spacing {fs / window:g} Hz)"
        )
    weights = np.where((np.arange(len(freqs)) == 0) | ((window % 2 == 0)
                       & (np.arange(len(freqs)) == window // 2)), 1.0, 2.0)[sel]
    starts = window_starts(len(x), window, overlap)
    out = np.empty(len(starts))
    frames = np.lib.stride_tricks.sliding_window_view(x, window) if len(starts) else None
    per_block = max(1, _BLOCK_VALUES // window)
    for b0 in range(0, len(starts), per_block):
        idx = starts[b0:b0 + per_block]
        spec = scipy.fft.rfft(frames[idx], axis=1)[:, sel]
        power = (spec.real**2 + spec.imag**2) @ weights
        out[b0:b0 + len(idx)] = np.sqrt(power) / window
    return out


@dataclass(frozen=True)
class FFTBandParams:
    """Settings of the FFT band method.

    Parameters
    ----------
    channels : tuple of str, default ("p1",)
        Pressure channels; with several, the feature is the root of the summed mean squares.
    band_hz : (float, float) or None, default None
        Band edges in Hz; None uses ``(0.5 f_n, 1.5 f_n)`` around ``natural_frequency_hz``.
    natural_frequency_hz : float, default 69.7
        Hydraulic natural frequency of Eq. 2-6 (Table 2-1 values).
    window : int, default 1000
        Window size N in samples.
    overlap : float, default 50
        Overlap in percent.
    """

    channels: tuple[str, ...] = ("p1",)
    band_hz: tuple[float, float] | None = None
    natural_frequency_hz: float = DEFAULT_NATURAL_FREQUENCY_HZ
    window: int = 1000
    overlap: float = 50.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "channels", check_channels(self.channels))
        check_positive(self.natural_frequency_hz, "natural_frequency_hz")
        if self.band_hz is not None:
            low, high = (float(b) for b in self.band_hz)
            if not (0.0 <= low < high):
                raise ValueError(f"band_hz={self.band_hz!r} must satisfy 0 <= low < high")
            object.__setattr__(self, "band_hz", (low, high))
        check_int(self.window, "window", 2)
        check_overlap(self.overlap)

    @property
    def resolved_band_hz(self) -> tuple[float, float]:
        """The band used, Hz."""
        if self.band_hz is not None:
            return self.band_hz
        f = self.natural_frequency_hz
        return (BAND_LOW_FACTOR * f, BAND_HIGH_FACTOR * f)


def fft_band_feature(recording, params: FFTBandParams = FFTBandParams()) -> FeatureSeries:
    """Windowed band RMS of the chamber pressure(s) of a recording.

    Parameters
    ----------
    recording : leakdiag.io.Recording
        Must hold ``params.channels``.
    params : FFTBandParams, optional
        Settings.

    Returns
    -------
    FeatureSeries
        ``name="fft_band"``, values in Pa, one per window (last-sample timestamps).

    Raises
    ------
    leakdiag.io.RecordingError
        If a channel is missing, or holds NaN or inf (named with the recording and the first
        bad sample: one would spread into every later window).
    ValueError
        If the band reaches above the recording's Nyquist frequency (the default band's upper
        edge, 104.6 Hz, needs a sample rate of at least 209.1 Hz).

    Notes
    -----
    Per window :math:`W`, :math:`\\sqrt{\\sum_c \\mathrm{RMS}_{band}(p_c, W)^2}` with the
    band RMS of :func:`fft_band_rms`; NaN in a window that overlaps a hold of one exact value
    at least a window long (a frozen sensor; one counted ``DegenerateWindowWarning``).
    Assumptions where the papers are not specific: the band
    (0.5 to 1.5 times the natural frequency of Eq. 2-6, wide enough to keep the resonance as the
    leak's damping shifts and broadens it), a rectangular window (exact Parseval, no taper
    correction), 1 s windows with 50 % overlap.

    References
    ----------
    .. [1] A. Y. Goharrizi and N. Sepehri, "A wavelet-based approach to internal seal damage
       diagnosis in hydraulic actuators", IEEE Trans. Industrial Electronics 57(5), 2010.
    .. [2] A. Y. Goharrizi, "Internal leakage detection in hydraulic actuators using empirical
       mode decomposition and Hilbert spectrum", PhD thesis, University of Manitoba, 2011.

    Examples
    --------
    >>> from leakdiag.io.recording import Recording
    >>> t = np.arange(3000) / 1000.0
    >>> rec = Recording({"p1": 2.0 * np.sin(2 * np.pi * 70 * t)}, sample_rate=1000.0)
    >>> np.round(fft_band_feature(rec, FFTBandParams(overlap=0)).values, 6).tolist()
    [1.414214, 1.414214, 1.414214]
    """
    recording.require(*params.channels)
    fs_hz = recording.sample_rate
    band = params.resolved_band_hz
    return channel_rms_feature(
        recording, params.channels, params.window, params.overlap,
        lambda p: fft_band_rms(p, fs_hz, params.window, params.overlap, band), "fft_band",
        {"band_hz": band})
