"""A curve in the style of the paper's Fig. 4: the range span of an FLS feature in the sidescan
against a swept rotation angle, one curve per distance of the feature from the sidescan.

The set-up is the paper's (and `sonarproj paper`'s scenarios 1-3): the paper presets, a feature
at azimuth 0 and elevation 0 at half the FLS's maximum range (5 m), placed at f * 30 m in the
sidescan for f = 0.1 .. 0.9, one rotation angle swept 0..180° in 1° steps (the other two 0), the
arc sampled every 0.1° as the published code. That is 9 x 181 = 1629 poses, run by
`sonarproj.sweep` from a small sweep TOML written into the output directory.

Run:  python examples/python/fig4_curve.py [--out DIR] [--angle roll|pitch|yaw]
          [--backend auto|cpu|cpu-fast|gpu]
"""

from __future__ import annotations

import argparse
import csv
import os
import tempfile
import time
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import sonarproj  # noqa: E402

FRACTIONS = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9]  # of the sidescan's range_max
SSS_RANGE_MAX = 30.0  # paper-sss: 0.1 - 30 m
FEATURE_RANGE = 5.0   # 0.5 x paper-fls's 10 m

# The sweep file (docs/sweeps.md; data/example-sweep.toml is the commented example). `from`/`to`
# are presets; `[feature]` is the true point in sonar 1, `[place]` where it appears in sonar 2,
# `[rotation]` roll, pitch, yaw (deg, R = (Rz Ry Rx)^T). Every combination of the keys' values is
# a pose; keys left out are 0.
SWEEP_TOML = """\
# Written by examples/python/fig4_curve.py
from = "paper-fls"
to = "paper-sss"
step = 0.1
metric = "span"

[feature]
range = {feature_range}

[place]
range = [{place_ranges}]

[rotation]
{angle} = {{ start = 0, stop = 180, step = 1 }}
"""


def parse_args() -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", help="output directory (default: a new temporary directory)")
    p.add_argument("--angle", default="pitch", choices=["roll", "pitch", "yaw"],
                   help="the rotation angle to sweep (default: pitch)")
    p.add_argument("--backend", default="auto", help="auto (default), cpu, cpu-fast or gpu")
    a = p.parse_args()
    a.out = a.out or tempfile.mkdtemp(prefix="sonarproj-fig4-")
    os.makedirs(a.out, exist_ok=True)
    return a


def main() -> None:
    args = parse_args()
    places = [round(f * SSS_RANGE_MAX, 6) for f in FRACTIONS]

    # One sweep directory per angle: sonarproj refuses to run a different sweep into a directory
    # that holds another one, and re-running the same sweep resumes (here: reads it back).
    config = os.path.join(args.out, f"sweep-{args.angle}.toml")
    with open(config, "w", encoding="utf-8") as f:
        f.write(SWEEP_TOML.format(feature_range=FEATURE_RANGE, angle=args.angle,
                                  place_ranges=", ".join(f"{p:g}" for p in places)))
    sweep_dir = os.path.join(args.out, f"sweep-{args.angle}")

    t0 = time.perf_counter()
    result = sonarproj.sweep(config, sweep_dir, backend=args.backend)
    elapsed = time.perf_counter() - t0
    print(f"fig4_curve: paper-fls feature at {FEATURE_RANGE:g} m -> paper-sss, {args.angle} 0..180°")
    print(f"  sweep file : {config}")
    print(f"  poses      : {result['poses']} ({result['computed']} computed, {result['resumed']} resumed) "
          f"on {result['device']} in {result['seconds']:.3f} s ({elapsed:.3f} s with I/O)")
    print(f"  CSV        : {result['file']}")
    print(f"  sonarproj's own figure: {result['figure']}")

    # sweep.csv: index, the pose columns (range, azimuth, elevation, place_range, ..., roll,
    # pitch, yaw), then the metric columns. `span` is in metres; 0 where nothing is visible.
    curves: dict[float, list[tuple[float, float]]] = defaultdict(list)
    with open(result["file"], newline="", encoding="utf-8") as f:
        for row in csv.DictReader(f):
            curves[float(row["place_range"])].append((float(row[args.angle]), float(row["span"])))

    fig, ax = plt.subplots(figsize=(8, 4.8), constrained_layout=True)
    cmap = plt.get_cmap("viridis")
    print(f"  {'place (m)':>9}  {'max span (m)':>12}  {'at ' + args.angle:>10}  "
          f"{'span at 0°':>10}  {'span at 90°':>11}")
    for k, place in enumerate(sorted(curves)):
        pts = sorted(curves[place])
        angles = [a for a, _ in pts]
        spans = [s for _, s in pts]
        best = max(range(len(spans)), key=spans.__getitem__)
        at = dict(pts)
        print(f"  {place:9g}  {spans[best]:12.6f}  {angles[best]:9g}°  {at[0.0]:10.6f}  {at[90.0]:11.6f}")
        ax.plot(angles, spans, color=cmap(k / (len(curves) - 1)), lw=1.6,
                label=f"{place:g} m ({place / SSS_RANGE_MAX:.1f} × {SSS_RANGE_MAX:g} m)")

    ax.set_xlabel(f"{args.angle} (deg)")
    ax.set_ylabel("range span in the sidescan (m)")
    ax.set_xlim(0, 180)
    ax.set_xticks(range(0, 181, 30))
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.set_title(f"FLS feature at {FEATURE_RANGE:g} m seen by the sidescan: span against {args.angle}")
    # The legend goes outside the axes so it never hides a curve.
    ax.legend(title="feature distance from the\nsidescan (× its maximum range)", loc="upper left",
              bbox_to_anchor=(1.01, 1.0), fontsize=8, title_fontsize=8)
    png = os.path.join(args.out, f"fig4_{args.angle}.png")
    fig.savefig(png, dpi=120)
    print(f"  figure: {png}")


if __name__ == "__main__":
    main()
