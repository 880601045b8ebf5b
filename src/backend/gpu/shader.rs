//! WGSL module assembly.
//!
//! WGSL has no `#include`, so a module is the concatenation of named files from `shaders/`,
//! embedded at compile time with `include_str!` (the binary does not need the source tree),
//! after two generated preambles:
//!
//! 1. specialisation lines, `const NAME: T = value;`, chosen by the caller ([`Spec`]) with
//!    defaults per module;
//! 2. the shared enumerations of [`crate::gpu_types`] (`ESTIMATOR_*`, `CONTROL_*`, ...), so
//!    their values are written once, in Rust.
//!
//! Every file is preceded by a `// ---- file: NAME ----` marker so that naga's error locations
//! can be traced back. [`MODULES`] lists every module Brume builds; `tests/gpu/wgsl.rs`
//! validates each with naga.
use crate::gpu_types::{
    GpuControlMode, GpuEstimator, GpuMajorantMode, GpuPhaseKind, GpuQueue, GpuWideCounter,
    PATH_FLAG_FLIGHT_STARTED, PATH_FLAG_SPECULAR, PATH_FLAG_SURFACE, SURFACE_DIELECTRIC,
    SURFACE_NULL, SURFACE_OPAQUE,
};
use std::fmt::Write;

/// One WGSL source file, by its path under `shaders/`.
#[derive(Clone, Copy, Debug)]
pub struct ShaderFile {
    pub name: &'static str,
    pub source: &'static str,
}

macro_rules! shader_file {
    ($path:literal) => {
        ShaderFile {
            name: $path,
            source: include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/shaders/", $path)),
        }
    };
}

