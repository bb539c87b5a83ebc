//! The WGSL stages parse and validate, and the structs and constants they share with Rust have
//! the same sizes and values on both sides (the "keep in sync" comments, checked).

use naga::valid::{Capabilities, ValidationFlags, Validator};
use sonarproj::gpu::{shaders, types};

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
}
