"""``leakdiag fit``: fit a detector on healthy recordings and save it (joblib + metadata record)."""

from __future__ import annotations

import os

import click

from leakdiag.cli._options import no_progress_option, recording_options, resample_option
from leakdiag.detect.base import read_channels as detector_channels

__all__ = ["fit", "fit_detector", "detector_channels", "channels_of_methods", "system_of",
           "common_load", "check_out_path"]

#: Suffixes of recordings (``leakdiag.io``): ``-o`` with one of them is refused unless the file
#: is already a detector file (``fit ... -o a.parquet`` overwrote a healthy input).
_RECORDING_SUFFIXES = (".parquet", ".pq", ".csv", ".h5", ".hdf5", ".txt")


def _same_file(a: str, b: str) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:  # one does not exist (yet)
        return os.path.realpath(a) == os.path.realpath(b)


def check_out_path(out: str, inputs) -> None:
    """Refuse an ``-o`` that would overwrite an input or a recording.

    Parameters
    ----------
    out : str
        The detector file to write.
    inputs : iterable of (option, path)
        The recordings read (``--healthy``, ``--calibrate``).

    Raises
    ------
    click.BadParameter
        When ``out`` is (the same file as) one of ``inputs``, or has a recording's suffix and is
        not already a detector file.

    Examples
    --------
    >>> check_out_path("h1.parquet", [("--healthy", "h1.parquet")])
    Traceback (most recent call last):
    ...
    click.exceptions.BadParameter: h1.parquet is the --healthy recording h1.parquet: writing the detector would overwrite it; give a new file, e.g. det.joblib
    """
    from leakdiag.stream.detector_file import sniff_detector_file

    for opt, p in inputs:
        if _same_file(out, p):
            raise click.BadParameter(f"{out} is the {opt} recording {p}: writing the detector "
                                     "would overwrite it; give a new file, e.g. det.joblib",
                                     param_hint="--out")
    suffix = os.path.splitext(out)[1].lower()
    if suffix in _RECORDING_SUFFIXES:
        try:
            is_detector = os.path.isfile(out) and sniff_detector_file(out) is None
        except OSError:
            is_detector = False
        if not is_detector:
            stem = os.path.splitext(out)[0]
            raise click.BadParameter(
                f"{out}: a recording's suffix ({suffix}), "
                + ("and the file is not a detector file: writing would overwrite it"
                   if os.path.exists(out) else "but a detector file is a joblib pickle")
                + f"; give e.g. {stem}.joblib", param_hint="--out")


def channels_of_methods(methods, system=None, recording=None) -> list[str]:
    """The channels that ``methods`` read, on ``system`` (both rigs when None and
    ``recording`` does not say): what detect and fit read of a file (the other columns are
    neither converted nor checked).

    Parameters
    ----------
    methods : sequence of str
        Method names (:data:`leakdiag.bench.registry.METHODS`); unknown ones are skipped
        (they are refused where they are fitted).
    system : {"vca", "eha"}, optional
        The rig.
    recording : Recording, optional
        Only its channels are returned (and its metadata's rig is used when ``system`` is
        None).

    Returns
    -------
    list of str
        Sorted.

    Examples
    --------
    >>> channels_of_methods(["acf-p1", "ccf-p1p2"], "vca")
    ['p1', 'p2']
    >>> channels_of_methods(["flow-balance"])  # either rig
    ['p1', 'p2', 'pa', 'pb', 'speed', 'u', 'x']
    """
    from leakdiag.bench.registry import make_detector
    from leakdiag.detect.base import Alarm

    said = system or (recording.meta.get("system") if recording is not None else None)
    out: set[str] = set()
    for rig in ([str(said).lower()] if said else ["vca", "eha"]):
        for m in methods:
            try:
                det = make_detector(m, rig, Alarm())
            except (TypeError, ValueError):  # not a method (of that rig)
                continue
            out.update(c for c in detector_channels(det, recording)
                       if recording is None or c in recording.channels)
    return sorted(out)


def common_load(recordings) -> str | None:
    """The load every recording's metadata names, or None (unknown or mixed).

    Parameters
    ----------
    recordings : iterable of Recording
        Healthy recordings.

    Returns
    -------
    str or None
        ``meta["load"]`` when all recordings carry the same one.

    Examples
    --------
    >>> from leakdiag.io.recording import Recording
    >>> r = lambda load: Recording({"p1": [0.0, 1.0]}, 1.0, meta={"load": load})
    >>> common_load([r("spring"), r("spring")]), common_load([r("spring"), r("none")])
    ('spring', None)
    """
    from leakdiag.io.recording import load_name

    loads = {load_name(r.meta.get("load")) for r in recordings}
    return loads.pop() if len(loads) == 1 else None


