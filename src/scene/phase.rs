//! `BRUME_medium_vdb.phase`: the medium's phase function, an object naming its `type` and its
//! parameters (docs/BRUME_medium_vdb.md):
//!
//! ```json
//! {"type": "henyey-greenstein", "g": 0.3}
//! {"type": "two-lobe", "g1": 0.85, "g2": -0.3, "weight": 0.9}
//! {"type": "draine", "g": 0.6, "alpha": 1.0}
//! {"type": "mie", "diameter": 20.0}
//! {"type": "rayleigh"}
//! ```
use super::error::{Ctx, SceneError};
use super::json::Obj;
use crate::volume::phase::HenyeyGreenstein;
use crate::volume::phases::{Draine, Phase};

/// The phase types a scene may name.
pub const PHASE_TYPES: [&str; 5] = ["henyey-greenstein", "two-lobe", "draine", "mie", "rayleigh"];

/// The `phase` member of `obj` (a medium's extension), `None` when absent.
pub fn read_phase(ctx: &mut Ctx, obj: &Obj) -> Result<Option<Phase>, SceneError> {
    let Some(value) = obj.map.get("phase") else {
        return Ok(None);
    };
    let p = Obj::new(ctx, value, obj.at("phase"))?;
    let kind = p.string(ctx, "type")?.ok_or_else(|| {
        ctx.invalid(
            p.at("type"),
            format!("missing: one of {}", PHASE_TYPES.join(", ")),
        )
    })?;
    // A mean cosine strictly inside (-1, 1).
    let g = |ctx: &Ctx, key: &str| p.number(ctx, key, 0.0, -1.0, 1.0, true);
    let (phase, fields): (Phase, &[&str]) = match kind.as_str() {
        "henyey-greenstein" => (Phase::hg(g(ctx, "g")?), &["type", "g"]),
        "two-lobe" => (
            Phase::TwoLobe {
                a: HenyeyGreenstein::new(g(ctx, "g1")?),
                b: HenyeyGreenstein::new(g(ctx, "g2")?),
                w: p.number(ctx, "weight", 0.5, 0.0, 1.0, false)?,
            },
            &["type", "g1", "g2", "weight"],
        ),
        "draine" => (
            Phase::Draine(Draine::new(
                g(ctx, "g")?,
                p.number(ctx, "alpha", 1.0, -1.0, 1e4, false)?,
            )),
            &["type", "g", "alpha"],
        ),
        "mie" => {
            let at = p.at("diameter");
            if !p.map.contains_key("diameter") {
                return Err(ctx.invalid(at, "missing: the droplets' diameter in micrometres"));
            }
            let d = p.number(ctx, "diameter", 0.0, 0.0, 50.0, false)?;
            let phase = Phase::mie(d).ok_or_else(|| {
                ctx.invalid(
                    at,
                    format!("{d}: the fit covers diameters in (0, 50] micrometres"),
                )
            })?;
            (phase, &["type", "diameter"])
        }
        "rayleigh" => (Phase::Rayleigh, &["type"]),
        other => {
            return Err(ctx.invalid(
                p.at("type"),
                format!(
                    "'{other}' is not a phase function: one of {}",
                    PHASE_TYPES.join(", ")
                ),
            ))
        }
    };
    p.warn_unknown(ctx, fields);
    if obj.map.contains_key("anisotropy") {
        ctx.warn(
            obj.at("anisotropy"),
            "the phase object replaces it: ignored",
        );
    }
    Ok(Some(phase))
}
