"""Run a feature over a whole chunk source (e.g. a file larger than memory) and collect its series."""

from __future__ import annotations

import numpy as np

from leakdiag.features.series import FeatureSeries
from leakdiag.features.spec import MethodSpec
from leakdiag.features.windowing import window_step
from leakdiag.stream.feature import StreamingFeature
from leakdiag.stream.chunks import ChunkSource

__all__ = ["stream_feature"]


def stream_feature(source: ChunkSource, spec: MethodSpec, progress: bool = False) -> FeatureSeries:
    """Compute a feature over every chunk of ``source``; only the feature series is kept.

    Parameters
    ----------
    source : ChunkSource
        Chunks of samples (from :func:`~leakdiag.stream.open_chunks` or
        :func:`~leakdiag.stream.recording_chunks`).
    spec : MethodSpec
        Method and settings.
    progress : bool, default False
        Show a tqdm progress bar in samples.

    Returns
    -------
    FeatureSeries
        Same windows, times and values as the batch feature on the whole recording;
        ``params`` also holds ``n_samples`` and ``n_degenerate`` (zero-variance windows, NaN).

    Notes
    -----
    Memory is one chunk plus less than one window per channel plus the output (one float per
    window), independent of the recording length.

    Examples
    --------
    >>> from leakdiag.io.recording import Recording
    >>> from leakdiag.stream.chunks import recording_chunks
    >>> rec = Recording({"p1": np.sin(np.arange(1000) / 5.0)}, sample_rate=100.0)
    >>> spec = MethodSpec("autocorrelation", ("p1",), lag=1, window=200, overlap=5)
    >>> fs = stream_feature(recording_chunks(rec, 333), spec)
    >>> len(fs), round(float(fs.values[0]), 2)
    (5, 0.98)
    """
    feat = StreamingFeature(spec, source.sample_rate, source.start_time)
    times, values = [], []
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=source.n_samples, unit="sample", unit_scale=True, desc=spec.method)
    try:
        for chunk in source:
            fs = feat.push(chunk)
            times.append(fs.time)
            values.append(fs.values)
            if bar is not None:
                bar.update(len(chunk[spec.channels[0]]))
    finally:
        if bar is not None:
            bar.close()
    t = np.concatenate(times) if times else np.empty(0)
    v = np.concatenate(values) if values else np.empty(0)
    settings = {**spec.record.setting_entries(spec.value), "n_samples": feat.n_samples_seen,
                "n_degenerate": feat.n_degenerate}
    return FeatureSeries(t, v, spec.method, settings, window=spec.window, overlap=spec.overlap,
                         step=window_step(spec.window, spec.overlap), channels=spec.channels,
                         sample_rate=source.sample_rate, start_time=feat.start_time)
