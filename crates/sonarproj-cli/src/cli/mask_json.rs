//! The JSON of a ping's masks, per feature, as `sonarproj mask --json` prints it and
//! `--stream` writes it line by line.

use serde_json::{Value, json};
use sonarproj::masks::{FeatureSummary, MaskEngine, MaskSet, PingSummary, bounding_box, run_lengths};
use sonarproj::{Measurement, SonarKind};

/// Returns the per-feature JSON of `set`: occupied count and bounding box, with the run-length
/// masks when `runs`.
pub(super) fn features_json(
    engine: &MaskEngine,
    features: &[Measurement],
    set: &MaskSet,
    runs: bool,
) -> Vec<Value> {
    let fls = engine.source().kind == SonarKind::Fls;
    features
        .iter()
        .zip(&set.masks)
        .map(|(f, m)| {
            let mut v = json!({
                "range": f.range,
                "azimuth": fls.then_some(f.azimuth),
                "occupied": m.occupancy.count(),
                "bounding_box": bounding_box(engine.layout(), &m.occupancy),
                "radius": m.radius,
                "noise_radius": m.noise_radius,
                "cells": m.cells,
            });
            if runs {
                v["runs"] = json!(run_lengths(&m.occupancy));
            }
            v
        })
        .collect()
}

/// Returns the per-feature JSON of `summary`, as [`features_json`] writes it without runs.
pub(super) fn summary_json(
    engine: &MaskEngine,
    features: &[Measurement],
    summary: &PingSummary,
) -> Vec<Value> {
    let fls = engine.source().kind == SonarKind::Fls;
    features
        .iter()
        .zip(&summary.features)
        .map(|(f, s): (_, &FeatureSummary)| {
            json!({
                "range": f.range,
                "azimuth": fls.then_some(f.azimuth),
                "occupied": s.occupied,
                "bounding_box": s.bounding_box,
                "radius": s.radius,
                "noise_radius": s.noise_radius,
                "cells": s.cells,
            })
        })
        .collect()
}
