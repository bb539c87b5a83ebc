"""Sonar pings read from ROS 2 bags written by an independent library: `mcap-ros2-support`
serialises the messages from the real `marine_acoustic_msgs` definitions (its own CDR encoder,
not the engine's), and `sonarproj sonar from-bag` must give back each ping's sonar (as the beam
table reader makes it) and its image in the sonar's beam order."""

import math

import mcap_ros2.writer as mcap_ros2_writer
import numpy as np
import pytest

import sonarproj

# The definitions as the ROS 2 packages give them (marine_acoustic_msgs 2.x, std_msgs,
# builtin_interfaces, geometry_msgs), in the form a bag's schema holds them.
SEPARATOR = "=" * 80
DEFINITION = "\n".join(
    [
        "std_msgs/Header header\nPingInfo ping_info\ngeometry_msgs/Vector3[] beam_directions\n"
        "float32[] ranges\nSonarImageData image",
        SEPARATOR,
        "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id",
        SEPARATOR,
        "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec",
        SEPARATOR,
        "MSG: marine_acoustic_msgs/PingInfo\nfloat32 frequency\nfloat32 sound_speed\n"
        "float32[] tx_beamwidths\nfloat32[] rx_beamwidths",
        SEPARATOR,
        "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z",
        SEPARATOR,
        "MSG: marine_acoustic_msgs/SonarImageData\nbool is_bigendian\nuint32 DTYPE_UINT8=0\n"
        "uint32 DTYPE_UINT16=2\nuint32 dtype\nuint32 beam_count\nuint8[] data",
    ]
)


def fan(beams, bins, half=0.5):
    """Beams from +half to -half rad of azimuth (port to starboard: the message's Y, to starboard,
    increasing), uneven like a real driver's; bins of 2 cm from 0.51 m."""
    az = [half * math.sin(math.pi / 2 * (1 - 2 * k / (beams - 1))) for k in range(beams)]
    directions = [(0.0, -math.sin(a), math.cos(a)) for a in az]
    ranges = [0.51 + 0.02 * i for i in range(bins)]
    return directions, ranges


def message(sec, directions, ranges, image, frame="sonar_link"):
    beams = len(directions)
    big = image.dtype.byteorder == ">"
    return {
        "header": {"stamp": {"sec": sec, "nanosec": 5}, "frame_id": frame},
        "ping_info": {
            "frequency": 1.2e6,
            "sound_speed": 1500.0,
            "tx_beamwidths": [math.radians(20.0)] * beams,
            "rx_beamwidths": [math.radians(0.6)] * beams,
        },
        "beam_directions": [{"x": x, "y": y, "z": z} for x, y, z in directions],
        "ranges": ranges,
        "image": {
            "is_bigendian": big,
            "dtype": 0 if image.dtype.itemsize == 1 else 2,
            "beam_count": beams,
            "data": image.tobytes(),
        },
    }


def write_bag(path, topic, messages):
    with open(path, "wb") as f:
        writer = mcap_ros2_writer.Writer(f)
        schema = writer.register_msgdef("marine_acoustic_msgs/msg/ProjectedSonarImage", DEFINITION)
        for k, m in enumerate(messages):
            writer.write_message(topic=topic, schema=schema, message=m, log_time=k, publish_time=k)
        writer.finish()


def test_from_bag_reads_each_ping_as_the_beam_table_reader_does(cli, tmp_path):
    rng = np.random.default_rng(5)
    d1, r1 = fan(64, 40)
    d2, r2 = fan(96, 70, half=0.6)
    images = [
        rng.integers(0, 256, (40, 64), dtype=np.uint8),
        rng.integers(0, 65536, (70, 96), dtype=np.uint16).astype(">u2"),
        rng.integers(0, 65536, (70, 96), dtype=np.uint16),
    ]
    tables = [(d1, r1), (d2, r2), (d2, r2)]
    bag = tmp_path / "log.mcap"
    write_bag(bag, "/oculus/sonar_image", [message(100 + k, *t, im) for k, (t, im) in enumerate(zip(tables, images))])
    for k, ((directions, ranges), image) in enumerate(zip(tables, images)):
        out = tmp_path / f"ping{k}"
        done = cli("sonar", "from-bag", str(bag), "--ping", str(k), "--out", str(out))
        assert f"ping {k}: {len(ranges)} ranges × {len(directions)} beams" in done.stdout
        # The message's ranges are float32: the reader sees what the bag holds.
        held = np.asarray(ranges, dtype=np.float32).astype(float)
        want, columns = sonarproj.Sonar.from_projected_sonar_image(
            directions, held, math.degrees(np.float32(math.radians(20.0))), name="oculus/sonar_image"
        )
        got = sonarproj.Sonar.from_toml(out / "sonar.toml")
        assert (got.range_bins, got.beams) == (want.range_bins, want.beams)
        assert got.range_min == pytest.approx(want.range_min, abs=1e-12)
        assert got.range_max == pytest.approx(want.range_max, abs=1e-12)
        assert got.elevation_aperture == pytest.approx(want.elevation_aperture, abs=1e-12)
        np.testing.assert_allclose(got.beam_edges, want.beam_edges, rtol=0, atol=1e-12)
        # Beams listed port to starboard: the sonar's beam 0 (starboard-most) is the last column.
        assert list(columns) == list(range(len(directions)))[::-1]
        np.testing.assert_array_equal(np.load(out / "image.npy"), image[:, columns].astype(image.dtype.newbyteorder("=")))


