//! The GPU context for the `gpu_*` tests: SKIP (with a visible line) only when no adapter
//! exists at all; any other failure to use the GPU fails the test.
use brume::backend::gpu::{GpuContext, GpuGrid};
use brume::gpu_types::{
    GpuControlMode, GpuEstimator, GpuMajorantMode, GpuRay, GpuTrackingParams, GpuTrackingStats,
};
use brume::math::{Ray, Vec3};
use brume::volume::tracking::ControlExtinction;
use brume::volume::{LeafBounds, SparseGrid};

pub fn gpu_or_skip(test: &str) -> Option<GpuContext> {
    // As `brume` does at start: Mesa's device-select layer would print libwayland's
    // "XDG_RUNTIME_DIR is invalid" on a headless machine. Once for the process, and before
    // any context exists: the test threads wait here, so no thread is inside Mesa (reading
    // the environment) while it changes.
    static QUIET: std::sync::Once = std::sync::Once::new();
    QUIET.call_once(|| {
        if std::env::var_os("XDG_RUNTIME_DIR").is_none()
            && std::env::var_os("MESA_VK_DEVICE_SELECT").is_none()
        {
            std::env::set_var("NODEVICE_SELECT", "1");
        }
    });
    match GpuContext::new() {
        Ok(ctx) => {
            println!("{test}: {}", ctx.describe());
            Some(ctx)
        }
        Err(e) if e.no_adapter => {
            eprintln!("SKIP: no GPU adapter: {}", e.reason);
            None
        }
        Err(e) => panic!("{test}: GPU adapter present but unusable: {}", e.reason),
    }
}

/// A medium for the tracking kernels: a grid, its bounds, `sigma_t = scale * value`, one
/// index-space ray and its optical depth.
pub struct Medium {
    pub name: &'static str,
    pub grid: SparseGrid,
    pub bounds: LeafBounds,
    pub scale: f32,
    pub ray: GpuRay,
    /// Optical depth along the ray at unit channel scale.
    pub tau: f64,
}

pub fn slab() -> Medium {
    let (grid, _) = SparseGrid::from_dense([32, 32, 32], [0, 0, 0], &vec![1.0; 32 * 32 * 32], 0.0)
        .expect("slab");
    let bounds = LeafBounds::build(&grid);
    let d = [1.0f32, 0.2, 0.1];
    let scale = 0.03;
    Medium {
        name: "slab",
        grid,
        bounds,
        scale,
        ray: GpuRay {
            o: [-3.0, 10.0, 12.0],
            t_min: 0.0,
            d,
            t_max: f32::INFINITY,
        },
        // x runs through [-1, 32]: 31 unit voxels plus two half ramps, at any y, z inside.
        tau: scale as f64 * 32.0 / d[0] as f64,
    }
}

pub fn blob() -> Medium {
    let grid = super::convert(&super::blob());
    let bounds = LeafBounds::build(&grid);
    let scale = 0.012;
    let ray = GpuRay {
        o: [-20.0, 16.0, -3.0],
        t_min: 0.0,
        d: [0.9, 0.15, 0.05],
        t_max: 55.0,
    };
    let r = Ray::new(Vec3::from_array(ray.o), Vec3::from_array(ray.d));
    // Midpoint quadrature of the CPU lookup (piecewise trilinear: 2M steps are plenty).
    let n = 2_000_000;
    let h = ray.t_max as f64 / n as f64;
    let tau = (0..n)
        .map(|i| {
            let t = ((i as f64 + 0.5) * h) as f32;
            scale as f64 * grid.sample_trilinear(r.at(t).as_dvec3()) as f64
        })
        .sum::<f64>()
        * h;
    Medium {
        name: "blob",
        grid,
        bounds,
        scale,
        ray,
        tau,
    }
}

impl Medium {
    /// Optical depth from the ray's start to parameter `t` (midpoint quadrature of the CPU
    /// lookup, `n` steps).
    pub fn tau_to(&self, t: f32, n: usize) -> f64 {
        let r = Ray::new(Vec3::from_array(self.ray.o), Vec3::from_array(self.ray.d));
        let h = t as f64 / n as f64;
        (0..n)
            .map(|i| {
                let s = ((i as f64 + 0.5) * h) as f32;
                self.scale as f64 * self.grid.sample_trilinear(r.at(s).as_dvec3()) as f64
            })
            .sum::<f64>()
            * h
    }
}

/// Samples per ray of the tracking-kernel tests, the media's single-scattering albedo and the
/// RGB extinction scales of spectral tracking.
pub const SAMPLES: u32 = 100_000;
pub const ALBEDO: f32 = 0.7;
pub const RGB: [f32; 3] = [0.4, 1.0, 2.0];

/// One estimator configuration of the tracking kernel.
#[derive(Clone, Copy, Debug)]
pub struct TrackingCase {
    pub estimator: GpuEstimator,
    pub b: f32,
    pub control: ControlExtinction,
    pub majorant: GpuMajorantMode,
}

/// What one dispatch of the tracking kernel wrote: a `vec4` per sample, the distance kernel's
/// events (empty for transmittance) and the summed counters.
pub struct TrackingOutput {
    pub results: Vec<[f32; 4]>,
    pub events: Vec<[u32; 2]>,
    pub stats: GpuTrackingStats,
}

/// Runs `pipeline` (the tracking kernel, as `TRANSMITTANCE_MODULE` or `DISTANCE_MODULE`) for
/// [`SAMPLES`] samples of `m`'s ray through `grid`, seeded `seed`.
pub fn run_tracking(
    ctx: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    grid: &GpuGrid,
    m: &Medium,
    c: TrackingCase,
    seed: u32,
    with_events: bool,
) -> TrackingOutput {
    let (control_mode, control_value) = GpuControlMode::from_control(c.control);
    let rgb = c.estimator == GpuEstimator::Spectral;
    let params = GpuTrackingParams {
        estimator: c.estimator as u32,
        majorant_mode: c.majorant as u32,
        control_mode: control_mode as u32,
        spectral_mode: 0,
        b: c.b,
        control_value,
        albedo: ALBEDO,
        control_albedo: ALBEDO,
        channel_scale: if rgb { RGB } else { [1.0; 3] },
        seed,
        majorant_channel_scale: if rgb { RGB[2] } else { 1.0 },
        samples_per_ray: SAMPLES,
        invocation_count: SAMPLES,
        _pad0: 0,
    };
    let params_buf = ctx.uniform_buffer("params", &params);
    let rays = ctx.storage_buffer("rays", &[m.ray]);
    let results = ctx.storage_buffer_zeroed("results", SAMPLES as u64 * 16);
    let stats = ctx.storage_buffer("stats", &[GpuTrackingStats::default()]);
    let events = ctx.storage_buffer_zeroed("events", SAMPLES as u64 * 8);
    let mut bindings = grid.bindings(true, true);
    bindings.extend([
        (1, 0, &params_buf),
        (1, 1, &rays),
        (1, 2, &results),
        (1, 3, &stats),
    ]);
    if with_events {
        bindings.push((1, 4, &events));
    }
    ctx.dispatch(pipeline, &bindings, SAMPLES.div_ceil(64))
        .unwrap();
    TrackingOutput {
        results: ctx.read_buffer(&results),
        events: if with_events {
            ctx.read_buffer(&events)
        } else {
            Vec::new()
        },
        stats: ctx.read_buffer::<GpuTrackingStats>(&stats)[0],
    }
}
