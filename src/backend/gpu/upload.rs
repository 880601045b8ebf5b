//! The scene as the GPU reads it: the VDB medium's grid, tracking parameters and emission,
//! and the textures, each built from the CPU's `RenderScene` exactly as the CPU integrator
//! would use it (the surfaces are `geometry`, the per-render parameters `params`).
use std::borrow::Cow;

use bytemuck::Zeroable;
use glam::Vec3;

use super::device::{bounds_layout, byte_size, GpuContext, GpuGrid};
use super::error::GpuRenderError;
use crate::gpu_types::grid::daffine_rows;
use crate::gpu_types::{
    CellBounds, GpuControlMode, GpuEmissionParams, GpuEstimator, GpuGridInfo, GpuMajorantMode,
    GpuPhase, GpuTexture, GpuTrackingParams, GpuVdbMedium, GpuVelocityBlur, GpuWavefrontParams,
    WF_FLAG_ABSORPTION, WF_FLAG_FORCE_SPECTRAL,
};
use crate::render::settings::Absorption;
use crate::render::{media::GridField, media::TrackingConfig, media::VdbMedium};
use crate::render::{Estimator, FeatureFlags, MajorantMode, RenderScene};
use crate::volume::grid::BRICK_VOXELS;
use crate::volume::SparseGrid;

pub(super) fn affine_rows(m: glam::Affine3A) -> [[f32; 4]; 3] {
    let (a, t) = (m.matrix3, m.translation);
    let row = |r: usize| [a.col(0)[r], a.col(1)[r], a.col(2)[r], t[r]];
    [row(0), row(1), row(2)]
}

/// The density grid as `m`'s walks index it: the grid itself, or, where the walk bounds cover
/// a larger cell box (a blurred medium's bounds, dilated by how far its lookups are advected,
/// `volume::motion`), the grid widened to that box with background cells, so the DDA's cells,
/// the bounds' cells and the grid's cells are one index (`SparseGrid::widen_to` changes no
/// value).
fn walked_grid(m: &VdbMedium) -> Cow<'_, SparseGrid> {
    let g = &m.density.grid.grid;
    let b = m.bounds();
    if b.cell_origin == g.cell_origin && b.dims == g.dims {
        return Cow::Borrowed(g);
    }
    let mut wide = g.clone();
    wide.widen_to(b.cell_origin, b.dims);
    Cow::Owned(wide)
}

/// The velocity grids of `m`'s blur, uploaded after its density and emission grids (none
/// without blur).
fn velocity_components(m: &VdbMedium) -> Vec<&SparseGrid> {
    m.blur
        .iter()
        .flat_map(|b| b.advection.velocity.components.iter())
        .collect()
}

/// `GpuVelocityBlur` of `m`'s blur, with the headers of its velocity components
/// ([`velocity_components`]) as placed in the grid buffers; zero (no blur) without one.
fn velocity_blur(m: &VdbMedium, components: &[GpuGridInfo]) -> GpuVelocityBlur {
    let Some(b) = &m.blur else {
        return GpuVelocityBlur::default();
    };
    let adv = &b.advection;
    GpuVelocityBlur {
        x: components[0],
        y: components[1],
        z: components[2],
        velocity_from_density: daffine_rows(adv.velocity_from_density),
        index_from_value: daffine_rows(adv.index_from_value),
        world_from_index: affine_rows(b.world_from_index),
        factor: b.factor,
        staggered: adv.velocity.staggered as u32,
        ..Default::default()
    }
}

