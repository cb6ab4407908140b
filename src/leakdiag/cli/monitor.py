"""``leakdiag monitor``: stream a recording, a growing file or stdin through the windowed features.

Each completed window becomes one JSON line (time, value, and with a fitted detector its score and
alarm); alarms are printed as they are raised and cleared.
"""

from __future__ import annotations

import os
import signal
import sys
import time

import click

from leakdiag._format import seconds
from leakdiag.features.spec import MethodSpec
from leakdiag.cli._features import check_setting_options, spec_from_options
from leakdiag.cli._monitor_method import MonitorMethod, resolve_method
from leakdiag.cli._options import recording_options
from leakdiag.cli.dashboard import live_options, open_monitor_hooks
from leakdiag.features.windowing import window_step
from leakdiag.cli._signals import StopSignals, Stopped, signal_name
from leakdiag.stream.blind import BlindSpans
from leakdiag.stream.episodes import AlarmEpisodes

__all__ = ["monitor", "build_source", "load_detector", "parse_replay", "unjudged_reason"]


def parse_replay(replay: str) -> float | None:
    """Replay speed from ``fast``, ``realtime`` or a factor such as ``10`` / ``10x``.

    Parameters
    ----------
    replay : str
        The option value.

    Returns
    -------
    float or None
        Speed factor (1.0 is real time); None for as fast as possible.

    Raises
    ------
    click.BadParameter
        For anything else.

    Examples
    --------
    >>> parse_replay("fast") is None, parse_replay("realtime"), parse_replay("20x")
    (True, 1.0, 20.0)
    """
    key = replay.strip().lower()
    if key == "fast":
        return None
    if key in ("realtime", "real-time", "1x"):
        return 1.0
    try:
        v = float(key.rstrip("x"))
    except ValueError:
        v = -1.0
    if not v > 0:
        raise click.BadParameter(f"--replay={replay!r}: use fast, realtime or a factor like 10x")
    return v


def load_detector(path: str):
    """Load a detector file written by ``leakdiag fit`` (or a bare pickled detector/scorer).

    Parameters
    ----------
    path : str
        Detector file; only load files you trust (joblib files are pickles and run code).

    Returns
    -------
    detector : object
        The fitted detector.
    meta : DetectorMeta or None
        Its metadata record (None for a bare pickle).

    Raises
    ------
    click.BadParameter
        If the file cannot be loaded.
    """
    from leakdiag.stream.detector_file import load_detector_file

    try:
        return load_detector_file(path)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--detector") from None


def check_streamable(detector, meta, path: str, hint: str = "--detector") -> None:
    """Refuse a detector that judges whole recordings (monitor and batch run window by window).

    Parameters
    ----------
    detector : object
        Loaded detector.
    meta : DetectorMeta or None
        Its metadata record.
    path : str
        Its file (for the message).
    hint : str, default "--detector"
        Where the file was given (option or job-file entry).

    Raises
    ------
    click.BadParameter
        Naming the file and what to use instead.
    """
    if callable(getattr(detector, "score_windows", None)) or \
            callable(getattr(detector, "spec", None)):
        return
    name = meta.method if meta else type(detector).__name__
    raise click.BadParameter(f"{path}: {name} judges whole recordings and cannot run window by "
                             f"window; use leakdiag detect FILE --detector {path}, or fit a "
                             "single-feature detector (acf-p1, ccf-p1p2, ccf-ux, mlr-p1)",
                             param_hint=hint)


def build_source(input_path: str, channels, follow: bool, sample_rate, chunk: int,
                 idle_timeout: float | None, batch_lines: int = 1, column_map=None):
    """The chunk source for ``--input``: stdin, a followed CSV, a chunked file or a recording.

    Parameters
    ----------
    input_path : str
        ``-`` for CSV lines on stdin, else a file.
    channels : sequence of str
        Channels needed.
    follow : bool
        Follow a growing CSV file.
    sample_rate : float or None
        Sample rate in Hz when the input has no time column.
    chunk : int
        Samples per chunk for files.
    idle_timeout : float or None
        Stop following after this many seconds without new data.
    batch_lines : int, default 1
        CSV lines per chunk for stdin and ``--follow`` (1: lowest latency).
    column_map : optional
        Column map (``--map``/``--col``): the file is then read whole with
        :func:`leakdiag.io.read_recording` and replayed.

    Returns
    -------
    ChunkSource

    Raises
    ------
    click.UsageError
        For a column map with stdin or ``--follow`` (those take CSV with channel names).
    """
    return _open_input(input_path, channels, follow, sample_rate, chunk, idle_timeout,
                       batch_lines, column_map)[0]


def _open_input(input_path: str, channels, follow: bool, sample_rate, chunk: int,
                idle_timeout: float | None, batch_lines: int = 1, column_map=None):
    """:func:`build_source` and the input's channel units: a file's as batch reads it
    (:func:`leakdiag.stream.files.open_recording`), None for stdin and ``--follow`` (CSV: SI
    assumed)."""
    from leakdiag.stream import csv_lines, tail_csv
    from leakdiag.stream.files import open_recording

    if column_map is not None and (input_path == "-" or follow):
        raise click.UsageError("--map/--col/--time-unit apply to files; stdin and --follow "
                               "take CSV with a header naming the channels (time, p1, ...)")
    if input_path == "-":
        return csv_lines(sys.stdin, channels, sample_rate, batch_lines), None
    if follow:
        return tail_csv(input_path, channels, sample_rate, idle_timeout_s=idle_timeout,
                        batch_lines=batch_lines), None
    return open_recording(input_path, channels, chunk, sample_rate, column_map)


