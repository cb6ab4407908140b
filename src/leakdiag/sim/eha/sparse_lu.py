"""Sparse elimination of the EHA's Rosenbrock matrix :math:`W = I - \\gamma h J`: plan and code.

Every ROS2 step (:mod:`leakdiag.sim.eha.integrate`) factorises :math:`W` once and solves with
it twice. :math:`J`, the Jacobian of Eqs. 3-1 to 3-19 (:mod:`leakdiag.sim.eha.jacobian`), has
33 structural non-zeros of 81 (:data:`JACOBIAN_PATTERN`: each state depends on a few others).
Eliminated in the order :data:`ELIMINATION_ORDER` (speed-loop integral, current, speed, line
pressures, chamber pressures, position, velocity; of all 9! orders one with the fewest
operations) the factors gain 5 fill-ins, and a factorisation costs 9 reciprocals, 12
multiplications and 31 multiply-subtracts instead of the dense LU's 9 divisions, 36
multiplications and 204 multiply-subtracts; a solve 31 multiply-subtracts instead of 72.

The elimination does **not pivot**. The former dense LU pivoted on raw magnitudes, and those
mix units (Pa with m and A): measured on states of open- and closed-loop runs with and without
a leak and the spring (every 7th sample of 20 s, steps of 1e-6 to 1e-3 s), its solutions were
off by up to 1.8e-6 of the solution's largest scaled component (states in the integrator's
units, ``_STATE_SCALE``), the elimination in this order without pivoting by 2.4e-14, and its
smallest pivot on those states was 0.046. A pivot of magnitude below :data:`PIVOT_FLOOR` (or
not finite) makes the factorisation report failure, and the integrator then falls back to the
dense LU with partial pivoting for that step (``Solution.n_dense`` counts them: 1 step of
221,000 in a 60-s closed-loop run of unit 5 with the spring and a 0.5 L/min leak, none in the
open-loop runs looked at).

The kernels are straight-line code generated from the plan (:func:`generate_source`) into
``_sparse_lu_kernel.py``, which is committed. To regenerate it after a change of the pattern
or the order, write ``generate_source()`` to a temporary file and move that over the module
(the package imports the kernel, so the module must not be truncated first)::

    python -c "from leakdiag.sim.eha.sparse_lu import generate_source as g; print(g(), end='')" \\
        > /tmp/k.py && mv /tmp/k.py src/leakdiag/sim/eha/_sparse_lu_kernel.py

A test checks that the committed file is what the plan generates. A Jacobian entry outside
:data:`JACOBIAN_PATTERN` would be ignored by the sparse factorisation, so another test checks
the pattern against :func:`~leakdiag.sim.eha.jacobian._jacobian_into` on many states.
"""

from __future__ import annotations

from leakdiag.sim.eha.model import S_I, S_P1, S_P2, S_PA, S_PB, S_V, S_W, S_X, S_Z, STATE_NAMES

__all__ = ["JACOBIAN_PATTERN", "ELIMINATION_ORDER", "PIVOT_FLOOR", "elimination_plan",
           "generate_source"]

#: Structural non-zeros of the EHA Jacobian, row state -> column states (``jacobian.py``: the
#: only entries it writes after zeroing the matrix; closed loop and the end stops included).
JACOBIAN_PATTERN: dict[int, tuple[int, ...]] = {
    S_X: (S_V,),
    S_V: (S_X, S_V, S_P1, S_P2),
    S_P1: (S_X, S_V, S_P1, S_P2, S_PA),
    S_P2: (S_X, S_V, S_P1, S_P2, S_PB),
    S_PA: (S_P1, S_PA, S_PB, S_W),
    S_PB: (S_P2, S_PA, S_PB, S_W),
    S_I: (S_X, S_I, S_W, S_Z),
    S_W: (S_PA, S_PB, S_I, S_W),
    S_Z: (S_X, S_W),
}

#: Pivot order of the elimination: the fewest operations (factorisation plus two solves) of all
#: orders of the nine states, for :data:`JACOBIAN_PATTERN`.
ELIMINATION_ORDER: tuple[int, ...] = (S_Z, S_I, S_W, S_PA, S_PB, S_P1, S_P2, S_X, S_V)

#: Smallest pivot magnitude the sparse elimination accepts (pivots of W are dimensionless: a
#: diagonal scaling of the states leaves them unchanged); the pivots measured on run states
#: (module docstring) were >= 0.046.
PIVOT_FLOOR = 1e-3


