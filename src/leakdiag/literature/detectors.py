"""Detectors for the literature methods, with the shared ``fit`` / ``score`` / ``predict``.

Each class only builds its feature (:meth:`_feature_series`); the healthy calibration, CUSUM
alarm and onset search are those of :class:`leakdiag.detect.base.Detector`. Settings are stored
verbatim in ``__init__`` (scikit-learn convention) and validated when the feature is computed.
"""

from __future__ import annotations

import warnings

import numpy as np

from leakdiag.detect.base import Detector
from leakdiag.features._degenerate import DegenerateWindowWarning
from leakdiag.features.series import FeatureSeries
from leakdiag.io.errors import RecordingError
from leakdiag.io.recording import load_name
from leakdiag.literature._physics import DEFAULT_NATURAL_FREQUENCY_HZ
from leakdiag.literature.ekf import (HOLD_FACTOR, MATCH_MAX_SIGNAL_S, MATCH_SKIP_S, MEASURED,
                                    EKFParams, ekf_feature, longest_holds_s,
                                    match_measurement_noise, run_vca_ekf)
from leakdiag.literature.emd_hilbert import EMDHilbertParams, emd_hilbert_feature
from leakdiag.literature.fft_band import FFTBandParams, fft_band_feature
from leakdiag.literature.wavelet import WaveletParams, wavelet_feature
from leakdiag.sim.vca.params import LOADS, VCAParams

__all__ = ["WaveletDetector", "FFTBandDetector", "EMDHilbertDetector", "EKFDetector"]


