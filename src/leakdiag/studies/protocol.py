"""The thesis's experimental protocol on the simulators, as serialisable cases.

:class:`ProtocolConfig` holds every setting of a reproduction (durations, onsets, leak sizes,
loads, seeds, chunk length). :func:`build_cases` turns it into plain-dict cases of three kinds,
each run by the pure :func:`run_case` (serially or on Dask, see :mod:`leakdiag.runtime.executor`):

* ``"tables"``: one simulated experiment (case study 1 or 2 of a system), every row of
  ``tables.csv`` of that case computed at its stated setting, plus the Sec. 4.4 procedure
  (:func:`~leakdiag.studies.sweep.ofat_sweep`) run on our own values;
* ``"sensitivity"``: one experiment of case study 3 (leak size x load x seed x duration), every
  preferred method of the thesis measured;
* ``"stationarity"``: the Sec. 4.7 analysis of the case-study-1 experiment.

Two named protocols (:data:`PROTOCOLS`): ``"thesis"`` (the default) runs the case studies as
the Sec. 5.1 and Sec. 6 lists state them (VCA case studies 1-2 without load, step amplitudes
8-20, 5-17 and 2-20 mm, the sensor chains of Secs. 2.2 and 3.2); ``"v1"`` keeps the setup of the
first reproductions (spring load, 2-20 mm, default sensors) so that effects can be compared.

Simulations go through :func:`~leakdiag.runtime.cache.cached_simulation`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from leakdiag.features.registry import feature_record
from leakdiag.features.spec import MethodSpec, compute_feature
from leakdiag.runtime.cache import cached_simulation
from leakdiag.sim.reference import PseudoRandomSteps
from leakdiag.sim.sensors import THESIS_EHA_SENSORS, THESIS_VCA_SENSORS
from leakdiag.studies.grid import measure_row, quiet_degenerate
from leakdiag.studies.nan_windows import nan_windows_by_side, pct_change_nan_as_zero
from leakdiag.studies.select import SelectionRule
from leakdiag.studies.stationarity import stationarity
from leakdiag.studies.sweep import ofat_sweep
from leakdiag.studies.thesis import channels_of, load_tables

__all__ = ["ProtocolConfig", "QUICK", "FULL", "THESIS", "V1", "PROTOCOLS", "protocol_config",
           "build_cases", "run_case", "simulate_case", "case_simulator_kwargs",
           "SENSITIVITY_METHODS"]

VCA_DURATION_S = 400.0  # Sec. 4.5: 400 s experiments, leak at about 200 s
VCA_ONSET_S = 200.0  # Sec. 4.5
EHA_DURATION_S = 180.0  # Sec. 6 case studies: 180 s, leak after 90 s
EHA_ONSET_S = 90.0  # Sec. 6
VCA_CASE_LEAKS_LPM = {1: 0.10, 2: 0.047}  # Sec. 5.1 case studies 1 and 2
EHA_CASE_LEAKS_LPM = {1: 1.2, 2: 0.98}  # Sec. 6 case studies 1 and 2
VCA_SENSITIVITY_LPM = (0.047, 0.1, 0.2, 0.3, 0.4, 0.5)  # Sec. 5.1 case study 3: 0.047-0.5
EHA_SENSITIVITY_LPM = (0.77, 0.98, 1.2, 1.4, 1.63)  # Sec. 6 case study 3: 0.77-1.63
VCA_SENSITIVITY_DURATIONS_S = (300.0, 400.0, 600.0)  # Sec. 5.1: tests of 300, 400 and 600 s
#: Step amplitudes of the pseudorandom reference per VCA case study, mm (Sec. 5.1 list: case
#: study 1 "amplitude: 8 mm to 20 mm", case study 2 "5 mm to 17 mm", case study 3 "2 mm to
#: 20 mm").
VCA_REFERENCE_MM = ((1, 8.0, 20.0), (2, 5.0, 17.0), (3, 2.0, 20.0))
#: Load of VCA case studies 1 and 2: Sec. 5.1 list, "under a no-load condition" (both).
VCA_CASE_LOAD = "none"
STATIONARITY_WINDOW = 400  # Sec. 4.7.1: window 400
STATIONARITY_OVERLAP = 50.0  # Sec. 4.7.1: 50 % overlap

#: Methods measured in the sensitivity study (Figs. 5-23 to 5-28, 6-5 to 6-20): the thesis's
#: preferred settings (case-study-2 tables), p2 variants as in Figs. 5-24 and 5-28.
SENSITIVITY_METHODS = {
    "vca": (("autocorrelation", "p1", "1", 200, 5.0), ("autocorrelation", "p2", "1", 200, 5.0),
            ("cross-correlation", "p1,p2", "1", 100, 5.0),
            ("cross-correlation", "u,x", "1", 100, 5.0),
            ("metric-length", "p1", "83:3", 500, 5.0), ("metric-length", "p2", "83:3", 500, 5.0)),
    "eha": (("autocorrelation", "p1", "1", 200, 10.0),
            ("cross-correlation", "p1,p2", "16", 100, 10.0),
            ("cross-correlation", "u,x", "8", 100, 5.0),
            ("metric-length", "p1", "43:3", 400, 5.0)),
}


@dataclass(frozen=True)
class ProtocolConfig:
    """Every setting of a reproduction run (stored with its results).

    Parameters
    ----------
    name : str
        ``"thesis"``, ``"v1"`` or their ``-quick`` versions (or any label).
    vca_duration_s, vca_onset_s : float
        Case-study 1 and 2 VCA experiment length and leak onset, s.
    eha_duration_s, eha_onset_s : float
        Same for the EHA.
    vca_load, eha_load : str
        Load of the case-study 1-2 experiments: VCA ``"none"`` (Sec. 5.1: case studies 1 and 2
        "under a no-load condition"; protocol ``v1`` used ``"spring"`` after Sec. 4.5), EHA
        ``"none"`` (Sec. 6, "no-load condition").
    table_seed : int
        Seed of the case-study 1-2 experiments.
    vca_sensitivity_lpm, eha_sensitivity_lpm : tuple of float
        Leak sizes of case study 3, L/min.
    vca_sensitivity_durations_s : tuple of float
        VCA experiment lengths of case study 3 (leak at half time), s.
    eha_sensitivity_duration_s : float
        EHA experiment length of case study 3, s.
    loads : tuple of str
        Loads of case study 3.
    sensitivity_seeds : tuple of int
        Seeds of case study 3.
    chunk : int
        RMS chunk length in feature values (Sec. 5.2; not stated in the thesis).
    cache_dir : str or None
        Simulation cache folder (None: default, see :func:`leakdiag.runtime.cache.resolve_cache_dir`).
    vca_reference_mm : tuple of (case_study, min_mm, max_mm) or None
        Step amplitudes of the VCA reference per case study (:data:`VCA_REFERENCE_MM`, Sec.
        5.1); ``None``: the simulator's default reference (2-20 mm, protocol ``v1``).
    sensor_chain : {"thesis", "default"}
        ``"thesis"``: the chains of Secs. 2.2 and 3.2
        (:data:`~leakdiag.sim.sensors.THESIS_VCA_SENSORS`,
        :data:`~leakdiag.sim.sensors.THESIS_EHA_SENSORS`); ``"default"``: the simulators'
        defaults (protocol ``v1``).

    Examples
    --------
    >>> QUICK.vca_duration_s, FULL.vca_duration_s, FULL.vca_load, V1.vca_load
    (60.0, 400.0, 'none', 'spring')
    """

    name: str = "thesis"
    vca_duration_s: float = VCA_DURATION_S
    vca_onset_s: float = VCA_ONSET_S
    eha_duration_s: float = EHA_DURATION_S
    eha_onset_s: float = EHA_ONSET_S
    vca_load: str = VCA_CASE_LOAD
    eha_load: str = "none"
    table_seed: int = 0
    vca_sensitivity_lpm: tuple = VCA_SENSITIVITY_LPM
    eha_sensitivity_lpm: tuple = EHA_SENSITIVITY_LPM
    vca_sensitivity_durations_s: tuple = VCA_SENSITIVITY_DURATIONS_S
    eha_sensitivity_duration_s: float = EHA_DURATION_S
    loads: tuple = ("spring", "none")
    sensitivity_seeds: tuple = (1, 2)
    chunk: int = 10
    cache_dir: str | None = None
    extra: dict = field(default_factory=dict)
    vca_reference_mm: tuple | None = VCA_REFERENCE_MM
    sensor_chain: str = "thesis"

    def __post_init__(self) -> None:
        if self.sensor_chain not in ("thesis", "default"):
            raise ValueError(f"sensor_chain={self.sensor_chain!r} must be 'thesis' or 'default'")
        if self.vca_reference_mm is not None:
            for item in self.vca_reference_mm:
                cs, lo, hi = item
                if not 0 <= lo < hi:
                    raise ValueError(f"vca_reference_mm entry {item!r}: need 0 <= min < max")

    def as_dict(self) -> dict:
        """All fields as plain data.

        Returns
        -------
        dict
        """
        return dataclasses.asdict(self)


#: The case studies as the thesis states them (Sec. 5.1 and Sec. 6 lists): VCA case studies 1
#: and 2 without load, their stated step amplitudes, the sensor chains of Secs. 2.2 and 3.2.
THESIS = ProtocolConfig()
#: The protocol of the first reproductions (before issue 14): VCA case studies 1-2 under the
#: spring load, the simulator's 2-20 mm reference everywhere, the simulators' default sensors.
V1 = ProtocolConfig(name="v1", vca_load="spring", vca_reference_mm=None, sensor_chain="default")
#: Protocols by name (``leakdiag reproduce --protocol``).
PROTOCOLS = {"thesis": THESIS, "v1": V1}
#: The default protocol at full length (the thesis's).
FULL = THESIS


def _quick(cfg: ProtocolConfig) -> ProtocolConfig:
    """The short CI version of a protocol (same setup, shorter runs, fewer cases)."""
    return dataclasses.replace(
        cfg, name=f"{cfg.name}-quick", vca_duration_s=60.0, vca_onset_s=30.0,
        eha_duration_s=40.0, eha_onset_s=20.0, vca_sensitivity_lpm=(0.047, 0.5),
        eha_sensitivity_lpm=(0.77, 1.63), vca_sensitivity_durations_s=(60.0,),
        eha_sensitivity_duration_s=40.0, sensitivity_seeds=(1,))


#: A short version for CI: 60 s VCA (leak at 30 s), 40 s EHA (leak at 20 s), one seed, two
#: leak sizes per system, one VCA duration.
QUICK = _quick(THESIS)


def protocol_config(name: str = "thesis", quick: bool = False) -> ProtocolConfig:
    """A named protocol, optionally in its short version.

    Parameters
    ----------
    name : {"thesis", "v1"}
        Protocol (:data:`PROTOCOLS`).
    quick : bool, default False
        Short CI version.

    Returns
    -------
    ProtocolConfig

    Raises
    ------
    ValueError
        For an unknown name.

    Examples
    --------
    >>> protocol_config("v1", quick=True).name
    'v1-quick'
    """
    if name not in PROTOCOLS:
        raise ValueError(f"protocol={name!r} must be one of {sorted(PROTOCOLS)}")
    cfg = PROTOCOLS[name]
    return _quick(cfg) if quick else cfg


def _vca_extras(cfg: ProtocolConfig, case_study: int) -> dict:
    """Simulator arguments beyond the v1 ones: the reference and the sensor chain."""
    out = {}
    if cfg.vca_reference_mm is not None:
        ref = {int(cs): (float(lo), float(hi)) for cs, lo, hi in cfg.vca_reference_mm}
        if case_study in ref:
            lo, hi = ref[case_study]
            out["reference"] = {"min_amplitude_m": lo * 1e-3, "max_amplitude_m": hi * 1e-3}
    if cfg.sensor_chain == "thesis":
        out["sensor_chain"] = "thesis"
    return out


def build_cases(cfg: ProtocolConfig, systems=("vca", "eha")) -> list[dict]:
    """All cases of a reproduction as plain dicts (each runnable by :func:`run_case`).

    Parameters
    ----------
    cfg : ProtocolConfig
        Settings.
    systems : sequence of {"vca", "eha"}
        Systems to include.

    Returns
    -------
    list of dict

    Raises
    ------
    ValueError
        For an unknown system.

    Examples
    --------
    >>> cases = build_cases(QUICK, ["vca"])
    >>> sorted({c["kind"] for c in cases}), len(cases)
    (['sensitivity', 'stationarity', 'tables'], 7)
    """
    cases = []
    for system in systems:
        if system not in ("vca", "eha"):
            raise ValueError(f"unknown system {system!r}; use 'vca' or 'eha'")
        vca = system == "vca"
        dur = cfg.vca_duration_s if vca else cfg.eha_duration_s
        onset = cfg.vca_onset_s if vca else cfg.eha_onset_s
        load = cfg.vca_load if vca else cfg.eha_load
        leaks = VCA_CASE_LEAKS_LPM if vca else EHA_CASE_LEAKS_LPM
        base = {"system": system, "chunk": cfg.chunk, "cache_dir": cfg.cache_dir}
        def extras(cs):
            if vca:
                return _vca_extras(cfg, cs)
            return {"sensor_chain": "thesis"} if cfg.sensor_chain == "thesis" else {}

        for cs, leak in leaks.items():
            sim = {"duration": dur, "leak_lpm": leak, "onset": onset, "load": load,
                   "seed": cfg.table_seed, **extras(cs)}
            cases.append({**base, "kind": "tables", "case_study": cs, "sim": sim})
        cases.append({**base, "kind": "stationarity", "case_study": 1,
                      "sim": {"duration": dur, "leak_lpm": leaks[1], "onset": onset,
                              "load": load, "seed": cfg.table_seed, **extras(1)}})
        durations = cfg.vca_sensitivity_durations_s if vca else (cfg.eha_sensitivity_duration_s,)
        for leak in (cfg.vca_sensitivity_lpm if vca else cfg.eha_sensitivity_lpm):
            for load3 in cfg.loads:
                for d in durations:
                    for seed in cfg.sensitivity_seeds:
                        sim = {"duration": float(d), "leak_lpm": float(leak),
                               "onset": float(d) / 2, "load": load3, "seed": int(seed),
                               **extras(3)}
                        cases.append({**base, "kind": "sensitivity", "case_study": 3,
                                      "sim": sim})
    return cases


def case_simulator_kwargs(system: str, case_study: int,
                          config: ProtocolConfig | None = None) -> dict:
    """The simulator arguments of case study 1 or 2 as a protocol runs it (seed left out).

    What :func:`build_cases` gives a ``"tables"`` case, in the form ``simulate_vca`` /
    ``simulate_eha`` take (the reference and sensor chain as objects), so that another caller
    (``leakdiag demo``) runs the same experiment.

    Parameters
    ----------
    system : {"vca", "eha"}
        Rig.
    case_study : {1, 2}
        Case study (Sec. 5.1, Sec. 6).
    config : ProtocolConfig, optional
        Protocol (default :data:`THESIS`).

    Returns
    -------
    dict
        ``duration``, ``leak_lpm``, ``onset``, ``load`` and, as the protocol states them,
        ``reference`` (VCA) and ``sensor_params``.

    Raises
    ------
    ValueError
        For an unknown system or a case study other than 1 and 2.

    Examples
    --------
    >>> kw = case_simulator_kwargs("vca", 1)
    >>> kw["duration"], kw["onset"], kw["leak_lpm"], kw["load"]
    (400.0, 200.0, 0.1, 'none')
    >>> kw["reference"].min_amplitude_m, kw["reference"].max_amplitude_m
    (0.008, 0.02)
    """
    cfg = config or THESIS
    if system not in ("vca", "eha"):
        raise ValueError(f"unknown system {system!r}; use 'vca' or 'eha'")
    case = next((c for c in build_cases(cfg, (system,))
                 if c["kind"] == "tables" and c["case_study"] == case_study), None)
    if case is None:
        raise ValueError(f"case_study={case_study!r} must be 1 or 2 (case study 3 is a grid)")
    sim = _simulator_kwargs(system, case["sim"])
    sim.pop("seed")
    return sim


def _simulator_kwargs(system: str, sim: dict) -> dict:
    """A case's plain ``sim`` dict as simulator arguments (reference and sensors as objects)."""
    sim = dict(sim)
    if "reference" in sim:
        sim["reference"] = PseudoRandomSteps(**sim["reference"])
    chain = sim.pop("sensor_chain", "default")
    if chain == "thesis":
        sim["sensor_params"] = THESIS_VCA_SENSORS if system == "vca" else THESIS_EHA_SENSORS
    elif chain != "default":
        raise ValueError(f"sensor_chain={chain!r} must be 'thesis' or 'default'")
    return sim


