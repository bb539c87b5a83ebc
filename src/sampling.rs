//! Measurements, the 3D set each back-projects to (an FLS arc or an SSS surface; docs/commands.md,
//! `--step`), and the sampling plan that draws points from that set.

use crate::error::{Error, Result, finite};
use crate::geometry::sonar::{Sonar, SonarKind};

pub use crate::limits::MAX_SAMPLES_PER_POSE;

/// What sonar 1 measured of a feature: range (m), and azimuth (deg) for an FLS.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measurement {
    /// Measured range (m).
    pub range: f64,
    /// Measured azimuth (deg) for an FLS. An SSS does not measure it: 0, ignored.
    pub azimuth: f64,
}

impl Measurement {
    /// Returns the measurement of the point `(range, azimuth)` by `sonar`, checking that it lies
    /// in the sonar's field of view (an SSS keeps only the range).
    ///
    /// # Errors
    /// [`Error::InvalidValue`] when a value is not finite or outside the field of view.
    pub fn of(sonar: &Sonar, range: f64, azimuth: f64) -> Result<Self> {
        sonar.check_point("feature", range, azimuth, 0.0)?;
        Ok(Measurement {
            range,
            azimuth: match sonar.kind {
                SonarKind::Fls => azimuth,
                SonarKind::Sss => 0.0,
            },
        })
    }

    /// Returns `Ok(())` when this measurement could come from `sonar`, as [`Measurement::of`]
    /// checks. Entry points use it on measurements built by hand.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] when a value is not finite or outside the field of view.
    pub fn validate(&self, sonar: &Sonar) -> Result<()> {
        sonar.check_point("feature", self.range, self.azimuth, 0.0)
    }
}

/// How densely the back-projected set is sampled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sampling {
    /// Step sampling as the published code does it. For an aperture `A` (deg) and step `s` (deg),
    /// `n = round(A / s)` (ties to even, as Python), plus one if even, samples at
    /// `linspace(-A/2, A/2, n)`.
    Step(f64),
    /// Steps chosen so neighbouring samples land less than half a range bin and half a beam
    /// apart in sonar 2 (docs/commands.md, `--step`): see [`auto_spacing`].
    Auto,
    /// No samples: an FLS feature's arc solved in closed form ([`crate::exact`]). Sonar 1 must
    /// be an FLS.
    Exact,
}

impl std::str::FromStr for Sampling {
    type Err = Error;

    /// Parses `auto`, `exact` or a step in degrees (checked as [`Sampling::validated`]).
    fn from_str(text: &str) -> Result<Self> {
        match text.trim() {
            "auto" => Ok(Sampling::Auto),
            "exact" => Ok(Sampling::Exact),
            t => match t.parse::<f64>() {
                Ok(step) => Sampling::Step(step).validated(),
                Err(_) => Err(Error::invalid(
                    "step",
                    format!("{t:?}"),
                    "must be a step in degrees (> 0), \"auto\" or \"exact\"",
                )),
            },
        }
    }
}

impl std::fmt::Display for Sampling {
    /// Writes `auto`, `exact` or the step in degrees: what its `FromStr` reads back.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Sampling::Step(s) => write!(f, "{s}"),
            Sampling::Auto => f.write_str("auto"),
            Sampling::Exact => f.write_str("exact"),
        }
    }
}

impl Sampling {
    /// Returns the sampling checked: a step must be finite and positive.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] naming `step`.
    pub fn validated(self) -> Result<Self> {
        if let Sampling::Step(s) = self {
            finite("step", s)?;
            if s <= 0.0 {
                return Err(Error::invalid("step", s, "must be > 0 degrees"));
            }
        }
        Ok(self)
    }

    /// Returns the sampling checked for sonar 1 `source`: [`Sampling::validated`], and exact
    /// sampling only for an FLS (a sidescan's back-projected set is a surface, not an arc).
    ///
    /// # Errors
    /// [`Error::InvalidValue`] naming `step`.
    pub fn validated_for(self, source: &Sonar) -> Result<Self> {
        if self == Sampling::Exact && source.kind == SonarKind::Sss {
            return Err(Error::invalid(
                "step",
                "exact",
                "exact sampling solves an imaging sonar's (FLS) arc; sonar 1 is a sidescan, whose \
                 back-projected set is a surface: give a step in degrees or auto",
            ));
        }
        self.validated()
    }
}

