//! The WGSL stages parse and validate, and the structs, constants, bindings and workgroup sizes
//! they share with Rust are the same on both sides (the "keep in sync" comments, checked).
#![expect(
    clippy::cast_possible_truncation,
    reason = "WGSL constants are small integers or f32 values, read back as f64"
)]

use naga::valid::{Capabilities, ValidationFlags, Validator};

use crate::gpu::pipeline::Binding;
use crate::gpu::shaders::{self, Precision};
use crate::projection::gpu::types;

/// Returns every stage and variant as `(name, full source, needs f64)`.
fn all() -> Vec<(&'static str, String, bool)> {
    vec![
        ("splat (f64)", shaders::splat(Precision::F64), true),
        ("splat (double-f32)", shaders::splat(Precision::DoubleF32), false),
        ("reduce", shaders::reduce(), false),
        ("poses (f64)", shaders::poses(Precision::F64), true),
        ("poses (double-f32)", shaders::poses(Precision::DoubleF32), false),
        ("mask", shaders::mask(), false),
        ("mask reduce", shaders::mask_reduce(), false),
    ]
}

fn module(source: &str, name: &str) -> naga::Module {
    let module = naga::front::wgsl::parse_str(source)
        .unwrap_or_else(|e| panic!("{name}.wgsl does not parse:\n{}", e.emit_to_string(source)));
    Validator::new(ValidationFlags::all(), Capabilities::FLOAT64)
        .validate(&module)
        .unwrap_or_else(|e| panic!("{name}.wgsl does not validate: {e:?}"));
    module
}

#[test]
fn every_stage_parses_and_validates() {
    for (name, source, needs_f64) in all() {
        module(&source, name);
        if !needs_f64 {
            // Without the f64 capability too: adapters that lack it run this variant.
            let m = naga::front::wgsl::parse_str(&source).unwrap();
            Validator::new(ValidationFlags::all(), Capabilities::empty())
                .validate(&m)
                .unwrap_or_else(|e| panic!("{name} needs a capability it should not: {e:?}"));
        }
    }
}

#[test]
fn shared_structs_have_the_rust_sizes() {
    let m = module(&shaders::splat(Precision::F64), "splat");
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(m.to_ctx()).unwrap();
    let size_of = |name: &str| {
        let (h, _) = m
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("no struct {name} in the WGSL"));
        layouter[h].size as usize
    };
    assert_eq!(
        size_of("TargetParams"),
        std::mem::size_of::<types::TargetParams>()
    );
    assert_eq!(size_of("Pose"), std::mem::size_of::<types::PoseGpu>());
    assert_eq!(size_of("BeamEdge"), std::mem::size_of::<types::BeamEdgeGpu>());
    let m = module(&shaders::poses(Precision::F64), "poses");
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(m.to_ctx()).unwrap();
    let (h, _) = m
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some("GridParams"))
        .expect("GridParams in poses.wgsl");
    assert_eq!(
        layouter[h].size as usize,
        std::mem::size_of::<types::GridParams>()
    );
    let members = wgsl_members(&m, "GridParams");
    use std::mem::offset_of;
    for (name, offset) in [
        ("first", offset_of!(types::GridParams, first)),
        ("lens", offset_of!(types::GridParams, lens)),
        ("offsets", offset_of!(types::GridParams, offsets)),
        ("count", offset_of!(types::GridParams, count)),
        ("placement", offset_of!(types::GridParams, placement)),
        ("fls", offset_of!(types::GridParams, fls)),
    ] {
        assert!(
            members.contains(&(name.to_string(), offset)),
            "GridParams.{name} at {offset}: {members:?}"
        );
    }
}

/// Returns `(member name, byte offset)` of WGSL struct `name` in `m`.
fn wgsl_members(m: &naga::Module, name: &str) -> Vec<(String, usize)> {
    let ty = m
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no struct {name} in the WGSL"))
        .1;
    match &ty.inner {
        naga::TypeInner::Struct { members, .. } => members
            .iter()
            .map(|mb| (mb.name.clone().unwrap_or_default(), mb.offset as usize))
            .collect(),
        other => panic!("{name} is not a struct: {other:?}"),
    }
}

