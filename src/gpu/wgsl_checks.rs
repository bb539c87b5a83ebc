//! What the shader tests of both pipelines read of a WGSL stage through naga: the module (parsed
//! and validated), a struct's members and size, a constant, and the bindings and workgroup size of
//! its entry point. Test-only.

use naga::valid::{Capabilities, ValidationFlags, Validator};

use crate::gpu::pipeline::Binding;

/// Returns `source` parsed and validated with the f64 capability. Panics with `name` and naga's
/// message when it is not.
pub(crate) fn module(source: &str, name: &str) -> naga::Module {
    module_with(source, name, Capabilities::FLOAT64)
}

/// Returns `source` parsed and validated with `capabilities`, as [`module`] does.
pub(crate) fn module_with(source: &str, name: &str, capabilities: Capabilities) -> naga::Module {
    let module = naga::front::wgsl::parse_str(source)
        .unwrap_or_else(|e| panic!("{name}.wgsl does not parse:\n{}", e.emit_to_string(source)));
    Validator::new(ValidationFlags::all(), capabilities)
        .validate(&module)
        .unwrap_or_else(|e| panic!("{name}.wgsl does not validate: {e:?}"));
    module
}

/// Validates `source` without the f64 capability, as adapters without f64 run it. Panics with
/// `name` when it needs the capability.
pub(crate) fn validate_without_f64(source: &str, name: &str) {
    let m = naga::front::wgsl::parse_str(source).unwrap();
    Validator::new(ValidationFlags::all(), Capabilities::empty())
        .validate(&m)
        .unwrap_or_else(|e| panic!("{name} needs a capability it should not: {e:?}"));
}

/// Returns the byte size of WGSL struct `name` in `m`, as naga lays it out.
pub(crate) fn struct_size(m: &naga::Module, name: &str) -> usize {
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(m.to_ctx()).unwrap();
    let (h, _) = m
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no struct {name} in the WGSL"));
    layouter[h].size as usize
}

/// Returns `(member name, byte offset)` of WGSL struct `name` in `m`.
pub(crate) fn wgsl_members(m: &naga::Module, name: &str) -> Vec<(String, usize)> {
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

/// Returns the value of the WGSL constant `name` of `m` (a u32 or f32 literal, as f64).
pub(crate) fn constant(m: &naga::Module, name: &str) -> f64 {
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

/// Returns the kinds of `module`'s group-0 bindings in binding order, and the x size of the
/// `main` entry point's workgroup.
pub(crate) fn interface(module: &naga::Module) -> (Vec<Binding>, u32) {
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

/// Returns the module-scope names `part` declares (constants, overrides, variables, functions,
/// structs, aliases), read from the start of its lines.
fn declared(part: &str) -> Vec<String> {
    let mut names = Vec::new();
    for line in part.lines() {
        // Attributes first (`@group(0) @binding(1) var<…> name`, `@compute … fn main`).
        let mut rest = line.trim_start();
        while let Some(r) = rest.strip_prefix('@') {
            rest = r.split_once(' ').map_or("", |(_, r)| r).trim_start();
        }
        for keyword in ["const ", "override ", "var ", "var<", "fn ", "struct ", "alias "] {
            if let Some(r) = rest.strip_prefix(keyword) {
                let r = if keyword == "var<" {
                    r.split_once('>').map_or("", |(_, r)| r)
                } else {
                    r
                };
                let name: String = r
                    .trim_start()
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                if !name.is_empty() && line.starts_with(|c: char| !c.is_whitespace()) {
                    names.push(name);
                }
            }
        }
    }
    names
}

/// Returns the identifiers `part` uses outside its comments.
fn identifiers(part: &str) -> std::collections::HashSet<String> {
    part.lines()
        .map(|l| l.split("//").next().unwrap_or(""))
        .flat_map(|l| l.split(|c: char| !(c.is_alphanumeric() || c == '_')))
        .filter(|w| w.starts_with(|c: char| c.is_alphabetic() || c == '_'))
        .map(str::to_string)
        .collect()
}

/// Asserts that no part of `parts` uses a module-scope name that only a later part declares.
/// `parts` are named WGSL pieces, in the order a stage is assembled.
pub(crate) fn assert_declared_before_use(parts: &[(&str, String)]) {
    for (i, (name, part)) in parts.iter().enumerate() {
        let before: std::collections::HashSet<String> =
            parts[..=i].iter().flat_map(|(_, p)| declared(p)).collect();
        let used = identifiers(part);
        for (later, later_part) in &parts[i + 1..] {
            for global in declared(later_part) {
                assert!(
                    before.contains(&global) || !used.contains(&global),
                    "{name} uses {global}, declared after it in {later}"
                );
            }
        }
    }
}
