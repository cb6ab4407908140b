"""Case study 3: sensitivity of every method to the leak size (Table 5-17, Sec. 6.1.5-6.4.5).

Many simulated experiments (leak size x load x seed x duration; leak at half time), each measured
with every method at the thesis's preferred setting; per method the range of |% change| and its
trend along leak size (:func:`~leakdiag.studies.reproduce.sensitivity_summary`).
"""

from __future__ import annotations

from leakdiag.runtime.executor import run_cases
from leakdiag.studies.protocol import FULL, QUICK, ProtocolConfig, build_cases, run_case
from leakdiag.studies.reproduce import sensitivity_summary

__all__ = ["sensitivity_cases", "run_sensitivity"]


def sensitivity_cases(config: ProtocolConfig, systems=("vca", "eha")) -> list[dict]:
    """The case-study-3 cases of a protocol.

    Parameters
    ----------
    config : ProtocolConfig
        Settings (leak sizes, loads, seeds, durations).
    systems : sequence of str
        ``"vca"`` and/or ``"eha"``.

    Returns
    -------
    list of dict

    Examples
    --------
    >>> len(sensitivity_cases(QUICK, ["eha"]))
    4
    """
    return [c for c in build_cases(config, systems) if c["kind"] == "sensitivity"]


def run_sensitivity(systems=("vca", "eha"), config: ProtocolConfig | None = None, *,
                    quick: bool = False, scheduler: str | None = "local",
                    n_workers: int | None = None, progress: bool = True):
    """Run case study 3 and summarise it.

    Parameters
    ----------
    systems : sequence of str
        ``"vca"`` and/or ``"eha"``.
    config : ProtocolConfig, optional
        Settings (default FULL, or QUICK if ``quick``).
    quick : bool, default False
        Short protocol.
    scheduler : str or None, default "local"
        ``"serial"``, ``"local"`` or a Dask scheduler address.
    n_workers : int, optional
        Local cluster workers.
    progress : bool, default True
        Progress bar.

    Returns
    -------
    rows : pandas.DataFrame
        One row per experiment and method.
    summary : pandas.DataFrame
        Range per method beside the thesis's.
    """
    import pandas as pd


    cfg = config or (QUICK if quick else FULL)
    cases = sensitivity_cases(cfg, systems)
    res = run_cases(run_case, cases, scheduler=scheduler, n_workers=n_workers,
                    desc="sensitivity", progress=progress)
    rows = pd.DataFrame([r for cr in res for r in cr.result["rows"]])
    return rows, sensitivity_summary(rows)
