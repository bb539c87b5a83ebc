//! WGSL sources of the stages, each prefixed with the shared structs (WGSL has no includes).

/// The shared structs and helpers (`shaders/shared/types.wgsl`).
pub const SHARED: &str = include_str!("../../shaders/shared/types.wgsl");

/// Returns the full source of the splat stage (`shaders/splat.wgsl`).
pub fn splat() -> String {
    format!("{SHARED}\n{}", include_str!("../../shaders/splat.wgsl"))
}

/// Returns the full source of the reduce stage (`shaders/reduce.wgsl`).
pub fn reduce() -> String {
    format!("{SHARED}\n{}", include_str!("../../shaders/reduce.wgsl"))
}

/// Returns every stage as `(name, full source)`.
pub fn all() -> Vec<(&'static str, String)> {
    vec![("splat", splat()), ("reduce", reduce())]
}
