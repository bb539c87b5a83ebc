//! Sonar pings read from ROS 2 bags that the `mcap` crate writes, with the messages CDR-encoded
//! by `cdr-encoding` under the real message definitions: each ping's sonar, image and stamp, and
//! a clear error for every way a bag can be wrong.
#![expect(
    clippy::cast_possible_truncation,
    clippy::cast_precision_loss,
    reason = "small counts of beams, bins and samples, built to fit"
)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use sonarproj::Sonar;
use sonarproj_apps::io::bag::{
    BagImage, BagPing, Header, PROJECTED_SONAR_IMAGE, PROJECTED_SONAR_IMAGE_DEFINITION, PingInfo,
    ProjectedSonarImage, SonarImageData, Time, Vector3, read_bag,
};

/// Returns a fan of `beams` beams from −30° to 30° listed port to starboard (the message's Y,
/// starboard, increasing), with `bins` range bins of 1 cm centred from 0.505 m.
fn fan(beams: usize, bins: usize) -> (Vec<Vector3>, Vec<f32>) {
    let dirs = (0..beams)
        .map(|k| {
            // Azimuth positive to port: the first beam is the port-most.
            let az = (30.0 - 60.0 * k as f64 / (beams - 1) as f64).to_radians();
            Vector3 {
                x: 0.0,
                y: -az.sin(),
                z: az.cos(),
            }
        })
        .collect();
    let ranges = (0..bins).map(|i| 0.505 + 0.01 * i as f32).collect();
    (dirs, ranges)
}

/// Returns a ping of `fan(beams, bins)` at `sec` whose sample at (range i, message column j) is
/// `i * beams + j` (as uint8 when small enough, else uint16 in the given byte order).
fn ping(sec: i32, beams: usize, bins: usize, big_endian: bool) -> ProjectedSonarImage {
    let (beam_directions, ranges) = fan(beams, bins);
    let n = beams * bins;
    let (dtype, data) = if n <= 256 {
        (0, (0..n).map(|v| v as u8).collect())
    } else {
        let bytes = |v: u16| {
            if big_endian {
                v.to_be_bytes()
            } else {
                v.to_le_bytes()
            }
        };
        (2, (0..n).flat_map(|v| bytes(v as u16)).collect())
    };
    ProjectedSonarImage {
        header: Header {
            stamp: Time {
                sec,
                nanosec: 250_000_000,
            },
            frame_id: "oculus".into(),
        },
        ping_info: PingInfo {
            frequency: 1.2e6,
            sound_speed: 1500.0,
            tx_beamwidths: vec![20f32.to_radians(); beams],
            rx_beamwidths: vec![0.6f32.to_radians(); beams],
        },
        beam_directions,
        ranges,
        image: SonarImageData {
            is_bigendian: big_endian,
            dtype,
            beam_count: beams as u32,
            data,
        },
    }
}

/// Writes a bag at `path`: `pings` on `topic` under the real definition, and a string message on
/// `/chatter` before each.
fn write_bag(path: &Path, topic: &str, pings: &[ProjectedSonarImage]) {
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut w = mcap::WriteOptions::new().profile("ros2").create(file).unwrap();
    let schema = w
        .add_schema(
            PROJECTED_SONAR_IMAGE,
            "ros2msg",
            PROJECTED_SONAR_IMAGE_DEFINITION.as_bytes(),
        )
        .unwrap();
    let channel = w.add_channel(schema, topic, "cdr", &BTreeMap::new()).unwrap();
    let text = w
        .add_schema("std_msgs/msg/String", "ros2msg", b"string data")
        .unwrap();
    let chatter = w.add_channel(text, "/chatter", "cdr", &BTreeMap::new()).unwrap();
    for (k, p) in pings.iter().enumerate() {
        let header = |channel_id| mcap::records::MessageHeader {
            channel_id,
            sequence: k as u32,
            log_time: 1_000 + k as u64,
            publish_time: 1_000 + k as u64,
        };
        // A CDR string: the encapsulation header, the length with its NUL, the bytes.
        w.write_to_known_channel(&header(chatter), &[0, 1, 0, 0, 3, 0, 0, 0, b'h', b'i', 0])
            .unwrap();
        w.write_to_known_channel(&header(channel), &p.to_cdr().unwrap())
            .unwrap();
    }
    w.finish().unwrap();
}

