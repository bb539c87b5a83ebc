//! The WGSL sources of the projection's stages (poses, splat or exact, reduce, summary). WGSL has no includes, so each stage is
//! assembled here from its parts, each part after the ones it reads:
//!
//! 1. the metric slots, generated from the metric table;
//! 2. the splat stage's constants, generated from `src/clip.rs` and `projection/culling.rs`;
//! 3. the shared structs (`shaders/shared/types.wgsl`);
//! 4. the `Real` arithmetic of the device's precision (`shaders/shared/real_*.wgsl`);
//! 5. the splat stage's decisions (`shaders/shared/clip.wgsl`, twin of `src/clip.rs`);
//! 6. for the exact stage, its roots and `atan` in f64 (`shaders/shared/roots_f64.wgsl`);
//! 7. the stage itself.
//!
//! The summary stage takes the metric slots, the metrics' numbers (their order in the metric
//! table), the shared structs, the exact widening of f32 bits (`shaders/shared/widen.wgsl`) and
//! itself.
//!
//! The WGSL lives in the package (`shaders/`), so `cargo package` ships it.

use std::fmt::Write as _;

use crate::gpu::Precision;
use crate::metrics::{METRICS, Reduce};

use super::types::METRIC_STRIDE;

/// The shared structs and helpers (`shaders/shared/types.wgsl`).
const SHARED: &str = include_str!("../../../shaders/shared/types.wgsl");

/// The splat stage's decisions (`shaders/shared/clip.wgsl`, twin of `src/clip.rs`).
const CLIP: &str = include_str!("../../../shaders/shared/clip.wgsl");

/// Returns the `Real` prelude of `precision` (`shaders/shared/real_*.wgsl`).
fn real(precision: Precision) -> &'static str {
    match precision {
        Precision::F64 => include_str!("../../../shaders/shared/real_f64.wgsl"),
        Precision::DoubleF32 => include_str!("../../../shaders/shared/real_df.wgsl"),
    }
}

/// Returns the WGSL name of a metric's slot: `METRIC_` and its name in capitals. A minimum, stored
/// as the bitwise NOT of its order key, adds `_NOT`.
fn slot_name(name: &str, reduce: Reduce) -> String {
    let not = if reduce == Reduce::Min { "_NOT" } else { "" };
    format!("METRIC_{}{not}", name.to_uppercase())
}

/// Returns the WGSL constants of the metric slots, from the metric table ([`METRICS`]):
/// `METRIC_STRIDE` (slots a pose), and one slot per metric the GPU reduces.
fn metric_slots() -> String {
    let mut out = format!("const METRIC_STRIDE: u32 = {METRIC_STRIDE}u;\n");
    for m in METRICS.iter() {
        if let Some(slot) = m.gpu_slot {
            let _ = writeln!(out, "const {}: u32 = {slot}u;", slot_name(m.name, m.reduce));
        }
    }
    out
}

/// Returns the WGSL numbers of the metrics, `METRIC_ORDER_` and the name in capitals: their
/// order in the metric table ([`crate::Metric::all`]), as the summary stage's host side numbers them.
fn metric_order() -> String {
    let mut out = String::new();
    for (k, m) in crate::Metric::all().enumerate() {
        let _ = writeln!(out, "const METRIC_ORDER_{}: u32 = {k}u;", m.name().to_uppercase());
    }
    out
}

/// Returns the WGSL constants of the splat stage's decisions, from the Rust ones: the f32 slack and
/// widening ([`crate::clip::F32_SLACK`], [`crate::clip::F32_WIDEN`]), and the culling block
/// ([`crate::projection::culling::BLOCK`]).
fn clip_constants() -> String {
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
        real(precision),
        include_str!("../../../shaders/splat.wgsl")
    )
}

/// The exact stage's root finding and `atan` in f64 (`shaders/shared/roots_f64.wgsl`).
const ROOTS: &str = include_str!("../../../shaders/shared/roots_f64.wgsl");

/// Returns the full source of the exact stage (`shaders/exact.wgsl`). It needs f64: the splat
/// stage's decisions (`clip.wgsl`) take `Real` as f64, and the roots are f64's.
pub(crate) fn exact() -> String {
    format!(
        "{}{}\n{SHARED}\n{}\n{CLIP}\n{ROOTS}\n{}",
        metric_slots(),
        clip_constants(),
        real(Precision::F64),
        include_str!("../../../shaders/exact.wgsl")
    )
}

/// Returns the full source of the poses stage of a grid (`shaders/poses.wgsl`) at `precision`.
pub(crate) fn poses(precision: Precision) -> String {
    format!(
        "{}\n{SHARED}\n{}\n{}",
        metric_slots(),
        real(precision),
        include_str!("../../../shaders/poses.wgsl")
    )
}

/// Returns the full source of the reduce stage (`shaders/reduce.wgsl`).
pub(crate) fn reduce() -> String {
    format!(
        "{}\n{SHARED}\n{}",
        metric_slots(),
        include_str!("../../../shaders/reduce.wgsl")
    )
}

/// f32 bits widened to f64 exactly, without the device's conversion (`shaders/shared/widen.wgsl`).
pub(crate) const WIDEN: &str = include_str!("../../../shaders/shared/widen.wgsl");

/// Returns the full source of the summary stage (`shaders/summary.wgsl`). It needs f64, 64-bit
/// integers and their atomics.
pub(crate) fn summary() -> String {
    format!(
        "{}{}\n{SHARED}\n{WIDEN}\n{}",
        metric_slots(),
        metric_order(),
        include_str!("../../../shaders/summary.wgsl")
    )
}

#[cfg(test)]
#[path = "source_tests.rs"]
mod tests;
