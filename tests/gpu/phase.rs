//! The WGSL phase functions (shaders/common/phase.wgsl) against `Phase`: for every kind the
//! sampled directions, pdfs and evaluations agree to rounding (WGSL's sin/cos/sqrt/pow are not
//! the CPU's libm, so not bit for bit; on a GPU, to the precision of its built-ins), and
//! Draine's rejection, fed the same random stream, takes the same candidates. Rendered, each
//! kind keeps the furnace at 1 and renders the cloud as the CPU does (per-pixel z-tests
//! against the CPU with another seed, and the CPU's image with the same seed replayed).
use crate::common;

use brume::backend::gpu::shader::TEST_PHASE_MODULE;
use brume::backend::gpu::GpuContext;
use brume::gpu_types::GpuPhase;
use brume::sampling::rng::Rng;
use brume::volume::check::SplitMix64;
use brume::volume::phases::{Draine, Phase};
use glam::{Vec2, Vec3};

/// The largest differences between the GPU's samples and the CPU's for one set of phases.
#[derive(Debug, Default)]
struct Agreement {
    /// `|wi_gpu - wi_cpu|`.
    dir: f32,
    /// Relative difference of the sample's pdf from the CPU's: Henyey-Greenstein's from its
    /// sampled cosine, the others' `p` at the GPU's direction (within a narrow lobe, |g| near
    /// 1, a direction an ulp away has a pdf 1e-5 apart).
    pdf_rel: f32,
    /// Relative difference of the GPU's `p(wo, wi)` from the CPU's, at the GPU's direction.
    p_rel: f32,
    /// `|mean_cosine_gpu - mean_cosine_cpu|` (what shapes equiangular sampling).
    mean_cos: f32,
    /// Samples whose direction differs by more than 1e-3 (a different candidate or lobe).
    diverged: usize,
    samples: usize,
}

/// Samples every phase of `phases` at `n` random `(u, wo)` on the GPU and on the CPU, with the
/// same random stream for a rejection's further points.
fn compare(ctx: &GpuContext, phases: &[Phase], n: usize, seed: u64) -> Agreement {
    let pipeline = ctx.pipeline(&TEST_PHASE_MODULE, &[]).unwrap();
    let mut rng = SplitMix64(seed);
    let mut inputs: Vec<[f32; 4]> = Vec::with_capacity(3 * n);
    let mut cases = Vec::with_capacity(n);
    for i in 0..n {
        let phase = phases[i % phases.len()];
        let r = GpuPhase::of(&phase);
        let u = Vec2::new(rng.uniform() as f32, rng.uniform() as f32);
        let stream = rng.next_u64() as u32;
        let z = rng.range(-1.0, 1.0) as f32;
        let phi = rng.range(0.0, std::f64::consts::TAU) as f32;
        let s = (1.0 - z * z).max(0.0).sqrt();
        let wo = Vec3::new(s * phi.cos(), s * phi.sin(), z).normalize();
        inputs.push([f32::from_bits(r.kind), r.g_a, r.g_b, r.w]);
        inputs.push([r.alpha, u.x, u.y, f32::from_bits(stream)]);
        inputs.push([wo.x, wo.y, wo.z, 0.0]);
        cases.push((phase, u, stream, wo));
    }
    let input = ctx.storage_buffer("inputs", &inputs);
    let out = ctx.storage_buffer_zeroed("outputs", (2 * n) as u64 * 16);
    ctx.dispatch(
        &pipeline,
        &[(0, 0, &input), (0, 1, &out)],
        (n as u32).div_ceil(64),
    )
    .unwrap();
    let gpu: Vec<[f32; 4]> = ctx.read_buffer(&out);
    let mut a = Agreement {
        samples: n,
        ..Default::default()
    };
    for (i, &(phase, u, stream, wo)) in cases.iter().enumerate() {
        let mut more = Rng::new(i as u32, 0, stream);
        let s = phase.sample(wo, u, &mut || more.uniform_vec2());
        let (wi_gpu, pdf_gpu) = (Vec3::from_slice(&gpu[2 * i][..3]), gpu[2 * i][3]);
        let p_gpu = gpu[2 * i + 1][0];
        a.mean_cos = a
            .mean_cos
            .max((gpu[2 * i + 1][1] - phase.mean_cosine()).abs());
        let dir = (wi_gpu - s.wi).length();
        if dir > 1e-3 {
            a.diverged += 1;
            continue;
        }
        a.dir = a.dir.max(dir);
        // Evaluate at the GPU's direction so only the arithmetic of p is compared.
        let p_cpu = phase.p(wo, wi_gpu);
        let pdf_cpu = match phase {
            Phase::HenyeyGreenstein(_) => s.pdf,
            _ => p_cpu,
        };
        a.pdf_rel = a.pdf_rel.max((pdf_gpu - pdf_cpu).abs() / pdf_cpu);
        a.p_rel = a.p_rel.max((p_gpu - p_cpu).abs() / p_cpu);
    }
    a
}

