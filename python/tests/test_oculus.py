"""Saved Oculus pings, built here byte by byte from the layout of the vendor's SDK header
(`Oculus.h`: OculusMessageHeader, OculusSimpleFireMessage[2], OculusSimplePingResult[2], all
packed little-endian), independently of the reader: fields, beams, image orientation, the
bearing sign, and refusals naming the offset and the field."""

import struct

import numpy as np
import pytest

import sonarproj
from sonarproj import InputError, Pose


def ping_message(version, bearings_cdeg, rows, sample_bytes, gains, frequency=2.1e6, ping_id=7,
                 range_resolution=0.01):
    """Returns one simple ping result: image value at (row, beam) = (row * 7 + beam) % 2**bits."""
    v2 = version == 2
    n = len(bearings_cdeg)
    fixed = 202 if v2 else 122
    image_offset = fixed + 2 * n + 6
    stride = n * sample_bytes + (4 if gains else 0)
    total = image_offset + rows * stride
    flags = 0x01 | 0x08 | (0x04 if gains else 0)
    head = struct.pack("<HHHHHIH", 0x4F53, 7, 0, 0x23, version, total - 16, 0)
    fire = struct.pack("<BBBBBdddd", 2, 0, 255, 127, flags, 5.0, 50.0, 1500.0, 0.0)
    if v2:
        fire += struct.pack("<I8I", 0, *([0] * 8))
        result = struct.pack("<IIddddddddBdHH4IIII", ping_id, 0, frequency, 10.0, 1.0, 90.0, 1.0, 2.0,
                             1500.0, 12.5, 1 if sample_bytes == 2 else 0, range_resolution, rows, n,
                             0, 0, 0, 0, image_offset, rows * stride, total)
    else:
        result = struct.pack("<IIddddIBdHHIII", ping_id, 0, frequency, 10.0, 1.0, 1500.0, 125,
                             1 if sample_bytes == 2 else 0, range_resolution, rows, n, image_offset,
                             rows * stride, total)
    body = head + fire + result
    assert len(body) == fixed
    body += struct.pack(f"<{n}h", *bearings_cdeg)
    body += b"\0" * (image_offset - len(body))
    for r in range(rows):
        if gains:
            body += struct.pack("<f", 1000.0 + r)  # the row's gain, a float32
        values = [(r * 7 + c) % (256 if sample_bytes == 1 else 65536) for c in range(n)]
        body += struct.pack(f"<{n}{'B' if sample_bytes == 1 else 'H'}", *values)
    assert len(body) == total
    return body


BEARINGS = [-3000, -2000, -1100, -400, 0, 350, 1000, 2100, 3000]


@pytest.mark.parametrize("version, sample_bytes, gains", [(1, 1, False), (0, 1, True), (2, 2, True), (2, 1, False)])
def test_a_ping_reads_as_its_sonar_and_image(tmp_path, version, sample_bytes, gains):
    f = tmp_path / "ping.raw"
    f.write_bytes(ping_message(version, BEARINGS, 11, sample_bytes, gains))
    [p] = sonarproj.read_oculus(f)
    assert (p.ping_id, p.frequency, p.range_resolution, p.version) == (7, 2.1e6, 0.01, 2 if version == 2 else 1)
    assert p.image.shape == (11, len(BEARINGS)) and p.image.dtype == (np.uint8 if sample_bytes == 1 else np.uint16)
    rows, cols = np.indices(p.image.shape)
    np.testing.assert_array_equal(p.image, (rows * 7 + cols) % (256 if sample_bytes == 1 else 65536))
    assert p.bearings == [b / 100 for b in BEARINGS]
    assert (p.gains is not None) == gains
    assert not gains or (p.gains.dtype == np.float32 and list(p.gains) == [1000.0 + r for r in range(11)])
    s = p.sonar
    assert (s.kind, s.range_min, s.range_bins, s.beams, s.elevation_aperture) == ("fls", 0.0, 11, len(BEARINGS), 12.0)
    assert s.range_max == pytest.approx(0.11, abs=1e-15)
    edges = s.beam_edges
    for j, b in enumerate(BEARINGS):
        assert edges[j] < b / 100 < edges[j + 1]


def test_a_positive_bearing_is_port_and_lands_in_its_own_column(tmp_path):
    # The ping's sonar looks at a point placed 20° to port (+y, this project's azimuth); the
    # occupied column is the one whose Oculus bearing is +21°, the beam containing +20°.
    f = tmp_path / "ping.raw"
    f.write_bytes(ping_message(1, BEARINGS, 400, 1, False, range_resolution=0.025))
    [p] = sonarproj.read_oculus(f)
    sss = sonarproj.Sonar("sss", 0.5, 20, 170, 0.2, 1000)
    pose = Pose.placement((8.0, 0.0, 0.0), (6.0, 20.0, 0.0), roll=90)
    m = sonarproj.project(sss, p.sonar, pose, 8.0, step=0.01, occupancy=True, backend="cpu")
    columns = np.nonzero(m["occupancy"].any(axis=0))[0]
    truth_column = int(np.argmin([abs(b / 100 - 20.0) for b in BEARINGS]))
    assert BEARINGS[truth_column] == 2100
    assert truth_column in columns, (columns, m["azimuth_min"], m["azimuth_max"])
    # Port columns are the high ones: the image is in the project's layout as it comes.
    assert truth_column > len(BEARINGS) // 2