def _quiet(feature, recording, params) -> FeatureSeries:
    """The feature with its undefined windows counted in ``settings['n_nan_windows']`` instead
    of a warning: they are NaN, and the detector's alarm skips them (a NO LEAK over a long
    span of them is refused, docs/detect.md, "Blind spans")."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DegenerateWindowWarning)
        fs = feature(recording, params)
    n_nan = int(np.count_nonzero(~np.isfinite(fs.values)))
    return fs.with_values(fs.values, fs.name, {**fs.settings, "n_nan_windows": n_nan})


class WaveletDetector(Detector):
    """Leak detector on the RMS of a wavelet detail level (Goharrizi & Sepehri 2010).

    Parameters
    ----------
    channels : tuple of str, default ("p1",)
        Pressure channels (``("p1", "p2")`` for Thakur's both-chamber variant).
    wavelet : str, default "db4"
        Mother wavelet.
    level : int or None, default None
        Detail level; None: the level whose band holds ``natural_frequency_hz``.
    natural_frequency_hz : float, default 69.7
        Hydraulic natural frequency (Eq. 2-6, Table 2-1).
    window : int, default 1000
        Window size N in samples.
    overlap : float, default 50
        Overlap in percent.
    alarm : Alarm, optional
        Search settings.

    Notes
    -----
    Feature: :func:`leakdiag.literature.wavelet.wavelet_feature` (see its assumptions).

    Examples
    --------
    >>> WaveletDetector(level=3).get_params()["level"]
    3
    """

    def __init__(self, channels=("p1",), wavelet="db4", level=None,
                 natural_frequency_hz=DEFAULT_NATURAL_FREQUENCY_HZ, window=1000, overlap=50.0,
                 alarm=None):
        self.channels = channels
        self.wavelet = wavelet
        self.level = level
        self.natural_frequency_hz = natural_frequency_hz
        self.window = window
        self.overlap = overlap
        self.alarm = alarm

    def _feature_series(self, recording) -> FeatureSeries:
        return _quiet(wavelet_feature, recording, WaveletParams(
            tuple(self.channels), self.wavelet, self.level, self.natural_frequency_hz,
            self.window, self.overlap))


class FFTBandDetector(Detector):
    """Leak detector on the pressure RMS in a band around the natural frequency (FFT).

    Parameters
    ----------
    channels : tuple of str, default ("p1",)
        Pressure channels.
    band_hz : (float, float) or None, default None
        Band in Hz; None: 0.5 to 1.5 times ``natural_frequency_hz``.
    natural_frequency_hz : float, default 69.7
        Hydraulic natural frequency (Eq. 2-6, Table 2-1).
    window : int, default 1000
        Window size N in samples.
    overlap : float, default 50
        Overlap in percent.
    alarm : Alarm, optional
        Search settings.

    Notes
    -----
    Feature: :func:`leakdiag.literature.fft_band.fft_band_feature` (Goharrizi & Sepehri 2010).

    Examples
    --------
    >>> FFTBandDetector(band_hz=(40.0, 100.0)).get_params()["band_hz"]
    (40.0, 100.0)
    """

    def __init__(self, channels=("p1",), band_hz=None,
                 natural_frequency_hz=DEFAULT_NATURAL_FREQUENCY_HZ, window=1000, overlap=50.0,
                 alarm=None):
        self.channels = channels
        self.band_hz = band_hz
        self.natural_frequency_hz = natural_frequency_hz
        self.window = window
        self.overlap = overlap
        self.alarm = alarm

    def _feature_series(self, recording) -> FeatureSeries:
        return _quiet(fft_band_feature, recording, FFTBandParams(
            tuple(self.channels), self.band_hz, self.natural_frequency_hz, self.window,
            self.overlap))


class EMDHilbertDetector(Detector):
    """Leak detector on the RMS of the first IMF's instantaneous amplitude (Goharrizi 2012).

    Parameters
    ----------
    channels : tuple of str, default ("p1",)
        Pressure channels.
    window : int, default 1000
        Window size N in samples.
    overlap : float, default 50
        Overlap in percent.
    block : int, default 10000
        Samples per EMD block.
    margin : int, default 500
        Context samples on each side of a block.
    sifting_iterations : int or None, default 10
        Fixed number of sifting iterations (None: PyEMD's stopping criteria).
    alarm : Alarm, optional
        Search settings.

    Notes
    -----
    Feature: :func:`leakdiag.literature.emd_hilbert.emd_hilbert_feature`. The slowest method
    (see ``docs/literature.md`` for seconds per hour of signal).

    Examples
    --------
    >>> EMDHilbertDetector(block=5000).get_params()["block"]
    5000
    """

    def __init__(self, channels=("p1",), window=1000, overlap=50.0, block=10_000, margin=500,
                 sifting_iterations=10, alarm=None):
        self.channels = channels
        self.window = window
        self.overlap = overlap
        self.block = block
        self.margin = margin
        self.sifting_iterations = sifting_iterations
        self.alarm = alarm

    def _feature_series(self, recording) -> FeatureSeries:
        return _quiet(emd_hilbert_feature, recording, EMDHilbertParams(
            tuple(self.channels), self.window, self.overlap, self.block, self.margin,
            self.sifting_iterations))


def _match_subset(kept: list, rec) -> list:
    """The recordings whose first ``MATCH_MAX_SIGNAL_S`` seconds the noise is matched on,
    chosen by the digest of their samples, not their order (the same healthy set in another
    order gave 75 and 83 kPa when the first given were used): ``kept`` holds ``(digest,
    recording)`` in digest order, trimmed to the fewest that reach the signal length."""
    import hashlib

    h = hashlib.blake2b(digest_size=16)
    for c in sorted(rec.channels):
        h.update(c.encode())
        h.update(np.ascontiguousarray(rec[c], dtype=np.float64).tobytes())
    kept = sorted(kept + [(h.digest(), rec)], key=lambda x: x[0])
    span, out = 0.0, []
    for d, r in kept:
        if span >= MATCH_MAX_SIGNAL_S:
            break
        out.append((d, r))
        span += max(0.0, r.duration - MATCH_SKIP_S)
    return out


class EKFDetector(Detector):
    """Leak detector on the VCA extended Kalman filter (An & Sepehri 2005).

    Parameters
    ----------
    feature : {"leak_flow", "residual", "coefficient"}, default "leak_flow"
        Windowed mean of the leak's size with the sign of :math:`\\hat k_l` (L/min), windowed
        innovation RMS (:math:`\\sqrt{NIS/3}`), or the windowed mean of :math:`\\hat k_l`
        over the root of its windowed mean filter variance (dimensionless; the benchmark's
        ``ekf``).
    model : VCAParams or None, default None
        Model the filter assumes (None: Table 2-1).
    load : {"none", "spring", "auto"}, default "none"
        Load the filter assumes; ``"auto"`` reads ``recording.meta['load']`` (the rig's known
        load configuration, stripped and lower-cased; not stated: "none"; another load is
        refused, naming the recording; its stiffness is still the nominal one of ``model``).
    leak_model : {"turbulent", "laminar"}, default "turbulent"
        Leak law of the coefficient state.
    pressure_noise_std_pa : float or None, default 10e3
        Pressure measurement noise, Pa; None: matched at :meth:`fit` to the filter's
        innovations on the healthy recordings (``pressure_noise_std_pa_``, ``noise_match_``;
        :func:`~leakdiag.literature.ekf.match_measurement_noise`) and used for every
        recording judged (before a fit, each recording is matched on itself).
    leak_coefficient_walk : float, default 2e-10
        Random-walk intensity of the leak coefficient per square-root second.
    window : int, default 1000
        Window size N in samples.
    overlap : float, default 50
        Overlap in percent.
    alarm : Alarm, optional
        Search settings.

    Notes
    -----
    Feature: :func:`leakdiag.literature.ekf.ekf_feature`. VCA recordings only (channels ``u``,
    ``x``, ``p1``, ``p2``).

    Examples
    --------
    >>> EKFDetector(feature="residual").get_params()["feature"]
    'residual'
    """

    def __init__(self, feature="leak_flow", model=None, load="none", leak_model="turbulent",
                 pressure_noise_std_pa=10e3, leak_coefficient_walk=2e-10, window=1000,
                 overlap=50.0, alarm=None):
        self.feature = feature
        self.model = model
        self.load = load
        self.leak_model = leak_model
        self.pressure_noise_std_pa = pressure_noise_std_pa
        self.leak_coefficient_walk = leak_coefficient_walk
        self.window = window
        self.overlap = overlap
        self.alarm = alarm

    def ekf_params(self, recording=None):
        """The :class:`~leakdiag.literature.ekf.EKFParams` of this detector.

        Parameters
        ----------
        recording : Recording, optional
            Resolves ``load="auto"`` from ``recording.meta['load']``, compared stripped and
            lower-cased (:func:`leakdiag.io.recording.load_name`); a load not stated (absent,
            None or empty) or no recording: ``"none"``.

        Returns
        -------
        EKFParams

        Raises
        ------
        leakdiag.io.RecordingError
            If ``load="auto"`` and the recording states a load the filter's model has no case
            for (it knows ``"none"`` and ``"spring"``), naming the recording and the load.
        """
        load = load_name(self.load) or "none"
        if load == "auto":
            stated = None if recording is None else recording.meta.get("load")
            load = load_name(stated) or "none"
            if load not in LOADS:
                source = recording.meta.get("source", "<recording>")
                raise RecordingError(
                    f"{source}: load {stated!r}: the EKF's model has a case for the loads "
                    f"{list(LOADS)} only (Table 2-1; a spring at its nominal stiffness), so "
                    "load='auto' cannot filter this recording: correct its meta['load'], or "
                    "give EKFDetector the load it should assume (load='none' or 'spring')")
        if hasattr(self, "threshold_") and not hasattr(self, "max_hold_s_"):
            # fitted by the code before 2026-11-27: no hold limits, its noise estimated per
            # recording; judged now it would be filtered otherwise than it was fitted
            raise RecordingError(
                "this EKF detector was fitted before the EKF learned its channels' hold limits "
                "and matched its pressure noise on its healthy recordings (2026-11-27): its "
                "threshold belongs to another filter; fit it again (leakdiag fit)")
        noise = self.pressure_noise_std_pa
        if noise is None:  # matched at fit time (None before a fit: on the recording itself)
            noise = getattr(self, "pressure_noise_std_pa_", None)
        return EKFParams(model=self.model if self.model is not None else VCAParams(),
                         load=load, leak_model=self.leak_model,
                         pressure_noise_std_pa=noise,
                         leak_coefficient_walk=self.leak_coefficient_walk,
                         max_hold_s=getattr(self, "max_hold_s_", None), window=self.window,
                         overlap=self.overlap, feature=self.feature)

    def _fit_features(self, recordings) -> None:
        """From the healthy recordings: the longest hold of each measured channel
        (``longest_hold_s_``, s) and the limit beyond which a judged recording's channel is
        frozen (``max_hold_s_``, :data:`~leakdiag.literature.ekf.HOLD_FACTOR` times it); with
        ``pressure_noise_std_pa=None`` the pressure noise matched to the filter's innovations
        on ``MATCH_MAX_SIGNAL_S`` seconds of them, the recordings taken in the order of their
        samples' digest, not as given (``pressure_noise_std_pa_``, Pa, and ``noise_match_``),
        so that every recording is then filtered alike."""
        holds, kept = [], []
        for r in recordings:  # one pass (a lazy sequence loads each recording once)
            holds.append(longest_holds_s(r))
            if self.pressure_noise_std_pa is None:
                kept = _match_subset(kept, r)
        subset = [r for _, r in kept]
        longest = np.max(holds, axis=0)
        self.longest_hold_s_ = dict(zip(MEASURED, (float(v) for v in longest)))
        self.max_hold_s_ = tuple(HOLD_FACTOR * float(v) for v in longest)
        if self.pressure_noise_std_pa is None:
            self.pressure_noise_std_pa_ = None  # not the previous fit's while matching
            self.noise_match_ = match_measurement_noise(subset, self.ekf_params(subset[0]))
            self.pressure_noise_std_pa_ = self.noise_match_.pressure_noise_std_pa

    def _feature_series(self, recording) -> FeatureSeries:
        return _quiet(ekf_feature, recording, self.ekf_params(recording))

    def leak_size_lpm(self, recording, onset_s: float) -> float:
        """Leak size from the filter alone: the mean of :math:`\\hat k_l |g(\\Delta \\hat P)|`
        (``EKFResult.leak_size_lpm``, the sign of :math:`\\hat k_l` kept) after minus before
        ``onset_s``.

        Parameters
        ----------
        recording : Recording
            VCA recording.
        onset_s : float
            Onset time in s (e.g. ``predict(recording).onset_s``).

        Returns
        -------
        float
            L/min; NaN when one side of the onset has no sample.
        """
        res = run_vca_ekf(recording, self.ekf_params(recording))
        q = res.leak_size_lpm  # a negative k_l (model bias) stays negative
        before, after = res.time < onset_s, res.time >= onset_s
        if not before.any() or not after.any():
            return float("nan")
        return float(q[after].mean() - q[before].mean())
