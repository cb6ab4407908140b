"""Position reference signals for closed-loop simulations (thesis Sec. 4.5, 5.1).

Every reference is a frozen dataclass with ``samples(time, rng) -> x_ref`` (metres) so that a
simulator can take any of them; :func:`as_reference` also accepts a plain array of samples or a
file. The thesis excites the actuator with "a series of desired step inputs having amplitudes
between 2 mm to 18 mm" (Sec. 4.5; 2-20 mm in case study 3, Sec. 5.1).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np

from leakdiag._validation import as_1d_float, check_finite, check_positive

__all__ = [
    "Reference",
    "PseudoRandomSteps",
    "SineReference",
    "ChirpReference",
    "SampledReference",
    "as_reference",
]


class Reference(Protocol):
    """Anything with ``samples(time, rng) -> numpy.ndarray`` (reference position in m)."""

    def samples(self, time: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Reference position (m) at each time (s)."""


@dataclass(frozen=True)
class PseudoRandomSteps:
    """Pseudorandom step sequence: random levels held for random times (Sec. 4.5).

    Parameters
    ----------
    min_amplitude_m : float, default 2e-3
        Smallest step level magnitude (Sec. 5.1 case study 3: 2 mm).
    max_amplitude_m : float, default 20e-3
        Largest step level magnitude (Sec. 5.1 case study 3: 20 mm).
    min_hold_s : float, default 1.0
        Shortest hold time of a level.
    max_hold_s : float, default 5.0
        Longest hold time (the thesis does not give hold times; Figs. 5-1 and 5-3 show a few
        steps in a 20 s close-up, so 1-5 s is used).
    bipolar : bool, default True
        Draw a random sign for each level, so the piston moves both ways about the centre (and
        a spring load changes between compression and extension, Sec. 4.5, Fig. 4-8).

    Notes
    -----
    Level magnitudes are uniform in ``[min_amplitude_m, max_amplitude_m]`` and hold times
    uniform in ``[min_hold_s, max_hold_s]``; the sequence starts at the first drawn level at
    ``t = 0``. The draws depend only on ``rng``, so the same seed gives the same sequence.

    Examples
    --------
    >>> ref = PseudoRandomSteps()
    >>> x = ref.samples(np.arange(0, 100, 0.01), np.random.default_rng(1))
    >>> bool(np.all((np.abs(x) >= 2e-3) & (np.abs(x) <= 20e-3)))
    True
    """

    min_amplitude_m: float = 2e-3
    max_amplitude_m: float = 20e-3
    min_hold_s: float = 1.0
    max_hold_s: float = 5.0
    bipolar: bool = True

    def __post_init__(self) -> None:
        lo = float(self.min_amplitude_m)
        if not np.isfinite(lo) or lo < 0:
            raise ValueError(f"min_amplitude_m={self.min_amplitude_m!r} must be >= 0")
        if not self.max_amplitude_m >= lo:
            raise ValueError(
                f"max_amplitude_m={self.max_amplitude_m!r} must be >= min_amplitude_m={lo!r}"
            )
        check_positive(self.min_hold_s, "min_hold_s")
        if not self.max_hold_s >= self.min_hold_s:
            raise ValueError(
                f"max_hold_s={self.max_hold_s!r} must be >= min_hold_s={self.min_hold_s!r}"
            )

    def samples(self, time: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Reference position (m) at each time (s), see class notes.

        Parameters
        ----------
        time : numpy.ndarray
            Sample times in s, 1-D.
        rng : numpy.random.Generator
            Draws the hold times and levels.

        Returns
        -------
        numpy.ndarray
            Reference position in m, same shape as ``time``.
        """
        t = as_1d_float(time, "time")
        out = np.empty_like(t)
        if t.size == 0:
            return out
        span = t[-1] - t[0]
        n_max = int(np.ceil(span / self.min_hold_s)) + 2
        holds = rng.uniform(self.min_hold_s, self.max_hold_s, n_max)
        levels = rng.uniform(self.min_amplitude_m, self.max_amplitude_m, n_max)
        if self.bipolar:
            levels = levels * rng.choice(np.array([-1.0, 1.0]), n_max)
        edges = t[0] + np.cumsum(holds)
        idx = np.searchsorted(edges, t, side="right")
        out[:] = levels[np.minimum(idx, n_max - 1)]
        return out


@dataclass(frozen=True)
class SineReference:
    """Sinusoidal reference ``offset + amplitude * sin(2 pi f t)``.

    Parameters
    ----------
    amplitude_m : float, default 10e-3
        Amplitude in m.
    frequency_hz : float, default 0.5
        Frequency in Hz.
    offset_m : float, default 0.0
        Mean position in m.

    Examples
    --------
    >>> SineReference(1.0, 0.25).samples(np.array([0.0, 1.0]), None).round(12).tolist()
    [0.0, 1.0]
    """

    amplitude_m: float = 10e-3
    frequency_hz: float = 0.5
    offset_m: float = 0.0

    def samples(self, time: np.ndarray, rng: np.random.Generator | None) -> np.ndarray:
        """Reference position (m) at each time (s); ``rng`` is unused.

        Parameters
        ----------
        time : numpy.ndarray
            Sample times in s, 1-D.
        rng : numpy.random.Generator or None
            Unused (deterministic reference).

        Returns
        -------
        numpy.ndarray
            Reference position in m, same shape as ``time``.
        """
        t = as_1d_float(time, "time")
        return self.offset_m + self.amplitude_m * np.sin(2 * np.pi * self.frequency_hz * t)


@dataclass(frozen=True)
class ChirpReference:
    """Linear chirp from ``f0_hz`` to ``f1_hz`` over ``duration_s``, then held at ``f1_hz``.

    Parameters
    ----------
    amplitude_m : float, default 5e-3
        Amplitude in m.
    f0_hz, f1_hz : float, default 0.1, 5.0
        Start and end frequencies in Hz.
    duration_s : float, default 100.0
        Sweep duration in s.

    Notes
    -----
    Phase :math:`\\phi(t) = 2\\pi (f_0 t + (f_1 - f_0) t^2 / (2 T))` for :math:`t \\le T`.

    Examples
    --------
    >>> ChirpReference(1.0, 1.0, 1.0, 10.0).samples(np.array([0.25]), None).round(12).tolist()
    [1.0]
    """

    amplitude_m: float = 5e-3
    f0_hz: float = 0.1
    f1_hz: float = 5.0
    duration_s: float = 100.0

    def samples(self, time: np.ndarray, rng: np.random.Generator | None) -> np.ndarray:
        """Reference position (m) at each time (s); ``rng`` is unused.

        Parameters
        ----------
        time : numpy.ndarray
            Sample times in s, 1-D.
        rng : numpy.random.Generator or None
            Unused (deterministic reference).

        Returns
        -------
        numpy.ndarray
            Reference position in m, same shape as ``time``.
        """
        t = as_1d_float(time, "time")
        T = check_positive(self.duration_s, "duration_s")
        k = (self.f1_hz - self.f0_hz) / T
        tc = np.minimum(t, T)
        phase = 2 * np.pi * (self.f0_hz * tc + 0.5 * k * tc**2) + 2 * np.pi * self.f1_hz * (t - tc)
        return self.amplitude_m * np.sin(phase)


@dataclass(frozen=True)
class SampledReference:
    """A reference given as samples at the simulation's output rate (e.g. from a file).

    Parameters
    ----------
    values_m : numpy.ndarray
        Reference position in m, one value per output sample; shorter arrays are held at
        their last value, longer ones truncated.

    Examples
    --------
    >>> SampledReference(np.array([1.0, 2.0])).samples(np.zeros(3), None).tolist()
    [1.0, 2.0, 2.0]
    """

    values_m: np.ndarray

    def samples(self, time: np.ndarray, rng: np.random.Generator | None) -> np.ndarray:
        """The stored samples, held or truncated to ``len(time)``; ``rng`` is unused.

        Parameters
        ----------
        time : numpy.ndarray
            Sample times in s, 1-D (only its length is used).
        rng : numpy.random.Generator or None
            Unused.

        Returns
        -------
        numpy.ndarray
            Reference position in m, ``len(time)`` values.

        Raises
        ------
        ValueError
            If the stored reference is empty or not finite.
        """
        t = as_1d_float(time, "time")
        v = as_1d_float(self.values_m, "reference")
        if v.size == 0:
            raise ValueError("reference holds no samples")
        check_finite(v, "reference")
        if v.size >= t.size:
            return v[: t.size].copy()
        return np.concatenate([v, np.full(t.size - v.size, v[-1])])


def as_reference(ref) -> Reference:
    """Turn a reference specification into a :class:`Reference`.

    Parameters
    ----------
    ref : None, Reference, array_like, str or pathlib.Path
        ``None``: :class:`PseudoRandomSteps` defaults. An object with ``samples``: itself. An
        array: :class:`SampledReference` (metres). A path: a ``.npy`` file, or a CSV/Parquet
        file with an ``x_ref`` column (metres), read into :class:`SampledReference`.

    Returns
    -------
    Reference

    Raises
    ------
    ValueError
        If a file has no ``x_ref`` column or the suffix is unknown.
    FileNotFoundError
        If a path does not exist.

    Examples
    --------
    >>> type(as_reference(None)).__name__
    'PseudoRandomSteps'
    >>> type(as_reference([0.0, 1e-3])).__name__
    'SampledReference'
    """
    if ref is None:
        return PseudoRandomSteps()
    if hasattr(ref, "samples"):
        return ref
    if isinstance(ref, (str, Path)):
        path = Path(ref)
        if not path.exists():
            raise FileNotFoundError(f"reference file {path} does not exist")
        suffix = path.suffix.lower()
        if suffix == ".npy":
            return SampledReference(np.load(path))
        if suffix in (".csv", ".parquet"):
            import pandas as pd

            df = pd.read_csv(path) if suffix == ".csv" else pd.read_parquet(path)
            if "x_ref" not in df.columns:
                raise ValueError(f"{path}: no 'x_ref' column; columns are {list(df.columns)}")
            return SampledReference(df["x_ref"].to_numpy(dtype=np.float64))
        raise ValueError(f"{path}: unknown reference file type {suffix!r} (.npy, .csv, .parquet)")
    return SampledReference(as_1d_float(ref, "reference"))
