//! The wavefront's stage graph and its WGSL variants: the stages named once ([`Stage`]), which
//! of them a scene's [`FeatureFlags`] need, and the specialisation constants that cut the code
//! of absent features at assembly ([`variant_name`], [`specs`]).
use super::shader::{self, Module, Spec};
use crate::gpu_types::{GpuQueue, GPU_LIGHT_PASSES};
use crate::render::{FeatureFlags, RenderSettings, SamplerKind};

/// The wavefront stages, in the order an iteration runs them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Stage {
    /// Camera rays for free slots (`tile::render_tile`, `path::generate`).
    Generate,
    /// The first surface along each ray (`path::intersect`: `TriangleBvh::closest_hit` over
    /// obvhs' CWBVH).
    Intersect,
    /// The equiangular estimate over the flight's span towards a point or spot light
    /// (`path::equiangular`), drawn before the flight.
    Equiangular,
    /// Free flight up to that surface through the homogeneous medium the path is in or the
    /// VDB medium it crosses (`path::sample_medium`, `media::sample_vdb`,
    /// `homogeneous::sample_homogeneous`), gathering volume emission.
    SampleMedium,
    /// Depth limit and next-event estimation at a medium scattering event
    /// (`path::scatter_medium`).
    ScatterMedium,
    /// Emission, null interfaces, smooth dielectrics and next-event estimation at opaque
    /// surfaces (`path::shade_surface`).
    ShadeSurface,
    /// Shadow-ray transmittance through media and null interfaces (`next_event::trace_shadow`).
    TraceShadow,
    /// Next-event estimation towards the emitting media at the events the phase stage
    /// continues (`path::emitters`, `emitters::emitter_event`), after the event's shadow ray.
    Emitters,
    /// The next direction (phase function or BSDF) and Russian roulette (`path::sample_phase`).
    SamplePhase,
    /// Environment light for rays that leave the scene (`path::escape`).
    Escape,
    /// A finished path's radiance to its camera sample's entry.
    Accumulate,
}

impl Stage {
    pub const COUNT: usize = 11;
    pub const ALL: [Stage; Stage::COUNT] = [
        Stage::Generate,
        Stage::Intersect,
        Stage::Equiangular,
        Stage::SampleMedium,
        Stage::ScatterMedium,
        Stage::ShadeSurface,
        Stage::TraceShadow,
        Stage::Emitters,
        Stage::SamplePhase,
        Stage::Escape,
        Stage::Accumulate,
    ];

