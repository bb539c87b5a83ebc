//! Sonars as HoloOcean describes them. A scenario's sensor entry (its `sensor_type` and
//! `configuration` block) is read into a [`Sonar`] whose data layout is the simulator's frame,
//! index for index.
//!
//! - `ImagingSonar`: a frame of `(RangeBins, AzimuthBins)`, an FLS with `RangeBins` bins and
//!   `AzimuthBins` uniform beams. Row `i` is the range bin
//!   `[RangeMin + i·RangeRes, RangeMin + (i+1)·RangeRes)`. Column `j` is the azimuth bin from
//!   `−Azimuth/2 + j·AzimuthRes`. HoloOcean's azimuth is positive to port (`atan2(−y, x)` in
//!   Unreal's left-handed frame, +y to starboard), so column 0 is the starboard-most beam, as
//!   in this project's layout.
//! - `SidescanSonar`: one fan over both sides (`Azimuth` is the wide angle, `Elevation` the
//!   along-track width), a two-sided SSS ([`Sonar::two_sided`]). Its frame has `RangeBins`
//!   values, port far→near then starboard near→far, each side `RangeBins / 2` bins over the
//!   whole range.
//!
//! Defaults are HoloOcean's (its Python `holoocean.sensors` and C++ sensors agree on them):
//! imaging 120° × 20°, 0.1–10 m, 512 × 512 bins; sidescan 170° × 0.25°, 0.5–35 m, 5 cm bins.
//! Give `RangeBins` or `RangeRes`, and `AzimuthBins` or `AzimuthRes`, never both (HoloOcean
//! refuses both too). A resolution must divide its span into whole bins, or the simulator's
//! bins would not end where its field of view does. Keys that only shape the simulated
//! intensities (noise, multipath, octree and shadowing settings) are accepted and ignored. Any
//! other key is refused, so a misspelt `RangeMAx` does not silently become the default.

use super::sonar::{BeamLayout, Sonar, SonarKind};
use crate::error::{Error, Result};
use crate::limits::{MAX_BEAMS, MAX_RANGE_BINS};

