"""Resumable rows of the perf studies: one CSV per settings-and-code key, rewritten whole.

A study keys its rows by a hash of everything a row depends on (settings, the source of its row
functions, the code and library versions); :func:`resume` reads the rows of that key (a file
with other columns is discarded with a message, :func:`leakdiag.bench._workfiles.
read_or_discard`) and names the files of other keys, which are not reused; :func:`save`
rewrites the file after each new row (temporary file, atomic rename), so a cut run loses at
most the row it was computing.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd


def resume(out, key: str, columns: list[str], what: str,
           filled: tuple[str, ...] = ()) -> tuple[Path, list[dict]]:
    """The state file of ``key`` in folder ``out`` and the rows it already holds.

    Parameters
    ----------
    out : str or path-like
        The study's folder (created).
    key : str
        The rows' key (``rows-<key>.csv``).
    columns : list of str
        The columns a row file must have (exactly, in order).
    what : str
        What the rows are, for the message of a discarded file.
    filled : tuple of str, default ()
        Columns no row may leave empty (a file with one is discarded).

    Returns
    -------
    state : pathlib.Path
    rows : list of dict
    """
    from leakdiag.bench._workfiles import read_or_discard

    def read(path) -> pd.DataFrame:
        df = pd.read_csv(path)
        if list(df.columns) != list(columns):
            raise ValueError(f"columns {list(df.columns)}, not {list(columns)}")
        empty = [c for c in filled if df[c].isna().any()]
        if empty:
            raise ValueError(f"empty values in column(s) {empty}")
        return df

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    state = out / f"rows-{key}.csv"
    done = read_or_discard(state, read, what)
    rows = [] if done is None else done.to_dict("records")
    print(f"reused {len(rows)} rows from {state}" if rows else f"no rows to reuse in {state}",
          flush=True)
    others = sorted(p.name for p in out.glob("rows-*.csv") if p != state)
    if others:
        print(f"not reused (other settings or code): {', '.join(others)}", flush=True)
    return state, rows


def save(path, rows: list[dict], columns: list[str]) -> pd.DataFrame:
    """Write ``rows`` whole to ``path`` (temporary file, atomic rename).

    Parameters
    ----------
    path : str or path-like
        The CSV file.
    rows : list of dict
        The rows.
    columns : list of str
        Their columns, in order.

    Returns
    -------
    pandas.DataFrame
        The rows written.
    """
    from leakdiag.bench._workfiles import write_atomic

    df = pd.DataFrame(rows, columns=columns)
    write_atomic(path, lambda tmp: df.to_csv(tmp, index=False))
    return df


def leak_study_args(ap, argv, suites, out: str, per_size: int, first: int, what: str):
    """Parse ``argv`` with the options the leaking-run studies share (``--per-size``,
    ``--first``, ``--out``, ``--workers``, ``--systems``) and check the rigs;
    ``(args, systems)``."""
    ap.add_argument("--per-size", type=int, default=per_size)
    ap.add_argument("--first", type=int, default=first)
    ap.add_argument("--out", default=out)
    ap.add_argument("--workers", type=int, default=1,
                    help="processes judging runs (rows are written in the suite's order)")
    ap.add_argument("--systems", default=",".join(suites),
                    help=f"rigs to {what}, comma-separated (default: all)")
    args = ap.parse_args(argv)
    systems = args.systems.split(",")
    unknown = sorted(set(systems) - set(suites))
    if unknown:
        ap.error(f"--systems: unknown rig(s) {unknown}; choose from {sorted(suites)}")
    return args, systems


def run_rows(todo: list, fn, workers: int, state, rows: list[dict], columns: list[str],
             shown: str) -> None:
    """Judge ``todo`` (argument tuples of ``fn``, a module-level function) in ``workers``
    processes, in order, appending each row to ``rows`` and saving them all to ``state`` after
    each; prints the system, load, size, seed and the row's ``shown`` column per row."""
    import multiprocessing

    pool = multiprocessing.Pool(workers) if workers > 1 else None
    try:
        it = pool.imap(fn, todo) if pool else map(fn, todo)
        for (system, _, c), row in zip(todo, it):
            rows.append(row)
            save(state, rows, columns)
            print(system, c.load, c.leak_lpm, c.seed, row.get(shown, ""), flush=True)
    finally:
        if pool:
            pool.terminate()
