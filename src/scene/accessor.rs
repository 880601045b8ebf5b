//! Accessor checks before any read: the gltf crate's readers panic on an accessor whose
//! bytes run past its buffer view, so every accessor is checked first.
use gltf::accessor::{DataType, Dimensions};

use super::error::{Ctx, SceneError};

/// Checks an accessor's type and that its bytes lie inside its buffer view, because the gltf
/// crate's readers would otherwise panic on a short slice.
pub fn check_accessor(
    ctx: &Ctx,
    acc: &gltf::Accessor,
    pointer: &str,
    types: &[DataType],
    dims: Dimensions,
) -> Result<(), SceneError> {
    let here = format!("/accessors/{}", acc.index());
    if acc.sparse().is_some() {
        return Err(ctx.invalid(
            here,
            format!("used by {pointer}: sparse accessors are not supported"),
        ));
    }
    if !types.contains(&acc.data_type()) || acc.dimensions() != dims {
        return Err(ctx.invalid(
            here,
            format!(
                "used by {pointer}: expected {dims:?} of {types:?}, found {:?} of {:?}",
                acc.dimensions(),
                acc.data_type()
            ),
        ));
    }
    let Some(view) = acc.view() else {
        return Err(ctx.invalid(
            here,
            format!("used by {pointer}: accessor has no bufferView"),
        ));
    };
    let elem = acc.size();
    let stride = view.stride().unwrap_or(elem);
    // Checked: a hostile `count` must not wrap around and pass the test.
    let need = match acc.count() {
        0 => Some(0),
        n => stride
            .checked_mul(n - 1)
            .and_then(|x| x.checked_add(acc.offset()))
            .and_then(|x| x.checked_add(elem)),
    };
    let Some(need) = need else {
        return Err(ctx.invalid(
            here,
            format!("used by {pointer}: count {} overflows", acc.count()),
        ));
    };
    if need > view.length() {
        return Err(ctx.invalid(
            here,
            format!(
                "used by {pointer}: needs {need} bytes of bufferView {} but it has {}",
                view.index(),
                view.length()
            ),
        ));
    }
    Ok(())
}
