"""Child process for the store tests: write chunks to a store, print each committed chunk."""

import sys

from leakdiag.store import ChunkSummary, EventStore

if __name__ == "__main__":
    path, name, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
    st = EventStore(path)
    run = st.start_run(name, command="monitor", source=f"{name}.parquet", feature="ac p1")
    i = 0
    while n < 0 or i < n:
        v = float(i)
        st.add_chunk(run, ChunkSummary(0.2 * i, 0.2 * i + 0.1, 2, 0, v, v - 1, v + 1, v))
        print(i, flush=True)
        i += 1
    st.end_run(run)
