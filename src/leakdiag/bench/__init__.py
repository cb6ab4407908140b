"""The detection benchmark (``leakdiag benchmark``): a fixed, seeded, versioned suite of simulated
experiments, a registry of detection methods, scoring (ROC AUC, detection and false-alarm rates,
minimum detectable leak, onset error, detection delay) and an HTML report.

Sub-modules: :mod:`~leakdiag.bench.suite` (the cases), :mod:`~leakdiag.bench.registry` (methods by
name), :mod:`~leakdiag.bench.scoring` (metrics), :mod:`~leakdiag.bench.run` (orchestration),
:mod:`~leakdiag.bench.report` (tables and figures).
"""

__all__: list[str] = []
