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

/// Returns the transform message of `child` in `parent` at `ns`: rotation `q`, translation `t`.
fn stamped(
    parent: &str,
    child: &str,
    ns: i64,
    q: glam::DQuat,
    t: [f64; 3],
) -> sonarproj_apps::io::tf::TransformStamped {
    use sonarproj_apps::io::bag::Vector3;
    use sonarproj_apps::io::tf::{Quaternion, Transform, TransformStamped};
    TransformStamped {
        header: Header {
            stamp: Time {
                sec: (ns / 1_000_000_000) as i32,
                nanosec: (ns % 1_000_000_000) as u32,
            },
            frame_id: parent.into(),
        },
        child_frame_id: child.into(),
        transform: Transform {
            translation: Vector3 {
                x: t[0],
                y: t[1],
                z: t[2],
            },
            rotation: Quaternion {
                x: q.x,
                y: q.y,
                z: q.z,
                w: q.w,
            },
        },
    }
}

mod tf {
    use super::*;
    use glam::{DMat3, DMat4, DQuat, DVec3};
    use sonarproj_apps::io::tf::{
        Axes, Frames, TF_MESSAGE, TF_MESSAGE_DEFINITION, TfMessage, TransformStamped,
    };

    /// Returns the transform message of `child` in `parent` at `ns`: rotation about z by
    /// `yaw` then y by `pitch` (deg), and translation `t`.
    fn link(parent: &str, child: &str, ns: i64, yaw: f64, pitch: f64, t: [f64; 3]) -> TransformStamped {
        let q = DQuat::from_rotation_z(yaw.to_radians()) * DQuat::from_rotation_y(pitch.to_radians());
        super::stamped(parent, child, ns, q, t)
    }

    /// The homogeneous matrix of the same transform, built from rotation matrices.
    fn matrix(yaw: f64, pitch: f64, t: [f64; 3]) -> DMat4 {
        let r = DMat3::from_rotation_z(yaw.to_radians()) * DMat3::from_rotation_y(pitch.to_radians());
        DMat4::from_cols(
            r.x_axis.extend(0.0),
            r.y_axis.extend(0.0),
            r.z_axis.extend(0.0),
            DVec3::from(t).extend(1.0),
        )
    }

    fn write(path: &Path, messages: &[(&str, TfMessage)]) {
        let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
        let mut w = mcap::Writer::new(file).unwrap();
        let schema = w
            .add_schema(TF_MESSAGE, "ros2msg", TF_MESSAGE_DEFINITION.as_bytes())
            .unwrap();
        let mut channels = BTreeMap::new();
        for (k, (topic, m)) in messages.iter().enumerate() {
            let id = *channels
                .entry(*topic)
                .or_insert_with(|| w.add_channel(schema, topic, "cdr", &BTreeMap::new()).unwrap());
            let header = mcap::records::MessageHeader {
                channel_id: id,
                sequence: k as u32,
                log_time: k as u64,
                publish_time: k as u64,
            };
            w.write_to_known_channel(&header, &m.to_cdr().unwrap()).unwrap();
        }
        w.finish().unwrap();
    }

