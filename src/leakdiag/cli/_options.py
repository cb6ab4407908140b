"""Options shared by the commands that read recordings, defined once.

``@recording_options`` adds ``--map``, ``--col``, ``--sample-rate`` and ``--time-unit``;
:func:`column_map_from` turns them into what :func:`leakdiag.io.read_recording` takes, and
:func:`read_healthy` reads healthy reference recordings and checks that they agree with the
suspect recording (sample rate, system, channels, units).
"""

from __future__ import annotations

import math
import warnings

import click

from leakdiag.io.checks import same_rate
from leakdiag.runtime.paths import prepare_out_dir, prepare_out_file

__all__ = ["recording_options", "resample_option", "column_map_from", "read_with", "read_healthy",
           "false_alarm_option", "healthy_option", "no_progress_option", "scheduler_option",
           "workers_option", "check_workers", "FiniteFloat", "prepare_out_dir",
           "prepare_out_file", "list_option_values", "warn_low_rate", "rate_basis",
           "rate_warning",
           "TIME_UNIT_CHOICES"]

#: Below this rate (Hz) a time column is probably not in seconds (ms, sample counter): warned.
LOW_RATE_HZ = 20.0
#: Rates above this are warned about too (Hz): a time column in seconds declared in ms or us
#: (``--time-unit``) reads 1000 or 10**6 times too fast (audit of users' recordings 2026-11-27,
#: finding 9: 1e+09 Hz without a word). Actuator pressure recordings run at 1-20 kHz (the real
#: rotary-actuator files at 1 kHz); 200 kHz is ten times above any of them.
HIGH_RATE_HZ = 200e3
#: Time units of a time column (as :class:`leakdiag.io.ColumnMap` accepts them).
TIME_UNIT_CHOICES = ["s", "ms", "us", "samples"]


def recording_options(f):
    """Decorator: ``--map``, ``--col``, ``--sample-rate``, ``--time-unit`` (one definition).

    Parameters
    ----------
    f : callable
        The click command function; it receives ``column_map``, ``cols``, ``sample_rate`` and
        ``time_unit``.

    Returns
    -------
    callable
    """
    opts = [
        click.option("--map", "column_map", type=click.Path(exists=True, dir_okay=False),
                     help="TOML column map: which column is which channel, its unit and gain "
                          "(docs/io.md)."),
        click.option("--col", "cols", multiple=True, metavar="CH=COLUMN[:UNIT[*GAIN]]",
                     help="Column mapping, e.g. --col p1=PG_1:psi (repeatable; adds to --map)."),
        click.option("--sample-rate", type=float, default=None,
                     help="Sample rate (Hz) when the file has no time column; refused if it "
                          "contradicts the file's time column or header."),
        click.option("--time-unit", type=click.Choice(TIME_UNIT_CHOICES), default=None,
                     help="Unit of the file's time column (default s)."),
    ]
    for opt in reversed(opts):
        f = opt(f)
    return f


def resample_option(f):
    """Decorator: ``--resample HZ`` (interpolate a non-uniform time axis onto a uniform grid).

    Parameters
    ----------
    f : callable
        The click command function (receives ``resample``).

    Returns
    -------
    callable
    """
    return click.option("--resample", type=float, metavar="HZ", default=None,
                        help="Interpolate a non-uniform time axis onto a uniform grid at this "
                             "rate (Hz).")(f)


def healthy_option(f):
    """Decorator: repeatable ``--healthy FILE``.

    Parameters
    ----------
    f : callable
        The click command function (receives ``healthy``, a tuple of paths).

    Returns
    -------
    callable
    """
    return click.option("--healthy", multiple=True, type=click.Path(exists=True, dir_okay=False),
                        help="Healthy reference recording of the same machine (repeatable).")(f)


