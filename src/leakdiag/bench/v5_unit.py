"""Benchmark v5, per-unit mode (``--unit-fit N``): each unit fitted on N of its own healthy runs.

Deployment-like: a monitored unit gives a few healthy recordings of its own; the detector is
fitted on them (standardisation, identification) and its threshold comes from **reference
maxima** of training units fitted the same way (``Detector.fit(own, reference_maxima=...)``,
pooling rule in ``docs/detect.md``):

* reference (:func:`reference_group`): for every training unit, the detector is fitted on its N
  own healthy runs, and the CUSUM maximum of its calibration run -- a run that fit never saw --
  is one reference maximum (``Detector.segment_maxima``);
* scoring (:func:`score_chunk_unit`): for every held-out run, N own healthy runs of the same
  unit (same machine and sensor noise, other seeds) are simulated, each method is fitted on
  them with the reference maxima pooled, and the held-out run is judged.

Detectors with their own ``fit`` take reference maxima when that ``fit`` has a
``reference_maxima`` parameter (flow balance: GLR segment maxima, ``reference_settings``).
"""

from __future__ import annotations

import time
import warnings
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from leakdiag.bench._workfiles import read_or_discard, write_atomic
from leakdiag.bench.registry import make_detector
from leakdiag.bench.run import _recording, simulator_has_machines
from leakdiag.bench.v5_common import (
    Plan,
    _key,
    _simulate,
    deadline_alarms,
    error_row,
    run_row,
    shard_rows,
    v5_alarm,
    write_shard,
)
from leakdiag.bench.v5_suite import V5_VERSION
from leakdiag.detect.base import Detector
from leakdiag.detect.threshold import InsufficientHealthyDataWarning, ReferenceMaxima

__all__ = ["own_cases", "own_seed", "MAX_OWN_RUNS", "UnitRefConfig", "UnitChunkConfig", "reference_group",
           "score_chunk_unit", "takes_reference", "plan_units"]


#: Own healthy runs per unit at most (:func:`own_seed` keeps their seeds apart up to it).
MAX_OWN_RUNS = 10_000
#: Seeds of own runs after the first ten start here, above every ``10 * seed + 9`` of a suite.
_OWN_SEED_BASE = 10**13


def own_seed(seed: int, k: int) -> int:
    """Seed of own run ``k`` (0-based) of the unit of the suite run ``seed``.

    The first ten are ``10 * seed + k + 1``, as the committed results were made; from the
    eleventh on ``10**13 + 10**4 * seed + k``: with ``10 * seed + k + 1`` alone, own run 10 of one
    unit was own run 0 of the next (the same operating conditions and noise on another
    machine; a statistics audit, 2026-11-29, found 106 of 1,170 own seeds repeated at
    ``--unit-fit 11``).

    Parameters
    ----------
    seed : int
        The suite run's seed (below 10**9: the suites' seeds are below 10**8).
    k : int
        Own run, 0 to :data:`MAX_OWN_RUNS` - 1.

    Returns
    -------
    int

    Raises
    ------
    ValueError
        Outside those ranges.

    Examples
    --------
    >>> own_seed(70_000_000, 0), own_seed(70_000_000, 9), own_seed(70_000_000, 10)
    (700000001, 700000010, 10700000000010)
    """
    if not 0 <= int(seed) < 10**9 or not 0 <= int(k) < MAX_OWN_RUNS:
        raise ValueError(f"own_seed({seed}, {k}): the seed must be in [0, 1e9) and the run in "
                         f"[0, {MAX_OWN_RUNS})")
    if k < 10:
        return 10 * int(seed) + k + 1
    return _OWN_SEED_BASE + 10**4 * int(seed) + k


def own_cases(case, n: int, nuisance) -> list:
    """The ``n`` own healthy runs of a run's unit (same machine and sensor noise).

    Parameters
    ----------
    case : BenchCase
        A run of the suite.
    n : int
        Own runs.
    nuisance : Nuisance
        Operating-condition ranges (drawn afresh for each own run).

    Returns
    -------
    list of BenchCase
        Role ``"own"``, seeds :func:`own_seed` (disjoint from the suite's seeds and from
        every other unit's own runs), no leak.

    Raises
    ------
    ValueError
        For more than :data:`MAX_OWN_RUNS` own runs.

    Examples
    --------
    >>> from leakdiag.bench.v5_suite import V5_QUICK_SUITES, build_v5_suite
    >>> c = build_v5_suite(V5_QUICK_SUITES)[0]
    >>> [o.seed for o in own_cases(c, 2, V5_QUICK_SUITES["vca"].nuisance)]
    [700000001, 700000002]
    """
    if n > MAX_OWN_RUNS:
        raise ValueError(f"--unit-fit {n}: at most {MAX_OWN_RUNS} own healthy runs per unit")
    out = []
    for k in range(n):
        seed = own_seed(case.seed, k)
        nz = nuisance.draw(np.random.default_rng(seed), case.duration_s)
        nz.update(machine=case.nuisance["machine"], index=k)
        out.append(replace(case, role="own", leak_lpm=0.0, onset_s=None, seed=seed,
                           nuisance=nz))
    return out


