"""Correspondence masks drawn over a real imaging-sonar ping, in its own geometry.

An Oculus (Blueprint Subsea M-series) ping is read with `sonarproj.read_oculus`: its sonar (the
ping's exact bearings and range lines) and its image. A sidescan ("holoocean-sidescan") beside
it has detected three features, given as ranges; the pose between the two sonars is known with a
covariance, as a navigation filter gives it (x, y, z, roll, pitch, yaw in m² and rad²). Where can
each detection appear in the ping? `sonarproj.MaskEngine` answers in the ping's own layout, and
the picture draws the image and the masks as a fan seen from above: forward up, port on the
left, near range at the bottom (as every picture of sonarproj).

Without `--ping`, the example writes a synthetic ping first (speckle and a bright seabed band, in
the vendor SDK's simple-ping-result layout) so that it runs anywhere; with a recorded ping
(`--ping FILE.raw`, e.g. the liboculus test pings) it draws the real image.

Run:  python examples/python/oculus_masks.py [--ping FILE.raw] [--index K] [--out DIR] [--backend auto|cpu|gpu]
"""

from __future__ import annotations

import argparse
import os
import struct
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

import sonarproj  # noqa: E402

DETECTIONS = [0.9, 1.3, 1.7]  # sidescan ranges (m)

# The imaging sonar relative to the sidescan: p_imaging = R p_sidescan + t (the paper's
# roll/pitch/yaw, deg; t in m).
ROLL, PITCH, YAW = 30.0, 5.0, 10.0
T = (0.15, 0.1, -0.05)

# The pose's covariance as a navigation filter gives it (x, y, z in m², roll, pitch, yaw in
# rad²), and the sidescan's range error; the widened masks hold the true pixel with
# probability at least COVERAGE.
COVARIANCE = np.diag([0.005**2, 0.005**2, 0.005**2, np.radians(0.1) ** 2, np.radians(0.1) ** 2, np.radians(0.1) ** 2])
SIGMA_RANGE = 0.005
COVERAGE = 0.99

COLOURS = ["tab:orange", "tab:cyan", "tab:pink"]


def parse_args() -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--ping", help="an Oculus file (default: a synthetic ping written to --out)")
    p.add_argument("--index", type=int, default=0, help="which ping of the file (default 0)")
    p.add_argument("--out", help="output directory (default: a new temporary directory)")
    p.add_argument("--backend", default="auto", help="auto (default), cpu or gpu")
    a = p.parse_args()
    a.out = a.out or tempfile.mkdtemp(prefix="sonarproj-oculus-")
    os.makedirs(a.out, exist_ok=True)
    return a


def write_synthetic_ping(path: str, seed: int = 3) -> None:
    """Writes one simple ping result (layout version 2, 8-bit, no gains) as the SDK's `Oculus.h`
    lays it out: 256 beams over ±30° (denser at the centre, as the units' are), 700 range lines
    of 2.8 mm, speckle and a bright band where a flat seabed would be."""
    rng = np.random.default_rng(seed)
    n, rows, res = 256, 700, 0.0028
    u = np.linspace(-1.0, 1.0, n)
    bearings = np.round(3000 * (0.6 * u + 0.4 * u**3)).astype(np.int16)  # 0.01°
    r = (np.arange(rows) + 0.5) * res
    az = np.radians(bearings / 100.0)
    R, AZ = np.meshgrid(r, az, indexing="ij")
    seabed = 1.1 + 0.25 * np.sin(AZ * 3)  # m: a gently uneven bottom
    image = rng.rayleigh(18.0, size=(rows, n)) + 170 * np.exp(-0.5 * ((R - seabed) / 0.12) ** 2)
    image = np.clip(image, 0, 255).astype(np.uint8)
    fixed = 202
    image_offset = fixed + 2 * n
    total = image_offset + image.size
    head = struct.pack("<HHHHHIH", 0x4F53, 1, 0, 0x23, 2, total - 16, 0)
    fire = struct.pack("<BBBBBdddd", 2, 0, 255, 127, 0x09, 2.0, 50.0, 1500.0, 0.0) + bytes(36)
    result = struct.pack("<IIddddddddBdHH4IIII", 1, 0, 2.1e6, 12.0, 1.0, 0.0, 0.0, 0.0, 1500.0, 0.0,
                         0, res, rows, n, 0, 0, 0, 0, image_offset, image.size, total)
    body = head + fire + result + bearings.astype("<i2").tobytes() + image.tobytes()
    assert len(body) == total
    with open(path, "wb") as f:
        f.write(body)