def test_from_bag_refuses_a_missing_topic_naming_the_ones_there_are(cli, tmp_path):
    d, r = fan(16, 10)
    bag = tmp_path / "log.mcap"
    write_bag(bag, "/sonar", [message(1, d, r, np.zeros((10, 16), dtype=np.uint8))])
    done = cli("sonar", "from-bag", str(bag), "--topic", "/other", "--out", str(tmp_path / "o"), check=False)
    assert done.returncode == 2, done.stderr
    assert 'no topic "/other"' in done.stderr and '"/sonar"' in done.stderr, done.stderr
    assert not (tmp_path / "o").exists()
    done = cli("sonar", "from-bag", str(bag), "--ping", "1", "--out", str(tmp_path / "o"), check=False)
    assert done.returncode == 2 and "--ping" in done.stderr, done.stderr
    assert not (tmp_path / "o").exists()


def test_read_bag_streams_the_pings_as_the_command_line_reads_them(cli, tmp_path):
    rng = np.random.default_rng(8)
    d, r = fan(48, 30)
    images = [rng.integers(0, 256, (30, 48), dtype=np.uint8) for _ in range(5)]
    bag = tmp_path / "log.mcap"
    write_bag(bag, "/fls", [message(200 + k, d, r, im, frame="fls_link") for k, im in enumerate(images)])
    pings = sonarproj.read_bag(bag)
    assert iter(pings) is pings
    got = list(pings)
    assert [p.index for p in got] == list(range(5))
    assert [p.stamp_ns for p in got] == [(200 + k) * 10**9 + 5 for k in range(5)]
    assert [p.time for p in got] == pytest.approx([200 + k + 5e-9 for k in range(5)], abs=1e-6)
    assert {p.frame_id for p in got} == {"fls_link"}
    # One table, one sonar object; the image in the sonar's beam order.
    assert all(p.sonar is got[0].sonar for p in got)
    for p, image in zip(got, images):
        np.testing.assert_array_equal(p.image, image[:, ::-1])
    out = tmp_path / "ping3"
    cli("sonar", "from-bag", str(bag), "--topic", "/fls", "--ping", "3", "--out", str(out))
    np.testing.assert_array_equal(np.load(out / "image.npy"), got[3].image)
    assert sonarproj.Sonar.from_toml(out / "sonar.toml").beam_edges.tolist() == got[3].sonar.beam_edges.tolist()
    assert "BagPing 3" in repr(got[3]) and "30 ranges × 48 beams" in repr(got[3])


def test_read_bag_refuses_bad_input_naming_it(tmp_path):
    d, r = fan(16, 10)
    bag = tmp_path / "log.mcap"
    write_bag(bag, "/sonar", [message(1, d, r, np.zeros((10, 16), dtype=np.uint8))])
    with pytest.raises(sonarproj.InputError, match='no topic "/x".*"/sonar"'):
        list(sonarproj.read_bag(bag, "/x"))
    with pytest.raises(sonarproj.InputTypeError, match="topic"):
        sonarproj.read_bag(bag, 5)
    with pytest.raises(sonarproj.InputTypeError, match="path"):
        sonarproj.read_bag(5)
    with pytest.raises(sonarproj.InputError, match="elevation"):
        sonarproj.read_bag(bag, elevation=-1)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(bag.read_bytes()[:200])
    with pytest.raises(sonarproj.InputError, match="MCAP"):
        list(sonarproj.read_bag(cut))


TF_DEFINITION = "\n".join(
    [
        "geometry_msgs/TransformStamped[] transforms",
        SEPARATOR,
        "MSG: geometry_msgs/TransformStamped\nstd_msgs/Header header\nstring child_frame_id\nTransform transform",
        SEPARATOR,
        "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id",
        SEPARATOR,
        "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec",
        SEPARATOR,
        "MSG: geometry_msgs/Transform\nVector3 translation\nQuaternion rotation",
        SEPARATOR,
        "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z",
        SEPARATOR,
        "MSG: geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1",
    ]
)


def quaternion_xyzw(r):
    """The unit quaternion (x, y, z, w) of rotation matrix `r`, from its largest component."""
    t = np.trace(r)
    k = int(np.argmax([t, r[0, 0], r[1, 1], r[2, 2]]))
    if k == 0:
        w = math.sqrt(1 + t) / 2
        return [(r[2, 1] - r[1, 2]) / (4 * w), (r[0, 2] - r[2, 0]) / (4 * w), (r[1, 0] - r[0, 1]) / (4 * w), w]
    i, j, l = [(0, 1, 2), (1, 2, 0), (2, 0, 1)][k - 1]
    q = [0.0, 0.0, 0.0]
    q[i] = math.sqrt(1 + r[i, i] - r[j, j] - r[l, l]) / 2
    q[j] = (r[j, i] + r[i, j]) / (4 * q[i])
    q[l] = (r[l, i] + r[i, l]) / (4 * q[i])
    w = (r[l, j] - r[j, l]) / (4 * q[i])
    return [*q, w]


