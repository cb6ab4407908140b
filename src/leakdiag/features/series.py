"""The :class:`FeatureSeries`: one value per window, with the window's timestamp."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["FeatureSeries"]


@dataclass(frozen=True)
class FeatureSeries:
    """A windowed feature as a time series (one value per window, Sec. 4.4).

    Parameters
    ----------
    time : numpy.ndarray
        Timestamp of each window in seconds (or samples when ``sample_rate=1``), shape ``(m,)``.
        Convention: the time of the window's **last** sample, i.e. the moment its value is
        known (see ``docs/features.md``).
    values : numpy.ndarray
        Feature value per window, shape ``(m,)``; NaN where the window is degenerate
        (zero variance).
    name : str
        Feature name, e.g. ``"autocorrelation"``.
    params : dict
        Settings that produced it (``lag``, ``window``, ``overlap``, ``channels``, ...).

    Examples
    --------
    >>> fs = FeatureSeries(np.array([0.1, 0.2]), np.array([1.0, 0.5]), "demo", {})
    >>> fs.to_pandas().tolist()
    [1.0, 0.5]
    """

    time: np.ndarray
    values: np.ndarray
    name: str = "feature"
    params: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if np.shape(self.time) != np.shape(self.values):
            raise ValueError(
                f"time and values must have the same shape, got {np.shape(self.time)} "
                f"and {np.shape(self.values)}"
            )

    def __len__(self) -> int:
        return len(self.values)

    @property
    def n_windows(self) -> int:
        """Number of windows (int)."""
        return len(self.values)

    def to_pandas(self):
        """Return the series as a :class:`pandas.Series` indexed by time in seconds.

        Returns
        -------
        pandas.Series
            Values indexed by ``time``; the series name is the feature name.
        """
        import pandas as pd

        return pd.Series(self.values, index=pd.Index(self.time, name="time"), name=self.name)
