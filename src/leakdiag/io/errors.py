"""The error of bad recording input (its own module so that every reader and check can raise it
without importing :mod:`leakdiag.io.recording`)."""

from __future__ import annotations

__all__ = ["RecordingError", "CutLastRowWarning"]


class RecordingError(ValueError):
    """Bad recording input; the message names the file, channel, row or window and the problem."""


class CutLastRowWarning(UserWarning):
    """A delimited text file's last row has fewer fields than the header but every column
    read: it is read (a file cut while it was written or copied loses the end of its last
    line), and said, since the file may hold only part of the recording (a CLI audit,
    2026-11-29: a CSV cut in half was judged NO LEAK without a word)."""

