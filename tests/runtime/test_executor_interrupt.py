"""Ctrl-C during a run on our own local Dask cluster: one line, not the workers' tracebacks.

An audit (2026-11-29) pressed Ctrl-C in ``leakdiag reproduce`` (default ``--scheduler local``)
and got about 67 lines of Dask worker tracebacks (``KeyboardInterrupt`` in each worker's event
loop, the scheduler's and the nannies' warnings) before ``Aborted.``. A terminal sends SIGINT to
the whole foreground process group, workers included, so the test does the same.
"""

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

#: ``leakdiag reproduce`` through its entry point, with cases that only say they started and
#: sleep (the protocol's simulations would make the moment of the interrupt a matter of luck).
SCRIPT = textwrap.dedent("""
    import importlib, pathlib, signal, sys, time

    from leakdiag.cli.main import main

    rp = importlib.import_module("leakdiag.studies.reproduce")  # the module, not the function

    def case(config):
        pathlib.Path(config["flag"]).touch()
        time.sleep(300)

    if __name__ == "__main__":  # not in the workers (spawned: they import this file)
        # as at a terminal: a job started in the background (``make test &``) inherits SIGINT
        # ignored, and Python then installs no KeyboardInterrupt handler (the run went on)
        signal.signal(signal.SIGINT, signal.default_int_handler)
        flags = pathlib.Path(sys.argv[1])
        rp.build_cases = lambda cfg, systems: [{"flag": str(flags / f"running-{i}")}
                                               for i in range(4)]
        rp.run_case = case
        sys.exit(main(["reproduce", "vca", "--quick", "--workers", "2", "--no-progress",
                       "--out", str(flags / "out"), "--cache-dir", str(flags / "cache")]))
""")


@pytest.mark.slow
def test_ctrl_c_on_a_local_cluster_prints_one_line(tmp_path):
    script = tmp_path / "run.py"
    script.write_text(SCRIPT)
    env = {**os.environ, "PYTHONWARNINGS": "ignore::DeprecationWarning"}
    proc = subprocess.Popen([sys.executable, str(script), str(tmp_path)], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)  # its own process group, as at a terminal
    try:
        deadline = time.monotonic() + 120
        while len(list(tmp_path.glob("running-*"))) < 2:  # both workers busy
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline, "the workers never started a case"
            time.sleep(0.2)
        time.sleep(1.0)
        os.killpg(proc.pid, signal.SIGINT)  # what Ctrl-C at a terminal does
        try:
            out, err = proc.communicate(timeout=90)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            out, err = proc.communicate()  # closes the pipes (no ResourceWarning later)
            pytest.fail("the run did not end within 90 s of Ctrl-C; it printed:\n"
                        + out[-3000:] + "\n--- stderr ---\n" + err[-6000:])
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
    assert proc.returncode == 1
    assert [line for line in err.splitlines() if line.strip()] == ["Aborted."], err
    assert out == ""