    pub fn name(self) -> &'static str {
        self.module().label
    }

    /// The WGSL module (its last file is the stage's, its entry point the stage's).
    pub fn module(self) -> Module {
        match self {
            Stage::Generate => shader::STAGE_GENERATE_MODULE,
            Stage::Intersect => shader::STAGE_INTERSECT_MODULE,
            Stage::Equiangular => shader::STAGE_EQUIANGULAR_MODULE,
            Stage::SampleMedium => shader::STAGE_SAMPLE_MEDIUM_MODULE,
            Stage::ScatterMedium => shader::STAGE_SCATTER_MEDIUM_MODULE,
            Stage::ShadeSurface => shader::STAGE_SHADE_SURFACE_MODULE,
            Stage::TraceShadow => shader::STAGE_TRACE_SHADOW_MODULE,
            Stage::Emitters => shader::STAGE_EMITTERS_MODULE,
            Stage::SamplePhase => shader::STAGE_SAMPLE_PHASE_MODULE,
            Stage::Escape => shader::STAGE_ESCAPE_MODULE,
            Stage::Accumulate => shader::STAGE_ACCUMULATE_MODULE,
        }
    }

    /// The queue the stage consumes in an iteration of parity `parity`. (The intersect stage
    /// only annotates the paths of the medium queue, which the medium stage then consumes.)
    pub fn input_queue(self, parity: u32) -> GpuQueue {
        let pick = |a: GpuQueue, b: GpuQueue| if parity == 0 { a } else { b };
        match self {
            Stage::Generate => pick(GpuQueue::Done0, GpuQueue::Done1),
            Stage::Intersect | Stage::Equiangular | Stage::SampleMedium => {
                pick(GpuQueue::Medium0, GpuQueue::Medium1)
            }
            Stage::ScatterMedium => GpuQueue::Scatter,
            Stage::ShadeSurface => GpuQueue::Surface,
            Stage::TraceShadow => GpuQueue::Shadow,
            Stage::Emitters | Stage::SamplePhase => GpuQueue::Phase,
            Stage::Escape => GpuQueue::Escape,
            Stage::Accumulate => pick(GpuQueue::Done1, GpuQueue::Done0),
        }
    }

    /// Whether the indirect arguments must be recomputed before this stage: a stage since
    /// the last computation may have appended to its input queue. (The phase queue is
    /// complete when the shadow stage's arguments are computed, whatever the stage list: only
    /// the scatter and surface stages, both earlier, append to it.)
    pub(super) fn needs_args(self) -> bool {
        !matches!(self, Stage::Emitters | Stage::SamplePhase)
    }

    /// The stages a scene with `features` needs: kernels for effects the scene lacks are not
    /// dispatched (no intersection or surface shading without surfaces, no medium scattering
    /// without media, nothing between generation and escape with neither, no media lights
    /// without emitting media).
    pub fn for_features(features: FeatureFlags) -> Vec<Stage> {
        let media = features.heterogeneous || features.homogeneous;
        let surfaces = features.surfaces;
        let emission = effective(features).emission;
        Stage::ALL
            .into_iter()
            .filter(|s| match s {
                Stage::Generate | Stage::Escape | Stage::Accumulate => true,
                Stage::Intersect | Stage::ShadeSurface => surfaces,
                Stage::ScatterMedium => media,
                Stage::Emitters => emission,
                Stage::Equiangular => effective(features).equiangular,
                Stage::SampleMedium | Stage::TraceShadow | Stage::SamplePhase => media || surfaces,
            })
            .collect()
    }
}

/// The WGSL variant name of `features`: the effects the kernels are specialised for, in
/// `FeatureFlags` order (`surfaces`, `vdb`, `homogeneous`, `emission`, `spectral`, `textures`,
/// `envmap`, `mixture`, `motion`, `phases`, `equiangular`), e.g.
/// `wavefront[surfaces+vdb+emission]`. `mixture` is `overlapping` as [`gpu_features`] sets it:
/// several VDB media, overlapping or not.
pub fn variant_name(features: FeatureFlags) -> String {
    let f = effective(features);
    let on: Vec<&str> = [
        (f.surfaces, "surfaces"),
        (f.heterogeneous, "vdb"),
        (f.homogeneous, "homogeneous"),
        (f.emission, "emission"),
        (f.chromatic, "spectral"),
        (f.textures, "textures"),
        (f.env_map, "envmap"),
        (f.overlapping, "mixture"),
        (f.motion, "motion"),
        (f.phases, "phases"),
        (f.equiangular, "equiangular"),
    ]
    .into_iter()
    .filter(|(b, _)| *b)
    .map(|(_, n)| n)
    .collect();
    if on.is_empty() {
        "wavefront[empty]".into()
    } else {
        format!("wavefront[{}]", on.join("+"))
    }
}

/// The passes a render keeps beside the beauty, as the kernels are specialised for them: the
/// light passes (`FEATURE_LIGHT_PASSES`), the data passes (`FEATURE_DATA_PASSES`) and the
/// light groups (`FEATURE_LIGHT_GROUPS`, `groups` of them). Without any the kernels bind no
/// pass buffer and hold no pass code.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Passes {
    pub light: bool,
    pub data: bool,
    pub groups: u32,
}

impl Passes {
    /// The passes `settings` asks for.
    pub fn of(settings: &RenderSettings) -> Passes {
        Passes {
            light: settings.light_passes,
            data: settings.data_passes,
            groups: settings.light_groups.len() as u32,
        }
    }

