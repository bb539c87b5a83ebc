"""`sonarproj bench sweep --pyarrow PYTHON`: pyarrow, the peer writer, writing the sweep's own
Parquet table again, and the Parquet sweep set against the projection plus that write."""

import subprocess
import sys

import pyarrow.parquet as pq


def test_the_peer_script_writes_the_same_table_again(cli, root, tmp_path):
    """The script the CLI hands the interpreter reads the sweep's table and writes it again:
    the same rows and columns, Snappy, and a positive time."""
    script = root / "crates" / "sonarproj-cli" / "src" / "cli" / "pyarrow_peer.py"
    cli("sweep", "--config", root / "data" / "bench-sweep-1m.toml", "--out", tmp_path / "s",
        "--format", "parquet", "--max-chunks", "1")
    # One chunk of the sweep's million poses, finished as its own Parquet part.
    parts = sorted((tmp_path / "s").rglob("*.parquet"))
    assert parts, list((tmp_path / "s").rglob("*"))
    table = pq.read_table(parts[0])
    out = tmp_path / "peer.parquet"
    done = subprocess.run([sys.executable, script, parts[0], out, "2"], capture_output=True,
                          text=True, check=True)
    assert float(done.stdout) > 0
    again = pq.read_table(out)
    assert again.equals(table)
    meta = pq.ParquetFile(out).metadata
    assert meta.row_group(0).column(0).compression == "SNAPPY"


def test_bench_sweep_sets_parquet_against_pyarrow(cli):
    """With this interpreter (it has pyarrow), each backend's Parquet sweep is printed against
    its projection plus pyarrow's write of the same table, the ratio from those numbers."""
    done = cli("bench", "sweep", "--backends", "cpu-fast", "--poses", "2000", "--runs", "1",
               "--measures", "parquet", "--pyarrow", sys.executable)
    line = next(l for l in done.stdout.splitlines()
                if l.startswith("cpu-fast parquet against pyarrow: "))
    words = line.split()
    q, ratio, p, w = (float(words[k].rstrip("x,")) for k in (4, 6, 9, 18))
    assert w > 0 and p > 0
    # Each figure is printed to 0.5 ms (the ratio to 0.005): the ratio lies within what those
    # roundings allow.
    low, high = (q - 5e-4) / (p + w + 1e-3), (q + 5e-4) / (p + w - 1e-3)
    assert low - 0.005 <= ratio <= high + 0.005, line
