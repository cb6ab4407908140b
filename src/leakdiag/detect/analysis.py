"""Analyse a recording with one or more thesis methods: feature series plus the Sec. 5.2 verdict."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from leakdiag.detect.measure import rms_change
from leakdiag.features.methods import MethodSpec, compute_feature
from leakdiag.features.series import FeatureSeries

__all__ = ["Analysis", "analyze_recording", "VERDICT_COLUMNS"]

#: Columns of the verdict table, in order.
VERDICT_COLUMNS = [
    "method", "channels", "setting", "window", "overlap", "n_windows", "mean_rms_before",
    "mean_rms_after", "pct_change", "pct_change_signed", "n_chunks_before", "n_chunks_after",
    "n_chunks_straddling", "n_chunks_empty", "n_nan_windows",
]


@dataclass
class Analysis:
    """Result of :func:`analyze_recording`.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per feature series: settings, windows used and, when the onset is known, the
        Sec. 5.2 measure (columns :data:`VERDICT_COLUMNS`).
    series : list of FeatureSeries
        The feature series, in table order.
    results : list of RMSChange or None
        Sec. 5.2 results in table order (None when no onset was given).
    onset : float or None
        Onset used, in seconds.
    """

    table: "object"
    series: list = field(default_factory=list)
    results: list = field(default_factory=list)
    onset: float | None = None

    def features_frame(self):
        """All feature series as one tidy DataFrame (``label, time, value`` plus settings).

        Returns
        -------
        pandas.DataFrame
        """
        import pandas as pd

        frames = []
        for row, fs in zip(self.table.to_dict("records"), self.series):
            frames.append(pd.DataFrame({
                "method": row["method"], "channels": row["channels"], "setting": row["setting"],
                "window": row["window"], "overlap": row["overlap"], "time": fs.time,
                "value": fs.values}))
        return pd.concat(frames, ignore_index=True)


def _moment_series(df, spec: MethodSpec) -> list[FeatureSeries]:
    out = []
    for col in ("mean", "variance", "skewness", "kurtosis"):
        out.append(FeatureSeries(df["time"].to_numpy(), df[col].to_numpy(dtype=float), col,
                                 {"channels": ",".join(spec.channels), "window": spec.window,
                                  "overlap": spec.overlap,
                                  "sample_rate": df.attrs.get("sample_rate", None) or 1.0}))
    return out


def analyze_recording(recording, specs, onset: float | None = None, chunk: int = 10) -> Analysis:
    """Compute each method's feature series and, with an onset, the Sec. 5.2 measure.

    Parameters
    ----------
    recording : Recording
        The recording (channels ``p1``, ``p2``, ``x``, ``u`` as the methods need).
    specs : MethodSpec or sequence of MethodSpec
        Methods and settings (see :func:`leakdiag.features.methods.thesis_defaults`).
    onset : float, optional
        Leak onset in seconds; default ``recording.meta['onset']`` if present.
    chunk : int, default 10
        Chunk length (feature values) of the Sec. 5.2 RMS.

    Returns
    -------
    Analysis
        Verdict table, feature series and RMS results.

    Raises
    ------
    RecordingError
        Missing channel or a recording shorter than one window.
    ValueError
        If the onset leaves no whole chunk on one side.
    """
    import pandas as pd

    if isinstance(specs, MethodSpec):
        specs = [specs]
    if onset is None:
        onset = recording.onset
    rows, series, results = [], [], []
    for spec in specs:
        out = compute_feature(recording, spec)
        fss = _moment_series(out, spec) if spec.method == "moments" else [out]
        for fs in fss:
            fs.params["sample_rate"] = recording.sample_rate
            method = spec.method if spec.method != "moments" else f"moments:{fs.name}"
            row = {"method": method, "channels": ",".join(spec.channels),
                   "setting": spec.setting, "window": spec.window, "overlap": spec.overlap,
                   "n_windows": len(fs),
                   "n_nan_windows": int(np.count_nonzero(~np.isfinite(fs.values)))}
            res = None
            if onset is not None:
                res = rms_change(fs, onset=onset, chunk=chunk)
                row.update({k: v for k, v in res.as_dict().items()
                            if k in VERDICT_COLUMNS and k != "n_windows"})
            rows.append(row)
            series.append(fs)
            results.append(res)
    table = pd.DataFrame(rows).reindex(columns=VERDICT_COLUMNS)
    return Analysis(table=table, series=series, results=results, onset=onset)
