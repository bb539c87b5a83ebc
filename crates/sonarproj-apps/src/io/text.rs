//! Values written as text on a command line or in a stream: comma-separated numbers (pose
//! strings), feature measurements, and the JSON lines of a mask stream. For any text, each
//! parser returns `Ok` or an error naming the field (property-tested in `tests/parsers.rs`).

use serde::Deserialize;
use sonarproj::error::{Field, excerpt};
use sonarproj::masks::Noise;
use sonarproj::{Measurement, RelativePose, Rotation, Sonar, SonarKind};

use crate::error::{Error, Result};

/// Returns the `N` comma-separated numbers of `text`, a pose string such as `1,2,0.5`.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] naming `field` for another count or a field that is not
/// a number.
pub fn numbers<const N: usize>(field: impl Into<Field> + Clone, text: &str) -> Result<[f64; N]> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != N {
        return Err(Error::invalid(
            field.clone(),
            excerpt(text),
            format!("needs {N} comma-separated numbers, got {}", parts.len()),
        ));
    }
    let mut out = [0.0; N];
    for (o, p) in out.iter_mut().zip(&parts) {
        *o = p
            .parse()
            .map_err(|_| Error::invalid(field.clone(), excerpt(p), "must be a number"))?;
    }
    Ok(out)
}

/// Returns `text` as three numbers, or one given for all three, named `field`.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] naming `field`.
pub fn one_or_three(field: impl Into<Field> + Clone, text: &str) -> Result<[f64; 3]> {
    if text.contains(',') {
        numbers::<3>(field, text)
    } else {
        let [v] = numbers::<1>(field, text)?;
        Ok([v; 3])
    }
}

/// Returns the measurement of a feature of `source` given as numbers: `R` for a sidescan, `R, A`
/// for an imaging sonar. The error says which form this sonar takes.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] naming `field`.
pub fn measurement(source: &Sonar, field: impl Into<Field> + Clone, numbers: &[f64]) -> Result<Measurement> {
    let (range, azimuth) = match (numbers, source.kind) {
        ([r], SonarKind::Sss) => (*r, 0.0),
        ([r, a], SonarKind::Fls) => (*r, *a),
        (_, SonarKind::Sss) => {
            return Err(Error::invalid(
                field,
                format!("{numbers:?}"),
                "must be one number, the range R (m): a sidescan measures no azimuth",
            ));
        }
        (_, SonarKind::Fls) => {
            return Err(Error::invalid(
                field,
                format!("{numbers:?}"),
                "must be two numbers, range and azimuth R,A (m, deg): an imaging sonar measures both",
            ));
        }
    };
    Measurement::of(source, range, azimuth).map_err(|e| Error::from(e).in_context(field.clone()))
}

/// Returns the measurement `R` or `R,A` of feature `k` (from 0) in `source`. Errors name it
/// feature `k + 1`, as in the command line's `--feature N`.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] naming the feature.
pub fn feature(source: &Sonar, k: usize, text: &str) -> Result<Measurement> {
    let field = Field::param(crate::params::FEATURE, format!(" {}", k + 1));
    let values = text
        .split(',')
        .map(|part| numbers::<1>(field.clone(), part).map(|v| v[0]))
        .collect::<Result<Vec<f64>>>()?;
    measurement(source, field, &values)
}

/// A pose in a stream line.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PoseLine {
    roll: Option<f64>,
    pitch: Option<f64>,
    yaw: Option<f64>,
    quaternion: Option<[f64; 4]>,
    matrix: Option<[[f64; 3]; 3]>,
    translation: [f64; 3],
}

/// One number for all three axes, or three.
#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum Triple {
    One(f64),
    Three([f64; 3]),
}

impl Triple {
    fn get(&self) -> [f64; 3] {
        match self {
            Triple::One(v) => [*v; 3],
            Triple::Three(v) => *v,
        }
    }
}

/// Noise in a stream line.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SigmaLine {
    rotation: Option<Triple>,
    translation: Option<Triple>,
    range: Option<f64>,
    azimuth: Option<f64>,
    coverage: Option<f64>,
}

/// One stream input line.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Line {
    pose: PoseLine,
    features: Vec<Vec<f64>>,
    sigma: Option<SigmaLine>,
}

/// What one line of a mask stream asks for.
#[derive(Clone, Debug, PartialEq)]
pub struct MaskRequest {
    /// The pose of sonar 2 relative to sonar 1.
    pub pose: RelativePose,
    /// The features, as sonar 1 measured them.
    pub features: Vec<Measurement>,
    /// The noise of the line's `sigma`, when given.
    pub noise: Option<Noise>,
}

/// Returns the pose, features and noise of the mask stream line `text`, with features checked
/// against sonar 1 (`source`). A line is one JSON object:
/// `{"pose": {…}, "features": [[R, A], …], "sigma"?: {…}}`.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] or [`sonarproj::Error::Input`] naming the key.
pub fn parse_mask_line(source: &Sonar, text: &str) -> Result<MaskRequest> {
    // The parser's whole message says what and where, cutting a value at 200 characters. Then
    // comes the form of a line for this sonar's features.
    let features = match source.kind {
        SonarKind::Fls => "[[R, A], …]",
        SonarKind::Sss => "[[R], …]",
    };
    let line: Line = serde_json::from_str(text).map_err(|e| {
        Error::invalid(
            "line",
            e,
            format!(
                "must be one JSON object: {{\"pose\": {{\"roll\",\"pitch\",\"yaw\" | \"quaternion\" | \
                 \"matrix\", \"translation\"}}, \"features\": {features}, \"sigma\"?: {{…}}}}"
            ),
        )
    })?;
    let p = &line.pose;
    let rotation = match (p.quaternion, p.matrix) {
        (Some(q), None) if p.roll.is_none() && p.pitch.is_none() && p.yaw.is_none() => {
            Rotation::QuaternionWxyz(q)
        }
        (None, Some(m)) if p.roll.is_none() && p.pitch.is_none() && p.yaw.is_none() => Rotation::Matrix(m),
        (None, None) => Rotation::RollPitchYaw {
            roll: p.roll.unwrap_or(0.0),
            pitch: p.pitch.unwrap_or(0.0),
            yaw: p.yaw.unwrap_or(0.0),
        },
        _ => {
            return Err(Error::input(
                "pose",
                "several rotations given; give one of roll/pitch/yaw, quaternion or matrix",
            ));
        }
    };
    let pose = RelativePose::new(rotation, p.translation).map_err(|e| e.in_context("pose"))?;
    if line.features.is_empty() {
        return Err(Error::invalid(
            "features",
            "[]",
            "must list at least one [R] or [R, A]",
        ));
    }
    let features = line
        .features
        .iter()
        .enumerate()
        .map(|(k, f)| {
            let field = format!("features[{k}]");
            measurement(source, &field, f)
        })
        .collect::<Result<Vec<_>>>()?;
    let noise = line
        .sigma
        .map(|s| {
            Noise {
                rotation: s.rotation.map_or([0.0; 3], |t| t.get()),
                translation: s.translation.map_or([0.0; 3], |t| t.get()),
                range: s.range.unwrap_or(0.0),
                azimuth: s.azimuth.unwrap_or(0.0),
                coverage: s.coverage.unwrap_or(0.99),
            }
            .validated()
            .map_err(|e| e.in_context("sigma"))
        })
        .transpose()?;
    Ok(MaskRequest {
        pose,
        features,
        noise,
    })
}