def false_alarm_option(default: float = 0.01, per: str = "run", upper: float = 1.0):
    """Decorator factory: ``--false-alarm-rate`` (the one name for the false-alarm target).

    Parameters
    ----------
    default : float, default 0.01
        Default rate.
    per : str, default "run"
        What the rate is per (stated in the help).
    upper : float, default 1.0
        Largest accepted rate (included); 0 is always refused.

    Returns
    -------
    callable
    """
    return click.option("--false-alarm-rate", type=click.FloatRange(0, upper, min_open=True),
                        default=default, show_default=True,
                        help=f"Chance of a false 'leak' per {per} on healthy operation.")


def no_progress_option(f):
    """Decorator: ``--no-progress``.

    Parameters
    ----------
    f : callable
        The click command function (receives ``no_progress``).

    Returns
    -------
    callable
    """
    return click.option("--no-progress", is_flag=True, help="Hide progress messages and bars.")(f)


def _check_scheduler(ctx, param, value):
    """``--scheduler`` is refused at parse time when it is no name nor address (the executor's
    rule, :func:`leakdiag.runtime.executor.run_cases`), before any work."""
    if value is None or value in ("serial", "local") or ":" in str(value):
        return value
    raise click.BadParameter(f"{value!r} must be 'serial', 'local' or the address of a Dask "
                             "scheduler such as tcp://127.0.0.1:8786")


def scheduler_option(default: str = "local"):
    """Decorator factory: ``--scheduler serial|local|ADDRESS`` (one definition for every command
    that runs on Dask: batch, reproduce, sensitivity, benchmark).

    Parameters
    ----------
    default : str, default "local"
        Default scheduler.

    Returns
    -------
    callable
    """
    return click.option("--scheduler", default=default, show_default=True,
                        metavar="serial|local|ADDRESS", callback=_check_scheduler,
                        help="serial: in this process; local: a Dask cluster on this machine; or "
                             "the address of a Dask scheduler (tcp://host:8786).")


def workers_option(f):
    """Decorator: ``--workers N`` (N >= 1; worker processes of the local Dask cluster).

    Zero or a negative number is refused at parse time: a local cluster without workers never
    runs a case (the command used to wait at 0 % until killed). Pair it with
    :func:`check_workers`, which refuses ``--workers`` with another scheduler than ``local``.

    Parameters
    ----------
    f : callable
        The click command function (receives ``workers``, an int or None).

    Returns
    -------
    callable
    """
    return click.option("--workers", type=click.IntRange(min=1), default=None,
                        help="Worker processes of the local Dask cluster (with --scheduler local "
                             "only; default: one per core).")(f)


def check_workers(scheduler: str, workers: int | None) -> None:
    """Refuse ``--workers`` with a scheduler that does not start a local cluster.

    With ``--scheduler serial`` every case runs in this process, and a scheduler address has
    the workers of its own cluster: ``--workers`` would be ignored, so it is refused.

    Parameters
    ----------
    scheduler : str
        ``--scheduler``.
    workers : int or None
        ``--workers`` (None: not given).

    Raises
    ------
    click.UsageError
        When ``workers`` is given and ``scheduler`` is not ``"local"``.
    """
    if workers is None or scheduler == "local":
        return
    why = ("serial runs every case in this process" if scheduler == "serial" else
           f"the scheduler at {scheduler} has the workers of its own cluster")
    raise click.UsageError(f"--workers {workers} is for --scheduler local ({why}): drop "
                           "--workers or give --scheduler local")


class FiniteFloat(click.FloatRange):
    """A float option that refuses ``nan`` and ``inf`` (and values out of its range).

    :class:`click.FloatRange` lets ``nan`` through (no comparison is true) and accepts ``inf``
    when there is no upper bound; this type refuses both with a one-line usage error.

    Parameters
    ----------
    min, max : float, optional
        Bounds.
    min_open, max_open : bool, default False
        Exclude the bound.

    Examples
    --------
    >>> FiniteFloat(min=0, min_open=True).convert("2.5", None, None)
    2.5
    """

    name = "float"

    def convert(self, value, param, ctx):  # noqa: D102 - click's ParamType.convert
        rv = click.FLOAT.convert(value, param, ctx)
        if not math.isfinite(rv):
            self.fail(f"{value} is not a finite number.", param, ctx)
        return super().convert(rv, param, ctx)