/// Medium `m`'s optics and tracking parameters under `cfg`, as the CPU's `sample_vdb`,
/// `transmittance_vdb` and the mixture's views choose them (`grid`, `emission` and
/// `bounds_base` left for the caller; `None` when the medium's extinction bound is not
/// positive: nothing to track).
pub(super) fn medium_record(
    m: &VdbMedium,
    cfg: &TrackingConfig,
    features: FeatureFlags,
) -> Option<GpuVdbMedium> {
    let bound = m.sigma_t_bound;
    if bound.is_nan() || bound <= 0.0 {
        return None;
    }
    let spectral = features.chromatic && (!m.grey || cfg.force_spectral);
    let weight = cfg.absorption == Absorption::Weight;
    // GreyView: the grey sigma_s per unit density is the channel mean (absorption as an
    // event) or sigma_t (as a weight: the trackers see no absorption).
    let sigma_s = if weight {
        bound
    } else {
        (m.sigma_s.x + m.sigma_s.y + m.sigma_s.z) / 3.0
    };
    // GreyView: sigma_a = max(sigma_t - sigma_s, 0) per unit density when any medium absorbs.
    let albedo = if features.absorption {
        sigma_s / bound
    } else {
        1.0
    };
    let (control_mode, control_value) = GpuControlMode::from_control(cfg.control());
    let grey_estimator = grey_estimator(cfg);
    let estimator = if spectral {
        GpuEstimator::Spectral
    } else {
        grey_estimator
    };
    let residual = cfg.residual_shadow();
    let shadow = if spectral {
        GpuEstimator::Spectral
    } else if residual {
        GpuEstimator::ResidualRatio
    } else {
        GpuEstimator::Ratio
    };
    let sigma_t = m.sigma_a + m.sigma_s;
    let per_channel = |num: Vec3, den: Vec3| {
        Vec3::select(den.cmpgt(Vec3::ZERO), num / den, Vec3::ZERO).to_array()
    };
    // The RGB factor of a scattering event: GreyView::scatter_albedo, or RgbView's
    // scatter_albedo for spectral tracking (the albedo with absorption as a weight, else 1);
    // albedo_rgb splits spectral lookups as RgbView's coefficients do.
    let (scatter_albedo, albedo_rgb) = match (spectral, weight) {
        (true, true) => (per_channel(m.sigma_s, sigma_t), [1.0; 3]),
        (true, false) => ([1.0; 3], per_channel(m.sigma_s, sigma_t)),
        (false, _) if sigma_s > 0.0 => ((m.sigma_s / sigma_s).to_array(), [0.0; 3]),
        (false, _) => ([0.0; 3], [0.0; 3]),
    };
    // RgbView's tracker coefficients per unit density.
    let (rgb_sigma_a, rgb_sigma_s) = if weight {
        (Vec3::ZERO, sigma_t)
    } else {
        (m.sigma_a, m.sigma_s)
    };
    Some(GpuVdbMedium {
        lo: m.world_bounds.min.to_array(),
        hi: m.world_bounds.max.to_array(),
        phase_g: m.phase.henyey_greenstein_g().unwrap_or(0.0),
        spectral: spectral as u32,
        scatter_albedo,
        albedo_rgb,
        shadow_estimator: shadow as u32,
        tracking: GpuTrackingParams {
            estimator: estimator as u32,
            // The walk the CPU's free flights take for this medium (`WalkPlan::of`).
            majorant_mode: gpu_majorant_mode(m.walk(cfg.majorant).free) as u32,
            control_mode: control_mode as u32,
            spectral_mode: 0,
            b: cfg.b(),
            control_value,
            albedo,
            control_albedo: sigma_s / bound,
            channel_scale: (sigma_t / bound).to_array(),
            seed: 0,
            majorant_channel_scale: 1.0,
            samples_per_ray: 0,
            invocation_count: 0,
            _pad0: 0,
        },
        // GreyView with the CPU's ABS (absorption as an event in a scene that absorbs).
        grey_sigma_a: if features.absorption && !weight {
            (bound - sigma_s).max(0.0)
        } else {
            0.0
        },
        grey_sigma_s: sigma_s,
        rgb_sigma_a: rgb_sigma_a.to_array(),
        rgb_sigma_s: rgb_sigma_s.to_array(),
        sigma_s: m.sigma_s.to_array(),
        control_albedo: sigma_s / bound,
        shadow_majorant_mode: gpu_majorant_mode(m.walk(cfg.majorant).shadow) as u32,
        sigma_t_mean: (m.sigma_s + m.sigma_a).element_sum() / 3.0,
        sigma_max: m.bounds().global.max * bound,
        ..Default::default()
    })
}

