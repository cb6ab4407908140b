"""Recordings in and out: the :class:`Recording` model, readers and writers."""

from leakdiag.io.recording import STANDARD_CHANNELS, Recording, RecordingError

__all__ = ["Recording", "RecordingError", "STANDARD_CHANNELS"]