def system_of(recordings, given: str | None, names) -> str:
    """The system (vca/eha) from ``--system`` or the recordings' metadata, never a silent guess.

    Parameters
    ----------
    recordings : sequence of Recording
        Recordings whose ``meta['system']`` is read.
    given : str or None
        ``--system``.
    names : sequence of str
        File names for messages.

    Returns
    -------
    str

    Raises
    ------
    ValueError
        When the files disagree with each other or with ``--system``, or nothing says which.

    Examples
    --------
    >>> from leakdiag.io import Recording
    >>> import numpy as np
    >>> system_of([Recording({"p1": np.zeros(3)}, 1.0, meta={"system": "EHA"})], None, ["a"])
    'eha'
    """
    found = {}
    for r, n in zip(recordings, names):
        s = r.meta.get("system")
        if s:
            found[n] = str(s).lower()
    kinds = set(found.values())
    if len(kinds) > 1:
        raise ValueError("the files come from different systems: "
                         + ", ".join(f"{n}: {s}" for n, s in found.items()))
    if given is not None:
        if kinds and given not in kinds:
            n, s = next(iter(found.items()))
            raise ValueError(f"--system {given}, but {n}'s metadata says {s!r}")
        return given
    if kinds:
        return kinds.pop()
    raise ValueError(f"{', '.join(names)}: the metadata does not say which system recorded "
                     "them; give --system vca or --system eha (it selects the thesis's settings)")


def fit_detector(method: str, system: str, healthy, *, false_alarms_per_hour: float = 1.0,
                 burn_in_s: float = 5.0, onset_method: str = "binseg",
                 confidence: float | None = None):
    """Build the registry's detector ``method`` for ``system`` and fit it on ``healthy``.

    Parameters
    ----------
    method : str
        Key of :data:`leakdiag.bench.registry.METHODS`.
    system : {"vca", "eha"}
        Rig.
    healthy : sequence of Recording
        Healthy recordings.
    false_alarms_per_hour : float, default 1.0
        CUSUM false-alarm target on healthy operation.
    burn_in_s : float, default 5.0
        Leading seconds ignored in every recording.
    onset_method : {"binseg", "pelt", "cusum"}, default "binseg"
        Onset estimator.
    confidence : float, optional
        Calibration-conditional threshold (:class:`~leakdiag.detect.base.Alarm`); None: the
        marginal conformal rank.

    Returns
    -------
    Detector
        Fitted.
    """
    from leakdiag.bench.registry import make_detector
    from leakdiag.detect.base import Alarm

    alarm = Alarm(false_alarms_per_hour=false_alarms_per_hour, onset_method=onset_method,
                  burn_in_s=burn_in_s, confidence=confidence)
    det = make_detector(method, system, alarm)
    return det.fit(list(healthy))


def _method_names():
    from leakdiag.bench.registry import METHODS

    return sorted(METHODS)


class _LazyChoice(click.Choice):
    """A Choice over the registry's methods, read when the command runs (helpers add methods)."""

    def __init__(self):
        super().__init__([])

    def convert(self, value, param, ctx):
        self.choices = _method_names()
        return super().convert(value, param, ctx)

    def get_metavar(self, param, *args, **kwargs):
        return "METHOD"


@click.command("fit", epilog="Example: leakdiag fit --healthy h1.parquet --healthy h2.parquet "
                             "--healthy h3.parquet --method ccf-p1p2 --false-alarm-rate 10 -o "
                             "det.joblib (three 120-s runs support about 10 false alarms per "
                             "hour; the default 1 per hour needs about an hour of healthy data)")
@click.option("--healthy", multiple=True, required=True,
              type=click.Path(exists=True, dir_okay=False),
              help="Healthy recording of the machine (repeat for several; more gives a "
                   "threshold that holds better).")
@click.option("--method", "-m", required=True, type=_LazyChoice(),
              help="Detector (leakdiag benchmark --list-methods): acf-p1, ccf-p1p2, mlr-p1, "
                   "combined, wavelet-p1, fft-p1, emd-p1, ekf, ...")
