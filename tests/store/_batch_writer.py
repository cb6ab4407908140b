"""Child process for the store tests: store a fleet's batch rows once a start file exists.

``python _batch_writer.py URL GO N_FOLDERS PER_FOLDER``: waits for the file GO (so that two
children start their writes within a millisecond), then :func:`record_batch` of
:func:`_rows.fleet_rows`; prints the runs it wrote.
"""

import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from _rows import JOB, fleet_rows  # noqa: E402

from leakdiag.store import EventStore  # noqa: E402
from leakdiag.store.writers import record_batch  # noqa: E402

if __name__ == "__main__":
    url, go, n_folders, per_folder = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
    st = EventStore(url)
    rows = fleet_rows(n_folders, per_folder)
    print("ready", flush=True)
    while not os.path.exists(go):
        time.sleep(0.0005)
    w = record_batch(st, rows, JOB)
    print(getattr(w, "n_runs", w), flush=True)
    st.close()
