"""The one executor: run pure ``run_case(config) -> result`` calls serially or on Dask.

A *case* is one call of a pure, module-level function on one configuration (a plain dict, a
dataclass, a path; serialisable). The serial executor (tests) and the Dask executor (production: a
``dask.distributed.LocalCluster`` by default, or an existing scheduler by address) give the same
results in the same order; each result is stored with its configuration in a :class:`CaseResult`.

The studies, the benchmark and the batch runner all run here. The two Dask runners this replaces
(``studies/executor.py`` and ``batch/runner.py``) differed in one setting, now the ``on_error``
parameter: what a case that fails (its function raises, or its worker dies) does to the run. The
studies stop at the first failure (``on_error=None``, the default); a batch job turns the failure
into that recording's error row and goes on (``on_error=callable``). The batch runner also writes
each recording's rows as soon as it finishes: ``on_result`` is called in completion order.
"""

from __future__ import annotations

import numbers
import time
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, Callable, Sequence

from threadpoolctl import threadpool_limits

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
    config : object
        The configuration passed to ``run_case``.
    result : object
        What ``run_case(config)`` returned (or ``on_error(config, exc)`` for a failed case).
    elapsed_s : float
        Wall time of the call in seconds (measured where it ran; NaN for a case whose worker
        was lost).
    """

    config: Any
    result: Any
    elapsed_s: float


def _timed(run_case: Callable[[Any], Any], config: Any) -> tuple[Any, float]:
    # one BLAS thread per case, in the caller's process as in Dask's workers (whose nannies set
    # OPENBLAS_NUM_THREADS=1): the cases' matrices are small, and threads only contend
    t0 = time.perf_counter()
    with threadpool_limits(1):
        out = run_case(config)
    return out, time.perf_counter() - t0


def _progress(total: int, desc: str, enabled: bool):
    from tqdm.auto import tqdm

    return tqdm(total=total, desc=desc, disable=not enabled, leave=False, dynamic_ncols=True)


def _run_serial(run_case, configs, on_done, on_error):
    for i, cfg in enumerate(configs):
        try:
            res, dt = _timed(run_case, cfg)
        except Exception as exc:  # noqa: BLE001 - handed to on_error, or raised again
            if on_error is None:
                raise
            res, dt = on_error(cfg, exc), float("nan")
        on_done(i, res, dt)


def _quiet_shutdown() -> None:
    """Run on each worker of our own local cluster once every case is done: its ``distributed``
    loggers to CRITICAL, so that a worker whose heartbeat outlives the scheduler's close (a
    loaded machine) prints no ``Failed to communicate with scheduler during heartbeat``
    traceback after the command's results (a docs audit, 2026-11-29, saw one in three
    ``batch`` runs at load 3). The cases' failures have reached us by then (``on_error``)."""
    import logging

    logging.getLogger("distributed").setLevel(logging.CRITICAL)


#: Loggers of this process silenced while our own cluster closes after an interrupt or a
#: failure: the scheduler's and nannies' warnings about the workers being stopped mid-case
#: (``Removing worker ...``, ``Worker process still alive after 4.0 seconds, killing``) and
#: tornado's about the interrupted wait (``Exception in callback ... sync.<locals>.cancel``).
_CLOSE_LOGGERS = ("distributed", "tornado")


