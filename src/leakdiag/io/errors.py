"""The error of bad recording input (its own module so that every reader and check can raise it
without importing :mod:`leakdiag.io.recording`)."""

from __future__ import annotations

__all__ = ["RecordingError"]


class RecordingError(ValueError):
    """Bad recording input; the message names the file, channel, row or window and the problem."""
