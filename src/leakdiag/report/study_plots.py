"""Figures of the studies: % change against the varied parameter, sensitivity against leak size,
windowed moments (Sec. 4.7). Stacked feature panels come from :mod:`leakdiag.report.figures`.

All functions return a :class:`matplotlib.figure.Figure` drawn with the Agg backend.
"""

from __future__ import annotations

import numpy as np

__all__ = ["plot_pct_vs_parameter", "plot_sensitivity", "plot_moments", "plot_grid_heatmap",
           "plot_stacked"]


#: Points drawn per line at most (every k-th value beyond that; the report stays light).
PLOT_MAX_POINTS = 1500


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def plot_pct_vs_parameter(x, ours, thesis=None, xlabel: str = "parameter",
                          title: str = "", xticklabels=None,
                          label: str = "leakdiag (simulator)"):
    """|% change| against the varied parameter: ours, and the thesis's if given.

    Parameters
    ----------
    x : array_like
        Varied values (numbers; for lag ratios the ``l`` of ``l:k``).
    ours : array_like
        Our |% change|.
    thesis : array_like, optional
        The thesis's |% change| at the same settings.
    xlabel : str
        Axis label.
    title : str
        Title.
    xticklabels : sequence of str, optional
        Tick labels at ``x`` (e.g. ``"83:3"``).
    label : str, default "leakdiag (simulator)"
        Legend entry of ``ours`` (e.g. the user's file name).

    Returns
    -------
    matplotlib.figure.Figure
    """
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.4, 3.8))  # >= 900 px at 150 dpi: readable
    ax.plot(x, ours, "o-", color="tab:blue", label=label)
    if thesis is not None:
        ax.plot(x, thesis, "s--", color="tab:gray", label="thesis (test rig)")
    if xticklabels is not None:
        ax.set_xticks(list(x))
        ax.set_xticklabels(list(xticklabels), fontsize=8)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("% change of mean RMS")
    ax.set_title(title, fontsize=9, loc="left")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


#: Marker and colour of each load in the sensitivity figures (others: "x", grey).
_LOAD_STYLE = {"none": ("^", "tab:blue"), "spring": ("o", "tab:orange")}