    /// A rig: the sidescan fixed under base_link, the FLS on a pan joint that turns from 0° to
    /// 40° of yaw in a second (and moves 0.2 m) on /tf. At 0.25 s the joint is at 10° and 0.05 m:
    /// a turn about one axis interpolates linearly in its angle. The relative pose is the
    /// product of the homogeneous matrices, in either sonar's axes.
    #[test]
    fn the_rig_comes_from_the_logs_transforms() {
        let (dir, path) = tmp("tf.mcap");
        let statics = TfMessage {
            transforms: vec![
                link("base_link", "sss_link", 0, -90.0, 0.0, [0.1, -0.4, -0.2]),
                link("pan_link", "fls_link", 0, 0.0, 25.0, [0.3, 0.0, 0.05]),
            ],
        };
        let at = |ns, yaw, x| TfMessage {
            transforms: vec![link("base_link", "pan_link", ns, yaw, 0.0, [x, 0.2, 0.0])],
        };
        write(
            &path,
            &[
                ("/tf_static", statics),
                ("/tf", at(0, 0.0, 0.5)),
                ("/tf", at(1_000_000_000, 40.0, 0.7)),
            ],
        );
        let frames = Frames::read(&path).unwrap();
        let base_sss = matrix(-90.0, 0.0, [0.1, -0.4, -0.2]);
        let pan_fls = matrix(0.0, 25.0, [0.3, 0.0, 0.05]);
        for (ns, yaw, x) in [
            (0, 0.0, 0.5),
            (250_000_000, 10.0, 0.55),
            (1_000_000_000, 40.0, 0.7),
        ] {
            let base_pan = matrix(yaw, 0.0, [x, 0.2, 0.0]);
            let sss_fls = base_sss.inverse() * base_pan * pan_fls;
            let r = DMat3::from_mat4(sss_fls);
            let t = sss_fls.w_axis.truncate();
            let image = DMat3::from_cols(DVec3::Z, DVec3::NEG_Y, DVec3::X);
            for (axes, want_r, want_t) in [
                (Axes::ForwardLeftUp, r, t),
                // A point of the FLS's image frame is M p in its own axes.
                (Axes::SonarImage, r * image, t),
            ] {
                let pose = frames
                    .relative_pose(("fls_link", axes), ("sss_link", Axes::ForwardLeftUp), ns)
                    .unwrap();
                assert!(
                    (pose.rotation - want_r)
                        .to_cols_array()
                        .iter()
                        .all(|d| d.abs() < 1e-12),
                    "{ns} {axes:?}: {:?} vs {want_r:?}",
                    pose.rotation
                );
                assert!(
                    (pose.translation - want_t).length() < 1e-12,
                    "{ns}: {:?}",
                    pose.translation
                );
            }
        }
        // Before the first sample and after the last: no extrapolation.
        for ns in [-1, 1_000_000_001] {
            let e = frames
                .relative_pose(
                    ("fls_link", Axes::ForwardLeftUp),
                    ("sss_link", Axes::ForwardLeftUp),
                    ns,
                )
                .unwrap_err()
                .to_string();
            assert!(
                e.contains("no transform from \"base_link\" to \"pan_link\""),
                "{e}"
            );
        }
        let e = frames
            .relative_pose(
                ("fls_link", Axes::ForwardLeftUp),
                ("camera", Axes::ForwardLeftUp),
                0,
            )
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("not connected") && e.contains("\"camera\" is in no transform"),
            "{e}"
        );
        // A frame given two parents, and a rotation that is not one.
        let two = dir.path().join("two.mcap");
        write(
            &two,
            &[(
                "/tf_static",
                TfMessage {
                    transforms: vec![
                        link("a", "c", 0, 0.0, 0.0, [0.0; 3]),
                        link("b", "c", 0, 0.0, 0.0, [0.0; 3]),
                    ],
                },
            )],
        );
        let e = Frames::read(&two).unwrap_err().to_string();
        assert!(
            e.contains("frame \"c\" has two parents") && e.contains("transforms[1]"),
            "{e}"
        );
        let mut squashed = link("a", "c", 0, 0.0, 0.0, [0.0; 3]);
        squashed.transform.rotation.w = 2.0;
        write(
            &two,
            &[(
                "/tf_static",
                TfMessage {
                    transforms: vec![squashed],
                },
            )],
        );
        let e = Frames::read(&two).unwrap_err().to_string();
        assert!(e.contains("norm is 2"), "{e}");
    }
}

mod masks {
    use super::*;
    use glam::{DMat3, DQuat, DVec3};
    use sonarproj::masks::MaskEngine;
    use sonarproj::{Measurement, RelativePose, Rotation};
    use sonarproj_apps::io::bag::from_cdr;
    use sonarproj_apps::io::bag_masks::{BagMasks, IMAGE, Image, masks_of_bag};
    use sonarproj_apps::io::tf::{TF_MESSAGE, TF_MESSAGE_DEFINITION, TfMessage, TransformStamped};