def refuse_own_healthy_file(meta, input_path: str, follow: bool, detector_path) -> None:
    """Refuse a recording file that is one of the detector file's own healthy files (the same
    bytes: :func:`leakdiag.stream.detector_file.own_healthy_reason`), as ``detect`` and
    ``batch`` refuse it; stdin and ``--follow`` (a growing file) are not checked.

    Raises
    ------
    ValueError
        Naming both files (the command prints it as an error, exit code 2).
    """
    if meta is None or not getattr(meta, "healthy_sha256", ()) or input_path == "-" or follow:
        return
    from leakdiag.batch.store import content_hash
    from leakdiag.stream.detector_file import own_healthy_reason

    why = own_healthy_reason(meta, content_hash(input_path), input_path, str(detector_path))
    if why is not None:  # an error of the input, as detect says it (not a usage error)
        raise ValueError(why)


def refuse_own_healthy_samples(detector, source, input_path: str, follow: bool, cmap,
                               sample_rate, detector_path) -> None:
    """Refuse a recording file that holds the same samples as one of the detector's healthy
    recordings, as ``detect`` refuses it (a copy saved with CRLF line ends or as Parquet was
    judged NO LEAK by monitor: a user-data audit, 2026-11-29); read whole only when its length
    and rate are a healthy recording's
    (:func:`leakdiag.stream.detector_file.own_healthy_samples_reason`). Stdin and
    ``--follow`` are not checked.

    Raises
    ------
    ValueError
        Naming both files (the command prints it as an error, exit code 2).
    """
    if detector is None or input_path == "-" or follow:
        return
    from leakdiag.io import read_recording
    from leakdiag.stream.detector_file import own_healthy_samples_reason

    why = own_healthy_samples_reason(
        detector, str(source.source), source.n_samples, source.sample_rate,
        lambda chans: read_recording(input_path, cmap, sample_rate=sample_rate, channels=chans),
        str(detector_path))
    if why is not None:
        raise ValueError(why)


def _spec(method, channels, lag, lag_ratio, window, overlap, detector, given=()):
    """The monitored feature; ``given`` lists the feature options given on the command line,
    refused where they would be ignored (a detector's own feature, the other lag kind).
    ``method`` is a canonical name or None for the detector's own
    (:func:`~leakdiag.cli._monitor_method.resolve_method`); the detector's own name is
    harmless, like its other settings; another one is refused by the scorer
    (:func:`leakdiag.stream.detector.as_scorer`: "differs from the monitored")."""
    own = detector.spec() if detector is not None and \
        callable(getattr(detector, "spec", None)) else None
    if own is not None and method in (None, own.method):
        spec = own
        try:  # the same values as the detector's are harmless
            mine = MethodSpec(spec.method, tuple(c.strip() for c in channels.split(","))
                              if channels else spec.channels, lag=lag or spec.lag,
                              lag_ratio=lag_ratio or spec.lag_ratio, window=window,
                              overlap=overlap)
            given = [g for g in given if getattr(mine, g[2:].replace("-", "_")) !=
                     getattr(spec, g[2:].replace("-", "_"))]
        except ValueError:  # e.g. a lag ratio for a correlation detector: refused below
            pass
        if given:
            raise click.UsageError(
                f"{', '.join(given)}: the detector file fixes its feature ({spec.label}); leave "
                f"{'it' if len(given) == 1 else 'them'} out, or fit a detector with the feature "
                "you want (leakdiag fit)")
        return spec
    method = method or "autocorrelation"
    check_setting_options([method], lag if "--lag" in given else None,
                          lag_ratio if "--lag-ratio" in given else None)
    return spec_from_options(method, channels, lag, lag_ratio, window, overlap)


def unjudged_reason(has_detector: bool, n_win: int, n_scored: int, blind, source: str,
                    label: str, window: int, n_alarm: int = 0) -> str | None:
    """Why a monitor run with a detector judged nothing, or None (it judged, or has none).

    Parameters
    ----------
    has_detector : bool
        Whether the monitor had a detector (without one nothing is judged by design: the
        store marks that run itself, ``NO DETECTOR``).
    n_win, n_scored : int
        Windows completed, and of them windows with a finite detector score (after the
        detector's burn-in).
    blind : BlindSpans or None
        The blind-span tracker (None: the detector predates it).
    source, label : str
        The input and the feature, for the message.
    window : int
        Window length (samples).
    n_alarm : int, default 0
        Alarms raised: an alarm on the windows that were looked at judged the run, whatever
        the blind spans (as ``detect`` reads LEAK then).

    Returns
    -------
    str or None
        The reason stored with the run (status ``unjudged``).

    Examples
    --------
    >>> unjudged_reason(True, 21, 0, None, "short.parquet", "acf p1", 200)[:52]
    'short.parquet: no window was scored: all 21 windows '
    >>> unjudged_reason(True, 300, 280, None, "ok.parquet", "acf p1", 200) is None
    True
    """
    if not has_detector:
        return None
    if n_win == 0:
        return (f"{source}: shorter than one window (window={window}) of {label}: no window "
                "was scored, nothing was judged")
    if n_scored == 0:
        return (f"{source}: no window was scored: all {n_win} windows lie in the detector's "
                "burn-in (the stream is shorter than the burn-in plus one window), nothing "
                "was judged")
    if blind is not None and blind.blind and not n_alarm:
        return f"BLIND: {blind.words(source, label)}"
    return None


