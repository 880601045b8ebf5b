//! OpenVDB data ([`FloatGridData`]) into Brume's [`SparseGrid`], with the bad-value policy.
//!
//! # Policy for bad values
//! * **NaN or Inf** anywhere that a lookup can read (any leaf voxel, active or not, any tile,
//!   the background) is an error, [`VolumeError::NonFinite`], naming how many there are and the
//!   index coordinate of the first one met (leaves in order, then tiles). A density cannot be
//!   NaN, and a patched value would hide a broken simulation.
//! * **Negative** values are clamped to 0: extinction cannot be negative, but small negative
//!   densities are a common artefact of advection and filtering, so they are not fatal. The
//!   caller gets their count, the most negative value and a warning in the
//!   [`ConversionReport`]; the library never prints.
//! * **Size**: the dense cell index is refused beyond [`ConversionPolicy::max_cells`]
//!   ([`VolumeError::TooManyCells`]) instead of exhausting memory.
use std::collections::HashMap;

use brume_ffi::{FloatGridData, GridClass, GridInfo, Leaf, LEAF_DIM, LEAF_VOXELS};

use super::error::{NonFiniteTally, VolumeError};
use super::grid::{SparseGrid, BRICK_VOXELS, CONSTANT_BIT, DEFAULT_MAX_CELLS};
use crate::math::{DAffine3, DMat4, DVec3, IndexBox};

/// Limits applied while converting.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ConversionPolicy {
    /// Largest dense cell index accepted (cells of 8^3 voxels, padding included).
    pub max_cells: u64,
}

impl Default for ConversionPolicy {
    fn default() -> Self {
        Self {
            max_cells: DEFAULT_MAX_CELLS,
        }
    }
}

/// What conversion changed or noticed, for the caller to log.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ConversionReport {
    /// Leaf voxels (active or not) that were negative and clamped to 0.
    pub negative_voxels: u64,
    /// Tiles that were negative and clamped to 0.
    pub negative_tiles: u64,
    /// Whether the background itself was negative (then clamped to 0).
    pub negative_background: bool,
    /// The most negative value seen (0 when none).
    pub most_negative: f32,
    /// Index coordinate of the first negative value met.
    pub first_negative: Option<[i32; 3]>,
    /// Leaves whose 512 values were all equal, stored as constant cells without a brick.
    pub uniform_leaves: u64,
    /// Tiles equal to the background, which need no cells of their own.
    pub background_tiles: u64,
    /// Human-readable warnings, one per kind of issue.
    pub warnings: Vec<String>,
}

impl ConversionReport {
    fn note_negative(&mut self, value: f32, at: [i32; 3]) {
        self.most_negative = self.most_negative.min(value);
        self.first_negative.get_or_insert(at);
    }
}

/// Clamp policy for one finite value; `-0.0` becomes `+0.0` so constants deduplicate by bits.
#[inline]
fn clamp_density(v: f32) -> f32 {
    if v < 0.0 {
        0.0
    } else {
        v + 0.0
    }
}

/// What conversion does to each finite value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum ValueRule {
    /// Densities: negatives clamped to 0 and reported ([`clamp_density`]).
    Density,
    /// Signed quantities (a velocity component): kept as they are.
    Signed,
}

impl ValueRule {
    #[inline]
    fn apply(self, v: f32) -> f32 {
        match self {
            Self::Density => clamp_density(v),
            Self::Signed => v,
        }
    }

    /// Whether a negative value is a clamp to report.
    #[inline]
    fn reports_negative(self, v: f32) -> bool {
        self == Self::Density && v < 0.0
    }
}

/// Index-space coordinate of OpenVDB leaf offset `offset` in a leaf at `origin`.
pub(super) fn leaf_voxel(origin: [i32; 3], offset: usize) -> [i32; 3] {
    [
        origin[0] + (offset >> 6) as i32,
        origin[1] + (offset >> 3 & 7) as i32,
        origin[2] + (offset & 7) as i32,
    ]
}

/// Rejects NaN and Inf anywhere a lookup can read.
fn check_finite(data: &FloatGridData) -> Result<(), VolumeError> {
    let mut tally = NonFiniteTally::default();
    tally.note(data.background, [0; 3], "background");
    for leaf in &data.leaves {
        for (offset, &v) in leaf.values.iter().enumerate() {
            tally.note(v, leaf_voxel(leaf.origin, offset), "leaf voxel");
        }
    }
    for tile in &data.tiles {
        tally.note(tile.value, tile.origin, "tile");
    }
    tally.finish()
}

