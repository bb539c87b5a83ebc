"""The paper authors' first published example, reproduced with sonarproj: a feature seen by a
forward-looking sonar (FLS), looked for in a sidescan sonar (SSS).

Source of every number in CONFIG below: BYU-FRoSt-Lab/crossmodal_stereo_sonar_geometry,
src/example_fl2ss.py, its `config` dictionary (same keys, same values). This script does not use
their code; it asks sonarproj for what their script computes:

* the FLS measures (range 5 m, azimuth 0°) and loses the elevation, so the feature lies on an
  arc of elevations -5°..+5°, sampled every 0.1° (101 samples, as their linspace);
* the arc is moved into the SSS's frame and clipped to its field of view;
* the SSS keeps only the range of each visible sample: their script scatters those ranges on a
  line from ss_min_range to ss_max_range (it prints nothing).

We print the count of visible samples, their ranges (min, max, span) and the SSS range bins they
fall in, and draw their plot (plus a zoom, since at 30 m full scale the 0.87 m span is a dot).

Run:  python examples/python/example_fl2ss.py [--out DIR] [--backend auto|cpu|cpu-fast|gpu]
"""

from __future__ import annotations

import argparse
import math
import os
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import sonarproj  # noqa: E402

# The authors' config, verbatim values (metres and degrees, as in sonarproj's Python API).
CONFIG = {
    # Forward-looking sonar
    "fl_min_range": 0.1,
    "fl_max_range": 10,
    "fl_azimuth_aperture": 60,
    "fl_elevation_aperture": 10,
    "fl_elevation_resolution": 0.1,
    # Sidescan sonar
    "ss_min_range": 0.1,
    "ss_max_range": 30,
    "ss_azimuth_aperture": 130,
    "ss_elevation_aperture": 0.3,
    # Feature, in the FLS frame
    "feat_range": 5,
    "feat_azimuth": 0,
    "feat_elevation": 0,
    # Relative pose: where the feature appears in the SSS, and the rotation
    "rp_range": 15,
    "rp_azimuth": 0,
    "rp_elevation": 0,
    "rp_roll": 0,
    "rp_pitch": 90,
    "rp_yaw": 0,
}

# What the original leaves unspecified: a data layout (range bins, beams). Their SSS measurement
# is a continuous range, their FLS has no image. sonarproj's Sonar needs a layout, so we choose
# the paper presets' layouts: 1 cm range bins ((30 - 0.1) / 0.01 = 2990 bins for the SSS;
# 990 bins x 512 beams for the FLS). The FLS's layout plays no part here (it is sonar 1), and the
# SSS's bins only affect `occupied` / `occupied_measure`, not the visible count or the span.
# Note also: the config's FLS elevation aperture is 10°, where the `paper-fls` preset (paper
# Table I) has 12°, so we build the sonars from the config rather than use the presets.
SSS_RANGE_BINS = 2990
FLS_RANGE_BINS, FLS_BEAMS = 990, 512


def parse_args() -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", help="output directory (default: a new temporary directory)")
    p.add_argument("--backend", default="auto", help="auto (default), cpu, cpu-fast or gpu")
    a = p.parse_args()
    a.out = a.out or tempfile.mkdtemp(prefix="sonarproj-fl2ss-")
    os.makedirs(a.out, exist_ok=True)
    return a


