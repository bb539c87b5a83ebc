//! WGSL sources of the stages (WGSL has no includes): the projection stages are prefixed with the
//! metric slots, generated here from the metric table, and the shared structs; the splat stage
//! also with the `Real` arithmetic the adapter supports and the decisions of
//! `shaders/shared/clip.wgsl`. The WGSL lives in the package (`shaders/`), so `cargo package`
//! ships it.

use std::fmt::Write as _;

use crate::metrics::{METRICS, Reduce};
use crate::projection::gpu::types::METRIC_STRIDE;

/// The shared structs and helpers (`shaders/shared/types.wgsl`).
const SHARED: &str = include_str!("../../shaders/shared/types.wgsl");

/// The splat stage's decisions (`shaders/shared/clip.wgsl`, twin of `src/clip.rs`).
const CLIP: &str = include_str!("../../shaders/shared/clip.wgsl");

/// How the splat stage computes the transform and its decisions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Precision {
    /// `f64` (needs `wgpu::Features::SHADER_F64`): agrees with the CPU reference to ~1e-15.
    F64,
    /// Double-f32 (`hi + lo`): ~1e-13 where the driver keeps IEEE f32 semantics and fuses fma,
    /// f32 (~1e-7) where it does not.
    DoubleF32,
}

impl Precision {
    /// Returns the `Real` prelude of this precision (`shaders/shared/real_*.wgsl`).
    pub(crate) fn prelude(self) -> &'static str {
        match self {
            Precision::F64 => include_str!("../../shaders/shared/real_f64.wgsl"),
            Precision::DoubleF32 => include_str!("../../shaders/shared/real_df.wgsl"),
        }
    }

    /// Returns a short name (`f64`, `double-f32`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Precision::F64 => "f64",
            Precision::DoubleF32 => "double-f32",
        }
    }

    /// Returns the precision `text` names: `f64`, or `double-f32` (also `df`); `None` for any
    /// other text. The one spelling every front accepts.
    #[must_use]
    pub fn parse(text: &str) -> Option<Precision> {
        match text.trim() {
            "f64" => Some(Precision::F64),
            "double-f32" | "df" => Some(Precision::DoubleF32),
            _ => None,
        }
    }
}

/// Returns the WGSL name of `metric`'s slot: `METRIC_` and its name in capitals, with `_NOT` for
/// a minimum (stored as the bitwise NOT of its order key).
fn slot_name(name: &str, reduce: Reduce) -> String {
    let not = if reduce == Reduce::Min { "_NOT" } else { "" };
    format!("METRIC_{}{not}", name.to_uppercase())
}

/// Returns the WGSL constants of the metric slots: `METRIC_STRIDE` (slots a pose) and one slot
/// per metric the GPU reduces, from the metric table ([`METRICS`]).
pub(crate) fn metric_slots() -> String {
    let mut out = format!("const METRIC_STRIDE: u32 = {METRIC_STRIDE}u;\n");
    for m in METRICS.iter() {
        if let Some(slot) = m.gpu_slot {
            let _ = writeln!(out, "const {}: u32 = {slot}u;", slot_name(m.name, m.reduce));
        }
    }
    out
}

/// Returns the WGSL constants of the splat stage's decisions, from the Rust ones: the f32 slack
/// and widening ([`crate::clip::F32_SLACK`], [`crate::clip::F32_WIDEN`]) and the culling block
/// ([`crate::projection::culling::BLOCK`]).
pub(crate) fn clip_constants() -> String {
    #[expect(
        clippy::cast_possible_truncation,
        reason = "the shader's f32 constants are the Rust values rounded to f32"
    )]
    let f32_of = |v: f64| v as f32;
    format!(
        "const F32_SLACK: f32 = {:e};\nconst F32_WIDEN: f32 = {:e};\nconst BLOCK: u32 = {}u;\n",
        f32_of(crate::clip::F32_SLACK),
        f32_of(crate::clip::F32_WIDEN),
        crate::projection::culling::BLOCK
    )
}

/// Returns the full source of the splat stage (`shaders/splat.wgsl`) at `precision`.
pub(crate) fn splat(precision: Precision) -> String {
    format!(
        "{}{}\n{SHARED}\n{}\n{CLIP}\n{}",
        metric_slots(),
        clip_constants(),
        precision.prelude(),
        include_str!("../../shaders/splat.wgsl")
    )
}

/// Returns the full source of the poses stage of a grid (`shaders/poses.wgsl`) at `precision`.
pub(crate) fn poses(precision: Precision) -> String {
    format!(
        "{}\n{SHARED}\n{}\n{}",
        metric_slots(),
        precision.prelude(),
        include_str!("../../shaders/poses.wgsl")
    )
}

/// Returns the full source of the reduce stage (`shaders/reduce.wgsl`).
pub(crate) fn reduce() -> String {
    format!(
        "{}\n{SHARED}\n{}",
        metric_slots(),
        include_str!("../../shaders/reduce.wgsl")
    )
}

/// Sonar 2 as both mask stages see it (`shaders/shared/mask_params.wgsl`).
const MASK_PARAMS: &str = include_str!("../../shaders/shared/mask_params.wgsl");

/// Returns the full source of the mask stage (`shaders/mask.wgsl`, with its cells per block
/// generated from [`crate::masks::plan::BLOCK`]).
pub(crate) fn mask() -> String {
    format!(
        "const CELLS: u32 = {}u;\n{MASK_PARAMS}\n{}",
        crate::masks::plan::BLOCK * crate::masks::plan::BLOCK,
        include_str!("../../shaders/mask.wgsl")
    )
}

/// Returns the full source of the masks' reduce stage (`shaders/mask_reduce.wgsl`).
pub(crate) fn mask_reduce() -> String {
    format!(
        "{MASK_PARAMS}\n{}",
        include_str!("../../shaders/mask_reduce.wgsl")
    )
}

#[cfg(test)]
#[path = "shader_tests.rs"]
mod tests;
