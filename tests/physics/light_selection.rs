//! Guided light selection at medium events (`Lights::phase_selection`, `sample_selected`):
//! - the selection is a distribution (sums to 1, every light keeps at least its uniform share
//!   `s / n`) that favours the light the phase function looks at, a constant sky keeps
//!   `1 - a` of its probability (the rest goes to the punctual lights, or to no estimate),
//!   and `sample_selected` draws with exactly those probabilities (chi-square);
//! - on every example scene where it applies, the guided image agrees with the uniform one
//!   (per-pixel z-test, Sidak-corrected at 99.9 %, and the image means; independent seeds),
//!   so the estimator stays unbiased (what it does to the variance is measured by
//!   `brume bench peers --renderers brume,brume-uniform-lights`, not here).
use crate::common;
use common::render::*;

use brume::render::lights::{Lights, Selection, GUIDED_UNIFORM_SHARE};
use brume::render::{LightSelection, RenderScene, RenderSettings};
use brume::volume::phase::HenyeyGreenstein;
use glam::{Vec2, Vec3};

/// Chi-square of `draws` choices drawn by `sample_selected` (index: punctual light, then the
/// environment, then "no estimate") against the selection's probabilities.
fn chi_square_of_choices(lights: &Lights, sel: &Selection, wo: Vec3, ph: &HenyeyGreenstein) -> f64 {
    let n = lights.count();
    let mut counts = vec![0u64; n + 1];
    let draws = 100_000u32;
    let mut rng = brume::sampling::Rng::new(3, 5, 7);
    for _ in 0..draws {
        let ls = lights.sample_selected(
            sel,
            Vec3::ZERO,
            rng.uniform_f32(),
            Vec2::new(rng.uniform_f32(), rng.uniform_f32()),
            |u| {
                let s = ph.sample(wo, u);
                (s.wi, s.pdf)
            },
            0.0,
        );
        counts[match ls {
            None => n,
            Some(ls) if ls.is_delta => 0,
            Some(_) => n - 1,
        }] += 1;
    }
    let (mut chi2, mut cells) = (0.0, 0);
    for (&c, &q) in counts.iter().zip(&sel.pmf[..=n]) {
        if q > 0.0 {
            let e = q as f64 * draws as f64;
            chi2 += (c as f64 - e).powi(2) / e;
            cells += 1;
        } else {
            assert_eq!(c, 0, "a choice of probability 0 was drawn");
        }
    }
    println!(
        "choices {counts:?} for pmf {:?}: chi-square {chi2:.2}",
        &sel.pmf[..=n]
    );
    assert!(cells == 2, "two choices with mass in these scenes");
    chi2
}

#[test]
fn the_selection_is_a_distribution_that_follows_the_phase_function() {
    let scene = load_scene("dense_fog.gltf");
    let rs = RenderScene::new(&scene, false).unwrap();
    // The fog's albedo (0.95, 0.8, 0.6): the share of the sky left to the continuation ray.
    assert_eq!(rs.lights.continuation_albedo, 0.95);
    assert!(rs.lights.guided(), "a sun and a sky");
    let n = rs.lights.count();
    let ph = HenyeyGreenstein::new(0.5);
    let sun_dir = -Vec3::from(rs.lights.punctual[0].direction);
    let p = Vec3::ZERO;
    // Looking at the sun (wo opposite the light direction: forward scattering towards it) and
    // away from it; first with the whole sky estimated at the event (a = 0, as
    // `--light-selection guided-full-sky` does).
    let a = rs.lights.continuation_albedo;
    let lights = &rs.lights;
    let toward = lights
        .phase_selection(p, 0.0, |wi| ph.p(-sun_dir, wi), 0.0)
        .unwrap();
    let away = lights
        .phase_selection(p, 0.0, |wi| ph.p(sun_dir, wi), 0.0)
        .unwrap();
    for sel in [toward, away] {
        let sum: f32 = sel.pmf[..=n].iter().sum();
        assert!((sum - 1.0).abs() < 1e-6, "{sel:?}");
        assert_eq!(sel.pmf[n], 0.0, "no 'no estimate' with a = 0: {sel:?}");
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
        "a = 0: P(sun) looking at it {:.3}, looking away {:.3}",
        toward.pmf[0], away.pmf[0]
    );
    assert!(toward.pmf[0] > 0.7 && away.pmf[0] < 0.3);
    // 1 degree of freedom at 99.9 %: 10.83.
    assert!(chi_square_of_choices(lights, &toward, -sun_dir, &ph) < 10.83);

    // With the fog's a, the sky keeps (1 - a) of its probability and the sun takes the rest.
    for (wo, q) in [(-sun_dir, toward), (sun_dir, away)] {
        let sel = lights
            .phase_selection(p, a, |wi| ph.p(wo, wi), 0.0)
            .unwrap();
        let sum: f32 = sel.pmf[..=n].iter().sum();
        assert!((sum - 1.0).abs() < 1e-6, "{sel:?}");
        assert!(
            (sel.env - (1.0 - a) * q.env).abs() < 1e-6,
            "{sel:?} from {q:?}"
        );
        assert!(
            (sel.pmf[0] - (q.pmf[0] + a * q.env)).abs() < 1e-6,
            "{sel:?} from {q:?}"
        );
        assert_eq!(sel.pmf[n], 0.0);
        assert!(chi_square_of_choices(lights, &sel, wo, &ph) < 10.83);
    }
}

#[test]
fn a_sky_alone_is_estimated_at_one_event_in_one_over_one_minus_albedo() {
    // The plume (albedo 0.9) under a constant sky: guided, the sky chosen with probability
    // 1 - a = 0.1 and no estimate otherwise.
    let scene = load_scene("plume_sky.gltf");
    let rs = RenderScene::new(&scene, false).unwrap();
    let lights = &rs.lights;
    assert!(lights.guided() && lights.count() == 1 && lights.constant_environment());
    assert_eq!(lights.continuation_albedo, 0.9);
    let ph = HenyeyGreenstein::new(0.0);
    let sel = lights
        .phase_selection(
            Vec3::ZERO,
            lights.continuation_albedo,
            |wi| ph.p(Vec3::Z, wi),
            0.0,
        )
        .unwrap();
    assert!(
        (sel.env - 0.1).abs() < 1e-6 && (sel.pmf[1] - 0.9).abs() < 1e-6,
        "{sel:?}"
    );
    assert!(chi_square_of_choices(lights, &sel, Vec3::Z, &ph) < 10.83);
    // The darkest medium decides: the dark fog (albedo 0.2) keeps most of its sky estimates.
    let dark = load_scene("ablation/dense_fog_dark.gltf");
    let rs = RenderScene::new(&dark, false).unwrap();
    assert!((rs.lights.continuation_albedo - 0.2).abs() < 1e-6);
    // Only scattering media count: the smoke tank's water only absorbs (albedo 0, but no
    // medium events), so its smoke (albedo 0.8) decides.
    let tank = load_scene("smoke_tank.gltf");
    let rs = RenderScene::new(&tank, false).unwrap();
    assert!((rs.lights.continuation_albedo - 0.8).abs() < 1e-6);
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
