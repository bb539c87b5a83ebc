//! Poses from rigs: mounts in a common frame, FLU and FRD axes, ROS roll/pitch/yaw against the
//! paper's, sidescan pairs and beam-angle tables — checked by hand arithmetic on known rigs.

use glam::{DQuat, DVec3};
use sonarproj::rig::{Mount, relative_pose, sidescan_pair};
use sonarproj::{BeamLayout, Rotation};

use sonarproj_testkit as common;

/// Returns `Ry(θ)ᵀ v` for θ in degrees, written out by hand.
fn ry_t(deg: f64, v: DVec3) -> DVec3 {
    let (s, c) = deg.to_radians().sin_cos();
    DVec3::new(c * v.x - s * v.z, v.y, s * v.x + c * v.z)
}

/// Returns `Rz(θ)ᵀ v` for θ in degrees, written out by hand.
fn rz_t(deg: f64, v: DVec3) -> DVec3 {
    let (s, c) = deg.to_radians().sin_cos();
    DVec3::new(c * v.x + s * v.y, -s * v.x + c * v.y, v.z)
}

fn close(a: DVec3, b: DVec3) {
    assert!((a - b).length() < 1e-12, "{a} != {b}");
}

/// A vehicle with an FLS 1 m ahead and 0.2 m down, pitched 10° down, and a sidescan's port
/// channel 0.3 m to port, 30° below the horizontal. A point placed in the vehicle frame lands in
/// each sonar where `Rᵀ (P − o)` says, and the relative pose carries one to the other.
#[test]
fn a_point_on_a_known_rig_lands_where_hand_arithmetic_says() {
    let fls = Mount::from_rpy_deg(0.0, 10.0, 0.0, DVec3::new(1.0, 0.0, -0.2)).unwrap();
    let port = Mount::from_rpy_deg(0.0, 30.0, 90.0, DVec3::new(0.0, 0.3, 0.0)).unwrap();
    let p = DVec3::new(5.0, 3.0, -2.0);
    // FLS: R = Ry(10°), so p_fls = Ry(10°)ᵀ (P − o).
    let in_fls = ry_t(10.0, p - DVec3::new(1.0, 0.0, -0.2));
    close(fls.to_sonar(p), in_fls);
    // By hand: P − o = (4, 3, −1.8); c = cos 10°, s = sin 10°.
    close(
        in_fls,
        DVec3::new(
            4.0 * 0.984_807_753_012_208 + 1.8 * 0.173_648_177_666_930_3,
            3.0,
            4.0 * 0.173_648_177_666_930_3 - 1.8 * 0.984_807_753_012_208,
        ),
    );
    // Port channel: R = Rz(90°) Ry(30°), so p = Ry(30°)ᵀ Rz(90°)ᵀ (P − o) = (2.7 cos 30° + 2 sin 30°, −5, …).
    let in_port = ry_t(30.0, rz_t(90.0, p - DVec3::new(0.0, 0.3, 0.0)));
    close(port.to_sonar(p), in_port);
    assert!((in_port.y + 5.0).abs() < 1e-12);
    // The relative pose takes the FLS's point to the port channel's.
    let pose = relative_pose(&fls, &port).unwrap();
    close(pose.apply(in_fls), in_port);
    // And both mounts take their points back to the vehicle's.
    close(fls.to_common(in_fls), p);
    close(port.to_common(in_port), p);
}

