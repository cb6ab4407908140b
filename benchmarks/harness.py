"""Benchmark harness: time a fast path against a reference in the same run, report ratios.

Every benchmark case records one :class:`RatioRecord` through the ``record_ratio`` fixture
(``benchmarks/conftest.py``); at the end of the session all records are printed as one table
(``pytest_terminal_summary``), with samples per second and the goals. Benchmarks never assert
timings: a busy machine must not fail the build. The load average is printed with the table
because the team's machine is shared (2 cores).

Usage in a benchmark module::

    def test_bench_my_feature(record_ratio):
        fast = best_time(lambda: my_fast(x))
        ref = best_time(lambda: my_reference(x), repeats=1)
        record_ratio("my feature N=200", fast, ref, n_samples=len(x), goal_ratio=50)
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from typing import Callable

__all__ = ["RatioRecord", "best_time", "format_table", "DEFAULT_TIMER"]

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

    def verdicts(self) -> str:
        """``met``/``NOT met`` for each goal that is set."""
        out = []
        if self.goal_ratio is not None:
            out.append(f">={self.goal_ratio:g}x {'met' if self.ratio >= self.goal_ratio else 'NOT met'}")
        rate = self.samples_per_s
        if self.goal_samples_per_s is not None and rate is not None:
            ok = rate >= self.goal_samples_per_s
            out.append(f">={self.goal_samples_per_s / 1e6:g} Ms/s {'met' if ok else 'NOT met'}")
        return "; ".join(out)


def best_time(fn: Callable[[], object], repeats: int = 5, warmup: int = 1,
              timer: Callable[[], float] = DEFAULT_TIMER) -> float:
    """Best (minimum) time of ``repeats`` calls of ``fn`` after ``warmup`` untimed calls.

    Parameters
    ----------
    fn : callable
        Zero-argument callable to time.
    repeats : int, default 5
        Timed calls; the minimum is the least disturbed by other load.
    warmup : int, default 1
        Untimed calls first (Numba compilation, caches).
    timer : callable, default :data:`DEFAULT_TIMER`
        Clock in seconds.

    Returns
    -------
    float
        Seconds.
    """
    for _ in range(warmup):
        fn()
    best = float("inf")
    for _ in range(repeats):
        t0 = timer()
        fn()
        best = min(best, timer() - t0)
    return best


def format_table(records: list[RatioRecord]) -> list[str]:
    """The end-of-session table, one line per record."""
    try:
        load = "load average %.2f %.2f %.2f" % os.getloadavg()
    except OSError:  # pragma: no cover - platform without getloadavg
        load = "load average unknown"
    head = (f"{'case':<44} {'fast ms':>9} {'ref ms':>10} {'ratio':>8} {'Msamples/s':>10}  "
            "goals / notes")
    lines = [f"fast vs reference, measured in this run (CPU time, best of repeats; {load}, "
             f"{os.cpu_count()} cpus)", head, "-" * len(head)]
    for r in records:
        rate = r.samples_per_s
        rate_s = f"{rate / 1e6:10.1f}" if rate is not None else f"{'-':>10}"
        notes = "; ".join(p for p in (r.verdicts(), r.extra) if p)
        lines.append(f"{r.name:<44} {r.fast_seconds * 1e3:9.3f} {r.reference_seconds * 1e3:10.1f} "
                     f"{r.ratio:8.1f} {rate_s}  {notes}")
    return lines