/// The GPU walk of a CPU walk (`WalkPlan::of`, `WalkPlan::shadow`): an
/// adaptive hierarchy of one node or of leaf cells only is walked as the global bound or the
/// per-leaf DDA, which give its segments bit for bit.
fn gpu_majorant_mode(walk: MajorantMode) -> GpuMajorantMode {
    match walk {
        MajorantMode::Leaf => GpuMajorantMode::PerCell,
        MajorantMode::Global => GpuMajorantMode::Global,
        MajorantMode::Culled => GpuMajorantMode::Culled,
        MajorantMode::Adaptive => GpuMajorantMode::Adaptive,
    }
}

/// The grey free-flight estimator of `cfg`.
fn grey_estimator(cfg: &TrackingConfig) -> GpuEstimator {
    match cfg.estimator {
        Estimator::Delta => GpuEstimator::Delta,
        Estimator::WeightedDelta => GpuEstimator::WeightedDelta,
        Estimator::Decomposition => GpuEstimator::Decomposition,
        Estimator::WeightedDecomposition => GpuEstimator::WeightedDecomposition,
    }
}

/// The estimator ids and tracking parameters of `rs`'s (first) medium under `cfg`, as the
/// CPU's `sample_vdb` / `transmittance_vdb` choose them, and the mixture variant's shared
/// parameters.
pub(super) fn medium_params(
    rs: &RenderScene,
    cfg: &TrackingConfig,
    features: FeatureFlags,
    p: &mut GpuWavefrontParams,
) {
    p.phases = GpuPhase::table(rs.vdb.iter().map(|m| &m.phase));
    if features.overlapping {
        p.vdb_count = rs.vdb.len() as u32;
        p.flags |= (features.absorption as u32 * WF_FLAG_ABSORPTION)
            | (cfg.force_spectral as u32 * WF_FLAG_FORCE_SPECTRAL);
        p.mix_estimator = grey_estimator(cfg) as u32;
    }
    let Some(r) = rs.vdb.first().and_then(|m| medium_record(m, cfg, features)) else {
        return;
    };
    p.has_medium = 1;
    p.medium_lo = r.lo;
    p.medium_hi = r.hi;
    p.phase_g = r.phase_g;
    p.spectral = r.spectral;
    p.scatter_albedo = r.scatter_albedo;
    p.albedo_rgb = r.albedo_rgb;
    p.shadow_estimator = r.shadow_estimator;
    p.shadow_majorant_mode = r.shadow_majorant_mode;
    p.tracking = r.tracking;
    // The equiangular estimate's in-scattering and free-flight density (`equiangular.wgsl`):
    // per unit of the extinction the tracker reads, `sigma_t_bound` times the density.
    let m = &rs.vdb[0];
    let bound = m.sigma_t_bound;
    p.medium_sigma_s = (m.sigma_s / bound).to_array();
    p.medium_sigma_t = (m.sigma_s + m.sigma_a).element_sum() / 3.0 / bound;
    p.medium_sigma_max = m.bounds().global.max * bound;
}

/// The grids the emission of `m` reads, in the order [`emission_params`] expects them: the
/// emission grid, then the temperature grid (none when `features` has no emission).
fn emission_fields(m: &VdbMedium, features: FeatureFlags) -> Vec<GridField> {
    let Some(e) = m.emission.as_ref().filter(|_| features.emission) else {
        return Vec::new();
    };
    e.grid
        .iter()
        .cloned()
        .chain(e.blackbody.as_ref().map(|b| b.temperature.clone()))
        .collect()
}

/// `GpuEmissionParams` of `m`'s `Emission`, with the headers of the grids
/// [`emission_fields`] listed.
fn emission_params(
    m: &VdbMedium,
    features: FeatureFlags,
    infos: &[GpuGridInfo],
) -> GpuEmissionParams {
    let mut p = GpuEmissionParams {
        light_group: u32::from(m.light_group),
        ..Default::default()
    };
    let Some(e) = m.emission.as_ref().filter(|_| features.emission) else {
        return p;
    };
    let mut next = infos.iter();
    p.strength_color = e.strength_color.to_array();
    if let Some(r) = &e.region {
        p.region_from_world = affine_rows(r.index_from_world);
        // An empty region (no active voxel anywhere) as a finite empty box.
        let empty = r.bounds.is_empty();
        p.region_min = if empty {
            [1.0; 3]
        } else {
            r.bounds.min.to_array()
        };
        p.region_max = if empty {
            [0.0; 3]
        } else {
            r.bounds.max.to_array()
        };
        p.has_region = 1;
    }
    if e.grid.is_some() {
        p.grid = *next.next().expect("emission grid uploaded");
        p.has_grid = 1;
    }
    if let Some(b) = &e.blackbody {
        p.temperature = *next.next().expect("temperature grid uploaded");
        p.has_blackbody = 1;
        p.tint = b.tint.to_array();
        p.temperature_scale = b.scale;
        p.temperature_offset = b.offset;
        p.intensity = b.intensity;
    }
    p
}