def _hook_names(live: dict) -> str:
    """What the hooks of a run are, for the summary: "store", "page" or "page and store"."""
    names = [n for n, key in (("page", "dashboard_bind"), ("store", "store"))
             if live.get(key) is not None]
    return " and ".join(names)


def _close_hooks(hooks, exc, n_win: int, linger_s: float, say, stop: "StopSignals",
                 unjudged: str | None = None) -> None:
    """End the run of the hooks after the loop, which ``exc`` ended (None: the end of the
    input). A signal meanwhile (in the hand-over of the last chunks, the store's end of the run,
    ``--linger``) shortens that end and changes nothing else. ``unjudged``: why the run judged
    nothing (:func:`unjudged_reason`); not for a run stopped before its first window."""
    stop.busy = False
    try:
        if isinstance(exc, KeyboardInterrupt):  # the user stopped it: not a failure
            hooks.close(True, 0.0, say, f"stopped by {signal_name(exc)} after {n_win} windows",
                        stopped=True, unjudged=unjudged if n_win else None)
        else:
            # bad input (a RecordingError) in its own words, a class name only for a bug, as
            # batch stores its rows (a workflow audit, 2026-11-30: "RecordingError: ...")
            from leakdiag.io.errors import RecordingError

            why = (None if exc is None else str(exc) if isinstance(exc, RecordingError)
                   else f"{type(exc).__name__}: {exc}")
            hooks.close(exc is None, linger_s, say, why, unjudged=unjudged)
    except KeyboardInterrupt:
        pass
    finally:
        stop.busy = True


def _stored_source(source) -> str:
    """A segment's input as the store records it: a file's real path, stdin as it is.

    >>> _stored_source("-"), _stored_source("<stdin>")
    ('-', '<stdin>')
    """
    import os

    s = str(source)
    return s if s in ("-", "<stdin>") else os.path.realpath(s)


def _open_events(events: str | None, append: bool):
    """The ``--events`` stream: stdout for ``-``, the file appended to with
    ``--append-events``, else replaced, with a note when it held lines (a workflow audit,
    2026-11-30: a monitor restarted by a service wiped the killed run's alarm lines without a
    word)."""
    if events is None:
        return None
    if events == "-":
        return sys.stdout
    size = os.path.getsize(events) if os.path.isfile(events) else 0
    if not append and size:  # its size, not its lines: a long run's file is not read
        click.echo(f"leakdiag: note: {events} held {size} bytes of events: replaced "
                   "(--append-events keeps them)", err=True)
    return open(events, "a" if append else "w", encoding="utf-8")


def _store_segment(st, actuator: str, source: str, method: str, sv, system,
                   session: dict | None = None) -> None:
    """One judged segment into the store, as ``detect --store`` stores a file's verdict, with
    its session (:func:`_segment_session`)."""
    import pandas as pd

    from leakdiag.store.writers import record_verdicts

    # an alarm that is no evidence (refused, or expected by chance): stored inconclusive
    row = {"method": method, "leak": None, "error": sv.reason, "alarm_refused": sv.inconclusive}
    if sv.verdict is not None:
        d = sv.verdict.as_dict()
        # with what the size's interval holds, as detect stores it (a workflow audit,
        # 2026-11-30: the flow balance's interval was stored as a "prediction interval")
        row.update({k: d.get(k) for k in ("leak", "alarm_time_s", "score_max", "threshold",
                                            "onset_s", "leak_lpm", "leak_lpm_low",
                                            "leak_lpm_high", "onset_censored",
                                            "leak_lpm_in_range", "leak_lpm_interval_holds")},
                   error=None)
        if sv.continues_from_onset_s is not None:  # the leak found earlier continues: its
            # onset, as the console says, not this segment's first windows (an audit,
            # 2026-11-29: the fleet page showed "at or before 45.2 s" for a leak from 25.8 s)
            row.update(onset_s=sv.continues_from_onset_s,
                       onset_censored=sv.continues_onset_censored)
    tab = pd.DataFrame([row])
    tab.attrs["system"] = system
    span = f"{seconds(sv.start_s, 6)}-{seconds(sv.end_s, 6)} s"
    record_verdicts(st, actuator, f"{source} [{span}]", tab,
                    command="monitor", config=None if session is None else {"session": session})


def _segment_session(seg: float, live: bool, speed: float | None) -> dict:
    """The session a ``monitor --segment`` run stores with each segment: an id, the wall
    seconds between segments it expects (``interval_s``: a segment's length for a live input,
    divided by the replay speed for a paced file, 0 for a file read as fast as possible) and
    ``ended`` false until the session ends in any way but ``kill -9``
    (:meth:`~leakdiag.store.database.EventStore.end_session`): the fleet page says a session
    that has not ended and sent no segment for 3 intervals (at least a minute) is silent. A
    session killed with ``kill -9`` read as a finished ``monitor`` (an audit, 2026-11-29).

    >>> s = _segment_session(60.0, False, 10.0)
    >>> s["interval_s"], s["ended"], len(s["id"])
    (6.0, False, 32)
    >>> [_segment_session(60.0, live, None)["interval_s"] for live in (True, False)]
    [60.0, 0.0]
    """
    import uuid

    interval = seg if live else (0.0 if speed is None else seg / float(speed))
    return {"id": uuid.uuid4().hex, "interval_s": float(interval), "ended": False}