@dataclass(frozen=True)
class UnitRefConfig:
    """Reference maxima of every method of one group from its training units."""

    cases: tuple  # calibration runs (one per training unit)
    methods: tuple
    n_units: tuple  # per method: training units used (reduced budget)
    alarm: object
    n_own: int
    nuisance: object
    cache_dir: str | None
    path: str


@dataclass(frozen=True)
class UnitChunkConfig:
    """A chunk of held-out runs judged per unit."""

    cases: tuple
    methods: tuple
    caps: tuple  # per method: (n_test_healthy, n_test_leak) or None
    alarm: object
    n_own: int
    nuisance: object
    ref_path: str
    path: str


def takes_reference(det) -> bool:
    """Whether a detector's ``fit`` pools reference maxima (has a ``reference_maxima`` parameter).

    Parameters
    ----------
    det : Detector
        Unfitted detector.

    Returns
    -------
    bool
        True for the base class's ``fit`` and for own fits that take ``reference_maxima``
        (flow balance); False otherwise.
    """
    import inspect

    return (isinstance(det, Detector)
            and "reference_maxima" in inspect.signature(type(det).fit).parameters)


def _fit_own(det, own, ref):
    """Fit on own runs (+ reference maxima); an own-only unsupported threshold is expected."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InsufficientHealthyDataWarning)
        return det.fit(own, reference_maxima=ref) if ref is not None else det.fit(own)


def _load_refs(path) -> dict:
    """Read a reference file of :func:`reference_group` (``refs`` and ``rows``)."""
    import joblib

    saved = joblib.load(path)
    if not isinstance(saved, dict) or not {"refs", "rows"} <= set(saved):
        raise ValueError(f"{path}: not a reference file of reference_group")
    return saved


def reference_group(config: UnitRefConfig) -> list[dict]:
    """Reference maxima of each method from the group's training units (or read them back).

    Parameters
    ----------
    config : UnitRefConfig
        Training units, methods, alarm, own runs per unit, output path.

    Returns
    -------
    list of dict
        Per method: ``n_reference`` maxima, ``n_units``, ``error`` (first failure), CPU s (as
        recorded when computed) and ``reused`` (read back from the work folder).
    """
    import joblib

    path = Path(config.path)
    saved = read_or_discard(path, _load_refs, "reference maxima")  # damaged: removed, redone
    if saved is not None:
        return [{**r, "reused": True} for r in saved["rows"]]
    c0 = config.cases[0]
    build = replace(config.alarm, on_insufficient="warn")  # the own-only threshold is not used here
    maxima = {m: [] for m in config.methods}
    errors: dict[str, str] = {}
    cpu = dict.fromkeys(config.methods, 0.0)
    used: dict = {}
    for i, u in enumerate(config.cases):
        own = [_recording(o, config.cache_dir) for o in own_cases(u, config.n_own,
                                                                   config.nuisance)]
        run = _recording(u, config.cache_dir)
        for m, n_units in zip(config.methods, config.n_units):
            if m in errors or i >= n_units:
                continue
            det = make_detector(m, c0.system, build)
            if not takes_reference(det):
                continue  # own fit and threshold rule: fitted per unit at scoring time
            t0 = time.process_time()
            try:
                _fit_own(det, own, None)
                # the method's own settings (e.g. combined: direction up; GLR: its segment)
                used[m] = det.reference_settings()
                maxima[m].append(det.segment_maxima([run]))
            except (ValueError, NotImplementedError) as exc:
                errors[m] = f"{type(exc).__name__}: {exc}"
            cpu[m] += time.process_time() - t0
    refs, rows = {}, []
    for m in config.methods:
        got = np.concatenate(maxima[m]) if maxima[m] else np.zeros(0)
        if m not in errors and got.size:
            b = used[m]
            refs[m] = ReferenceMaxima(got, b["segment_s"], b["drift"], b["direction"],
                                      b["burn_in_s"],
                                      f"benchmark v5 training units, {c0.system} {c0.load} "
                                      f"{c0.excitation}, {config.n_own} own runs each",
                                      len(config.cases))
        rows.append({"method": m, "system": c0.system, "load": c0.load,
                     "excitation": c0.excitation, "n_reference": int(got.size),
                     "n_units": len(maxima[m]), "error": errors.get(m), "cpu_s": cpu[m]})
    write_atomic(path, lambda tmp: joblib.dump({"refs": refs, "rows": rows}, tmp))
    return [{**r, "reused": False} for r in rows]


def score_chunk_unit(config: UnitChunkConfig) -> dict:
    """Judge held-out runs, each method fitted on the run's unit's own healthy runs.

    Parameters
    ----------
    config : UnitChunkConfig
        Runs, methods, reference maxima path, shard path.

    Returns
    -------
    dict
        ``rows`` in the shard and ``reused`` (the shard existed: read back, not recomputed).
    """
    path = Path(config.path)
    n = read_or_discard(path, shard_rows, "result shard")  # damaged: warned, removed, redone
    if n is not None:
        return {"rows": n, "reused": True}
    refs = _load_refs(config.ref_path)["refs"]
    rows = []
    for c in config.cases:
        idx = c.nuisance.get("position", c.nuisance["index"])  # budget caps
        todo = [m for m, caps in zip(config.methods, config.caps)
                if caps is None or idx < (caps[0] if c.role == "test_healthy" else caps[1])]
        if not todo:
            continue
        t0 = time.process_time()
        own = [_simulate(o) for o in own_cases(c, config.n_own, config.nuisance)]
        rec = _simulate(c)
        sim_cpu = time.process_time() - t0
        for m in todo:
            det = make_detector(m, c.system, config.alarm)
            ref = None
            if takes_reference(det):
                ref = refs.get(m)
                if ref is None:
                    continue  # no reference could be built (its error is in fits.csv)
            t0 = time.process_time()
            try:
                _fit_own(det, own, ref)
                v = det.predict(rec)
            except (ValueError, ArithmeticError, NotImplementedError) as exc:
                rows.append(error_row(c, m, exc))
                continue
            basis = getattr(det, "threshold_basis_", None)
            rows.append({**run_row(c, m, rec, v, time.process_time() - t0, sim_cpu),
                         **deadline_alarms(det, rec, c),
                         "threshold_method": getattr(basis, "method", None),
                         "threshold_k": getattr(basis, "k", np.nan),
                         "threshold_n": getattr(basis, "n", np.nan)})
    return {"rows": write_shard(rows, path), "reused": False}


def plan_units(suites, methods, work, groups, fp, n_own, far, onset_method, cache_dir, budget,
               confidence=None):
    """Stages 2 and 3 of :func:`~leakdiag.bench.v5_run.run_v5` in per-unit mode.

    Parameters
    ----------
    suites : dict
        Rig -> suite.
    methods : sequence of str
        Registry names.
    work : pathlib.Path
        Resumable state folder.
    groups : dict
        (rig, load, excitation) -> runs of the group.
    fp : str
        Code fingerprint (part of every key).
    n_own : int
        Own healthy runs per unit.
    far : float
        Target false alarms per run.
    onset_method : str
        Onset estimator.
    cache_dir : str or None
        Simulation cache.
    budget : dict
        Reduced budget per method.
    confidence : float, optional
        Calibration-conditional thresholds (``Alarm.confidence``).

    Returns
    -------
    Plan
        :func:`reference_group` tasks (one per group) and :func:`score_chunk_unit` chunks.
    """

    ref_cfgs, chunk_cfgs = [], []
    for key, group in groups.items():
        s = suites[key[0]]
        alarm = v5_alarm(far, s.duration_s, onset_method, confidence)
        cal = tuple(c for c in group if c.role == "cal")
        n_units = tuple(budget[m][0] if m in budget else len(cal) for m in methods)
        caps = tuple(budget[m][1:] if m in budget else None for m in methods)
        k = _key([V5_VERSION, fp, "unit", n_own, list(methods), n_units, asdict(alarm),
                  [c.seed for c in cal], simulator_has_machines(key[0])])
        ref_path = str(work / "refs" / f"{k}.joblib")
        ref_cfgs.append(UnitRefConfig(cal, tuple(methods), n_units, alarm, n_own, s.nuisance,
                                      cache_dir, ref_path))
        test = [c for c in group if c.role != "cal"]
        for i in range(0, len(test), s.chunk):
            chunk = tuple(test[i: i + s.chunk])
            kc = _key([k, [c.seed for c in chunk], caps])
            chunk_cfgs.append(UnitChunkConfig(chunk, tuple(methods), caps, alarm, n_own,
                                              s.nuisance, ref_path,
                                              str(work / "unit-shards" / f"{kc}.parquet")))
    return Plan(reference_group, ref_cfgs, "reference maxima", score_chunk_unit, chunk_cfgs,
                "score held-out units", len(ref_cfgs))