/// What [`upload_grid`] puts on the GPU: the grid buffers, the emission uniform, the mixture's
/// media records and the single medium's velocity blur.
pub(super) struct UploadedMedia {
    pub(super) grid: Option<GpuGrid>,
    pub(super) emission: GpuEmissionParams,
    pub(super) media: Vec<GpuVdbMedium>,
    /// `GpuWavefrontParams::blur` (a scene with one VDB medium).
    pub(super) blur: GpuVelocityBlur,
}

/// The VDB medium's grid on the GPU, with the medium's own world -> index map and sigma_t per
/// unit value, its emission grids and then its velocity components following the density in
/// the same buffers, and the emission uniform and velocity blur pointing into them (`None` and
/// zero emission without a VDB medium). The mixture variant (`features.overlapping`) uploads
/// every medium ([`upload_media`]).
pub(super) fn upload_grid(
    ctx: &GpuContext,
    rs: &RenderScene,
    features: FeatureFlags,
    cfg: &TrackingConfig,
) -> Result<UploadedMedia, GpuRenderError> {
    let m = match rs.vdb.first() {
        Some(m) if features.heterogeneous => m,
        _ => {
            return Ok(UploadedMedia {
                grid: None,
                emission: GpuEmissionParams::default(),
                media: Vec::new(),
                blur: GpuVelocityBlur::default(),
            })
        }
    };
    if features.overlapping {
        let (g, media) = upload_media(ctx, rs, features, cfg)?;
        return Ok(UploadedMedia {
            grid: Some(g),
            emission: media[0].emission,
            media,
            blur: GpuVelocityBlur::default(),
        });
    }
    // `GpuGrid::upload_with` checks every buffer against the binding limit.
    let grid = walked_grid(m);
    let fields = emission_fields(m, features);
    let mut extra: Vec<&SparseGrid> = fields.iter().map(|f| &f.grid.grid).collect();
    extra.extend(velocity_components(m));
    let (mut gg, mut infos) = GpuGrid::upload_with(
        ctx,
        &grid,
        m.bounds(),
        m.walked_hierarchy(cfg.majorant),
        m.sigma_t_bound,
        &voxel_table(m),
        &extra,
    )
    .map_err(GpuRenderError::Limits)?;
    gg.info.index_from_world = affine_rows(m.density.index_from_world);
    ctx.queue
        .write_buffer(&gg.info_buffer, 0, bytemuck::bytes_of(&gg.info));
    for (info, f) in infos.iter_mut().zip(&fields) {
        info.index_from_world = affine_rows(f.index_from_world);
    }
    let emission = emission_params(m, features, &infos[..fields.len()]);
    let blur = velocity_blur(m, &infos[fields.len()..]);
    Ok(UploadedMedia {
        grid: Some(gg),
        emission,
        media: Vec::new(),
        blur,
    })
}