def _store_session_end(st, actuator: str, source, name: str, system, done, judge, stopped,
                       failed, session: dict) -> None:
    """A stopped or failed ``monitor --segment`` session as one more run of the actuator.

    Its judged segments are finished runs, so the fleet page read "OK, monitor finished" after
    a SIGTERM or an input error (a store audit, 2026-11-29; the streamed monitor's run says
    "stopped" or "failed"). A failure is stored ``failed`` (FAILED), a stop ``unjudged`` (NOT
    JUDGED: the input after the last judged segment was not judged), each with why. A session
    killed with ``kill -9`` stores nothing more: its last judged segment stands."""
    from leakdiag.store.summary import FinishedRun

    since = done[-1].end_s if done else judge.start_time
    if failed is not None:
        status, why = "failed", (f"monitor --segment failed: {failed}; the segments before "
                                 "the error were judged")
    else:
        status, why = "unjudged", (f"monitor --segment stopped by {stopped.name}; the input "
                                   f"from {seconds(since, 6)} s on was not judged")
    st.add_finished_runs(actuator, [FinishedRun(
        "monitor", f"{_stored_source(source.source)} [from {seconds(since, 6)} s]", name,
        status, why,
        system=system, config={"method": name, "session": session})])


def _monitor_segments(detector, meta, detector_path, input_path, follow, replay, sample_rate,
                      chunk, idle_timeout, batch_lines, cmap, events, quiet, segment_s,
                      store=None, actuator=None, append_events=False):
    """``monitor`` with a whole-recording detector: the stream judged in consecutive segments
    (:class:`leakdiag.stream.segments.SegmentJudge`), a line and a JSON event per segment and,
    with ``store``, each segment stored as a finished run with its verdict as ``detect``
    stores one (one transaction per segment: a crash loses at most the segment being read)."""
    from leakdiag.cli.fit import detector_channels
    from leakdiag.stream import paced
    from leakdiag.io.recording import machine_unit
    from leakdiag.stream.detector_file import (ADVICE_MAP, check_detector_fits,
                                                unchecked_note)
    from leakdiag.stream.segments import DEFAULT_SEGMENT_S, SegmentJudge

    chans = list(detector_channels(detector))
    name = meta.method if meta is not None else type(detector).__name__
    if not chans:
        raise click.UsageError(f"{detector_path}: {name} does not say which channels it reads; "
                               "judge files with leakdiag detect or batch")
    refuse_own_healthy_file(meta, input_path, follow, detector_path)  # as streamed detectors
    source, units = _open_input(input_path, chans, follow, sample_rate, chunk, idle_timeout,
                                batch_lines, cmap)
    refuse_own_healthy_samples(detector, source, input_path, follow, cmap, sample_rate,
                               detector_path)
    check_detector_fits(meta, sample_rate=source.sample_rate, channels=source.channels,
                        units=units, system=source.meta.get("system"), source=source.source,
                        path=str(detector_path), load=source.meta.get("load"),
                        machine=machine_unit(source.meta))
    if meta is not None:
        from leakdiag.stream.detector_file import fitted_machine

        note = unchecked_note(str(source.source), source.meta, [
            (str(detector_path), meta.system, getattr(meta, "load", None),
             fitted_machine(detector, meta))], ADVICE_MAP)
        if note is not None:
            click.echo(f"leakdiag: warning: {note}", err=True)
    st = None
    if store is not None:
        from leakdiag.cli.dashboard import monitor_actuator
        from leakdiag.store import EventStore

        actuator = monitor_actuator(store, str(source.source), actuator)
        st = EventStore(store)
        click.get_current_context().call_on_close(st.close)
    seg = DEFAULT_SEGMENT_S if segment_s is None else float(segment_s)
    # a segment in which the detector expects a false alarm by chance: its LEAK is no evidence
    # (detect reads such an alarm INCONCLUSIVE; an audit, 2026-11-28, found monitor reading LEAK
    # where detect said INCONCLUSIVE) unless it is judged at a raised level (judge_run), as detect
    # judges a file
    from leakdiag.detect.decision import (detector_rate, expected_false_alarms, raised_level,
                                          run_level_confidence, run_level_how,
                                          run_level_method, run_segments, unheld_long_run,
                                          unheld_words)

    basis = getattr(detector, "threshold_basis_", None)
    per_hour, burn = detector_rate(detector)
    shortest = getattr(detector, "shortest_run_s", None)
    if callable(shortest) and seg <= shortest():  # every segment would be NOT JUDGED (a CLI
        # audit, 2026-11-29: 50 lines of "too short to judge", then exit 2)
        raise click.UsageError(
            f"--segment {seg:g}: {detector_path} cannot judge a segment this short: its "
            f"{burn:g}-s burn-in and the windows its test needs take about {shortest():.3g} s; "
            f"give a --segment longer than that")
    span = max(seg - burn, 0.0)
    n_full = int(round(seg * source.sample_rate))
    # the segments as the detector counts them, as judge_run does (a statistics audit,
    # 2026-11-28, finding 3: counted by time here, 2 where the detector counts 1)
    n_seg = run_segments(detector, n_full, source.sample_rate)[1]
    expected = expected_false_alarms(basis, per_hour, span, n_seg)
    # a segment longer than the detector's healthy one is judged at its run level (judge_run)
    raised = raised_level(detector, n_full, source.sample_rate)
    if expected >= 1.0 and raised is None:
        raise click.UsageError(
            f"--segment {seg:g}: {detector_path} expects about {expected:.3g} false alarms in a "
            f"healthy segment this long, and its healthy reference cannot hold a segment this "
            f"long to a healthy segment's rate, so its LEAK would be no evidence: give a shorter "
            f"--segment, or fit the detector for fewer false alarms per hour")
    unheld = unheld_long_run(detector, n_full, source.sample_rate)
    if unheld is not None:  # every alarm of a full segment would be read inconclusive
        raise click.UsageError(f"--segment {seg:g}: {detector_path}: "
                               f"{unheld_words(*unheld, basis)}")
    method = None if raised is None else run_level_method(detector, span, n_seg)
    judge = SegmentJudge(detector, chans, source.sample_rate, source.start_time, seg,
                         units=units, meta=source.meta, source=str(source.source))
    speed = None if input_path == "-" or follow else parse_replay(replay)
    out = _open_events(events, append_events)
    say = (lambda msg: None) if quiet else (lambda msg: click.echo(msg, err=out is sys.stdout))
    done: list = []

    system = source.meta.get("system") or getattr(meta, "system", None)
    session = _segment_session(seg, input_path == "-" or follow, speed)

    def emit(verdicts, last=False):
        for sv in verdicts:
            # the stream's last, shorter segment that could not be judged (too short: the
            # input ended) after judged ones is not stored: as the newest run it set the
            # fleet page's state to NOT JUDGED over the stream's INCONCLUSIVE, NO LEAK or
            # LEAK (an audit, 2026-11-29); it is printed and in the events as before
            # (another reason, a stuck channel in the tail, is stored)
            tail = last and sv.too_short and any(d.decision != "NOT JUDGED" for d in done)
            done.append(sv)
            say(sv.words())
            if out is not None:
                out.write(sv.to_json() + "\n")
                out.flush()
            if st is not None and not tail:
                # the file's real path, as the streaming monitor and detect store it (a store
                # audit, 2026-11-29: the path as typed, relative, escaped the check that keeps
                # one stem of two folders apart, default_actuator)
                _store_segment(st, actuator, _stored_source(source.source), name, sv, system,
                               session)

    stopped = failed = None
    t0 = time.perf_counter()
    with StopSignals() as stop:
        try:
            try:
                try:
                    for chunk_ in paced(source, speed):
                        stop.busy = True
                        emit(judge.push(chunk_))
                        stop.check()
                except ValueError as exc:  # bad input (a NaN, a gap): judge what came before
                    failed = exc
                stop.busy = True
                last = judge.finish()
                emit([] if last is None else [last], last=True)
            finally:
                if out is not None and out is not sys.stdout:
                    out.close()
        except KeyboardInterrupt as exc:
            stopped = exc if isinstance(exc, Stopped) else Stopped(signal.SIGINT)
    dt = time.perf_counter() - t0
    count = {d: sum(sv.decision == d for sv in done)
             for d in ("LEAK", "NO LEAK", "INCONCLUSIVE", "NOT JUDGED")}
    end = ("" if stopped is None else f"; stopped by {stopped.name}") + (
        "" if failed is None else "; the input stopped with an error (below): the samples "
        "before it were judged")
    say(f"{source.source}: {judge.n_samples_seen} samples at {source.sample_rate:g} Hz, "
        f"{len(done)} segment(s) of up to {seg:g} s judged by {name}: {count['LEAK']} LEAK, "
        f"{count['NO LEAK']} NO LEAK, {count['INCONCLUSIVE']} INCONCLUSIVE, "
        f"{count['NOT JUDGED']} not judged, in {dt:.3g} s{end}")
    if basis is not None:
        from leakdiag.cli._words import threshold_words

        say(f"  threshold: {threshold_words(basis)} (per segment: each is judged as one run)")
    full = any(sv.end_s - sv.start_s >= seg - 0.5 / source.sample_rate for sv in done)
    if raised is not None and full:  # the full segments were judged at the run level
        # (judge_run); without a full segment no line: an audit (2026-11-29) found a 200-s
        # input under --segment 300 described at a level no segment was judged at
        level, at_level = raised
        how = run_level_how(at_level, float(basis.target_per_segment), method,
                            run_level_confidence(basis, method),
                            bool(getattr(detector, "restarts_per_segment", False)), "segment")
        say(f"  run level: a {seg:g}-s segment expects about {expected:.3g} false alarms at the "
            f"fitted level {float(detector.threshold_):.4g}, so full segments are judged at the "
            f"level {level:.4g}, {how} (docs/detect.md section 6, 'Long runs')")
    if st is not None:
        if stopped is not None or failed is not None:
            _store_session_end(st, actuator, source, name, system, done, judge, stopped,
                               failed, session)
        st.end_session(actuator, session["id"])  # only kill -9 leaves it running
    if stopped is not None:
        click.get_current_context().exit(128 + stopped.signum)
    if failed is not None:
        msg = str(failed)
        raise ValueError(msg if msg.startswith(str(source.source)) else
                         f"{source.source}: {msg}") from None
    if done and count["NOT JUDGED"] == len(done):
        raise ValueError(f"{source.source}: no segment could be judged by {name}; first "
                         f"reason: {done[0].reason}")