/// One value of a HoloOcean configuration block as its JSON (or a TOML form of it) gives it.
#[derive(Clone, Debug, PartialEq)]
pub enum HoloValue {
    /// A number (JSON makes no difference between integers and floats).
    Number(f64),
    /// Anything else, by the name of its type (`bool`, `string`, `list`, `table`).
    Other(&'static str),
}

/// The keys that shape the geometry of both sensor types.
const GEOMETRY: &[&str] = &[
    "Azimuth",
    "Elevation",
    "RangeMin",
    "RangeMax",
    "RangeBins",
    "RangeRes",
    "AzimuthBins",
    "AzimuthRes",
];
/// The sensor types read, with the keys that shape their geometry. Keys that only shape the
/// simulated intensities are below (accepted, ignored).
const IMAGING: (&str, &[&str]) = ("ImagingSonar", GEOMETRY);
const SIDESCAN: (&str, &[&str]) = ("SidescanSonar", GEOMETRY);
const IGNORED: &[&str] = &[
    "AddSigma",
    "AddCov",
    "MultSigma",
    "MultCov",
    "MultiPath",
    "ClusterSize",
    "ScaleNoise",
    "AzimuthStreaks",
    "RangeSigma",
    "ShowWarning",
    "ElevationBins",
    "ElevationRes",
    "InitOctreeRange",
    "ViewRegion",
    "ViewOctree",
    "ShadowEpsilon",
    "WaterDensity",
    "WaterSpeedSound",
    "WaterSoundSpeed",
    "UseApprox",
];
/// Keys the sidescan takes beyond the imaging sonar's: none. Its azimuth bins decide its side
/// split, which is checked.
const SIDESCAN_IGNORED: &[&str] = &[];

/// How close (in bins) a resolution must divide its span to a whole number of bins.
const WHOLE_BINS: f64 = 1e-6;

/// The coarsest sidescan azimuth bins (deg) accepted: HoloOcean's side split moves by one.
const MAX_SIDESCAN_AZIMUTH_RES: f64 = 1.0;

impl Sonar {
    /// Returns the sonar HoloOcean simulates for a sensor of `sensor_type` (`ImagingSonar` or
    /// `SidescanSonar`), configured by `config` (its `configuration` block's keys and values) and
    /// named `name`. Its data layout is the frame HoloOcean returns (see the module docs).
    ///
    /// ```
    /// use sonarproj::Sonar;
    /// use sonarproj::geometry::holoocean::HoloValue::Number;
    /// let config = [("RangeMax".to_string(), Number(40.0)), ("RangeRes".to_string(), Number(0.05))];
    /// let sonar = Sonar::from_holoocean("fls", "ImagingSonar", &config)?;
    /// assert_eq!((sonar.range_bins, sonar.beam_count()), (798, 512)); // (40 − 0.1) / 0.05
    /// # Ok::<(), sonarproj::Error>(())
    /// ```
    ///
    /// # Errors
    /// [`Error::InvalidValue`] or [`Error::Input`] naming `HoloOcean <sensor_type>: <key>`: an
    /// unknown sensor type or key, a value that is not a number, both bins and a resolution, a
    /// resolution that does not divide its span, an odd sidescan `RangeBins`, and every check
    /// of [`Sonar::validate`].
    pub fn from_holoocean(name: &str, sensor_type: &str, config: &[(String, HoloValue)]) -> Result<Sonar> {
        let (kind, geometry, extra) = match sensor_type {
            t if t == IMAGING.0 => (SonarKind::Fls, IMAGING.1, &[][..]),
            t if t == SIDESCAN.0 => (SonarKind::Sss, SIDESCAN.1, SIDESCAN_IGNORED),
            other => {
                return Err(Error::invalid(
                    "HoloOcean sensor_type",
                    format!("{other:?}"),
                    "must be ImagingSonar or SidescanSonar (the sonars whose frames' layout is read)",
                ));
            }
        };
        let field = |key: &str| format!("HoloOcean {sensor_type}: {key}");
        let given = given_keys(sensor_type, geometry, extra, config)?;
        let fls = kind == SonarKind::Fls;
        let get = |k: &str, default: f64| given.get(k).copied().unwrap_or(default);
        let azimuth = get("Azimuth", if fls { 120.0 } else { 170.0 });
        let elevation = get("Elevation", if fls { 20.0 } else { 0.25 });
        let range_min = get("RangeMin", if fls { 0.1 } else { 0.5 });
        let range_max = get("RangeMax", if fls { 10.0 } else { 35.0 });
        if range_max <= range_min {
            return Err(Error::invalid(
                field("RangeMax"),
                range_max,
                format!("must be > RangeMin ({range_min})"),
            ));
        }
        let range_default = if fls { Bins::Count(512) } else { Bins::Res(0.05) };
        // A sidescan's RangeBins count both sides.
        let range_max_bins = if fls { MAX_RANGE_BINS } else { 2 * MAX_RANGE_BINS };
        let (range_bins, range_key) = bins(
            &field,
            &given,
            "RangeBins",
            "RangeRes",
            range_max - range_min,
            range_default,
            range_max_bins,
        )?;
        let beams = if fls {
            let (n, _) = bins(
                &field,
                &given,
                "AzimuthBins",
                "AzimuthRes",
                azimuth,
                Bins::Count(512),
                MAX_BEAMS,
            )?;
            BeamLayout::Uniform { count: n }
        } else {
            // HoloOcean puts a sidescan return on a side by its azimuth bin: the first bin above
            // the nadir goes to starboard. With fine bins (its default) that is the nadir itself,
            // where this project splits. Coarse bins would move the split.
            let (n, key) = bins(
                &field,
                &given,
                "AzimuthBins",
                "AzimuthRes",
                azimuth,
                Bins::Count(u32::MAX),
                u32::MAX,
            )?;
            {
                let res = azimuth / f64::from(n);
                if res > MAX_SIDESCAN_AZIMUTH_RES {
                    return Err(Error::invalid(
                        field(key),
                        short(given.get(key).copied().unwrap_or(f64::from(n))),
                        format!(
                            "makes azimuth bins of {}°: HoloOcean splits the sides at its first bin above \
                             the nadir, that far from it, where this project splits at the nadir; give \
                             bins of {MAX_SIDESCAN_AZIMUTH_RES}° or finer (or leave them to HoloOcean)",
                            short(res)
                        ),
                    ));
                }
            }
            BeamLayout::Uniform { count: 2 }
        };
        let range_bins = if fls {
            range_bins
        } else if range_bins % 2 == 1 {
            return Err(Error::invalid(
                field(range_key),
                short(given.get(range_key).copied().unwrap_or(f64::from(range_bins))),
                format!(
                    "makes {range_bins} range bins, an odd number: HoloOcean's sidescan frame gives each side \
                     RangeBins / 2 bins"
                ),
            ));
        } else {
            range_bins / 2
        };
        Sonar {
            name: name.to_string(),
            kind,
            range_min,
            range_max,
            azimuth_aperture: azimuth,
            elevation_aperture: elevation,
            range_bins,
            beams,
        }
        .validated()
        .map_err(|e| e.in_context(format!("HoloOcean {sensor_type}")))
    }
}

/// Returns the numbers `config` gives for the geometry keys of HoloOcean's `sensor_type`
/// (`geometry`), leaving out the noise, multipath and octree keys (and `extra`).
///
/// # Errors
/// [`Error::Input`] for a key of no such sensor, or a value that is not a number.
/// [`Error::InvalidValue`] for a number that is not finite.
fn given_keys<'c>(
    sensor_type: &str,
    geometry: &[&str],
    extra: &[&str],
    config: &'c [(String, HoloValue)],
) -> Result<std::collections::BTreeMap<&'c str, f64>> {
    let field = |key: &str| format!("HoloOcean {sensor_type}: {key}");
    let mut given = std::collections::BTreeMap::new();
    for (key, value) in config {
        let k = key.as_str();
        if IGNORED.contains(&k) || extra.contains(&k) {
            continue;
        }
        if !geometry.contains(&k) {
            return Err(Error::input(
                field(&crate::error::excerpt(k)),
                format!(
                    "not a key of HoloOcean's {sensor_type} (its geometry is {}; noise, \
                     multipath and octree keys are accepted and ignored)",
                    geometry.join(", ")
                ),
            ));
        }
        match value {
            HoloValue::Number(v) if v.is_finite() => {
                given.insert(k, *v);
            }
            HoloValue::Number(v) => return Err(Error::invalid(field(k), v, "must be a finite number")),
            HoloValue::Other(t) => {
                return Err(Error::input(field(k), format!("must be a number, not a {t}")));
            }
        }
    }
    Ok(given)
}