def simulate_case(case: dict):
    """The (cached) simulated recording of a case.

    Parameters
    ----------
    case : dict
        A case from :func:`build_cases`.

    Returns
    -------
    Recording

    Raises
    ------
    ValueError
        For an unknown ``sensor_chain`` in the case's simulator arguments.
    """
    sim = _simulator_kwargs(case["system"], case["sim"])
    return cached_simulation(case["system"], cache_dir=case.get("cache_dir"), **sim)


def _spec(method, channels, lag, window, overlap):
    rec = feature_record(method)
    chans = tuple(c.strip() for c in str(channels).split(","))
    kw = {"lag_ratio": str(lag)} if rec.setting == "lag_ratio" else \
        {"lag": int(lag)} if rec.setting == "lag" else {}
    return MethodSpec(rec.name, chans, window=int(window), overlap=float(overlap), **kw)


def _measure(rec, spec, onset, chunk, keep_series=False) -> dict:
    with quiet_degenerate():
        fs = compute_feature(rec, spec)
    lag = spec.lag_ratio if spec.lag_ratio is not None else spec.lag
    row = measure_row(fs, onset, chunk, spec.method, spec.channels, lag, spec.window,
                      spec.overlap)
    # disclosed beside the measure (thesis audit 2026-11-28, F1): the undefined windows per
    # side, and the % change with them counted as 0 (a sensitivity, not the measure)
    row.update(nan_windows_by_side(fs, onset, chunk))
    row["pct_change_signed_nan_as_0"] = pct_change_nan_as_zero(fs, onset, chunk)
    if keep_series:
        row["series_time"] = np.asarray(fs.time, dtype=np.float32)
        row["series_values"] = np.asarray(fs.values, dtype=np.float32)
    return row