    /// The message's axes in this project's (and REP 103's): X up, Y starboard, Z forward.
    fn image_axes() -> DMat3 {
        DMat3::from_cols(DVec3::Z, DVec3::NEG_Y, DVec3::X)
    }

    fn transform(parent: &str, child: &str, r: DMat3, t: [f64; 3]) -> TransformStamped {
        super::stamped(parent, child, 0, DQuat::from_mat3(&r), t)
    }

    /// A ping of a 32-beam, ±30° sonar with 10 cm bins from 1 m to 10 m, at `sec` s + 0.25 s.
    fn long_ping(sec: i32) -> ProjectedSonarImage {
        let mut p = ping(sec, 32, 90, false);
        p.ranges = (0..90).map(|i| 1.05 + 0.1 * i as f32).collect();
        p.header.frame_id = "oculus".into();
        p
    }

    /// For every ping, the mask image is the union of the masks the engine draws for the
    /// features of its stamp under the pose the rig's matrices give (built here from the
    /// rotation matrices, with the FLS's frame in the message's axes), laid out in the message's
    /// columns. A ping without features gets an empty image; a feature of no ping's stamp is
    /// counted apart.
    #[test]
    fn every_ping_gets_the_masks_of_its_features_under_the_rig_of_the_log() {
        let (dir, path) = tmp("log.mcap");
        // Sonar 1 (paper-fls) 0.4 m to port of base_link, pitched 10° down; sonar 2 (the
        // pings' oculus frame, X up and Z forward) at the origin, yawed 5° to port.
        let r_fls = DMat3::from_rotation_z(0.0) * DMat3::from_rotation_y(10f64.to_radians());
        let r_oculus = DMat3::from_rotation_z(5f64.to_radians()) * image_axes();
        let (t_fls, t_oculus) = ([0.1, 0.4, 0.0], [0.0, 0.0, -0.05]);
        let pings = [long_ping(100), long_ping(101), long_ping(102)];
        {
            let file = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
            let mut w = mcap::Writer::new(file).unwrap();
            let tf_schema = w
                .add_schema(TF_MESSAGE, "ros2msg", TF_MESSAGE_DEFINITION.as_bytes())
                .unwrap();
            let tf = w
                .add_channel(tf_schema, "/tf_static", "cdr", &BTreeMap::new())
                .unwrap();
            let schema = w
                .add_schema(
                    PROJECTED_SONAR_IMAGE,
                    "ros2msg",
                    PROJECTED_SONAR_IMAGE_DEFINITION.as_bytes(),
                )
                .unwrap();
            let sonar = w
                .add_channel(schema, "/oculus/sonar_image", "cdr", &BTreeMap::new())
                .unwrap();
            let statics = TfMessage {
                transforms: vec![
                    transform("base_link", "fls_link", r_fls, t_fls),
                    transform("base_link", "oculus", r_oculus, t_oculus),
                ],
            };
            let header = |channel_id, k: u64| mcap::records::MessageHeader {
                channel_id,
                sequence: k as u32,
                log_time: 50 + k,
                publish_time: 50 + k,
            };
            w.write_to_known_channel(&header(tf, 0), &statics.to_cdr().unwrap())
                .unwrap();
            for (k, p) in pings.iter().enumerate() {
                w.write_to_known_channel(&header(sonar, k as u64), &p.to_cdr().unwrap())
                    .unwrap();
            }
            w.finish().unwrap();
        }
        // Ping 0: two features; ping 1: none; ping 2: one, its stamp written in ns; and one
        // feature at a stamp of no ping.
        let features = dir.path().join("features.csv");
        std::fs::write(
            &features,
            "stamp,range,azimuth\n100.25,5,0\n100.25,7.5,-12\n102.25,4,20\n150.0,5,0\n",
        )
        .unwrap();
        let source = Sonar::preset("paper-fls").unwrap();
        let job = BagMasks {
            bag: &path,
            topic: None,
            elevation: None,
            source: &source,
            from_frame: "fls_link",
            to_frame: None,
            features: &features,
            noise: None,
        };
        let out = dir.path().join("masks.mcap");
        let engine = |target: Sonar| Ok(MaskEngine::new(source.clone(), target)?);
        let report = masks_of_bag(&job, &engine, &out).unwrap();
        assert_eq!(
            (
                report.pings,
                report.pings_with_features,
                report.features,
                report.unmatched
            ),
            (3, 2, 3, 1)
        );
        assert_eq!(report.masks_topic, "/oculus/sonar_image/masks");
        // The pose: p2 = M⁻¹-free form: sonar 2's axes are the message's, so a point of sonar 1
        // (REP 103) goes to base_link, then into the oculus frame, then into this project's axes.
        let r = image_axes() * r_oculus.transpose() * r_fls;
        let t = image_axes() * (r_oculus.transpose() * (DVec3::from(t_fls) - DVec3::from(t_oculus)));
        let pose = RelativePose::new(Rotation::Matrix(r.transpose().to_cols_array_2d()), t).unwrap();
        let bagged = read_all(&path, None).unwrap();
        let target = (*bagged[0].sonar).clone();
        let reference = MaskEngine::new(source.clone(), target).unwrap();
        let want_features: [Vec<Measurement>; 3] = [
            vec![
                Measurement::of(&source, 5.0, 0.0).unwrap(),
                Measurement::of(&source, 7.5, -12.0).unwrap(),
            ],
            vec![],
            vec![Measurement::of(&source, 4.0, 20.0).unwrap()],
        ];
        let file = std::fs::File::open(&out).unwrap();
        let mut seen = 0;
        for (k, message) in mcap::io::MessageReader::new(std::io::BufReader::new(file)).enumerate() {
            let message = message.unwrap();
            assert_eq!(message.channel.schema.as_ref().unwrap().name, IMAGE);
            assert_eq!(message.log_time, 50 + k as u64);
            let image: Image = from_cdr(&message.data).unwrap();
            assert_eq!(image.header.stamp, pings[k].header.stamp);
            assert_eq!(image.header.frame_id, "oculus");
            assert_eq!((image.height, image.width, image.step), (90, 32, 32));
            assert_eq!(image.encoding, "mono8");
            let union = if want_features[k].is_empty() {
                sonarproj::Occupancy::new(90, 32)
            } else {
                reference
                    .masks(&pose, &want_features[k], None, sonarproj::masks::Counts::Skip)
                    .unwrap()
                    .union
            };
            // Beam b of the sonar is the message's column 31 − b (the beams are listed port first).
            for i in 0..90 {
                for b in 0..32 {
                    let v = image.data[i * 32 + (31 - b)];
                    assert_eq!(v == 255, union.get(i, b), "ping {k} pixel ({i}, {b})");
                    assert!(v == 0 || v == 255);
                }
            }
            if k != 1 {
                assert!(union.count() > 0, "ping {k}'s features are seen");
            }
            seen += 1;
        }
        assert_eq!(seen, 3);
        // A sonar 1 frame the transforms do not hold: refused naming it, and no file left.
        let other = dir.path().join("other.mcap");
        let bad = BagMasks {
            from_frame: "camera",
            ..job
        };
        let e = masks_of_bag(&bad, &engine, &other).unwrap_err().to_string();
        assert!(e.contains("ping 0") && e.contains("\"camera\""), "{e}");
        assert!(!other.exists());
        // A features file without stamps.
        std::fs::write(&features, "range,azimuth\n5,0\n").unwrap();
        let e = masks_of_bag(&job, &engine, &other).unwrap_err().to_string();
        assert!(e.contains("features file") && e.contains("stamp"), "{e}");
    }
}
