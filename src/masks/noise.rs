//! Noise on the pose and the measurement, and the radius by which it widens a mask.

use serde::Serialize;
use statrs::distribution::{ChiSquared, ContinuousCDF, Normal};

use crate::error::{Error, Result, finite};
use crate::geometry::SonarKind;
use crate::limits::{MAX_RANGE, MAX_SIGMA_ANGLE};

/// Standard deviations of the pose and the measurement, and the probability the widened mask
/// must reach.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Noise {
    /// Roll, pitch, yaw (deg), or any small rotation about sonar 1's axes (per axis).
    pub rotation: [f64; 3],
    /// Translation x, y, z (m).
    pub translation: [f64; 3],
    /// Measured range (m).
    pub range: f64,
    /// Measured azimuth (deg); ignored for an SSS feature.
    pub azimuth: f64,
    /// The probability that the true pixel lies in the widened mask, in `(0, 1)`.
    pub coverage: f64,
}

impl Noise {
    /// Returns the noise checked: sigmas finite and `>= 0`, coverage in `(0, 1)`.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] naming the sigma or `coverage`.
    pub fn validated(self) -> Result<Self> {
        let named = [
            ("sigma roll", self.rotation[0]),
            ("sigma pitch", self.rotation[1]),
            ("sigma yaw", self.rotation[2]),
            ("sigma tx", self.translation[0]),
            ("sigma ty", self.translation[1]),
            ("sigma tz", self.translation[2]),
            ("sigma range", self.range),
            ("sigma azimuth", self.azimuth),
        ];
        for (k, (field, v)) in named.into_iter().enumerate() {
            finite(field, v)?;
            // Angles (deg) go up to half a turn and lengths (m) up to the largest sonar range.
            // Wider noise means nothing, and this keeps the radius finite.
            let (max, unit) = match k {
                0..=2 | 7 => (MAX_SIGMA_ANGLE, "deg"),
                _ => (MAX_RANGE, "m"),
            };
            if !(0.0..=max).contains(&v) {
                return Err(Error::invalid(field, v, format!("must be in [0, {max}] {unit}")));
            }
        }
        finite("coverage", self.coverage)?;
        if !(self.coverage > 0.0 && self.coverage < 1.0) {
            return Err(Error::invalid(
                "coverage",
                self.coverage,
                "must be in (0, 1), e.g. 0.99",
            ));
        }
        Ok(self)
    }

    /// Returns the radius `D` (m) by which the true point's image in sonar 2 can lie away from the
    /// noise-free back-projection of measured range `r` (m), with probability at least `coverage`.
    ///
    /// 1. The true point `P` and the point `P'` of the measured arc at `P`'s own elevation differ
    ///    by at most `|δr| + (r + |δr|)·|δa|`. The azimuth term is for an FLS only.
    /// 2. The true pose moves `P` by at most `|δt| + (r + |δr|)·|δθ|` from where the nominal pose
    ///    puts it, with `|δθ| ≤ |δroll| + |δpitch| + |δyaw|` (a telescoped product of small
    ///    rotations).
    /// 3. Each of the `k` groups with a non-zero sigma (translation, rotation, range, azimuth) is
    ///    bounded at probability `1 − (1 − coverage)/k`. By the union bound, all bounds then hold
    ///    together with probability at least `coverage`. With `χ₃` the quantile of the chi
    ///    distribution with 3 degrees of freedom and `z` that of `|N(0,1)|`: `|δt| ≤ max σ_t · χ₃`,
    ///    `Σ|δθ_i| ≤ ‖σ_θ‖ · χ₃` (Cauchy–Schwarz), `|δr| ≤ σ_r · z` and `|δa| ≤ σ_a · z`.
    ///
    /// The result is conservative: simulated coverage is higher than stated (tests/masks.rs).
    #[must_use]
    pub fn radius(&self, r: f64, source: SonarKind) -> f64 {
        let rot_norm = self
            .rotation
            .iter()
            .map(|s| s.to_radians().powi(2))
            .sum::<f64>()
            .sqrt();
        let t_max = self.translation.iter().fold(0.0f64, |a, &b| a.max(b));
        let az = match source {
            SonarKind::Fls => self.azimuth.to_radians(),
            SonarKind::Sss => 0.0,
        };
        let groups = [t_max, rot_norm, self.range, az]
            .iter()
            .filter(|s| **s > 0.0)
            .count();
        if groups == 0 {
            return 0.0;
        }
        let q = 1.0 - (1.0 - self.coverage) / groups as f64;
        let chi3 = ChiSquared::new(3.0).expect("3 dof").inverse_cdf(q).sqrt();
        let z = Normal::standard().inverse_cdf(0.5 + q / 2.0);
        let dr = self.range * z;
        let far = r + dr;
        t_max * chi3 + far * rot_norm * chi3 + dr + far * az * z
    }
}
