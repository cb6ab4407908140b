"""``leakdiag reproduce --from-results PKL``: the report of a run saved with ``--save-results``
rebuilt without simulating (an audit, 2026-11-29: no command read the saved results). The
rebuilt report of a real run is compared with the run's own in
``tests/studies/test_reproduce.py``; here, what is refused, through the entry point."""

import importlib
import pickle

import pytest

from leakdiag.cli.main import main


@pytest.fixture(autouse=True)
def no_run(monkeypatch):
    rp = importlib.import_module("leakdiag.studies.reproduce")
    monkeypatch.setattr(rp, "reproduce", lambda *a, **k: pytest.fail("a run was started"))


def _err(capsys):
    return capsys.readouterr().err.strip().splitlines()[-1]


def test_not_saved_results_are_refused(tmp_path, capsys):
    pkl = tmp_path / "list.pkl"
    pkl.write_bytes(pickle.dumps([1, 2]))
    assert main(["reproduce", "--from-results", str(pkl), "--out", str(tmp_path / "o")]) == 2
    assert _err(capsys) == (f"leakdiag: error: --from-results {pkl}: not results saved by "
                            "leakdiag reproduce --save-results (it holds a list)")
    csv = tmp_path / "t.csv"
    csv.write_text("a,b\n1,2\n")
    assert main(["reproduce", "--from-results", str(csv), "--out", str(tmp_path / "o")]) == 2
    assert _err(capsys).startswith(f"leakdiag: error: --from-results {csv}: cannot read it as "
                                   "results saved by --save-results (UnpicklingError: ")
    assert not (tmp_path / "o").exists()


def test_options_of_a_new_run_are_refused(tmp_path, capsys):
    pkl = tmp_path / "r.pkl"
    pkl.write_bytes(b"")
    code = main(["reproduce", "--from-results", str(pkl), "--quick", "--chunk", "5",
                 "--out", str(tmp_path / "o")])
    assert code == 2
    assert _err(capsys) == ("Error: --quick, --chunk: for a new run; --from-results rebuilds "
                            "the report of a saved one, with its settings: drop them")


def test_a_system_is_needed_without_from_results(tmp_path, capsys):
    assert main(["reproduce", "--out", str(tmp_path / "o")]) == 2
    assert _err(capsys) == ("Error: Missing argument 'SYSTEM' (vca, eha or all), or give "
                            "--from-results PKL to rebuild a saved run's report.")
