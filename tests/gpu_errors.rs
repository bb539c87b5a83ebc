//! GPU failures are errors with their cause: a shader the device refuses, or a pipeline whose
//! bindings do not match its shader, is an `Error::Gpu` carrying wgpu's error as its source,
//! never a panic.

use sonarproj_testkit as common;

use sonarproj::Error;
use sonarproj::test_support::build_stage;

#[test]
fn a_refused_stage_is_an_error_with_its_cause() {
    let Some(ctx) = common::gpu_context() else {
        return;
    };
    let uses_out = "@group(0) @binding(0) var<storage, read_write> out: array<u32>;\n\
                    @compute @workgroup_size(1) fn main() { out[0] = 1u; }";
    for (what, source, bindings) in [
        ("not WGSL at all", "fn main( {", &["uniform"][..]),
        ("a binding the table does not have", uses_out, &["uniform"][..]),
    ] {
        let e = build_stage(&ctx, "broken", source, bindings).unwrap_err();
        assert!(matches!(e, Error::Gpu { .. }), "{what}: {e}");
        assert!(e.to_string().contains("building the broken stage"), "{what}: {e}");
        assert!(std::error::Error::source(&e).is_some(), "{what}: no source");
        assert!(
            !e.is_input(),
            "{what}: a failure of the machine, not the user's input"
        );
    }
    // And a good one builds.
    build_stage(&ctx, "fine", uses_out, &["read_write"]).unwrap();
}