fn read_all(path: &Path, topic: Option<&str>) -> Result<Vec<BagPing>, String> {
    read_bag(path, topic, None)
        .map_err(|e| e.to_string())?
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| e.to_string())
}

fn tmp(name: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    (dir, path)
}

/// Every ping comes back with its stamp, frame, sonar and image. The sonar is the one the beam
/// table reader makes of the same table; pings with the same table share it. The image is in the
/// sonar's beam order: beam 0 is the starboard-most, the message's last column (the beams are
/// listed port to starboard).
#[test]
fn pings_come_back_with_their_sonar_image_and_stamp() {
    let (_dir, path) = tmp("rig.mcap");
    let pings = [
        ping(10, 16, 12, false),
        ping(11, 16, 12, false),
        ping(12, 24, 20, true),
    ];
    write_bag(&path, "/oculus/sonar_image", &pings);
    let got = read_all(&path, None).unwrap();
    assert_eq!(got.len(), 3);
    for (k, (g, p)) in got.iter().zip(&pings).enumerate() {
        assert_eq!(g.index, k);
        assert_eq!(
            g.stamp_ns,
            i64::from(p.header.stamp.sec) * 1_000_000_000 + 250_000_000
        );
        assert_eq!(g.log_time, 1_000 + k as u64);
        assert_eq!(g.frame_id, "oculus");
        let dirs: Vec<[f64; 3]> = p.beam_directions.iter().map(|v| [v.x, v.y, v.z]).collect();
        let ranges: Vec<f64> = p.ranges.iter().map(|&r| f64::from(r)).collect();
        let (want, columns) = Sonar::from_projected_sonar_image(
            "oculus/sonar_image",
            &dirs,
            &ranges,
            f64::from(20f32.to_radians()).to_degrees(),
        )
        .unwrap();
        assert_eq!(*g.sonar, want);
        let beams = dirs.len();
        assert_eq!(columns, (0..beams).rev().collect::<Vec<_>>());
        let rows = ranges.len();
        let at = |i: usize, b: usize| (i * beams + (beams - 1 - b)) as u32;
        match &g.image {
            BagImage::U8(v) => {
                assert_eq!(v.len(), rows * beams);
                for (n, &s) in v.iter().enumerate() {
                    assert_eq!(u32::from(s), at(n / beams, n % beams), "ping {k} sample {n}");
                }
            }
            BagImage::U16(v) => {
                assert_eq!(v.len(), rows * beams);
                for (n, &s) in v.iter().enumerate() {
                    assert_eq!(u32::from(s), at(n / beams, n % beams), "ping {k} sample {n}");
                }
            }
            BagImage::F32(_) => panic!("no float pings written"),
        }
    }
    assert!(
        Arc::ptr_eq(&got[0].sonar, &got[1].sonar),
        "the same table makes one sonar"
    );
    assert_ne!(got[1].sonar, got[2].sonar);
    // Named, the topic gives the same pings; the sonar is named after it.
    let named = read_all(&path, Some("/oculus/sonar_image")).unwrap();
    assert_eq!(named.len(), 3);
    assert_eq!(named[0].sonar.name, "oculus/sonar_image");
}

