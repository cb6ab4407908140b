"""Runtime services shared by the studies, the benchmark and the batch runner.

* :mod:`leakdiag.runtime.executor`: the one executor, serial or Dask (:func:`run_cases`).
* :mod:`leakdiag.runtime.cache`: the on-disk cache of simulated recordings
  (:func:`~leakdiag.runtime.cache.cached_simulation`); imported on demand, since it loads the
  simulators.
* :mod:`leakdiag.runtime.memory`: this machine's memory, for refusing a run that cannot fit.
* :mod:`leakdiag.runtime.collector`: the garbage collector frozen during a long loop
  (:func:`~leakdiag.runtime.collector.frozen_collector`).
"""

from leakdiag.runtime.executor import LOCAL, SERIAL, CaseResult, run_cases

__all__ = ["run_cases", "CaseResult", "SERIAL", "LOCAL"]