@click.option("--system", type=click.Choice(["vca", "eha"]), default=None,
              help="Rig (default: the files' metadata; required when they do not say).")
@recording_options
@resample_option
@click.option("--false-alarm-rate", type=click.FloatRange(min=0, min_open=True), default=1.0,
              show_default=True,
              help="False alarms per hour of healthy operation the detector's threshold is set "
                   "for (continuous monitoring: the CUSUM restarts at every healthy segment "
                   "unless in alarm; the flow balance's GLR does not, docs/detect.md section 2).")
@click.option("--burn-in", "burn_in_s", type=click.FloatRange(min=0), default=5.0,
              show_default=True,
              help="Seconds ignored at the start of every recording.")
@click.option("--confidence", type=click.FloatRange(0, 1, min_open=True, max_open=True),
              default=None,
              help="Make the false-alarm rate a promise about THIS threshold: it holds with this "
                   "probability over the healthy data (e.g. 0.95; needs more healthy data, "
                   "about 3x). Default: the rate holds on average over calibrations.")
@click.option("--calibrate", "calibration", multiple=True,
              type=click.Path(exists=True, dir_okay=False),
              help="Recording with a known leak (metadata onset and leak_lpm, e.g. simulated), "
                   "repeatable, at least 3: detect then gives the leak size with an interval.")
@click.option("--out", "-o", required=True, type=click.Path(dir_okay=False),
              help="Detector file to write (joblib), e.g. det.joblib; written whole or not at "
                   "all, never over a --healthy/--calibrate input. It is a pickle: loading it "
                   "(detect, monitor, batch) runs code, so load only files you trust.")