def list_option_values(option: str, text: str, kind: type, example: str, check=None,
                       rule: str = "") -> tuple:
    """The values of a list option (``1,2,3`` or ``start:stop:step``), each one checked.

    Parameters
    ----------
    option : str
        Option name for the messages, e.g. ``"--windows"``.
    text : str
        What was given.
    kind : type
        ``int``, ``float`` or ``str`` (as :func:`leakdiag.studies.sweep.parse_values`).
    example : str
        A valid value, shown when the list is empty.
    check : callable, optional
        ``check(value) -> bool``; a value for which it is false is refused with ``rule``.
    rule : str
        What ``check`` requires, in words.

    Returns
    -------
    tuple

    Raises
    ------
    click.BadParameter
        For an empty list (it is never taken to mean the defaults), an unreadable item or
        range, or a value that ``check`` refuses; the message names the option.
    """
    from leakdiag.studies.sweep import parse_values

    if not str(text).replace(",", "").strip():
        raise click.BadParameter(f"{text!r} is an empty list; give e.g. {example}",
                                 param_hint=f"'{option}'")
    try:
        vals = parse_values(text, kind)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint=f"'{option}'") from None
    where = "" if len(vals) == 1 else f" in {text!r}"
    for v in vals:
        if check is not None and not check(v):
            raise click.BadParameter(f"{v!r}{where}: {rule}", param_hint=f"'{option}'")
    return tuple(vals)


def column_map_from(column_map, cols, time_unit=None):
    """The column map for :func:`leakdiag.io.read_recording` from ``--map``/``--col``/``--time-unit``.

    Parameters
    ----------
    column_map : str or None
        ``--map`` path.
    cols : sequence of str
        ``--col`` specs.
    time_unit : str or None
        ``--time-unit``.

    Returns
    -------
    ColumnMap, str or None
        None when no option was given (files written by leakdiag restore exactly).
    """
    if not cols and time_unit is None:
        return column_map
    import leakdiag.io as lio

    return lio.build_column_map(list(cols), base=column_map, time_unit=time_unit)


#: The reader's arguments that are options of the commands reading files.
_READ_OPTIONS = {"resample": "--resample", "sample_rate": "--sample-rate"}


def read_with(path, cmap, sample_rate=None, resample=None, channels=None):
    """Read ``path`` and make messages name it.

    Parameters
    ----------
    path : str
        File.
    cmap : optional
        Column map (from :func:`column_map_from`).
    sample_rate, resample : float, optional
        As in :func:`leakdiag.io.read_recording`.
    channels : collection of str, optional
        Read only these channels (:func:`leakdiag.io.read_recording`).

    Returns
    -------
    Recording
    """
    import leakdiag.io as lio
    from leakdiag.cli._words import option_names

    try:
        if resample is None:
            rec = lio.read_recording(path, column_map=cmap, sample_rate=sample_rate,
                                     channels=channels)
        else:
            rec = lio.read_recording(path, column_map=cmap, sample_rate=sample_rate,
                                     resample=resample, channels=channels)
    except ValueError as exc:  # the reader names its arguments as Python does (resample=-5.0)
        named = option_names(str(exc), _READ_OPTIONS)
        if named == str(exc):
            raise
        raise type(exc)(named) from None
    if rec.meta.get("source") != str(path):
        rec.meta["origin"] = rec.meta.get("source")
        rec.meta["source"] = str(path)
    if sample_rate is None:
        warn_low_rate(path, rec.sample_rate, basis=rate_basis(path, cmap, rec.sample_rate))
    return rec


#: Where a sample rate came from (:func:`rate_basis`), as the rate warnings say it.
RATE_FROM_TIME = "from the time column"
RATE_FROM_HEADER = "from the file's leakdiag header"
RATE_FROM_MAP = "from sample_rate_hz in the column map"


