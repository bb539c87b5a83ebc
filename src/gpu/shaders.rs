//! WGSL sources of the stages, each prefixed with the shared structs and, for the splat stage,
//! the `Real` arithmetic the adapter supports (WGSL has no includes).

/// The shared structs and helpers (`shaders/shared/types.wgsl`).
pub const SHARED: &str = include_str!("../../shaders/shared/types.wgsl");

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
    #[must_use]
    pub fn prelude(self) -> &'static str {
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
}

/// Returns the full source of the splat stage (`shaders/splat.wgsl`) at `precision`.
#[must_use]
pub fn splat(precision: Precision) -> String {
    format!(
        "{SHARED}\n{}\n{}",
        precision.prelude(),
        include_str!("../../shaders/splat.wgsl")
    )
}

/// Returns the full source of the reduce stage (`shaders/reduce.wgsl`).
#[must_use]
pub fn reduce() -> String {
    format!("{SHARED}\n{}", include_str!("../../shaders/reduce.wgsl"))
}

/// Returns the full source of the mask stage (`shaders/mask.wgsl`, self-contained).
#[must_use]
pub fn mask() -> &'static str {
    include_str!("../../shaders/mask.wgsl")
}

/// Returns every stage and variant as `(name, full source, needs f64)`.
#[must_use]
pub fn all() -> Vec<(&'static str, String, bool)> {
    vec![
        ("splat (f64)", splat(Precision::F64), true),
        ("splat (double-f32)", splat(Precision::DoubleF32), false),
        ("reduce", reduce(), false),
        ("mask", mask().to_string(), false),
    ]
}
