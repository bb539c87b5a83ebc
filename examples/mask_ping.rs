//! A correspondence mask for a ping of features: for each feature a sidescan detected, the
//! pixels of a forward-looking sonar where it can appear, written as an NPY array
//! (`uint8`, shape `[feature, range_bin, beam]`).
//!
//! Run: `cargo run --release --example mask_ping [OUT.npy]` (default: in the temp directory).

use sonarproj::masks::{Counts, MaskEngine};
use sonarproj::{Measurement, RelativePose, Rotation, Sonar};

fn main() -> Result<(), sonarproj_apps::Error> {
    let out = std::env::args_os().nth(1).map_or_else(
        || std::env::temp_dir().join("sonarproj-mask-ping.npy"),
        Into::into,
    );
    let sidescan = Sonar::preset("holoocean-sidescan").expect("a preset");
    let imaging = Sonar::preset("holoocean-imaging").expect("a preset");
    // Built once per sonar pair; each ping reuses it (and its GPU buffers with `on_gpu`).
    let engine = MaskEngine::new(sidescan, imaging)?;
    // The imaging sonar relative to the sidescan: pitched 5°, yawed 10°, 30 cm ahead.
    let rotation = Rotation::RollPitchYaw {
        roll: 0.0,
        pitch: 5.0,
        yaw: 10.0,
    };
    let pose = RelativePose::new(rotation, [0.3, 0.2, -0.1])?;
    // One ping: three features at these ranges (a sidescan measures no azimuth); the third lies
    // beyond the imaging sonar's 10 m, so its mask is empty.
    let features = [4.0, 7.5, 12.0]
        .iter()
        .map(|&r| Measurement::of(engine.source(), r, 0.0))
        .collect::<Result<Vec<_>, _>>()?;
    let set = engine.masks(&pose, &features, None, Counts::Skip)?;
    for (k, mask) in set.masks.iter().enumerate() {
        println!(
            "feature {} at {:>4} m: {:5} of {} pixels possible",
            k + 1,
            features[k].range,
            mask.occupancy.count(),
            engine.layout().range_bins * engine.layout().beams()
        );
    }
    println!("union: {} pixels", set.union.count());
    sonarproj_apps::report::mask_image::write_npy(&out, engine.layout(), &set.masks, false)?;
    println!("wrote {}", out.display());
    Ok(())
}
