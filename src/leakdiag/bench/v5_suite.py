"""Benchmark v5 suite: every run on its own virtual machine; training and test units disjoint.

Per rig, load and excitation (a *group*): ``n_cal`` healthy calibration runs on training
machines, ``n_test_healthy`` held-out healthy runs and ``n_test_leak`` leaking runs per size on
test machines. Every run is its own unit (machine id), so calibration and test runs are i.i.d.
draws of (unit, operating conditions, noise): the exchangeability the conformal threshold needs
holds by construction, and no test unit was seen in fitting. Noise is drawn per run (unit) from
``noise_range_pa``; loads are never pooled.

Machine ids: training ``1 + i`` (block per group), test ``10_000_000 + seed``; the simulator's
``machine=`` argument receives them when it has one (``leakdiag.sim``'s virtual machines).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from leakdiag.bench.suite import EXCITATIONS, BenchCase, Nuisance

__all__ = ["V5_VERSION", "V5Suite", "V5_SUITES", "V5_QUICK_SUITES", "build_v5_suite",
           "restrict_sizes", "V5_DEFAULT_FAR", "V5_QUICK_FAR", "DEADLINES_S"]

#: Version of the v5 suite (seeds, sizes, ranges). Bump on any change.
V5_VERSION = "5.0"
#: Default per-run false-alarm target of the full suite and of ``--quick`` (20 calibration runs
#: support 1/21 at best, so the quick suite asks for 5 %).
V5_DEFAULT_FAR = 0.01
V5_QUICK_FAR = 0.05
#: Detection deadlines after the true onset (s): 10 s is the goal's, 5 and 30 s are reported.
DEADLINES_S = (5.0, 10.0, 30.0)
#: Seed offsets of the roles (disjoint blocks; leakdiag choice).
_ROLE_OFFSET = {"cal": 0, "test_healthy": 2_000_000, "test_leak": 4_000_000}
#: First machine id of test units (training units are numbered from 1).
TEST_MACHINE_BASE = 10_000_000


@dataclass(frozen=True)
class V5Suite:
    """Suite settings of one rig (benchmark v5).

    Parameters
    ----------
    system : {"vca", "eha"}
        Rig.
    leak_lpm : tuple of float
        Leak sizes (L/min), log-spaced (1-2-5 series).
    loads : tuple of str
        Loads (one group each, never pooled).
    excitations : tuple of str
        Excitations (one group each).
    duration_s : float
        Run duration (s).
    onset_range_s : tuple of float
        Uniform range of the leak onset (s).
    n_cal, n_test_healthy, n_test_leak : int
        Calibration runs (training machines), held-out healthy runs and leaking runs per size
        (test machines), per group.
    noise_range_pa : tuple of float
        Uniform range of the unit's pressure-sensor noise standard deviation (Pa).
    base_seed : int
        First seed of the rig's block.
    nuisance : Nuisance
        Operating-condition ranges (noise factor unused: the noise is drawn from
        ``noise_range_pa``).
    chunk : int
        Test runs per scoring task (one Parquet shard each).
    first_test_index : int, default 0
        Index of the first held-out run of each role and size (``--first-index``): a fresh
        block of seeds for a final measurement. Indexes 0-999 healthy and 0-49 leaking are
        the full suite's, which the project's development has seen (benchmark audit
        2026-11-28, findings 3-4); the run counts ``n_test_*`` follow from it.
    size_indexes : tuple of int, optional
        Place of each of ``leak_lpm`` in the suite the seeds follow (``--sizes`` keeps a
        restricted suite's runs those of the whole suite); None: ``0, 1, ...``.
    """

    system: str
    leak_lpm: tuple[float, ...]
    loads: tuple[str, ...]
    excitations: tuple[str, ...]
    duration_s: float
    onset_range_s: tuple[float, float]
    n_cal: int
    n_test_healthy: int
    n_test_leak: int
    noise_range_pa: tuple[float, float]
    base_seed: int
    nuisance: Nuisance = field(default_factory=Nuisance)
    chunk: int = 25
    first_test_index: int = 0
    size_indexes: tuple[int, ...] | None = None


#: The full v5 suite (60-s runs: onset U[20, 28] s leaves >= 32 s for the 30-s deadline and
#: >= 15 s of monitored healthy operation before it, after the 5-s burn-in).
V5_SUITES: dict[str, V5Suite] = {
    "vca": V5Suite("vca", (0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5), ("none", "spring"),
                   ("operating",), 60.0, (20.0, 28.0), 300, 1000, 50, (10e3, 40e3), 50_000_000),
    "eha": V5Suite("eha", (0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 1.63), ("none", "spring"),
                   ("operating",), 60.0, (20.0, 28.0), 300, 1000, 50, (10e3, 40e3), 60_000_000),
}

#: ``--quick``: one load, 30-s runs, 20 calibration and 20 healthy runs, the largest leak.
V5_QUICK_SUITES: dict[str, V5Suite] = {
    "vca": V5Suite("vca", (0.5,), ("none",), ("operating",), 30.0, (12.0, 15.0), 20, 20, 4,
                   (10e3, 10e3), 70_000_000, chunk=12),
    "eha": V5Suite("eha", (1.63,), ("none",), ("operating",), 30.0, (12.0, 15.0), 20, 20, 4,
                   (10e3, 10e3), 80_000_000, chunk=12),
}


def restrict_sizes(suite: V5Suite, sizes) -> V5Suite:
    """The suite with only some of its leak sizes, each run keeping the whole suite's seed.

    Parameters
    ----------
    suite : V5Suite
        A whole suite (``size_indexes`` None).
    sizes : sequence of float
        Leak sizes (L/min), each one of ``suite.leak_lpm`` (to 1e-9 relative).

    Returns
    -------
    V5Suite
        ``leak_lpm`` the sizes given, in the suite's order, with their ``size_indexes``.

    Raises
    ------
    ValueError
        If a size is not one of the suite's, or the suite is already restricted.

    Examples
    --------
    >>> s = restrict_sizes(V5_SUITES["vca"], [0.02, 0.005])
    >>> s.leak_lpm, s.size_indexes
    ((0.005, 0.02), (1, 3))
    """
    if suite.size_indexes is not None:
        raise ValueError(f"{suite.system}: the suite's sizes are already restricted")
    idx = [next((j for j, q in enumerate(suite.leak_lpm)
                 if math.isclose(q, float(x), rel_tol=1e-9)), None) for x in sizes]
    if None in idx:
        raise ValueError(f"leak size {sizes[idx.index(None)]!r} L/min is not in the "
                         f"{suite.system} suite's sizes {list(suite.leak_lpm)}")
    idx = sorted(set(idx))
    return replace(suite, leak_lpm=tuple(suite.leak_lpm[j] for j in idx),
                   size_indexes=tuple(idx))


def build_v5_suite(suites: dict[str, V5Suite]) -> list[BenchCase]:
    """All runs of the v5 suite, in a fixed order.

    Parameters
    ----------
    suites : dict
        Rig -> :class:`V5Suite`.

    Returns
    -------
    list of BenchCase
        ``noise_level`` is ``"unit"`` (drawn per run); ``nuisance`` holds the drawn conditions
        plus ``machine`` (unit id), ``index`` (run number within its role and size, from
        ``first_test_index`` for held-out runs) and ``position`` (``index`` minus that first).

    Raises
    ------
    ValueError
        If a rig of :data:`V5_SUITES` is given a load that its full suite does not have (the
        seeds follow the load's place in the full suite).

    Notes
    -----
    Seed of run ``i`` of role ``r``, load ``l``, excitation ``e``, size ``j`` (its place in
    the whole suite, ``size_indexes``):
    ``base_seed + offset[r] + 500_000 l + 100_000 e + 10_000 j + i`` (``l`` the load's index
    in the full suite :data:`V5_SUITES`, ``e`` the excitation's in ``EXCITATIONS``; offsets cal 0,
    test_healthy 2 000 000, test_leak 4 000 000). Training machines are ``1 + i +
    10_000 (2 l + e)``, test machines ``10_000_000 + seed``.

    Examples
    --------
    >>> cases = build_v5_suite(V5_QUICK_SUITES)
    >>> len(cases), cases[0].nuisance["machine"], cases[-1].role
    (88, 1, 'test_leak')
    """
    out: list[BenchCase] = []
    for name, s in suites.items():
        for load in s.loads:
            # the load's place in the full suite, not in a restricted one (``--loads spring``
            # took the seeds, and so the cached results, of load none: an audit, 2026-11-27)
            full = V5_SUITES[name].loads if name in V5_SUITES else s.loads
            if load not in full:
                raise ValueError(f"{name}: load {load!r} is not in the v5 suite's loads "
                                 f"{list(full)}: its runs would take another load's seeds")
            li = full.index(load)
            for exc in s.excitations:
                e = EXCITATIONS.index(exc)
                plan = [("cal", 0, 0.0, s.n_cal), ("test_healthy", 0, 0.0, s.n_test_healthy)]
                # the size's place in the whole suite (``--sizes``), as the load's above
                js = s.size_indexes if s.size_indexes is not None else range(len(s.leak_lpm))
                if len(js) != len(s.leak_lpm):
                    raise ValueError(f"{name}: {len(js)} size indexes for {len(s.leak_lpm)} "
                                     "sizes")
                plan += [("test_leak", j, q, s.n_test_leak) for j, q in zip(js, s.leak_lpm)]
                for role, j, q, n in plan:
                    first = 0 if role == "cal" else s.first_test_index
                    if first + n > 10_000:  # the next size's (or load's) seeds
                        raise ValueError(f"{name}: held-out indexes up to {first + n - 1} "
                                         "overlap the seeds of the next size (at most 9999)")
                    for i in range(first, first + n):
                        seed = (s.base_seed + _ROLE_OFFSET[role] + 500_000 * li + 100_000 * e
                                + 10_000 * j + i)
                        rng = np.random.default_rng(seed)
                        onset = float(rng.uniform(*s.onset_range_s)) if q > 0 else None
                        nz = s.nuisance.draw(rng, s.duration_s)
                        noise = float(rng.uniform(*s.noise_range_pa))
                        machine = (1 + i + 10_000 * (2 * li + e) if role == "cal"
                                   else TEST_MACHINE_BASE + seed)
                        nz.update(machine=int(machine), index=i, position=i - first)
                        out.append(BenchCase(name, role, load, "unit", exc, float(q), onset,
                                             seed, s.duration_s, noise, nz))
    return out
