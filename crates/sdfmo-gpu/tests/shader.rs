//! The WGSL compiles and validates with naga (no adapter needed), and the documented binding
//! layout is the one the shader declares.

use naga::valid::{Capabilities, ValidationFlags, Validator};

fn module(source: &str) -> naga::Module {
    naga::front::wgsl::parse_str(source).unwrap_or_else(|e| panic!("{}", e.emit_to_string(source)))
}

#[test]
fn render_shader_validates() {
    let source = sdfmo_gpu::shader_source();
    let m = module(&source);
    Validator::new(ValidationFlags::all(), Capabilities::empty())
        .validate(&m)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&source)));
    assert!(m
        .entry_points
        .iter()
        .any(|e| e.name == sdfmo_gpu::ENTRY_POINT
            && e.workgroup_size == [sdfmo_gpu::WORKGROUP_SIZE, sdfmo_gpu::WORKGROUP_SIZE, 1]));
}

#[test]
fn library_alone_validates_and_binds_only_the_octree() {
    let m = module(sdfmo_gpu::TRACE_WGSL);
    Validator::new(ValidationFlags::all(), Capabilities::empty())
        .validate(&m)
        .expect("sdfmo.wgsl validates on its own");
    let bindings: Vec<_> = m
        .global_variables
        .iter()
        .filter_map(|(_, g)| {
            g.binding
                .as_ref()
                .map(|b| (g.name.clone(), b.group, b.binding))
        })
        .collect();
    assert_eq!(bindings, vec![(Some("smo".to_string()), 0, 0)]);
}

#[test]
fn render_bindings_match_the_documented_layout() {
    let m = module(&sdfmo_gpu::shader_source());
    let mut bindings: Vec<_> = m
        .global_variables
        .iter()
        .filter_map(|(_, g)| {
            g.binding
                .as_ref()
                .map(|b| (b.binding, g.name.clone().unwrap_or_default()))
        })
        .collect();
    bindings.sort();
    let names: Vec<_> = bindings.iter().map(|(b, n)| format!("{b}:{n}")).collect();
    assert_eq!(
        names,
        ["0:smo", "1:params", "2:pixels", "3:colors", "4:rays"]
    );
}
