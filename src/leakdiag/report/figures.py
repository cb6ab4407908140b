"""Figures in the thesis's style: a feature series against time with the leak onset marked."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

from leakdiag.features.series import FeatureSeries

__all__ = ["plot_feature_series", "save_figure"]


def plot_feature_series(series: Sequence, onset: float | None = None, titles: Sequence[str] | None = None,
                        ylabel: str | None = None, rms=None, ax=None):
    """Plot one or more feature series as stacked panels (Figs. 5-7 to 5-22 style).

    Parameters
    ----------
    series : FeatureSeries or sequence of FeatureSeries
        Series to plot, one panel each.
    onset : float, optional
        Leak onset in seconds, drawn as a dashed vertical line.
    titles : sequence of str, optional
        Panel titles (default: the series' labels from their params).
    ylabel : str, optional
        Y-axis label (default: the feature name).
    rms : RMSChange or sequence of RMSChange, optional
        Sec. 5.2 results; the mean RMS before and after are drawn as horizontal segments.
    ax : matplotlib Axes, optional
        Draw a single series into this axes.

    Returns
    -------
    matplotlib.figure.Figure
        The figure (not shown; save it with :func:`save_figure`).
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    if isinstance(series, FeatureSeries):
        series = [series]
    if rms is not None and not isinstance(rms, (list, tuple)):
        rms = [rms]
    n = len(series)
    if ax is not None:
        fig, axes = ax.figure, [ax]
    else:
        fig, axes = plt.subplots(n, 1, figsize=(9, 2.2 * n + 0.6), sharex=True, squeeze=False)
        axes = list(axes[:, 0])
    for i, (fs, a) in enumerate(zip(series, axes)):
        a.plot(fs.time, fs.values, lw=0.7, color="tab:blue")
        if onset is not None:
            a.axvline(onset, color="tab:red", ls="--", lw=1.0, label=f"leak onset {onset:g} s")
        if rms is not None and i < len(rms) and rms[i] is not None:
            r = rms[i]
            t0, t1 = float(fs.time[0]), float(fs.time[-1])
            # the RMS is a magnitude: on a feature that goes negative it is drawn at +- RMS, so
            # that it does not read as the level of a signed feature (a CLI audit, 2026-11-28,
            # finding 6: a negative cross-correlation with its RMS drawn above it)
            vals = np.asarray(fs.values, dtype=float)
            signed = bool(np.isfinite(vals).any() and np.nanmin(vals) < 0)
            pm = "+-" if signed else ""
            a.hlines(r.mean_rms_before, t0, r.onset, color="k", lw=1.2,
                     label=f"mean RMS before {pm}{r.mean_rms_before:.4g}")
            a.hlines(r.mean_rms_after, r.onset, t1, color="tab:orange", lw=1.2,
                     label=f"mean RMS after {pm}{r.mean_rms_after:.4g} "
                           f"({r.pct_change_signed:+.1f}%)")
            if signed:
                a.hlines(-r.mean_rms_before, t0, r.onset, color="k", lw=1.2, ls=":")
                a.hlines(-r.mean_rms_after, r.onset, t1, color="tab:orange", lw=1.2, ls=":")
        label = titles[i] if titles is not None else _label(fs)
        a.set_title(label, fontsize=9, loc="left")
        a.set_ylabel(ylabel or fs.name, fontsize=8)
        a.grid(alpha=0.3)
        if onset is not None or rms is not None:
            a.legend(fontsize=7, loc="best")
    axes[-1].set_xlabel("time (s)")
    fig.tight_layout()
    return fig


def _label(fs) -> str:
    p = fs.params
    parts = [fs.name, ",".join(fs.channels)]
    if p.get("lag") is not None:
        parts.append(f"lag {p['lag']}")
    if p.get("lag_ratio") is not None:
        lr = p["lag_ratio"]
        parts.append(f"lag ratio {lr if isinstance(lr, str) else '%d:%d' % tuple(lr)}")
    if fs.window is not None:
        parts.append(f"window {fs.window}")
    if fs.overlap is not None:
        parts.append(f"overlap {fs.overlap:g}%")
    return ", ".join(x for x in parts if x)


def save_figure(fig, path) -> Path:
    """Save a figure as PNG (150 dpi) and close it.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        Figure to save.
    path : str or Path
        Output file; parent folders are created.

    Returns
    -------
    Path
        The written path.
    """
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=150)
    plt.close(fig)
    return path
