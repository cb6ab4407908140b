"""Numba kernels shared by the windowed features (compute only: no checks, no warnings).

``blocksums`` (anchored block sums of Eq. 4.1-4.2 for any window starts), ``stepsums``
(step-increment kernels for short steps), ``smalllag`` (short-lag variants), ``values`` (the
per-window formulas) and ``chunks`` (chunking constants and window times). See
``docs/features.md``, "Numerical method and accuracy".
"""
