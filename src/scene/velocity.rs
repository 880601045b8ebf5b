//! A medium's velocity grid (`BRUME_medium_vdb.velocityGrid`, `velocityScale`,
//! `velocityUnit`) and the shutter (`BRUME_render.shutter`): what velocity motion blur needs
//! of a scene.
//!
//! Blender's conventions, so a scale gives the same smear in Brume and Cycles
//! (`intern/cycles/blender/volume.cpp`, `scene/object.cpp`, `kernel/integrator/volume_shader.h`):
//! Cycles reads density at `P - (tau - 1/2) * s * v`, with `tau` in `[0, 1]` across the
//! shutter and `s` the object's velocity scale, which Blender sets to
//! `velocityScale * shutter / fps` for velocities per second and leaves at `velocityScale`
//! for velocities per frame. With a time offset `dt` in frames from the frame (the shutter's
//! centre for Cycles' "center" position), `tau - 1/2 = dt / shutter`, so the displacement
//! is `dt * factor * v` with `factor` of [`VelocityDesc::factor`].
use std::sync::Arc;

use super::error::{Ctx, SceneError};
use super::json::Obj;
use crate::volume::{self, GridLoadError, VectorGrid};

/// The time unit of a velocity grid's values (Blender's `velocity_unit`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VelocityUnit {
    /// World units per second (Blender's default; Mantaflow and Houdini bakes).
    Second,
    /// World units per frame.
    Frame,
}

impl VelocityUnit {
    pub fn name(self) -> &'static str {
        match self {
            VelocityUnit::Second => "second",
            VelocityUnit::Frame => "frame",
        }
    }
}

/// The shutter, in frames relative to the frame's time: each camera sample's time is uniform
/// in `[open, close]`. `{0, 0}` renders without blur.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shutter {
    pub open: f32,
    pub close: f32,
}

impl Shutter {
    pub const CLOSED: Shutter = Shutter {
        open: 0.0,
        close: 0.0,
    };

    /// Whether samples see more than one instant.
    pub fn is_open(&self) -> bool {
        self.close > self.open
    }

    /// The shutter's length in frames.
    pub fn length(&self) -> f32 {
        self.close - self.open
    }

    /// The largest `|dt|` of a sample.
    pub fn max_offset(&self) -> f32 {
        self.open.abs().max(self.close.abs())
    }

    /// The time offset of a sample at uniform `u` in `[0, 1)`.
    #[inline]
    pub fn time(&self, u: f32) -> f32 {
        self.open + u * (self.close - self.open)
    }

    /// Parses `OPEN,CLOSE` (frames around the frame time), as `--shutter` takes it.
    pub fn parse(s: &str) -> Result<Shutter, String> {
        let (a, b) = s.split_once(',').ok_or_else(|| {
            format!("expected OPEN,CLOSE in frames (such as -0.25,0.25), got {s:?}")
        })?;
        let num = |x: &str| {
            x.trim()
                .parse::<f32>()
                .ok()
                .filter(|v| v.is_finite() && v.abs() <= 1e4)
                .ok_or_else(|| format!("{x:?} is not a number of frames in [-10000, 10000]"))
        };
        Shutter::new(num(a)?, num(b)?)
    }

    /// A shutter from `open` to `close`, which may not come before `open`.
    pub fn new(open: f32, close: f32) -> Result<Shutter, String> {
        if close < open {
            return Err(format!(
                "the shutter closes ({close}) before it opens ({open})"
            ));
        }
        Ok(Shutter { open, close })
    }
}

/// A medium's velocity: its grid, read from the medium's file, and how to scale it.
#[derive(Clone, Debug)]
pub struct VelocityDesc {
    /// The grid's name in the medium's file (`velocityGrid`).
    pub grid_name: String,
    /// `velocityScale` (default 1).
    pub scale: f32,
    /// `velocityUnit` (default "second").
    pub unit: VelocityUnit,
    pub grid: Arc<VectorGrid>,
}

impl PartialEq for VelocityDesc {
    fn eq(&self, o: &Self) -> bool {
        self.grid_name == o.grid_name
            && self.scale == o.scale
            && self.unit == o.unit
            && Arc::ptr_eq(&self.grid, &o.grid)
    }
}

impl VelocityDesc {
    /// Displacement per frame of time offset per unit of velocity under `shutter` at `fps`
    /// (see the module docs): `scale / fps` for velocities per second, `scale / shutter` for
    /// velocities per frame (Blender's reading: a velocity per frame smears by `scale * v`
    /// over the whole shutter, whatever its length); 0 with a closed shutter.
    pub fn factor(&self, shutter: Shutter, fps: f32) -> f32 {
        if !shutter.is_open() {
            return 0.0;
        }
        match self.unit {
            VelocityUnit::Second => self.scale / fps,
            VelocityUnit::Frame => self.scale / shutter.length(),
        }
    }
}

/// The members of `BRUME_medium_vdb` this module reads.
pub const FIELDS: &[&str] = &["velocityGrid", "velocityScale", "velocityUnit"];

/// Reads the medium's velocity members and loads its velocity grid from `path` (the medium's
/// file); `None` without `velocityGrid`.
pub fn read_velocity(
    ctx: &mut Ctx,
    obj: &Obj,
    path: &std::path::Path,
) -> Result<Option<VelocityDesc>, SceneError> {
    let scale = obj.number(ctx, "velocityScale", 1.0, 0.0, 1e6, false)?;
    let unit = match obj.string(ctx, "velocityUnit")?.as_deref() {
        None | Some("second") => VelocityUnit::Second,
        Some("frame") => VelocityUnit::Frame,
        Some(other) => {
            return Err(ctx.invalid(
                obj.at("velocityUnit"),
                format!("'{other}' is not one of second, frame"),
            ))
        }
    };
    let Some(grid_name) = obj.string(ctx, "velocityGrid")? else {
        for key in ["velocityScale", "velocityUnit"] {
            if obj.map.contains_key(key) {
                ctx.warn(
                    obj.at(key),
                    "no velocityGrid: the medium has no velocity blur",
                );
            }
        }
        return Ok(None);
    };
    let grid = volume::load_scene_vector_grid(path, &grid_name).map_err(|e| {
        let msg = match e {
            GridLoadError::File(m) | GridLoadError::Grid(m) => m,
        };
        ctx.invalid(
            obj.at("velocityGrid"),
            format!("grid {grid_name:?} in {}: {msg}", path.display()),
        )
    })?;
    Ok(Some(VelocityDesc {
        grid_name,
        scale,
        unit,
        grid: Arc::new(grid),
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shutters_parse_and_refuse() {
        assert_eq!(
            Shutter::parse("-0.25,0.25").unwrap(),
            Shutter {
                open: -0.25,
                close: 0.25
            }
        );
        assert!(!Shutter::parse("0,0").unwrap().is_open());
        for bad in ["0.5", "1,0", "a,b", "nan,1", "0,1e9"] {
            assert!(Shutter::parse(bad).is_err(), "{bad}");
        }
        let s = Shutter::parse("-0.5,0.25").unwrap();
        assert_eq!(s.max_offset(), 0.5);
        assert_eq!(s.time(0.0), -0.5);
    }
}
