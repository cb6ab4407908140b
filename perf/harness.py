"""Benchmark harness: time a fast path against a reference in the same run, report ratios.

Every benchmark case records one :class:`RatioRecord` through the ``record_ratio`` fixture
(``perf/conftest.py``); at the end of the session all records are printed as one table
(``pytest_terminal_summary``), with samples per second and the goals. Benchmarks never assert
timings: a busy machine must not fail the build. The load average is printed with the table
because the team's machine is shared (2 cores).

Usage in a benchmark module::

    def test_bench_my_feature(record_ratio):
        fast = best_time(lambda: my_fast(x))
        ref = best_time(lambda: my_reference(x), repeats=1)
        record_ratio("my feature N=200", fast, ref, n_samples=len(x), goal_ratio=50)

Timing on a shared host. The team's VM is a guest whose cores are hyperthreads of a shared
host: when another tenant runs on the sibling hyperthread, throughput-bound kernels (the
feature kernels) slow down by up to 2.2x for seconds at a time, while a latency-bound loop
barely moves (see ``docs/features.md``, "Speed"). Repeats made back to back all fall into one
such period. :func:`time_calls` can therefore spread the repeats over ``spread_s`` seconds of
wall time; the best of them estimates the speed on an undisturbed core, and the median, which
the table prints beside it, shows what a disturbed run gets.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from typing import Callable

__all__ = ["RatioRecord", "best_time", "time_calls", "format_table", "DEFAULT_TIMER"]

#: CPU time of this process: on a shared machine it approximates "one core" better than the wall
#: clock (the kernels are single-threaded). Pass ``timer=time.perf_counter`` for wall time.
DEFAULT_TIMER: Callable[[], float] = time.process_time


@dataclass(frozen=True)
class RatioRecord:
    """One benchmark case: fast vs reference seconds measured in the same run."""

    name: str
    fast_seconds: float
    reference_seconds: float
    n_samples: int | None = None
    extra: str = ""
    goal_ratio: float | None = None
    goal_samples_per_s: float | None = None
    fast_median_seconds: float | None = None  # median of the fast path's repeats, if known

    @property
    def ratio(self) -> float:
        """Speed-up, ``reference_seconds / fast_seconds``."""
        return self.reference_seconds / self.fast_seconds if self.fast_seconds > 0 else float("inf")

    @property
    def samples_per_s(self) -> float | None:
        """Samples per second of the fast path (None without ``n_samples``)."""
        if self.n_samples is None or self.fast_seconds <= 0:
            return None
        return self.n_samples / self.fast_seconds

    @property
    def median_samples_per_s(self) -> float | None:
        """Samples per second at the median repeat (None without both numbers)."""
        if self.n_samples is None or not self.fast_median_seconds:
            return None
        return self.n_samples / self.fast_median_seconds

    def verdicts(self) -> str:
        """``met``/``NOT met`` for each goal that is set."""
        out = []
        if self.goal_ratio is not None:
            out.append(f">={self.goal_ratio:g}x {'met' if self.ratio >= self.goal_ratio else 'NOT met'}")
        rate = self.samples_per_s
        if self.goal_samples_per_s is not None and rate is not None:
            ok = rate >= self.goal_samples_per_s
            text = f">={self.goal_samples_per_s / 1e6:g} Ms/s {'met' if ok else 'NOT met'}"
            median = self.median_samples_per_s
            if median is not None:
                ok_median = median >= self.goal_samples_per_s
                text += f" (best), {'met' if ok_median else 'NOT met'} (median)"
            out.append(text)
        return "; ".join(out)


def time_calls(fn: Callable[[], object], repeats: int = 5, warmup: int = 1,
               timer: Callable[[], float] = DEFAULT_TIMER,
               spread_s: float = 0.0) -> list[float]:
    """Times of ``repeats`` calls of ``fn`` after ``warmup`` untimed calls.

    Parameters
    ----------
    fn : callable
        Zero-argument callable to time.
    repeats : int, default 5
        Timed calls, ``>= 1``.
    warmup : int, default 1
        Untimed calls first (Numba compilation, caches).
    timer : callable, default :data:`DEFAULT_TIMER`
        Clock in seconds.
    spread_s : float, default 0.0
        Wall time in seconds over which to spread the timed calls: the harness sleeps
        ``spread_s / repeats`` before each of them (sleep is not CPU time), so that the repeats
        sample several states of a shared host rather than one. 0 times them back to back.

    Returns
    -------
    list of float
        Seconds per timed call, in call order.

    Raises
    ------
    ValueError
        If ``repeats < 1`` or ``spread_s < 0``.
    """
    if repeats < 1:
        raise ValueError(f"repeats must be >= 1, got {repeats}")
    if spread_s < 0:
        raise ValueError(f"spread_s must be >= 0, got {spread_s}")
    for _ in range(warmup):
        fn()
    pause = spread_s / repeats
    times = []
    for _ in range(repeats):
        if pause > 0:
            time.sleep(pause)
        t0 = timer()
        fn()
        times.append(timer() - t0)
    return times


def best_time(fn: Callable[[], object], repeats: int = 5, warmup: int = 1,
              timer: Callable[[], float] = DEFAULT_TIMER, spread_s: float = 0.0) -> float:
    """Best (minimum) time of ``repeats`` calls of ``fn`` after ``warmup`` untimed calls.

    The minimum is the least disturbed by other load. Parameters as :func:`time_calls`.

    Returns
    -------
    float
        Seconds.
    """
    return min(time_calls(fn, repeats, warmup, timer, spread_s))


def format_table(records: list[RatioRecord]) -> list[str]:
    """The end-of-session table, one line per record."""
    try:
        load = "load average %.2f %.2f %.2f" % os.getloadavg()
    except OSError:  # pragma: no cover - platform without getloadavg
        load = "load average unknown"
    head = (f"{'case':<44} {'fast ms':>9} {'ref ms':>10} {'ratio':>8} {'Msamples/s':>10} "
            f"{'median':>7}  goals / notes")
    lines = [f"fast vs reference, measured in this run (CPU time, best of repeats; median: "
             f"Msamples/s at the median repeat; {load}, "
             f"{os.cpu_count()} cpus)", head, "-" * len(head)]
    for r in records:
        rate = r.samples_per_s
        rate_s = f"{rate / 1e6:10.1f}" if rate is not None else f"{'-':>10}"
        median = r.median_samples_per_s
        median_s = f"{median / 1e6:7.1f}" if median is not None else f"{'-':>7}"
        notes = "; ".join(p for p in (r.verdicts(), r.extra) if p)
        lines.append(f"{r.name:<44} {r.fast_seconds * 1e3:9.3f} {r.reference_seconds * 1e3:10.1f} "
                     f"{r.ratio:8.1f} {rate_s} {median_s}  {notes}")
    return lines
