//! Plain Rust data read out of OpenVDB. Nothing here refers to a C++ type: the safe wrapper
//! converts into these at once, so no OpenVDB type leaves this crate.

/// Voxels per leaf edge in OpenVDB's default 5-4-3 tree (and in Brume's bricks).
pub const LEAF_DIM: i32 = 8;
/// Voxels per leaf.
pub const LEAF_VOXELS: usize = 512;

/// OpenVDB's grid class, which says how values are meant to be read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GridClass {
    /// Signed distances: negative inside, `background` is the narrow-band half-width.
    LevelSet,
    /// Densities, zero (background) outside.
    FogVolume,
    Staggered,
    Unknown,
}

/// Everything Brume needs to know about one grid before (or without) reading its voxels.
#[derive(Clone, Debug)]
pub struct GridInfo {
    pub name: String,
    /// OpenVDB's value type name: "float", "double", "vec3s", "int32", ...
    pub value_type: String,
    pub class: GridClass,
    /// Voxel edge lengths along the index axes, in world units.
    pub voxel_size: [f64; 3],
    /// Row-major 4x4 matrix mapping index space to world space, with OpenVDB's convention that
    /// voxel `(i, j, k)` has its centre at index-space point `(i, j, k)`. Only meaningful when
    /// `is_affine`; see `transform_error`.
    pub world_from_index: [[f64; 4]; 4],
    /// `false` for frustum and other non-linear maps, which Brume rejects.
    pub is_affine: bool,
    /// Inclusive index-space bounding box of the active voxels (tiles included), or `None` for
    /// a grid with no active values.
    pub active_bbox: Option<([i32; 3], [i32; 3])>,
    pub active_voxel_count: u64,
    pub leaf_count: u64,
    /// Tiles of the upper tree levels (active or holding a non-background value).
    pub tile_count: u64,
    /// The background value for scalar grids (`None` for vector and other types).
    pub background: Option<f64>,
    /// The grid's own metadata, stringified: `(name, type, value)`.
    pub metadata: Vec<(String, String, String)>,
}

/// One 8^3 leaf node exactly as OpenVDB stores it.
#[derive(Clone, Debug, PartialEq)]
pub struct Leaf {
    /// Index-space coordinate of voxel (0, 0, 0) of the leaf; a multiple of 8 on each axis.
    pub origin: [i32; 3],
    /// Values in OpenVDB's leaf order: `offset = (x << 6) | (y << 3) | z` for local
    /// coordinates `x, y, z` in `0..8` (x slowest). Inactive voxels keep their stored value,
    /// because OpenVDB's samplers read it too.
    pub values: Box<[f32; LEAF_VOXELS]>,
    /// Active-state bits, bit `offset % 64` of word `offset / 64`.
    pub active: [u64; 8],
}

/// A constant region of an upper tree level (internal nodes or the root).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tile {
    /// Index-space coordinate of the tile's minimum corner voxel.
    pub origin: [i32; 3],
    /// Edge length in voxels: 128 or 4096 in a 5-4-3 tree (always a multiple of 8).
    pub dim: u32,
    pub value: f32,
    pub active: bool,
}

/// A float grid read completely: every leaf and every tile that is active or differs from the
/// background. Values anywhere else equal `background`.
#[derive(Clone, Debug)]
pub struct FloatGridData {
    pub info: GridInfo,
    pub background: f32,
    pub leaves: Vec<Leaf>,
    pub tiles: Vec<Tile>,
}

impl Leaf {
    /// OpenVDB's linear offset of local voxel `(x, y, z)`.
    #[inline]
    pub fn offset(x: usize, y: usize, z: usize) -> usize {
        (x << 6) | (y << 3) | z
    }

    #[inline]
    pub fn is_active(&self, offset: usize) -> bool {
        self.active[offset >> 6] >> (offset & 63) & 1 == 1
    }
}

/// One 8^3 leaf of a Vec3 grid exactly as OpenVDB stores it (in single precision).
#[derive(Clone, Debug, PartialEq)]
pub struct Vec3Leaf {
    /// Index-space coordinate of voxel (0, 0, 0) of the leaf; a multiple of 8 on each axis.
    pub origin: [i32; 3],
    /// `(x, y, z)` vectors in OpenVDB's leaf order (see [`Leaf::values`]), inactive voxels
    /// included.
    pub values: Box<[[f32; 3]; LEAF_VOXELS]>,
    /// Active-state bits, bit `offset % 64` of word `offset / 64`.
    pub active: [u64; 8],
}

/// A constant vector over a region of an upper tree level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vec3Tile {
    /// Index-space coordinate of the tile's minimum corner voxel.
    pub origin: [i32; 3],
    /// Edge length in voxels (a multiple of 8).
    pub dim: u32,
    pub value: [f32; 3],
    pub active: bool,
}

/// A Vec3 grid (`vec3s`, or `vec3d` rounded to single precision) read completely: every leaf,
/// every tile that is active or differs from the background, in the same order as a float
/// grid's. Values anywhere else equal `background`. `info.class` says whether the components
/// are cell-centred or staggered (MAC: component `a` sits on the voxel's lower face along `a`).
#[derive(Clone, Debug)]
pub struct Vec3GridData {
    pub info: GridInfo,
    pub background: [f32; 3],
    pub leaves: Vec<Vec3Leaf>,
    pub tiles: Vec<Vec3Tile>,
}