/// Reads OpenVDB's row-major `world_from_index` (column-vector convention: translation in the
/// last column) and checks it is an invertible affine map.
fn transforms(info: &GridInfo) -> Result<(DAffine3, DAffine3), VolumeError> {
    if !info.is_affine {
        return Err(VolumeError::Transform(
            "the grid's map is not affine (frustum or other non-linear map)".into(),
        ));
    }
    let m = info.world_from_index;
    if m.iter().flatten().any(|x| !x.is_finite()) {
        return Err(VolumeError::Transform(format!(
            "non-finite matrix entry in {m:?}"
        )));
    }
    if m[3] != [0.0, 0.0, 0.0, 1.0] {
        // A translation in the last row would mean OpenVDB's own row-vector layout reached us
        // untransposed; refusing is safer than guessing which convention was meant.
        return Err(VolumeError::Transform(format!(
            "last row is {:?}, expected [0, 0, 0, 1] (translation belongs in the last column)",
            m[3]
        )));
    }
    // glam is column-major: the rows of `m` are the columns of its transpose.
    let world_from_index = DAffine3::from_mat4(DMat4::from_cols_array_2d(&m).transpose());
    let det = world_from_index.matrix3.determinant();
    let invertible = det.abs() > 1e-300 && det.is_finite();
    if !invertible {
        return Err(VolumeError::Transform(format!(
            "singular linear part (determinant {det})"
        )));
    }
    Ok((world_from_index, world_from_index.inverse()))
}

/// Cell box `[lo, hi)` in cell units over the leaves and the non-background tiles, before
/// padding; `None` when there is nothing but background.
fn occupied_cells(
    data: &FloatGridData,
    background: f32,
    rule: ValueRule,
) -> Option<([i64; 3], [i64; 3])> {
    let mut cells = IndexBox::EMPTY;
    for leaf in &data.leaves {
        let c = leaf.origin.map(|o| (o >> 3) as i64);
        cells.include(c, c.map(|x| x + 1));
    }
    for tile in data
        .tiles
        .iter()
        .filter(|t| rule.apply(t.value) != background)
    {
        let c = tile.origin.map(|o| (o >> 3) as i64);
        cells.include(c, c.map(|x| x + (tile.dim / 8) as i64));
    }
    cells.corners()
}

/// Deduplicating table of constant-cell values; the background is entry 0.
struct ConstantTable {
    values: Vec<f32>,
    lookup: HashMap<u32, u32>,
}

impl ConstantTable {
    fn new(background: f32) -> Self {
        Self {
            values: vec![background],
            lookup: HashMap::from([(background.to_bits(), 0)]),
        }
    }

    fn entry(&mut self, v: f32) -> u32 {
        let values = &mut self.values;
        let index = *self.lookup.entry(v.to_bits()).or_insert_with(|| {
            values.push(v);
            (values.len() - 1) as u32
        });
        index | CONSTANT_BIT
    }
}

impl SparseGrid {
    /// Converts a float grid read from OpenVDB, applying the bad-value policy of this module
    /// (NaN/Inf rejected, negatives clamped to 0 and reported) and the size limit of `policy`.
    ///
    /// Lookups then read what OpenVDB's samplers read: leaf voxels (inactive ones too), tile
    /// values over their whole extent, and the background elsewhere. Where a leaf and a tile
    /// overlap (never in a valid tree) the leaf wins.
    pub fn from_vdb(
        data: &FloatGridData,
        policy: ConversionPolicy,
    ) -> Result<(SparseGrid, ConversionReport), VolumeError> {
        convert(data, policy, ValueRule::Density)
    }

    /// As [`from_vdb`](Self::from_vdb) for a signed quantity (a velocity component): values
    /// are kept as they are, negatives included; NaN/Inf and the size limit still apply.
    pub fn from_vdb_signed(
        data: &FloatGridData,
        policy: ConversionPolicy,
    ) -> Result<SparseGrid, VolumeError> {
        convert(data, policy, ValueRule::Signed).map(|(grid, _)| grid)
    }

    /// Builds a grid from a dense block of `dims` voxels whose first value sits at voxel
    /// `origin`, x fastest (`values[x + dims[0] * (y + dims[1] * z)]`). Voxels outside the
    /// block read `background`. Meant for tests and synthetic media; goes through
    /// [`from_vdb`](Self::from_vdb) so the same policy applies.
    pub fn from_dense(
        dims: [usize; 3],
        origin: [i32; 3],
        values: &[f32],
        background: f32,
    ) -> Result<(SparseGrid, ConversionReport), VolumeError> {
        let data = dense_to_vdb(dims, origin, values, background)?;
        SparseGrid::from_vdb(&data, ConversionPolicy::default())
    }
}