def fan(ax, values, sonar, **kwargs):
    """Draws `values` ((range_bins, beams), column 0 the starboard-most) as a fan seen from
    above in sonarproj's frame: y = r sin(az) on the horizontal axis (positive to port; the
    axis increases to the left so port is on the left), x = r cos(az) forward, up."""
    r = sonar.range_min + np.arange(sonar.range_bins + 1) * (sonar.range_max - sonar.range_min) / sonar.range_bins
    az = np.radians(np.asarray(sonar.beam_edges))
    R, AZ = np.meshgrid(r, az, indexing="ij")
    return ax.pcolormesh(R * np.sin(AZ), R * np.cos(AZ), values, shading="flat", **kwargs)


def main() -> None:
    args = parse_args()
    path = args.ping
    if path is None:
        path = os.path.join(args.out, "synthetic_ping.raw")
        write_synthetic_ping(path)
    pings = sonarproj.read_oculus(path)
    ping = pings[args.index]
    fls = ping.sonar
    sss = sonarproj.Sonar.preset("holoocean-sidescan")
    pose = sonarproj.Pose(ROLL, PITCH, YAW, t=T)

    engine = sonarproj.MaskEngine(sss, fls, backend=args.backend)
    exact = engine.masks(pose, DETECTIONS)
    wide = engine.masks(pose, DETECTIONS, covariance=COVARIANCE, sigma={"range": SIGMA_RANGE},
                        coverage=COVERAGE)

    print(f"oculus_masks: {path} ping {args.index} of {len(pings)} (id {ping.ping_id}, v{ping.version}, "
          f"{ping.frequency / 1e6:.2f} MHz): {fls.range_bins} ranges x {fls.beams} beams, "
          f"{fls.range_max:.3f} m, bearings {ping.bearings[0]:.2f}° to {ping.bearings[-1]:.2f}°")
    print(f"  masks on {engine.device}: sidescan ranges {DETECTIONS} m, roll {ROLL:g}, pitch {PITCH:g}, "
          f"yaw {YAW:g}, t {T} m")
    for k, r in enumerate(DETECTIONS):
        b = exact.boxes[k]
        where = (f"{b['range_min']:.3f}..{b['range_max']:.3f} m, {b['azimuth_min']:.1f}..{b['azimuth_max']:.1f}°"
                 if b else "not in view")
        print(f"  {r:4.2f} m: {int(exact.masks[k].sum()):6d} px exact ({where}), "
              f"{int(wide.masks[k].sum()):6d} px widened (noise radius {wide.noise_radius[k]:.3f} m)")

    fig, ax = plt.subplots(figsize=(8.2, 6.4))
    fan(ax, ping.image.astype(float), fls, cmap="gray", vmin=0, vmax=np.percentile(ping.image, 99.5))
    handles = []
    for k, r in enumerate(DETECTIONS):
        colour = COLOURS[k % len(COLOURS)]
        fan(ax, np.ma.masked_equal(exact.masks[k].astype(float), 0), fls,
            cmap=matplotlib.colors.ListedColormap([colour]), alpha=0.75, vmin=0, vmax=1)
        widened = np.ma.masked_equal(wide.masks[k].astype(float) - exact.masks[k], 0)
        fan(ax, widened, fls, cmap=matplotlib.colors.ListedColormap([colour]), alpha=0.22, vmin=0, vmax=1)
        handles.append(Patch(color=colour, alpha=0.75, label=f"{r:g} m: exact ({int(exact.masks[k].sum())} px)"))
        handles.append(Patch(color=colour, alpha=0.22,
                             label=f"{r:g} m: σ-widened ({int(wide.masks[k].sum())} px)"))
    half = np.radians(fls.azimuth_aperture / 2)
    ax.set_aspect("equal")
    # y increases to the left: port (+y) on the left, as seen from above.
    ax.set_xlim(fls.range_max * np.sin(half) * 1.05, -fls.range_max * np.sin(half) * 1.05)
    ax.set_ylim(0, fls.range_max * 1.03)
    ax.set_xlabel("y (m, + port)      ◀ port | starboard ▶")
    ax.set_ylabel("x (m, forward)")
    ax.text(0.01, 0.99, "◀ port", transform=ax.transAxes, ha="left", va="top", fontsize=10)
    ax.text(0.99, 0.99, "starboard ▶", transform=ax.transAxes, ha="right", va="top", fontsize=10)
    ax.set_title(f"Oculus ping {ping.ping_id} ({ping.frequency / 1e6:.1f} MHz), seen from above; masks of "
                 f"sidescan detections at {', '.join(f'{r:g}' for r in DETECTIONS)} m", fontsize=9)
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8,
              title=f"pose covariance, coverage {COVERAGE}", title_fontsize=8)
    png = os.path.join(args.out, "oculus_masks.png")
    fig.savefig(png, dpi=110, bbox_inches="tight")
    print(f"  figure: {png}")


if __name__ == "__main__":
    main()