/// The phases of each kind the test samples.
fn kinds() -> Vec<(&'static str, Vec<Phase>)> {
    let gs = [
        -0.99f32, -0.9, -0.5, -0.1, 0.0, 0.1, 0.3, 0.5, 0.8, 0.9, 0.99,
    ];
    let two_lobe = |a: f32, b: f32, w: f32| Phase::TwoLobe {
        a: brume::volume::phase::HenyeyGreenstein::new(a),
        b: brume::volume::phase::HenyeyGreenstein::new(b),
        w,
    };
    vec![
        (
            "henyey-greenstein",
            gs.iter().map(|&g| Phase::hg(g)).collect(),
        ),
        (
            "two-lobe",
            vec![
                two_lobe(0.8, -0.3, 0.7),
                two_lobe(0.95, -0.5, 0.9),
                two_lobe(0.2, 0.6, 0.0),
            ],
        ),
        (
            "draine",
            [
                (0.0, 1.0),
                (0.5, 1.0),
                (0.7, -0.9),
                (0.3, 250.0),
                (-0.6, 5.0),
            ]
            .iter()
            .map(|&(g, alpha)| Phase::Draine(Draine::new(g, alpha)))
            .collect(),
        ),
        (
            "mie",
            [0.05f32, 0.5, 3.0, 20.0, 50.0]
                .iter()
                .map(|&d| Phase::mie(d).unwrap())
                .collect(),
        ),
        ("rayleigh", vec![Phase::Rayleigh]),
    ]
}

#[test]
fn wgsl_phases_match_cpu() {
    let Some(ctx) = common::gpu::gpu_or_skip("gpu_phase") else {
        return;
    };
    // A CPU adapter (llvmpipe) computes sin, cos, sqrt and pow to about an ulp, as libm does.
    // WGSL lets a GPU's built-ins be far coarser (sin and cos to 2^-11 absolute on [-pi, pi]);
    // NVIDIA's land within 2e-5 in direction and 1e-5 in pdf. The bounds for a GPU sit below
    // WGSL's own, and far below what a wrong formula gives (errors of order 1).
    let cpu_adapter = ctx.adapter_info.device_type == wgpu::DeviceType::Cpu;
    let (dir_tol, pdf_tol): (f32, f32) = if cpu_adapter {
        (4e-6, 4e-6)
    } else {
        (1e-4, 1e-4)
    };
    for (k, (name, phases)) in kinds().into_iter().enumerate() {
        let a = compare(&ctx, &phases, 20_000, 0x9A5E + k as u64);
        println!(
            "{name}: {} samples, max |wi_gpu - wi_cpu| {:.2e}, max pdf rel diff {:.2e}, max \
             p(wo, wi) rel diff {:.2e}, max mean cosine diff {:.2e}, {} diverged",
            a.samples, a.dir, a.pdf_rel, a.p_rel, a.mean_cos, a.diverged
        );
        assert!(
            a.mean_cos < 1e-6,
            "{name}: mean cosines differ by {}",
            a.mean_cos
        );
        // Draine's accept test compares against a threshold: rounding may flip it only for a
        // candidate within an ulp of it.
        assert!(
            a.diverged <= a.samples / 10_000,
            "{name}: {} samples took other candidates",
            a.diverged
        );
        // Rayleigh's direction is taken from its cosine (sin = sqrt(1 - mu^2)): an ulp of mu
        // near the poles, where the CPU's f64 root and the GPU's f32 one round apart, moves
        // it by up to ~5e-5.
        let dir_tol = if name == "rayleigh" {
            dir_tol.max(5e-5)
        } else {
            dir_tol
        };
        assert!(a.dir < dir_tol, "{name}: directions differ by {}", a.dir);
        assert!(
            a.pdf_rel < pdf_tol,
            "{name}: pdfs differ by {} relative",
            a.pdf_rel
        );
        assert!(
            a.p_rel < 1e-5,
            "{name}: p(wo, wi) differs by {} relative",
            a.p_rel
        );
    }
}

