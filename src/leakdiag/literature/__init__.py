"""Methods from the literature (thesis Sec. 1.3), side by side with the thesis's own.

* :mod:`~leakdiag.literature.wavelet`: RMS of a wavelet detail level of the chamber pressure
  (Goharrizi & Sepehri 2010; Thakur 2011).
* :mod:`~leakdiag.literature.fft_band`: RMS of the pressure in a band around the hydraulic
  natural frequency (Goharrizi & Sepehri 2010).
* :mod:`~leakdiag.literature.emd_hilbert`: RMS of the instantaneous amplitude of the first IMF
  (Goharrizi & Sepehri 2012).
* :mod:`~leakdiag.literature.ekf`: extended Kalman filter on the VCA model with a
  leak-coefficient state (An & Sepehri 2005).
* :mod:`~leakdiag.literature.detectors`: the four as detectors with ``fit`` / ``score`` /
  ``predict``; :mod:`~leakdiag.literature.registry`: their benchmark factories. The comparison
  suite and compute-time measurement live with the benchmark, in
  :mod:`leakdiag.bench.comparison` (``docs/literature.md``).

Sub-modules are imported on demand (PyWavelets, PyEMD and Numba kernels load only when used).
"""

from __future__ import annotations

import importlib
from typing import Any

from leakdiag._numba_cache import configure as _configure_numba_cache

_configure_numba_cache()  # before any kernel is defined (leakdiag._numba_cache)

__all__ = ["wavelet", "fft_band", "emd_hilbert", "ekf", "detectors", "registry",
           "WaveletDetector",
           "FFTBandDetector", "EMDHilbertDetector", "EKFDetector"]

_SUBMODULES = {"wavelet", "fft_band", "emd_hilbert", "ekf", "detectors", "registry"}


def __getattr__(name: str) -> Any:
    if name in _SUBMODULES:
        return importlib.import_module(f"leakdiag.literature.{name}")
    if name in __all__:
        return getattr(importlib.import_module("leakdiag.literature.detectors"), name)
    raise AttributeError(f"module 'leakdiag.literature' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)
