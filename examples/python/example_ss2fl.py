"""The paper authors' second published example, reproduced with sonarproj: a feature seen by a
sidescan sonar (SSS), looked for in a forward-looking sonar (FLS) image.

Source of every number in CONFIG below: BYU-FRoSt-Lab/crossmodal_stereo_sonar_geometry,
src/example_ss2fl.py, its `config` dictionary (same keys, same values). This script does not use
their code; it asks sonarproj for what their script computes:

* the SSS measures a range (15 m) and loses azimuth and elevation, so the feature lies on a
  surface: azimuths -65°..+65° x elevations -0.15°..+0.15°, sampled every 0.1°
  (1301 x 3 = 3903 samples, as their two linspaces);
* the surface is moved into the FLS's frame and clipped to its field of view;
* the FLS keeps (range, azimuth) of each visible sample: their script scatters those points in
  the FLS's fan seen from above (it prints nothing).

We print the visible sample count, the range and azimuth extents of the projection in the FLS,
the occupied pixels, the projection area as their script sets it up (sonarproj's
`projection_area`: visible samples counted in 0.08 m squares, 37 cells = 0.2368 m²) and the
occupied area at the FLS's own resolution (`occupied_measure`), and draw their plot from the
occupied pixels, plus a zoom.

Run:  python examples/python/example_ss2fl.py [--out DIR] [--backend auto|cpu|cpu-fast|gpu]
"""

from __future__ import annotations

import argparse
import os
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import sonarproj  # noqa: E402

# The authors' config, verbatim values (metres and degrees, as in sonarproj's Python API).
CONFIG = {
    # Sidescan sonar
    "ss_min_range": 0.1,
    "ss_max_range": 30,
    "ss_azimuth_aperture": 130,
    "ss_azimuth_resolution": 0.1,
    "ss_elevation_aperture": 0.3,
    "ss_elevation_resolution": 0.1,
    # Forward-looking sonar
    "fl_min_range": 0.1,
    "fl_max_range": 10,
    "fl_azimuth_aperture": 60,
    "fl_elevation_aperture": 10,
    # Feature. Their comment says "with respect to the forward-looking sonar", but this is the
    # SSS's measurement: its range must lie in the SSS's range and it is back-projected in the
    # SSS's frame.
    "feat_range": 15,
    "feat_azimuth": 0,
    "feat_elevation": 0,
    # Relative pose: where the feature appears in the FLS, and the rotation
    "rp_range": 5,
    "rp_azimuth": 0,
    "rp_elevation": 0,
    "rp_roll": 45,
    "rp_pitch": 0,
    "rp_yaw": 45,
}

# What the original leaves unspecified: a data layout. Their FLS has no image (continuous
# range/azimuth points), their SSS none either. sonarproj's Sonar needs range bins (and beams for
# an FLS); we choose the paper presets' layouts: FLS 990 range bins (1 cm) x 512 beams
# (60°/512 = 0.117°), SSS 2990 bins (1 cm; it is sonar 1 here, so its layout plays no part).
# The FLS layout decides `occupied` and `occupied_measure` (the summed true areas of the occupied
# polar pixels), not the visible count, the extents or the projection area. Their script sets up
# a 0.08 m Cartesian grid over the FLS image ("area_spacing", squares of 0.0064 m², from
# x0 = fl_min_range cos(A/2), y0 = -fl_max_range sin(A/2)) for the projection area: sonarproj's
# `projection_area` counts the visible samples in that grid (`area_grid=0.08`, the default).
# The config's FLS elevation aperture is 10°, where the `paper-fls` preset has 12°.
FLS_RANGE_BINS, FLS_BEAMS = 990, 512
SSS_RANGE_BINS = 2990


def parse_args() -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", help="output directory (default: a new temporary directory)")
    p.add_argument("--backend", default="auto", help="auto (default), cpu, cpu-fast or gpu")
    a = p.parse_args()
    a.out = a.out or tempfile.mkdtemp(prefix="sonarproj-ss2fl-")
    os.makedirs(a.out, exist_ok=True)
    return a


