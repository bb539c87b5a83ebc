//! Recovering the elevation an FLS loses, from the range a second sonar measures of the same
//! feature: the FLS arc meets the sphere of the other sonar's range in closed form.
//!
//! Run: `cargo run --release --example recover_elevation`

use sonarproj::geometry::pose::{cart_to_sph, sph_to_cart};
use sonarproj::recovery::{DEFAULT_CURVE_STEP, Observation, Sigmas, recover};
use sonarproj::{RelativePose, Rotation, Sonar};

fn main() -> Result<(), sonarproj::Error> {
    let fls = Sonar::preset("paper-fls").expect("a preset");
    let sss = Sonar::preset("paper-sss").expect("a preset");
    // A feature at range 5 m, azimuth 0°, elevation 3° in the FLS frame; the sidescan is pitched
    // 90° and placed so that it sees the feature 15 m away.
    let truth = sph_to_cart(5.0, 0.0, 3f64.to_radians());
    let rotation = Rotation::RollPitchYaw {
        roll: 0.0,
        pitch: 90.0,
        yaw: 0.0,
    };
    let pose = RelativePose::placement(rotation, [5.0, 0.0, 3.0], [15.0, 0.0, 0.0])?;
    // What each sonar measures: the FLS keeps range and azimuth, the sidescan only range.
    let (r1, az1, _) = cart_to_sph(truth);
    let (r2, _, _) = cart_to_sph(pose.apply(truth));
    let first = Observation {
        range: r1,
        azimuth: Some(az1.to_degrees()),
    };
    let second = Observation {
        range: r2,
        azimuth: None,
    };
    // Measurement noise: 1 cm in range, 0.1° in azimuth.
    let sigmas = Sigmas {
        range: 0.01,
        azimuth: 0.1,
    };
    let rec = recover(&fls, &sss, &pose, first, second, Some(sigmas), DEFAULT_CURVE_STEP)?;
    for c in &rec.candidates {
        println!(
            "candidate {}: elevation {:.3}° (σ {:.3}°), in view of both: {}",
            c.rank,
            c.first[2],
            c.sigma_elevation.unwrap_or(f64::NAN),
            c.in_view
        );
    }
    let best = rec.candidates.first().expect("the planted point is found");
    assert!((best.first[2] - 3.0).abs() < 1e-6, "recovered {}°", best.first[2]);
    println!("recovered the planted elevation, 3°");
    Ok(())
}