/// The conversion behind [`SparseGrid::from_vdb`] and [`SparseGrid::from_vdb_signed`].
fn convert(
    data: &FloatGridData,
    policy: ConversionPolicy,
    rule: ValueRule,
) -> Result<(SparseGrid, ConversionReport), VolumeError> {
    check_finite(data)?;
    let (world_from_index, index_from_world) = transforms(&data.info)?;
    for leaf in &data.leaves {
        if leaf.origin.iter().any(|o| o % LEAF_DIM != 0) {
            return Err(VolumeError::MisalignedLeaf {
                origin: leaf.origin,
            });
        }
    }
    for tile in &data.tiles {
        if tile.dim == 0 || tile.dim % 8 != 0 || tile.origin.iter().any(|o| o % LEAF_DIM != 0) {
            return Err(VolumeError::BadTile {
                origin: tile.origin,
                dim: tile.dim,
            });
        }
    }

    let mut report = ConversionReport::default();
    let background = rule.apply(data.background);
    if rule.reports_negative(data.background) {
        report.negative_background = true;
        report.note_negative(data.background, [0; 3]);
    }

    let mut grid = SparseGrid {
        cells: Vec::new(),
        dims: [0; 3],
        cell_origin: [0; 3],
        bricks: Vec::new(),
        constants: vec![background],
        background,
        world_from_index,
        index_from_world,
        voxel_size: DVec3::from_array(data.info.voxel_size),
        name: data.info.name.clone(),
    };

    if let Some((lo, hi)) = occupied_cells(data, background, rule) {
        // One cell of padding on every side: trilinear reconstruction is non-background up
        // to one voxel beyond the last stored voxel, and the bounds need those cells.
        let lo = lo.map(|c| c - 1);
        let hi = hi.map(|c| c + 1);
        let dims = [0, 1, 2].map(|a| (hi[a] - lo[a]) as u64);
        let cells = dims[0].saturating_mul(dims[1]).saturating_mul(dims[2]);
        if cells > policy.max_cells {
            return Err(VolumeError::TooManyCells {
                dims,
                cells,
                limit: policy.max_cells,
            });
        }
        if lo
            .iter()
            .chain(hi.iter())
            .any(|&c| c * 8 < i32::MIN as i64 || c * 8 > i32::MAX as i64)
        {
            return Err(VolumeError::Transform(
                "cell box exceeds 32-bit voxel coordinates".into(),
            ));
        }
        grid.dims = dims.map(|d| d as u32);
        grid.cell_origin = lo.map(|c| c as i32);
        grid.cells = vec![CONSTANT_BIT; cells as usize];
        fill_cells(&mut grid, data, &mut report, rule)?;
    }

    if report.negative_voxels + report.negative_tiles > 0 || report.negative_background {
        report.warnings.push(format!(
            "clamped negative densities to 0: {} voxel(s), {} tile(s){}; most negative {} first at {:?}",
            report.negative_voxels,
            report.negative_tiles,
            if report.negative_background { ", and the background" } else { "" },
            report.most_negative,
            report.first_negative.unwrap_or_default(),
        ));
    }
    if data.info.class == GridClass::LevelSet {
        report.warnings.push(
            "grid class is level set: values are signed distances, not densities".to_string(),
        );
    }
    Ok((grid, report))
}

