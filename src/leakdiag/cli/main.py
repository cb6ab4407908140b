"""The ``leakdiag`` command line.

Sub-commands live in one module each under :mod:`leakdiag.cli` and are loaded lazily, so that
``leakdiag --help`` is fast. To add a command, add its ``"name": "module:function"`` to
:data:`COMMANDS`.
"""

from __future__ import annotations

import importlib
import sys
import warnings

import click

from leakdiag._version import __version__

__all__ = ["main", "COMMANDS"]

#: Sub-command name -> "module:attribute" of its click command.
COMMANDS: dict[str, str] = {
    "analyze": "leakdiag.cli.analyze:analyze",
    "demo": "leakdiag.cli.demo:demo",
    "simulate": "leakdiag.cli.simulate:simulate",
    "monitor": "leakdiag.cli.monitor:monitor",
    "batch": "leakdiag.cli.batch:batch",
    "benchmark": "leakdiag.cli.benchmark:benchmark",
    "detect": "leakdiag.cli.detect:detect",
    "fit": "leakdiag.cli.fit:fit",
    "dashboard": "leakdiag.cli.dashboard:dashboard",
    "sweep": "leakdiag.cli.sweep:sweep",
    "sensitivity": "leakdiag.cli.sensitivity:sensitivity",
    "reproduce": "leakdiag.cli.reproduce:reproduce",
}


_ARGV: list[str] | None = None  # arguments of the current main() call (for the notice below)
#: Commands that run the Numba feature kernels (a first run compiles them, ~15 s, then cached).
_KERNEL_COMMANDS = {"analyze", "demo", "detect", "fit", "monitor", "sweep", "batch", "reproduce",
                    "sensitivity", "benchmark"}


def _kernels_cached() -> bool:
    """True when Numba's on-disk cache of the feature kernels exists for this code (in the
    folder :mod:`leakdiag._numba_cache` names by the kernels' source)."""
    from leakdiag._numba_cache import kernel_cache_dir

    d = kernel_cache_dir()
    return d.is_dir() and any(next(p.glob("*.nbi"), None) is not None
                              for p in d.glob("features*"))


def _stderr_is_terminal() -> bool:
    """The compilation notice is for people at a terminal, not for logs and scripts."""
    return bool(getattr(sys.stderr, "isatty", lambda: False)())


class _LazyGroup(click.Group):
    def list_commands(self, ctx):
        return sorted(COMMANDS)

    def get_command(self, ctx, cmd_name):
        target = COMMANDS.get(cmd_name)
        if target is None:
            return None
        args = _ARGV or []
        if cmd_name in _KERNEL_COMMANDS and not {"-h", "--help"} & set(args) \
                and _stderr_is_terminal() and not _kernels_cached():
            click.echo("leakdiag: first run: compiling the feature kernels (about 15 s, once; "
                       "cached afterwards)...", err=True)
        mod, attr = target.split(":")
        return getattr(importlib.import_module(mod), attr)


@click.group(cls=_LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="leakdiag")
def cli() -> None:
    """leakdiag: internal leakage diagnosis of hydraulic actuators (VCA and EHA)."""


def _format_warning(message, category, filename, lineno, line=None) -> str:
    """One-line warnings for terminal users (no source line of leakdiag's code)."""
    return f"leakdiag: warning: {message}\n"


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; bad input becomes a one-line error on stderr and exit code 2.

    Parameters
    ----------
    argv : list of str, optional
        Arguments (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit code: 0 on success, 2 for bad input (``ValueError``, ``TypeError``, ``KeyError``,
        ``OSError`` or a leakdiag ``RuntimeError`` such as a leak that cannot be calibrated),
        click's own code for usage errors, 1 when aborted or when a command exits with 1
        (``leakdiag batch`` with error rows).

    Examples
    --------
    >>> main(["--version"])  # doctest: +ELLIPSIS
    leakdiag, version ...
    0
    """
    global _ARGV
    warnings.formatwarning = _format_warning
    _ARGV = list(sys.argv[1:] if argv is None else argv)
    try:
        code = cli.main(args=argv, prog_name="leakdiag", standalone_mode=False)
    except click.exceptions.Abort:
        click.echo("Aborted.", err=True)
        return 1
    except click.ClickException as exc:
        exc.show()
        return exc.exit_code
    except (ValueError, TypeError, KeyError, OSError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        click.echo(f"leakdiag: error: {msg}", err=True)
        return 2
    except RuntimeError as exc:
        if not type(exc).__module__.startswith("leakdiag."):
            raise  # a bug, not bad input: keep the traceback
        click.echo(f"leakdiag: error: {exc}", err=True)  # e.g. sim.leak.LeakCalibrationError
        return 2
    # click returns the code of a ``click.exceptions.Exit`` (e.g. batch with error rows)
    return code if isinstance(code, int) and not isinstance(code, bool) else 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