/// The phases the renders take: one of each kind but Henyey-Greenstein (the other render
/// tests' media).
fn render_phases() -> Vec<Phase> {
    vec![
        Phase::TwoLobe {
            a: brume::volume::phase::HenyeyGreenstein::new(0.8),
            b: brume::volume::phase::HenyeyGreenstein::new(-0.3),
            w: 0.7,
        },
        Phase::Draine(Draine::new(0.5, 1.0)),
        Phase::mie(20.0).unwrap(),
        Phase::Rayleigh,
    ]
}

#[test]
fn furnace_renders_one_with_every_phase_on_the_gpu() {
    use common::render::{against_one, load_scene, sidak_z};
    let Some(ctx) = common::gpu::gpu_or_skip("furnace_renders_one_with_every_phase") else {
        return;
    };
    let phases = render_phases();
    let alpha = 1e-3 / phases.len() as f64;
    for (i, phase) in phases.into_iter().enumerate() {
        let mut scene = load_scene("furnace.gltf");
        scene.vdb_media[0].phase = Some(phase);
        let s = brume::render::RenderSettings {
            width: 16,
            height: 12,
            spp: 64,
            seed: 500 + i as u32,
            ..Default::default()
        };
        let label = format!("furnace {}", phase.name());
        let out = crate::render::gpu_render(&ctx, &scene, &s, &label);
        let (a, _) = against_one(&out, alpha, &label);
        assert_eq!(a.failing, 0, "{label}: {a:?}");
        assert!(a.mean_z < sidak_z(alpha, 3), "{label}: {a:?}");
    }
}

#[test]
fn every_phase_renders_the_cloud_as_the_cpu_does() {
    let Some(ctx) = common::gpu::gpu_or_skip("every_phase_renders_the_cloud") else {
        return;
    };
    let phases = render_phases();
    let alpha = 1e-3 / phases.len() as f64;
    for (i, phase) in phases.into_iter().enumerate() {
        let mut scene = common::render::load_scene("cloud.gltf");
        scene.vdb_media[0].phase = Some(phase);
        let s = brume::render::RenderSettings {
            width: 24,
            height: 18,
            spp: 32,
            seed: 600 + i as u32,
            ..Default::default()
        };
        let label = format!("cloud {}", phase.name());
        let (g, c) = crate::render::gpu_against_cpu(&ctx, &scene, &s, &label, alpha);
        crate::render::print_parity(Some(&ctx), &label, &scene, &s, &g, &c);
    }
}

/// A homogeneous medium of each phase function (`BRUME_materials_volume_scattering.phase`):
/// the furnace's box filled with an absorbing, scattering medium, alone (the homogeneous
/// variant) and around the cloud (the mixture variant, where an event picks whose phase
/// applies), renders as the CPU does and replays its image with the same seed.
#[test]
fn homogeneous_phases_render_as_the_cpu_does() {
    let Some(ctx) = common::gpu::gpu_or_skip("homogeneous_phases_render") else {
        return;
    };
    let mut cases: Vec<(Phase, bool)> = render_phases().into_iter().map(|p| (p, false)).collect();
    cases.extend([(Phase::Rayleigh, true), (Phase::mie(20.0).unwrap(), true)]);
    let alpha = 1e-3 / cases.len() as f64;
    for (i, (phase, cloud)) in cases.into_iter().enumerate() {
        let mut scene = common::render::homogeneous_furnace(phase, 0.4, cloud);
        scene.homogeneous_media[0].sigma_a = [0.15; 3];
        let s = brume::render::RenderSettings {
            width: 24,
            height: 18,
            spp: 32,
            seed: 800 + i as u32,
            ..Default::default()
        };
        let label = format!("homogeneous {} (cloud inside: {cloud})", phase.name());
        let (g, c) = crate::render::gpu_against_cpu(&ctx, &scene, &s, &label, alpha);
        crate::render::print_parity(Some(&ctx), &label, &scene, &s, &g, &c);
    }
}