def test_several_pings_in_one_file(tmp_path):
    f = tmp_path / "pings.raw"
    f.write_bytes(ping_message(1, BEARINGS, 4, 1, False, ping_id=1) + ping_message(2, BEARINGS, 6, 2, True, ping_id=2))
    pings = sonarproj.read_oculus(f)
    assert [(p.ping_id, p.image.shape[0], p.version) for p in pings] == [(1, 4, 1), (2, 6, 2)]
    assert pings[1].offset == len(ping_message(1, BEARINGS, 4, 1, False))


@pytest.mark.parametrize("mangle, words", [
    (lambda b: b"GIF89a" + b[6:], ["offset 0: oculusId", "not an Oculus message"]),
    (lambda b: b[:-3], ["offset 10: payloadSize", "truncated"]),
    (lambda b: b[:100], ["truncated"]),
    (lambda b: b[:97] + b"\x03" + b[98:], ["offset 97: dataSize", "32 bits"]),
    (lambda b: b[:61] + struct.pack("<d", 5e6) + b[69:], ["offset 61: frequency", "5000000 Hz"]),
])
def test_a_foreign_or_truncated_file_is_refused_naming_offset_and_field(tmp_path, mangle, words):
    f = tmp_path / "bad.raw"
    f.write_bytes(mangle(ping_message(1, BEARINGS, 4, 1, False)))
    with pytest.raises(InputError) as e:
        sonarproj.read_oculus(f)
    for w in words:
        assert w in str(e.value), (w, str(e.value))


def test_an_unknown_frequency_takes_the_elevation_given(tmp_path):
    f = tmp_path / "ping.raw"
    f.write_bytes(ping_message(1, BEARINGS, 4, 1, False, frequency=5e6))
    [p] = sonarproj.read_oculus(f, elevation=15)
    assert p.sonar.elevation_aperture == 15.0


def test_a_ping_and_its_sonar_print_in_a_few_words(tmp_path):
    # 256 measured beams: the sonar's repr summarises them instead of printing 257 edges.
    f = tmp_path / "ping.raw"
    bearings = [round(-3000 + 6000 * k / 255) for k in range(256)]
    f.write_bytes(ping_message(2, bearings, 5, 1, False, frequency=2098880.597))
    [p] = sonarproj.read_oculus(f)
    assert repr(p) == "<OculusPing 7 at byte 0 (v2): 5 ranges × 256 beams, 2.099 MHz>"
    text = repr(p.sonar)
    assert text.startswith("<Sonar 'oculus-ping-7': fls, 0–0.05 m in 5 range bins, 256 beams, edges -30.") and len(text) < 150, text


def test_the_command_line_writes_the_same_sonar_and_image(tmp_path, cli):
    f = tmp_path / "pings.raw"
    f.write_bytes(ping_message(1, BEARINGS, 4, 1, False, ping_id=1) + ping_message(2, BEARINGS, 6, 2, True, ping_id=2))
    out = tmp_path / "out"
    cli("sonar", "from-oculus", f, "--out", out, "--ping", "1", "--gains")
    p = sonarproj.read_oculus(f)[1]
    assert sonarproj.Sonar.from_toml(out / "sonar.toml").beam_edges.tolist() == p.sonar.beam_edges.tolist()
    assert sonarproj.Sonar.from_toml(out / "sonar.toml").range_max == p.sonar.range_max
    image = np.load(out / "image.npy")
    assert image.dtype == np.uint16 and np.array_equal(image, p.image)
    assert np.array_equal(np.load(out / "gains.npy"), p.gains)
    # The sonar file's header gives the frequency as a person reads it.
    assert "2.1 MHz" in (out / "sonar.toml").read_text().splitlines()[0]
    # The sonar file works wherever one does.
    done = cli("project", "--from", "paper-sss", "--to", out / "sonar.toml", "--range", "5", "--place-range", "0.05")
    assert '"visible"' in done.stdout
    bad = cli("sonar", "from-oculus", f, "--out", tmp_path / "o2", "--ping", "2", check=False)
    assert bad.returncode == 2 and "ping = 2" in bad.stderr and "2 pings" in bad.stderr
    # --gains for a ping without them is refused before anything is written.
    none = cli("sonar", "from-oculus", f, "--out", tmp_path / "o3", "--ping", "0", "--gains", check=False)
    assert none.returncode == 2 and "--gains" in none.stderr and not (tmp_path / "o3").exists()
