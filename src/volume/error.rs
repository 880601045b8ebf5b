//! Why a volume could not be built. Every message names the numbers a user needs to act on.
use thiserror::Error;

/// Errors from converting OpenVDB data into a [`SparseGrid`](super::SparseGrid).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum VolumeError {
    /// NaN or infinite densities have no physical meaning and would poison every majorant
    /// they touch, so the whole grid is refused rather than silently patched.
    #[error(
        "{count} non-finite value(s) (NaN or Inf) in the grid; first at index coordinate \
         {first:?} ({what}, value {value})"
    )]
    NonFinite {
        count: u64,
        first: [i32; 3],
        what: &'static str,
        value: f32,
    },

    /// The dense leaf-resolution index would need more cells than the configured limit.
    #[error(
        "dense cell index of {dims:?} = {cells} cells exceeds the limit of {limit} cells \
         (each cell is 8^3 voxels; a 4096^3 root tile alone needs 512^3 cells)"
    )]
    TooManyCells {
        dims: [u64; 3],
        cells: u64,
        limit: u64,
    },

    #[error("{what} count {count} does not fit the 31-bit cell entry")]
    IndexOverflow { what: &'static str, count: usize },

    #[error("leaf origin {origin:?} is not a multiple of 8 on every axis")]
    MisalignedLeaf { origin: [i32; 3] },

    #[error("tile at {origin:?} has dimension {dim}, which is not a positive multiple of 8")]
    BadTile { origin: [i32; 3], dim: u32 },

    #[error("dense block of {dims:?} voxels was given {got} values")]
    DenseSize { dims: [usize; 3], got: usize },

    #[error("index-to-world transform rejected: {0}")]
    Transform(String),
}

/// Counts the non-finite values a check meets and keeps the first, for
/// [`VolumeError::NonFinite`].
#[derive(Debug, Default)]
pub(crate) struct NonFiniteTally {
    count: u64,
    first: Option<([i32; 3], &'static str, f32)>,
}

impl NonFiniteTally {
    /// Notes `value` at index coordinate `at`; `what` says where it is stored.
    pub fn note(&mut self, value: f32, at: [i32; 3], what: &'static str) {
        if !value.is_finite() {
            self.count += 1;
            self.first.get_or_insert((at, what, value));
        }
    }

    /// `Ok` when every value was finite, else the error with the count and the first.
    pub fn finish(self) -> Result<(), VolumeError> {
        match self.first {
            None => Ok(()),
            Some((first, what, value)) => Err(VolumeError::NonFinite {
                count: self.count,
                first,
                what,
                value,
            }),
        }
    }
}
