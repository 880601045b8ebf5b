// Mirrors src/gpu_types/, the source of truth for every host/WGSL shared struct (same struct
// and member names). tests/gpu/wgsl.rs parses this file with naga and checks that every size
// and member offset equals the Rust `#[repr(C)]` layout. Rows are 16 bytes: a vec3 plus one
// scalar, so WGSL's vec3 alignment adds no hidden padding.

// GpuGridInfo: the SparseGrid header (src/volume/grid.rs).
struct GpuGridInfo {
    dims: vec3<u32>,             // cell counts of the dense cell index
    brick_count: u32,            // 512-float bricks in `bricks`
    cell_origin: vec3<i32>,      // cell coordinate of cells[0]
    constant_count: u32,         // entries in `constants`
    index_from_world: array<vec4<f32>, 3>, // rows of the world -> index affine map
    background: f32,             // value outside the cell box
    density_scale: f32,          // sigma_t = density_scale * value
    global_bounds_index: u32,    // index of the global CellBounds in `bounds`
    cell_offset: u32,            // first entry of this grid in `cells` (emission grids follow)
}

// GpuRay: o + t d over [t_min, t_max].
struct GpuRay {
    o: vec3<f32>,
    t_min: f32,
    d: vec3<f32>,
    t_max: f32,
}

// GpuMajorantSegment: MajorantSegment (src/volume/segment.rs).
struct GpuMajorantSegment {
    t_min: f32,
    t_max: f32,
    sigma_maj: f32,
    sigma_min: f32,
}

// CellBounds (src/volume/bounds.rs): bounds of the reconstructed values in or near a cell.
struct CellBounds {
    min: f32,
    max: f32,
}

// GpuTrackingParams: one tracking dispatch.
struct GpuTrackingParams {
    estimator: u32,              // ESTIMATOR_* constant
    majorant_mode: u32,          // MAJORANT_PER_CELL, MAJORANT_GLOBAL, MAJORANT_ADAPTIVE or MAJORANT_CULLED
    control_mode: u32,           // CONTROL_* constant
    spectral_mode: u32,          // 0 history-aware max, 1 history-aware average
    b: f32,                      // majorant scale
    control_value: f32,          // constant sigma_c or fraction m
    albedo: f32,                 // sigma_s / sigma_t
    control_albedo: f32,         // split of the control extinction
    channel_scale: vec3<f32>,    // RGB extinction multipliers (spectral)
    seed: u32,                   // Rng::new(pixel, sample, seed)
    majorant_channel_scale: f32, // majorant multiplier (max channel_scale for spectral)
    samples_per_ray: u32,
    invocation_count: u32,
    _pad0: u32,
}

// GpuTrackingStats: TrackingStats counters, accumulated with atomics.
struct GpuTrackingStats {
    lookups: atomic<u32>,
    null_collisions: atomic<u32>,
    real_collisions: atomic<u32>,
    control_collisions: atomic<u32>,
    majorant_violations: atomic<u32>,
    invalid_majorants: atomic<u32>,
    collision_cap_hits: atomic<u32>,
    roulette_kills: atomic<u32>,
    max_abs_weight_bits: atomic<u32>, // bits of a non-negative f32: atomicMax is a float max
    segments: atomic<u32>,
    _pad1: u32,
    _pad2: u32,
}