@click.command(epilog="Example: leakdiag monitor run.parquet --detector det.joblib "
                      "--events events.jsonl")
@click.argument("file", required=False, metavar="[FILE]")
@click.option("--input", "-i", "input_path", default=None,
              help="Recording file (Parquet, HDF5, CSV, ...) or '-' for CSV lines on stdin "
                   "(or give it as FILE, like analyze and detect).")
@click.option("--replay", default="fast", show_default=True,
              help="Replay speed of a file: fast, realtime, or a factor like 10x (paced "
                   "replays are handed on in pieces of at most 0.1 s of wall-clock time).")
@click.option("--follow", is_flag=True, help="Follow a growing CSV file (like tail -f).")
@click.option("--idle-timeout", type=click.FloatRange(min=0), default=None,
              help="With --follow: stop after this many seconds without new lines.")
@click.option("--method", "-m", type=MonitorMethod(), default=None,
              help="Feature (default: the detector's, else autocorrelation), or a method name "
                   "of leakdiag fit -m, e.g. ccf-p1p2: the cross-correlation of p1,p2.")
@click.option("--channels", "-c", default=None, help="Channels, e.g. p1 | p1,p2 | u,x.")
@click.option("--lag", type=click.IntRange(min=1), default=None,
              help="Lag in samples (correlations; default 1).")
