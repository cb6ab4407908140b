"""The thesis's studies: sweeps (Sec. 4.4), preferred settings, sensitivity (case study 3),
stationarity (Sec. 4.7) and the reproduction protocol (``leakdiag reproduce``).

They run on the shared runtime: :mod:`leakdiag.runtime.cache` (on-disk cache of simulations)
and :mod:`leakdiag.runtime.executor` (serial or Dask execution of pure cases), re-exported here.
See ``docs/studies.md``.
"""

from leakdiag.runtime.cache import cached_simulation
from leakdiag.runtime.executor import CaseResult, run_cases
from leakdiag.studies.grid import grid, grid_loop
from leakdiag.studies.protocol import FULL, QUICK, ProtocolConfig
from leakdiag.studies.reproduce import reproduce
from leakdiag.studies.select import THESIS_CHOICES, SelectionRule, preferred_setting
from leakdiag.studies.sweep import OFATResult, ofat_sweep, one_factor_sweep, parse_values

__all__ = [
    "cached_simulation", "run_cases", "CaseResult", "grid", "grid_loop", "one_factor_sweep",
    "ofat_sweep", "OFATResult", "parse_values", "SelectionRule", "preferred_setting",
    "THESIS_CHOICES", "ProtocolConfig", "FULL", "QUICK", "reproduce",
]
