"""Wavelet method: RMS of one detail level of the chamber pressure(s) over sliding windows.

Goharrizi & Sepehri (2010) decompose a chamber pressure with the discrete wavelet transform and
track the RMS of the detail level whose band holds the hydraulic natural frequency; Thakur (2011)
applies the same idea to both chamber pressures of the EHA.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from leakdiag._validation import as_1d_float, check_int, check_overlap, check_positive
from leakdiag.features.series import FeatureSeries
from leakdiag.literature._physics import DEFAULT_NATURAL_FREQUENCY_HZ
from leakdiag.literature._windowed import channel_rms_feature, check_channels, windowed_rms

__all__ = ["WaveletParams", "wavelet_level_for_frequency", "wavelet_detail",
           "wavelet_detail_rms", "wavelet_feature"]

DEFAULT_WAVELET = "db4"  # assumption: the papers' Daubechies family, 8-tap member (see Notes)


def wavelet_level_for_frequency(frequency_hz: float, sample_rate: float) -> int:
    """Detail level ``j`` whose band ``[fs / 2^(j+1), fs / 2^j]`` contains ``frequency_hz``.

    Parameters
    ----------
    frequency_hz : float
        Frequency to capture (e.g. the hydraulic natural frequency), Hz, below ``fs / 2``.
    sample_rate : float
        Sample rate ``fs`` in Hz.

    Returns
    -------
    int
        Level ``j >= 1``.

    Raises
    ------
    ValueError
        If a value is not positive or ``frequency_hz >= sample_rate / 2``.

    Examples
    --------
    >>> wavelet_level_for_frequency(69.7, 1000.0)
    3
    >>> wavelet_level_for_frequency(300.0, 1000.0)
    1
    """
    f = check_positive(frequency_hz, "frequency_hz")
    fs = check_positive(sample_rate, "sample_rate")
    if f >= fs / 2:
        raise ValueError(f"frequency_hz={f} must be below the Nyquist frequency {fs / 2} Hz")
    return max(1, int(math.floor(math.log2(fs / f))))


def wavelet_detail(x, wavelet: str = DEFAULT_WAVELET, level: int = 3) -> np.ndarray:
    """Detail coefficients of one level of the normalised stationary wavelet transform.

    Parameters
    ----------
    x : array_like
        Signal, shape ``(n,)``, ``n >= 2``.
    wavelet : str, default "db4"
        PyWavelets name of an orthogonal mother wavelet.
    level : int, default 3
        Detail level ``j >= 1`` (band about ``[fs / 2^(j+1), fs / 2^j]``).

    Returns
    -------
    numpy.ndarray
        Detail coefficients aligned with ``x``, shape ``(n,)``, unit of ``x``.

    Raises
    ------
    ValueError
        If the wavelet is unknown or not orthogonal, or ``level < 1``.

    Notes
    -----
    The undecimated transform (``pywt.swt`` with ``norm=True``) is a tight frame for an
    orthogonal wavelet: the mean squares of the levels add up to the mean square of the signal,
    so the RMS of a detail level is the RMS of the signal's content in that band, in Pa.
    The signal is decomposed once (cost ``O(n * level)``), not per window, so overlapping windows
    share the work and no window-edge effects appear inside the record. The ends are padded by
    reflection over the filter support before the (circular) transform and trimmed afterwards.

    Examples
    --------
    A 100 Hz sine sampled at 1 kHz lies in the level-3 band (62.5-125 Hz):

    >>> t = np.arange(4096) / 1000.0
    >>> d3 = wavelet_detail(np.sin(2 * np.pi * 100 * t), "db4", 3)
    >>> bool(np.sqrt(np.mean(d3[500:-500] ** 2)) > 0.6)
    True
    """
    import pywt

    x = as_1d_float(x)
    level = check_int(level, "level", 1)
    if wavelet not in pywt.wavelist(kind="discrete"):
        raise ValueError(f"wavelet={wavelet!r} is not a discrete PyWavelets wavelet")
    w = pywt.Wavelet(wavelet)
    if not w.orthogonal:
        raise ValueError(f"wavelet={wavelet!r} must be orthogonal for an energy-preserving detail")
    n = len(x)
    if n < 2:
        raise ValueError(f"signal length {n} must be >= 2")
    margin = (w.dec_len - 1) * 2**level
    extra = (-(n + 2 * margin)) % 2**level
    padded = np.pad(x, (margin, margin + extra), mode="symmetric")
    coeffs = pywt.swt(padded, w, level=level, trim_approx=True, norm=True)
    return np.ascontiguousarray(coeffs[1][margin:margin + n])


def wavelet_detail_rms(x, window: int, overlap: float, wavelet: str = DEFAULT_WAVELET,
                       level: int = 3) -> np.ndarray:
    """RMS of one wavelet detail level of ``x`` over every complete window.

    Parameters
    ----------
    x : array_like
        Signal (a chamber pressure in Pa), shape ``(n,)``.
    window : int
        Window size N in samples.
    overlap : float
        Overlap in percent, ``[0, 100)``.
    wavelet : str, default "db4"
        Mother wavelet.
    level : int, default 3
        Detail level.

    Returns
    -------
    numpy.ndarray
        RMS per window (unit of ``x``), shape ``(n_windows,)``.

    Examples
    --------
    >>> t = np.arange(4096) / 1000.0
    >>> r = wavelet_detail_rms(np.sin(2 * np.pi * 400 * t), 1024, 0, "db4", 3)
    >>> bool(r.max() < 0.05)  # 400 Hz is outside the level-3 band
    True
    """
    return windowed_rms(wavelet_detail(x, wavelet, level), window, overlap)


@dataclass(frozen=True)
class WaveletParams:
    """Settings of the wavelet method.

    Parameters
    ----------
    channels : tuple of str, default ("p1",)
        Pressure channels; with several, the feature is the root of the summed mean squares.
    wavelet : str, default "db4"
        Mother wavelet (orthogonal).
    level : int or None, default None
        Detail level; None picks the level whose band contains ``natural_frequency_hz``.
    natural_frequency_hz : float, default 69.7
        Hydraulic natural frequency of Eq. 2-6 (Table 2-1 values).
    window : int, default 1000
        Window size N in samples.
    overlap : float, default 50
        Overlap in percent.
    """

    channels: tuple[str, ...] = ("p1",)
    wavelet: str = DEFAULT_WAVELET
    level: int | None = None
    natural_frequency_hz: float = DEFAULT_NATURAL_FREQUENCY_HZ
    window: int = 1000
    overlap: float = 50.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "channels", check_channels(self.channels))
        if self.level is not None:
            check_int(self.level, "level", 1)
        check_positive(self.natural_frequency_hz, "natural_frequency_hz")
        check_int(self.window, "window", 2)
        check_overlap(self.overlap)

    def resolved_level(self, sample_rate: float) -> int:
        """The detail level used at ``sample_rate`` (Hz).

        Parameters
        ----------
        sample_rate : float
            Sample rate in Hz.

        Returns
        -------
        int
            ``level`` if set, else the level whose band holds ``natural_frequency_hz``
            (:func:`wavelet_level_for_frequency`).
        """
        if self.level is not None:
            return int(self.level)
        return wavelet_level_for_frequency(self.natural_frequency_hz, sample_rate)


def wavelet_feature(recording, params: WaveletParams = WaveletParams()) -> FeatureSeries:
    """Windowed RMS of a wavelet detail level of the chamber pressure(s) of a recording.

    Parameters
    ----------
    recording : leakdiag.io.Recording
        Must hold ``params.channels``.
    params : WaveletParams, optional
        Settings.

    Returns
    -------
    FeatureSeries
        ``name="wavelet"``, values in Pa, one per window, timestamped at each window's last
        sample.

    Raises
    ------
    leakdiag.io.RecordingError
        If a channel is missing, or holds NaN or inf (named with the recording and the first
        bad sample: one would spread into every later window).

    Notes
    -----
    For channels :math:`c` and detail :math:`d_{j,c}` of level :math:`j` the value of window
    :math:`W` is :math:`\\sqrt{\\sum_c \\frac{1}{N}\\sum_{i \\in W} d_{j,c}[i]^2}`.
    A window is NaN when a channel holds one exact value for at least a window (a frozen
    sensor) in it or within the filter's reach of it, ``(filter length - 1) 2^j`` samples
    (one counted :class:`~leakdiag.features.DegenerateWindowWarning`).

    Assumptions where the papers are not specific: the mother wavelet (Daubechies-4, a common
    choice for transients with compact support and 4 vanishing moments), the undecimated
    transform instead of a per-window DWT (shift invariance, one decomposition per record), the
    level (the one whose dyadic band holds the natural frequency, Sec. 1.3: "the frequency
    component sensitive to internal leakage") and the window (1 s at 1 kHz, 50 % overlap).

    References
    ----------
    .. [1] A. Y. Goharrizi and N. Sepehri, "A wavelet-based approach to internal seal damage
       diagnosis in hydraulic actuators", IEEE Trans. Industrial Electronics 57(5), 2010.
    .. [2] R. Thakur, "Detection of internal leakage in electrohydrostatic actuators",
       MSc thesis, University of Manitoba, 2011.

    Examples
    --------
    >>> from leakdiag.io.recording import Recording
    >>> t = np.arange(4000) / 1000.0
    >>> rec = Recording({"p1": 1e5 * np.sin(2 * np.pi * 80 * t)}, sample_rate=1000.0)
    >>> fs = wavelet_feature(rec, WaveletParams(window=1000, overlap=0))
    >>> fs.time.tolist()
    [0.999, 1.999, 2.999, 3.999]
    """
    import pywt

    recording.require(*params.channels)
    fs_hz = recording.sample_rate
    level = params.resolved_level(fs_hz)
    # a detail sample depends on (filter length - 1) * 2^level neighbours (56 for db4, level 3):
    # the windows that far from a frozen hold see its edges and are undefined too
    reach = ((pywt.Wavelet(params.wavelet).dec_len - 1) * 2**level
             if params.wavelet in pywt.wavelist(kind="discrete") else 0)
    return channel_rms_feature(
        recording, params.channels, params.window, params.overlap,
        lambda p: wavelet_detail_rms(p, params.window, params.overlap, params.wavelet, level),
        "wavelet",
        {"wavelet": params.wavelet, "level": level}, reach=reach)
