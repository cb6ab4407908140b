"""The thesis's studies: sweeps (Sec. 4.4), preferred settings, sensitivity (case study 3),
stationarity (Sec. 4.7) and the reproduction protocol (``leakdiag reproduce``).

Shared infrastructure: :mod:`leakdiag.studies.cache` (on-disk cache of simulations) and
:mod:`leakdiag.studies.executor` (serial or Dask execution of pure cases). See
``docs/studies.md``.
"""

from leakdiag.studies.cache import cached_simulation
from leakdiag.studies.executor import CaseResult, run_cases
from leakdiag.studies.grid import grid, grid_loop
from leakdiag.studies.protocol import FULL, QUICK, ProtocolConfig
from leakdiag.studies.reproduce import reproduce, write_outputs
from leakdiag.studies.select import THESIS_CHOICES, SelectionRule, preferred_setting
from leakdiag.studies.sweep import OFATResult, ofat_sweep, one_factor_sweep, parse_values

__all__ = [
    "cached_simulation", "run_cases", "CaseResult", "grid", "grid_loop", "one_factor_sweep",
    "ofat_sweep", "OFATResult", "parse_values", "SelectionRule", "preferred_setting",
    "THESIS_CHOICES", "ProtocolConfig", "FULL", "QUICK", "reproduce", "write_outputs",
]