def rate_basis(path, cmap, rate: float) -> str:
    """Where a file's sample rate came from, for the rate warnings: its leakdiag header (a
    Parquet or HDF5 file leakdiag wrote, read without a map), the column map's
    ``sample_rate_hz`` (a file without a time column, or a sample counter; a map's rate equal
    to the time column's is named as the map's), else its time column.

    Parameters
    ----------
    path : str
        File (``"-"``: stdin, whose rate comes from its time column).
    cmap : ColumnMap, str or None
        The column map the file was read with (or its TOML file).
    rate : float
        The rate (Hz) read.

    Returns
    -------
    str
        :data:`RATE_FROM_HEADER`, :data:`RATE_FROM_MAP` or :data:`RATE_FROM_TIME`.
    """
    from leakdiag.io import load_column_map, recording_units

    if cmap is not None:
        try:
            given = load_column_map(cmap).sample_rate_hz  # a batch job's map is its file
        except (OSError, ValueError):
            given = None
        return RATE_FROM_MAP if given is not None and float(given) == rate else RATE_FROM_TIME
    try:
        header = recording_units(path) is not None
    except ValueError:  # stdin, a followed file, another format: no header
        header = False
    return RATE_FROM_HEADER if header else RATE_FROM_TIME


def warn_low_rate(path, rate: float, advice: str = "give --time-unit ms (or samples with "
                                                    "--sample-rate)",
                  basis: str = RATE_FROM_TIME) -> None:
    """Warn when a file's sample rate is implausibly low (or high) for actuator pressures,
    saying where the rate came from (until 2026-11-28 always "from the time column", also for
    a rate that an attribute gave: streams audit 2026-11-27, finding 9).

    Parameters
    ----------
    path : str
        File (for the message).
    rate : float
        Sample rate (Hz).
    advice : str
        What the command lets the user do about a time column in other units.
    basis : str, default RATE_FROM_TIME
        Where the rate came from (:func:`rate_basis`); the advice is the time column's only
        for a rate from the time column.

    Warns
    -----
    UserWarning
        Below :data:`LOW_RATE_HZ` (a time column in milliseconds or a sample counter read as
        seconds), or above :data:`HIGH_RATE_HZ` (a time column in seconds read as ms or us).
    """
    msg = rate_warning(path, rate, basis, advice)
    if msg is not None:
        warnings.warn(msg, UserWarning, stacklevel=3)


def rate_warning(path, rate: float, basis: str, advice: str,
                 high_advice: str = "Then give --time-unit s (the default)") -> str | None:
    """The words of :func:`warn_low_rate` (None: the rate is plausible); ``batch`` prints them
    with its own advice."""
    if LOW_RATE_HZ <= rate <= HIGH_RATE_HZ:
        return None
    what = ("low for actuator pressures" if rate < LOW_RATE_HZ else
            f"high for actuator pressures (above {HIGH_RATE_HZ:g} Hz)")
    head = f"{path}: sample rate {rate:g} Hz {basis} is {what}"
    if basis == RATE_FROM_HEADER:
        return (f"{head}; the header of a file leakdiag wrote gives the rate its samples were "
                "written at: if that is wrong, write the recording again with its true rate")
    if basis == RATE_FROM_MAP:
        return f"{head}; check sample_rate_hz in the column map (in Hz)"
    if rate < LOW_RATE_HZ:
        return (f"{head}; if the time column is in milliseconds or a sample counter, "
                f"{advice}")
    return f"{head}; is the time column in s rather than ms or us? {high_advice}"


