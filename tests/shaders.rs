//! The WGSL stages parse and validate, and the structs and constants they share with Rust have
//! the same sizes and values on both sides (the "keep in sync" comments, checked).

use naga::valid::{Capabilities, ValidationFlags, Validator};
use sonarproj::gpu::shaders;
use sonarproj::projection::gpu::types;

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
    for (name, source, needs_f64) in shaders::all() {
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
    let m = module(&shaders::splat(shaders::Precision::F64), "splat");
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
    let m = module(&shaders::splat(shaders::Precision::F64), "splat");
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

#[test]
fn metric_slots_match() {
    let m = module(&shaders::splat(shaders::Precision::F64), "splat");
    let value = |name: &str| -> usize {
        let c = m
            .constants
            .iter()
            .find(|(_, c)| c.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("no const {name} in the WGSL"))
            .1;
        match m.global_expressions[c.init] {
            naga::Expression::Literal(naga::Literal::U32(v)) => v as usize,
            ref e => panic!("{name} is not a u32 literal: {e:?}"),
        }
    };
    assert_eq!(value("METRIC_STRIDE"), types::METRIC_STRIDE);
    assert_eq!(value("METRIC_VISIBLE"), types::METRIC_VISIBLE);
    assert_eq!(value("METRIC_OCCUPIED"), types::METRIC_OCCUPIED);
    assert_eq!(value("METRIC_RANGE_MIN_NOT"), types::METRIC_RANGE_MIN_NOT);
    assert_eq!(value("METRIC_RANGE_MAX"), types::METRIC_RANGE_MAX);
    assert_eq!(value("METRIC_AZIMUTH_MIN_NOT"), types::METRIC_AZIMUTH_MIN_NOT);
    assert_eq!(value("METRIC_AZIMUTH_MAX"), types::METRIC_AZIMUTH_MAX);
    assert_eq!(value("METRIC_MEASURE"), types::METRIC_MEASURE);
    // The culling blocks of the shader are those of its CPU twin (the direction table holds
    // one ball per cpu_fast block).
    assert_eq!(value("BLOCK"), sonarproj::projection::fast::BLOCK);
}

#[test]
fn mask_structs_match_the_rust_layout() {
    use sonarproj::masks::gpu::{MASK_JOB_SIZE, MASK_PARAMS_SIZE, MaskJob, MaskParams, source};
    use std::mem::offset_of;
    let m = module(source(), "mask");
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
        ("fls", offset_of!(MaskParams, fls)),
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
        ("az_count", offset_of!(MaskJob, az_count)),
        ("el_count", offset_of!(MaskJob, el_count)),
        ("az_offset", offset_of!(MaskJob, az_offset)),
        ("el_offset", offset_of!(MaskJob, el_offset)),
        ("block_offset", offset_of!(MaskJob, block_offset)),
        ("block_count", offset_of!(MaskJob, block_count)),
    ];
    let want: Vec<(String, usize)> = job.iter().map(|(n, o)| (n.to_string(), *o)).collect();
    assert_eq!(wgsl_members(&m, "MaskJob"), want);
}

/// Returns the kinds of `module`'s group-0 bindings in binding order, and the x size of the
/// `main` entry point's workgroup.
fn interface(module: &naga::Module) -> (Vec<sonarproj::gpu::pipeline::Binding>, u32) {
    use sonarproj::gpu::pipeline::Binding;
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
    use sonarproj::masks::gpu::{MASK_BINDINGS, MASK_WORKGROUP, source};
    use sonarproj::projection::gpu::{REDUCE_BINDINGS, SPLAT_BINDINGS};
    use sonarproj::projection::gpu::{REDUCE_WORKGROUP, SPLAT_WORKGROUP};
    for precision in [shaders::Precision::F64, shaders::Precision::DoubleF32] {
        let (b, w) = interface(&module(&shaders::splat(precision), "splat"));
        assert_eq!(b, SPLAT_BINDINGS, "splat.wgsl bindings");
        assert_eq!(w, SPLAT_WORKGROUP, "splat.wgsl workgroup size");
    }
    let (b, w) = interface(&module(&shaders::reduce(), "reduce"));
    assert_eq!(b, REDUCE_BINDINGS, "reduce.wgsl bindings");
    assert_eq!(u64::from(w), REDUCE_WORKGROUP, "reduce.wgsl workgroup size");
    let (b, w) = interface(&module(source(), "mask"));
    assert_eq!(b, MASK_BINDINGS, "mask.wgsl bindings");
    assert_eq!(u64::from(w), MASK_WORKGROUP, "mask.wgsl workgroup size");
}
