"""Pluggable executors: run pure ``run_case(config) -> result`` calls serially or on Dask.

A *case* is one call of a pure, module-level function on one configuration (a plain dict or a
dataclass, serialisable). The serial executor (tests) and the Dask executor (production: a
``dask.distributed.LocalCluster`` by default, or an existing scheduler by address) give the same
results in the same order; each result is stored with its configuration in a :class:`CaseResult`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Callable, Sequence

__all__ = ["CaseResult", "run_cases", "SERIAL", "LOCAL"]

#: Scheduler name: run in this process, one case after the other.
SERIAL = "serial"
#: Scheduler name: start a ``dask.distributed.LocalCluster`` for the call.
LOCAL = "local"


@dataclass(frozen=True)
class CaseResult:
    """One case: its configuration, its result and the wall time it took.

    Attributes
    ----------
    config : dict or dataclass
        The configuration passed to ``run_case``.
    result : object
        What ``run_case(config)`` returned.
    elapsed_s : float
        Wall time of the call in seconds (measured where it ran).
    """

    config: Any
    result: Any
    elapsed_s: float


def _timed(run_case: Callable[[Any], Any], config: Any) -> tuple[Any, float]:
    t0 = time.perf_counter()
    out = run_case(config)
    return out, time.perf_counter() - t0


def _progress(total: int, desc: str, enabled: bool):
    from tqdm.auto import tqdm

    return tqdm(total=total, desc=desc, disable=not enabled, leave=False, dynamic_ncols=True)


def _run_serial(run_case, configs, desc, progress):
    out = []
    with _progress(len(configs), desc, progress) as bar:
        for cfg in configs:
            res, dt = _timed(run_case, cfg)
            out.append(CaseResult(cfg, res, dt))
            bar.update(1)
    return out


def _run_dask(run_case, configs, scheduler, n_workers, desc, progress):
    from dask.distributed import Client, LocalCluster, as_completed

    if scheduler == LOCAL:
        # Port 0 everywhere: never collide with another cluster on the shared machine.
        cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                               scheduler_port=0, dashboard_address=":0")
        client = Client(cluster)
    else:
        cluster = None
        client = Client(scheduler)
    try:
        futures = [client.submit(_timed, run_case, cfg, pure=False) for cfg in configs]
        index = {f.key: i for i, f in enumerate(futures)}
        results: list[CaseResult | None] = [None] * len(configs)
        with _progress(len(configs), desc, progress) as bar:
            for fut in as_completed(futures):
                i = index[fut.key]
                res, dt = fut.result()
                results[i] = CaseResult(configs[i], res, dt)
                bar.update(1)
        return results
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def run_cases(run_case: Callable[[Any], Any], configs: Sequence[Any], *,
              scheduler: str | None = SERIAL, n_workers: int | None = None,
              desc: str = "cases", progress: bool = True) -> list[CaseResult]:
    """Run ``run_case`` on every configuration, serially or on Dask; results in input order.

    Parameters
    ----------
    run_case : callable
        A pure, module-level (picklable) function ``run_case(config) -> result``.
    configs : sequence
        Configurations (plain dicts or dataclasses).
    scheduler : str or None, default "serial"
        ``"serial"`` (or None): in this process. ``"local"``: a new
        ``dask.distributed.LocalCluster`` (processes, one thread each) closed afterwards.
        ``"tcp://host:port"`` (any address a ``dask.distributed.Client`` accepts): an existing
        scheduler.
    n_workers : int, optional
        Workers of the local cluster (default: Dask's choice, one per core).
    desc : str, default "cases"
        Label of the tqdm progress bar.
    progress : bool, default True
        Show the progress bar.

    Returns
    -------
    list of CaseResult
        One per configuration, in the order of ``configs``.

    Raises
    ------
    ValueError
        For an unknown scheduler name.

    Notes
    -----
    Results are identical across schedulers because every case is a pure function of its
    configuration (seeds live in the configuration); only ``elapsed_s`` differs.

    Examples
    --------
    >>> out = run_cases(abs, [-2, 3], progress=False)
    >>> [(c.config, c.result) for c in out]
    [(-2, 2), (3, 3)]
    """
    configs = list(configs)
    if scheduler is None or scheduler == SERIAL:
        return _run_serial(run_case, configs, desc, progress)
    if scheduler == LOCAL or "://" in str(scheduler) or ":" in str(scheduler):
        if not configs:
            return []
        return _run_dask(run_case, configs, scheduler, n_workers, desc, progress)
    raise ValueError(
        f"scheduler={scheduler!r} must be 'serial', 'local' or a Dask scheduler address "
        f"such as 'tcp://127.0.0.1:8786'"
    )
