"""Folders and files of ``leakdiag benchmark``: checked before any work, earlier outputs removed.

* :func:`prepare_folder` creates ``--out`` / ``--work-dir`` / the simulation cache and writes a
  probe file into it, so that an unusable folder is refused before the suite runs, not after;
* :func:`earlier_outputs` (before the run) and :func:`remove_stale_outputs` (after it wrote its
  report) delete, from the report folder, the files an earlier benchmark run wrote there and
  this run did not rewrite (by name: :data:`OUTPUT_NAMES`, :data:`FIGURE_PATTERNS`; only when
  the folder's ``settings.json`` is a benchmark's), so that a report never sits beside stale
  files of another run; other files are never touched;
* :class:`NothingJudgedError`: no held-out run was judged (every fit failed), said with the
  first error and the option that would change it.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

__all__ = ["OUTPUT_NAMES", "FIGURE_PATTERNS", "prepare_folder", "earlier_outputs",
           "remove_stale_outputs", "NothingJudgedError"]

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


def _outputs(out: Path) -> list[str]:
    """Files in ``out`` named as the benchmark names its outputs, relative to ``out``."""
    found = [name for name in OUTPUT_NAMES if (out / name).is_file()]
    figs = out / "figures"
    if figs.is_dir():
        found += [f"figures/{f.name}" for f in sorted(figs.iterdir())
                  if f.is_file() and any(p.fullmatch(f.name) for p in FIGURE_PATTERNS)]
    return found


def earlier_outputs(out) -> dict[str, int] | None:
    """The outputs an earlier benchmark run left in a report folder, before this run writes.

    Parameters
    ----------
    out : path-like
        Report folder (``--out``).

    Returns
    -------
    dict or None
        Relative path -> modification time (ns) of each file named as a benchmark output; None
        when the folder holds no earlier benchmark report (no ``settings.json`` whose
        ``command`` is a ``leakdiag benchmark`` command line), so that files of another tool
        that happen to share a name (``report.md``, ``index.html``) are never removed.
    """
    out = Path(out)
    try:
        settings = json.loads((out / "settings.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not (isinstance(settings, dict)
            and str(settings.get("command", "")).startswith("leakdiag benchmark")):
        return None
    return {name: (out / name).stat().st_mtime_ns for name in _outputs(out)}


def remove_stale_outputs(out, before: dict[str, int] | None) -> list[str]:
    """After this run wrote its report: delete the earlier run's outputs it did not rewrite.

    Only files recorded by :func:`earlier_outputs` (an earlier benchmark's, by name) that this
    run left as they were are removed; an emptied ``figures/`` is removed too. Removing after
    the write means a run that fails before writing leaves the earlier report whole.

    Parameters
    ----------
    out : path-like
        Report folder (``--out``).
    before : dict or None
        :func:`earlier_outputs` taken before the run (None: nothing is removed).

    Returns
    -------
    list of str
        Removed files, relative to ``out``, sorted.

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> for name in ("settings.json", "results.csv", "notes.txt"):
    ...     _ = (d / name).write_text('{"command": "leakdiag benchmark -o d"}')
    >>> before = earlier_outputs(d)
    >>> _ = (d / "settings.json").write_text("{}")  # this run's
    >>> remove_stale_outputs(d, before), sorted(p.name for p in d.iterdir())
    (['results.csv'], ['notes.txt', 'settings.json'])
    """
    if not before:
        return []
    out = Path(out)
    removed = []
    for name, mtime in before.items():
        f = out / name
        if f.is_file() and f.stat().st_mtime_ns == mtime:
            f.unlink()
            removed.append(name)
    figs = out / "figures"
    if removed and figs.is_dir() and not any(figs.iterdir()):
        figs.rmdir()
    return sorted(removed)
