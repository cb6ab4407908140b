"""Benchmark factories of the literature methods: ``factory(system, alarm) -> Detector``.

They follow :mod:`leakdiag.bench.registry` (``"name": factory`` in its ``METHODS``);
:data:`LITERATURE_METHODS` maps the names to the factories so that the benchmark registry
includes them with one update (and imports them, so the import graph shows the dependency).
"""

from __future__ import annotations

from leakdiag.literature.detectors import (EKFDetector, EMDHilbertDetector, FFTBandDetector,
                                           WaveletDetector)

__all__ = ["LITERATURE_METHODS", "wavelet_p1", "wavelet_p1p2", "fft_p1", "emd_p1", "ekf"]


def wavelet_p1(system, alarm):
    """Wavelet detail RMS of chamber-1 pressure (Goharrizi & Sepehri 2010).

    Parameters
    ----------
    system : {"vca", "eha"}
        Rig (both have the 69.7 Hz natural frequency of Tables 2-1 and 3-1).
    alarm : Alarm
        Search settings.

    Returns
    -------
    WaveletDetector

    Examples
    --------
    >>> wavelet_p1("vca", None).channels
    ('p1',)
    """
    return WaveletDetector(channels=("p1",), alarm=alarm)


def wavelet_p1p2(system, alarm):
    """Wavelet detail RMS of both chamber pressures (Thakur 2011).

    Parameters
    ----------
    system : {"vca", "eha"}
        Rig.
    alarm : Alarm
        Search settings.

    Returns
    -------
    WaveletDetector

    Examples
    --------
    >>> wavelet_p1p2("eha", None).channels
    ('p1', 'p2')
    """
    return WaveletDetector(channels=("p1", "p2"), alarm=alarm)


def fft_p1(system, alarm):
    """FFT band RMS of chamber-1 pressure (Goharrizi & Sepehri 2010).

    Parameters
    ----------
    system : {"vca", "eha"}
        Rig.
    alarm : Alarm
        Search settings.

    Returns
    -------
    FFTBandDetector

    Examples
    --------
    >>> fft_p1("vca", None).band_hz is None
    True
    """
    return FFTBandDetector(channels=("p1",), alarm=alarm)


def emd_p1(system, alarm):
    """EMD + Hilbert first-IMF amplitude RMS of chamber-1 pressure (Goharrizi & Sepehri 2012).

    Parameters
    ----------
    system : {"vca", "eha"}
        Rig.
    alarm : Alarm
        Search settings.

    Returns
    -------
    EMDHilbertDetector

    Examples
    --------
    >>> emd_p1("vca", None).sifting_iterations
    10
    """
    return EMDHilbertDetector(channels=("p1",), alarm=alarm)


def ekf(system, alarm):
    """Extended Kalman filter with a leak-coefficient state (An & Sepehri 2005), VCA model.

    Parameters
    ----------
    system : {"vca", "eha"}
        Rig. For ``"eha"`` the detector is returned but its ``fit`` raises ``ValueError``
        (no EHA filter yet), which the benchmark reports as an error row.
    alarm : Alarm
        Search settings.

    Returns
    -------
    EKFDetector
        Standardised leak-coefficient feature (``k_l`` over the root of its filter variance),
        pressure noise matched at fit time to the filter's innovations on the healthy
        recordings (``pressure_noise_std_pa=None``; the same for every recording judged), load
        taken from the recording's metadata (``load="auto"``); the filter carries a load-force
        disturbance state.

    Examples
    --------
    >>> d = ekf("vca", None)
    >>> d.load, d.feature, d.pressure_noise_std_pa
    ('auto', 'coefficient', None)
    """
    return EKFDetector(feature="coefficient", load="auto", pressure_noise_std_pa=None,
                       alarm=alarm)


#: Benchmark name -> factory of each literature method.
LITERATURE_METHODS = {
    "wavelet-p1": wavelet_p1,
    "wavelet-p1p2": wavelet_p1p2,
    "fft-p1": fft_p1,
    "emd-p1": emd_p1,
    "ekf": ekf,
}