/// A bin count, or a resolution that makes one.
#[derive(Clone, Copy)]
enum Bins {
    Count(u32),
    Res(f64),
}

/// Returns `x` as a message quotes it: whole when short, in exponent form when its digits
/// would run long (1e300).
fn short(x: f64) -> String {
    let plain = format!("{x}");
    if plain.len() > 20 { format!("{x:e}") } else { plain }
}

/// Returns the number of bins that `count_key` or `res_key` (never both) give over `span`, or
/// that `default` gives, at most `max`, and the key that gave it.
fn bins<'k>(
    field: &dyn Fn(&str) -> String,
    given: &std::collections::BTreeMap<&str, f64>,
    count_key: &'k str,
    res_key: &'k str,
    span: f64,
    default: Bins,
    max: u32,
) -> Result<(u32, &'k str)> {
    let (choice, key) = match (given.get(count_key), given.get(res_key)) {
        (Some(_), Some(_)) => {
            return Err(Error::input(
                field(&format!("{count_key}/{res_key}")),
                "both given; give one (HoloOcean's Python client refuses both too)",
            ));
        }
        (Some(&n), None) => {
            if !(n >= 1.0 && n.fract() == 0.0 && n <= f64::from(max)) {
                return Err(Error::invalid(
                    field(count_key),
                    short(n),
                    format!("must be a whole number in [1, {max}]"),
                ));
            }
            #[expect(
                clippy::cast_possible_truncation,
                clippy::cast_sign_loss,
                reason = "checked: a whole number in [1, max]"
            )]
            (Bins::Count(n as u32), count_key)
        }
        (None, Some(&r)) => {
            if r <= 0.0 {
                return Err(Error::invalid(field(res_key), short(r), "must be > 0"));
            }
            (Bins::Res(r), res_key)
        }
        (None, None) => (default, res_key),
    };
    match choice {
        Bins::Count(n) => Ok((n, key)),
        Bins::Res(r) => {
            let ratio = span / r;
            let whole = ratio.round();
            if !(whole >= 1.0 && (ratio - whole).abs() <= WHOLE_BINS && whole <= f64::from(max)) {
                return Err(Error::invalid(
                    field(res_key),
                    short(r),
                    format!(
                        "must divide the span ({}) into whole bins, at most {max} ({} here): HoloOcean's \
                         bins would not end where its field of view does; give {count_key} instead",
                        short(span),
                        short(ratio)
                    ),
                ));
            }
            #[expect(
                clippy::cast_possible_truncation,
                clippy::cast_sign_loss,
                reason = "checked: a whole number in [1, max]"
            )]
            Ok((whole as u32, key))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::HoloValue::{Number, Other};
    use super::*;

    fn config(pairs: &[(&str, HoloValue)]) -> Vec<(String, HoloValue)> {
        pairs.iter().map(|(k, v)| ((*k).to_string(), v.clone())).collect()
    }

    /// HoloOcean's documented defaults. The imaging sonar is the `holoocean-imaging` preset. The
    /// sidescan's 5 cm bins over 0.5–35 m make a frame of 690 values, 345 a side.
    #[test]
    fn defaults_are_holooceans() {
        let imaging = Sonar::from_holoocean("x", "ImagingSonar", &[]).unwrap();
        let preset = Sonar::preset("holoocean-imaging").unwrap();
        assert_eq!(
            (
                imaging.kind,
                imaging.range_min,
                imaging.range_max,
                imaging.range_bins,
                imaging.beams.clone()
            ),
            (
                preset.kind,
                preset.range_min,
                preset.range_max,
                preset.range_bins,
                preset.beams.clone()
            )
        );
        assert_eq!(
            (imaging.azimuth_aperture, imaging.elevation_aperture),
            (120.0, 20.0)
        );
        let sidescan = Sonar::from_holoocean("x", "SidescanSonar", &[]).unwrap();
        assert!(sidescan.two_sided());
        assert_eq!(
            (sidescan.range_bins, sidescan.range_min, sidescan.range_max),
            (345, 0.5, 35.0)
        );
        assert_eq!(
            (sidescan.azimuth_aperture, sidescan.elevation_aperture),
            (170.0, 0.25)
        );
    }

    #[test]
    fn bins_or_resolutions_give_the_frames_shape() {
        // A scenario's sidescan: RangeBins 2000 is the preset's two sides of 1000.
        let s = Sonar::from_holoocean(
            "x",
            "SidescanSonar",
            &config(&[
                ("RangeBins", Number(2000.0)),
                ("AddSigma", Number(0.1)),
                ("AzimuthBins", Number(1000.0)),
            ]),
        )
        .unwrap();
        assert_eq!(s.range_bins, 1000);
        let f = Sonar::from_holoocean(
            "x",
            "ImagingSonar",
            &config(&[
                ("Azimuth", Number(130.0)),
                ("RangeMin", Number(1.0)),
                ("RangeMax", Number(40.0)),
                ("RangeRes", Number(0.05)),
                ("AzimuthRes", Number(0.25)),
                ("MultiPath", Other("bool")),
            ]),
        )
        .unwrap();
        assert_eq!(
            (f.range_bins, f.beam_count(), f.azimuth_aperture),
            (780, 520, 130.0)
        );
    }

    #[test]
    fn bad_configurations_name_the_key() {
        let refused = |t: &str, pairs: &[(&str, HoloValue)], words: &[&str]| {
            let e = Sonar::from_holoocean("x", t, &config(pairs)).unwrap_err();
            assert!(e.is_input(), "{e}");
            let text = e.to_string();
            for w in words {
                assert!(text.contains(w), "{text} lacks {w:?}");
            }
        };
        refused(
            "ProfilingSonar",
            &[],
            &["sensor_type", "ProfilingSonar", "ImagingSonar or SidescanSonar"],
        );
        refused(
            "ImagingSonar",
            &[("RangeMAx", Number(5.0))],
            &["ImagingSonar: \"RangeMAx\"", "not a key"],
        );
        refused(
            "ImagingSonar",
            &[("RangeBins", Number(5.0)), ("RangeRes", Number(0.1))],
            &["RangeBins/RangeRes", "both"],
        );
        refused(
            "ImagingSonar",
            &[("RangeRes", Number(0.07))],
            &["RangeRes = 0.07", "whole bins", "RangeBins instead"],
        );
        refused(
            "ImagingSonar",
            &[("AzimuthBins", Number(10.5))],
            &["AzimuthBins = 10.5", "whole number"],
        );
        refused(
            "ImagingSonar",
            &[("RangeMax", Other("string"))],
            &["RangeMax", "not a string"],
        );
        refused(
            "ImagingSonar",
            &[("RangeMax", Number(0.05))],
            &["RangeMax = 0.05", "> RangeMin"],
        );
        refused(
            "SidescanSonar",
            &[("RangeBins", Number(999.0))],
            &["RangeBins = 999", "odd"],
        );
        refused(
            "SidescanSonar",
            &[("RangeRes", Number(34.5 / 691.0))],
            &["RangeRes", "691 range bins", "odd"],
        );
        refused(
            "SidescanSonar",
            &[("AzimuthBins", Number(3.0))],
            &["AzimuthBins = 3", "splits the sides"],
        );
        refused(
            "ImagingSonar",
            &[("RangeBins", Number(2f64.powi(40)))],
            &["RangeBins = 1099511627776", "[1, 1048576]"],
        );
        refused(
            "ImagingSonar",
            &[("RangeRes", Number(1e-300))],
            &["RangeRes = 1e-300", "at most 1048576", "(9.9e300 here)"],
        );
        // Half a bin off at a million bins is refused too (the tolerance is in bins).
        refused(
            "ImagingSonar",
            &[
                ("RangeMin", Number(0.0)),
                ("RangeMax", Number(1000.0)),
                ("RangeRes", Number(1000.0 / 1_000_000.5)),
            ],
            &["RangeRes", "whole bins"],
        );
        refused(
            "SidescanSonar",
            &[("Azimuth", Number(400.0))],
            &["HoloOcean SidescanSonar", "azimuth_aperture"],
        );
    }
}