def _run_tables(case, rec) -> dict:
    t = load_tables()
    t = t[(t.system.str.lower() == case["system"]) & (t.case_study == case["case_study"])]
    onset = float(rec.onset if rec.onset is not None else case["sim"]["onset"])
    rows = []
    for r in t.itertuples(index=False):
        spec = _spec(r.method, ",".join(channels_of(r.signals)), r.lag, r.window, r.overlap_pct)
        out = _measure(rec, spec, onset, case["chunk"], keep_series=True)
        out["row_id"] = int(r.row_id)
        rows.append(out)
    ofat = []
    if case["case_study"] == 1:
        for (method, signals), g in t.groupby(["method", "signals"], sort=False):
            lags = list(dict.fromkeys(g.loc[g.varied.isin(["lag", "lag_ratio"]), "lag"]))
            wins = list(dict.fromkeys(g.loc[g.varied == "window", "window"].astype(int)))
            ovs = list(dict.fromkeys(g.loc[g.varied == "overlap", "overlap_pct"].astype(float)))
            if not (lags and wins and ovs):
                continue
            first = g.iloc[0]
            try:
                res = ofat_sweep(rec, method, ",".join(channels_of(signals)), lags, wins, ovs,
                                 start_window=int(first.window),
                                 start_overlap=float(first.overlap_pct), rule=SelectionRule(),
                                 onset=onset, chunk=case["chunk"])
            except ValueError as exc:
                ofat.append({"method": method, "signals": signals, "error": str(exc)})
                continue
            ofat.append({"method": method, "signals": signals, **{f"chosen_{k}": v for k, v in
                                                                   res.chosen.items()},
                         "table": res.table()})
    return {"rows": rows, "ofat": ofat, "leak_lpm_achieved": rec.meta.get("leak_lpm_achieved")}