def test_masks_of_bag_draws_each_pings_features_under_the_logged_rig(cli, tmp_path):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    # Sonar 2 (the pings' frame "oculus", X up and Z forward) looks forward like base_link;
    # sonar 1 (paper-fls, REP 103 axes) sits 0.3 m to port, yawed 4° to starboard.
    d, r = fan(40, 80, half=0.5)
    r = [1.0 + 0.1 * i for i in range(80)]
    image_axes = np.array([[0.0, 0.0, 1.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]])
    yaw = math.radians(-4.0)
    r_fls = np.array([[math.cos(yaw), -math.sin(yaw), 0], [math.sin(yaw), math.cos(yaw), 0], [0, 0, 1]])
    t_fls = np.array([0.0, 0.3, 0.0])

    def stamped(child, rot, t):
        x, y, z, w = quaternion_xyzw(rot)
        return {
            "header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": "base_link"},
            "child_frame_id": child,
            "transform": {"translation": {"x": t[0], "y": t[1], "z": t[2]}, "rotation": {"x": x, "y": y, "z": z, "w": w}},
        }

    bag = tmp_path / "log.mcap"
    with open(bag, "wb") as f:
        writer = mcap_ros2_writer.Writer(f)
        tf = writer.register_msgdef("tf2_msgs/msg/TFMessage", TF_DEFINITION)
        sonar = writer.register_msgdef("marine_acoustic_msgs/msg/ProjectedSonarImage", DEFINITION)
        # The oculus frame's axes in base_link: the image axes' matrix itself (X_o up, Z_o forward).
        transforms = {"transforms": [stamped("fls_link", r_fls, t_fls), stamped("oculus", image_axes.T, [0, 0, 0])]}
        writer.write_message(topic="/tf_static", schema=tf, message=transforms, log_time=0, publish_time=0)
        for k in range(3):
            m = message(10 + k, d, r, np.zeros((80, 40), dtype=np.uint8), frame="oculus")
            writer.write_message(topic="/sonar", schema=sonar, message=m, log_time=k + 1, publish_time=k + 1)
        writer.finish()
    features = tmp_path / "features.csv"
    features.write_text("stamp_ns,range,azimuth\n10000000005,5,0\n10000000005,3,10\n12000000005,6,-15\n")
    got = sonarproj.masks_of_bag(bag, "paper-fls", "fls_link", features, tmp_path / "py.mcap", backend="cpu-fast")
    assert got == {
        "topic": "/sonar",
        "masks_topic": "/sonar/masks",
        "pings": 3,
        "pings_with_features": 2,
        "features": 3,
        "unmatched": 0,
    }
    done = cli(
        "mask", "--from", "paper-fls", "--bag", str(bag), "--from-frame", "fls_link",
        "--features", str(features), "--out", str(tmp_path / "cli.mcap"), "--backend", "cpu-fast",
    )
    assert "3 pings of \"/sonar\" (2 with features, 3 features drawn, 0 matched no ping)" in done.stdout
    # The pose in this project's convention, from the matrices: sonar 1 → base_link → oculus,
    # then the oculus axes into this project's.
    rot = image_axes @ image_axes @ r_fls  # oculus in base_link is image_axesᵀ; its inverse is image_axes
    pose = sonarproj.Pose.from_matrix(rot, t=(image_axes @ image_axes @ t_fls).tolist())
    ping = next(iter(sonarproj.read_bag(bag)))
    want = {
        0: [(5.0, 0.0), (3.0, 10.0)],
        2: [(6.0, -15.0)],
    }
    for name in ("py.mcap", "cli.mcap"):
        with open(tmp_path / name, "rb") as f:
            decoded = list(make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages())
        assert len(decoded) == 3
        for k, (schema, channel, msg, image) in enumerate(decoded):
            assert (schema.name, channel.topic) == ("sensor_msgs/msg/Image", "/sonar/masks")
            assert (image.header.stamp.sec, image.header.frame_id) == (10 + k, "oculus")
            assert (image.height, image.width, image.step, image.encoding) == (80, 40, 40, "mono8")
            pixels = np.frombuffer(bytes(image.data), dtype=np.uint8).reshape(80, 40)
            if k in want:
                union = sonarproj.masks("paper-fls", ping.sonar, pose, want[k], backend="cpu-fast").union
                # The image is in the message's columns: beam b is column 39 − b.
                np.testing.assert_array_equal(pixels[:, ::-1] == 255, union.astype(bool), err_msg=f"{name} ping {k}")
                assert union.any()
            else:
                assert not pixels.any()
