//! The properties every fuzz input must keep: a clear error naming the file, or a valid result
//! (a grid whose bounds validate and whose values are finite and non-negative; a scene that
//! validates and renders finite; an environment map of finite, non-negative pixels).
use std::path::Path;

use brume::volume::{load_grid_from, ConversionPolicy};
use brume_ffi::VdbFile;

use super::{set_stage, STAGE_OPENVDB_READER};

/// What one input did: loaded, refused with an error, or broke a property (`Err`).
pub(crate) enum Verdict {
    Accepted,
    Refused,
    /// Refused because OpenVDB's reader crashed or hung on it (in its own process).
    ReaderCrashed,
}

pub(crate) fn check_vdb(path: &Path) -> Result<Verdict, String> {
    let shown = path.display().to_string();
    set_stage(STAGE_OPENVDB_READER);
    let opened = VdbFile::open(path);
    set_stage("brume");
    let file = match opened {
        Ok(f) => f,
        Err(e) => {
            let msg = e.to_string();
            return if msg.contains(&shown) && msg.len() > shown.len() + 2 {
                Ok(if e.kind == brume_ffi::VdbErrorKind::ReaderCrashed {
                    Verdict::ReaderCrashed
                } else {
                    Verdict::Refused
                })
            } else {
                Err(format!("unclear error: {msg:?}"))
            };
        }
    };
    let policy = ConversionPolicy { max_cells: 1 << 22 };
    let mut any = false;
    let names: Vec<String> = file.grids().iter().map(|g| g.name.clone()).collect();
    for name in names.iter().take(8) {
        match load_grid_from(&file, name, policy) {
            Ok(g) => {
                any = true;
                let finite = |v: &f32| v.is_finite() && *v >= 0.0;
                if !(g.grid.bricks.iter().all(finite)
                    && g.grid.constants.iter().all(finite)
                    && finite(&g.grid.background))
                {
                    return Err(format!(
                        "grid {name:?}: non-finite or negative value accepted"
                    ));
                }
                g.bounds
                    .validate(&g.grid, 64)
                    .map_err(|e| format!("grid {name:?}: bounds invalid: {e}"))?;
                let b = g.grid.index_bounds();
                if !b.is_empty() {
                    let c = (b.min + b.max) * 0.5;
                    let v = g.grid.sample_trilinear(c.as_dvec3());
                    if !v.is_finite() {
                        return Err(format!("grid {name:?}: lookup {v}"));
                    }
                }
            }
            Err(e) => {
                let msg = e.to_string();
                if !(msg.contains(&shown) && msg.len() > shown.len() + 2) {
                    return Err(format!("grid {name:?}: unclear error {msg:?}"));
                }
            }
        }
    }
    Ok(if any {
        Verdict::Accepted
    } else {
        Verdict::Refused
    })
}

pub(crate) fn check_gltf(path: &Path) -> Result<Verdict, String> {
    let scene = match brume::scene::load(path) {
        Ok(s) => s,
        Err(e) => {
            let msg = e.to_string();
            return if msg.trim().is_empty() {
                Err("empty error message".into())
            } else {
                Ok(Verdict::Refused)
            };
        }
    };
    scene
        .validate()
        .map_err(|e| format!("accepted scene does not validate: {e}"))?;
    for m in &scene.vdb_media {
        let in01 = |c: &[f32; 3]| c.iter().all(|x| (0.0..=1.0).contains(x));
        let ok = m.density_scale.is_finite()
            && m.density_scale >= 0.0
            && in01(&m.color)
            && in01(&m.absorption_color)
            && in01(&m.emission_color)
            && in01(&m.blackbody_tint)
            && m.anisotropy > -1.0
            && m.anisotropy < 1.0
            && m.emission_strength.is_finite()
            && m.temperature_scale.is_finite()
            && m.temperature_offset.is_finite()
            && m.sigma_t_per_density().iter().all(|x| x.is_finite());
        if !ok {
            return Err(format!("accepted out-of-range medium parameters: {m:?}"));
        }
    }
    // A tiny render of what was accepted must be finite.
    let settings = brume::render::RenderSettings {
        width: 2,
        height: 2,
        spp: 1,
        max_depth: 4,
        tile_size: 2,
        ..Default::default()
    };
    let rs = brume::render::RenderScene::new(&scene, false)
        .map_err(|e| format!("accepted scene cannot be prepared: {e}"))?;
    let out = brume::backend::cpu::render(
        &rs,
        &settings,
        &std::sync::atomic::AtomicBool::new(false),
        &|_, _, _| {},
    );
    for y in 0..2 {
        for x in 0..2 {
            let v = out.film.mean(x, y);
            if !(v[0].is_finite() && v[1].is_finite() && v[2].is_finite()) {
                return Err(format!("accepted scene renders {v:?}"));
            }
        }
    }
    Ok(Verdict::Accepted)
}

/// An environment map: refused with a message, or decoded into finite, non-negative pixels of
/// the size it claims, whose light samples and lookups are finite.
pub(crate) fn check_envmap(path: &Path) -> Result<Verdict, String> {
    use brume::render::envmap::EnvLight;
    let decoded = match brume::scene::envmap::read_environment_image(path) {
        Ok(d) => d,
        Err(e) => {
            return if e.trim().is_empty() {
                Err("empty error message".into())
            } else {
                Ok(Verdict::Refused)
            };
        }
    };
    let img = decoded.image;
    if img.width == 0 || img.height == 0 || img.rgb.len() != (img.width * img.height) as usize {
        return Err(format!(
            "accepted a {}x{} image with {} pixels",
            img.width,
            img.height,
            img.rgb.len()
        ));
    }
    if !img.rgb.iter().flatten().all(|c| c.is_finite() && *c >= 0.0) {
        return Err("accepted a non-finite or negative pixel".into());
    }
    let env = brume::scene::Environment {
        radiance: [1.0; 3],
        map: None,
        image: Some(std::sync::Arc::new(img)),
        rotation: [0.3, 0.2, 0.1],
    };
    if let Some(light) = EnvLight::new(&env) {
        for k in 0..16 {
            let u = glam::Vec2::new((k as f32 + 0.5) / 16.0, ((k * 7) % 16) as f32 / 16.0);
            if let Some(s) = light.sample(u) {
                let ok = s.le.is_finite() && s.pdf.is_finite() && s.pdf > 0.0;
                if !ok || !light.le(s.wi).is_finite() || !light.pdf(s.wi).is_finite() {
                    return Err(format!("light sample {s:?}"));
                }
            }
        }
    }
    Ok(Verdict::Accepted)
}
