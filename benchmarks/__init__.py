"""Benchmarks run by ``make bench`` (``pytest benchmarks``); see ``benchmarks/harness.py``."""
