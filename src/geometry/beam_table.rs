//! A driver's beam table (beam centres, as an Oculus bearing table or a ROS
//! `ProjectedSonarImage` gives them) turned into a sonar's beam edges: midpoints between
//! neighbouring centres and the aperture's bounds at the ends.

use super::sonar::{BeamLayout, Sonar, SonarKind};
use crate::error::{Error, Result, finite, finite_named};

impl Sonar {
    /// Returns this FLS with the beams of a driver's beam-angle table. `centres` (deg, increasing)
    /// are the beam azimuths that ProjectedSonarImage's beam directions or an Oculus bearing table
    /// give, in degrees. Beam edges are the midpoints between neighbours. The outer edges are
    /// `±azimuth_aperture / 2` when it is given. Otherwise the aperture is the smallest symmetric
    /// one that gives the outer beams half their neighbour's spacing on their outer side.
    ///
    /// ```
    /// use sonarproj::Sonar;
    /// // Beams denser at the centre, as many imaging sonars have them.
    /// let centres = [-50.0, -30.0, -15.0, -5.0, 0.0, 5.0, 15.0, 30.0, 50.0];
    /// let sonar = Sonar::preset("holoocean-imaging").unwrap().with_beam_centres(&centres, None)?;
    /// assert_eq!(sonar.beam_count(), 9);
    /// assert_eq!(sonar.azimuth_aperture, 120.0); // 50 + (50 - 30) / 2 on each side
    /// # Ok::<(), sonarproj::Error>(())
    /// ```
    ///
    /// # Errors
    /// [`Error::InvalidValue`] when the sonar is not an FLS, a centre is not finite, the centres do
    /// not increase strictly or do not lie inside the aperture, or the result is invalid.
    pub fn with_beam_centres(self, centres: &[f64], azimuth_aperture: Option<f64>) -> Result<Sonar> {
        let ctx = format!("sonar {:?}", self.name);
        if self.kind != SonarKind::Fls {
            return Err(Error::invalid(
                format!("{ctx}: kind"),
                self.kind.name(),
                "beams need an FLS",
            ));
        }
        for (i, &c) in centres.iter().enumerate() {
            finite_named(|| format!("{ctx}: beam_centres[{i}]"), c)?;
        }
        let aperture = match (azimuth_aperture, centres.len()) {
            (Some(a), _) => a,
            (None, 0 | 1) => {
                return Err(Error::input(
                    format!("{ctx}: azimuth_aperture"),
                    "missing; it is needed when the table has fewer than two beams",
                ));
            }
            (None, n) => {
                let low = centres[0] - (centres[1] - centres[0]) / 2.0;
                let high = centres[n - 1] + (centres[n - 1] - centres[n - 2]) / 2.0;
                2.0 * low.abs().max(high.abs())
            }
        };
        let edges = edges_from_centres(&ctx, aperture, centres)?;
        Sonar {
            azimuth_aperture: aperture,
            beams: BeamLayout::Edges(edges),
            ..self
        }
        .validated()
    }
}

/// Returns the azimuth aperture (deg) of a driver's beam table `centres` (deg, increasing): its
/// outer edges lie half a spacing beyond the outer beams. The table must be symmetric about the
/// boresight within a tenth of the mean spacing (this project's sonars are centred on it), and
/// within 360°. `Err` says what is wrong with the table, for the caller to name it.
///
/// # Errors
/// Fewer than two beams (one beam's width is not in the table), centres not finite or not
/// increasing, an off-centre table, or one wider than 360°.
pub fn aperture_of_beam_centres(centres: &[f64]) -> std::result::Result<f64, String> {
    let n = centres.len();
    if n < 2 {
        return Err(format!(
            "{n} beam{}: a lone beam's width is not in the table",
            if n == 1 { "" } else { "s" }
        ));
    }
    if let Some(k) = (0..n).find(|&k| !centres[k].is_finite() || k > 0 && centres[k] <= centres[k - 1]) {
        return Err(format!(
            "beam {k} ({}°) does not follow the one before in increasing azimuth",
            centres[k]
        ));
    }
    let low = centres[0] - (centres[1] - centres[0]) / 2.0;
    let high = centres[n - 1] + (centres[n - 1] - centres[n - 2]) / 2.0;
    #[expect(clippy::cast_precision_loss, reason = "a beam count")]
    let spacing = (high - low) / n as f64;
    if (low + high).abs() > 0.1 * spacing {
        return Err(format!(
            "the beams span {low:.3}° to {high:.3}°, not centred on the boresight (this project's \
             sonars are symmetric about it)"
        ));
    }
    let aperture = 2.0 * low.abs().max(high.abs());
    if aperture > 360.0 {
        return Err(format!("the beams span {aperture:.3}°, more than 360°"));
    }
    Ok(aperture)
}

/// Returns beam edges (deg) from beam centres (deg): midpoints between centres, and the aperture
/// bounds at both ends.
pub(super) fn edges_from_centres(ctx: &str, aperture: f64, centres: &[f64]) -> Result<Vec<f64>> {
    let field = format!("{ctx}: beam_centres");
    let h = aperture / 2.0;
    if centres.is_empty() {
        return Err(Error::invalid(field, "[]", "needs at least one centre"));
    }
    for (i, &c) in centres.iter().enumerate() {
        finite(&format!("{field}[{i}]"), c)?;
        if c.abs() >= h {
            return Err(Error::invalid(
                format!("{field}[{i}]"),
                c,
                format!("must lie strictly inside (-{h}, {h}) deg"),
            ));
        }
        if i > 0 && c <= centres[i - 1] {
            return Err(Error::invalid(
                format!("{field}[{i}]"),
                c,
                format!("centres must increase strictly (previous is {})", centres[i - 1]),
            ));
        }
    }
    let mut edges = Vec::with_capacity(centres.len() + 1);
    edges.push(-h);
    edges.extend(centres.windows(2).map(|w| 0.5 * (w[0] + w[1])));
    edges.push(h);
    Ok(edges)
}
