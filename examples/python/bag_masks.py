"""Correspondence masks for a whole robot log: Oculus pings in a ROS 2 bag, the rig in its /tf_static.

The Oculus pings (a recorded file with `--ping FILE.raw`, e.g. the liboculus test pings, or a
synthetic one) are converted into `marine_acoustic_msgs/ProjectedSonarImage` messages as the
UW-APL `oculus_sonar_driver` publishes them (bearing b as the direction (0, -sin b, cos b) in a
frame with X up and Z forward), and written with the rig's transforms into an MCAP bag by
`mcap-ros2-support` (the library ROS 2 tools write bags with). Then:

1. `sonarproj.read_bag` reads the pings back, and each ping's sonar and image are checked against
   what `sonarproj.read_oculus` gives for the same ping;
2. `sonarproj.masks_of_bag` draws, for every ping, the masks of three sidescan detections of its
   stamp under the logged rig, into `masks.mcap` (a `sensor_msgs/Image` per ping, which Foxglove
   opens beside the bag);
3. the first ping is drawn with its masks, read back from `masks.mcap`, as a fan seen from above.

Run:  python examples/python/bag_masks.py [--ping FILE.raw] [--out DIR] [--backend auto|cpu|gpu]
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
from mcap.reader import make_reader  # noqa: E402
from mcap_ros2.decoder import DecoderFactory  # noqa: E402
from mcap_ros2.writer import Writer  # noqa: E402

import sonarproj  # noqa: E402
from oculus_masks import COVARIANCE, DETECTIONS, PITCH, ROLL, SIGMA_RANGE, T, YAW, fan, write_synthetic_ping  # noqa: E402

TOPIC = "/oculus/sonar_image"
SEPARATOR = "=" * 80
HEADER = "\n".join(
    [
        SEPARATOR,
        "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id",
        SEPARATOR,
        "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec",
    ]
)
# The message definitions as their ROS 2 packages give them.
PING_DEFINITION = "\n".join(
    [
        "std_msgs/Header header\nPingInfo ping_info\ngeometry_msgs/Vector3[] beam_directions\n"
        "float32[] ranges\nSonarImageData image",
        HEADER,
        SEPARATOR,
        "MSG: marine_acoustic_msgs/PingInfo\nfloat32 frequency\nfloat32 sound_speed\n"
        "float32[] tx_beamwidths\nfloat32[] rx_beamwidths",
        SEPARATOR,
        "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z",
        SEPARATOR,
        "MSG: marine_acoustic_msgs/SonarImageData\nbool is_bigendian\nuint32 dtype\nuint32 beam_count\nuint8[] data",
    ]
)
TF_DEFINITION = "\n".join(
    [
        "geometry_msgs/TransformStamped[] transforms",
        SEPARATOR,
        "MSG: geometry_msgs/TransformStamped\nstd_msgs/Header header\nstring child_frame_id\nTransform transform",
        HEADER,
        SEPARATOR,
        "MSG: geometry_msgs/Transform\nVector3 translation\nQuaternion rotation",
        SEPARATOR,
        "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z",
        SEPARATOR,
        "MSG: geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1",
    ]
)
# The message's axes (X up, Y starboard, Z forward) in REP 103's and sonarproj's (x forward,
# y port, z up): a point (X, Y, Z) of the message is (Z, -Y, X). It is its own inverse.
IMAGE_AXES = np.array([[0.0, 0.0, 1.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]])


def parse_args() -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--ping", help="an Oculus file (default: a synthetic ping written to --out)")
    p.add_argument("--out", help="output directory (default: a new temporary directory)")
    p.add_argument("--backend", default="auto", help="auto (default), cpu or gpu")
    a = p.parse_args()
    a.out = a.out or tempfile.mkdtemp(prefix="sonarproj-bag-")
    os.makedirs(a.out, exist_ok=True)
    return a


def quaternion_xyzw(r: np.ndarray) -> list[float]:
    """The unit quaternion (x, y, z, w) of rotation matrix `r`, from its largest component."""
    t = np.trace(r)
    k = int(np.argmax([t, r[0, 0], r[1, 1], r[2, 2]]))
    if k == 0:
        w = math.sqrt(1 + t) / 2
        return [(r[2, 1] - r[1, 2]) / (4 * w), (r[0, 2] - r[2, 0]) / (4 * w), (r[1, 0] - r[0, 1]) / (4 * w), w]
    i, j, m = [(0, 1, 2), (1, 2, 0), (2, 0, 1)][k - 1]
    q = [0.0, 0.0, 0.0]
    q[i] = math.sqrt(1 + r[i, i] - r[j, j] - r[m, m]) / 2
    q[j] = (r[j, i] + r[i, j]) / (4 * q[i])
    q[m] = (r[m, i] + r[i, m]) / (4 * q[i])
    return [*q, (r[m, j] - r[j, m]) / (4 * q[i])]


def ping_message(ping: sonarproj.OculusPing, sec: int) -> dict:
    """The ProjectedSonarImage of an Oculus ping: one direction per bearing, the centre of each
    range line, the elevation aperture as the transmit beam width (rad), the image as sent."""
    b = np.radians(ping.bearings)
    res = ping.range_resolution
    rows, beams = ping.image.shape
    return {
        "header": {"stamp": {"sec": sec, "nanosec": 0}, "frame_id": "oculus"},
        "ping_info": {
            "frequency": ping.frequency,
            "sound_speed": 1500.0,
            "tx_beamwidths": [math.radians(ping.sonar.elevation_aperture)] * beams,
            "rx_beamwidths": [],
        },
        "beam_directions": [{"x": 0.0, "y": -math.sin(a), "z": math.cos(a)} for a in b],
        "ranges": [(i + 0.5) * res for i in range(rows)],
        "image": {
            "is_bigendian": False,
            "dtype": 0 if ping.image.dtype == np.uint8 else 2,
            "beam_count": beams,
            "data": ping.image.astype(ping.image.dtype.newbyteorder("<")).tobytes(),
        },
    }


def write_bag(path: str, pings: list, pose: sonarproj.Pose) -> None:
    """Writes the pings (a second apart) and the rig: the sidescan's frame is base_link, and the
    Oculus frame (message axes) is placed so that a sidescan point p is R p + t in the Oculus's
    sonarproj axes: its rotation in base_link is R^T M and its origin -R^T t (M = IMAGE_AXES)."""
    r, t = pose.rotation, pose.translation
    rot, origin = r.T @ IMAGE_AXES, -(r.T @ t)
    x, y, z, w = quaternion_xyzw(rot)
    link = {
        "header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": "base_link"},
        "child_frame_id": "oculus",
        "transform": {
            "translation": {"x": origin[0], "y": origin[1], "z": origin[2]},
            "rotation": {"x": x, "y": y, "z": z, "w": w},
        },
    }
    with open(path, "wb") as f:
        writer = Writer(f)
        tf = writer.register_msgdef("tf2_msgs/msg/TFMessage", TF_DEFINITION)
        sonar = writer.register_msgdef("marine_acoustic_msgs/msg/ProjectedSonarImage", PING_DEFINITION)
        writer.write_message(topic="/tf_static", schema=tf, message={"transforms": [link]}, log_time=0, publish_time=0)
        for k, p in enumerate(pings):
            ns = (k + 1) * 10**9
            writer.write_message(topic=TOPIC, schema=sonar, message=ping_message(p, k + 1), log_time=ns, publish_time=ns)
        writer.finish()


def main() -> None:
    args = parse_args()
    path = args.ping
    if path is None:
        path = os.path.join(args.out, "synthetic_ping.raw")
        write_synthetic_ping(path)
    pings = sonarproj.read_oculus(path)
    pose = sonarproj.Pose(ROLL, PITCH, YAW, t=T)
    bag = os.path.join(args.out, "log.mcap")
    write_bag(bag, pings, pose)

    # 1. The bag's pings are the Oculus file's: the same beams and image; the range bins as the
    # message's float32 centres give them.
    for oculus, logged in zip(pings, sonarproj.read_bag(bag), strict=True):
        np.testing.assert_array_equal(logged.image, oculus.image)
        np.testing.assert_allclose(logged.sonar.beam_edges, oculus.sonar.beam_edges, rtol=0, atol=1e-9)
        assert logged.sonar.range_bins == oculus.sonar.range_bins
        assert abs(logged.sonar.range_max - oculus.sonar.range_max) < 1e-6 * oculus.sonar.range_max
    print(f"bag_masks: {len(pings)} Oculus ping(s) of {path} written to {bag} and read back alike")

    # 2. The masks of every ping, under the logged rig.
    features = os.path.join(args.out, "features.csv")
    with open(features, "w") as f:
        f.write("stamp,range\n")
        for k in range(len(pings)):
            f.writelines(f"{k + 1},{r}\n" for r in DETECTIONS)
    masks = os.path.join(args.out, "masks.mcap")
    report = sonarproj.masks_of_bag(bag, "holoocean-sidescan", "base_link", features, masks,
                                    covariance=COVARIANCE, sigma={"range": SIGMA_RANGE}, backend=args.backend)
    print(f"  masks: {report['pings']} pings, {report['features']} features drawn, "
          f"{report['unmatched']} of no ping; {masks} ({report['masks_topic']})")

    # The masks equal those of the mask engine under the pose itself.
    with open(masks, "rb") as f:
        decoded = list(make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages())
    first = decoded[0].decoded_message
    mask = np.frombuffer(bytes(first.data), dtype=np.uint8).reshape(first.height, first.width) == 255
    direct = sonarproj.masks("holoocean-sidescan", pings[0].sonar, pose, DETECTIONS, covariance=COVARIANCE,
                             sigma={"range": SIGMA_RANGE}, backend=args.backend)
    np.testing.assert_array_equal(mask, direct.union.astype(bool))
    print(f"  ping 1: {int(mask.sum())} px of masks, as the mask engine draws them under the pose itself")

    # 3. The first ping with its masks from masks.mcap.
    fls = pings[0].sonar
    fig, ax = plt.subplots(figsize=(7.6, 6.4))
    fan(ax, pings[0].image.astype(float), fls, cmap="gray", vmin=0, vmax=np.percentile(pings[0].image, 99.5))
    fan(ax, np.ma.masked_equal(mask.astype(float), 0), fls,
        cmap=matplotlib.colors.ListedColormap(["tab:orange"]), alpha=0.55, vmin=0, vmax=1)
    half = np.radians(fls.azimuth_aperture / 2)
    ax.set_aspect("equal")
    ax.set_xlim(fls.range_max * np.sin(half) * 1.05, -fls.range_max * np.sin(half) * 1.05)
    ax.set_ylim(0, fls.range_max * 1.03)
    ax.set_xlabel("y (m, + port)      ◀ port | starboard ▶")
    ax.set_ylabel("x (m, forward)")
    ax.set_title(f"Ping 1 of {os.path.basename(bag)} ({TOPIC}) with its masks from masks.mcap\n"
                 f"(sidescan detections at {', '.join(f'{r:g}' for r in DETECTIONS)} m, rig from /tf_static, "
                 "σ-widened)", fontsize=9)
    png = os.path.join(args.out, "bag_masks.png")
    fig.savefig(png, dpi=110, bbox_inches="tight")
    print(f"  figure: {png}")


if __name__ == "__main__":
    main()
