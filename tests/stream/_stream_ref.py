"""Plain per-window reference implementations of Eq. 4.1-4.3 (slow, obviously correct)."""

import numpy as np

from leakdiag.features.windowing import window_starts, window_times


def windows(n, window, overlap):
    return window_starts(n, window, overlap)


def ac_ref(x, lag, window, overlap):
    out = []
    for s in windows(len(x), window, overlap):
        w = np.asarray(x[s:s + window], dtype=float)
        if np.all(w == w[0]):
            out.append(np.nan)
            continue
        d = w - w.mean()
        out.append(np.sum(d[:window - lag] * d[lag:]) / np.sum(d * d))
    return np.array(out)


def cc_ref(y, x, lag, window, overlap):
    out = []
    for s in windows(len(x), window, overlap):
        wy = np.asarray(y[s:s + window], dtype=float)
        wx = np.asarray(x[s:s + window], dtype=float)
        if np.all(wy == wy[0]) or np.all(wx == wx[0]):
            out.append(np.nan)
            continue
        dy, dx = wy - wy.mean(), wx - wx.mean()
        num = np.sum(dy[:window - lag] * dx[lag:]) / window
        out.append(num / np.sqrt(np.var(wx) * np.var(wy)))
    return np.array(out)


def mlr_ref(x, ell, k, window, overlap):
    x = np.asarray(x, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    out = []
    for s in windows(len(x), window, overlap):
        w = x[s:s + window]
        n = window - ell
        num = np.linalg.norm(w[k:k + n] - w[:n], axis=1).sum()
        den = np.linalg.norm(w[ell:ell + n] - w[:n], axis=1).sum()
        out.append(num / den if den > 0 else np.nan)
    return np.array(out)


def times_ref(n, window, overlap, sample_rate, start_time=0.0):
    return window_times(windows(n, window, overlap), window, sample_rate, start_time)
