//! `brume bench render`'s environment-map section: the HDR-sky cloud (scenes/cloud_sky.gltf)
//! against the same cloud under a constant sky of the map's mean radiance (per-sample time,
//! target at most 1.3x), and the ablation of the map's importance sampling against uniform
//! sphere sampling at equal time (RMSE against a long importance-sampled reference).
use crate::render::envmap::EnvSampling;
use crate::render::RenderSettings;
use anyhow::{anyhow, Result};
use std::path::Path;

/// Solid-angle mean of the scene's map radiance (`sin(theta)`-weighted pixel mean).
fn mean_radiance(scene: &crate::scene::Scene) -> [f32; 3] {
    let env = &scene.environment;
    let Some(img) = &env.image else {
        return env.radiance;
    };
    let (mut acc, mut wsum) = ([0f64; 3], 0f64);
    for j in 0..img.height {
        let w = (std::f64::consts::PI * (j as f64 + 0.5) / img.height as f64).sin();
        for i in 0..img.width {
            let p = img.at(i, j);
            for c in 0..3 {
                acc[c] += w * p[c] as f64;
            }
            wsum += w;
        }
    }
    [0, 1, 2].map(|c| (acc[c] / wsum) as f32 * env.radiance[c])
}

fn rmse(a: &crate::film::Film, reference: &crate::film::Film) -> f64 {
    let (pa, pr) = (a.pixels(), reference.pixels());
    let sum: f64 = pa
        .iter()
        .zip(pr)
        .flat_map(|(x, r)| (0..3).map(move |c| (x.mean[c] - r.mean[c]).powi(2)))
        .sum();
    (sum / (3 * pa.len()) as f64).sqrt()
}

/// Prints the per-sample time of the HDR-sky cloud and of the constant-sky cloud, and the
/// ablation. `render` renders a scene with settings (`backend::cpu::render_scene`).
pub fn env_map_bench(
    width: u32,
    height: u32,
    spp: u32,
    render: &dyn Fn(
        &crate::scene::Scene,
        &RenderSettings,
    ) -> Result<crate::backend::cpu::RenderOutput>,
) -> Result<()> {
    let path = Path::new("scenes/cloud_sky.gltf");
    let sky = crate::scene::load(path)?;
    if sky.environment.image.is_none() {
        return Err(anyhow!("{}: no environment map", path.display()));
    }
    let mut constant = crate::scene::load(path)?;
    constant.environment.radiance = mean_radiance(&sky);
    constant.environment.image = None;
    constant.environment.map = None;
    let base = RenderSettings {
        width,
        height,
        spp,
        ..RenderSettings::default()
    };
    println!();
    println!(
        "environment map: {} ({width}x{height}, {spp} spp, {} threads; best of 3 alternating runs)",
        path.display(),
        rayon::current_num_threads()
    );
    render(
        &sky,
        &RenderSettings {
            spp: 1,
            ..base.clone()
        },
    )?;
    let samples = (width * height * spp) as f64;
    let (mut t_map, mut t_const) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..3 {
        t_map = t_map.min(render(&sky, &base)?.seconds);
        t_const = t_const.min(render(&constant, &base)?.seconds);
    }
    let us = |t: f64| 1e6 * t / samples;
    println!(
        "  per-sample time: map {:.3} us, constant sky {:?} {:.3} us, ratio {:.3}x (target <= 1.3x)",
        us(t_map),
        constant.environment.radiance,
        us(t_const),
        t_map / t_const
    );

    // Ablation: the same time budget for each strategy; RMSE against a reference of 32x the
    // samples (importance-sampled; its own error is common to both rows).
    let reference = render(
        &sky,
        &RenderSettings {
            spp: spp * 32,
            seed: 99,
            ..base.clone()
        },
    )?;
    let budget = t_map;
    println!(
        "  ablation at equal time ({budget:.2} s each; reference {} spp in {:.1} s):",
        reference.spp, reference.seconds
    );
    let mut rows = Vec::new();
    for mode in [EnvSampling::Importance, EnvSampling::Uniform] {
        let out = render(
            &sky,
            &RenderSettings {
                spp: u32::MAX / 2,
                time_limit: Some(budget),
                max_pass_spp: 1,
                env_sampling: mode,
                seed: 7,
                ..base.clone()
            },
        )?;
        let e = rmse(&out.film, &reference.film);
        // The budget stops new passes, so a render overshoots by up to one pass: scale the
        // error to the budget exactly (MSE ~ 1 / time for an unbiased estimator).
        let e_equal = e * (out.seconds / budget).sqrt();
        println!(
            "    {:<10} {:>5} spp in {:.2} s, RMSE {:.5} (at {budget:.2} s: {:.5})",
            mode.to_string(),
            out.spp,
            out.seconds,
            e,
            e_equal
        );
        rows.push(e_equal);
    }
    println!(
        "  uniform / importance RMSE at equal time: {:.2}x (time to equal error: {:.1}x)",
        rows[1] / rows[0],
        (rows[1] / rows[0]).powi(2)
    );
    Ok(())
}