/// The shared WGSL files (`shaders/common/`) and kernels.
pub mod files {
    use super::ShaderFile;
    /// Mirrors of `gpu_types` structs.
    pub const TYPES: ShaderFile = shader_file!("common/types.wgsl");
    /// Accurate `ln` (f32::ln).
    pub const MATH: ShaderFile = shader_file!("common/math.wgsl");
    /// `sampling::Rng`.
    pub const RNG: ShaderFile = shader_file!("common/rng.wgsl");
    /// `sampling::sobol`: Owen-scrambled padded 2D Sobol points.
    pub const SOBOL: ShaderFile = shader_file!("common/sobol.wgsl");
    /// `SparseGrid` lookups.
    pub const GRID: ShaderFile = shader_file!("common/grid.wgsl");
    /// `DdaMajorantIterator`.
    pub const DDA: ShaderFile = shader_file!("common/dda.wgsl");
    /// `HenyeyGreenstein`.
    pub const PHASE: ShaderFile = shader_file!("common/phase.wgsl");
    /// `sample_free_flight` and the estimators.
    pub const TRACKING: ShaderFile = shader_file!("common/tracking.wgsl");
    /// The tracking kernel, transmittance or distance sampling: one (ray, sample) per
    /// invocation.
    pub const TRACKING_KERNEL: ShaderFile = shader_file!("kernels/tracking.wgsl");
    /// Wavefront bindings, queues and counters.
    pub const WAVEFRONT: ShaderFile = shader_file!("common/wavefront.wgsl");
    /// `Emission::radiance`, `blackbody_emission` and the media's `on_collision`.
    pub const EMISSION: ShaderFile = shader_file!("common/emission.wgsl");
    /// `Principled`, `fresnel_dielectric`, `refract`, `Frame`, `cosine_hemisphere`.
    pub const BSDF: ShaderFile = shader_file!("common/bsdf.wgsl");
    /// The CWBVH closest-hit query, `intersect_triangle`, `shading_normal`, `emitted`.
    pub const SURFACES: ShaderFile = shader_file!("common/surfaces.wgsl");
    /// The placements of the two-level BVH: scene-wide slots and transforms.
    pub const PLACEMENTS: ShaderFile = shader_file!("common/placements.wgsl");
    /// `TextureRef::sample`, `Scene::uv_at`, `base_color_at`, `emission_at`.
    pub const TEXTURES: ShaderFile = shader_file!("common/textures.wgsl");
    /// `sample_homogeneous`, `transmittance_homogeneous`, `stack_cross`.
    pub const MEDIA: ShaderFile = shader_file!("common/media.wgsl");
    /// `integrator::mixture` and `volume::merge`: several VDB media, overlapping or inside a
    /// homogeneous one (the mixture variant).
    pub const MIXTURE: ShaderFile = shader_file!("common/mixture.wgsl");
    /// `Advection::source` and `NodeMotion::world_from_node`: motion blur.
    pub const ADVECTION: ShaderFile = shader_file!("common/advection.wgsl");
    /// `EnvironmentMap`: Blender's equirectangular lookup and the map's importance sampling.
    pub const ENVMAP: ShaderFile = shader_file!("common/envmap.wgsl");
    /// `Lights::sample` for punctual lights, the environment and area lights, `power_heuristic`.
    pub const LIGHTS: ShaderFile = shader_file!("common/lights.wgsl");
    /// Shadow rays' transmittance through media and null interfaces.
    pub const SHADOW: ShaderFile = shader_file!("common/shadow.wgsl");
    /// Equiangular sampling towards point and spot lights, weighed against free flight.
    pub const EQUIANGULAR: ShaderFile = shader_file!("common/equiangular.wgsl");
    /// Pixel jitter towards lamps inside media (`integrator::glow`).
    pub const GLOW: ShaderFile = shader_file!("common/glow.wgsl");
    /// Emitting media sampled as lights, and the flights' MIS weight against them.
    pub const MEDIA_LIGHTS: ShaderFile = shader_file!("common/media_lights.wgsl");
    /// Queue bookkeeping between stages: counter resets and indirect dispatch arguments.
    pub const QUEUES: ShaderFile = shader_file!("kernels/queues.wgsl");
    /// The wavefront stages, one file each (see `backend::gpu::render::Stage`).
    pub const STAGE_GENERATE: ShaderFile = shader_file!("stages/generate.wgsl");
    pub const STAGE_INTERSECT: ShaderFile = shader_file!("stages/intersect.wgsl");
    pub const STAGE_SHADE_SURFACE: ShaderFile = shader_file!("stages/shade_surface.wgsl");
    pub const STAGE_EQUIANGULAR: ShaderFile = shader_file!("stages/equiangular.wgsl");
    pub const STAGE_SAMPLE_MEDIUM: ShaderFile = shader_file!("stages/sample_medium.wgsl");
    pub const STAGE_SCATTER_MEDIUM: ShaderFile = shader_file!("stages/scatter_medium.wgsl");
    pub const STAGE_TRACE_SHADOW: ShaderFile = shader_file!("stages/trace_shadow.wgsl");
    pub const STAGE_EMITTERS: ShaderFile = shader_file!("stages/emitters.wgsl");
    pub const STAGE_SAMPLE_PHASE: ShaderFile = shader_file!("stages/sample_phase.wgsl");
    pub const STAGE_ESCAPE: ShaderFile = shader_file!("stages/escape.wgsl");
    pub const STAGE_ACCUMULATE: ShaderFile = shader_file!("stages/accumulate.wgsl");
    /// Test kernels comparing the mirrors with the CPU.
    pub const TEST_RNG: ShaderFile = shader_file!("tests/rng.wgsl");
    pub const TEST_SOBOL: ShaderFile = shader_file!("tests/sobol.wgsl");
    pub const TEST_GRID: ShaderFile = shader_file!("tests/grid.wgsl");
    pub const TEST_DDA: ShaderFile = shader_file!("tests/dda.wgsl");
    pub const TEST_PHASE: ShaderFile = shader_file!("tests/phase.wgsl");
    pub const TEST_MATH: ShaderFile = shader_file!("tests/math.wgsl");
}

/// A specialisation constant's value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SpecValue {
    U32(u32),
    F32(f32),
    Bool(bool),
}

/// One `const NAME: T = value;` line prepended to a module.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spec {
    pub name: &'static str,
    pub value: SpecValue,
}

impl Spec {
    pub const fn u32(name: &'static str, v: u32) -> Spec {
        Spec {
            name,
            value: SpecValue::U32(v),
        }
    }
    pub const fn f32(name: &'static str, v: f32) -> Spec {
        Spec {
            name,
            value: SpecValue::F32(v),
        }
    }
    pub const fn bool(name: &'static str, v: bool) -> Spec {
        Spec {
            name,
            value: SpecValue::Bool(v),
        }
    }

