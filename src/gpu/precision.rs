//! The arithmetic a device gives the projection's `Real` numbers: f64 where the adapter has it in
//! shaders, else double-f32.

/// How the splat stage computes the transform and its decisions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Precision {
    /// `f64` (needs `wgpu::Features::SHADER_F64`): agrees with the CPU reference to ~1e-15.
    F64,
    /// Double-f32 (`hi + lo`): ~1e-13 where the driver keeps IEEE f32 semantics and fuses fma, and
    /// f32 (~1e-7) where it does not.
    DoubleF32,
}

impl Precision {
    /// Returns a short name (`f64`, `double-f32`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Precision::F64 => "f64",
            Precision::DoubleF32 => "double-f32",
        }
    }

    /// Returns the precision `text` names: `f64`, or `double-f32` (also `df`). `None` for any other
    /// text. This is the one spelling every front accepts.
    #[must_use]
    pub fn parse(text: &str) -> Option<Precision> {
        match text.trim() {
            "f64" => Some(Precision::F64),
            "double-f32" | "df" => Some(Precision::DoubleF32),
            _ => None,
        }
    }
}
