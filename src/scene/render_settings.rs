//! Brume's scene-level render settings, `BRUME_render`: defaults a scene file carries for its
//! own render (the command line overrides each one), so a study or a comparison can ship its
//! estimator parameters with the scene, as the seed paper's scenes do.
//!
//! ```json
//! "extensions": { "BRUME_render": {
//!     "estimator": "weighted-delta", "b": 0.75, "m": 0.02, "majorant": "local",
//!     "spp": 64, "width": 320, "height": 240, "maxDepth": 256, "seed": 0,
//!     "sampler": "sobol", "frame": 1, "fps": 24,
//!     "frameRange": [1, 240], "shutter": { "open": -0.25, "close": 0.25 } } }
//! ```
use super::error::{Ctx, SceneError};
use super::json::Obj;

pub const BRUME_RENDER: &str = "BRUME_render";

/// Every field is optional; `None` leaves Brume's default.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneRenderSettings {
    /// "delta", "weighted-delta", "decomposition" or "weighted-decomposition" (checked here).
    pub estimator: Option<String>,
    pub b: Option<f32>,
    pub m: Option<f32>,
    /// "global", "leaf", "adaptive" or "local" (an alias of "adaptive").
    pub majorant: Option<String>,
    pub spp: Option<u32>,
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub max_depth: Option<u32>,
    pub seed: Option<u32>,
    /// "sobol" or "independent".
    pub sampler: Option<String>,
    /// The frame a sequence's files are read for (`uri` with a run of `#`) unless the command
    /// line picks one.
    pub frame: Option<i32>,
    /// Frames per second: frame `f` is time `f / fps` of the file's animations.
    pub fps: Option<f32>,
    /// The shot's frames, `[first, last]` (both included): what `--frames scene` renders.
    pub frame_range: Option<(i32, i32)>,
    /// The shutter, `{ "open": -0.25, "close": 0.25 }` in frames around the frame's time.
    pub shutter: Option<super::velocity::Shutter>,
    /// `filmTransparent`: leave the environment seen straight through out of the colour.
    pub film_transparent: Option<bool>,
    /// `blackbody`: "temperature" or "voxels" (`render::settings::BlackbodyModel`).
    pub blackbody: Option<String>,
}

const ESTIMATORS: [&str; 4] = [
    "delta",
    "weighted-delta",
    "decomposition",
    "weighted-decomposition",
];

pub fn read_render_settings(
    ctx: &mut Ctx,
    doc: &gltf::Document,
) -> Result<SceneRenderSettings, SceneError> {
    let Some(value) = doc.extension_value(BRUME_RENDER) else {
        return Ok(SceneRenderSettings::default());
    };
    let obj = Obj::new(ctx, value, format!("/extensions/{BRUME_RENDER}"))?;
    obj.warn_unknown(
        ctx,
        &[
            "estimator",
            "b",
            "m",
            "majorant",
            "spp",
            "width",
            "height",
            "maxDepth",
            "seed",
            "sampler",
            "frame",
            "fps",
            "shutter",
            "frameRange",
            "filmTransparent",
            "blackbody",
        ],
    );
    let choice = |ctx: &Ctx, key: &str, allowed: &[&str]| -> Result<Option<String>, SceneError> {
        match obj.string(ctx, key)? {
            Some(s) if !allowed.contains(&s.as_str()) => Err(ctx.invalid(
                obj.at(key),
                format!("'{s}' is not one of {}", allowed.join(", ")),
            )),
            other => Ok(other),
        }
    };
    let present = |key: &str| obj.map.contains_key(key);
    // A number in [lo, hi] (above lo with `open`), when present.
    let number = |ctx: &Ctx, key: &str, lo: f32, hi: f32, open: bool| {
        present(key)
            .then(|| obj.number(ctx, key, lo, lo, hi, open))
            .transpose()
    };
    // A whole number in [lo, hi], when present.
    let whole = |ctx: &Ctx, key: &str, lo: f32, hi: f32| -> Result<Option<f32>, SceneError> {
        let v = number(ctx, key, lo, hi, false)?;
        match v {
            Some(v) if v.fract() != 0.0 => {
                Err(ctx.invalid(obj.at(key), format!("expected a whole number, got {v}")))
            }
            v => Ok(v),
        }
    };
    let count = |ctx: &Ctx, key: &str, max: f32| Ok(whole(ctx, key, 0.0, max)?.map(|v| v as u32));
    Ok(SceneRenderSettings {
        estimator: choice(ctx, "estimator", &ESTIMATORS)?,
        b: number(ctx, "b", 0.0, f32::MAX, true)?,
        m: number(ctx, "m", 0.0, f32::MAX, false)?,
        majorant: choice(ctx, "majorant", &["global", "leaf", "adaptive", "local"])?,
        spp: count(ctx, "spp", 1e7)?,
        width: count(ctx, "width", 32768.0)?.filter(|&w| w > 0),
        height: count(ctx, "height", 32768.0)?.filter(|&h| h > 0),
        max_depth: count(ctx, "maxDepth", 1e6)?,
        seed: count(ctx, "seed", u32::MAX as f32)?,
        sampler: choice(ctx, "sampler", &["sobol", "independent"])?,
        frame: whole(ctx, "frame", -1e6, 1e6)?.map(|f| f as i32),
        fps: number(ctx, "fps", 0.0, 1e6, true)?,
        shutter: read_shutter(ctx, &obj)?,
        frame_range: read_frame_range(ctx, &obj)?,
        film_transparent: obj.boolean(ctx, "filmTransparent")?,
        blackbody: choice(ctx, "blackbody", &["temperature", "voxels"])?,
    })
}

/// `frameRange`: `[first, last]`, whole numbers, `first <= last`.
fn read_frame_range(ctx: &Ctx, obj: &Obj) -> Result<Option<(i32, i32)>, SceneError> {
    let Some(value) = obj.map.get("frameRange") else {
        return Ok(None);
    };
    let bad = || {
        ctx.invalid(
            obj.at("frameRange"),
            "expected [first, last]: two whole frame numbers, first <= last",
        )
    };
    let frame = |v: &serde_json::Value| {
        v.as_i64()
            .filter(|f| f.abs() <= 1_000_000)
            .map(|f| f as i32)
    };
    match value.as_array().map(|a| a.as_slice()) {
        Some([a, b]) => match (frame(a), frame(b)) {
            (Some(a), Some(b)) if a <= b => Ok(Some((a, b))),
            _ => Err(bad()),
        },
        _ => Err(bad()),
    }
}

/// `shutter`: `open` and `close` in frames around the frame's time, `open <= close`.
fn read_shutter(ctx: &mut Ctx, obj: &Obj) -> Result<Option<super::velocity::Shutter>, SceneError> {
    let Some(value) = obj.map.get("shutter") else {
        return Ok(None);
    };
    let s = Obj::new(ctx, value, obj.at("shutter"))?;
    s.warn_unknown(ctx, &["open", "close"]);
    let open = s.number(ctx, "open", -0.25, -1e4, 1e4, false)?;
    let close = s.number(ctx, "close", 0.25, -1e4, 1e4, false)?;
    super::velocity::Shutter::new(open, close)
        .map(Some)
        .map_err(|why| ctx.invalid(obj.at("shutter"), why))
}
