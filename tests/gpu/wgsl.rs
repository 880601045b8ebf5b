//! WGSL checks that need no adapter: every module `backend::gpu::shader` assembles parses and
//! validates with naga, and every struct in `gpu_types` has the same size and member offsets
//! in WGSL (naga's layouter) as in Rust.
use brume::backend::gpu::shader::{files, MODULES};
use brume::gpu_types::SHARED_STRUCTS;

fn parse(label: &str, source: &str) -> naga::Module {
    naga::front::wgsl::parse_str(source)
        .unwrap_or_else(|e| panic!("{label}: WGSL parse error\n{}", e.emit_to_string(source)))
}

/// Every module of [`MODULES`] with its default specialisation, assembled and parsed once
/// for the tests that read them (parsing them all takes about a second).
fn default_modules() -> &'static [(String, naga::Module)] {
    static PARSED: std::sync::OnceLock<Vec<(String, naga::Module)>> = std::sync::OnceLock::new();
    PARSED.get_or_init(|| {
        MODULES
            .iter()
            .map(|m| {
                let source = m.source(&[]);
                let module = parse(m.label, &source);
                (source, module)
            })
            .collect()
    })
}

#[test]
fn every_module_parses_and_validates() {
    for (m, (source, module)) in MODULES.iter().zip(default_modules()) {
        let mut validator = naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::default(),
        );
        validator.validate(module).unwrap_or_else(|e| {
            panic!(
                "{}: WGSL validation error\n{}",
                m.label,
                e.emit_to_string(source)
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

/// No kernel reads more uniform blocks from one bind group than every driver Brume runs on
/// handles; the generic variant (each module's defaults, every feature on) reads the most.
/// Lavapipe corrupted its heap creating the generic `sample_medium` with three in group 0
/// (`tools/lavapipe_ubo/`).
#[test]
fn no_kernel_reads_more_uniform_blocks_than_lavapipe_takes() {
    use brume::backend::gpu::shader::MAX_UNIFORM_BLOCKS_PER_GROUP;
    for m in MODULES {
        let bindings = m
            .bindings(&[])
            .unwrap_or_else(|e| panic!("{}: {e}", m.label));
        let per_group = [0, 1].map(|g| {
            bindings
                .iter()
                .filter(|b| b.uniform && b.group == g)
                .count()
        });
        println!("{:<14} uniform blocks per group {per_group:?}", m.label);
        assert!(
            per_group.iter().all(|&n| n <= MAX_UNIFORM_BLOCKS_PER_GROUP),
            "{}: {per_group:?}",
            m.label
        );
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
            if first.starts_with("// Mirrors") {
                check_mirror_header(f.name, f.source);
            }
        }
    }
}

/// The opening paragraph of a WGSL file's comment (up to an empty comment line or code).
fn header(source: &str) -> String {
    source
        .lines()
        .take_while(|l| l.starts_with("//") && l.trim() != "//")
        .map(|l| l.trim_start_matches('/').trim())
        .collect::<Vec<_>>()
        .join(" ")
}

fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// Whether `word` occurs in `text` as a whole identifier.
fn has_word(text: &str, word: &str) -> bool {
    text.match_indices(word).any(|(i, _)| {
        let before = text[..i].chars().next_back().map_or(true, |c| !is_ident(c));
        let after = text[i + word.len()..]
            .chars()
            .next()
            .map_or(true, |c| !is_ident(c));
        before && after
    })
}

/// Whether `name` is defined (a type, trait, function or constant) in `text`.
fn defines(text: &str, name: &str) -> bool {
    [
        "struct ", "enum ", "trait ", "type ", "impl ", "for ", "fn ", "const ", "mod ",
    ]
    .iter()
    .any(|k| has_word(text, &format!("{k}{name}")))
}

/// Whether `text` declares `name`: an item ([`defines`]), a field (`name: T`) or an enum
/// variant (a capitalised name opening a line as `Name,`, `Name(` or `Name {`).
fn declares(text: &str, name: &str) -> bool {
    defines(text, name)
        || text.match_indices(name).any(|(i, _)| {
            let before = text[..i].chars().next_back().map_or(true, |c| !is_ident(c));
            let rest = &text[i + name.len()..];
            let field = rest.starts_with(':') && !rest.starts_with("::");
            let line_start = text[..i]
                .rsplit('\n')
                .next()
                .unwrap_or("")
                .trim()
                .is_empty();
            let variant = line_start
                && name.starts_with(char::is_uppercase)
                && (rest.starts_with(',') || rest.starts_with('(') || rest.starts_with(" {"));
            before && (field || variant)
        })
}

/// The Rust sources a header names (`src/...` files, and every file under a named folder);
/// all of `src/` when it names none.
fn named_sources(file: &str, header: &str) -> Vec<(String, String)> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut paths = Vec::new();
    for (i, _) in header.match_indices("src/") {
        if i > 0 && is_ident(header[..i].chars().next_back().unwrap()) {
            continue;
        }
        let tail = &header[i..];
        let end = tail
            .find(|c: char| !(is_ident(c) || c == '/' || c == '.'))
            .unwrap_or(tail.len());
        let path = tail[..end].trim_end_matches('.').to_string();
        let full = root.join(&path);
        assert!(
            full.exists(),
            "{file}: its Mirrors header names {path}, which does not exist"
        );
        paths.push(full);
    }
    if paths.is_empty() {
        paths.push(root.join("src"));
    }
    let mut out = Vec::new();
    while let Some(p) = paths.pop() {
        if p.is_dir() {
            for e in std::fs::read_dir(&p).unwrap() {
                paths.push(e.unwrap().path());
            }
        } else if p.extension().is_some_and(|e| e == "rs") {
            let text = std::fs::read_to_string(&p).unwrap();
            out.push((p.display().to_string(), text));
        }
    }
    out
}

/// Types of other crates that headers cite (obvhs' BVH, whose traversal surfaces.wgsl follows).
const EXTERNAL: &[&str] = &["CwBvh", "CwBvhNode"];

/// Every `src/...` path a "Mirrors" header names exists, and every Rust item it names as
/// `Type::item`, or in backticks, exists in Brume's sources: a header that still names a moved
/// file or a renamed or removed function fails here.
fn check_mirror_header(file: &str, source: &str) {
    let header = header(source);
    let sources = named_sources(file, &header);
    // A name is looked for in the files the header names, then (types it mentions in
    // passing, such as the GPU structs) anywhere in src/.
    let everything = named_sources(file, "src/");
    let defined_in_sources = |name: &str| {
        sources
            .iter()
            .chain(&everything)
            .any(|(_, t)| defines(t, name))
    };
    let declared_in_sources = |name: &str| {
        sources
            .iter()
            .chain(&everything)
            .any(|(_, t)| declares(t, name))
    };
    // `Type::item` (items may be functions, fields or variants).
    for (i, _) in header.match_indices("::") {
        let ty: String = header[..i]
            .chars()
            .rev()
            .take_while(|&c| is_ident(c))
            .collect::<Vec<_>>()
            .into_iter()
            .rev()
            .collect();
        let item: String = header[i + 2..]
            .chars()
            .take_while(|&c| is_ident(c))
            .collect();
        // `GpuPathState::hit_*`: a family of fields.
        let family = header[i + 2 + item.len()..].starts_with('*');
        if family
            || ty.is_empty()
            || item.is_empty()
            || !ty.starts_with(char::is_uppercase)
            || EXTERNAL.contains(&ty.as_str())
        {
            continue;
        }
        assert!(
            defined_in_sources(&ty),
            "{file}: its Mirrors header names {ty}::{item}, but no named source defines {ty}"
        );
        assert!(
            sources
                .iter()
                .chain(&everything)
                .any(|(_, t)| defines(t, &ty) && declares(t, &item)),
            "{file}: its Mirrors header names {ty}::{item}, but no source that defines {ty} \
             declares {item}"
        );
    }
    // `name` in backticks: a function, type, constant, field or variant (of Brume's, or a
    // WGSL function of the file itself).
    for (k, quoted) in header.split('`').enumerate() {
        if k % 2 == 0 || !quoted.chars().all(is_ident) || quoted.is_empty() {
            continue;
        }
        assert!(
            declared_in_sources(quoted) || defines(source, quoted),
            "{file}: its Mirrors header names `{quoted}`, which no named source has"
        );
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

/// The functions an entry point reaches through calls.
fn reachable(module: &naga::Module, entry: &str) -> std::collections::BTreeSet<String> {
    fn walk(m: &naga::Module, block: &naga::Block, seen: &mut std::collections::BTreeSet<String>) {
        for s in block.iter() {
            match s {
                naga::Statement::Call { function, .. } => {
                    let f = &m.functions[*function];
                    let name = f.name.clone().unwrap_or_default();
                    if seen.insert(name) {
                        walk(m, &f.body, seen);
                    }
                }
                naga::Statement::Block(b) => walk(m, b, seen),
                naga::Statement::If { accept, reject, .. } => {
                    walk(m, accept, seen);
                    walk(m, reject, seen);
                }
                naga::Statement::Loop {
                    body, continuing, ..
                } => {
                    walk(m, body, seen);
                    walk(m, continuing, seen);
                }
                naga::Statement::Switch { cases, .. } => {
                    for c in cases {
                        walk(m, &c.body, seen);
                    }
                }
                _ => {}
            }
        }
    }
    let ep = module
        .entry_points
        .iter()
        .find(|e| e.name == entry)
        .expect("entry point");
    let mut seen = std::collections::BTreeSet::new();
    walk(module, &ep.function.body, &mut seen);
    seen
}

/// Specialisation: a wavefront stage compiled without a feature holds no code for it (no
/// call to the feature's functions, not even in a dead branch), and with every feature on
/// some stage does call each of them.
#[test]
fn variants_without_a_feature_hold_no_code_for_it() {
    use brume::backend::gpu::render::Stage;
    use brume::backend::gpu::Spec;
    let features: [(&str, &[&str]); 10] = [
        (
            "FEATURE_MOTION",
            &["advection_source", "velocity_component", "quat_slerp"],
        ),
        ("FEATURE_TEXTURES", &["texture_sample", "wrap_index"]),
        (
            "FEATURE_MIXTURE",
            &[
                "sample_media_mix",
                "mix_next",
                "mix_coeffs",
                "mix_transmittance",
            ],
        ),
        (
            "FEATURE_HETEROGENEOUS",
            &["sample_free_flight", "tracking_transmittance"],
        ),
        (
            "FEATURE_HOMOGENEOUS",
            &["sample_homogeneous", "transmittance_homogeneous"],
        ),
        (
            "FEATURE_SURFACES",
            &[
                "bvh_intersect_node",
                "intersect_triangle",
                "principled_sample",
            ],
        ),
        (
            "FEATURE_EMISSION",
            &["emission_met", "emission_mis_weight", "blackbody_emission"],
        ),
        (
            "FEATURE_LIGHT_PASSES",
            &["gather_pass", "pass_of", "clear_passes"],
        ),
        (
            "FEATURE_DATA_PASSES",
            &["record_albedo", "record_depth", "clear_data"],
        ),
        (
            "FEATURE_LIGHT_GROUPS",
            &[
                "gather_group",
                "clear_groups",
                "light_group_of",
                "gather_flight_groups",
                "emit_to_group",
            ],
        ),
    ];
    for (feature, functions) in features {
        let mut used_somewhere = std::collections::BTreeSet::new();
        for stage in Stage::ALL {
            let m = stage.module();
            for on in [true, false] {
                let source = m.source(&[Spec::bool(feature, on)]);
                let module = parse(m.label, &source);
                let calls = reachable(&module, m.entry_point);
                for f in functions {
                    if on {
                        if calls.contains(*f) {
                            used_somewhere.insert(*f);
                        }
                    } else {
                        assert!(
                            !calls.contains(*f),
                            "{}: {feature} off, yet it calls {f}",
                            m.label
                        );
                    }
                }
            }
        }
        for f in functions {
            assert!(
                used_somewhere.contains(f),
                "{feature}: no stage calls {f} with the feature on"
            );
        }
        println!("{feature}: off -> none of {functions:?} reachable");
    }
}

/// A WGSL constant's value as its bits, for exact comparison.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Bits {
    F32(u32),
    U32(u32),
}

/// Every `const` the assembled modules declare, by name, as naga evaluated it.
fn wgsl_constants() -> std::collections::BTreeMap<String, Bits> {
    let mut out = std::collections::BTreeMap::new();
    for (_, module) in default_modules() {
        for (_, c) in module.constants.iter() {
            let Some(name) = c.name.clone() else { continue };
            let value = match module.global_expressions[c.init] {
                naga::Expression::Literal(naga::Literal::F32(x)) => Bits::F32(x.to_bits()),
                naga::Expression::Literal(naga::Literal::U32(x)) => Bits::U32(x),
                _ => continue,
            };
            if let Some(seen) = out.insert(name.clone(), value) {
                assert_eq!(seen, value, "{name} differs between WGSL modules");
            }
        }
    }
    out
}

/// The constants the WGSL mirror writes out again hold the Rust values bit for bit: the
/// physics constants (roulette, collision cap, control cutoff, the thinning hand-on's bound),
/// the sampler's salts and dimension layout, the RNG's constants and the grid's encodings.
/// The parity tests would catch most drift only on a device, and only on the paths they reach.
#[test]
fn mirrored_constants_match_rust() {
    use brume::sampling::{discrete, rng, sobol};
    use brume::volume::tracking;
    let wgsl = wgsl_constants();
    let f = |x: f32| Bits::F32(x.to_bits());
    let u = Bits::U32;
    let rust: &[(&str, Bits)] = &[
        ("MAJORANT_TOLERANCE", f(tracking::MAJORANT_TOLERANCE)),
        ("ROULETTE_THRESHOLD", f(tracking::ROULETTE_THRESHOLD)),
        (
            "MAX_TENTATIVE_COLLISIONS",
            u(u32::try_from(tracking::MAX_TENTATIVE_COLLISIONS).expect("fits a u32")),
        ),
        ("CONTROL_DEPTH_CUTOFF", f(tracking::CONTROL_DEPTH_CUTOFF)),
        ("RECYCLE_MIN_P", f(tracking::RECYCLE_MIN_P)),
        ("ONE_MINUS_EPSILON", f(discrete::ONE_MINUS_EPSILON)),
        ("ENV_ONE_BELOW", f(discrete::ONE_MINUS_EPSILON)), // sampling::piecewise uses it too
        ("SOBOL_SALT", u(sobol::SOBOL_SALT)),
        ("DIM_JITTER", u(sobol::DIM_JITTER)),
        ("DIMS_PER_BOUNCE", u(sobol::DIMS_PER_BOUNCE)),
        ("DIM_DISTANCE", u(sobol::DIM_DISTANCE)),
        ("DIM_LIGHT_SELECT", u(sobol::DIM_LIGHT_SELECT)),
        ("DIM_LIGHT", u(sobol::DIM_LIGHT)),
        ("DIM_LOBE", u(sobol::DIM_LOBE)),
        ("DIM_SCATTER", u(sobol::DIM_SCATTER)),
        ("DIM_RR", u(sobol::DIM_RR)),
        ("PCG_MULT", u(rng::PCG_MULT)),
        ("PCG_INC", u(rng::PCG_INC)),
        ("RXS_M_XS_MULT", u(rng::RXS_M_XS_MULT)),
        ("INC_SALT", u(rng::INC_SALT)),
        ("CELL_WIDTH", f(brume::volume::bounds::CELL_WIDTH)),
        ("CONSTANT_BIT", u(brume::volume::CONSTANT_BIT)),
        ("STACK_NONE", u(brume::gpu_types::wavefront::STACK_NONE)),
        ("INV_4PI", f(brume::sampling::warp::INV_4PI)),
        ("PI", f(std::f32::consts::PI)),
    ];
    for (name, value) in rust {
        let found = wgsl
            .get(*name)
            .unwrap_or_else(|| panic!("no WGSL constant {name}"));
        assert_eq!(found, value, "WGSL {name} is not the Rust value");
        println!("{name:<26} {value:?}: ok");
    }
}

/// With every feature and pass on (each module's defaults), no stage binds more storage
/// buffers than the 16 a stage may (`max_storage_buffers_per_shader_stage`, as the device
/// asks for it).
#[test]
fn no_stage_binds_more_storage_buffers_than_a_stage_takes() {
    use brume::backend::gpu::render::Stage;
    for stage in Stage::ALL {
        let m = stage.module();
        let bindings = m
            .bindings(&[])
            .unwrap_or_else(|e| panic!("{}: {e}", m.label));
        let storage = bindings.iter().filter(|b| !b.uniform).count();
        println!("{:<14} {storage} storage buffers", m.label);
        assert!(storage <= 16, "{}: {storage} storage buffers", m.label);
    }
}
