"""Folders and files of ``leakdiag benchmark``: checked before any work, earlier outputs removed.

* :func:`prepare_folder` creates ``--out`` / ``--work-dir`` / the simulation cache and writes a
  probe file into it, so that an unusable folder is refused before the suite runs, not after;
* :func:`remove_previous_outputs` deletes, from the report folder, the files an earlier
  benchmark run wrote there (by name: :data:`OUTPUT_NAMES`, :data:`FIGURE_PATTERNS`), so that
  a report never sits beside stale files of another run; other files are never touched;
* :class:`NothingJudgedError`: no held-out run was judged (every fit failed), said with the
  first error and the option that would change it.
"""

from __future__ import annotations

import re
from pathlib import Path

__all__ = ["OUTPUT_NAMES", "FIGURE_PATTERNS", "prepare_folder", "remove_previous_outputs",
           "NothingJudgedError"]

#: Files ``leakdiag benchmark`` writes into ``--out`` (suite v5 and suite v4 together: a folder
#: may hold either suite's report from an earlier run).
OUTPUT_NAMES = ("report.md", "settings.json", "summary.csv", "detection.csv",
                "false_alarms.csv", "fits.csv", "size.csv", "runs.csv.gz",  # v5
                "index.html", "results.csv", "results_by_condition.csv",
                "summary_by_condition.csv", "runs.csv", "simulations.csv")  # v4
#: Figures under ``--out/figures``: v5 ``detection_<rig>_<load>_<input>.png``, v4 the HTML
#: report's numbered ``fig-NNN.png``.
FIGURE_PATTERNS = (re.compile(r"detection_[A-Za-z0-9]+_[A-Za-z0-9]+_[A-Za-z0-9]+\.png"),
                   re.compile(r"fig-\d{3,}\.png"))


class NothingJudgedError(RuntimeError):
    """No held-out run of the benchmark was judged (every method failed to fit, or to judge)."""


def prepare_folder(path, option: str) -> Path:
    """Create a folder the benchmark will write to and check that a file can be written there
    (:func:`leakdiag.runtime.paths.prepare_out_dir`, as ``reproduce`` does).

    Parameters
    ----------
    path : path-like
        The folder (created with its parents).
    option : str
        How the user named it (e.g. ``"--out"``), for the message.

    Returns
    -------
    pathlib.Path
        The folder.

    Raises
    ------
    ValueError
        The one-line message of ``prepare_out_dir`` (the benchmark's errors are ValueErrors).

    Examples
    --------
    >>> import tempfile
    >>> prepare_folder(Path(tempfile.mkdtemp()) / "a" / "b", "--out").is_dir()
    True
    """
    from leakdiag.runtime.paths import prepare_out_dir

    try:
        return prepare_out_dir(path, option)
    except OSError as exc:
        raise ValueError(str(exc)) from None


def remove_previous_outputs(out) -> list[str]:
    """Delete the files an earlier benchmark run wrote into a report folder.

    Only files named as the benchmark names its outputs (:data:`OUTPUT_NAMES` in the folder,
    :data:`FIGURE_PATTERNS` in its ``figures/``) are removed; an emptied ``figures/`` is removed
    too. Everything else (notes, scripts, other folders) stays.

    Parameters
    ----------
    out : path-like
        Report folder (``--out``).

    Returns
    -------
    list of str
        Removed files, relative to ``out``, sorted.

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> for name in ("summary.csv", "notes.txt"):
    ...     _ = (d / name).write_text("x")
    >>> remove_previous_outputs(d), sorted(p.name for p in d.iterdir())
    (['summary.csv'], ['notes.txt'])
    """
    out = Path(out)
    removed = []
    for name in OUTPUT_NAMES:
        f = out / name
        if f.is_file() or f.is_symlink():
            f.unlink()
            removed.append(name)
    figs = out / "figures"
    if figs.is_dir():
        for f in sorted(figs.iterdir()):
            if f.is_file() and any(p.fullmatch(f.name) for p in FIGURE_PATTERNS):
                f.unlink()
                removed.append(f"figures/{f.name}")
        if not any(figs.iterdir()):
            figs.rmdir()
    return sorted(removed)
