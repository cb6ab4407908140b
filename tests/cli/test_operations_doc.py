"""docs/operations.md's examples run as written and print what the page shows.

The set-up block (``bash``) is run command by command through :func:`leakdiag.cli.main.main`
(its ``for s in $(seq A B)`` loop and ``$(for f in GLOB; do echo --healthy $f; done)`` expanded
here), then every ``$ leakdiag ...`` line of the page's ``console`` blocks, and each line the page
prints under it must be one the command printed, with wall times ("in 0.225 s") and the page's
``...`` elisions matching anything. Two substitutions, which change the pacing and not a value:
``--replay 20x`` runs as ``--replay fast`` and ``batch`` with ``--scheduler serial``; the
dashboard's commands (servers that run until Ctrl-C) are left to ``tests/dashboard``. A
simulator or detector change that moves a number shown in the page fails this test (a docs
audit of 2026-11-26 found the page's set-up refused by ``fit`` and every number stale).
"""

import glob
import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from leakdiag.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "operations.md"


def _blocks(kind: str) -> list[str]:
    return re.findall(rf"```{kind}\n(.*?)```", PAGE.read_text(encoding="utf-8"), re.S)


def setup_commands() -> list[list[str]]:
    """The set-up block as argument lists (its loop and command substitution expanded)."""
    text = _blocks("bash")[0].replace("\\\n", " ")
    loop = re.search(r"for (\w+) in \$\(seq (\d+) (\d+)\); do\n(.*?)\ndone", text, re.S)
    cmds = []
    for line in text[:loop.start()].splitlines() if loop else text.splitlines():
        if line.strip():
            cmds.append(line)
    if loop:
        var, a, b, body = loop.group(1), int(loop.group(2)), int(loop.group(3)), loop.group(4)
        cmds += [body.strip().replace(f"${var}", str(i)) for i in range(a, b + 1)]
        cmds += [ln for ln in text[loop.end():].splitlines() if ln.strip()]
    return [shlex.split(c) for c in cmds]


def _expand(args: list[str]) -> list[str]:
    """``$(for f in GLOB; do echo --healthy $f; done)`` -> ``--healthy`` per matching file."""
    line = " ".join(args)
    m = re.search(r"\$\(for (\w+) in (\S+); do echo (\S+) \$\1; done\)", line)
    if not m:
        return args
    files = sorted(glob.glob(m.group(2)))
    assert files, f"{m.group(2)} matches nothing"
    expanded = " ".join(f"{m.group(3)} {f}" for f in files)
    return shlex.split(line[:m.start()] + expanded + line[m.end():])


def console_steps() -> list[tuple[str, list[str]]]:
    """``(command, printed lines)`` of every ``$`` line in the console blocks."""
    steps = []
    for block in _blocks("console"):
        lines = block.replace("\\\n", " ").splitlines()
        cur = None
        for line in lines:
            if line.startswith("$ "):
                cur = (line[2:].strip(), [])
                steps.append(cur)
            elif cur is not None and line.strip():
                cur[1].append(line)
            elif cur is None and line.strip():  # output without a command: fit's line
                steps.append(("(set-up)", [line]))
    return steps


def _pattern(expected: str) -> re.Pattern:
    """The page's line as a regex: ``...`` elides, wall times and job digests vary (the digest
    hashes the detector file's absolute path)."""
    out = []
    for i, p in enumerate(re.split(r"(\.\.\.|in [0-9.]+ s\b|job [0-9a-f]{16})",
                                   expected.strip())):
        if i % 2 == 0:
            out.append(re.escape(p))
        elif p == "...":
            out.append(".*")
        elif p.startswith("job "):
            out.append("job [0-9a-f]{16}")
        else:
            out.append(r"in [0-9.]+ s")
    return re.compile("".join(out) + "$")


def _assert_printed(cmd: str, expected: list[str], printed: list[str]) -> None:
    for line in expected:
        pat = _pattern(line)
        assert any(pat.match(p.strip()) for p in printed), (
            f"docs/operations.md shows for `{cmd}`:\n  {line}\nbut it printed:\n  "
            + "\n  ".join(printed[:40]))


def _run(args: list[str], capsys) -> list[str]:
    args = ["fast" if a == "20x" else a for a in args]
    if args[0] == "batch" and "--scheduler" not in args:
        args = [*args, "--scheduler", "serial", "--no-progress"]
    code = main(args)
    out = capsys.readouterr()
    printed = (out.out + out.err).splitlines()
    ok = 1 if args[0] == "batch" and "broken" in " ".join(printed) else 0
    assert code == ok, f"leakdiag {' '.join(args)} -> {code}\n" + "\n".join(printed[-30:])
    return printed


def test_setup_block_is_the_expected_one():
    cmds = setup_commands()
    assert [c[1] for c in cmds] == ["simulate"] * 15 + ["fit"]
    assert sum(c[1] == "simulate" and "300" in c for c in cmds) == 12


@pytest.mark.filterwarnings("ignore:.*have zero variance")
def test_operations_page_runs_as_written_and_prints_what_it_shows(tmp_path, monkeypatch,
                                                                  capsys):
    monkeypatch.chdir(tmp_path)
    printed_setup: list[str] = []
    for args in setup_commands():
        assert args[0] == "leakdiag"
        printed_setup += _run(_expand(args[1:]), capsys)
    (tmp_path / "job.toml").write_text(_blocks("toml")[0], encoding="utf-8")
    steps = console_steps()
    assert sum(cmd.startswith("leakdiag ") for cmd, _ in steps) >= 5
    for cmd, expected in steps:
        if "--dashboard" in cmd or cmd.startswith("leakdiag dashboard"):
            continue  # servers (until Ctrl-C): the browser tests of tests/dashboard run them
        if cmd == "(set-up)":
            _assert_printed("leakdiag fit", expected, printed_setup)
        elif cmd.startswith("leakdiag "):
            _assert_printed(cmd, expected, _run(shlex.split(cmd)[1:], capsys))
        elif cmd.startswith(("head ", "tail ")):
            tool, n, name = shlex.split(cmd)
            lines = (tmp_path / name).read_text(encoding="utf-8").splitlines()
            k = int(n.lstrip("-"))
            got = lines[:k] if tool == "head" else lines[-k:]
            assert len(got) == len(expected)
            for g, e in zip(got, expected):  # values to the page's 1e-9 (docs: "to about 1e-9")
                g, e = json.loads(g), json.loads(e)
                assert g.keys() == e.keys()
                for key in g:
                    assert g[key] == (pytest.approx(e[key], rel=1e-9)
                                      if isinstance(e[key], float) else e[key]), key
        elif cmd.startswith("echo "):
            text, name = re.match(r'echo "(.*)" > (\S+)', cmd).groups()
            (tmp_path / name).write_text(text + "\n", encoding="utf-8")
        elif cmd.startswith("python -c "):
            out = subprocess.run([sys.executable, "-c", shlex.split(cmd)[2]], text=True,
                                 capture_output=True, check=True).stdout
            _assert_printed(cmd, expected, out.splitlines())
        else:
            raise AssertionError(f"the test does not know how to run `{cmd}`")