// GpuPhase: a medium's phase function (PHASE_* kind, unused parameters zero).
struct GpuPhase {
    kind: u32,
    g_a: f32,   // HG lobe's g (Mie: the HG part's; Draine: its own)
    g_b: f32,   // second lobe's g (two-lobe: b; Mie: the Draine part's)
    w: f32,     // first lobe's weight (two-lobe: w; Mie: w_d)
    alpha: f32, // Draine's alpha (Draine, Mie)
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// GpuVelocityBlur: a medium's velocity blur (src/gpu_types/motion.rs; VelocityBlur, Advection).
struct GpuVelocityBlur {
    x: GpuGridInfo,                                // the velocity's components in the grid buffers
    y: GpuGridInfo,
    z: GpuGridInfo,
    velocity_from_density: array<vec4<f32>, 3>,    // rows: density index -> velocity index
    index_from_value: array<vec4<f32>, 3>,         // rows: velocity value -> density-index displacement
    world_from_index: array<vec4<f32>, 3>,         // rows: density index -> world (emission lookups)
    factor: f32,                                   // displacement per frame per unit velocity (0: no blur)
    staggered: u32,                                // 1: a staggered (MAC) velocity grid
    _pad0: u32,
    _pad1: u32,
}

// GpuCameraMotion: the shutter and the camera's poses across it (NodeMotion).
struct GpuCameraMotion {
    open: f32,                                      // Shutter::open, frames
    close: f32,                                     // Shutter::close, frames
    timed: u32,                                     // 1: samples draw a time
    moves: u32,                                     // 1: the camera moves (else wf.camera)
    rotation: array<vec4<f32>, GPU_CAMERA_POSES>,   // quaternions (x, y, z, w), open to close
    translation: array<vec4<f32>, GPU_CAMERA_POSES>, // positions (w unused)
}

// GpuSample: a finished camera sample (entry of the batch's sample buffer).
struct GpuSample {
    l: vec3<f32>,       // radiance, RGB
    lookups: u32,       // density and emission lookups of the path
    alpha: f32,         // coverage: 1 - transmittance to the background
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// GpuDataPasses: one path's or camera sample's data passes (PathState::data).
struct GpuDataPasses {
    albedo: vec3<f32>,  // throughput times the base colour, past the albedo, or times the sky
    depth: f32,         // camera-space Z of the camera ray's first surface, m
    normal: vec3<f32>,  // shading normal there, world (view direction in a medium)
    _pad0: u32,
}

// GpuPathState: one path of the wavefront integrator (see src/gpu_types/wavefront.rs for units).
struct GpuPathState {
    o: vec3<f32>,       // ray origin, world, m
    t0: f32,            // ray start, m
    d: vec3<f32>,       // unit ray direction
    prev_pdf: f32,      // sr^-1 density of d (0 for the camera ray)
    beta: vec3<f32>,    // throughput
    sample_id: u32,     // camera sample within the batch
    l: vec3<f32>,       // radiance so far
    depth: u32,         // scattering events
    rng_state: u32,     // Rng::state
    rng_inc: u32,       // Rng::inc
    flags: u32,         // PATH_FLAG_* bits
    collisions: u32,    // tentative collisions (guard)
    lookups: u32,       // density and emission lookups
    medium: u32,        // homogeneous medium the path is in (NO_INDEX: none)
    hit_prim: u32,      // GpuTriangle slot the ray hits first (NO_INDEX: none)
    hit_t: f32,         // its ray parameter, m
    hit_b1: f32,        // barycentric weight of corner 1
    hit_b2: f32,        // barycentric weight of corner 2
    outer: u32,         // the two media below `medium` on the stack, 16 bits each (STACK_NONE: none)
    phase_g: f32,       // g of the medium that scattered last (mixture variant)
    time: f32,          // the camera sample's time offset, frames (0 without a shutter)
    shadow_group: u32,  // light group of the pending shadow ray's light (light-group variant)
    phase_medium: u32,  // VDB medium whose phase applies (wf.phases; NO_INDEX: the homogeneous one's)
    seg_a: f32,         // the last flight's segment in media, relative to its event (PATH_FLAG_SEGMENT), m
    seg_b: f32,
    seg_sigma_max: f32, // the largest extinction of its media, m^-1
    seg_sigma_t: f32,   // the mean extinction at the event, m^-1
    _pad2: u32,
    surface_color: vec3<f32>, // base colour of the opaque surface stopped at (surface stage)
    dir_pdf: f32,       // density of `d` as drawn (prev_pdf before guided selection rescales it)
}

// GpuShadowRay: a pending next-event-estimation shadow ray, one slot per path.
struct GpuShadowRay {
    o: vec3<f32>,            // origin, world, m
    dist: f32,               // distance to the light (inf: directional/environment)
    wi: vec3<f32>,           // unit direction to the light
    medium: u32,             // homogeneous medium at the origin (NO_INDEX: none)
    contribution: vec3<f32>, // beta L_i f w / pdf, times the transmittance found
    outer: u32,              // the media below `medium` (GpuPathState::outer)
}

// GpuTriangle: a triangle in the BVH's primitive order, with what shading and shadow rays need.
struct GpuTriangle {
    p0: vec3<f32>,      // corners, world, m
    triangle: u32,      // index into Scene::triangles
    p1: vec3<f32>,
    material: u32,      // index into the materials
    p2: vec3<f32>,
    light_pdf: f32,     // luminance / total of the area lights (0: not a light)
    n0: vec3<f32>,      // shading normals at the corners (zero: none given)
    kind: u32,          // SURFACE_* kind of the material
    n1: vec3<f32>,
    interior: u32,      // Material::interior_medium
    n2: vec3<f32>,
    _pad0: u32,
}

// GpuPlacement: one placement of a stored shape where the GPU keeps instancing.
struct GpuPlacement {
    world_x: vec3<f32>,     // world_from_local's columns
    node_base: u32,         // the shape's first CWBVH node
    world_y: vec3<f32>,
    prim_base: u32,         // the shape's first GpuTriangle
    world_z: vec3<f32>,
    first_slot: u32,        // scene-wide slot of the shape's slot 0 here
    world_w: vec3<f32>,
    first_triangle: u32,    // index into Scene::triangles of its first triangle
    local_x: vec3<f32>,     // local_from_world's columns
    flags: u32,             // PLACEMENT_* bits
    local_y: vec3<f32>,
    _pad0: u32,
    local_z: vec3<f32>,
    _pad1: u32,
    local_w: vec3<f32>,
    _pad2: u32,
    normal_x: vec3<f32>,    // inverse transpose of the upper 3x3: columns
    _pad3: u32,
    normal_y: vec3<f32>,
    _pad4: u32,
    normal_z: vec3<f32>,
    _pad5: u32,
}

// GpuTriangleUv: TEXCOORD_0 at a GpuTriangle's corners, same slot.
struct GpuTriangleUv {
    uv0: vec2<f32>,
    uv1: vec2<f32>,
    uv2: vec2<f32>,
}

// GpuTexture: a texture use (scene::TextureRef) and its image in the texel pool.
struct GpuTexture {
    row0: vec3<f32>,    // KHR_texture_transform: u' = dot(row0, (u, v, 1))
    offset: u32,        // first texel of the image in `texels`
    row1: vec3<f32>,    // v' = dot(row1, (u, v, 1))
    width: u32,
    height: u32,
    wrap_s: u32,        // TEXTURE_WRAP_*
    wrap_t: u32,
    nearest: u32,       // 1: nearest texel, 0: bilinear
}

// GpuEnvMap: the environment map's header (src/gpu_types/envmap.rs).
struct GpuEnvMap {
    row0: vec4<f32>,    // rows of lookup_from_world (xyz)
    row1: vec4<f32>,
    row2: vec4<f32>,
    scale: vec3<f32>,   // color * strength
    integral: f32,      // PiecewiseConstant2D::integral
    width: u32,
    height: u32,
    func_offset: u32,   // offsets in env_data (floats); the pixels start at 0
    cond_offset: u32,
    marg_offset: u32,
    uniform: u32,       // 1: uniform sphere sampling
    _pad0: u32,
    _pad1: u32,
}

// GpuAreaLight: one entry of the area lights' selection CDF.
struct GpuAreaLight {
    cdf: f32,
    prim: u32,          // GpuTriangle slot
}

// GpuHomogeneousMedium: KHR_materials_volume medium, m^-1.
struct GpuHomogeneousMedium {
    sigma_a: vec3<f32>,
    g: f32,             // Henyey-Greenstein g (the phase of the variants without FEATURE_PHASES)
    sigma_s: vec3<f32>,
    _pad0: f32,
    phase: GpuPhase,    // its phase function (FEATURE_PHASES)
}

// obvhs' CwBvhNode (Ylitie et al. 2017), 80 bytes: byte fields read as words.
struct CwBvhNode {
    p: vec3<f32>,                 // min corner of the node's box
    e_imask: u32,                 // bytes: exponents e[0], e[1], e[2] of the child grid, imask
    child_base_idx: u32,          // first child node
    primitive_base_idx: u32,      // first primitive slot
    child_meta: vec2<u32>,        // 8 bytes: per-child meta (leaf count + offset, or slot + 24)
    child_min_x: vec2<u32>,       // 8 bytes each: quantised child planes
    child_max_x: vec2<u32>,
    child_min_y: vec2<u32>,
    child_max_y: vec2<u32>,
    child_min_z: vec2<u32>,
    child_max_z: vec2<u32>,
}

// Material (src/scene/material.rs), 64 bytes, uploaded as is.
struct Material {
    base_color: vec4<f32>,        // linear RGB base colour and alpha
    emission: vec3<f32>,          // emitted radiance, W m^-2 sr^-1
    metallic: f32,
    roughness: f32,               // perceptual roughness (alpha = roughness^2)
    transmission: f32,
    ior: f32,                     // index of refraction of the interior
    base_color_texture: u32,
    interior_medium: u32,
    emissive_texture: u32,
    flags: u32,                   // MATERIAL_DOUBLE_SIDED, ...
    _pad: u32,
}

// GpuWavefrontCounters: queue lengths, sample dispenser, counters (all atomics).
struct GpuWavefrontCounters {
    queue_count: array<atomic<u32>, 9>, // entries per QUEUE_*
    next_sample: atomic<u32>,           // next camera sample of the batch
    live: atomic<u32>,                  // paths started, not yet accumulated
    guard_fired: atomic<u32>,
    majorant_violations: atomic<u32>,
    invalid_majorants: atomic<u32>,
    collision_cap_hits: atomic<u32>,
    queue_overflows: atomic<u32>,       // pushes refused past a queue's path_count entries
    wide: array<atomic<u32>, 18>,       // WIDE_* (low, high) pairs of 64-bit totals
    _pad1: u32,
    _pad2: u32,
}

// GpuEmissionParams: volume emission of the VDB medium (integrator::media::Emission).
struct GpuEmissionParams {
    grid: GpuGridInfo,          // emission grid scaling strength_color (has_grid)
    temperature: GpuGridInfo,   // temperature grid of the blackbody term (has_blackbody)
    strength_color: vec3<f32>,  // emissionStrength * emissionColor, radiance per metre
    has_grid: u32,
    tint: vec3<f32>,            // blackbodyTint
    has_blackbody: u32,
    temperature_scale: f32,     // kelvin = scale * value + offset
    temperature_offset: f32,
    intensity: f32,             // blackbodyIntensity
    light_group: u32,           // VdbMedium::light_group (NO_GROUP: none kept)
    region_from_world: array<vec4<f32>, 3>, // density index_from_world rows (EmissionRegion)
    region_min: vec3<f32>,      // the region's box, half-open; no emission outside
    has_region: u32,
    region_max: vec3<f32>,
    _pad1: u32,
}

// GpuWavefrontParams: camera, batch, lights, limits, medium (one uniform per parity).
struct GpuWavefrontParams {
    camera: array<vec4<f32>, 3>, // rows of world_from_camera
    tan_half: f32,
    aspect: f32,
    znear: f32,
    seed: u32,
    forward: vec3<f32>,
    width: u32,
    height: u32,
    pixel0: u32,
    s0: u32,
    spp_batch: u32,
    total_samples: u32,
    path_count: u32,
    light_count: u32,
    parity: u32,
    env: vec3<f32>,
    env_pdf: f32,
    max_depth: u32,
    rr_depth: u32,
    max_collisions: u32,
    has_env: u32,
    medium_lo: vec3<f32>,
    phase_g: f32,
    medium_hi: vec3<f32>,
    has_medium: u32,
    scatter_albedo: vec3<f32>,
    spectral: u32,
    albedo_rgb: vec3<f32>,
    shadow_estimator: u32,
    tracking: GpuTrackingParams,
    camera_medium: u32,          // homogeneous medium around the camera (NO_INDEX: none)
    area_count: u32,             // entries of the area lights' CDF
    rr_throughput: f32,          // roulette before rr_depth below this throughput
    absorption_weight: u32,      // 1: grey homogeneous media scatter with the albedo as weight
    camera_outer: u32,           // the media below camera_medium (GpuPathState::outer)
    vdb_count: u32,              // entries of vdb_media (mixture variant)
    flags: u32,              // MIX_FLAG_* bits
    mix_estimator: u32,          // grey free-flight estimator of a mixture
    continuation_albedo: f32,    // Lights::continuation_albedo
    shadow_majorant_mode: u32,   // the VDB medium's shadow rays' walk (WalkPlan::shadow)
    environment_group: u32,      // LightGroups::environment (NO_GROUP: none)
    surfaces_group: u32,         // LightGroups::surfaces (NO_GROUP: none)
    punctual_groups: vec4<u32>,  // LightGroups::punctual, a byte each: light k in word k / 4
    medium_sigma_s: vec3<f32>,   // the VDB medium's sigma_s per unit of its tracked extinction
    medium_sigma_t: f32,         // its mean extinction per unit of the same
    medium_sigma_max: f32,       // its global majorant, m^-1
    volume_sampling: u32,        // VOLUME_SAMPLING_*
    positional_count: u32,       // point and spot lights among the punctual ones
    lamp_count: u32,             // lamps in media drawing directions (Lamps::count)
    blur: GpuVelocityBlur,       // the VDB medium's velocity blur (factor 0: none)
    motion: GpuCameraMotion,     // the shutter and the camera's poses
    phases: array<GpuPhase, 8>,  // each VDB medium's phase function (FEATURE_PHASES)
    media_light_cells: u32,      // cells sampled as media lights (0: none)
    media_light_nodes: u32,      // the word at which the light tree's nodes start
    glow_count: u32,             // lamps in media drawing pixel jitter (Glows::count)
    placement_count: u32,        // GpuPlacements (0: flat world-space triangles)
    glows: array<vec4<f32>, 2>,  // their film points in pixels, two to a row
    lamps: array<vec4<f32>, 4>,  // the lamps' positions, world space
    lit_count: u32,              // boxes of the media emitting media light (LitMedia::count)
    _lit_pad0: u32,
    _lit_pad1: u32,
    _lit_pad2: u32,
    lit_boxes: array<vec4<f32>, 8>, // box k's lowest corner in row 2k, its highest in 2k + 1
}

// GpuVdbMedium: one VDB medium of the mixture variant (entry of vdb_media).
struct GpuVdbMedium {
    grid: GpuGridInfo,           // density grid, density_scale = sigma_t_bound
    tracking: GpuTrackingParams, // its own tracking parameters
    emission: GpuEmissionParams,
    lo: vec3<f32>,               // world bounds
    phase_g: f32,
    hi: vec3<f32>,
    spectral: u32,               // tracked spectrally on its own
    scatter_albedo: vec3<f32>,   // GreyView / RgbView scatter_albedo
    shadow_estimator: u32,
    albedo_rgb: vec3<f32>,       // per-channel sigma_s / sigma_t
    grey_sigma_a: f32,           // GreyView::sigma_a per unit density
    rgb_sigma_a: vec3<f32>,      // RgbView::sigma_a per unit density
    grey_sigma_s: f32,           // GreyView::sigma_s per unit density
    rgb_sigma_s: vec3<f32>,      // RgbView::sigma_s per unit density
    bounds_base: u32,            // first entry of its bounds in grid_bounds
    sigma_s: vec3<f32>,          // true sigma_s per unit density
    control_albedo: f32,         // GreyView::control_albedo
    voxel_table: u32,            // 1: its walks thin by its per-voxel bounds (grid_voxels)
    shadow_majorant_mode: u32,   // its shadow rays' walk (WalkPlan::shadow)
    sigma_t_mean: f32,           // mean true extinction per unit density
    sigma_max: f32,              // global majorant, m^-1
    blur: GpuVelocityBlur,       // its velocity blur (factor 0: none)
}

// PunctualLight (src/scene/lights.rs): a point, spot or directional light, 64 bytes.
struct PunctualLight {
    position: vec3<f32>,
    kind: u32,              // LIGHT_POINT, LIGHT_SPOT or LIGHT_DIRECTIONAL
    direction: vec3<f32>,   // direction the light travels
    range: f32,
    intensity: vec3<f32>,   // W/sr (point, spot) or W/m^2 (directional)
    cos_inner: f32,
    cos_outer: f32,
    _pad: array<f32, 3>,
}
