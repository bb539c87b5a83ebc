//! The projection's WGSL stages parse and validate. The structs, constants, bindings and workgroup
//! sizes they share with Rust are the same on both sides.
#![expect(
    clippy::cast_possible_truncation,
    reason = "WGSL constants are small integers or f32 values, read back as f64"
)]

use std::mem::offset_of;

use super::{exact, poses, reduce, splat, summary};
use crate::gpu::Precision;
use crate::gpu::wgsl_checks::{constant, interface, module, struct_size, validate_without_f64, wgsl_members};
use crate::projection::gpu::types::{self, BeamEdgeGpu, GridParams, PoseGpu, TargetParams};

/// Returns every stage and variant as `(name, full source, needs f64)`.
fn all() -> Vec<(&'static str, String, bool)> {
    vec![
        ("splat (f64)", splat(Precision::F64), true),
        ("splat (double-f32)", splat(Precision::DoubleF32), false),
        ("exact", exact(), true),
        ("reduce", reduce(), false),
        ("poses (f64)", poses(Precision::F64), true),
        ("poses (double-f32)", poses(Precision::DoubleF32), false),
    ]
}

#[test]
fn every_stage_parses_and_validates() {
    for (name, source, needs_f64) in all() {
        module(&source, name);
        if !needs_f64 {
            // Also without the f64 capability, since adapters that lack it run this variant.
            validate_without_f64(&source, name);
        }
    }
}

/// The capabilities the summary stage needs: f64, 64-bit integers and their atomics.
fn summary_capabilities() -> naga::valid::Capabilities {
    use naga::valid::Capabilities as C;
    C::FLOAT64 | C::SHADER_INT64 | C::SHADER_INT64_ATOMIC_MIN_MAX | C::SHADER_INT64_ATOMIC_ALL_OPS
}

#[test]
fn the_summary_stage_parses_and_validates() {
    crate::gpu::wgsl_checks::module_with(&summary(), "summary", summary_capabilities());
    // The capabilities are the features the backend asks the device for.
    use wgpu::Features as F;
    assert_eq!(
        crate::projection::gpu::SUMMARY_FEATURES,
        F::SHADER_F64 | F::SHADER_INT64 | F::SHADER_INT64_ATOMIC_MIN_MAX | F::SHADER_INT64_ATOMIC_ALL_OPS
    );
}

/// The summary stage's structs, bindings, workgroup and metric numbers are the Rust side's.
#[test]
fn the_summary_stage_matches_its_host_side() {
    use crate::projection::gpu::types::{MarginalGpu, SummaryParams};
    let m = crate::gpu::wgsl_checks::module_with(&summary(), "summary", summary_capabilities());
    assert_eq!(struct_size(&m, "SummaryParams"), size_of::<SummaryParams>());
    assert_eq!(struct_size(&m, "MarginalGpu"), size_of::<MarginalGpu>());
    let params = [
        ("range_bin_width", offset_of!(SummaryParams, range_bin_width)),
        ("cell", offset_of!(SummaryParams, cell)),
        ("degrees", offset_of!(SummaryParams, degrees)),
        ("histogram_min", offset_of!(SummaryParams, histogram_min)),
        ("histogram_max", offset_of!(SummaryParams, histogram_max)),
        ("count", offset_of!(SummaryParams, count)),
        ("metric", offset_of!(SummaryParams, metric)),
        ("exact", offset_of!(SummaryParams, exact)),
        ("sss", offset_of!(SummaryParams, sss)),
        ("has_area", offset_of!(SummaryParams, has_area)),
        ("bins", offset_of!(SummaryParams, bins)),
        ("marginals", offset_of!(SummaryParams, marginals)),
        ("keep", offset_of!(SummaryParams, keep)),
        ("first_lo", offset_of!(SummaryParams, first_lo)),
        ("first_hi", offset_of!(SummaryParams, first_hi)),
        ("cells_at", offset_of!(SummaryParams, cells_at)),
        ("_pad", offset_of!(SummaryParams, _pad)),
    ];
    let pad = offset_of!(MarginalGpu, _pad);
    let marginal = [
        ("cell_offset", offset_of!(MarginalGpu, cell_offset)),
        ("axes", offset_of!(MarginalGpu, axes)),
        ("_pad0", pad),
        ("_pad1", pad + 4),
        ("digit", offset_of!(MarginalGpu, digit)),
    ];
    for (name, rust) in [("SummaryParams", &params[..]), ("MarginalGpu", &marginal[..])] {
        let rust: Vec<(String, usize)> = rust.iter().map(|(n, o)| (n.to_string(), *o)).collect();
        assert_eq!(
            wgsl_members(&m, name),
            rust,
            "{name}: WGSL (left) and Rust (right)"
        );
    }
    let (b, w) = interface(&m);
    assert_eq!(
        b,
        crate::projection::gpu::SUMMARY_BINDINGS,
        "summary.wgsl bindings"
    );
    assert_eq!(
        w as usize,
        super::super::summary::SUMMARY_WORKGROUP,
        "summary.wgsl workgroup size"
    );
    // The metric numbers are the metric table's order, as the host numbers them.
    for (k, metric) in crate::Metric::all().enumerate() {
        let name = format!("METRIC_ORDER_{}", metric.name().to_uppercase());
        assert_eq!(constant(&m, &name) as usize, k, "{name}");
    }
    assert!(
        !include_str!("../../../shaders/summary.wgsl").contains("const METRIC_"),
        "a hand-written metric number or slot"
    );
}

