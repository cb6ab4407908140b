"""Benchmarks run by ``make bench`` (``pytest perf``); see ``perf/harness.py``."""
