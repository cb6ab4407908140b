"""``leakdiag reproduce --table-seed N``: the case-study runs at another seed (an audit,
2026-11-29: 6 of the 24 trend verdicts changed with the seed, which no option could show)."""

import importlib

import pytest

from leakdiag.cli.main import main


class _Stop(Exception):
    pass


@pytest.fixture
def seen(monkeypatch):
    got = []
    rp = importlib.import_module("leakdiag.studies.reproduce")

    def run(systems, cfg, **kw):
        got.append(cfg)
        raise _Stop

    monkeypatch.setattr(rp, "reproduce", run)
    return got


@pytest.mark.parametrize("args, seed", [([], 0), (["--table-seed", "3"], 3)])
def test_the_seed_reaches_the_case_studies(tmp_path, seen, args, seed):
    with pytest.raises(_Stop):
        main(["reproduce", "vca", "--quick", "--scheduler", "serial", "--out",
              str(tmp_path / "o"), "--cache-dir", str(tmp_path / "c"), *args])
    assert seen[0].table_seed == seed and seen[0].name == "thesis-quick"


def test_a_negative_seed_is_refused(tmp_path, seen, capsys):
    assert main(["reproduce", "vca", "--table-seed", "-1", "--out", str(tmp_path / "o")]) == 2
    assert "--table-seed" in capsys.readouterr().err and not seen