/// Every way a bag can be wrong is an error naming the bag and what is wrong, never a panic.
#[test]
fn bad_bags_are_refused_naming_what_is_wrong() {
    let (dir, path) = tmp("rig.mcap");
    write_bag(&path, "/sonar", &[ping(1, 16, 12, false)]);
    let missing = read_all(&path, Some("/nope")).unwrap_err();
    assert!(
        missing.contains("no topic \"/nope\"")
            && missing.contains("\"/sonar\" (marine_acoustic_msgs/msg/ProjectedSonarImage)")
            && missing.contains("\"/chatter\" (std_msgs/msg/String)"),
        "{missing}"
    );
    let other = read_all(&path, Some("/chatter")).unwrap_err();
    assert!(
        other.contains("topic \"/chatter\" holds \"std_msgs/msg/String\""),
        "{other}"
    );
    // A truncated bag: an error (after the pings before the cut, if any), never a panic.
    let bytes = std::fs::read(&path).unwrap();
    for cut in [10, bytes.len() / 3, bytes.len() / 2, bytes.len() - 20] {
        let short = dir.path().join(format!("cut-{cut}.mcap"));
        std::fs::write(&short, &bytes[..cut]).unwrap();
        let e = read_all(&short, None).unwrap_err();
        assert!(e.contains("cut-") && e.contains("MCAP"), "{cut}: {e}");
    }
    let not_mcap = dir.path().join("text.mcap");
    std::fs::write(&not_mcap, "scenario,fraction\n1,2\n").unwrap();
    let e = read_all(&not_mcap, None).unwrap_err();
    assert!(e.contains("not a readable MCAP file"), "{e}");
    let no_pings = dir.path().join("empty.mcap");
    write_bag(&no_pings, "/sonar", &[]);
    let e = read_all(&no_pings, None).unwrap_err();
    assert!(
        e.contains("no marine_acoustic_msgs/msg/ProjectedSonarImage messages"),
        "{e}"
    );
    let fifo = dir.path().join("fifo.mcap");
    assert!(
        std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success()
    );
    let e = read_all(&fifo, None).unwrap_err();
    assert!(e.contains("not a regular file"), "{e}");
    // Messages that decode but make no sonar or image.
    type Spoil = Box<dyn Fn(&mut ProjectedSonarImage)>;
    let cases: Vec<(&str, Spoil)> = vec![
        (
            "beam_directions = 16 beams",
            Box::new(|p| p.beam_directions.swap(3, 7)),
        ),
        ("image.beam_count = 15", Box::new(|p| p.image.beam_count = 15)),
        ("image.dtype = 5", Box::new(|p| p.image.dtype = 5)),
        (
            "image.data holds 191 bytes",
            Box::new(|p| {
                p.image.data.pop();
            }),
        ),
        (
            "tx_beamwidths gives no elevation",
            Box::new(|p| p.ping_info.tx_beamwidths.clear()),
        ),
        ("ranges[", Box::new(|p| p.ranges[5] = 9.0)),
    ];
    for (want, spoil) in cases {
        let mut p = ping(1, 16, 12, false);
        spoil(&mut p);
        let bad = dir.path().join("bad.mcap");
        write_bag(&bad, "/sonar", &[ping(0, 16, 12, false), p]);
        let mut pings = read_bag(&bad, None, None).unwrap();
        assert!(pings.next().unwrap().is_ok());
        let e = pings.next().unwrap().unwrap_err().to_string();
        assert!(
            e.contains(want) && e.contains("topic \"/sonar\" message 1"),
            "{want}: {e}"
        );
        assert!(pings.next().is_none(), "nothing after an error");
    }
    // A message cut short inside: it does not decode.
    let bad = dir.path().join("short.mcap");
    let file = std::io::BufWriter::new(std::fs::File::create(&bad).unwrap());
    let mut w = mcap::Writer::new(file).unwrap();
    let schema = w
        .add_schema(
            PROJECTED_SONAR_IMAGE,
            "ros2msg",
            PROJECTED_SONAR_IMAGE_DEFINITION.as_bytes(),
        )
        .unwrap();
    let channel = w.add_channel(schema, "/sonar", "cdr", &BTreeMap::new()).unwrap();
    let data = ping(1, 16, 12, false).to_cdr().unwrap();
    let header = mcap::records::MessageHeader {
        channel_id: channel,
        sequence: 0,
        log_time: 0,
        publish_time: 0,
    };
    w.write_to_known_channel(&header, &data[..data.len() / 2])
        .unwrap();
    w.finish().unwrap();
    let e = read_all(&bad, None).unwrap_err();
    assert!(
        e.contains("does not decode as marine_acoustic_msgs/msg/ProjectedSonarImage"),
        "{e}"
    );
    // An elevation out of range is refused before the bag is opened.
    let e = read_bag(&path, None, Some(0.0)).err().unwrap().to_string();
    assert!(e.contains("elevation") && e.contains("(0, 180)"), "{e}");
}