    /// Whether any pass is kept.
    pub fn any(self) -> bool {
        self.light || self.data || self.groups > 0
    }

    /// RGB entries (a `vec4` each) of a path slot's or camera sample's light accumulators: the
    /// light passes where kept, then the light groups (`LIGHT_ENTRIES` in `wavefront.wgsl`).
    pub fn light_entries(self) -> u32 {
        self.light as u32 * GPU_LIGHT_PASSES + self.groups
    }
}

/// [`variant_name`] with the passes kept among the effects: `passes` for the light passes,
/// `data` for the data passes, `groups` for the light groups, e.g.
/// `wavefront[vdb+passes+data]`.
pub fn variant_name_with_passes(features: FeatureFlags, passes: Passes) -> String {
    let name = variant_name(features);
    let kept: Vec<&str> = [
        (passes.light, "passes"),
        (passes.data, "data"),
        (passes.groups > 0, "groups"),
    ]
    .into_iter()
    .filter(|(on, _)| *on)
    .map(|(_, n)| n)
    .collect();
    if kept.is_empty() {
        return name;
    }
    match name.strip_suffix(']') {
        Some("wavefront[empty") | None => format!("wavefront[{}]", kept.join("+")),
        Some(effects) => format!("{effects}+{}]", kept.join("+")),
    }
}

/// The flags the GPU variant of `rs` is built from: the scene's, with `overlapping` also set
/// for several VDB media that do not overlap (one grid binding holds them all only in the
/// mixture variant, `shaders/common/mixture.wgsl`).
pub fn gpu_features(rs: &crate::render::RenderScene) -> FeatureFlags {
    FeatureFlags {
        overlapping: rs.features.overlapping || rs.vdb.len() > 1,
        ..rs.features
    }
}

/// The flags the kernels are specialised for: `features` less what cannot apply (emission
/// and spectral tracking need a medium, the mixture a VDB medium).
fn effective(features: FeatureFlags) -> FeatureFlags {
    let media = features.heterogeneous || features.homogeneous;
    FeatureFlags {
        overlapping: features.overlapping && features.heterogeneous,
        emission: features.emission && features.heterogeneous,
        chromatic: features.chromatic && media,
        absorption: features.absorption && media,
        textures: features.textures && features.surfaces,
        phases: features.phases && media,
        equiangular: features.equiangular && media,
        ..features
    }
}

/// The specialisation constants of the variant for `features` and `sampler`, keeping the
/// `passes` asked for (without them, no pass buffer is bound and no code records a pass).
pub fn specs(features: FeatureFlags, sampler: SamplerKind, passes: Passes) -> Vec<Spec> {
    let f = effective(features);
    vec![
        Spec::bool("SAMPLER_SOBOL", sampler == SamplerKind::Sobol),
        Spec::bool("FEATURE_SURFACES", f.surfaces),
        Spec::bool("FEATURE_HOMOGENEOUS", f.homogeneous),
        Spec::bool("FEATURE_HETEROGENEOUS", f.heterogeneous),
        Spec::bool("FEATURE_CHROMATIC", f.chromatic),
        Spec::bool("FEATURE_EMISSION", f.emission),
        Spec::bool("FEATURE_TEXTURES", f.textures),
        Spec::bool("FEATURE_ENV_MAP", f.env_map),
        Spec::bool("FEATURE_MIXTURE", f.overlapping),
        Spec::bool("FEATURE_MOTION", f.motion),
        Spec::bool("FEATURE_PHASES", f.phases),
        Spec::bool("FEATURE_EQUIANGULAR", f.equiangular),
        Spec::bool("FEATURE_LIGHT_PASSES", passes.light),
        Spec::bool("FEATURE_DATA_PASSES", passes.data),
        Spec::bool("FEATURE_LIGHT_GROUPS", passes.groups > 0),
        Spec::u32("LIGHT_GROUPS", passes.groups),
    ]
}
