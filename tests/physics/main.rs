//! Physics and statistics: samplers, warps and phase functions against their densities, the
//! estimators and majorant walks against closed forms and quadrature, renders against analytic and
//! furnace cases, overlapping and nested media, emission bounds, light selection, and the stress
//! cases that must stay finite.
//!
//! One module per concern; `cargo test --release --test physics MODULE::` runs one of them.
#[path = "../common/mod.rs"]
mod common;

mod accel_auto;
mod accel_embree;
mod accel_instanced;
mod adaptive;
mod data_passes;
mod emission_support;
mod envmap;
mod equiangular;
mod film_alpha;
mod light_groups;
mod light_passes;
mod light_selection;
mod media_lights;
mod media_nested;
mod media_overlap;
mod motion_blur;
mod phase_models;
mod render_agreement;
mod render_furnace;
mod sampling_phase;
mod sampling_rng;
mod sampling_warp;
mod scene_bvh;
mod stress_render;
mod stress_tracking;
mod tracking_distance;
mod tracking_transmittance;
mod volume_dda;
mod volume_grid;
