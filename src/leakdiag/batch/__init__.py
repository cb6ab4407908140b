"""Batch runs of analyses, sweeps and fitted detectors over many recordings, serially or on Dask.

:func:`run_case` (pure, one recording -> result rows) and :func:`run_batch` (resumable, one Parquet
file per finished recording); the job is a :class:`BatchConfig` read from TOML by
:func:`load_config`. See ``docs/operations.md``.
"""

from leakdiag.batch.config import BatchConfig, DetectorRef, config_from_dict, load_config
from leakdiag.batch.runner import BatchSummary, expand_inputs, run_batch, run_case
from leakdiag.batch.store import RESULT_COLUMNS, read_results

__all__ = [
    "BatchConfig",
    "DetectorRef",
    "config_from_dict",
    "load_config",
    "BatchSummary",
    "expand_inputs",
    "run_batch",
    "run_case",
    "RESULT_COLUMNS",
    "read_results",
]