def pixel_centres(sonar: sonarproj.Sonar, occupancy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Returns (range m, azimuth deg) of the centres of the occupied pixels of an FLS image laid
    out as sonarproj returns it: row 0 = range_min, column 0 = the starboard-most beam."""
    rows, cols = np.nonzero(occupancy)
    dr = (sonar.range_max - sonar.range_min) / sonar.range_bins
    edges = np.asarray(sonar.beam_edges)
    return sonar.range_min + (rows + 0.5) * dr, 0.5 * (edges[cols] + edges[cols + 1])


def draw_fan(ax, sonar: sonarproj.Sonar, n_range_lines: int = 5, n_bearing_lines: int = 5) -> None:
    """The FLS's field of view from above in sonarproj's frame, x forward (up) and y to port:
    the horizontal axis is y, drawn increasing to the left (see `port_left`), so port is on the
    left as seen from above. Dashed range arcs and bearing lines as the authors' plot."""
    half = sonar.azimuth_aperture / 2
    az = np.radians(np.linspace(-half, half, 200))
    for k, r in enumerate(np.linspace(sonar.range_min, sonar.range_max, n_range_lines + 2)):
        edge = k in (0, n_range_lines + 1)
        ax.plot(r * np.sin(az), r * np.cos(az), c="k", lw=1 if edge else 0.6, ls="-" if edge else "--")
    for k, a in enumerate(np.linspace(-half, half, n_bearing_lines + 2)):
        edge = k in (0, n_bearing_lines + 1)
        r = np.array([sonar.range_min, sonar.range_max])
        ax.plot(r * np.sin(np.radians(a)), r * np.cos(np.radians(a)), c="k",
                lw=1 if edge else 0.6, ls="-" if edge else "--")


def port_left(ax) -> None:
    """Labels a view from above in sonarproj's frame: y (positive to port) on the horizontal
    axis, increasing to the left so that port is on the left; x (forward) up."""
    if not ax.xaxis_inverted():
        ax.invert_xaxis()
    ax.set_xlabel("y (m, + port)      ← port | starboard →")
    ax.set_ylabel("x (m, forward)")


def main() -> None:
    args = parse_args()
    c = CONFIG

    sss = sonarproj.Sonar(
        kind="sss",
        range_min=c["ss_min_range"],
        range_max=c["ss_max_range"],
        azimuth_aperture=c["ss_azimuth_aperture"],
        elevation_aperture=c["ss_elevation_aperture"],
        range_bins=SSS_RANGE_BINS,
    )
    fls = sonarproj.Sonar(
        kind="fls",
        range_min=c["fl_min_range"],
        range_max=c["fl_max_range"],
        azimuth_aperture=c["fl_azimuth_aperture"],
        elevation_aperture=c["fl_elevation_aperture"],
        range_bins=FLS_RANGE_BINS,
        beams=FLS_BEAMS,
    )

    # The pose: their passive rot_mtx_3d(roll, pitch, yaw) is R = (Rz(yaw) Ry(pitch) Rx(roll))^T,
    # sonarproj's convention, and their translation works out to t = sph(rp_*) - R sph(feat_*), so
    # p2 = R p1 + t puts the feature's true point at (rp_range, rp_azimuth, rp_elevation) in the
    # FLS: Pose.placement. (Their rot_mtx_3d also refuses pitch outside (-90°, 90°]; sonarproj
    # takes any angle.)
    pose = sonarproj.Pose.placement(
        feature=(c["feat_range"], c["feat_azimuth"], c["feat_elevation"]),
        place=(c["rp_range"], c["rp_azimuth"], c["rp_elevation"]),
        roll=c["rp_roll"],
        pitch=c["rp_pitch"],
        yaw=c["rp_yaw"],
    )

    # Their surface: round(130/0.1) = 1300 -> 1301 azimuths, round(0.3/0.1) = 3 elevations.
    # sonarproj has one `step` for both angles; the config's two resolutions are both 0.1°.
    assert c["ss_azimuth_resolution"] == c["ss_elevation_resolution"]
    step = c["ss_azimuth_resolution"]
    # A sidescan measures its range alone (sonarproj refuses an azimuth for an SSS feature).
    m = sonarproj.project(sss, fls, pose, c["feat_range"], step=step, occupancy=True,
                          backend=args.backend)
    occ = m["occupancy"]  # uint8 (990, 512): row 0 = range_min, column 0 = starboard-most beam
    r_pix, az_pix = pixel_centres(fls, occ)

    print("example_ss2fl: SSS feature (15 m) looked for in the FLS; roll 45, pitch 0, yaw 45; "
          "placed at 5 m")
    print(f"  pose: R = {np.round(pose.rotation, 6).tolist()}, t = {np.round(pose.translation, 6).tolist()} m")
    print(f"  device: {m['device']}")
    print(f"  visible surface samples : {m['visible']} of {m['total']}")
    print(f"  FLS range of the samples: {m['range_min']:.6f} .. {m['range_max']:.6f} m "
          f"(span {m['span']:.6f} m)")
    print(f"  FLS azimuth             : {m['azimuth_min']:.4f} .. {m['azimuth_max']:.4f} deg")
    print(f"  occupied FLS pixels     : {m['occupied']} of {occ.size}")
    print(f"  projection area         : {m['projection_area']:.6f} m² "
          f"({round(m['projection_area'] / 0.0064)} cells of 0.08 m, the authors' grid)")
    print(f"  occupied area           : {m['occupied_measure']:.6f} m² (summed FLS pixel areas)")

    # With step 0.1° the samples land about 15 m * 0.1° = 2.6 cm apart, farther than the 1 cm
    # pixels, so the occupied area above counts one pixel per sample. sonarproj's automatic sampling is
    # dense enough to leave no hole, which gives the area of the projected curve itself.
    auto = sonarproj.project(sss, fls, pose, c["feat_range"], occupancy=True, backend=args.backend)
    print(f"  auto sampling           : {auto['visible']} of {auto['total']} samples visible, "
          f"{auto['occupied']} pixels, occupied area {auto['occupied_measure']:.6f} m², "
          f"projection area {auto['projection_area']:.6f} m²")

    # Their plot: the fan from above (forward up) with the visible points; ours from the
    # occupied pixels' centres, at (y, x) of sonarproj's frame. Port (+azimuth, +y) is drawn on
    # the left as seen from above, so the y axis increases to the left. (Their scatter draws
    # (y, x) over a fan rotated to (-y, x), mirroring the points across the boresight; with a
    # symmetric fan outline the mirror is easy to miss.)
    lateral = r_pix * np.sin(np.radians(az_pix))  # y, to port (m)
    forward = r_pix * np.cos(np.radians(az_pix))
    fig, (ax, zoom) = plt.subplots(1, 2, figsize=(11, 5.2), constrained_layout=True,
                                   gridspec_kw={"width_ratios": [1.25, 1]})
    draw_fan(ax, fls)
    ax.scatter(lateral, forward, c="r", s=4, zorder=10, label=f"occupied pixels ({m['occupied']})")
    ax.set_aspect("equal")
    port_left(ax)
    ax.set_title("SSS feature (15 m) in the FLS: roll 45°, yaw 45°")
    ax.legend(loc="lower right", fontsize=8)

    ra, aa = pixel_centres(fls, auto["occupancy"])
    zoom.scatter(ra * np.sin(np.radians(aa)), ra * np.cos(np.radians(aa)), c="0.7", s=6,
                 label=f"auto sampling: {auto['occupied']} pixels")
    zoom.scatter(lateral, forward, c="r", s=6, label=f"step 0.1°: {m['occupied']} pixels")
    zoom.legend(loc="upper right", fontsize=8, markerscale=2)
    zoom.set_aspect("equal")
    zoom.margins(0.15)
    port_left(zoom)
    zoom.set_title(f"zoom: range {m['range_min']:.2f}–{m['range_max']:.2f} m, "
                   f"projection area {m['projection_area']:.4f} m²", fontsize=10)
    zoom.grid(alpha=0.3)
    png = os.path.join(args.out, "example_ss2fl.png")
    fig.savefig(png, dpi=110)
    print(f"  figure: {png}")


if __name__ == "__main__":
    main()