    /// The WGSL line. Panics on a non-finite `f32`, which WGSL cannot spell.
    pub fn wgsl(&self) -> String {
        match self.value {
            SpecValue::U32(v) => format!("const {}: u32 = {v}u;", self.name),
            // `{:?}` prints the shortest string that round-trips (e.g. `0.1`, `1e-5`).
            SpecValue::F32(v) => {
                assert!(v.is_finite(), "WGSL has no literal for {v} ({})", self.name);
                format!("const {}: f32 = {v:?}f;", self.name)
            }
            SpecValue::Bool(v) => format!("const {}: bool = {v};", self.name),
        }
    }
}

/// A compute module: its files in order, its entry point and default specialisations.
#[derive(Clone, Copy, Debug)]
pub struct Module {
    pub label: &'static str,
    pub files: &'static [ShaderFile],
    pub entry_point: &'static str,
    pub default_specs: &'static [Spec],
    pub dispatch: Dispatch,
}

/// How a module's invocations find their work. Every kind but `Own` has its entry point
/// generated by [`Module::source`]: the dispatch is written once, not in every file.
#[derive(Clone, Copy, Debug)]
pub enum Dispatch {
    /// The files write the entry point themselves.
    Own,
    /// A wavefront stage: the files define `fn LABEL(slot: u32)`, run on every path slot of
    /// this input queue (a WGSL expression).
    Queue(&'static str),
    /// A test kernel: the files define `fn LABEL(i: u32)`, run for every `i` below
    /// `LABEL_count()`, which they define too.
    Items,
}

impl Module {
    /// A test kernel with no specialisation constants of its own, run on each of its items
    /// ([`Dispatch::Items`]).
    pub const fn per_item(
        label: &'static str,
        files: &'static [ShaderFile],
        entry_point: &'static str,
    ) -> Module {
        Module {
            label,
            files,
            entry_point,
            default_specs: &[],
            dispatch: Dispatch::Items,
        }
    }
}

/// The shared enumerations as WGSL constants, generated from `gpu_types`.
pub fn shared_constants() -> String {
    let mut s = String::from("// ---- generated from src/gpu_types/ ----\n");
    for enumeration in [
        GpuEstimator::wgsl_constants(),
        GpuMajorantMode::wgsl_constants(),
        GpuControlMode::wgsl_constants(),
        GpuQueue::wgsl_constants(),
        GpuWideCounter::wgsl_constants(),
        GpuPhaseKind::wgsl_constants(),
    ] {
        s.push_str(&enumeration);
    }
    use crate::scene::lights::{LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT};
    for (name, v) in [
        ("QUEUE_COUNT", GpuQueue::COUNT as u32),
        ("LIGHT_POINT", LIGHT_POINT),
        ("LIGHT_SPOT", LIGHT_SPOT),
        ("LIGHT_DIRECTIONAL", LIGHT_DIRECTIONAL),
        ("PATH_FLAG_SPECULAR", PATH_FLAG_SPECULAR),
        ("PATH_FLAG_SURFACE", PATH_FLAG_SURFACE),
        ("PATH_FLAG_FLIGHT_STARTED", PATH_FLAG_FLIGHT_STARTED),
        ("PATH_FLAG_ESCAPED", crate::gpu_types::PATH_FLAG_ESCAPED),
        (
            "PATH_FLAG_FIRST_IN_MEDIUM",
            crate::gpu_types::PATH_FLAG_FIRST_IN_MEDIUM,
        ),
        (
            "PATH_FLAG_ALBEDO_SEEN",
            crate::gpu_types::PATH_FLAG_ALBEDO_SEEN,
        ),
        (
            "PATH_FLAG_DEPTH_SEEN",
            crate::gpu_types::PATH_FLAG_DEPTH_SEEN,
        ),
        ("PATH_FLAG_SEGMENT", crate::gpu_types::PATH_FLAG_SEGMENT),
        (
            "VOLUME_SAMPLING_DISTANCE",
            crate::gpu_types::VOLUME_SAMPLING_DISTANCE,
        ),
        (
            "VOLUME_SAMPLING_EQUIANGULAR",
            crate::gpu_types::VOLUME_SAMPLING_EQUIANGULAR,
        ),
        ("VOLUME_SAMPLING_MIS", crate::gpu_types::VOLUME_SAMPLING_MIS),
        ("LIGHT_PASSES", crate::gpu_types::GPU_LIGHT_PASSES),
        ("PASS_EMISSION", crate::gpu_types::PASS_EMISSION),
        ("PASS_BACKGROUND", crate::gpu_types::PASS_BACKGROUND),
        ("PASS_VOLUME_DIRECT", crate::gpu_types::PASS_VOLUME_DIRECT),
        ("PASS_SURFACE_DIRECT", crate::gpu_types::PASS_SURFACE_DIRECT),
        (
            "WF_FLAG_FILM_TRANSPARENT",
            crate::gpu_types::WF_FLAG_FILM_TRANSPARENT,
        ),
        ("SURFACE_OPAQUE", SURFACE_OPAQUE),
        ("SURFACE_DIELECTRIC", SURFACE_DIELECTRIC),
        ("SURFACE_NULL", SURFACE_NULL),
        ("PLACEMENT_MIRRORED", crate::gpu_types::PLACEMENT_MIRRORED),
        ("PLACEMENT_EMPTY", crate::gpu_types::PLACEMENT_EMPTY),
        ("NO_INDEX", crate::scene::NO_INDEX),
        ("WF_FLAG_ABSORPTION", crate::gpu_types::WF_FLAG_ABSORPTION),
        (
            "WF_FLAG_FORCE_SPECTRAL",
            crate::gpu_types::WF_FLAG_FORCE_SPECTRAL,
        ),
        (
            "WF_FLAG_GUIDED_LIGHTS",
            crate::gpu_types::WF_FLAG_GUIDED_LIGHTS,
        ),
        (
            "PATH_FLAG_ENV_BY_PHASE",
            crate::gpu_types::PATH_FLAG_ENV_BY_PHASE,
        ),
        (
            "GUIDED_MAX_PUNCTUAL",
            crate::render::lights::GUIDED_MAX_PUNCTUAL as u32,
        ),
        ("MAX_MIX", crate::gpu_types::GPU_MAX_VDB_MEDIA as u32),
        (
            "GPU_CAMERA_POSES",
            crate::gpu_types::GPU_CAMERA_POSES as u32,
        ),
        ("DIM_TIME", crate::sampling::sobol::DIM_TIME),
        ("TEXTURE_WRAP_REPEAT", crate::scene::texture::WRAP_REPEAT),
        ("TEXTURE_WRAP_CLAMP", crate::scene::texture::WRAP_CLAMP),
        ("TEXTURE_WRAP_MIRROR", crate::scene::texture::WRAP_MIRROR),
        (
            "MATERIAL_DOUBLE_SIDED",
            crate::scene::material::MATERIAL_DOUBLE_SIDED,
        ),
        (
            "EQUIANGULAR_CANDIDATES",
            crate::integrator::equiangular::CANDIDATES as u32,
        ),
        (
            "SHADOW_WALKS",
            crate::integrator::equiangular::SHADOW_WALKS as u32,
        ),
        ("EARLY_RR_DEPTH", crate::integrator::path::EARLY_RR_DEPTH),
    ] {
        writeln!(s, "const {name}: u32 = {v}u;").unwrap();
    }
    writeln!(
        s,
        "const BLACKBODY_TABLE_LEN: u32 = {}u;",
        crate::render::blackbody::TABLE_LEN
    )
    .unwrap();
    s.push_str(&shared_f32_constants());
    s
}

/// The `f32` constants the WGSL shares with Rust, as WGSL declarations.
fn shared_f32_constants() -> String {
    use crate::integrator::glow;
    use crate::render::blackbody;
    let mut s = String::new();
    for (name, v) in [
        (
            "GUIDED_UNIFORM_SHARE",
            crate::render::lights::GUIDED_UNIFORM_SHARE,
        ),
        ("BLACKBODY_T_MIN", blackbody::T_MIN),
        ("BLACKBODY_T_MAX", blackbody::T_MAX),
        ("BLACKBODY_STEP", blackbody::TABLE_STEP),
        ("STEFAN_BOLTZMANN_SCALE", blackbody::STEFAN_BOLTZMANN_SCALE),
        (
            "BACKGROUND_DEPTH",
            crate::integrator::path::BACKGROUND_DEPTH,
        ),
        ("GLOW_RADIUS", glow::GLOW_RADIUS),
        ("GLOW_SHARE", glow::GLOW_SHARE),
        ("CONE_SHARE", glow::CONE_SHARE),
        ("CONE_ANGLE", glow::CONE_ANGLE),
        ("COS_CONE_ANGLE", glow::COS_CONE_ANGLE),
        ("LIT_SHARE", crate::integrator::lit_media::LIT_SHARE),
        ("NEAR_LIGHT", crate::integrator::equiangular::NEAR_LIGHT),
    ] {
        writeln!(s, "const {name}: f32 = {v:?}f;").unwrap();
    }
    s
}

/// Concatenates `files` after the specialisation lines and the shared constants.
pub fn assemble(files: &[ShaderFile], specs: &[Spec]) -> String {
    let mut s = String::from("// ---- specialisation ----\n");
    for spec in specs {
        s.push_str(&spec.wgsl());
        s.push('\n');
    }
    s.push_str(&shared_constants());
    for f in files {
        writeln!(s, "// ---- file: {} ----", f.name).unwrap();
        s.push_str(&select_blocks(f, specs));
        s.push('\n');
    }
    s
}

/// Keeps or blanks the blocks between `// #if NAME` (or `// #if !NAME`) and `// #endif`
/// lines by the boolean specialisation `NAME`, so that a variant without a feature contains
/// no code for it at all. (A `const` condition would leave the code in the module as a dead
/// branch, and Mesa's lavapipe crashes running a stage whose dead branch holds the whole VDB
/// free flight.) Blanked lines stay as empty lines so naga's line numbers still match the
/// file. Blocks nest; a directive naming no boolean spec of the module keeps its block.
fn select_blocks(f: &ShaderFile, specs: &[Spec]) -> String {
    let mut out = String::with_capacity(f.source.len());
    let mut active = vec![true];
    for line in f.source.lines() {
        let t = line.trim();
        if let Some(cond) = t.strip_prefix("// #if ") {
            let (negate, name) = match cond.trim().strip_prefix('!') {
                Some(n) => (true, n.trim()),
                None => (false, cond.trim()),
            };
            let value = specs
                .iter()
                .find(|s| s.name == name)
                .map_or(true, |s| match s.value {
                    SpecValue::Bool(b) => b != negate,
                    _ => true,
                });
            let parent = *active.last().unwrap_or(&true);
            active.push(parent && value);
            out.push('\n');
            continue;
        }
        if t == "// #endif" {
            if active.len() > 1 {
                active.pop();
            }
            out.push('\n');
            continue;
        }
        if *active.last().unwrap_or(&true) {
            out.push_str(line);
        }
        out.push('\n');
    }
    out
}

/// Uniform blocks one kernel may read from one bind group. Mesa 22.3's lavapipe (Debian 12's
/// Vulkan on the CPU) wrote past the pipeline object it allocates, into the free heap, when it
/// created the generic `sample_medium` kernel with three uniform blocks in group 0; a later
/// `free` then failed glibc's heap checks (`tools/lavapipe_ubo/` reproduces it). With two per
/// group it is clean; tables go in read-only storage.
pub const MAX_UNIFORM_BLOCKS_PER_GROUP: usize = 2;

/// One resource an entry point uses, from naga's analysis (the one wgpu derives the
/// pipeline layout from).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Binding {
    pub group: u32,
    pub binding: u32,
    /// A uniform block (`var<uniform>`); otherwise a storage buffer.
    pub uniform: bool,
}