#[test]
fn shared_structs_have_the_rust_sizes() {
    let m = module(&splat(Precision::F64), "splat");
    assert_eq!(struct_size(&m, "TargetParams"), size_of::<TargetParams>());
    assert_eq!(struct_size(&m, "Pose"), size_of::<PoseGpu>());
    assert_eq!(struct_size(&m, "BeamEdge"), size_of::<BeamEdgeGpu>());
    let m = module(&poses(Precision::F64), "poses");
    assert_eq!(struct_size(&m, "GridParams"), size_of::<GridParams>());
    let members = wgsl_members(&m, "GridParams");
    for (name, offset) in [
        ("first", offset_of!(GridParams, first)),
        ("lens", offset_of!(GridParams, lens)),
        ("offsets", offset_of!(GridParams, offsets)),
        ("count", offset_of!(GridParams, count)),
        ("placement", offset_of!(GridParams, placement)),
        ("fls", offset_of!(GridParams, fls)),
    ] {
        assert!(
            members.contains(&(name.to_string(), offset)),
            "GridParams.{name} at {offset}: {members:?}"
        );
    }
}

#[test]
fn shared_struct_members_sit_at_the_rust_offsets() {
    let m = module(&splat(Precision::F64), "splat");
    let target = [
        ("range_min", offset_of!(TargetParams, range_min)),
        ("range_max", offset_of!(TargetParams, range_max)),
        ("inv_range_bin", offset_of!(TargetParams, inv_range_bin)),
        ("half_az", offset_of!(TargetParams, half_az)),
        ("inv_beam_width", offset_of!(TargetParams, inv_beam_width)),
        ("range_bins", offset_of!(TargetParams, range_bins)),
        ("beams", offset_of!(TargetParams, beams)),
        ("beams_uniform", offset_of!(TargetParams, beams_uniform)),
        ("words_per_pose", offset_of!(TargetParams, words_per_pose)),
        ("pose_count", offset_of!(TargetParams, pose_count)),
        ("measure_area", offset_of!(TargetParams, measure_area)),
        ("clip_elevation", offset_of!(TargetParams, clip_elevation)),
        ("range_min_sq", offset_of!(TargetParams, range_min_sq)),
        ("range_max_sq", offset_of!(TargetParams, range_max_sq)),
        ("sin_half_az", offset_of!(TargetParams, sin_half_az)),
        ("cos_half_az", offset_of!(TargetParams, cos_half_az)),
        ("sin2_half_el", offset_of!(TargetParams, sin2_half_el)),
        ("cos2_half_el", offset_of!(TargetParams, cos2_half_el)),
        ("grid_x0", offset_of!(TargetParams, grid_x0)),
        ("grid_y0", offset_of!(TargetParams, grid_y0)),
        ("inv_cell", offset_of!(TargetParams, inv_cell)),
        ("grid_nx", offset_of!(TargetParams, grid_nx)),
        ("grid_ny", offset_of!(TargetParams, grid_ny)),
        ("pixel_words", offset_of!(TargetParams, pixel_words)),
        ("cell_words", offset_of!(TargetParams, cell_words)),
        ("_pad", offset_of!(TargetParams, _pad)),
    ];
    let row = 16;
    let hi = offset_of!(PoseGpu, hi);
    let lo = offset_of!(PoseGpu, lo);
    let pose = [
        ("hi0", hi),
        ("hi1", hi + row),
        ("hi2", hi + 2 * row),
        ("lo0", lo),
        ("lo1", lo + row),
        ("lo2", lo + 2 * row),
        ("plan", offset_of!(PoseGpu, plan)),
    ];
    let edge = [
        ("angle", offset_of!(BeamEdgeGpu, angle)),
        ("width", offset_of!(BeamEdgeGpu, width)),
        ("cos_angle", offset_of!(BeamEdgeGpu, cos_angle)),
        ("sin_angle", offset_of!(BeamEdgeGpu, sin_angle)),
        ("_pad", offset_of!(BeamEdgeGpu, _pad)),
    ];
    for (name, rust) in [
        ("TargetParams", &target[..]),
        ("Pose", &pose[..]),
        ("BeamEdge", &edge[..]),
    ] {
        let wgsl = wgsl_members(&m, name);
        let rust: Vec<(String, usize)> = rust.iter().map(|(n, o)| (n.to_string(), *o)).collect();
        assert_eq!(
            wgsl, rust,
            "{name}: WGSL members (left) and Rust fields (right) differ"
        );
    }
}

