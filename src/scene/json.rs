//! Checked readers for Brume's own extension objects, which gltf-json leaves as raw JSON.
//! Each reader names the JSON pointer of the field it rejects. JSON has no NaN literal and
//! serde_json refuses out-of-range literals such as `1e400`, but finite doubles like `1e300`
//! still overflow `f32` to infinity, so every number is checked for finiteness after narrowing.
use serde_json::{Map, Value};

use super::error::{Ctx, SceneError};

/// A JSON object together with the pointer it lives at.
pub struct Obj<'a> {
    pub map: &'a Map<String, Value>,
    pub pointer: String,
}

impl<'a> Obj<'a> {
    /// Wraps `value`, which must be a JSON object.
    pub fn new(ctx: &Ctx, value: &'a Value, pointer: String) -> Result<Self, SceneError> {
        match value.as_object() {
            Some(map) => Ok(Self { map, pointer }),
            None => Err(ctx.invalid(pointer, "expected a JSON object")),
        }
    }

    /// Pointer of member `key`.
    pub fn at(&self, key: &str) -> String {
        format!("{}/{}", self.pointer, key)
    }

    /// Warns about members not in `known`: a misspelt field would otherwise silently take its
    /// default.
    pub fn warn_unknown(&self, ctx: &mut Ctx, known: &[&str]) {
        for key in self.map.keys() {
            if !known.contains(&key.as_str()) && key != "extras" && key != "extensions" {
                ctx.warn(self.at(key), "unknown field, ignored");
            }
        }
    }

    /// Optional string.
    pub fn string(&self, ctx: &Ctx, key: &str) -> Result<Option<String>, SceneError> {
        match self.map.get(key) {
            None => Ok(None),
            Some(Value::String(s)) if !s.is_empty() => Ok(Some(s.clone())),
            Some(Value::String(_)) => Err(ctx.invalid(self.at(key), "must not be empty")),
            Some(_) => Err(ctx.invalid(self.at(key), "expected a string")),
        }
    }

    /// Optional boolean.
    pub fn boolean(&self, ctx: &Ctx, key: &str) -> Result<Option<bool>, SceneError> {
        match self.map.get(key) {
            None => Ok(None),
            Some(Value::Bool(b)) => Ok(Some(*b)),
            Some(_) => Err(ctx.invalid(self.at(key), "expected true or false")),
        }
    }

    /// Optional non-negative integer (an index into a top-level glTF array).
    pub fn index(&self, ctx: &Ctx, key: &str) -> Result<Option<usize>, SceneError> {
        match self.map.get(key) {
            None => Ok(None),
            Some(v) => match v.as_u64() {
                Some(i) => Ok(Some(i as usize)),
                None => Err(ctx.invalid(self.at(key), "expected a non-negative integer index")),
            },
        }
    }

    /// A finite number in `[lo, hi]` (`open` excludes both ends), `default` when absent.
    pub fn number(
        &self,
        ctx: &Ctx,
        key: &str,
        default: f32,
        lo: f32,
        hi: f32,
        open: bool,
    ) -> Result<f32, SceneError> {
        match self.map.get(key) {
            None => Ok(default),
            Some(v) => check_number(ctx, v, self.at(key), lo, hi, open),
        }
    }

    /// An RGB triple with each component finite and in `[lo, hi]`, `default` when absent.
    pub fn rgb(
        &self,
        ctx: &Ctx,
        key: &str,
        default: [f32; 3],
        lo: f32,
        hi: f32,
    ) -> Result<[f32; 3], SceneError> {
        let Some(v) = self.map.get(key) else {
            return Ok(default);
        };
        let Some(arr) = v.as_array() else {
            return Err(ctx.invalid(self.at(key), "expected an array of 3 numbers"));
        };
        if arr.len() != 3 {
            return Err(ctx.invalid(
                self.at(key),
                format!("expected 3 components, found {}", arr.len()),
            ));
        }
        let mut out = [0.0; 3];
        for (i, c) in arr.iter().enumerate() {
            out[i] = check_number(ctx, c, format!("{}/{}", self.at(key), i), lo, hi, false)?;
        }
        Ok(out)
    }
}

/// `v` as a finite `f32` within `[lo, hi]` (or `(lo, hi)` when `open`).
pub fn check_number(
    ctx: &Ctx,
    v: &Value,
    pointer: String,
    lo: f32,
    hi: f32,
    open: bool,
) -> Result<f32, SceneError> {
    let Some(x) = v.as_f64() else {
        return Err(ctx.invalid(pointer, "expected a number"));
    };
    let x = x as f32;
    if !x.is_finite() {
        return Err(ctx.invalid(pointer, format!("{v} is too large for a 32-bit float")));
    }
    let inside = if open {
        x > lo && x < hi
    } else {
        x >= lo && x <= hi
    };
    if !inside {
        let (a, b) = if open { ('(', ')') } else { ('[', ']') };
        return Err(ctx.invalid(pointer, format!("{x} is outside {a}{lo}, {hi}{b}")));
    }
    Ok(x)
}

/// Checks a value that gltf-json already narrowed to `f32`.
pub fn check_f32(
    ctx: &Ctx,
    x: f32,
    pointer: impl Into<String>,
    lo: f32,
    hi: f32,
) -> Result<f32, SceneError> {
    let pointer = pointer.into();
    if !x.is_finite() {
        return Err(ctx.invalid(
            pointer,
            format!("{x}: not finite as a 32-bit float (the value is out of range)"),
        ));
    }
    if x < lo || x > hi {
        return Err(ctx.invalid(
            pointer,
            format!("{x} is outside {}", range_text(lo, hi, false)),
        ));
    }
    Ok(x)
}

/// `[lo, hi]`, `(lo, hi)`, or `[lo, inf)` when `hi` is `f32::MAX` (no upper limit).
fn range_text(lo: f32, hi: f32, open: bool) -> String {
    let (a, b) = if open { ('(', ')') } else { ('[', ']') };
    let lo_text = if lo == f32::MIN {
        "-inf".to_string()
    } else {
        lo.to_string()
    };
    if hi == f32::MAX {
        format!("{a}{lo_text}, inf)")
    } else {
        format!("{a}{lo_text}, {hi}{b}")
    }
}

/// Checks every component with [`check_f32`], pointers `/0`, `/1`, ...
pub fn check_all<const N: usize>(
    ctx: &Ctx,
    xs: [f32; N],
    pointer: &str,
    lo: f32,
    hi: f32,
) -> Result<[f32; N], SceneError> {
    for (i, x) in xs.iter().enumerate() {
        check_f32(ctx, *x, format!("{pointer}/{i}"), lo, hi)?;
    }
    Ok(xs)
}
