"""Correspondence masks over an imaging-sonar frame laid out as HoloOcean returns it.

A sidescan ("holoocean-sidescan") detects three features at ranges 3, 5.5 and 8 m. Under a known
relative pose, where can each one appear in the imaging sonar's frame ("holoocean-imaging")?
`sonarproj.MaskEngine` answers with one mask per feature in the imaging sonar's own layout, first
exactly (pose and ranges taken as true), then widened for uncertain pose and range (sigmas).

The frame is synthetic: speckle plus one bright blob, placed where a true point of the 5.5 m
sidescan feature really lies, so the masks can be checked against it. It is a numpy array of
shape (range_bins, beams) = (512, 512) as HoloOcean's ImagingSonar returns it: row 0 is
range_min, column 0 the starboard-most beam (docs/conventions.md); sonarproj's masks use the
same layout, so they overlay the frame index for index.

The picture is the raw layout as a person reads it: near range at the bottom, port on the left
(the columns are flipped for drawing only, since column 0 is starboard).

Run:  python examples/python/holoocean_masks.py [--out DIR] [--backend auto|cpu|gpu]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

import sonarproj  # noqa: E402

FEATURES = [3.0, 5.5, 8.0]  # sidescan ranges (m): a sidescan measures its range alone
TRUE_FEATURE = 1            # the feature whose true point gets the bright blob (5.5 m)

# The pose of the imaging sonar relative to the sidescan: p_imaging = R p_sidescan + t, with
# R = (Rz(yaw) Ry(pitch) Rx(roll))^T (deg) and t in metres.
ROLL, PITCH, YAW = 30.0, 5.0, 10.0
T = (0.3, 0.2, -0.1)

# Uncertainty (one standard deviation) of the pose and of the sidescan's range; the widened
# masks hold the true pixel with probability at least COVERAGE.
SIGMA = {"roll": 0.2, "pitch": 0.2, "yaw": 0.2, "tx": 0.02, "ty": 0.02, "tz": 0.02, "range": 0.02}
COVERAGE = 0.99

COLOURS = ["tab:orange", "tab:cyan", "tab:pink"]


def parse_args() -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", help="output directory (default: a new temporary directory)")
    p.add_argument("--backend", default="auto", help="auto (default), cpu or gpu")
    a = p.parse_args()
    a.out = a.out or tempfile.mkdtemp(prefix="sonarproj-masks-")
    os.makedirs(a.out, exist_ok=True)
    return a


def spherical(r, az, el) -> np.ndarray:
    """Points (n, 3) at range r (m), azimuth az, elevation el (deg): x forward, y port, z up."""
    az, el = np.radians(az), np.radians(el)
    return np.stack([r * np.cos(el) * np.cos(az), r * np.cos(el) * np.sin(az), r * np.sin(el)], axis=-1)


def true_point_in_imaging(pose: sonarproj.Pose, sss: sonarproj.Sonar, fls: sonarproj.Sonar,
                          r: float) -> tuple[float, float]:
    """A true point of a sidescan feature at range r that the imaging sonar sees: the point of
    the sidescan's beam (elevation 0) at that range nearest the middle of the part the imaging
    sonar sees. Returns its (range m, azimuth deg) in the imaging sonar."""
    az = np.linspace(-sss.azimuth_aperture / 2, sss.azimuth_aperture / 2, 17001)
    q = spherical(np.full_like(az, r), az, 0.0) @ pose.rotation.T + pose.translation
    rq = np.linalg.norm(q, axis=1)
    azq = np.degrees(np.arctan2(q[:, 1], q[:, 0]))
    elq = np.degrees(np.arcsin(q[:, 2] / rq))
    seen = np.flatnonzero((rq >= fls.range_min) & (rq <= fls.range_max)
                          & (np.abs(azq) <= fls.azimuth_aperture / 2)
                          & (np.abs(elq) <= fls.elevation_aperture / 2))
    if seen.size == 0:
        raise SystemExit(f"the imaging sonar sees no point of the {r} m feature under this pose")
    k = seen[seen.size // 2]
    return float(rq[k]), float(azq[k])


def synthetic_frame(fls: sonarproj.Sonar, blob_r: float, blob_az: float, seed: int = 7) -> np.ndarray:
    """A float32 frame in [0, 1], shape (range_bins, beams), row 0 = range_min, column 0 = the
    starboard-most beam: Rayleigh speckle fading with range, and a bright blob at (blob_r, blob_az)."""
    rng = np.random.default_rng(seed)
    rows, beams = fls.shape
    r = fls.range_min + (np.arange(rows) + 0.5) * (fls.range_max - fls.range_min) / rows
    edges = np.asarray(fls.beam_edges)
    az = 0.5 * (edges[:-1] + edges[1:])  # increasing with the column: starboard (-) to port (+)
    R, AZ = np.meshgrid(r, az, indexing="ij")
    speckle = rng.rayleigh(0.2, size=(rows, beams)) * (0.35 + 0.65 * np.exp(-R / 4.0))
    # The blob: a Gaussian about 12 cm in range and 1.5° in azimuth.
    blob = 0.9 * np.exp(-0.5 * (((R - blob_r) / 0.12) ** 2 + ((AZ - blob_az) / 1.5) ** 2))
    return np.clip(speckle + blob, 0, 1).astype(np.float32)


def pixel_of(fls: sonarproj.Sonar, r: float, az: float) -> tuple[int, int]:
    """(row, column) of a range and azimuth in the (range_bins, beams) layout."""
    row = int((r - fls.range_min) / (fls.range_max - fls.range_min) * fls.range_bins)
    col = int(np.searchsorted(np.asarray(fls.beam_edges), az, side="right") - 1)
    return min(row, fls.range_bins - 1), min(col, fls.beams - 1)


def main() -> None:
    args = parse_args()
    sss = sonarproj.Sonar.preset("holoocean-sidescan")  # 0.5-35 m, 170° x 0.25°, 2 x 1000 bins
    fls = sonarproj.Sonar.preset("holoocean-imaging")   # 0.1-10 m, 120° x 20°, 512 x 512
    pose = sonarproj.Pose(ROLL, PITCH, YAW, t=T)

    blob_r, blob_az = true_point_in_imaging(pose, sss, fls, FEATURES[TRUE_FEATURE])
    frame = synthetic_frame(fls, blob_r, blob_az)
    assert frame.shape == fls.shape == (512, 512)

    # One engine for the sonar pair, used for both calls (on a GPU it keeps its buffers).
    engine = sonarproj.MaskEngine(sss, fls, backend=args.backend)
    t0 = time.perf_counter()
    exact = engine.masks(pose, FEATURES)
    t1 = time.perf_counter()
    wide = engine.masks(pose, FEATURES, sigma=SIGMA, coverage=COVERAGE)
    t2 = time.perf_counter()

    row, col = pixel_of(fls, blob_r, blob_az)
    print(f"holoocean_masks: holoocean-sidescan features {FEATURES} m -> holoocean-imaging "
          f"{fls.shape}, roll {ROLL:g}, pitch {PITCH:g}, yaw {YAW:g}, t {T} m")
    print(f"  device: {engine.device}; exact masks {1e3 * (t1 - t0):.1f} ms, widened {1e3 * (t2 - t1):.1f} ms")
    print(f"  blob (a true point of the {FEATURES[TRUE_FEATURE]} m feature): range {blob_r:.3f} m, "
          f"azimuth {blob_az:.2f}° -> pixel row {row}, column {col}")
    print(f"  sigmas {SIGMA}, coverage {COVERAGE}")
    print(f"  {'feature':>8} {'pixels':>7} {'range (m)':>15} {'azimuth (deg)':>17} {'radius':>8} |"
          f" {'widened':>7} {'noise radius':>12} {'range (m)':>15}")
    for k, r in enumerate(FEATURES):
        b, w = exact.boxes[k], wide.boxes[k]
        box = (f"{b['range_min']:6.3f}..{b['range_max']:6.3f} {b['azimuth_min']:7.2f}..{b['azimuth_max']:6.2f}"
               if b else f"{'(empty)':>33}")
        wbox = f"{w['range_min']:6.3f}..{w['range_max']:6.3f}" if w else "(empty)"
        print(f"  {r:7.2f}m {int(exact.masks[k].sum()):7d} {box} {exact.radius[k]:7.4f}m |"
              f" {int(wide.masks[k].sum()):7d} {wide.noise_radius[k]:11.3f}m {wbox}")
    print(f"  union: {int(exact.union.sum())} pixels exact, {int(wide.union.sum())} widened, of {frame.size}")
    print(f"  blob pixel in the {FEATURES[TRUE_FEATURE]} m feature's mask: "
          f"exact {bool(exact.masks[TRUE_FEATURE, row, col])}, widened {bool(wide.masks[TRUE_FEATURE, row, col])}")

    # Drawing: flip the columns so port (column beams-1) is on the left; origin="lower" puts
    # row 0 (range_min) at the bottom. The extent's left edge is +aperture/2 (port).
    half = fls.azimuth_aperture / 2
    extent = (half, -half, fls.range_min, fls.range_max)
    edges = np.asarray(fls.beam_edges)
    az_cols = (0.5 * (edges[:-1] + edges[1:]))[::-1]  # azimuth of each drawn column, port first
    r_rows = fls.range_min + (np.arange(fls.range_bins) + 0.5) * (fls.range_max - fls.range_min) / fls.range_bins

    fig, axes = plt.subplots(1, 2, figsize=(13, 6.2), constrained_layout=True, sharey=True)
    for ax in axes:
        ax.imshow(frame[:, ::-1], origin="lower", extent=extent, aspect="auto", cmap="gray",
                  vmin=0, vmax=1, interpolation="nearest")
        ax.set_xlabel("azimuth (deg)")
        ax.set_xticks([60, 40, 20, 0, -20, -40, -60])
        # Port and starboard named under the axis ends, in axes coordinates.
        ax.text(0.0, -0.085, "◀ port", transform=ax.transAxes, ha="left", va="top", fontsize=10)
        ax.text(1.0, -0.085, "starboard ▶", transform=ax.transAxes, ha="right", va="top", fontsize=10)
    axes[0].set_ylabel("range (m)")
    axes[0].set_title("synthetic holoocean-imaging frame (512 x 512, raw layout)", fontsize=10)
    axes[0].annotate("blob", xy=(blob_az, blob_r), xytext=(blob_az + 15, blob_r + 1.2),
                     color="yellow", arrowprops=dict(arrowstyle="->", color="yellow"))

    ax = axes[1]
    handles = []
    for k, r in enumerate(FEATURES):
        colour = COLOURS[k % len(COLOURS)]
        # Exact mask: a translucent fill; widened mask: its outline, dashed.
        fill = np.ma.masked_equal(exact.masks[k][:, ::-1], 0)
        ax.imshow(fill, origin="lower", extent=extent, aspect="auto", interpolation="nearest",
                  cmap=matplotlib.colors.ListedColormap([colour]), alpha=0.85, vmin=0, vmax=1)
        if wide.masks[k].any():
            ax.contour(az_cols, r_rows, wide.masks[k][:, ::-1], levels=[0.5], colors=[colour],
                       linewidths=1.2, linestyles="--")
        handles.append(Patch(color=colour, label=f"{r:g} m: exact ({int(exact.masks[k].sum())} px)"))
        handles.append(Line2D([], [], color=colour, ls="--",
                              label=f"{r:g} m: σ-widened ({int(wide.masks[k].sum())} px)"))
    ax.set_xlim(half, -half)
    ax.set_title(f"masks of sidescan features at {', '.join(f'{r:g}' for r in FEATURES)} m "
                 f"(roll {ROLL:g}°, pitch {PITCH:g}°, yaw {YAW:g}°)", fontsize=10)
    # The legend goes outside the image so it hides no pixel.
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8,
              title=f"coverage {COVERAGE}", title_fontsize=8)
    png = os.path.join(args.out, "holoocean_masks.png")
    fig.savefig(png, dpi=110)
    print(f"  figure: {png}")
    np.save(os.path.join(args.out, "frame.npy"), frame)
    print(f"  frame: {os.path.join(args.out, 'frame.npy')} (float32, row 0 = range_min, column 0 = starboard)")


if __name__ == "__main__":
    main()
