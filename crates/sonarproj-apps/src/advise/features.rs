//! The features an advise file scores candidates over: `[features]` read, and the seeded draw.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sonarproj::geometry::sonar::Sonar;

use crate::error::Result;
use crate::io::toml_keys::{ConfigFile, numbers};

/// The most features an advise file may ask for.
pub const MAX_FEATURES: usize = 1_000_000;

/// The features candidates are scored over.
#[derive(Clone, Debug, PartialEq)]
pub enum Features {
    /// `count` features both sonars see, from one seeded sequence for every candidate.
    /// Points are drawn uniformly over the view volume of the sonar with the thinner elevation
    /// aperture (sonar 1 on a tie) and kept while the other sonar sees them. So neighbouring
    /// candidates share most of their features.
    Drawn {
        /// How many to keep.
        count: usize,
        /// The draw's seed.
        seed: u64,
    },
    /// Given points of sonar 1, `[range m, azimuth deg, elevation deg]`: those sonar 2 sees.
    Points(Vec<[f64; 3]>),
}

/// Returns the features of `[features]`: a seeded draw, or given points checked against sonar 1.
pub(super) fn read(f: ConfigFile<'_>, t: Option<&toml::Table>, source: &Sonar) -> Result<Features> {
    let missing = || f.missing("features", "required: [features] with count (and seed) or points");
    let t = t.ok_or_else(missing)?;
    f.only("features.", t, &["count", "seed", "points"])?;
    if let Some(points) = t.get("points") {
        for key in ["count", "seed"] {
            if t.contains_key(key) {
                return Err(f.error(
                    &format!("features.{key}"),
                    t[key].clone(),
                    "draws features: give count (and seed) or points, not both",
                ));
            }
        }
        let bad = || {
            f.error(
                "features.points",
                points.clone(),
                "must be a list of [range, azimuth, elevation]",
            )
        };
        let list = points.as_array().ok_or_else(bad)?;
        if list.is_empty() || list.len() > MAX_FEATURES {
            return Err(f.error(
                "features.points",
                format!("{} points", list.len()),
                format!("must have 1 to {MAX_FEATURES}"),
            ));
        }
        return Ok(Features::Points(
            list.iter()
                .enumerate()
                .map(|(i, p)| {
                    let xyz: Vec<f64> = numbers(p).unwrap_or_default();
                    let [r, az, el] = xyz.as_slice() else {
                        return Err(bad());
                    };
                    source
                        .check_point("feature", *r, *az, *el)
                        .map_err(|e| e.in_context(f.field(&format!("features.points[{i}]"))))?;
                    Ok([*r, *az, *el])
                })
                .collect::<Result<_>>()?,
        ));
    }
    #[expect(clippy::cast_possible_truncation, reason = "at most MAX_FEATURES")]
    let count = match f.whole(t, "features.count", 1.0, MAX_FEATURES as f64)? {
        Some(n) => n as usize,
        None => return Err(missing()),
    };
    let seed = f.whole(t, "features.seed", 0.0, 9.0e15)?.unwrap_or(1);
    Ok(Features::Drawn { count, seed })
}

/// Returns `count` seeded points `[range m, azimuth deg, elevation deg]` uniform in `source`.
/// The range's cube, the azimuth and the elevation's sine are uniform, so equal volumes are
/// equally likely.
#[must_use]
pub fn draw_features(source: &Sonar, count: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (lo, hi) = (source.range_min.max(1e-3), source.range_max);
    let (ha, he) = (
        source.azimuth_aperture / 2.0,
        (source.elevation_aperture / 2.0).to_radians(),
    );
    (0..count)
        .map(|_| {
            let u: f64 = rng.random();
            let r = (lo.powi(3) + u * (hi.powi(3) - lo.powi(3))).cbrt().clamp(lo, hi);
            let az = ha * (2.0 * rng.random::<f64>() - 1.0);
            let s = he.sin() * (2.0 * rng.random::<f64>() - 1.0);
            [
                r,
                az,
                s.asin().to_degrees().clamp(-he.to_degrees(), he.to_degrees()),
            ]
        })
        .collect()
}