@click.option("--lag-ratio", default=None, help="Metric-length lag ratio l:k (default 83:3).")
@click.option("--window", "-w", type=click.IntRange(min=2), default=200, show_default=True,
              help="Window N (samples).")
@click.option("--overlap", type=click.FloatRange(0, 100, max_open=True), default=5.0,
              show_default=True, help="Overlap (%).")
@click.option("--detector", "detector_path", type=click.Path(exists=True, dir_okay=False),
              help="Detector file from leakdiag fit: its feature settings are used (a "
                   "different --method, --channels, --lag, --window or --overlap is refused); "
                   "its threshold holds its false-alarm rate per hour of monitoring (the CUSUM "
                   "restarts at every healthy segment unless in alarm). A whole-recording "
                   "detector (the flow balance) judges consecutive --segment segments instead. "
                   "It is a pickle: loading it runs code, so load only files you trust.")
@recording_options
@click.option("--chunk", type=click.IntRange(min=1), default=65536, show_default=True,
              help="Samples per file chunk.")
@click.option("--batch-lines", type=click.IntRange(min=1), default=1, show_default=True,
              help="CSV lines per chunk for stdin/--follow (more: faster, later events).")
@click.option("--events", type=click.Path(dir_okay=False), default=None,
              help="Write one JSON line per window to this file ('-' for stdout); an "
                   "existing file is replaced, with a note (see --append-events).")
@click.option("--append-events", is_flag=True,
              help="Append to an existing --events file instead of replacing it (a monitor "
                   "restarted by a service keeps the earlier run's events).")
@click.option("--quiet", "-q", is_flag=True, help="Do not print alarms and the summary.")
@click.option("--segment", "segment_s", type=click.FloatRange(min=0, min_open=True),
              default=None,
              help="With a whole-recording detector (the flow balance): judge the stream in "
                   "consecutive segments of this many seconds, each as detect judges a file "
                   "(default 60).")