/// The metric slots the stages use are generated from the metric table: each has the slot the
/// Rust side decodes, and the stages name no slot the table does not give.
#[test]
fn metric_slots_match() {
    for (name, source) in [("splat", splat(Precision::F64)), ("reduce", reduce())] {
        let m = module(&source, name);
        let value = |c: &str| constant(&m, c) as usize;
        assert_eq!(value("METRIC_STRIDE"), types::METRIC_STRIDE);
        assert_eq!(value("METRIC_VISIBLE"), types::METRIC_VISIBLE);
        assert_eq!(value("METRIC_OCCUPIED"), types::METRIC_OCCUPIED);
        assert_eq!(value("METRIC_RANGE_MIN_NOT"), types::METRIC_RANGE_MIN_NOT);
        assert_eq!(value("METRIC_RANGE_MAX"), types::METRIC_RANGE_MAX);
        assert_eq!(value("METRIC_AZIMUTH_MIN_NOT"), types::METRIC_AZIMUTH_MIN_NOT);
        assert_eq!(value("METRIC_AZIMUTH_MAX"), types::METRIC_AZIMUTH_MAX);
        assert_eq!(value("METRIC_OCCUPIED_MEASURE"), types::METRIC_OCCUPIED_MEASURE);
    }
    // Nothing but the generated prefix defines a slot.
    for file in [
        include_str!("../../../shaders/shared/types.wgsl"),
        include_str!("../../../shaders/splat.wgsl"),
        include_str!("../../../shaders/reduce.wgsl"),
    ] {
        assert!(!file.contains("const METRIC_"), "a hand-written metric slot");
    }
}

/// The constants the splat stage's decisions share with Rust: the culling block and the
/// tolerances of `shaders/shared/clip.wgsl` are `src/clip.rs`'s.
#[test]
fn clip_constants_match() {
    let m = module(&splat(Precision::F64), "splat");
    assert_eq!(constant(&m, "BLOCK") as usize, crate::projection::culling::BLOCK);
    // f32 literals: the Rust values rounded to f32.
    assert_eq!(
        constant(&m, "F32_SLACK"),
        f64::from(crate::clip::F32_SLACK as f32)
    );
    assert_eq!(
        constant(&m, "F32_WIDEN"),
        f64::from(crate::clip::F32_WIDEN as f32)
    );
    // Generated, never hand-written.
    let clip = include_str!("../../../shaders/shared/clip.wgsl");
    for name in ["F32_SLACK", "F32_WIDEN", "BLOCK"] {
        assert!(
            !clip.contains(&format!("const {name}:")),
            "{name} written by hand"
        );
    }
}

