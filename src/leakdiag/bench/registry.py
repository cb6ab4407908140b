"""Detection methods of the benchmark, by name.

:data:`METHODS` maps a method name to its factory ``factory(system: str, alarm: Alarm) ->
Detector`` returning an *unfitted* detector for the rig (``"vca"`` or ``"eha"``). To add a method
(wavelet, FFT, EMD, EKF, ...), write its factory, import it here and add one line to
:data:`METHODS`; ``leakdiag benchmark --methods NAME ...`` then selects it.
"""

from __future__ import annotations

from dataclasses import replace

from leakdiag.detect.flow_balance import FlowBalanceDetector
from leakdiag.detect.methods import CombinedDetector, thesis_detector
from leakdiag.literature.registry import LITERATURE_METHODS

__all__ = ["METHODS", "make_detector", "thesis_methods", "DEFAULT_METHODS"]

#: Methods run when ``--methods`` is not given.
DEFAULT_METHODS = ("acf-p1", "acf-p2", "ccf-p1p2", "ccf-ux", "mlr-p1", "combined",
                   "wavelet-p1", "wavelet-p1p2", "fft-p1", "emd-p1", "ekf")


def make_detector(name: str, system: str, alarm):
    """Build the named method's unfitted detector for a rig.

    Parameters
    ----------
    name : str
        Key of :data:`METHODS`.
    system : {"vca", "eha"}
        Rig (selects the thesis's preferred settings).
    alarm : Alarm
        Search settings (false-alarm target, onset method).

    Returns
    -------
    Detector

    Raises
    ------
    ValueError
        For an unknown name (lists the known ones).

    Examples
    --------
    >>> from leakdiag.detect.base import Alarm
    >>> make_detector("ccf-ux", "vca", Alarm()).channels
    ('u', 'x')
    """
    if name not in METHODS:
        raise ValueError(f"unknown method {name!r}; known: {sorted(METHODS)}")
    return METHODS[name](system, alarm)


def thesis_methods() -> tuple[str, ...]:
    """Names of the methods of the thesis (one feature each).

    Returns
    -------
    tuple of str

    Examples
    --------
    >>> thesis_methods()
    ('acf-p1', 'acf-p2', 'ccf-p1p2', 'ccf-ux', 'mlr-p1')
    """
    return ("acf-p1", "acf-p2", "ccf-p1p2", "ccf-ux", "mlr-p1")


def _acf_p1(system, alarm):
    return thesis_detector(system, "autocorrelation", ("p1",), alarm)


def _acf_p2(system, alarm):
    det = _acf_p1(system, alarm)
    return det.set_params(channels=("p2",))


def _ccf_p1p2(system, alarm):
    return thesis_detector(system, "cross-correlation", ("p1", "p2"), alarm)


def _ccf_ux(system, alarm):
    return thesis_detector(system, "cross-correlation", ("u", "x"), alarm)


def _mlr_p1(system, alarm):
    return thesis_detector(system, "metric-length", ("p1",), alarm)


def _combined(system, alarm):
    parts = [_acf_p1(system, None), _ccf_p1p2(system, None), _ccf_ux(system, None),
             _mlr_p1(system, None)]
    # the Mahalanobis distance only grows with a change
    return CombinedDetector(parts, alarm=replace(alarm, direction="up"))


def _flow_balance(system, alarm):
    if alarm is None:
        return FlowBalanceDetector(system=system)
    # the suite's false-alarm target, burn-in and segment (v5: one per run's monitored span)
    return FlowBalanceDetector(system=system, false_alarms_per_hour=alarm.false_alarms_per_hour,
                               burn_in_s=alarm.burn_in_s, segment_s=alarm.segment_s,
                               confidence=alarm.confidence)


#: Method name -> factory.
METHODS = {
    "acf-p1": _acf_p1,
    "acf-p2": _acf_p2,
    "ccf-p1p2": _ccf_p1p2,
    "ccf-ux": _ccf_ux,
    "mlr-p1": _mlr_p1,
    "combined": _combined,
    # literature methods (issue 6; factories in leakdiag.literature.registry)
    **LITERATURE_METHODS,
    # physics-based (issue 12)
    "flow-balance": _flow_balance,
}
