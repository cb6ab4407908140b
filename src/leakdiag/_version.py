"""Version of leakdiag (one place, read by caches and recording metadata)."""

__version__ = "0.1.0"