/// The binding tables the pipelines are built with, and the workgroup sizes the dispatches are
/// computed with, are the WGSL's.
#[test]
fn binding_tables_and_workgroup_sizes_match_the_wgsl() {
    use crate::projection::gpu::{
        POSES_BINDINGS, POSES_WORKGROUP, REDUCE_BINDINGS, SPLAT_BINDINGS, SPLAT_WORKGROUP,
    };
    // The reduce stage runs one workgroup per pose whatever its size. Its 64 threads are the WGSL's
    // own, said here so that a change is seen.
    const REDUCE_WORKGROUP: u64 = 64;
    for precision in [Precision::F64, Precision::DoubleF32] {
        let (b, w) = interface(&module(&splat(precision), "splat"));
        assert_eq!(b, SPLAT_BINDINGS, "splat.wgsl bindings");
        assert_eq!(w, SPLAT_WORKGROUP, "splat.wgsl workgroup size");
    }
    // The exact stage binds what the splat stage binds, one pose a thread.
    let (b, w) = interface(&module(&exact(), "exact"));
    assert_eq!(b, SPLAT_BINDINGS, "exact.wgsl bindings");
    assert_eq!(
        w,
        crate::projection::gpu::EXACT_WORKGROUP,
        "exact.wgsl workgroup size"
    );
    for precision in [Precision::F64, Precision::DoubleF32] {
        let (b, w) = interface(&module(&poses(precision), "poses"));
        assert_eq!(b, POSES_BINDINGS, "poses.wgsl bindings");
        assert_eq!(u64::from(w), POSES_WORKGROUP, "poses.wgsl workgroup size");
    }
    let (b, w) = interface(&module(&reduce(), "reduce"));
    assert_eq!(b, REDUCE_BINDINGS, "reduce.wgsl bindings");
    assert_eq!(u64::from(w), REDUCE_WORKGROUP, "reduce.wgsl workgroup size");
}

/// No part of a stage reads a module-scope name that a later part declares. WGSL allows either
/// order, but a reader of the parts one by one should not have to look ahead.
#[test]
fn no_part_reads_a_name_declared_after_it() {
    let parts_of = |precision| {
        [
            ("metric slots", super::metric_slots()),
            ("clip constants", super::clip_constants()),
            ("types.wgsl", super::SHARED.to_string()),
            ("real", super::real(precision).to_string()),
            ("clip.wgsl", super::CLIP.to_string()),
            (
                "splat.wgsl",
                include_str!("../../../shaders/splat.wgsl").to_string(),
            ),
        ]
    };
    for precision in [Precision::F64, Precision::DoubleF32] {
        crate::gpu::wgsl_checks::assert_declared_before_use(&parts_of(precision));
    }
    crate::gpu::wgsl_checks::assert_declared_before_use(&[
        ("metric slots", super::metric_slots()),
        ("types.wgsl", super::SHARED.to_string()),
        ("real", super::real(Precision::F64).to_string()),
        (
            "poses.wgsl",
            include_str!("../../../shaders/poses.wgsl").to_string(),
        ),
    ]);
    crate::gpu::wgsl_checks::assert_declared_before_use(&[
        ("metric slots", super::metric_slots()),
        ("clip constants", super::clip_constants()),
        ("types.wgsl", super::SHARED.to_string()),
        ("real", super::real(Precision::F64).to_string()),
        ("clip.wgsl", super::CLIP.to_string()),
        ("roots_f64.wgsl", super::ROOTS.to_string()),
        (
            "exact.wgsl",
            include_str!("../../../shaders/exact.wgsl").to_string(),
        ),
    ]);
    crate::gpu::wgsl_checks::assert_declared_before_use(&[
        ("metric slots", super::metric_slots()),
        ("metric order", super::metric_order()),
        ("types.wgsl", super::SHARED.to_string()),
        ("widen.wgsl", super::WIDEN.to_string()),
        (
            "summary.wgsl",
            include_str!("../../../shaders/summary.wgsl").to_string(),
        ),
    ]);
    crate::gpu::wgsl_checks::assert_declared_before_use(&[
        ("metric slots", super::metric_slots()),
        ("types.wgsl", super::SHARED.to_string()),
        (
            "reduce.wgsl",
            include_str!("../../../shaders/reduce.wgsl").to_string(),
        ),
    ]);
}

/// The exact stage takes its pipeline constant: wgpu rebuilds the module with it through naga,
/// which refused constructs the plain validation accepts (a constant array in `atan_f64`).
#[test]
fn the_exact_stage_takes_its_workgroup_size() {
    let m = module(&exact(), "exact");
    let info = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::FLOAT64,
    )
    .validate(&m)
    .unwrap();
    for threads in [1.0, 64.0] {
        let mut constants = naga::back::PipelineConstants::default();
        constants.insert("WORKGROUP".to_string(), threads);
        if let Err(e) = naga::back::pipeline_constants::process_overrides(&m, &info, None, &constants) {
            panic!("WORKGROUP = {threads}: {e:#?}");
        }
    }
}