impl Module {
    /// The module's source with `specs` overriding the defaults of the same name (a spec the
    /// module does not declare is an error: it would be silently ignored otherwise).
    pub fn source(&self, specs: &[Spec]) -> String {
        for s in specs {
            assert!(
                self.default_specs.iter().any(|d| d.name == s.name),
                "module {} has no specialisation constant {}",
                self.label,
                s.name
            );
        }
        let merged: Vec<Spec> = self
            .default_specs
            .iter()
            .map(|d| *specs.iter().find(|s| s.name == d.name).unwrap_or(d))
            .collect();
        let mut source = assemble(self.files, &merged);
        let (what, item, guard) = match self.dispatch {
            Dispatch::Own => return source,
            Dispatch::Queue(queue) => (
                "the stage's dispatch over its queue",
                "slot",
                format!("var slot = 0u;\n    if (queue_item({queue}, id.x, &slot)) {{"),
            ),
            Dispatch::Items => (
                "one invocation per item",
                "id.x",
                format!("if (id.x < {}_count()) {{", self.label),
            ),
        };
        writeln!(
            source,
            "// ---- generated: {what} ----\n\
             @compute @workgroup_size(64)\n\
             fn {entry}(@builtin(global_invocation_id) id: vec3<u32>) {{\n\
             \x20   {guard}\n\
             \x20       {label}({item});\n\
             \x20   }}\n\
             }}",
            entry = self.entry_point,
            label = self.label,
        )
        .unwrap();
        source
    }