@no_progress_option
def fit(healthy, method, system, column_map, cols, sample_rate, time_unit, resample,
        false_alarm_rate, burn_in_s, confidence, calibration, out, no_progress):
    """Fit a detector on healthy recordings and save it for detect (and monitor, batch).

    Every method's file is for detect and batch. monitor runs window by window with the
    single-feature detectors (acf-p1, acf-p2, ccf-p1p2, ccf-ux, mlr-p1); combined,
    wavelet-p1, wavelet-p1p2, fft-p1, emd-p1, ekf and flow-balance judge whole recordings:
    batch reads each file whole for them, and monitor judges a stream with them in
    consecutive segments (--segment). The file holds the fitted detector and a record of what
    it was fitted on (leakdiag version and a fingerprint of its code, method, system, sample
    rate, channels, units); detect, monitor and batch refuse recordings that disagree with it
    and warn when other code loads it. The file is a pickle, as every joblib file: load only
    files you trust. flow-balance sizes leaks from physics (no --calibrate).
    """
    from leakdiag.cli._options import column_map_from, read_healthy
    from leakdiag.cli._words import (MODEL_LEVEL_WORDS, check_longer_than_burn_in,
                                     few_healthy_words, in_cli_words, threshold_words)
    from leakdiag.batch.store import content_hash
    from leakdiag.stream.detector_file import DetectorMeta, common_machine, save_detector

    if calibration and method == "flow-balance":
        raise click.BadParameter("flow-balance sizes a leak from the flow balance itself, not "
                                 "from leaking examples: --calibrate does not apply",
                                 param_hint="--calibrate")
    check_out_path(out, [*(("--healthy", h) for h in healthy),
                         *(("--calibrate", c) for c in calibration)])
    cmap = column_map_from(column_map, cols, time_unit)
    from leakdiag.bench.registry import make_detector
    from leakdiag.detect.base import Alarm

    # read only what the method reads, on either rig (a CLI audit, 2026-11-29: a text note
    # column beside the signals was refused here and in detect, read by monitor and batch)
    wanted = channels_of_methods([method], system) or None
    recs = read_healthy(healthy, None, cmap, sample_rate, channels=(), resample=resample,
                        keep=wanted)
    system = system_of(recs, system, healthy)
    # the channels the method reads must be in every healthy file, with one unit; others may
    # differ (a file without p2 was refused for acf-p1, which reads only p1)

    needed = detector_channels(make_detector(method, system, Alarm()), recs[0])
    read_healthy(healthy, None, cmap, sample_rate, channels=needed, resample=resample,
                 recordings=recs, reads=method)
    say = (lambda msg: None) if no_progress else (lambda msg: click.echo(msg, err=True))
    say(f"fitting {method} ({system.upper()}) on {len(recs)} healthy recording(s)...")
    check_longer_than_burn_in(recs, healthy, burn_in_s)
    try:
        det = fit_detector(method, system, recs, false_alarms_per_hour=false_alarm_rate,
                           burn_in_s=burn_in_s, confidence=confidence)
    except ValueError as exc:
        raise ValueError(in_cli_words(str(exc))) from None
    if calibration:
        from leakdiag.cli._options import read_with

        cal = [read_with(p, cmap, sample_rate, resample, wanted)
               for p in calibration]
        if len(cal) < 3:
            raise click.BadParameter(f"got {len(cal)} file(s); a leak-size calibration needs at "
                                     "least 3 recordings with known leaks (0 allowed)",
                                     param_hint="--calibrate")
        for p, r in zip(calibration, cal):
            if r.onset is None or r.meta.get("leak_lpm") is None:
                raise click.BadParameter(f"{p}: its metadata does not give the leak onset and "
                                         "size (leak_lpm), so it cannot calibrate the leak size; "
                                         "use recordings with known leaks, e.g. from leakdiag "
                                         "simulate --leak Q --onset T", param_hint="--calibrate")
        say(f"calibrating the leak size on {len(cal)} recording(s)...")
        det.calibrate(cal, validity={"system": system, "files": [str(p) for p in calibration]})
    chans = detector_channels(det, recs[0])
    meta = DetectorMeta(method=method, system=system, sample_rate_hz=float(recs[0].sample_rate),
                        channels=chans, units={c: recs[0].units.get(c) for c in chans
                                               if recs[0].units.get(c)},
                        false_alarms_per_hour=float(false_alarm_rate), n_healthy=len(recs),
                        healthy_files=tuple(str(h) for h in healthy), load=common_load(recs),
                        machine=common_machine(r.meta for r in recs),
                        # ("missing": a file not read by path, e.g. a pipe; not recorded)
                        healthy_sha256=tuple(x for x in map(content_hash, healthy)
                                             if x != "missing"))
    save_detector(det, meta, out)
    basis = getattr(det, "threshold_basis_", None)
    click.echo(f"wrote {out}: {method} for the {system.upper()} at {meta.sample_rate_hz:g} Hz, "
               f"channels {','.join(chans)}, for {false_alarm_rate:g} false alarm(s) per hour; "
               f"threshold {threshold_words(basis) if basis else f'{float(det.threshold_):.4g}'}"
               + (f"; leak size calibrated on {len(calibration)} recording(s)" if calibration
                  else ""))
    few = few_healthy_words(len(recs)) if method == "flow-balance" else None
    if few is not None:
        click.echo(f"  {few}")
    if basis is not None and basis.method == "glr-model":
        if confidence is not None:  # the confidence asked for is not held: said, not dropped
            # silently (a CLI audit, 2026-11-29: the same level and words as without it)
            click.echo(f"  --confidence {confidence:g} is not held: the healthy maxima are too "
                       f"few for a level at {confidence * 100:g} % confidence (it needs "
                       f"{basis.min_n_for_target}), so the level is the model-based one above, "
                       "which carries no confidence over the healthy data; give more healthy "
                       "recordings for it")
        # what a model-based level did on virtual machines (docs/detect.md section 6)
        click.echo(f"  {MODEL_LEVEL_WORDS}")
    if basis is not None and basis.method.startswith("conformal") and \
            not getattr(det, "restarts_per_segment", False):
        click.echo(f"  the rate holds for a recording's first {basis.segment_s:g}-s segment; a "
                   "longer recording carries the statistic over into the next segments, which "
                   "the healthy maxima do not cover: not guaranteed there (docs/detect.md "
                   "section 2)")
    from leakdiag.io.recording import machine_unit

    units = sorted({str(u) for u in (machine_unit(r.meta) for r in recs) if u is not None})
    if len(units) > 1:  # a fleet fit: said, not left to a generic line (a CLI audit, 2026-11-29)
        click.echo(f"  the healthy recordings name {len(units)} machine units "
                   f"({', '.join(units)}): a fleet fit, so the recordings judged are not "
                   "checked against a unit, and machines differ more than a small leak changes "
                   "what a detector measures (a flow balance's size band is then no promise; "
                   "docs/detect.md 8.5); fit one detector per machine where you can")