#[test]
fn shared_struct_members_sit_at_the_rust_offsets() {
    use std::mem::offset_of;
    use types::{BeamEdgeGpu, PoseGpu, TargetParams};
    let m = module(&shaders::splat(Precision::F64), "splat");
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

/// Returns the value of the WGSL constant `name` of `m` (a u32 or f32 literal, as f64).
fn constant(m: &naga::Module, name: &str) -> f64 {
    let c = m
        .constants
        .iter()
        .find(|(_, c)| c.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no const {name} in the WGSL"))
        .1;
    match m.global_expressions[c.init] {
        naga::Expression::Literal(naga::Literal::U32(v)) => f64::from(v),
        naga::Expression::Literal(naga::Literal::F32(v)) => f64::from(v),
        ref e => panic!("{name} is not a u32 or f32 literal: {e:?}"),
    }
}

/// The metric slots the stages use are generated from the metric table: each has the slot the
/// Rust side decodes, and the stages name no slot the table does not give.
#[test]
fn metric_slots_match() {
    for (name, source) in [
        ("splat", shaders::splat(Precision::F64)),
        ("reduce", shaders::reduce()),
    ] {
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
        include_str!("../../shaders/shared/types.wgsl"),
        include_str!("../../shaders/splat.wgsl"),
        include_str!("../../shaders/reduce.wgsl"),
    ] {
        assert!(!file.contains("const METRIC_"), "a hand-written metric slot");
    }
}

/// The constants the splat stage's decisions share with Rust: the culling block and the
/// tolerances of `shaders/shared/clip.wgsl` are `src/clip.rs`'s.
#[test]
fn clip_constants_match() {
    let m = module(&shaders::splat(Precision::F64), "splat");
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
    // The mask stage's block holds the mask planner's BLOCK × BLOCK cells, one per thread.
    let mask = module(&shaders::mask(), "mask");
    let block = crate::masks::plan::BLOCK;
    assert_eq!(constant(&mask, "CELLS") as usize, block * block);
    assert_eq!(block * block, crate::masks::gpu::MASK_WORKGROUP as usize);
    assert!(!include_str!("../../shaders/mask.wgsl").contains("const CELLS:"));
    // Generated, never hand-written.
    let clip = include_str!("../../shaders/shared/clip.wgsl");
    for name in ["F32_SLACK", "F32_WIDEN", "BLOCK"] {
        assert!(
            !clip.contains(&format!("const {name}:")),
            "{name} written by hand"
        );
    }
}

#[test]
fn mask_structs_match_the_rust_layout() {
    use crate::masks::gpu::{MASK_JOB_SIZE, MASK_PARAMS_SIZE, MaskJob, MaskParams, source};
    use std::mem::offset_of;
    let m = module(&source(), "mask");
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(m.to_ctx()).unwrap();
    let size = |name: &str| {
        let (h, _) = m
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some(name))
            .unwrap();
        layouter[h].size as usize
    };
    assert_eq!(size("MaskParams"), MASK_PARAMS_SIZE);
    assert_eq!(size("MaskJob"), MASK_JOB_SIZE);
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

/// Returns the kinds of `module`'s group-0 bindings in binding order, and the x size of the
/// `main` entry point's workgroup.
fn interface(module: &naga::Module) -> (Vec<Binding>, u32) {
    let mut bindings: Vec<(u32, Binding)> = module
        .global_variables
        .iter()
        .filter_map(|(_, v)| {
            let b = v.binding.as_ref()?;
            assert_eq!(b.group, 0, "{:?} is not in group 0", v.name);
            let kind = match v.space {
                naga::AddressSpace::Uniform => Binding::Uniform,
                naga::AddressSpace::Storage { access } if access.contains(naga::StorageAccess::STORE) => {
                    Binding::ReadWrite
                }
                naga::AddressSpace::Storage { .. } => Binding::Read,
                other => panic!("{:?}: unexpected address space {other:?}", v.name),
            };
            Some((b.binding, kind))
        })
        .collect();
    bindings.sort_by_key(|&(b, _)| b);
    let numbers: Vec<u32> = bindings.iter().map(|&(b, _)| b).collect();
    assert_eq!(
        numbers,
        (0..u32::try_from(numbers.len()).unwrap()).collect::<Vec<_>>(),
        "bindings are not 0..n"
    );
    let main = module
        .entry_points
        .iter()
        .find(|e| e.name == "main")
        .expect("a main entry point");
    let size = match &main.workgroup_size_overrides {
        // @workgroup_size(OVERRIDE): the override's default, a literal.
        Some([Some(x), None, None]) => {
            let naga::Expression::Override(o) = module.global_expressions[*x] else {
                panic!("the workgroup size is not an override")
            };
            let init = module.overrides[o].init.expect("the override has a default");
            let naga::Expression::Literal(naga::Literal::U32(size)) = module.global_expressions[init] else {
                panic!("the override's default is not a u32 literal")
            };
            size
        }
        Some(other) => panic!("workgroup size overrides {other:?}"),
        None => {
            assert_eq!(main.workgroup_size[1..], [1, 1], "workgroups are one-dimensional");
            main.workgroup_size[0]
        }
    };
    (bindings.into_iter().map(|(_, k)| k).collect(), size)
}

/// The binding tables the pipelines are built with, and the workgroup sizes the dispatches are
/// computed with, are the WGSL's (they were kept in sync by comments only).
#[test]
fn binding_tables_and_workgroup_sizes_match_the_wgsl() {
    use crate::gpu::options::SPLAT_WORKGROUP;
    use crate::masks::gpu::{
        MASK_BINDINGS, MASK_REDUCE_BINDINGS, MASK_REDUCE_WORKGROUP, MASK_WORKGROUP, reduce_source, source,
    };
    use crate::projection::gpu::{POSES_BINDINGS, POSES_WORKGROUP, REDUCE_BINDINGS, SPLAT_BINDINGS};
    // The reduce stage runs one workgroup per pose whatever its size: its 64 threads are the
    // WGSL's own, said here so that a change is seen.
    const REDUCE_WORKGROUP: u64 = 64;
    for precision in [Precision::F64, Precision::DoubleF32] {
        let (b, w) = interface(&module(&shaders::splat(precision), "splat"));
        assert_eq!(b, SPLAT_BINDINGS, "splat.wgsl bindings");
        assert_eq!(w, SPLAT_WORKGROUP, "splat.wgsl workgroup size");
    }
    for precision in [Precision::F64, Precision::DoubleF32] {
        let (b, w) = interface(&module(&shaders::poses(precision), "poses"));
        assert_eq!(b, POSES_BINDINGS, "poses.wgsl bindings");
        assert_eq!(u64::from(w), POSES_WORKGROUP, "poses.wgsl workgroup size");
    }
    let (b, w) = interface(&module(&shaders::reduce(), "reduce"));
    assert_eq!(b, REDUCE_BINDINGS, "reduce.wgsl bindings");
    assert_eq!(u64::from(w), REDUCE_WORKGROUP, "reduce.wgsl workgroup size");
    let (b, w) = interface(&module(&source(), "mask"));
    assert_eq!(b, MASK_BINDINGS, "mask.wgsl bindings");
    assert_eq!(u64::from(w), MASK_WORKGROUP, "mask.wgsl workgroup size");
    let (b, w) = interface(&module(&reduce_source(), "mask reduce"));
    assert_eq!(b, MASK_REDUCE_BINDINGS, "mask_reduce.wgsl bindings");
    assert_eq!(
        u64::from(w),
        MASK_REDUCE_WORKGROUP,
        "mask_reduce.wgsl workgroup size"
    );
}