    /// The resources the entry point uses with `specs`, checked against what every driver
    /// Brume runs on takes: at most [`MAX_UNIFORM_BLOCKS_PER_GROUP`] uniform blocks a group.
    pub fn bindings(&self, specs: &[Spec]) -> Result<Vec<Binding>, String> {
        self.checked_source(specs).map(|(_, bindings)| bindings)
    }

    /// The module's source with `specs` and its [`Module::bindings`], from one assembly and
    /// one parse: what a pipeline is created from.
    pub fn checked_source(&self, specs: &[Spec]) -> Result<(String, Vec<Binding>), String> {
        let source = self.source(specs);
        let m = naga::front::wgsl::parse_str(&source).map_err(|e| e.emit_to_string(&source))?;
        let info = naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::default(),
        )
        .validate(&m)
        .map_err(|e| e.emit_to_string(&source))?;
        let ep = m
            .entry_points
            .iter()
            .position(|e| e.name == self.entry_point)
            .ok_or_else(|| format!("no entry point {}", self.entry_point))?;
        let used = info.get_entry_point(ep);
        let bindings: Vec<Binding> = m
            .global_variables
            .iter()
            .filter(|(h, _)| !used[*h].is_empty())
            .filter_map(|(_, v)| {
                v.binding.as_ref().map(|b| Binding {
                    group: b.group,
                    binding: b.binding,
                    uniform: v.space == naga::AddressSpace::Uniform,
                })
            })
            .collect();
        for group in 0..=bindings.iter().map(|b| b.group).max().unwrap_or(0) {
            let uniforms = bindings
                .iter()
                .filter(|b| b.uniform && b.group == group)
                .count();
            if uniforms > MAX_UNIFORM_BLOCKS_PER_GROUP {
                return Err(format!(
                    "{} reads {uniforms} uniform blocks from bind group {group}, more than the \
                     {MAX_UNIFORM_BLOCKS_PER_GROUP} a kernel may (MAX_UNIFORM_BLOCKS_PER_GROUP)",
                    self.label
                ));
            }
        }
        Ok((source, bindings))
    }
}