def read_healthy(paths, suspect, cmap, sample_rate=None, channels=None, resample=None,
                 recordings=None, reads=None, keep=None):
    """Read healthy reference recordings and check they agree with the suspect recording.

    Parameters
    ----------
    paths : sequence of str
        Healthy files.
    suspect : Recording or None
        The recording under judgement (None: only the healthy files are checked among
        themselves).
    cmap : optional
        Column map.
    sample_rate : float, optional
        ``--sample-rate``.
    channels : sequence of str, optional
        Channels the methods need (checked in every file).
    resample : float, optional
        ``--resample`` (Hz).
    recordings : list of Recording, optional
        The files already read (only checked again, e.g. for the channels a method reads).
    reads : str, optional
        What needs ``channels`` (a method name), for the message of a missing one.
    keep : collection of str, optional
        Read only these channels of each file (default: ``channels`` when given, else all;
        :func:`leakdiag.io.read_recording`).

    Returns
    -------
    list of Recording

    Raises
    ------
    ValueError
        When a healthy file's sample rate, system, units or channels differ from the suspect's,
        its metadata records a leak (``leak_lpm`` > 0), two files hold the same samples
        (:func:`leakdiag.detect.base.check_healthy`), or a healthy file holds the suspect's
        samples (the judged file, or a copy of it, given as its own reference).
    """
    from leakdiag.detect.base import check_healthy, healthy_info
    from leakdiag.io.errors import RecordingError

    recs = (list(recordings) if recordings is not None else
            [read_with(p, cmap, sample_rate, resample,
                       keep if keep is not None else channels or None) for p in paths])
    ref = suspect if suspect is not None else (recs[0] if recs else None)
    if ref is None:
        return recs
    name = ref.meta.get("source", "<recording>")
    for p, r in zip(paths, recs):
        if not same_rate(r.sample_rate, ref.sample_rate):
            raise ValueError(f"--healthy {p}: sample rate {r.sample_rate:g} Hz differs from "
                             f"{name}'s {ref.sample_rate:g} Hz: references must be recorded at the "
                             "same rate (--map, --col and --time-unit apply to every file)")
        sys_r, sys_s = r.meta.get("system"), ref.meta.get("system")
        if sys_r and sys_s and str(sys_r).lower() != str(sys_s).lower():
            raise ValueError(f"--healthy {p}: system {sys_r!r} differs from {name}'s {sys_s!r}: "
                             "healthy references must come from the same kind of machine")
        for c in (channels if channels is not None else ref.channels):
            if c not in r.channels and reads is not None:
                raise ValueError(f"--healthy {p}: no channel {c!r}, which {reads} reads; "
                                 f"available: {sorted(r.channels)}")
            if c in ref.channels and c not in r.channels:
                raise ValueError(f"--healthy {p}: no channel {c!r}, which {name} has")
            if c in ref.channels and c in r.channels and \
                    r.units.get(c) != ref.units.get(c):
                raise ValueError(f"--healthy {p}: channel {c!r} is in {r.units.get(c)!r}, "
                                 f"{name} in {ref.units.get(c)!r}")
    if recordings is not None:  # checked when they were read
        return recs
    # samples compared over the channels the methods read (all without ``channels``): a copy
    # with other columns (a CSV export without leak_flow) is the same run to them (a CLI
    # audit, 2026-11-29: analyze judged a file against its own CSV export)
    ident = [c for c in channels if c in ref.channels] if channels else None
    ident = ident or None
    try:  # leaking by metadata, or one file given twice: the check of every detector's fit
        check_healthy([healthy_info(r, ident) for r in recs])
    except RecordingError as exc:
        raise ValueError(f"--healthy: {str(exc).removeprefix('fit: ')}") from None
    if suspect is not None:  # the judged file (or a copy) as its own reference: in-sample
        mine = healthy_info(suspect, ident)["digest"]
        for p, r in zip(paths, recs):
            if healthy_info(r, ident)["digest"] == mine:
                raise ValueError(
                    f"--healthy {p}: holds the same samples as {name}, the recording judged: a "
                    "recording cannot be its own healthy reference (compared with itself, a "
                    "leak reads NO LEAK); give healthy recordings other than the one judged")
    return recs
