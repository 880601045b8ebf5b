//! Light groups (`--passes lights`): on every example scene they add up to the beauty, which
//! keeping them leaves bit for bit as it is; and each group is the image its source makes
//! alone: the render with every other source turned off (per-pixel z-tests).
use crate::common::render::{
    assert_same_beauty, compare, load_scene, moments, render, EXAMPLE_SCENES,
};

use brume::backend::cpu::RenderOutput;
use brume::render::light_groups::LightGroups;
use brume::render::RenderSettings;
use brume::scene::Scene;

fn settings(scene: &Scene, spp: u32, groups: bool) -> RenderSettings {
    RenderSettings {
        width: 16,
        height: 12,
        spp,
        seed: 3,
        light_groups: match groups {
            true => LightGroups::of(scene).unwrap().names,
            false => Vec::new(),
        },
        ..RenderSettings::default()
    }
}

#[test]
fn light_groups_add_up_to_the_beauty_on_every_example_scene() {
    let mut worst = 0f64;
    for name in EXAMPLE_SCENES {
        let scene = load_scene(name);
        let with = render(&scene, &settings(&scene, 8, true));
        let without = render(&scene, &settings(&scene, 8, false));
        assert_same_beauty(&with.film, &without.film, name);
        let names = LightGroups::of(&scene).unwrap().names;
        assert!(!names.is_empty(), "{name}: no light group");
        let groups = with.film.passes().expect("light groups kept");
        assert_eq!(groups.names(), names.as_slice());
        let mut totals = vec![0f64; names.len()];
        for (i, p) in with.film.pixels().iter().enumerate() {
            for c in 0..3 {
                let sum: f64 = (0..names.len()).map(|k| groups.mean(i, k)[c]).sum();
                // The groups take the same f32 terms as the beauty; only their sums round
                // differently.
                let scale = p.mean[c].abs().max(1e-3);
                worst = worst.max((sum - p.mean[c]).abs() / scale);
            }
            for (k, t) in totals.iter_mut().enumerate() {
                *t += groups.mean(i, k).iter().sum::<f64>();
            }
        }
        let shares: Vec<String> = names
            .iter()
            .zip(&totals)
            .map(|(n, t)| format!("{n} {t:.3}"))
            .collect();
        println!("{name}: {}", shares.join(", "));
    }
    println!("largest difference of the groups' sum from the beauty: {worst:.2e} (relative)");
    assert!(worst < 1e-5, "{worst}");
}

/// Group `group` of `with` (a render keeping the groups) against the beauty of `alone` (the
/// scene with every other source off), pixel by pixel at family-wise level 1e-3.
fn group_is_its_source_alone(label: &str, with: &RenderOutput, group: &str, alone: &RenderOutput) {
    let groups = with.film.passes().unwrap();
    let k = groups.names().iter().position(|n| n == group).unwrap();
    let pixels = with.film.pixels();
    let (mut mean, mut var) = (Vec::new(), Vec::new());
    for (i, p) in pixels.iter().enumerate() {
        mean.extend(groups.mean(i, k));
        var.extend(groups.variance_of_mean(i, k, p.count));
    }
    let b = moments(alone);
    let a = compare((&mean, &var), (&b.0, &b.1), 1e-3);
    println!(
        "{label}: group {group} against its source alone: {} of {} values failing (worst z \
         {:.2}, threshold {:.2}), means {:.5} and {:.5} (z {:.2})",
        a.failing, a.pixels, a.worst_z, a.z_threshold, a.mean_a, a.mean_b, a.mean_z
    );
    assert!(a.mean_a > 0.0, "{label}: group {group} is black");
    assert_eq!(a.failing, 0, "{label}: {a:?}");
    assert!(a.mean_z < 4.0, "{label}: {a:?}");
}

/// The Cornell smoke: its bulb (a point light in the smoke) and its emissive ceiling.
#[test]
fn each_group_of_the_cornell_smoke_is_its_light_alone() {
    let scene = load_scene("cornell_smoke.gltf");
    let with = render(&scene, &settings(&scene, 512, true));
    let mut bulb_only = load_scene("cornell_smoke.gltf");
    for m in &mut bulb_only.materials {
        m.emission = [0.0; 3];
    }
    let mut surfaces_only = load_scene("cornell_smoke.gltf");
    for l in &mut surfaces_only.lights {
        l.intensity = [0.0; 3];
    }
    let spp = 512;
    let bulb = render(&bulb_only, &settings(&bulb_only, spp, false));
    let surfaces = render(&surfaces_only, &settings(&surfaces_only, spp, false));
    group_is_its_source_alone("cornell_smoke", &with, "light.bulb", &bulb);
    group_is_its_source_alone("cornell_smoke", &with, "surfaces", &surfaces);
}

/// The two-grid fire: the flame's medium and the sky.
#[test]
fn each_group_of_the_fire_is_its_source_alone() {
    let scene = load_scene("fire2.gltf");
    let with = render(&scene, &settings(&scene, 256, true));
    let mut flame_only = load_scene("fire2.gltf");
    flame_only.environment.radiance = [0.0; 3];
    let mut sky_only = load_scene("fire2.gltf");
    for m in &mut sky_only.vdb_media {
        m.emission_strength = 0.0;
        m.blackbody_intensity = 0.0;
    }
    let flame = render(&flame_only, &settings(&flame_only, 256, false));
    let sky = render(&sky_only, &settings(&sky_only, 256, false));
    group_is_its_source_alone("fire2", &with, "medium.flame", &flame);
    group_is_its_source_alone("fire2", &with, "environment", &sky);
}
