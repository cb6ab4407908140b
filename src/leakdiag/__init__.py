"""leakdiag: internal leakage diagnosis of hydraulic actuators.

Implements the methods of *Internal Leakage Diagnosis in Valve Controlled Actuation Systems
and Electrohydrostatic Actuation Systems* (the thesis in ``shared/thesis``) and goes beyond them.

The sub-packages follow the data flow (each imports only those before it; ``docs/layout.md``):
:mod:`leakdiag.io` (recordings in/out) -> :mod:`leakdiag.sim` (actuator models) ->
:mod:`leakdiag.features` (windowed features) -> :mod:`leakdiag.detect` (measures, alarms, onset)
-> :mod:`leakdiag.literature` (the literature's methods) -> :mod:`leakdiag.runtime` (executor,
cache) -> :mod:`leakdiag.studies` (sweeps, sensitivity, reproduction) -> :mod:`leakdiag.report`
(figures, HTML) -> :mod:`leakdiag.stream`, :mod:`leakdiag.batch`, :mod:`leakdiag.bench` ->
:mod:`leakdiag.store` -> :mod:`leakdiag.dashboard` -> :mod:`leakdiag.cli`.

Sub-packages are imported lazily so that ``import leakdiag`` stays fast.
"""

from __future__ import annotations

import importlib
from typing import Any

from leakdiag._version import __version__

__all__ = [
    "__version__",
    "Recording",
    "FeatureSeries",
    "io",
    "sim",
    "features",
    "detect",
    "studies",
    "report",
    "stream",
]

_SUBMODULES = {"io", "sim", "features", "detect", "literature", "runtime", "studies", "report",
               "stream", "batch", "bench", "store", "dashboard", "cli"}


def __getattr__(name: str) -> Any:
    if name in _SUBMODULES:
        return importlib.import_module(f"leakdiag.{name}")
    if name == "Recording":
        from leakdiag.io.recording import Recording

        return Recording
    if name == "FeatureSeries":
        from leakdiag.features.series import FeatureSeries

        return FeatureSeries
    raise AttributeError(f"module 'leakdiag' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)