use files::*;

/// The tracking kernel's files: one grid, the estimators, the kernel.
const TRACKING_KERNEL_FILES: &[ShaderFile] =
    &[TYPES, MATH, RNG, GRID, DDA, TRACKING, TRACKING_KERNEL];

/// Per-estimator transmittance over a SparseGrid along index-space rays.
pub const TRANSMITTANCE_MODULE: Module = Module {
    label: "transmittance",
    files: TRACKING_KERNEL_FILES,
    entry_point: "tracking_main",
    // One grid: the mixture hooks of `tracking.wgsl` are cut.
    default_specs: &[
        Spec::bool("FEATURE_MIXTURE", false),
        Spec::bool("FEATURE_MOTION", false),
        Spec::bool("KERNEL_DISTANCE", false),
    ],
    dispatch: Dispatch::Own,
};

/// Per-estimator distance sampling over a SparseGrid along index-space rays.
/// The same kernel as [`TRANSMITTANCE_MODULE`] with `KERNEL_DISTANCE` on.
pub const DISTANCE_MODULE: Module = Module {
    label: "distance",
    default_specs: &[
        Spec::bool("FEATURE_MIXTURE", false),
        Spec::bool("FEATURE_MOTION", false),
        Spec::bool("KERNEL_DISTANCE", true),
    ],
    ..TRANSMITTANCE_MODULE
};