@contextmanager
def _workers_ignore_sigint():
    """While our local cluster starts its worker processes, SIGINT is ignored in this process,
    so the workers (spawned: they inherit an ignored signal, and Python then installs no
    ``KeyboardInterrupt`` handler) ignore it for good. Ctrl-C at a terminal reaches the whole
    process group: each worker's event loop used to die with a ``KeyboardInterrupt`` traceback
    (about 67 lines for two workers before ``Aborted.``, an audit, 2026-11-29). The command
    itself still stops on Ctrl-C and closes the workers. Nothing is changed outside the main
    thread (where signals cannot be set)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


@contextmanager
def _silenced(names):
    """The named loggers of this process at CRITICAL inside the block, as they were after."""
    import logging

    loggers = [logging.getLogger(n) for n in names]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        for lg, level in zip(loggers, levels):
            lg.setLevel(level)


def _run_dask(run_case, configs, scheduler, n_workers, on_done, on_error):
    from dask.distributed import Client, LocalCluster, as_completed

    if scheduler == LOCAL:
        # Port 0 everywhere: never collide with another cluster on the shared machine.
        with _workers_ignore_sigint():
            cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                                   scheduler_port=0, dashboard_address=":0")
        client = Client(cluster)
    else:
        cluster = None
        client = Client(scheduler)
    failed = True
    try:
        futures = [client.submit(_timed, run_case, cfg, pure=False) for cfg in configs]
        index = {f.key: i for i, f in enumerate(futures)}
        for fut in as_completed(futures):
            i = index[fut.key]
            try:
                res, dt = fut.result()
            except Exception as exc:  # noqa: BLE001 - the case raised, or its worker died
                if on_error is None:
                    raise
                res, dt = on_error(configs[i], exc), float("nan")
            on_done(i, res, dt)
        failed = False
    finally:
        # Interrupted (Ctrl-C) or failed: the cases still running are stopped with the
        # cluster, and what this process's scheduler and nannies say about it is noise after
        # the one line the command prints (an existing scheduler's logs are its own).
        with _silenced(_CLOSE_LOGGERS if failed and cluster is not None else ()):
            if cluster is not None:  # our own workers only: an existing scheduler's are left
                try:
                    client.run(_quiet_shutdown)
                except Exception:  # noqa: BLE001 - a worker already gone: nothing to quieten
                    pass
            client.close()
            if cluster is not None:
                cluster.close()


def _check_n_workers(n_workers) -> None:
    """Refuse a worker count that would start a cluster that never runs a case."""
    if n_workers is None:
        return
    if isinstance(n_workers, bool) or not isinstance(n_workers, numbers.Integral):
        raise TypeError(f"n_workers={n_workers!r} must be an integer >= 1 (--workers at the "
                        "command line)")
    if n_workers < 1:
        raise ValueError(f"n_workers={n_workers} must be >= 1 (--workers at the command line): "
                         "a local Dask cluster without workers never runs a case")


def run_cases(run_case: Callable[[Any], Any], configs: Sequence[Any], *,
              scheduler: str | None = SERIAL, n_workers: int | None = None,
              desc: str = "cases", progress: bool = True,
              on_result: Callable[[CaseResult], None] | None = None,
              on_error: Callable[[Any, Exception], Any] | None = None) -> list[CaseResult]:
    """Run ``run_case`` on every configuration, serially or on Dask; results in input order.

    Parameters
    ----------
    run_case : callable
        A pure, module-level (picklable) function ``run_case(config) -> result`` (a
        ``functools.partial`` of one works too).
    configs : sequence
        Configurations (plain dicts, dataclasses, paths).
    scheduler : str or None, default "serial"
        ``"serial"`` (or None): in this process. ``"local"``: a new
        ``dask.distributed.LocalCluster`` (processes, one thread each) closed afterwards.
        ``"tcp://host:port"`` (any address a ``dask.distributed.Client`` accepts): an existing
        scheduler.
    n_workers : int, optional
        Workers of the local cluster, >= 1 (default: Dask's choice, one per core). Ignored by
        the serial executor and by an existing scheduler (its cluster has its own workers).
    desc : str, default "cases"
        Label of the tqdm progress bar.
    progress : bool, default True
        Show the progress bar.
    on_result : callable, optional
        Called with each :class:`CaseResult` as soon as its case finishes (completion order on
        Dask, input order serially), e.g. to write it to disk before the run ends.
    on_error : callable, optional
        What a failed case (an exception from ``run_case``, or a lost Dask worker) does. None
        (default): the exception propagates and the run stops. A callable
        ``on_error(config, exc) -> result``: its return value becomes the case's result
        (``elapsed_s`` NaN) and the run goes on.

    Returns
    -------
    list of CaseResult
        One per configuration, in the order of ``configs``.

    Raises
    ------
    ValueError
        For an unknown scheduler name, or ``n_workers`` below 1 (a local cluster without
        workers never runs a case: the call would wait forever).
    TypeError
        For an ``n_workers`` that is not an integer.
    Exception
        Whatever a case raised, when ``on_error`` is None.

    Notes
    -----
    Results are identical across schedulers because every case is a pure function of its
    configuration (seeds live in the configuration); only ``elapsed_s`` differs.

    Examples
    --------
    >>> out = run_cases(abs, [-2, 3], progress=False)
    >>> [(c.config, c.result) for c in out]
    [(-2, 2), (3, 3)]
    >>> out = run_cases(abs, [-2, "x"], progress=False, on_error=lambda cfg, exc: "failed")
    >>> [c.result for c in out]
    [2, 'failed']
    """
    configs = list(configs)
    dask = scheduler is not None and scheduler != SERIAL
    if dask and not (scheduler == LOCAL or ":" in str(scheduler)):
        raise ValueError(
            f"scheduler={scheduler!r} must be 'serial', 'local' or a Dask scheduler address "
            f"such as 'tcp://127.0.0.1:8786'"
        )
    _check_n_workers(n_workers)
    results: list[CaseResult | None] = [None] * len(configs)
    if not configs:
        return []
    with _progress(len(configs), desc, progress) as bar:
        def done(i: int, res: Any, dt: float) -> None:
            results[i] = CaseResult(configs[i], res, dt)
            if on_result is not None:
                on_result(results[i])
            bar.update(1)

        if dask:
            _run_dask(run_case, configs, scheduler, n_workers, done, on_error)
        else:
            _run_serial(run_case, configs, done, on_error)
    return results
