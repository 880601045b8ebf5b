//! [`SHARED_STRUCTS`]: the Rust layout of every host/WGSL shared struct, which
//! `tests/gpu/wgsl.rs` compares with naga's layout of `shaders/common/types.wgsl`.
use std::mem::{offset_of, size_of};

use super::*;

/// The Rust layout of one shared struct: its WGSL name, size and `(member, offset)` list.
pub struct StructLayout {
    pub name: &'static str,
    pub size: usize,
    pub members: &'static [(&'static str, usize)],
}

macro_rules! layout {
    ($t:ty, $wgsl:literal, [$($f:ident),* $(,)?]) => {
        StructLayout {
            name: $wgsl,
            size: size_of::<$t>(),
            members: &[$((stringify!($f), offset_of!($t, $f))),*],
        }
    };
}

/// Every host/WGSL shared struct, as Rust lays it out. The WGSL structs carry the same names
/// and member names; `tests/gpu/wgsl.rs` checks them with naga's layouter.
pub const SHARED_STRUCTS: &[StructLayout] = &[
    layout!(
        GpuPhase,
        "GpuPhase",
        [kind, g_a, g_b, w, alpha, _pad0, _pad1, _pad2]
    ),
    layout!(
        GpuEnvMap,
        "GpuEnvMap",
        [
            row0,
            row1,
            row2,
            scale,
            integral,
            width,
            height,
            func_offset,
            cond_offset,
            marg_offset,
            uniform,
            _pad0,
            _pad1
        ]
    ),
    layout!(
        GpuGridInfo,
        "GpuGridInfo",
        [
            dims,
            brick_count,
            cell_origin,
            constant_count,
            index_from_world,
            background,
            density_scale,
            global_bounds_index,
            cell_offset
        ]
    ),
    layout!(GpuRay, "GpuRay", [o, t_min, d, t_max]),
    layout!(
        GpuMajorantSegment,
        "GpuMajorantSegment",
        [t_min, t_max, sigma_maj, sigma_min]
    ),
    layout!(CellBounds, "CellBounds", [min, max]),
    layout!(
        GpuTrackingParams,
        "GpuTrackingParams",
        [
            estimator,
            majorant_mode,
            control_mode,
            spectral_mode,
            b,
            control_value,
            albedo,
            control_albedo,
            channel_scale,
            seed,
            majorant_channel_scale,
            samples_per_ray,
            invocation_count,
            _pad0
        ]
    ),
    layout!(
        GpuTrackingStats,
        "GpuTrackingStats",
        [
            lookups,
            null_collisions,
            real_collisions,
            control_collisions,
            majorant_violations,
            invalid_majorants,
            collision_cap_hits,
            roulette_kills,
            max_abs_weight_bits,
            segments,
            _pad1,
            _pad2
        ]
    ),
    layout!(
        GpuPathState,
        "GpuPathState",
        [
            o,
            t0,
            d,
            prev_pdf,
            beta,
            sample_id,
            l,
            depth,
            rng_state,
            rng_inc,
            flags,
            collisions,
            lookups,
            medium,
            hit_prim,
            hit_t,
            hit_b1,
            hit_b2,
            outer,
            phase_g,
            time,
            shadow_group,
            phase_medium,
            seg_a,
            seg_b,
            seg_sigma_max,
            seg_sigma_t,
            _pad2,
            surface_color,
            dir_pdf
        ]
    ),
    layout!(
        GpuShadowRay,
        "GpuShadowRay",
        [o, dist, wi, medium, contribution, outer]
    ),
    layout!(
        GpuTriangle,
        "GpuTriangle",
        [p0, triangle, p1, material, p2, light_pdf, n0, kind, n1, interior, n2, _pad0]
    ),
    layout!(GpuTriangleUv, "GpuTriangleUv", [uv0, uv1, uv2]),
    layout!(
        GpuTexture,
        "GpuTexture",
        [row0, offset, row1, width, height, wrap_s, wrap_t, nearest]
    ),
    layout!(GpuAreaLight, "GpuAreaLight", [cdf, prim]),
    layout!(
        GpuHomogeneousMedium,
        "GpuHomogeneousMedium",
        [sigma_a, g, sigma_s, _pad0, phase]
    ),
    CWBVH_NODE_LAYOUT,
    layout!(
        crate::scene::Material,
        "Material",
        [
            base_color,
            emission,
            metallic,
            roughness,
            transmission,
            ior,
            base_color_texture,
            interior_medium,
            emissive_texture,
            flags,
            _pad
        ]
    ),
    layout!(
        GpuWavefrontCounters,
        "GpuWavefrontCounters",
        [
            queue_count,
            next_sample,
            live,
            guard_fired,
            majorant_violations,
            invalid_majorants,
            collision_cap_hits,
            queue_overflows,
            wide,
            _pad1,
            _pad2
        ]
    ),
    layout!(
        GpuWavefrontParams,
        "GpuWavefrontParams",
        [
            camera,
            tan_half,
            aspect,
            znear,
            seed,
            forward,
            width,
            height,
            pixel0,
            s0,
            spp_batch,
            total_samples,
            path_count,
            light_count,
            parity,
            env,
            env_pdf,
            max_depth,
            rr_depth,
            max_collisions,
            has_env,
            medium_lo,
            phase_g,
            medium_hi,
            has_medium,
            scatter_albedo,
            spectral,
            albedo_rgb,
            shadow_estimator,
            tracking,
            camera_medium,
            area_count,
            rr_throughput,
            absorption_weight,
            camera_outer,
            vdb_count,
            flags,
            mix_estimator,
            continuation_albedo,
            shadow_majorant_mode,
            environment_group,
            surfaces_group,
            punctual_groups,
            medium_sigma_s,
            medium_sigma_t,
            medium_sigma_max,
            volume_sampling,
            positional_count,
            _pad_eq,
            blur,
            motion,
            phases,
            media_light_cells,
            media_light_total,
            glow_count,
            _pad_glow,
            glows
        ]
    ),
    layout!(
        GpuVdbMedium,
        "GpuVdbMedium",
        [
            grid,
            tracking,
            emission,
            lo,
            phase_g,
            hi,
            spectral,
            scatter_albedo,
            shadow_estimator,
            albedo_rgb,
            grey_sigma_a,
            rgb_sigma_a,
            grey_sigma_s,
            rgb_sigma_s,
            bounds_base,
            sigma_s,
            control_albedo,
            voxel_table,
            shadow_majorant_mode,
            sigma_t_mean,
            sigma_max,
            blur
        ]
    ),
    layout!(
        GpuVelocityBlur,
        "GpuVelocityBlur",
        [
            x,
            y,
            z,
            velocity_from_density,
            index_from_value,
            world_from_index,
            factor,
            staggered,
            _pad0,
            _pad1
        ]
    ),
    layout!(
        GpuCameraMotion,
        "GpuCameraMotion",
        [open, close, timed, moves, rotation, translation]
    ),
    layout!(
        GpuEmissionParams,
        "GpuEmissionParams",
        [
            grid,
            temperature,
            strength_color,
            has_grid,
            tint,
            has_blackbody,
            temperature_scale,
            temperature_offset,
            intensity,
            light_group,
            region_from_world,
            region_min,
            has_region,
            region_max,
            _pad1
        ]
    ),
    layout!(
        GpuSample,
        "GpuSample",
        [l, lookups, alpha, _pad0, _pad1, _pad2]
    ),
    layout!(
        GpuDataPasses,
        "GpuDataPasses",
        [albedo, depth, normal, _pad0]
    ),
    layout!(
        crate::scene::PunctualLight,
        "PunctualLight",
        [position, kind, direction, range, intensity, cos_inner, cos_outer, _pad]
    ),
];