/// The sample angles of one back-projected set, in sonar 1's frame.
///
/// A sample is `sph(range, base_azimuth + azimuths[i], elevations[j])`, where the base azimuth is
/// the measured azimuth for an FLS arc and 0 for an SSS surface. Samples are ordered with the
/// azimuth index fastest: sample `k` is `(i, j) = (k % n_az, k / n_az)`.
#[derive(Clone, Debug, PartialEq)]
pub struct SamplingPlan {
    /// Azimuth offsets (rad): `[0]` for an arc, the aperture's samples for a surface.
    pub azimuths: Vec<f64>,
    /// Elevations (rad).
    pub elevations: Vec<f64>,
}

impl SamplingPlan {
    /// Returns the plan for `measurement` of `source` seen from `target` with `sampling`.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] when the plan would exceed [`MAX_SAMPLES_PER_POSE`].
    pub fn new(
        source: &Sonar,
        target: &Sonar,
        measurement: &Measurement,
        sampling: Sampling,
    ) -> Result<Self> {
        let (n_az, n_el) = Self::counts(source, target, measurement, sampling, None)?;
        Ok(Self::with_counts(source, n_az, n_el))
    }

    /// Returns `(azimuth samples, elevation samples)` of the plan [`SamplingPlan::new`] draws,
    /// without drawing it (none in exact mode). Only [`Sampling::Auto`] uses `spacing`:
    /// [`auto_spacing`]`(target)`, computed once by a caller that counts many plans.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] when the plan would exceed [`MAX_SAMPLES_PER_POSE`].
    pub fn counts(
        source: &Sonar,
        target: &Sonar,
        measurement: &Measurement,
        sampling: Sampling,
        spacing: Option<f64>,
    ) -> Result<(usize, usize)> {
        let count = |aperture: f64| -> usize {
            match sampling {
                Sampling::Step(s) => step_count(aperture, s),
                Sampling::Auto => {
                    let d = spacing.unwrap_or_else(|| auto_spacing(target));
                    auto_count(aperture, measurement.range, d)
                }
                Sampling::Exact => 0,
            }
        };
        let n_el = count(source.elevation_aperture);
        let n_az = match source.kind {
            SonarKind::Fls => 1,
            SonarKind::Sss => count(source.azimuth_aperture),
        };
        let total = n_az as u64 * n_el as u64;
        if total > MAX_SAMPLES_PER_POSE {
            return Err(Error::invalid(
                "sampling",
                format!("{n_az} x {n_el} = {total} samples per pose"),
                format!("at most {MAX_SAMPLES_PER_POSE} samples per pose; use a coarser sampling step"),
            ));
        }
        Ok((n_az, n_el))
    }

    /// Returns the plan of `n_az × n_el` samples over `source`'s aperture (`n_az` is 1 for an FLS).
    #[must_use]
    pub fn with_counts(source: &Sonar, n_az: usize, n_el: usize) -> Self {
        let azimuths = match source.kind {
            SonarKind::Fls => vec![0.0],
            SonarKind::Sss => linspace_rad(source.azimuth_aperture, n_az),
        };
        SamplingPlan {
            azimuths,
            elevations: linspace_rad(source.elevation_aperture, n_el),
        }
    }

    /// Returns the number of samples drawn.
    #[must_use]
    pub fn total(&self) -> usize {
        self.azimuths.len() * self.elevations.len()
    }
}

/// Returns the azimuth (rad) that a plan's azimuth offsets are added to: the measured azimuth for
/// an FLS, 0 for an SSS.
#[must_use]
pub fn base_azimuth(source: &Sonar, m: &Measurement) -> f64 {
    match source.kind {
        SonarKind::Fls => m.azimuth.to_radians(),
        SonarKind::Sss => 0.0,
    }
}

/// Returns the step-mode sample count for aperture `a` and step `s` (deg): `round(a/s)` with ties
/// to even (as Python's `round`), plus one if even.
#[expect(
    clippy::cast_possible_truncation,
    reason = "sample counts are capped (MAX_SAMPLES_PER_POSE) before or right after the conversion"
)]
#[must_use]
pub fn step_count(a: f64, s: f64) -> usize {
    let n = (a / s).round_ties_even().min(MAX_SAMPLES_PER_POSE as f64 * 2.0) as usize;
    if n.is_multiple_of(2) { n + 1 } else { n }
}