def main() -> None:
    args = parse_args()
    c = CONFIG

    fls = sonarproj.Sonar(
        kind="fls",
        range_min=c["fl_min_range"],
        range_max=c["fl_max_range"],
        azimuth_aperture=c["fl_azimuth_aperture"],
        elevation_aperture=c["fl_elevation_aperture"],
        range_bins=FLS_RANGE_BINS,
        beams=FLS_BEAMS,
    )
    sss = sonarproj.Sonar(
        kind="sss",
        range_min=c["ss_min_range"],
        range_max=c["ss_max_range"],
        azimuth_aperture=c["ss_azimuth_aperture"],
        elevation_aperture=c["ss_elevation_aperture"],
        range_bins=SSS_RANGE_BINS,
    )

    # The pose. Their rot_mtx_3d(roll, pitch, yaw) (passive) is R = (Rz(yaw) Ry(pitch) Rx(roll))^T,
    # which is sonarproj's convention, and their translation (calculate_translation_from_p1_p2_and_rot,
    # then t = -R t) works out to t = sph(rp_*) - R sph(feat_*), so that p2 = R p1 + t puts the
    # feature's true point at (rp_range, rp_azimuth, rp_elevation) in the SSS. That is exactly
    # Pose.placement(feature=..., place=...).
    pose = sonarproj.Pose.placement(
        feature=(c["feat_range"], c["feat_azimuth"], c["feat_elevation"]),
        place=(c["rp_range"], c["rp_azimuth"], c["rp_elevation"]),
        roll=c["rp_roll"],
        pitch=c["rp_pitch"],
        yaw=c["rp_yaw"],
    )

    # Their arc: n = round(10 / 0.1) = 100 elevations, made odd -> 101, linspace(-5, 5, 101).
    # sonarproj's `step=` samples the same way (docs/commands.md: "step sampling as the published code").
    # The FLS measures (range, azimuth); the elevation only served the placement above.
    # (Their arc builder appends [feat_range, feat_elevation, elevation], i.e. it puts the
    # feature's elevation where its azimuth belongs; with both 0 in this config that changes
    # nothing, and sonarproj uses the azimuth.)
    m = sonarproj.project(
        fls, sss, pose, (c["feat_range"], c["feat_azimuth"]),
        step=c["fl_elevation_resolution"], occupancy=True, backend=args.backend,
    )
    occ = m["occupancy"]  # uint8, shape (2990,): 1 where an SSS range bin holds a visible sample
    bin_width = (sss.range_max - sss.range_min) / sss.range_bins
    bins = np.flatnonzero(occ)
    bin_centres = sss.range_min + (bins + 0.5) * bin_width

    # With pitch 90° the whole arc lies along the SSS's range axis: the span is the arc's chord.
    chord = 2 * c["feat_range"] * math.sin(math.radians(c["fl_elevation_aperture"] / 2))

    print("example_fl2ss: FLS feature (5 m, 0°) looked for in the SSS; roll 0, pitch 90, yaw 0; "
          "placed at 15 m")
    print(f"  pose: R = {np.round(pose.rotation, 6).tolist()}, t = {pose.translation.tolist()} m")
    print(f"  device: {m['device']}")
    print(f"  visible arc samples       : {m['visible']} of {m['total']}")
    print(f"  SSS ranges of the samples : {m['range_min']:.6f} .. {m['range_max']:.6f} m")
    print(f"  range span                : {m['span']:.6f} m  (arc chord 2*5*sin 5° = {chord:.6f} m)")
    print(f"  occupied SSS range bins   : {m['occupied']} of {sss.range_bins} "
          f"(bins {bins.min()}..{bins.max()}, {m['occupied_measure']:.2f} m of range)")

    # The same with sonarproj's automatic sampling (dense enough to leave no hole in the bins).
    auto = sonarproj.project(fls, sss, pose, (c["feat_range"], c["feat_azimuth"]), backend=args.backend)
    print(f"  auto sampling             : {auto['visible']} of {auto['total']} samples visible, "
          f"span {auto['span']:.6f} m, {auto['occupied']} bins occupied")

    # Their plot: the SSS range axis as a gray line and the measured ranges as red dots. We draw
    # the occupied range bins (their centres) and add a zoom on the span below it.
    fig, (top, zoom) = plt.subplots(2, 1, figsize=(8, 4.2), constrained_layout=True)
    for ax in (top, zoom):
        ax.plot([sss.range_min, sss.range_max], [0, 0], c="gray", lw=2, zorder=1)
        ax.scatter(bin_centres, np.zeros_like(bin_centres), c="r", s=12, zorder=10,
                   label=f"occupied range bins ({m['occupied']})")
        ax.set_yticks([])
        ax.set_xlabel("sidescan range (m)")
    top.set_xlim(0, sss.range_max + 0.5)
    # The authors' configuration, not the paper's presets: its FLS elevation aperture is 10°, so
    # the span is the chord 2·5·sin 5° = 0.872 m, where the README's row (paper-fls, 12°) has
    # 2·5·sin 6° = 1.045 m.
    top.set_title(f"The authors' example_fl2ss configuration (FLS elevation aperture "
                  f"{c['fl_elevation_aperture']:g}°, not the paper-fls preset's 12°):\n"
                  f"FLS feature (5 m, 0°) in the sidescan, roll 0°, pitch 90°, yaw 0°", fontsize=10)
    pad = 0.15
    zoom.set_xlim(m["range_min"] - pad, m["range_max"] + pad)
    zoom.fill_betweenx([-0.3, 0.3], m["range_min"], m["range_max"], color="tab:orange", alpha=0.3,
                       label=f"range span {m['span']:.3f} m", zorder=0)
    for ax in (top, zoom):
        ax.set_ylim(-1, 1)
    zoom.set_title("zoom on the range span", fontsize=10)
    zoom.legend(loc="upper left", fontsize=8, ncol=2, framealpha=0.9)
    png = os.path.join(args.out, "example_fl2ss.png")
    fig.savefig(png, dpi=120)
    print(f"  figure: {png}")


if __name__ == "__main__":
    main()
