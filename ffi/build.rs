//! Compiles the C++17 shim against OpenVDB and generates its Rust bindings.
//!
//! Debian's `libopenvdb-dev` ships no pkg-config file, so the link line is spelled out:
//! `-lopenvdb -ltbb -lImath-3_1` (measured: blosc, zlib and boost_iostreams are not needed at
//! link time). `OPENVDB_DIR` points at another installation (`include/` and `lib/` below it);
//! `OPENVDB_LIBS` replaces the library list (comma-separated) for other distributions.
//!
//! The Embree shim (`shim/brume_embree.cpp`, Debian's `libembree-dev`, Embree 3) is a separate
//! static library, so editing one shim does not recompile the other; `EMBREE_DIR` points at
//! another Embree 3 installation.
use std::env;
use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=shim/brume_vdb.h");
    println!("cargo:rerun-if-changed=shim/brume_vdb.cpp");
    println!("cargo:rerun-if-changed=shim/brume_vdb_vec3.cpp");
    println!("cargo:rerun-if-changed=shim/brume_vdb_internal.h");
    println!("cargo:rerun-if-env-changed=OPENVDB_DIR");
    println!("cargo:rerun-if-env-changed=OPENVDB_LIBS");

    let openvdb_dir = env::var_os("OPENVDB_DIR").map(PathBuf::from);
    // OpenVDB's templates at -O0 compile slowly and run far slower still: always optimise.
    shim(
        &["shim/brume_vdb.cpp", "shim/brume_vdb_vec3.cpp"],
        openvdb_dir.as_ref(),
    )
    .compile("brume_vdb_shim");

    let libs = env::var("OPENVDB_LIBS").unwrap_or_else(|_| "openvdb,tbb,Imath-3_1".to_string());
    for lib in libs.split(',').map(str::trim).filter(|l| !l.is_empty()) {
        println!("cargo:rustc-link-lib={lib}");
    }

    build_embree_shim();

    let bindings = bindgen::Builder::default()
        .header("shim/brume_vdb.h")
        .allowlist_function("brume_vdb_.*")
        .allowlist_type("BrumeVdb.*")
        .allowlist_var("BRUME_VDB_.*")
        .default_enum_style(bindgen::EnumVariation::Consts)
        .prepend_enum_name(false)
        .layout_tests(true)
        .generate()
        .expect("bindgen could not parse shim/brume_vdb.h (is libclang-dev installed?)");
    let out = PathBuf::from(env::var("OUT_DIR").unwrap()).join("bindings.rs");
    bindings
        .write_to_file(out)
        .expect("cannot write bindings.rs");
}

/// The Embree shim, its link line (`-lembree3`) and its bindings (`embree_bindings.rs`).
fn build_embree_shim() {
    println!("cargo:rerun-if-changed=shim/brume_embree.h");
    println!("cargo:rerun-if-changed=shim/brume_embree.cpp");
    println!("cargo:rerun-if-env-changed=EMBREE_DIR");
    let embree_dir = env::var_os("EMBREE_DIR").map(PathBuf::from);
    shim(&["shim/brume_embree.cpp"], embree_dir.as_ref()).compile("brume_embree_shim");
    println!("cargo:rustc-link-lib=embree3");

    let bindings = bindgen::Builder::default()
        .header("shim/brume_embree.h")
        .allowlist_function("brume_embree_.*")
        .allowlist_type("BrumeEmbree.*")
        .allowlist_var("BRUME_EMBREE_.*")
        .default_enum_style(bindgen::EnumVariation::Consts)
        .prepend_enum_name(false)
        .layout_tests(true)
        .generate()
        .expect("bindgen could not parse shim/brume_embree.h (is libclang-dev installed?)");
    let out = PathBuf::from(env::var("OUT_DIR").unwrap()).join("embree_bindings.rs");
    bindings
        .write_to_file(out)
        .expect("cannot write embree_bindings.rs");
}

/// A C++17 build of the shim `files`, optimised, with the library's headers and link path
/// under `dir` where one is given (`OPENVDB_DIR`, `EMBREE_DIR`).
fn shim(files: &[&str], dir: Option<&PathBuf>) -> cc::Build {
    let mut build = cc::Build::new();
    build
        .cpp(true)
        .files(files)
        .include("shim")
        .flag("-std=c++17")
        .flag_if_supported("-Wall")
        .flag_if_supported("-Wextra")
        .opt_level(2)
        .warnings(true);
    if let Some(dir) = dir {
        build.include(dir.join("include"));
        println!(
            "cargo:rustc-link-search=native={}",
            dir.join("lib").display()
        );
    }
    build
}
