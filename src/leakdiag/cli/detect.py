"""``leakdiag detect``: fit detectors on healthy recordings and give a verdict on a file."""

from __future__ import annotations

import click

__all__ = ["detect", "verdict_table"]


def verdict_table(file, healthy, *, methods=("acf-p1", "ccf-p1p2", "mlr-p1"), system="vca",
                  column_map=None, sample_rate=None, false_alarms_per_hour=1.0,
                  onset_method="binseg", burn_in_s=5.0):
    """Fit each method on the healthy files and judge ``file``.

    Parameters
    ----------
    file : path-like
        Recording to judge.
    healthy : sequence of path-like
        Healthy recordings of the same machine and operating conditions.
    methods : sequence of str
        Benchmark registry names (:data:`leakdiag.bench.registry.METHODS`).
    system : {"vca", "eha"}, default "vca"
        Selects the thesis's preferred feature settings.
    column_map : optional
        Column map for :func:`leakdiag.io.read_recording` (TOML path or dict).
    sample_rate : float, optional
        Sample rate in Hz when the files have no time column in seconds.
    false_alarms_per_hour : float, default 1.0
        Alarm target on healthy operation.
    onset_method : {"binseg", "pelt", "cusum"}, default "binseg"
        Onset estimator.
    burn_in_s : float, default 5.0
        Leading seconds ignored in every recording.

    Returns
    -------
    pandas.DataFrame
        One row per method: :meth:`Verdict.as_dict` plus ``method``, ``threshold_method`` and
        ``n_healthy`` (or ``error`` when the method cannot be fitted on the healthy files, or
        when a channel it reads is constant in ``file``).
    """
    import numpy as np
    import pandas as pd

    from leakdiag.bench.registry import make_detector
    from leakdiag.detect.base import Alarm
    from leakdiag.io import read_recording

    def read(p):
        return read_recording(p, column_map, sample_rate=sample_rate)

    rec = read(file)
    train = [read(p) for p in healthy]
    alarm = Alarm(false_alarms_per_hour=false_alarms_per_hour, onset_method=onset_method,
                  burn_in_s=burn_in_s)
    rows = []
    for m in methods:
        det = make_detector(m, system, alarm)
        dead = [c for c in getattr(det, "channels", ()) if c in rec.channels
                and rec[c].size and np.all(rec[c] == rec[c][0])]
        if dead:  # the detector's CUSUM skips NaN windows: a dead sensor would read "no leak"
            rows.append({"method": m, "error": f"{file}: channel {dead[0]!r} is constant "
                         f"({rec[dead[0]][0]:g}): zero variance, {m} cannot judge it"})
            continue
        try:
            det.fit(train)
        except ValueError as exc:
            rows.append({"method": m, "error": str(exc)})
            continue
        rows.append({"method": m, **det.predict(rec).as_dict(),
                     "threshold_method": det.alarm_threshold_.method, "n_healthy": len(train)})
    return pd.DataFrame(rows)


@click.command("detect")
@click.argument("file", type=click.Path(exists=True, dir_okay=False))
@click.option("--healthy", multiple=True, required=True, type=click.Path(exists=True, dir_okay=False),
              help="Healthy recording (repeat the option for several).")
@click.option("--methods", default="acf-p1,ccf-p1p2,mlr-p1", show_default=True,
              help="Comma-separated methods (leakdiag benchmark --list-methods).")
@click.option("--system", default="vca", show_default=True, type=click.Choice(["vca", "eha"]),
              help="Rig whose thesis settings the features use.")
@click.option("--map", "column_map", default=None, help="Column map (TOML) for the reader.")
@click.option("--sample-rate", default=None, type=float, help="Sample rate (Hz) if not in the file.")
@click.option("--false-alarms-per-hour", default=1.0, show_default=True, type=float)
@click.option("--onset", "onset_method", default="binseg", show_default=True,
              type=click.Choice(["binseg", "pelt", "cusum"]))
@click.option("--burn-in", "burn_in_s", default=5.0, show_default=True, type=float,
              help="Seconds ignored at the start of every recording.")
@click.option("--store", default=None, help="Also write the verdicts to this event store "
              "(SQLite file or SQLAlchemy URL).")
@click.option("--actuator", default=None, help="Actuator name in the store (default: FILE stem).")
def detect(file, healthy, methods, system, column_map, sample_rate, false_alarms_per_hour,
           onset_method, burn_in_s, store, actuator):
    """Judge FILE against healthy recordings: leak or not, onset, alarm time, confidence."""
    import numpy as np
    import pandas as pd

    tab = verdict_table(file, healthy, methods=[m.strip() for m in methods.split(",") if m.strip()],
                        system=system, column_map=column_map, sample_rate=sample_rate,
                        false_alarms_per_hour=false_alarms_per_hour, onset_method=onset_method,
                        burn_in_s=burn_in_s)
    cols = [c for c in ("method", "leak", "onset_s", "alarm_time_s", "confidence", "score_max",
                        "threshold", "threshold_method", "error") if c in tab]
    click.echo(tab[cols].to_string(index=False))
    if store:
        import os

        from leakdiag.store import EventStore
        from leakdiag.store.writers import record_verdicts

        st = EventStore(store)
        name = actuator or os.path.splitext(os.path.basename(file))[0]
        click.echo(f"{record_verdicts(st, name, file, tab)} alarm(s) for {name} written to {st.url}")
        st.close()
    scores = tab["score_max"] if "score_max" in tab else pd.Series(float("nan"), index=tab.index)
    if not np.isfinite(scores.to_numpy(dtype=float)).any():  # no method could judge FILE
        why = (tab["error"].dropna().iloc[0] if "error" in tab and tab["error"].notna().any()
               else "every feature value is NaN (zero variance: constant channel?)")
        raise ValueError(f"{file}: no method gave a finite score; first reason: {why}")