/// Every VDB medium of `rs` in one set of grid buffers (density grids and emission grids,
/// each medium's bounds after the previous one's) and the `GpuVdbMedium` of each, for the
/// mixture variant. The buffer set's header is the first density grid's.
fn upload_media(
    ctx: &GpuContext,
    rs: &RenderScene,
    features: FeatureFlags,
    cfg: &TrackingConfig,
) -> Result<(GpuGrid, Vec<GpuVdbMedium>), GpuRenderError> {
    let grids: Vec<Cow<SparseGrid>> = rs.vdb.iter().map(walked_grid).collect();
    let mut parts: Vec<(&SparseGrid, f32, Option<Vec<CellBounds>>)> = Vec::new();
    let mut fields_of = Vec::with_capacity(rs.vdb.len());
    for (m, g) in rs.vdb.iter().zip(&grids) {
        let adaptive = m.walked_hierarchy(cfg.majorant);
        let bounds = bounds_layout(m.bounds(), adaptive).map_err(GpuRenderError::Limits)?;
        parts.push((g.as_ref(), m.sigma_t_bound, Some(bounds)));
        let fields = emission_fields(m, features);
        fields_of.push(fields);
    }
    // The emission grids after every density grid (the first density's cells start at 0),
    // then every blurred medium's velocity components.
    for fields in &fields_of {
        for f in fields {
            parts.push((&f.grid.grid, 1.0, None));
        }
    }
    for m in &rs.vdb {
        for c in velocity_components(m) {
            parts.push((c, 1.0, None));
        }
    }
    let (mut gg, placed) = GpuGrid::upload_many(ctx, &parts).map_err(GpuRenderError::Limits)?;
    // Each medium's walks thin by its voxel bounds where the CPU's do; one binding holds
    // every such table at its grid's bricks.
    let (voxels, has_table) = mixture_voxel_table(rs);
    gg.set_voxels(ctx, &voxels)
        .map_err(GpuRenderError::Limits)?;
    let mut next_emission = rs.vdb.len();
    let mut next_velocity = rs.vdb.len() + fields_of.iter().map(Vec::len).sum::<usize>();
    let mut media = Vec::with_capacity(rs.vdb.len());
    for (k, m) in rs.vdb.iter().enumerate() {
        let fields = &fields_of[k];
        let mut infos: Vec<GpuGridInfo> = placed[next_emission..next_emission + fields.len()]
            .iter()
            .map(|p| p.0)
            .collect();
        next_emission += fields.len();
        for (info, f) in infos.iter_mut().zip(fields) {
            info.index_from_world = affine_rows(f.index_from_world);
        }
        let (mut grid, bounds_base) = placed[k];
        grid.index_from_world = affine_rows(m.density.index_from_world);
        let mut r = match medium_record(m, cfg, features) {
            Some(r) => r,
            None => {
                // Nothing to track (extinction bound not positive): zero majorants, so a
                // flight through it escapes with weight 1, as on the CPU.
                grid.density_scale = 0.0;
                GpuVdbMedium {
                    lo: m.world_bounds.min.to_array(),
                    hi: m.world_bounds.max.to_array(),
                    ..Default::default()
                }
            }
        };
        r.grid = grid;
        r.bounds_base = bounds_base;
        r.voxel_table = has_table[k] as u32;
        r.emission = emission_params(m, features, &infos);
        let velocity: Vec<GpuGridInfo> = placed
            [next_velocity..next_velocity + velocity_components(m).len()]
            .iter()
            .map(|p| p.0)
            .collect();
        next_velocity += velocity.len();
        r.blur = velocity_blur(m, &velocity);
        media.push(r);
    }
    // The uniform header is the first medium's, in world terms.
    let mut gg = gg;
    gg.info = media[0].grid;
    ctx.queue
        .write_buffer(&gg.info_buffer, 0, bytemuck::bytes_of(&gg.info));
    Ok((gg, media))
}

/// The scene's textures as the GPU reads them: one `GpuTexture` per texture use and every
/// decoded image in one pool of linear RGBA texels (each at least one element).
pub(super) struct Textures {
    pub(super) records: Vec<GpuTexture>,
    pub(super) texels: Vec<[f32; 4]>,
}

impl Textures {
    /// The pool, or the one-line reason it cannot be bound (`max_binding` bytes at most).
    pub(super) fn new(scene: &crate::scene::Scene, max_binding: u64) -> Result<Textures, String> {
        let mut texels: Vec<[f32; 4]> = Vec::new();
        let mut offsets = Vec::with_capacity(scene.images.len());
        for img in &scene.images {
            offsets.push(texels.len() as u32);
            texels.extend_from_slice(&img.texels);
        }
        let bytes = (texels.len() * 16) as u64;
        if bytes > max_binding || texels.len() > u32::MAX as usize {
            return Err(format!(
                "the textures need {} of texels, more than the device's {} storage binding",
                super::device::byte_size(bytes),
                super::device::byte_size(max_binding)
            ));
        }
        let records: Vec<GpuTexture> = scene
            .textures
            .iter()
            .map(|t| {
                let img = &scene.images[t.image_slot as usize];
                let m = t.transform;
                GpuTexture {
                    row0: [m[0], m[1], m[2]],
                    offset: offsets[t.image_slot as usize],
                    row1: [m[3], m[4], m[5]],
                    width: img.width,
                    height: img.height,
                    wrap_s: t.wrap[0],
                    wrap_t: t.wrap[1],
                    nearest: t.nearest as u32,
                }
            })
            .collect();
        Ok(Textures {
            records: if records.is_empty() {
                vec![GpuTexture::zeroed()]
            } else {
                records
            },
            texels: if texels.is_empty() {
                vec![[0.0; 4]]
            } else {
                texels
            },
        })
    }
}

