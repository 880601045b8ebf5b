//! Guided light selection at medium events (`Lights::phase_selection`, `sample_selected`):
//! - the selection is a distribution (sums to 1, every light keeps at least its uniform share
//!   `s / n`) that favours the light the phase function looks at, and `sample_selected`
//!   draws lights with exactly those probabilities (chi-square);
//! - on every example scene where it applies, the guided image agrees with the uniform one
//!   (per-pixel z-test, Sidak-corrected at 99.9 %, and the image means; independent seeds),
//!   so the estimator stays unbiased (what it does to the variance is measured by
//!   `brume bench peers --renderers brume,brume-uniform-lights`, not here).
mod common;
use common::render::*;

use brume::integrator::lights::GUIDED_UNIFORM_SHARE;
use brume::integrator::{LightSelection, RenderScene, RenderSettings};
use brume::volume::phase::HenyeyGreenstein;
use glam::{Vec2, Vec3};

#[test]
fn the_selection_is_a_distribution_that_follows_the_phase_function() {
    let scene = load_scene("dense_fog.gltf");
    let rs = RenderScene::new(&scene, false).unwrap();
    let lights = &rs.lights;
    assert!(lights.guided(), "a sun and a sky");
    let n = lights.count();
    let ph = HenyeyGreenstein::new(0.5);
    let sun_dir = -Vec3::from(lights.punctual[0].direction);
    let p = Vec3::ZERO;
    // Looking at the sun (wo opposite the light direction: forward scattering towards it) and
    // away from it.
    let toward = lights.phase_selection(p, |wi| ph.p(-sun_dir, wi)).unwrap();
    let away = lights.phase_selection(p, |wi| ph.p(sun_dir, wi)).unwrap();
    for sel in [toward, away] {
        let sum: f32 = sel.pmf[..n].iter().sum();
        assert!((sum - 1.0).abs() < 1e-6, "{sel:?}");
        for &q in &sel.pmf[..n] {
            assert!(q >= GUIDED_UNIFORM_SHARE / n as f32 - 1e-7, "{sel:?}");
        }
        assert_eq!(sel.env, sel.pmf[n - 1]);
        assert!(
            sel.env_by_phase,
            "a constant sky is sampled by the phase function"
        );
    }
    println!(
        "P(sun) looking at it {:.3}, looking away {:.3}",
        toward.pmf[0], away.pmf[0]
    );
    assert!(toward.pmf[0] > 0.7 && away.pmf[0] < 0.3);

    // The draws follow the probabilities: chi-square over the two choices, 100k draws.
    let mut counts = [0u64; 2];
    let draws = 100_000u32;
    let mut rng = brume::sampling::Rng::new(3, 5, 7);
    for _ in 0..draws {
        let ls = lights
            .sample_selected(
                &toward,
                p,
                rng.uniform_f32(),
                Vec2::new(rng.uniform_f32(), rng.uniform_f32()),
                |u| {
                    let s = ph.sample(-sun_dir, u);
                    (s.wi, s.pdf)
                },
            )
            .expect("a light");
        counts[if ls.is_delta { 0 } else { 1 }] += 1;
    }
    let chi2: f64 = counts
        .iter()
        .zip(&toward.pmf[..2])
        .map(|(&c, &q)| {
            let e = q as f64 * draws as f64;
            (c as f64 - e).powi(2) / e
        })
        .sum();
    println!(
        "choices {counts:?} for pmf {:?}: chi-square {chi2:.2} (1 dof)",
        &toward.pmf[..2]
    );
    // 1 degree of freedom at 99.9 %: 10.83.
    assert!(chi2 < 10.83);
}

#[test]
fn guided_selection_agrees_with_uniform_selection_on_every_example_scene() {
    let guided: Vec<&str> = EXAMPLE_SCENES
        .into_iter()
        .filter(|f| {
            let scene = load_scene(f);
            RenderScene::new(&scene, false).unwrap().lights.guided()
        })
        .collect();
    println!("scenes with guided selection: {guided:?}");
    assert!(guided.contains(&"dense_fog.gltf") && guided.contains(&"chromatic.gltf"));
    let alpha = 1e-3 / guided.len() as f64;
    for (i, file) in guided.iter().enumerate() {
        let scene = load_scene(file);
        let s = RenderSettings {
            width: 32,
            height: 24,
            spp: 256,
            seed: 70 + i as u32,
            ..RenderSettings::default()
        };
        let g = render(&scene, &s);
        let u = render(
            &scene,
            &RenderSettings {
                seed: s.seed + 1000,
                light_selection: LightSelection::Uniform,
                ..s.clone()
            },
        );
        let (gm, gv) = moments(&g);
        let (um, uv) = moments(&u);
        let a = compare((&gm, &gv), (&um, &uv), alpha);
        println!(
            "{file}: guided {:.5} vs uniform {:.5} (mean z {:.2}), worst pixel z {:.2} (threshold {:.2}), {} failing",
            a.mean_a, a.mean_b, a.mean_z, a.worst_z, a.z_threshold, a.failing
        );
        assert_eq!(a.failing, 0, "{file}: {a:?}");
        assert!(a.mean_z < sidak_z(alpha, 3), "{file}: {a:?}");
    }
}