/// ROS/URDF roll, pitch, yaw of sonar 2's mount in sonar 1's frame is the active rotation; the
/// relative pose's rotation is its transpose, which is exactly the paper's `RollPitchYaw` with
/// the same angles (and `t = −R o`).
#[test]
fn the_papers_roll_pitch_yaw_is_the_transposed_ros_rotation() {
    let origin = Mount::from_rpy_deg(0.0, 0.0, 0.0, DVec3::ZERO).unwrap();
    for (r, p, y) in [
        (0.0, 90.0, 0.0),
        (-30.0, 0.0, 0.0),
        (10.0, 20.0, 30.0),
        (170.0, -45.0, -120.0),
    ] {
        let o = DVec3::new(0.5, -1.0, 2.0);
        let second = Mount::from_rpy_deg(r, p, y, o).unwrap();
        let pose = relative_pose(&origin, &second).unwrap();
        let paper = Rotation::RollPitchYaw {
            roll: r,
            pitch: p,
            yaw: y,
        }
        .to_matrix()
        .unwrap();
        let diff = (pose.rotation - paper)
            .to_cols_array()
            .iter()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(diff < 1e-12, "rpy ({r}, {p}, {y}): {diff}");
        close(pose.translation, -(paper * o));
        // Not ROS's own matrix (unless it is symmetric): the active rotation differs.
        let active = Rotation::RollPitchYaw {
            roll: r,
            pitch: p,
            yaw: y,
        }
        .to_matrix()
        .unwrap()
        .transpose();
        if (r, p, y) == (10.0, 20.0, 30.0) {
            assert!(
                (pose.rotation - active)
                    .to_cols_array()
                    .iter()
                    .any(|v| v.abs() > 0.1)
            );
        }
    }
}

/// FRD: yaw +30° about z-down turns the boresight to starboard; in FLU that is yaw −30° about
/// z-up, and the position (1, 2, 3) FRD is (1, −2, −3) FLU.
#[test]
fn frd_mounts_convert_to_flu() {
    let frd = Mount::from_frd(
        DQuat::from_rotation_z(30f64.to_radians()),
        DVec3::new(1.0, 2.0, 3.0),
    )
    .unwrap();
    let flu = Mount::from_rpy_deg(0.0, 0.0, -30.0, DVec3::new(1.0, -2.0, -3.0)).unwrap();
    close(frd.position(), flu.position());
    // The boresight points forward and to starboard (−y in FLU).
    let boresight = frd.rotation() * DVec3::X;
    close(boresight, flu.rotation() * DVec3::X);
    assert!(boresight.y < 0.0);
    // A pitch of +10° in FRD raises the nose (about y-starboard); in FLU the boresight goes up.
    let up = Mount::from_frd(DQuat::from_rotation_y(10f64.to_radians()), DVec3::ZERO).unwrap();
    assert!((up.rotation() * DVec3::X).z > 0.17);
}

/// A point 10 m to port and 5 m below the vehicle lies on the port boresight when the channels
/// are depressed by atan(5/10); the starboard channel has it behind (x < 0).
#[test]
fn a_sidescan_pair_looks_to_both_sides() {
    let channel = common::preset("paper-sss");
    let depression = (5.0f64 / 10.0).atan().to_degrees();
    let pair = sidescan_pair(
        &channel,
        depression,
        DVec3::new(0.0, 0.1, 0.0),
        DVec3::new(0.0, -0.1, 0.0),
    )
    .unwrap();
    let p = DVec3::new(0.0, 10.1, -5.0);
    let in_port = pair.port.1.to_sonar(p);
    close(in_port, DVec3::new(125f64.sqrt(), 0.0, 0.0));
    assert!(pair.starboard.1.to_sonar(p).x < 0.0);
    assert_eq!(pair.port.0.name, "paper-sss (port)");
    assert!(sidescan_pair(&common::preset("paper-fls"), 10.0, DVec3::ZERO, DVec3::ZERO).is_err());
}