def elimination_plan(pattern: dict[int, tuple[int, ...]] = JACOBIAN_PATTERN,
                     order: tuple[int, ...] = ELIMINATION_ORDER):
    """Symbolic LU factorisation of ``I - c J`` for a Jacobian pattern, without pivoting.

    Parameters
    ----------
    pattern : dict of int to tuple of int, default JACOBIAN_PATTERN
        Structural non-zeros of J per row.
    order : tuple of int, default ELIMINATION_ORDER
        The pivots, a permutation of the states.

    Returns
    -------
    entries : list of (int, int)
        The entries of J (plus the diagonal) in row-major order: the ones W is built from.
    fill : list of (int, int)
        Entries that are zero in W and become non-zero in the factors.
    steps : list of (int, list of int, list of int)
        Per pivot ``k`` in order: the rows below it (later in ``order``) with a non-zero in
        column ``k``, and the columns right of it with a non-zero in row ``k``.

    Examples
    --------
    >>> _, fill, steps = elimination_plan({0: (1,), 1: (0,)}, (0, 1))
    >>> fill, steps
    ([], [(0, [1], [1]), (1, [], [])])
    """
    n = len(order)
    nz = {(r, c) for r, cols in pattern.items() for c in cols} | {(r, r) for r in range(n)}
    entries = sorted(nz)
    filled = set(nz)
    fill, steps = [], []
    for i, k in enumerate(order):
        later = order[i + 1:]
        rows = [r for r in later if (r, k) in filled]
        cols = [c for c in later if (k, c) in filled]
        for r in rows:
            for c in cols:
                if (r, c) not in filled:
                    filled.add((r, c))
                    fill.append((r, c))
        steps.append((k, rows, cols))
    return entries, fill, steps


def generate_source() -> str:
    """Source of ``_sparse_lu_kernel.py``: the factorisation and solve of the plan.

    Returns
    -------
    str
        A Python module defining ``_w_factor(jac, gh, a, floor) -> bool`` (writes the factors
        of ``I - gh * jac`` into ``a``, the pivots' reciprocals on its diagonal; False when a
        pivot's magnitude is below ``floor`` (:data:`PIVOT_FLOOR`) or not finite, ``a`` is then
        partly written) and
        ``_w_solve(a, b)`` (solves in place with those factors).
    """
    entries, fill, steps = elimination_plan()
    lines = [
        '"""GENERATED by leakdiag.sim.eha.sparse_lu.generate_source; do not edit.',
        '',
        'Sparse LU without pivoting of W = I - gh J for the EHA (see that module)."""',
        "",
        "import numba",
        "",
        "",
        '@numba.njit(cache=True, error_model="numpy", inline="always")',
        "def _w_factor(jac, gh, a, floor):",
        f"    # W = I - gh J on the {len(entries)} entries of the pattern, then the "
        f"{len(fill)} fill-ins",
    ]
    for r, c in entries:
        lines.append(f"    a[{r}, {c}] = 1.0 - gh * jac[{r}, {c}]" if r == c else
                     f"    a[{r}, {c}] = -gh * jac[{r}, {c}]")
    for r, c in fill:
        lines.append(f"    a[{r}, {c}] = 0.0")
    for k, rows, cols in steps:
        lines.append(f"    # pivot {STATE_NAMES[k]}")
        lines.append(f"    d = a[{k}, {k}]")
        lines.append("    if not abs(d) >= floor:  # also NaN")
        lines.append("        return False")
        lines.append("    inv = 1.0 / d")
        lines.append(f"    a[{k}, {k}] = inv")
        for r in rows:
            lines.append(f"    f = a[{r}, {k}] * inv")
            lines.append(f"    a[{r}, {k}] = f")
            for c in cols:
                lines.append(f"    a[{r}, {c}] -= f * a[{k}, {c}]")
    lines += ["    return True", "", "",
              '@numba.njit(cache=True, error_model="numpy", inline="always")',
              "def _w_solve(a, b):",
              "    # forward: L (unit diagonal) by columns in pivot order"]
    for k, rows, _ in steps:
        for r in rows:
            lines.append(f"    b[{r}] -= a[{r}, {k}] * b[{k}]")
    lines.append("    # backward: U by rows in reverse pivot order (reciprocal pivots)")
    for k, _, cols in reversed(steps):
        terms = "".join(f" - a[{k}, {c}] * b[{c}]" for c in cols)
        lines.append(f"    b[{k}] = (b[{k}]{terms}) * a[{k}, {k}]")
    lines.append("")
    return "\n".join(lines)
