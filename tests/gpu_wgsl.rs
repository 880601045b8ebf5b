//! WGSL checks that need no adapter: every module `backend::gpu::shader` assembles parses and
//! validates with naga, and every struct in `gpu_types` has the same size and member offsets
//! in WGSL (naga's layouter) as in Rust.
use brume::backend::gpu::shader::{files, MODULES};
use brume::gpu_types::SHARED_STRUCTS;

fn parse(label: &str, source: &str) -> naga::Module {
    naga::front::wgsl::parse_str(source)
        .unwrap_or_else(|e| panic!("{label}: WGSL parse error\n{}", e.emit_to_string(source)))
}

#[test]
fn every_module_parses_and_validates() {
    for m in MODULES {
        let source = m.source(&[]);
        let module = parse(m.label, &source);
        let mut validator = naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::default(),
        );
        validator.validate(&module).unwrap_or_else(|e| {
            panic!(
                "{}: WGSL validation error\n{}",
                m.label,
                e.emit_to_string(&source)
            )
        });
        assert!(
            module
                .entry_points
                .iter()
                .any(|e| e.name == m.entry_point && e.stage == naga::ShaderStage::Compute),
            "{}: no compute entry point {}",
            m.label,
            m.entry_point
        );
        println!("{:<14} ok ({} lines)", m.label, source.lines().count());
    }
}

/// Every stage/kernel/common file opens with a comment naming the Rust code it mirrors.
#[test]
fn every_file_names_what_it_mirrors() {
    let mut seen = std::collections::BTreeSet::new();
    for m in MODULES {
        for f in m.files {
            if !seen.insert(f.name) {
                continue;
            }
            let first = f.source.lines().next().unwrap_or("");
            assert!(
                first.starts_with("// Mirrors") || first.starts_with("// Test kernel for"),
                "{} must open with `// Mirrors <Rust function>`; found {first:?}",
                f.name
            );
        }
    }
}

#[test]
fn shared_struct_layouts_match_rust() {
    let source = brume::backend::gpu::shader::assemble(&[files::TYPES], &[]);
    let module = parse("types.wgsl", &source);
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).expect("layout");
    for rust in SHARED_STRUCTS {
        let (handle, ty) = module
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some(rust.name))
            .unwrap_or_else(|| panic!("types.wgsl has no struct {}", rust.name));
        let naga::TypeInner::Struct { members, span } = &ty.inner else {
            panic!("{} is not a struct in WGSL", rust.name);
        };
        let size = layouter[handle].size as usize;
        assert_eq!(
            size, rust.size,
            "{}: WGSL size {size}, Rust {}",
            rust.name, rust.size
        );
        assert_eq!(*span as usize, rust.size, "{}: WGSL span", rust.name);
        let wgsl: Vec<(&str, usize)> = members
            .iter()
            .map(|m| (m.name.as_deref().unwrap_or("?"), m.offset as usize))
            .collect();
        assert_eq!(
            wgsl,
            rust.members.to_vec(),
            "{}: WGSL members/offsets differ from Rust",
            rust.name
        );
        println!(
            "{:<20} {:>3} bytes, {} members: ok",
            rust.name,
            size,
            wgsl.len()
        );
    }
}
