//! The hierarchy as the GPU reads it: one flat bounds buffer.
use super::AdaptiveMajorants;
use crate::volume::bounds::{CellBounds, LeafBounds};
use crate::volume::cost::cell_count;

/// The GPU's bounds buffer: the per-leaf bounds, the global bound and the walk box (as
/// always: [`LeafBounds::gpu_walk_box`]), then a 16-slot table (8 [`CellBounds`], read as 16 `f32` values), the nodes of levels 1 and up,
/// and the leaf cells' levels packed 4 to an `f32` value (`sum_k level[4w + k] * 16^k`, exact
/// below 2^16) and 2 values to a `CellBounds`. Table slot `l` < 13 holds where level `l`
/// starts (0 for level 0), [`GPU_TABLE_LEVELS`] the level count and [`GPU_TABLE_PACKED`]
/// where the packed levels start. Integers are stored as exact `f32` values, not bit
/// patterns, so nothing depends on how a device moves floats; every index must stay below
/// 2^24. `shaders/common/dda.wgsl` (`adaptive_*`) reads it.
pub const GPU_TABLE_SLOTS: usize = 16;
pub const GPU_TABLE_LEVELS: usize = 13;
pub const GPU_TABLE_PACKED: usize = 14;

impl AdaptiveMajorants {
    pub fn gpu_bounds(&self, leaf: &LeafBounds) -> Result<Vec<CellBounds>, String> {
        let mut out = leaf.cells.clone();
        out.push(leaf.global);
        out.extend(leaf.gpu_walk_box());
        let table_at = out.len();
        out.extend([CellBounds::point(0.0); GPU_TABLE_SLOTS / 2]);
        let mut table = [0f32; GPU_TABLE_SLOTS];
        for (l, lv) in self.levels.iter().enumerate().skip(1) {
            let count = cell_count(lv.dims);
            table[l] = out.len() as f32;
            out.extend_from_slice(&self.nodes[lv.offset as usize..lv.offset as usize + count]);
        }
        table[GPU_TABLE_LEVELS] = self.levels.len() as f32;
        table[GPU_TABLE_PACKED] = out.len() as f32;
        let words: Vec<f32> = self
            .node_level
            .chunks(4)
            .map(|c| c.iter().rev().fold(0u32, |a, &l| a * 16 + l as u32) as f32)
            .collect();
        out.extend(words.chunks(2).map(|p| CellBounds {
            min: p[0],
            max: p.get(1).copied().unwrap_or(0.0),
        }));
        if out.len() >= 1 << 24 {
            return Err(format!(
                "the adaptive majorants need {} bounds entries; the GPU layout indexes at most 2^24",
                out.len()
            ));
        }
        for (k, pair) in table.chunks(2).enumerate() {
            out[table_at + k] = CellBounds {
                min: pair[0],
                max: pair[1],
            };
        }
        Ok(out)
    }
}