@live_options
def monitor(file, input_path, replay, follow, idle_timeout, method, channels, lag, lag_ratio,
            window, overlap, detector_path, column_map, cols, sample_rate, time_unit, chunk,
            batch_lines, events, append_events, quiet, segment_s, **live):
    """Monitor a stream: feature value per window, detector score and alarm, as soon as known.

    FILE (or --input FILE) is a recording file, or '-' for CSV lines on stdin. Without
    --detector only the feature is computed: no alarm is possible. Ctrl-C or SIGTERM stops it
    cleanly (the run stored as stopped, the summary printed; exit code 130 or 143). A run
    with --detector whose windows all lay in the detector's burn-in judged nothing: after the
    summary it is refused (exit code 2, as detect refuses a file too short to judge), with
    the reason stored with the run.
    """
    if file is not None and input_path is not None:
        raise click.UsageError(f"give the recording once: FILE ({file}) or --input "
                               f"({input_path}), not both")
    input_path = input_path if input_path is not None else file
    if input_path is None:
        raise click.UsageError("give the recording: leakdiag monitor FILE (or --input FILE; "
                               "'-' reads CSV lines from stdin)")
    import numpy as np

    from leakdiag.cli._options import (RATE_FROM_TIME, column_map_from, rate_basis,
                                       warn_low_rate)
    from leakdiag.io.checks import RESAMPLE_ADVICE
    from leakdiag.runtime.collector import frozen_collector
    from leakdiag.stream import Monitor, paced
    from leakdiag.io.recording import machine_unit
    from leakdiag.stream.detector_file import check_detector_fits

    if live.get("store") is not None:  # '', an in-memory database, 'sqlite:/x': refused first
        from leakdiag.store import StoreError, store_url
        from leakdiag.store.writers import check_stdin_named

        store_url(live["store"])
        try:  # before the detector's own warnings (an audit, 2026-11-30)
            check_stdin_named(input_path, live.get("actuator"))
        except StoreError as exc:
            raise click.UsageError(str(exc)) from None
    detector, meta = load_detector(detector_path) if detector_path else (None, None)
    ctx = click.get_current_context()
    given = [f"--{n.replace('_', '-')}" for n in ("channels", "lag", "lag_ratio", "window",
                                                  "overlap")
             if ctx.get_parameter_source(n) is click.core.ParameterSource.COMMANDLINE]
    from leakdiag.stream.segments import judges_whole

    method, channels = resolve_method(method, channels, detector, meta, detector_path)
    if detector is not None and judges_whole(detector):
        if method is not None or given:
            raise click.UsageError(f"{', '.join((['--method'] if method else []) + given)}: "
                                   f"{detector_path} judges whole recordings on its own "
                                   "channels; leave the feature options out")
        if live.get("dashboard_bind") is not None:
            raise click.UsageError(
                f"--dashboard: not available with a whole-recording detector ({detector_path}), "
                "which judges segments, not windows: give --store, and leakdiag dashboard "
                "--store shows each segment's verdict on the fleet page")
        return _monitor_segments(detector, meta, detector_path, input_path, follow, replay,
                                 sample_rate, chunk, idle_timeout, batch_lines,
                                 column_map_from(column_map, cols, time_unit), events, quiet,
                                 segment_s, live.get("store"), live.get("actuator"),
                                 append_events=append_events)
    if segment_s is not None:
        if detector is None:  # (said "a streamed detector judges every window": none given)
            raise click.UsageError("--segment needs --detector FILE with a whole-recording "
                                   "detector (the flow balance: leakdiag fit --method "
                                   "flow-balance), which judges each segment as detect judges "
                                   "a file")
        raise click.UsageError("--segment applies to a whole-recording detector (the flow "
                               "balance); a streamed detector judges every window")
    if detector is not None:
        check_streamable(detector, meta, detector_path)
    if idle_timeout is not None and not follow:
        raise click.UsageError("--idle-timeout applies to --follow only")
    if ctx.get_parameter_source("replay") is click.core.ParameterSource.COMMANDLINE and \
            (input_path == "-" or follow):
        raise click.UsageError("--replay paces a file; stdin and --follow run as the data "
                               "arrives")
    if ctx.get_parameter_source("batch_lines") is click.core.ParameterSource.COMMANDLINE and \
            input_path != "-" and not follow:
        raise click.UsageError("--batch-lines applies to stdin (--input -) and --follow only; "
                               "a file is read in --chunk samples")
    spec = _spec(method, channels, lag, lag_ratio, window, overlap, detector, given)
    cmap = column_map_from(column_map, cols, time_unit)
    # one of the detector's own healthy files: judged against a threshold it set itself (a
    # review, 2026-11-29: detect and batch refused it, monitor judged it)
    refuse_own_healthy_file(meta, input_path, follow, detector_path)
    try:
        source, units = _open_input(input_path, list(spec.channels), follow, sample_rate,
                                    chunk, idle_timeout, batch_lines, cmap)
    except ValueError as exc:  # advise only what monitor has: it streams, it cannot resample
        raise ValueError(str(exc).replace(
            RESAMPLE_ADVICE,
            "monitor needs a uniform time axis: resample the file first and monitor the copy "
            "(in Python: leakdiag.io.write_recording(leakdiag.io.read_recording(FILE, "
            "resample=RATE_HZ), OUT); no leakdiag command writes a resampled file, and analyze "
            "and detect --resample read it resampled)")) from None
    if sample_rate is None:  # stdin and --follow: their time column (no header, no map)
        basis = (rate_basis(input_path, cmap, source.sample_rate)
                 if input_path != "-" and not follow else RATE_FROM_TIME)
        warn_low_rate(source.source, source.sample_rate,
                      "give --time-unit ms (files; stdin and --follow need the time in s)",
                      basis=basis)
    refuse_own_healthy_samples(detector, source, input_path, follow, cmap, sample_rate,
                               detector_path)
    check_detector_fits(meta, sample_rate=source.sample_rate, channels=source.channels,
                        units=units, system=source.meta.get("system"), source=source.source,
                        path=str(detector_path), load=source.meta.get("load"),
                        machine=machine_unit(source.meta))
    if meta is not None:  # what the input's metadata leave unchecked, as detect and batch say it
        from leakdiag.stream.detector_file import ADVICE_MAP, unchecked_note

        note = unchecked_note(str(source.source), source.meta, [
            (str(detector_path), meta.system, getattr(meta, "load", None),
             getattr(meta, "machine", None))], ADVICE_MAP)
        if note is not None:
            click.echo(f"leakdiag: warning: {note}", err=True)
    mon = Monitor(spec, source.sample_rate, source.start_time, scorers=detector)
    speed = None if input_path == "-" or follow else parse_replay(replay)
    out = _open_events(events, append_events)
    say = (lambda msg: None) if quiet else (lambda msg: click.echo(msg, err=out is sys.stdout))
    n_win = n_alarm = n_scored = 0  # windows; alarm raisings (OK -> ALARM); scored windows
    alarm_on = False
    scorer = mon.scorers[0]
    episodes = AlarmEpisodes(getattr(scorer, "threshold_", None))  # as the store counts them
    healthy_span = getattr(detector, "nan_span_healthy_s_", None)  # None: fitted before it
    # every judged window counted (every_window): NO LEAK is refused as Detector.predict
    # refuses it, over a long undefined span or more than half of the windows undefined
    blind = (BlindSpans(healthy_span, window_step(spec.window, spec.overlap)
                        / source.sample_rate, every_window=True,
                        healthy_fraction=getattr(detector, "nan_fraction_healthy_", 0.0),
                        # its summary names spans from their first sample, as detect does (an
                        # audit, 2026-11-29: "from 1.339" where detect said "from 1.14")
                        window_span_s=(spec.window - 1) / source.sample_rate)
             if healthy_span is not None else None)
    live = {**live, "system": source.meta.get("system") or getattr(meta, "system", None)}
    hooks = stopped = t_loop = None  # stopped: the Stopped of a SIGINT or SIGTERM
    t0 = time.perf_counter()
    # SIGINT and SIGTERM stop the monitor cleanly, between chunks, with or without hooks
    with StopSignals() as stop:
        try:
            hooks = open_monitor_hooks(live, spec, mon, source, say)  # --store / --dashboard
            t0 = time.perf_counter()
            # what is loaded by now stays out of the collector's way (runtime.collector)
            with frozen_collector():
                try:
                    for chunk_ in paced(source, speed):
                        stop.busy = True  # a signal now waits until the chunk is handled
                        try:
                            evs = mon.push(chunk_)
                        except ValueError as exc:  # e.g. a NaN sample: name the input
                            msg = str(exc)
                            raise ValueError(msg if msg.startswith(source.source) else
                                             f"{source.source}: {msg}") from None
                        if hooks:
                            hooks.push(evs)
                        if out is not None and evs:
                            out.write("".join(e.to_json() + "\n" for e in evs))
                            out.flush()
                        n_win += len(evs)
                        raised = []
                        for i, e in enumerate(evs):
                            if e.alarm and not alarm_on:
                                n_alarm += 1
                                raised.append(i)
                                say(f"ALARM   t={seconds(e.time, 6)} s  {spec.label}  "
                                    f"value={e.value:.6g}  score={e.score:.6g}")
                            elif alarm_on and e.alarm is False:
                                say(f"cleared t={seconds(e.time, 6)} s  score={e.score:.6g}")
                            if e.alarm is not None:
                                alarm_on = e.alarm
                                # scored windows only (no burn-in); a defined window costs a
                                # count unless it ends an undefined span (BlindSpans.add's
                                # no-op for it)
                                if blind is None or e.score != e.score:
                                    pass
                                elif e.value == e.value and not blind.windows:
                                    blind.judged += 1
                                elif blind.add(e.time, e.value):
                                    say(f"BLIND   t={seconds(e.time, 6)} s  {spec.label}: "
                                        f"undefined for {blind.windows * blind.step_s:.3g} s, "
                                        "more than the "
                                        f"{blind.limit_s:.3g} s allowed (a stuck sensor?); no "
                                        "alarm is possible until it is defined again")
                        if not n_scored and evs and detector is not None:  # burn-in over?
                            sc = mon.last_arrays[0][2]
                            n_scored = 0 if sc is None else int(np.isfinite(sc).sum())
                        if raised or episodes.open and evs:  # (an excursion not ended yet)
                            episodes.add(raised, mon.last_arrays[0][2],
                                         getattr(scorer, "branches_", None))
                        stop.check()  # a signal that came meanwhile stops the monitor here
                finally:
                    stop.busy = True  # the input ended, or the loop stopped: this ends it
                    t_loop = time.perf_counter()
                    if out is not None and out is not sys.stdout:
                        out.close()
                    if hooks:
                        _close_hooks(hooks, sys.exc_info()[1], n_win, live["linger"], say, stop,
                                     unjudged_reason(detector is not None, n_win, n_scored,
                                                     blind, str(source.source), spec.label,
                                                     spec.window, n_alarm))
        except KeyboardInterrupt as exc:  # Ctrl-C or kill PID: how a --follow run ends
            stopped = exc if isinstance(exc, Stopped) else Stopped(signal.SIGINT)
        finally:
            if out is not None and out is not sys.stdout:
                out.close()  # (also when the hooks did not start)
    # the loop's time (the monitor's throughput); the hooks' close after it (the sidecar takes
    # the last chunks, the store ends the run, the page stops) is told apart
    t_end = time.perf_counter()
    dt = (t_end if t_loop is None else t_loop) - t0
    closing = "" if hooks is None or t_loop is None else \
        f" (then {t_end - t_loop:.2g} s to close the {_hook_names(live)})"
    n = mon.n_samples_seen
    alarms = (f"{n_alarm} alarm raising(s) in {episodes.n} episode(s)" if detector is not None
              else "no alarm possible (features only: give --detector FILE from leakdiag fit)")
    end = "" if stopped is None else f"; stopped by {stopped.name}"
    say(f"{source.source}: {n} samples at {source.sample_rate:g} Hz, {n_win} windows "
        f"({spec.label}), {alarms}, {mon.features[0].n_degenerate} degenerate, in {dt:.3g} s"
        f"{closing}{end}")
    if blind is not None and blind.blind and n_alarm == 0:
        click.echo(f"leakdiag: warning: {blind.words(source.source, spec.label)}", err=True)
    basis = getattr(detector, "threshold_basis_", None)
    if basis is not None:  # the basis of "alarm" / "no alarm", as detect prints it
        from leakdiag.cli._words import threshold_words

        say(f"  threshold: {threshold_words(basis)}")
    if stopped is not None:  # 128 + the signal's number, as a shell reports a signal's end
        ctx.exit(128 + stopped.signum)
    n_bad = mon.features[0].n_degenerate
    if n_win == 0:
        raise ValueError(f"{source.source}: {n} samples is shorter than one window "
                         f"(window={spec.window}): no feature value was computed")
    if n_bad == n_win:
        raise ValueError(f"{source.source}: all {n_win} windows of {spec.label} are degenerate "
                         "(zero variance: constant channel?); no feature value was computed")
    if detector is not None and not n_scored:
        # every window lay in the detector's burn-in: nothing was judged, and the console said
        # only "0 alarm raising(s)" with exit 0 while detect refused the file ("too short to
        # judge", exit 2) and batch marked it "not judged" (streams audit 2026-11-27, finding
        # 4). A refusal (exit 2) in the words the store records with the run ('unjudged')
        raise ValueError(unjudged_reason(True, n_win, n_scored, None, str(source.source),
                                         spec.label, spec.window))
