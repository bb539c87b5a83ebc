"""Times pyarrow writing a Parquet table again: `python pyarrow_peer.py TABLE OUT RUNS`.

The table is read back whole, then written to OUT with Snappy and pyarrow's other defaults
(its row groups too: a million rows, where a sweep's are 131 072), RUNS + 1 times. Prints the
median of the last RUNS writes in seconds (the first is a warm-up).
"""

import statistics
import sys
import time

import pyarrow.parquet as pq

path, out, runs = sys.argv[1], sys.argv[2], int(sys.argv[3])
table = pq.read_table(path)
times = []
for _ in range(runs + 1):
    start = time.perf_counter()
    pq.write_table(table, out, compression="snappy")
    times.append(time.perf_counter() - start)
print(statistics.median(times[1:]))