def plot_sensitivity(sens, system: str, thesis_ranges=None, figures=None):
    """Signed % change against leak size per method (case study 3), one panel per method, one
    marker and colour per load.

    The change is drawn signed (``pct_change_signed``): a leak whose effect reverses between
    loads (the feature falls without load and rises with the spring) shows as two clouds on
    either side of 0, which a plot of |% change| merges.

    Parameters
    ----------
    sens : pandas.DataFrame
        Sensitivity rows of one system (``method``, ``channels``, ``leak_lpm``, ``load``,
        ``pct_change_signed``).
    system : str
        ``"vca"`` or ``"eha"`` (title).
    thesis_ranges : pandas.DataFrame, optional
        Output of :func:`leakdiag.studies.reproduce.sensitivity_summary`; the thesis's range of
        |% change| (it prints magnitudes only) is drawn as grey bands at + and - that range.
    figures : dict, optional
        ``(method, channels)`` -> thesis figure (``"5-23"``), named in the panel's title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    plt = _plt()
    groups = list(sens.groupby(["method", "channels"], sort=False))
    n = len(groups)
    ncol = 2 if n > 1 else 1
    nrow = int(np.ceil(n / ncol))
    fig, axes = plt.subplots(nrow, ncol, figsize=(max(6.4, 5 * ncol), 2.8 * nrow), squeeze=False)
    for a, ((method, chans), g) in zip(axes.ravel(), groups):
        a.axhline(0.0, color="0.3", lw=0.8)
        for load, gl in g.groupby("load", sort=False):
            marker, colour = _LOAD_STYLE.get(load, ("x", "0.4"))
            a.scatter(gl["leak_lpm"], gl["pct_change_signed"], marker=marker, color=colour,
                      s=22, label=f"load {load}", alpha=0.8)
        if thesis_ranges is not None:
            r = thesis_ranges[(thesis_ranges.method == method)
                              & (thesis_ranges.channels == chans)]
            if len(r) and np.isfinite(r.thesis_min_pct.iloc[0]):
                lo, hi = r.thesis_min_pct.iloc[0], r.thesis_max_pct.iloc[0]
                a.axhspan(lo, hi, color="0.85", zorder=0, label="thesis |% change| range (±)")
                a.axhspan(-hi, -lo, color="0.85", zorder=0)
        cf = f" (cf. thesis Fig. {figures[(method, chans)]})" \
            if figures and (method, chans) in figures else ""
        a.set_title(f"{system.upper()} {method} {chans}{cf}", fontsize=9, loc="left")
        a.set_xlabel("mean leak (L/min)")
        a.set_ylabel("% change (signed)")
        a.grid(alpha=0.3)
        a.legend(fontsize=7)
    for a in axes.ravel()[n:]:
        a.set_visible(False)
    fig.tight_layout()
    return fig


def plot_moments(df, channel: str, onset: float | None = None, title: str = "",
                 unit: str = "", scale: float = 1.0):
    """The four windowed moments of a signal (Figs. 4-13 to 4-20), stacked.

    Parameters
    ----------
    df : pandas.DataFrame
        Windowed moments: a ``time`` column (or index) and one column per moment.
    channel : str
        Signal name (labels).
    onset : float, optional
        Leak onset, drawn dashed.
    title : str
        Title of the top panel.
    unit : str, default ""
        Unit the signal is drawn in (e.g. ``"kPa"``, as thesis Fig. 5-2): the mean is labelled
        in it, the variance in its square; skewness and kurtosis are labelled dimensionless.
    scale : float, default 1.0
        Factor from the signal's unit in ``df`` to ``unit`` (``1e-3`` for Pa to kPa): the mean
        is multiplied by it, the variance by its square.

    Returns
    -------
    matplotlib.figure.Figure
    """
    plt = _plt()
    factor = {"mean": scale, "variance": scale ** 2}
    label = {"mean": f"mean ({unit})" if unit else "mean",
             "variance": f"variance ({unit}²)" if unit else "variance",
             "skewness": "skewness (-)", "kurtosis": "kurtosis (-)"}
    t = df["time"].to_numpy() if "time" in df else df.index.to_numpy()
    cols = [c for c in df.columns if c != "time" and np.issubdtype(df[c].dtype, np.number)][:4]
    fig, axes = plt.subplots(len(cols), 1, figsize=(8, 1.7 * len(cols) + 0.5), sharex=True,
                             squeeze=False)
    k = max(1, len(t) // PLOT_MAX_POINTS)
    for a, c in zip(axes[:, 0], cols):
        a.plot(t[::k], df[c].to_numpy()[::k] * factor.get(c, 1.0), lw=0.7)
        if onset is not None:
            a.axvline(onset, color="tab:red", ls="--", lw=1.0)
        a.set_ylabel(label.get(c, c), fontsize=8)
        a.grid(alpha=0.3)
    axes[0, 0].set_title(title or f"windowed moments of {channel}", fontsize=9, loc="left")
    axes[-1, 0].set_xlabel("time (s)")
    fig.tight_layout()
    return fig


def plot_grid_heatmap(table, lag, title: str = ""):
    """|% change| over window x overlap at one lag (a slice of a full grid).

    Parameters
    ----------
    table : pandas.DataFrame
        Grid table (``lag`` or ``lag_ratio``, ``window``, ``overlap``, ``pct_change``).
    lag : int or str
        The lag (or ``"l:k"``) to show.
    title : str
        Title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    plt = _plt()
    key = table["lag_ratio"] if isinstance(lag, str) and ":" in lag else table["lag"]
    g = table[key.astype(str) == str(lag)]
    piv = g.pivot_table(index="overlap", columns="window", values="pct_change")
    fig, ax = plt.subplots(figsize=(7, 4))
    im = ax.imshow(piv.to_numpy(), aspect="auto", origin="lower", cmap="viridis")
    ax.set_xticks(range(len(piv.columns)))
    ax.set_xticklabels([str(c) for c in piv.columns], rotation=90, fontsize=7)
    ax.set_yticks(range(len(piv.index)))
    ax.set_yticklabels([f"{v:g}" for v in piv.index], fontsize=7)
    ax.set_xlabel("window (samples)")
    ax.set_ylabel("overlap (%)")
    ax.set_title(title or f"% change at lag {lag}", fontsize=9, loc="left")
    fig.colorbar(im, ax=ax, label="% change")
    fig.tight_layout()
    return fig


def plot_stacked(series, onset: float | None = None, titles=None, rms=None,
                 ylabel: str | None = None):
    """Stacked feature-series panels (Figs. 5-7 to 5-22 style), cheap to render.

    Like :func:`leakdiag.report.figures.plot_feature_series` but with fixed legend positions and
    no per-panel legend search, so that a report with many figures renders quickly.

    Parameters
    ----------
    series : sequence of (time, values)
        One panel each.
    onset : float, optional
        Leak onset (dashed line).
    titles : sequence of str, optional
        Panel titles.
    rms : sequence of (before, after, signed_pct) or None, optional
        Mean RMS before/after drawn as horizontal segments.
    ylabel : str, optional
        Label of every panel's y axis (the feature, e.g. ``"autocorrelation coefficient"``).

    Returns
    -------
    matplotlib.figure.Figure
    """
    plt = _plt()
    n = len(series)
    fig, axes = plt.subplots(n, 1, figsize=(8, 1.5 * n + 0.5), sharex=True, squeeze=False)
    for i, ((t, v), a) in enumerate(zip(series, axes[:, 0])):
        k = max(1, len(t) // PLOT_MAX_POINTS)
        a.plot(t[::k], v[::k], lw=0.6, color="tab:blue")
        if onset is not None:
            a.axvline(onset, color="tab:red", ls="--", lw=1.0)
        if rms is not None and rms[i] is not None and onset is not None:
            b, af, pct = rms[i]
            a.hlines(b, t[0], onset, color="k", lw=1.4)
            a.hlines(af, onset, t[-1], color="tab:orange", lw=1.4)
            a.text(0.995, 0.04, f"RMS {b:.3g} -> {af:.3g} ({pct:+.1f}%)", ha="right",
                   va="bottom", transform=a.transAxes, fontsize=7,
                   bbox={"fc": "white", "ec": "0.7", "alpha": 0.8})
        if titles is not None:
            a.set_title(titles[i], fontsize=8, loc="left")
        if ylabel:
            a.set_ylabel(ylabel, fontsize=7)
        a.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("time (s)")
    fig.tight_layout()
    return fig
