"""Methods from the literature (thesis Sec. 1.3), side by side with the thesis's own.

* :mod:`~leakdiag.methods.wavelet`: RMS of a wavelet detail level of the chamber pressure
  (Goharrizi & Sepehri 2010; Thakur 2011).
* :mod:`~leakdiag.methods.fft_band`: RMS of the pressure in a band around the hydraulic natural
  frequency (Goharrizi & Sepehri 2010).
* :mod:`~leakdiag.methods.emd_hilbert`: RMS of the instantaneous amplitude of the first IMF
  (Goharrizi & Sepehri 2012).
* :mod:`~leakdiag.methods.ekf`: extended Kalman filter on the VCA model with a leak-coefficient
  state (An & Sepehri 2005).

Sub-modules are imported on demand (PyWavelets, PyEMD and SciPy load only when used).
"""

from __future__ import annotations

__all__ = ["wavelet", "fft_band", "emd_hilbert", "ekf"]