/// RNG streams (test).
pub const TEST_RNG_MODULE: Module = Module {
    label: "test_rng",
    files: &[TYPES, RNG, TEST_RNG],
    entry_point: "rng_streams",
    default_specs: &[Spec::u32("DRAWS", 16)],
    dispatch: Dispatch::Items,
};

/// Scrambled Sobol points (test).
pub const TEST_SOBOL_MODULE: Module = Module::per_item(
    "test_sobol",
    &[TYPES, RNG, SOBOL, TEST_SOBOL],
    "sobol_points",
);

/// Grid lookups at given index points (test).
pub const TEST_GRID_MODULE: Module =
    Module::per_item("test_grid", &[TYPES, GRID, TEST_GRID], "grid_lookups");

/// Majorant DDA segments of given rays (test).
pub const TEST_DDA_MODULE: Module = Module {
    label: "test_dda",
    files: &[TYPES, GRID, DDA, TEST_DDA],
    entry_point: "dda_segments",
    default_specs: &[
        Spec::u32("MAX_SEGMENTS", 64),
        Spec::u32("DDA_MODE", 0),
        Spec::f32("DDA_SCALE", 1.0),
    ],
    dispatch: Dispatch::Items,
};

/// Phase-function sampling and evaluation, every kind (test).
pub const TEST_PHASE_MODULE: Module = Module {
    label: "test_phase",
    files: &[TYPES, RNG, PHASE, TEST_PHASE],
    entry_point: "phase_samples",
    default_specs: &[Spec::bool("FEATURE_PHASES", true)],
    dispatch: Dispatch::Items,
};

/// WGSL's `log` and `ln_f32` against `f32::ln` (test).
pub const TEST_MATH_MODULE: Module =
    Module::per_item("test_math", &[TYPES, MATH, TEST_MATH], "logs");

/// The specialisation constants of the wavefront modules (from the scene's `FeatureFlags`).
pub const WAVEFRONT_SPECS: &[Spec] = &[
    Spec::bool("FEATURE_SURFACES", true),
    Spec::bool("FEATURE_HOMOGENEOUS", true),
    Spec::bool("FEATURE_HETEROGENEOUS", true),
    Spec::bool("FEATURE_CHROMATIC", true),
    Spec::bool("FEATURE_EMISSION", true),
    Spec::bool("FEATURE_TEXTURES", true),
    Spec::bool("FEATURE_ENV_MAP", true),
    // Several VDB media (overlapping, or inside a homogeneous one): `mixture.wgsl`.
    Spec::bool("FEATURE_MIXTURE", true),
    // Samples at times across a shutter: velocity blur and camera motion (`advection.wgsl`).
    Spec::bool("FEATURE_MOTION", true),
    // Phase functions other than Henyey-Greenstein (`phase.wgsl`'s `phase_p`, `phase_sample`).
    Spec::bool("FEATURE_PHASES", true),
    // Flights' equiangular estimate towards point and spot lights (`equiangular.wgsl`).
    Spec::bool("FEATURE_EQUIANGULAR", true),
    // The radiance split into the light passes as well (`PathLimits::light_passes`).
    Spec::bool("FEATURE_LIGHT_PASSES", true),
    // The data passes a denoiser takes as well (`PathLimits::data_passes`).
    Spec::bool("FEATURE_DATA_PASSES", true),
    // The radiance split into the light groups as well (`PathLimits::light_groups`), and how
    // many the scene has (`LightGroups::len`; 0 without them).
    Spec::bool("FEATURE_LIGHT_GROUPS", true),
    Spec::u32(
        "LIGHT_GROUPS",
        crate::render::light_groups::MAX_LIGHT_GROUPS as u32,
    ),
    // The path's fixed-layout decisions from Sobol points (else from its PCG stream).
    Spec::bool("SAMPLER_SOBOL", true),
];

