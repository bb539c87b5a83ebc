//! The mask stages' WGSL parses and validates, and the structs, constants, bindings and
//! workgroup sizes they share with Rust are the same on both sides.
#![expect(
    clippy::cast_possible_truncation,
    reason = "WGSL constants are small integers, read back as f64"
)]

use std::mem::offset_of;

use super::{mask, mask_reduce};
use crate::gpu::wgsl_checks::{
    assert_declared_before_use, constant, interface, module, struct_size, validate_without_f64, wgsl_members,
};
use crate::masks::gpu::{
    MASK_BINDINGS, MASK_JOB_SIZE, MASK_PARAMS_SIZE, MASK_REDUCE_BINDINGS, MASK_REDUCE_WORKGROUP,
    MASK_WORKGROUP, MaskJob, MaskParams,
};
use crate::masks::plan::BLOCK;

#[test]
fn both_stages_parse_and_validate_without_f64() {
    for (name, source) in [("mask", mask()), ("mask reduce", mask_reduce())] {
        module(&source, name);
        validate_without_f64(&source, name);
    }
}

#[test]
fn mask_structs_match_the_rust_layout() {
    let m = module(&mask(), "mask");
    assert_eq!(struct_size(&m, "MaskParams"), MASK_PARAMS_SIZE);
    assert_eq!(struct_size(&m, "MaskJob"), MASK_JOB_SIZE);
    let params = [
        ("range_min", offset_of!(MaskParams, range_min)),
        ("range_max", offset_of!(MaskParams, range_max)),
        ("inv_range_bin", offset_of!(MaskParams, inv_range_bin)),
        ("range_bins", offset_of!(MaskParams, range_bins)),
        ("beams", offset_of!(MaskParams, beams)),
        ("words_per_mask", offset_of!(MaskParams, words_per_mask)),
        ("_pad0", offset_of!(MaskParams, _pad0)),
        ("beamed", offset_of!(MaskParams, beamed)),
        ("tan_half_el", offset_of!(MaskParams, tan_half_el)),
        ("tan_half_az", offset_of!(MaskParams, tan_half_az)),
        ("cos_half_az", offset_of!(MaskParams, cos_half_az)),
        ("_pad", offset_of!(MaskParams, _pad)),
    ];
    let want: Vec<(String, usize)> = params.iter().map(|(n, o)| (n.to_string(), *o)).collect();
    assert_eq!(wgsl_members(&m, "MaskParams"), want);
    let job = [
        ("row0", offset_of!(MaskJob, rows)),
        ("row1", offset_of!(MaskJob, rows) + 16),
        ("row2", offset_of!(MaskJob, rows) + 32),
        ("range", offset_of!(MaskJob, range)),
        ("radius", offset_of!(MaskJob, radius)),
        ("block_radius", offset_of!(MaskJob, block_radius)),
        ("az_count", offset_of!(MaskJob, az_count)),
        ("el_count", offset_of!(MaskJob, el_count)),
        ("az_offset", offset_of!(MaskJob, az_offset)),
        ("el_offset", offset_of!(MaskJob, el_offset)),
        ("block_a", offset_of!(MaskJob, block_a)),
    ];
    let want: Vec<(String, usize)> = job.iter().map(|(n, o)| (n.to_string(), *o)).collect();
    assert_eq!(wgsl_members(&m, "MaskJob"), want);
}

/// The mask stage's block holds the planner's BLOCK × BLOCK cells, one per thread. The constant
/// is generated, never hand-written.
#[test]
fn cells_of_a_block_match_the_planner() {
    let m = module(&mask(), "mask");
    assert_eq!(constant(&m, "CELLS") as usize, BLOCK * BLOCK);
    assert_eq!(BLOCK * BLOCK, MASK_WORKGROUP as usize);
    assert!(!include_str!("../../../shaders/mask.wgsl").contains("const CELLS:"));
}

/// The binding tables the pipelines are built with, and the workgroup sizes the dispatches are
/// computed with, are the WGSL's.
#[test]
fn binding_tables_and_workgroup_sizes_match_the_wgsl() {
    let (b, w) = interface(&module(&mask(), "mask"));
    assert_eq!(b, MASK_BINDINGS, "mask.wgsl bindings");
    assert_eq!(u64::from(w), MASK_WORKGROUP, "mask.wgsl workgroup size");
    let (b, w) = interface(&module(&mask_reduce(), "mask reduce"));
    assert_eq!(b, MASK_REDUCE_BINDINGS, "mask_reduce.wgsl bindings");
    assert_eq!(
        u64::from(w),
        MASK_REDUCE_WORKGROUP,
        "mask_reduce.wgsl workgroup size"
    );
}

/// No part of a stage reads a name declared after it.
#[test]
fn no_part_reads_a_name_declared_after_it() {
    let cells = format!("const CELLS: u32 = {}u;\n", BLOCK * BLOCK);
    assert_declared_before_use(&[
        ("cells", cells),
        ("mask_params.wgsl", super::MASK_PARAMS.to_string()),
        (
            "mask.wgsl",
            include_str!("../../../shaders/mask.wgsl").to_string(),
        ),
    ]);
    assert_declared_before_use(&[
        ("mask_params.wgsl", super::MASK_PARAMS.to_string()),
        (
            "mask_reduce.wgsl",
            include_str!("../../../shaders/mask_reduce.wgsl").to_string(),
        ),
    ]);
}