def _run_sensitivity(case, rec) -> dict:
    onset = float(rec.onset if rec.onset is not None else case["sim"]["onset"])
    rows = []
    for method, chans, lag, window, overlap in SENSITIVITY_METHODS[case["system"]]:
        row = _measure(rec, _spec(method, chans, lag, window, overlap), onset, case["chunk"])
        row.update({k: case["sim"][k] for k in ("leak_lpm", "load", "seed", "duration")})
        row["system"] = case["system"]
        row["leak_lpm_achieved"] = rec.meta.get("leak_lpm_achieved")
        rows.append(row)
    return {"rows": rows}


def run_case(case: dict) -> dict:
    """Run one case: simulate (cached), then measure. Pure: same case, same result.

    Parameters
    ----------
    case : dict
        A case from :func:`build_cases`.

    Returns
    -------
    dict
        ``"tables"``: ``rows`` (one per thesis table row, with the feature series) and ``ofat``;
        ``"sensitivity"``: ``rows`` (one per method); ``"stationarity"``: see
        :func:`leakdiag.studies.stationarity.stationarity`. Always ``cache_hit`` and ``case``.

    Raises
    ------
    ValueError
        For an unknown case kind.
    """
    rec = simulate_case(case)
    kind = case["kind"]
    if kind == "tables":
        out = _run_tables(case, rec)
    elif kind == "sensitivity":
        out = _run_sensitivity(case, rec)
    elif kind == "stationarity":
        out = stationarity(rec, window=STATIONARITY_WINDOW, overlap=STATIONARITY_OVERLAP)
    else:
        raise ValueError(f"unknown case kind {kind!r}")
    out["cache_hit"] = bool(rec.meta.get("cache_hit"))
    out["case"] = case
    return out