/// Returns the largest sample spacing (m) that auto sampling allows for `target`: half the
/// smaller of the range bin width and, for an FLS, the narrowest beam's arc length at
/// `target.range_min`. That arc length is floored at 1 cm.
pub fn auto_spacing(target: &Sonar) -> f64 {
    let dr = target.range_bin_width();
    match target.kind {
        SonarKind::Sss => dr / 2.0,
        SonarKind::Fls => {
            let edges = target.beam_edges_rad();
            let narrowest = edges
                .windows(2)
                .map(|w| w[1] - w[0])
                .fold(f64::INFINITY, f64::min);
            let arc = (narrowest * target.range_min).max(0.01);
            dr.min(arc) / 2.0
        }
    }
}

/// Returns the auto-mode sample count for aperture `a` (deg) at range `r` (m), so that the
/// spacing `a·r/(n−1)` is strictly below `d`. `n − 1` is rounded up to an even number with at
/// most five significant bits. So batches share few plans (at most 1/16 more samples than
/// needed), and the centre of the aperture is always a sample.
#[expect(
    clippy::cast_possible_truncation,
    reason = "sample counts are capped (MAX_SAMPLES_PER_POSE) before or right after the conversion"
)]
#[must_use]
pub fn auto_count(a: f64, r: f64, d: f64) -> usize {
    let needed = ((a.to_radians() * r / d).floor() + 1.0).min(MAX_SAMPLES_PER_POSE as f64 * 2.0);
    let mut intervals = (needed as u64).max(2);
    let bits = 64 - intervals.leading_zeros();
    if bits > 5 {
        let shift = bits - 5;
        intervals = intervals.div_ceil(1 << shift) << shift;
    }
    intervals += intervals % 2;
    intervals as usize + 1
}

/// Returns `linspace(-a/2, a/2, n)` in degrees as numpy computes it, converted to radians.
/// numpy takes `start + i·step`, sets the last to `stop`, and gives `[start]` for `n = 1`;
/// `n = 0` gives nothing.
pub fn linspace_rad(a: f64, n: usize) -> Vec<f64> {
    let (start, stop) = (-a / 2.0, a / 2.0);
    if n == 0 {
        return Vec::new();
    }
    if n == 1 {
        return vec![start.to_radians()];
    }
    let step = (stop - start) / (n - 1) as f64;
    let mut v: Vec<f64> = (0..n).map(|i| i as f64 * step + start).collect();
    v[n - 1] = stop;
    v.into_iter().map(f64::to_radians).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn step_counts_match_the_published_code() {
        let fls = Sonar::preset("paper-fls").unwrap();
        let sss = Sonar::preset("paper-sss").unwrap();
        let m = Measurement {
            range: 5.0,
            azimuth: 0.0,
        };
        let arc = SamplingPlan::new(&fls, &sss, &m, Sampling::Step(0.1)).unwrap();
        assert_eq!((arc.azimuths.len(), arc.elevations.len()), (1, 121));
        let surface = SamplingPlan::new(&sss, &fls, &m, Sampling::Step(0.1)).unwrap();
        assert_eq!((surface.azimuths.len(), surface.elevations.len()), (1301, 3));
        assert_eq!(surface.total(), 3903);
        assert_eq!(arc.elevations[0], (-6f64).to_radians());
        assert_eq!(arc.elevations[120], (6f64).to_radians());
        assert!(arc.elevations[60].abs() < 1e-15);
    }

    #[test]
    #[expect(
        clippy::cast_possible_truncation,
        reason = "sample counts are capped (MAX_SAMPLES_PER_POSE) before or right after the conversion"
    )]
    fn auto_spacing_is_below_half_a_bin_and_beam() {
        let fls = Sonar::preset("paper-fls").unwrap();
        let sss = Sonar::preset("paper-sss").unwrap();
        // paper-fls target: 1 cm bins; beam arc at 0.1 m is 0.2 mm, floored to 1 cm.
        assert!((auto_spacing(&fls) - 0.005).abs() < 1e-12);
        assert!((auto_spacing(&sss) - 0.005).abs() < 1e-12);
        for &(a, r) in &[(12.0, 0.1), (12.0, 9.9), (130.0, 29.0), (0.3, 15.0), (0.3, 0.2)] {
            let n = auto_count(a, r, 0.005);
            assert!(n % 2 == 1, "odd count for the centre sample");
            let spacing = a.to_radians() * r / (n - 1) as f64;
            assert!(spacing < 0.005, "a={a} r={r} n={n} spacing={spacing}");
            let tight = (a.to_radians() * r / 0.005).floor() as usize + 2;
            assert!(n <= tight + tight / 16 + 2, "n={n} far above {tight}");
        }
    }
}
