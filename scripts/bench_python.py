"""Times a batch through the Python package against the same batch through the Rust library in
the same process, and prints both.

    python scripts/bench_python.py [--poses 100000] [--step 0.1] [--backend cpu-fast] [--runs 5]

The Python call is `sonarproj.batch` from numpy arrays (column checks, conversion, the engine,
the metric arrays); the Rust figure is the library alone on the same columns (items built and
checked, one `Backend::project` call, metrics collected), timed inside the extension module.
Both take the median of `--runs` runs after one warm-up. The Rust timing function is only in a
package built with the `bench` feature: `maturin build --release --features bench`.
"""

import argparse
import statistics
import time

import numpy as np

import sonarproj
from sonarproj import _sonarproj


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=100_000)
    ap.add_argument("--step", type=float, default=0.1)
    ap.add_argument("--backend", default="cpu-fast")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--direction", choices=["fls-sss", "sss-fls"], default="fls-sss")
    a = ap.parse_args()
    first, second = ("paper-fls", "paper-sss") if a.direction == "fls-sss" else ("paper-sss", "paper-fls")
    s1, s2 = sonarproj.Sonar.preset(first), sonarproj.Sonar.preset(second)
    rng = np.random.default_rng(1)
    n = a.poses
    cols = {
        "range": rng.uniform(s1.range_min + 0.5, s1.range_max * 0.9, n),
        "azimuth": rng.uniform(-0.4, 0.4, n) * s1.azimuth_aperture,
        "elevation": np.zeros(n),
        "roll": rng.uniform(0, 180, n),
        "pitch": rng.uniform(0, 180, n),
        "yaw": rng.uniform(0, 180, n),
        "place_range": rng.uniform(s2.range_min + 0.5, s2.range_max * 0.9, n),
        "place_azimuth": np.zeros(n),
        "place_elevation": np.zeros(n),
    }
    ordered = [np.ascontiguousarray(cols[k], dtype=np.float64) for k in cols]

    def python_call() -> float:
        t = time.perf_counter()
        sonarproj.batch(first, second, cols, step=a.step, backend=a.backend)
        return time.perf_counter() - t

    if not hasattr(_sonarproj, "bench_rust_batch"):
        raise SystemExit("this package has no timing function: build it with "
                         "`maturin build --release --features bench` and install that wheel")

    def rust_call() -> float:
        return _sonarproj.bench_rust_batch(s1, s2, list(cols), ordered, a.step, a.backend)  # type: ignore[attr-defined]

    python_call(), rust_call()  # warm-up: backend opened, pages touched
    py, rs = [], []
    for _ in range(a.runs):  # interleaved, so drift hits both alike
        py.append(python_call())
        rs.append(rust_call())
    p, r = statistics.median(py), statistics.median(rs)
    samples = int(sonarproj.batch(first, second, {k: v[:1] for k, v in cols.items()}, step=a.step,
                                  backend=a.backend)["total"][0]) * n
    print(f"{n} poses {first} -> {second}, step {a.step} deg, backend {a.backend}, "
          f"{samples / 1e6:.0f} M samples, median of {a.runs}:")
    print(f"  Rust library: {r:.3f} s")
    print(f"  Python batch: {p:.3f} s  ({p / r:.3f} x the library)")


if __name__ == "__main__":
    main()
