//! The part header of a render's output: what a merge or a resume
//! needs to know about the render, and the checks a resume makes against its checkpoint.
use std::path::Path;

use anyhow::{anyhow, Result};

use crate::backend::cpu;
use crate::farm::{self, Coverage, PartInfo};
use crate::film::{AttrValue, Metadata, RenderInfo};
use crate::render::RenderSettings;

/// Header attribute of an adaptively sampled render: its noise threshold (a pixel may then
/// hold fewer samples than its coverage).
pub const NOISE_THRESHOLD_ATTRIBUTE: &str = "brume:noise_threshold";

/// What the header of a part needs that the settings do not hold: the scene's content hash,
/// the camera, the Brume version.
pub struct PartContext {
    scene: String,
    scene_hash: String,
    settings_key: String,
}

impl PartContext {
    /// The context of a render of `scene` at `frame` with `settings` through `camera` (a glTF
    /// camera's name, or the scene's default) under `shutter` (the scene's, or `--shutter`'s:
    /// an open one is part of the key, since the command line can change it).
    pub fn new(
        scene: &Path,
        frame: i32,
        settings: &RenderSettings,
        camera: Option<&str>,
        shutter: crate::scene::Shutter,
    ) -> Result<Self> {
        let mut settings_key = farm::settings_key(settings, camera);
        if shutter.is_open() {
            settings_key += &format!(" shutter={},{}", shutter.open, shutter.close);
        }
        Ok(Self {
            scene: scene.display().to_string(),
            scene_hash: farm::scene_hash(scene, frame)?,
            settings_key,
        })
    }

    /// The header of a render of `settings` that holds `spp` samples of its range so far.
    #[allow(clippy::too_many_arguments)]
    pub fn metadata(
        &self,
        settings: &RenderSettings,
        spp: u32,
        seconds: f64,
        backend: &str,
        gpu_variant: Option<&str>,
        interrupted: bool,
        features: crate::render::FeatureFlags,
    ) -> Metadata {
        let info = RenderInfo {
            estimator: settings.estimator.name().to_string(),
            b: settings.b,
            m: settings.m_or_default().unwrap_or(f32::NAN),
            majorant_mode: settings.majorant.name().to_string(),
            spp,
            seconds,
            seed: settings.seed as u64,
            scene: self.scene.clone(),
            backend: backend.to_string(),
        };
        let mut meta = info.to_metadata();
        meta.set("brume:features", AttrValue::Text(features.name()));
        meta.set(
            "brume:absorption",
            AttrValue::Text(settings.absorption.name().to_string()),
        );
        meta.set(
            "brume:light_selection",
            AttrValue::Text(settings.light_selection.name().to_string()),
        );
        meta.set(
            "brume:rr_throughput",
            AttrValue::Float(settings.rr_throughput),
        );
        meta.set(
            "brume:sampler",
            AttrValue::Text(settings.sampler.name().into()),
        );
        let film = if settings.film_transparent {
            crate::film::exr_io::FILM_TRANSPARENT
        } else {
            "opaque"
        };
        meta.set(
            crate::film::exr_io::FILM_ATTRIBUTE,
            AttrValue::Text(film.into()),
        );
        if settings.blackbody != crate::render::BlackbodyModel::Temperature {
            let model = settings.blackbody.name().into();
            meta.set("brume:blackbody", AttrValue::Text(model));
        }
        let sampling = settings.volume_sampling.name().into();
        meta.set("brume:volume_sampling", AttrValue::Text(sampling));
        if let Some(e) = settings.noise_threshold {
            meta.set(NOISE_THRESHOLD_ATTRIBUTE, AttrValue::Float(e));
            meta.set("brume:min_spp", AttrValue::Int(settings.min_spp as i32));
        }
        if let Some(v) = gpu_variant {
            // The WGSL variant the wavefront kernels were specialised for.
            meta.set("brume:gpu_variant", AttrValue::Text(v.to_string()));
        }
        meta.set(
            "brume:specialised",
            AttrValue::Text((!settings.generic).to_string()),
        );
        meta.set(
            "brume:interrupted",
            AttrValue::Text(interrupted.to_string()),
        );
        let (start, end) = (settings.sample_start, settings.spp);
        let region = settings
            .region
            .unwrap_or([0, 0, settings.width, settings.height]);
        PartInfo {
            scene_hash: self.scene_hash.clone(),
            settings: self.settings_key.clone(),
            seed: settings.seed.to_string(),
            version: env!("CARGO_PKG_VERSION").to_string(),
            width: settings.width,
            height: settings.height,
            coverage: vec![Coverage {
                start,
                end: start + spp,
                region,
            }],
            // A time-limited render (spp 0) has no end to continue to.
            target: (end != 0).then_some((start, end)),
            seconds,
            parts: 1,
        }
        .write_into(&mut meta);
        meta
    }

    /// Reads a checkpoint to continue: same scene, settings, seed, version and size; one
    /// sample range starting where this render starts, over the same region. Returns its
    /// render seconds and where to pick up.
    pub fn resume_from(
        &self,
        path: &Path,
        settings: &RenderSettings,
    ) -> Result<(f64, cpu::Resume)> {
        let p = farm::read_part(path)?;
        let here = self.metadata(
            settings,
            0,
            0.0,
            "",
            None,
            false,
            crate::render::FeatureFlags::ALL,
        );
        let mine = PartInfo::from_metadata(Path::new("(this render)"), &here)?;
        mine.check_same_image(Path::new("this render"), &p.info, path)?;
        let region = mine.coverage[0].region;
        let reached = match p.info.coverage[..] {
            [c] if c.start == settings.sample_start && c.region == region => c.end,
            [] if settings.sample_start == 0 => 0,
            _ => {
                return Err(anyhow!(
                    "{}: holds samples {} but this render covers {}..{}@{},{},{},{}: not its checkpoint",
                    path.display(),
                    p.metadata.text("brume:coverage").unwrap_or(""),
                    settings.sample_start,
                    settings.spp,
                    region[0],
                    region[1],
                    region[2],
                    region[3]
                ))
            }
        };
        if settings.spp != 0 && reached > settings.spp {
            return Err(anyhow!(
                "{}: reached sample {reached}, past this render's end {}",
                path.display(),
                settings.spp
            ));
        }
        Ok((
            p.info.seconds,
            cpu::Resume {
                film: p.film,
                reached,
            },
        ))
    }
}