/// The environment map's header and data buffer (`GpuEnvMap::from_map`), with the sampling
/// strategy of `settings`. A constant environment (bound only by the generic variant, which
/// compiles the map code in) becomes a one-pixel map of value 1 scaled by the radiance and
/// sampled uniformly: exactly the constant environment's estimator. Fails with a one-line
/// reason when the data exceed one storage binding.
pub(super) fn env_map_upload(
    rs: &RenderScene,
    settings: &crate::render::RenderSettings,
    max_binding: u64,
) -> Result<(crate::gpu_types::GpuEnvMap, Vec<f32>), String> {
    use crate::gpu_types::GpuEnvMap;
    use crate::render::envmap::EnvSampling;
    let Some(env) = &rs.lights.environment else {
        return Ok((GpuEnvMap::default(), vec![0.0; 4]));
    };
    let (mut info, data) = match &env.map {
        Some(map) => GpuEnvMap::from_map(map),
        None => {
            let info = GpuEnvMap {
                row0: [1.0, 0.0, 0.0, 0.0],
                row1: [0.0, 1.0, 0.0, 0.0],
                row2: [0.0, 0.0, 1.0, 0.0],
                scale: env.radiance.to_array(),
                integral: 1.0,
                width: 1,
                height: 1,
                func_offset: 3,
                cond_offset: 4,
                marg_offset: 6,
                uniform: 1,
                ..Default::default()
            };
            (info, vec![1.0, 1.0, 1.0, 1.0, 0.0, 1.0, 0.0, 1.0])
        }
    };
    if settings.env_sampling == EnvSampling::Uniform {
        info.uniform = 1;
    }
    let bytes = data.len() as u64 * 4;
    if bytes > max_binding || data.len() > u32::MAX as usize {
        return Err(format!(
            "the environment map and its distribution need {}, more than the device's {} storage binding",
            byte_size(bytes),
            byte_size(max_binding)
        ));
    }
    Ok((info, data))
}

/// The per-voxel bounds of the mixture's media as one table indexed by the shared bricks
/// buffer's brick index ([`GpuGrid::upload_many`] places the density grids' bricks first, in
/// medium order), and which media have theirs in it ([`voxel_table`]). The bricks of a medium
/// without one are filled with 255 (never read: its walks do not thin); the table ends after
/// the last medium that has one, and is empty where none does.
fn mixture_voxel_table(rs: &RenderScene) -> (Vec<u8>, Vec<bool>) {
    let mut table: Vec<u8> = Vec::new();
    let mut has = Vec::with_capacity(rs.vdb.len());
    let mut brick0 = 0usize;
    for m in &rs.vdb {
        let q = voxel_table(m);
        let bricks = m.density.grid.grid.brick_count();
        let fits = !q.is_empty() && q.len() == bricks * BRICK_VOXELS;
        if fits {
            table.resize(brick0 * BRICK_VOXELS, 255);
            table.extend_from_slice(&q);
        }
        has.push(fits);
        brick0 += bricks;
    }
    (table, has)
}

/// The per-voxel bounds a medium's walks thin by on the GPU: its table where that pays
/// (`VdbMedium::voxel_culling_pays`, as on the CPU), none (so `dda.wgsl` does not thin)
/// elsewhere.
fn voxel_table(m: &crate::render::media::VdbMedium) -> std::borrow::Cow<'_, [u8]> {
    if m.voxel_culling_pays {
        crate::volume::voxel_bounds::floored_voxel_q(m.bounds(), &m.density.grid.grid.cells)
    } else {
        std::borrow::Cow::Borrowed(&[])
    }
}
