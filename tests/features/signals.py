"""Test signals for the feature tests: each one stresses a different numerical weakness."""

from __future__ import annotations

import numpy as np

SUPPLY_LEVEL_PA = 8.6e6  # order of the VCA chamber pressures (Ch. 2): the large-offset case


def make_signals(n: int = 2400, seed: int = 1) -> dict[str, np.ndarray]:
    """Named float64 signals of length ``n``."""
    rng = np.random.default_rng(seed)
    t = np.arange(n)
    levels = np.repeat(rng.integers(0, 6, n // 150 + 1), 150)[:n]
    return {
        "random": rng.normal(size=n),
        "sine": np.sin(2 * np.pi * t / 97.0) + 0.01 * rng.normal(size=n),
        "constant_plus_noise": 5.0 + 1e-3 * rng.normal(size=n),
        # 8.6 MPa varying by kPa: naive prefix sums of x and x^2 lose ~10 digits here
        "large_offset": SUPPLY_LEVEL_PA + 2e3 * np.sin(2 * np.pi * t / 500.0)
        + 1e3 * rng.normal(size=n),
        # level steps of 50 kPa every 150 samples on top of 8.6 MPa with kPa noise
        "level_steps": SUPPLY_LEVEL_PA + 5e4 * levels + 1e3 * rng.normal(size=n),
    }


# (window, overlap %, lag) triples; overlap 99.5 at N=200 is step 1, 99 at N=37 is step 1
SETTINGS = [
    (200, 5.0, 1),
    (200, 99.0, 1),
    (200, 99.5, 17),
    (37, 99.0, 36),
    (64, 0.0, 3),
    (100, 50.0, 10),
    (500, 95.0, 250),
    (2, 0.0, 1),
]