/// Writes tiles, then leaves (so leaves win), into the background-filled cell index.
fn fill_cells(
    grid: &mut SparseGrid,
    data: &FloatGridData,
    report: &mut ConversionReport,
    rule: ValueRule,
) -> Result<(), VolumeError> {
    let mut constants = ConstantTable::new(grid.background);
    let origin = grid.cell_origin.map(|c| c as i64);
    let cell_of = |grid: &SparseGrid, c: [i64; 3]| -> usize {
        grid.cell_index(
            (c[0] - origin[0]) as u32,
            (c[1] - origin[1]) as u32,
            (c[2] - origin[2]) as u32,
        )
    };

    for tile in &data.tiles {
        let value = rule.apply(tile.value);
        if value == grid.background {
            report.background_tiles += 1;
            continue;
        }
        let entry = constants.entry(value);
        let c0 = tile.origin.map(|o| (o >> 3) as i64);
        let n = (tile.dim / 8) as i64;
        for z in c0[2]..c0[2] + n {
            for y in c0[1]..c0[1] + n {
                for x in c0[0]..c0[0] + n {
                    let at = cell_of(grid, [x, y, z]);
                    grid.cells[at] = entry;
                }
            }
        }
    }

    for leaf in &data.leaves {
        let brick = leaf_to_brick(leaf, report, rule);
        let at = cell_of(grid, leaf.origin.map(|o| (o >> 3) as i64));
        grid.cells[at] = if brick.iter().all(|&v| v == brick[0]) {
            report.uniform_leaves += 1;
            constants.entry(brick[0])
        } else {
            let index = grid.bricks.len() / BRICK_VOXELS;
            if index >= CONSTANT_BIT as usize {
                return Err(VolumeError::IndexOverflow {
                    what: "brick",
                    count: index + 1,
                });
            }
            grid.bricks.extend_from_slice(&brick);
            index as u32
        };
    }
    // Counted after the leaves so "first negative" follows the same order as non-finite values.
    for tile in data.tiles.iter().filter(|t| rule.reports_negative(t.value)) {
        report.negative_tiles += 1;
        report.note_negative(tile.value, tile.origin);
    }
    if constants.values.len() >= CONSTANT_BIT as usize {
        return Err(VolumeError::IndexOverflow {
            what: "constant",
            count: constants.values.len(),
        });
    }
    grid.constants = constants.values;
    Ok(())
}

/// One leaf's values in Brume order (`x + 8 y + 64 z`), under `rule` (densities: negatives
/// clamped and counted).
fn leaf_to_brick(
    leaf: &Leaf,
    report: &mut ConversionReport,
    rule: ValueRule,
) -> [f32; BRICK_VOXELS] {
    let mut brick = [0.0f32; BRICK_VOXELS];
    for (offset, &v) in leaf.values.iter().enumerate() {
        if rule.reports_negative(v) {
            report.negative_voxels += 1;
            report.note_negative(v, leaf_voxel(leaf.origin, offset));
        }
        let (x, y, z) = (offset >> 6, offset >> 3 & 7, offset & 7);
        brick[x + 8 * y + 64 * z] = rule.apply(v);
    }
    brick
}

/// Grid metadata for a synthetic grid: identity transform, unit voxels, fog volume.
pub fn synthetic_info(name: &str) -> GridInfo {
    GridInfo {
        name: name.to_string(),
        value_type: "float".to_string(),
        class: GridClass::FogVolume,
        voxel_size: [1.0; 3],
        world_from_index: [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 0.0, 0.0, 1.0],
        ],
        is_affine: true,
        active_bbox: None,
        active_voxel_count: 0,
        leaf_count: 0,
        tile_count: 0,
        background: Some(0.0),
        metadata: Vec::new(),
    }
}

/// Wraps a dense block (see [`SparseGrid::from_dense`]) as OpenVDB-style leaves, so tests can
/// add tiles or odd values before converting. Every voxel of the block is marked active.
pub fn dense_to_vdb(
    dims: [usize; 3],
    origin: [i32; 3],
    values: &[f32],
    background: f32,
) -> Result<FloatGridData, VolumeError> {
    if values.len() != dims[0] * dims[1] * dims[2] {
        return Err(VolumeError::DenseSize {
            dims,
            got: values.len(),
        });
    }
    let mut leaves: HashMap<[i32; 3], Leaf> = HashMap::new();
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let v = values[x + dims[0] * (y + dims[1] * z)];
                let ijk = [
                    origin[0] + x as i32,
                    origin[1] + y as i32,
                    origin[2] + z as i32,
                ];
                let leaf_origin = ijk.map(|c| c & !(LEAF_DIM - 1));
                let leaf = leaves.entry(leaf_origin).or_insert_with(|| Leaf {
                    origin: leaf_origin,
                    values: Box::new([background; LEAF_VOXELS]),
                    active: [0; 8],
                });
                let offset = Leaf::offset(
                    (ijk[0] & 7) as usize,
                    (ijk[1] & 7) as usize,
                    (ijk[2] & 7) as usize,
                );
                leaf.values[offset] = v;
                leaf.active[offset >> 6] |= 1 << (offset & 63);
            }
        }
    }
    let mut leaves: Vec<Leaf> = leaves.into_values().collect();
    // A fixed order keeps conversions (and the brick numbering) reproducible.
    leaves.sort_by_key(|l| l.origin);
    let mut info = synthetic_info("dense");
    info.leaf_count = leaves.len() as u64;
    info.background = Some(background as f64);
    Ok(FloatGridData {
        info,
        background,
        leaves,
        tiles: Vec::new(),
    })
}