/// Each channel's thin elevation aperture lies along the track and its fan across it: a point
/// 1 m ahead of a point on the boresight (10 m out) is 5.7° out of the fan's plane, far outside
/// the 0.3° aperture; points in the vehicle's cross-track plane, 40° above and below the
/// boresight, lie in the fan's plane (elevation 0) at azimuth ±40°, inside the 130° fan.
#[test]
fn a_sidescan_fan_lies_across_the_track() {
    let channel = common::preset("paper-sss");
    let pair = sidescan_pair(
        &channel,
        30.0,
        DVec3::new(0.2, 0.1, 0.0),
        DVec3::new(0.2, -0.1, 0.0),
    )
    .unwrap();
    // Elevation and azimuth (deg) of a sonar-frame point, written out here.
    let angles = |p: DVec3| {
        let el = (p.z / p.length()).asin().to_degrees();
        (el, p.y.atan2(p.x).to_degrees())
    };
    for (side, (_, mount)) in [("port", &pair.port), ("starboard", &pair.starboard)] {
        let o = mount.to_common(DVec3::ZERO);
        let boresight = mount.to_common(DVec3::X) - o;
        let on_axis = o + 10.0 * boresight;
        let (el, _) = angles(mount.to_sonar(on_axis + DVec3::X));
        assert!(
            (el.abs() - 0.1f64.atan().to_degrees()).abs() < 1e-9,
            "{side}: ahead at elevation {el}"
        );
        assert!(
            el.abs() > channel.elevation_aperture / 2.0,
            "{side}: a point ahead is in view"
        );
        for tilt in [-40.0f64, 40.0] {
            // Turn the boresight by `tilt` within the cross-track (y–z) plane.
            let (c, s) = (tilt.to_radians().cos(), tilt.to_radians().sin());
            let b = DVec3::new(
                0.0,
                boresight.y * c - boresight.z * s,
                boresight.y * s + boresight.z * c,
            );
            let (el, az) = angles(mount.to_sonar(o + 10.0 * b));
            assert!(el.abs() < 1e-9, "{side} {tilt}: elevation {el}");
            assert!((az.abs() - 40.0).abs() < 1e-9, "{side} {tilt}: azimuth {az}");
        }
    }
}

/// A driver's beam table becomes edges at the midpoints; a point at a centre's azimuth lies in
/// that beam.
#[test]
fn a_beam_angle_table_becomes_beam_edges() {
    let centres = [-40.0, -20.0, -8.0, -2.0, 2.0, 8.0, 20.0, 40.0];
    let sonar = common::preset("paper-fls")
        .with_beam_centres(&centres, Some(90.0))
        .unwrap();
    let BeamLayout::Edges(edges) = &sonar.beams else {
        panic!("edges expected")
    };
    assert_eq!(
        edges,
        &vec![-45.0, -30.0, -14.0, -5.0, 0.0, 5.0, 14.0, 30.0, 45.0]
    );
    for (j, c) in centres.iter().enumerate() {
        assert!(edges[j] < *c && *c < edges[j + 1]);
    }
    // Without an aperture: the outer beams get half their neighbour's spacing outside,
    // 40 + 20/2 = 50 on each side.
    let derived = common::preset("paper-fls")
        .with_beam_centres(&centres, None)
        .unwrap();
    assert_eq!(derived.azimuth_aperture, 100.0);
    // Bad tables are refused with the field named.
    let e = common::preset("paper-fls")
        .with_beam_centres(&[1.0, 0.0], None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("beam_centres[1]"), "{e}");
    assert!(
        common::preset("paper-sss")
            .with_beam_centres(&centres, None)
            .is_err()
    );
}

/// A glam quaternion and the command line's `w, x, y, z` order give the same rotation.
#[test]
fn quaternion_orders_agree() {
    let q = DQuat::from_rotation_z(0.3) * DQuat::from_rotation_x(-0.2);
    let a = Rotation::Quat(q).to_matrix().unwrap();
    let b = Rotation::QuaternionWxyz([q.w, q.x, q.y, q.z])
        .to_matrix()
        .unwrap();
    assert_eq!(a, b);
    // Read in the other order, the same four numbers are a different rotation.
    let swapped = Rotation::QuaternionWxyz([q.x, q.y, q.z, q.w])
        .to_matrix()
        .unwrap();
    assert!((a - swapped).to_cols_array().iter().any(|v| v.abs() > 0.1));
}