macro_rules! wavefront_module {
    ($name:ident, $file:expr, $label:literal, $entry:expr, $dispatch:expr) => {
        pub const $name: Module = Module {
            label: $label,
            files: &[
                TYPES,
                MATH,
                RNG,
                SOBOL,
                GRID,
                DDA,
                PHASE,
                ADVECTION,
                TRACKING,
                EMISSION,
                WAVEFRONT,
                GLOW,
                BSDF,
                PLACEMENTS,
                TEXTURES,
                SURFACES,
                MEDIA,
                MIXTURE,
                ENVMAP,
                LIGHTS,
                SHADOW,
                EQUIANGULAR,
                MEDIA_LIGHTS,
                $file,
            ],
            entry_point: $entry,
            default_specs: WAVEFRONT_SPECS,
            dispatch: $dispatch,
        };
    };
    // A stage: `fn LABEL(slot: u32)` in its file, run on every slot of `$queue`.
    ($name:ident, $file:expr, $label:literal, queue $queue:literal) => {
        wavefront_module!(
            $name,
            $file,
            $label,
            concat!($label, "_main"),
            Dispatch::Queue($queue)
        );
    };
}
// Each stage over its input queue, as `graph::Stage::input_queue` has it.
wavefront_module!(STAGE_GENERATE_MODULE, STAGE_GENERATE, "generate", queue "queue_done_in()");
wavefront_module!(STAGE_INTERSECT_MODULE, STAGE_INTERSECT, "intersect", queue "queue_medium_in()");
wavefront_module!(STAGE_SHADE_SURFACE_MODULE, STAGE_SHADE_SURFACE, "shade_surface", queue "QUEUE_SURFACE");
wavefront_module!(STAGE_EQUIANGULAR_MODULE, STAGE_EQUIANGULAR, "equiangular", queue "queue_medium_in()");
wavefront_module!(STAGE_SAMPLE_MEDIUM_MODULE, STAGE_SAMPLE_MEDIUM, "sample_medium", queue "queue_medium_in()");
wavefront_module!(STAGE_SCATTER_MEDIUM_MODULE, STAGE_SCATTER_MEDIUM, "scatter_medium", queue "QUEUE_SCATTER");
wavefront_module!(STAGE_TRACE_SHADOW_MODULE, STAGE_TRACE_SHADOW, "trace_shadow", queue "QUEUE_SHADOW");
wavefront_module!(STAGE_EMITTERS_MODULE, STAGE_EMITTERS, "emitters", queue "QUEUE_PHASE");
wavefront_module!(STAGE_SAMPLE_PHASE_MODULE, STAGE_SAMPLE_PHASE, "sample_phase", queue "QUEUE_PHASE");
wavefront_module!(STAGE_ESCAPE_MODULE, STAGE_ESCAPE, "escape", queue "QUEUE_ESCAPE");
wavefront_module!(STAGE_ACCUMULATE_MODULE, STAGE_ACCUMULATE, "accumulate", queue "queue_done_out()");
// Queue bookkeeping: entry points of their own.
wavefront_module!(
    QUEUE_RESET_MODULE,
    QUEUES,
    "queue_reset",
    "queue_reset",
    Dispatch::Own
);
wavefront_module!(
    QUEUE_ARGS_MODULE,
    QUEUES,
    "queue_args",
    "queue_args",
    Dispatch::Own
);

/// Every module Brume builds.
pub const MODULES: &[Module] = &[
    STAGE_GENERATE_MODULE,
    STAGE_INTERSECT_MODULE,
    STAGE_SHADE_SURFACE_MODULE,
    STAGE_EQUIANGULAR_MODULE,
    STAGE_SAMPLE_MEDIUM_MODULE,
    STAGE_SCATTER_MEDIUM_MODULE,
    STAGE_TRACE_SHADOW_MODULE,
    STAGE_EMITTERS_MODULE,
    STAGE_SAMPLE_PHASE_MODULE,
    STAGE_ESCAPE_MODULE,
    STAGE_ACCUMULATE_MODULE,
    QUEUE_RESET_MODULE,
    QUEUE_ARGS_MODULE,
    TRANSMITTANCE_MODULE,
    DISTANCE_MODULE,
    TEST_RNG_MODULE,
    TEST_SOBOL_MODULE,
    TEST_GRID_MODULE,
    TEST_DDA_MODULE,
    TEST_PHASE_MODULE,
    TEST_MATH_MODULE,
];
