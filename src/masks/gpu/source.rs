//! The WGSL sources of the two mask stages. WGSL has no includes, so each is assembled from
//! parts, each after the ones it reads: the cells a block holds (generated from
//! [`crate::masks::plan::BLOCK`]), sonar 2 as both stages see it
//! (`shaders/shared/mask_params.wgsl`), then the stage.

use crate::masks::plan::BLOCK;

/// Sonar 2 as both mask stages see it (`shaders/shared/mask_params.wgsl`).
const MASK_PARAMS: &str = include_str!("../../../shaders/shared/mask_params.wgsl");

/// Returns the full source of the mask stage (`shaders/mask.wgsl`).
pub(crate) fn mask() -> String {
    format!(
        "const CELLS: u32 = {}u;\n{MASK_PARAMS}\n{}",
        BLOCK * BLOCK,
        include_str!("../../../shaders/mask.wgsl")
    )
}

/// Returns the full source of the masks' reduce stage (`shaders/mask_reduce.wgsl`).
pub(crate) fn mask_reduce() -> String {
    format!(
        "{MASK_PARAMS}\n{}",
        include_str!("../../../shaders/mask_reduce.wgsl")
    )
}

#[cfg(test)]
#[path = "source_tests.rs"]
mod tests;
