//! The adaptive majorant hierarchy: per-leaf bounds merged into larger aligned blocks wherever
//! one coarse segment is cheaper to track through than the fine cells it replaces.
//!
//! Tight bounds need small cells and small cells need many DDA steps: the central trade-off of
//! null-collision tracking. Per-leaf (8^3 voxel) bounds cut density lookups sharply in sparse
//! media, but in a dense, smooth medium the walk through them costs more than the lookups it
//! saves; one global bound is the opposite. The anchors adapt the structure to the data:
//! Cycles merges octree nodes whose bounds are close, pbrt-v4 uses a coarse 16^3 grid, and
//! Yue et al. 2010 ("Unbiased, adaptive stochastic sampling for rendering inhomogeneous
//! participating media") split space by an explicit cost model. Brume does the last on an
//! octree (a mip pyramid of the per-leaf bounds), bottom-up:
//!
//! ```text
//! cost_leaf(n)  = c_step + c_collision * sigma_maj(n) * chord(n)   one segment over node n
//! cost_split(n) = sum_children (S(child) / S(n)) * cost(child)     walk the children instead
//! cost(n)       = min(cost_leaf(n), cost_split(n))
//! ```
//!
//! A node is the box its cells cover INSIDE the grid (the walk clips every ray to the grid's
//! box, so a node on the grid's edge is only as large as its cells there). `sigma_maj(n) *
//! chord(n)` is the expected number of tentative collisions (each a density lookup) on a
//! random chord through that box, of mean length `4 V / S` (Cauchy's formula for a convex
//! body of volume `V` and surface `S`), and a random line that meets a box meets a convex
//! part of it with probability `S(part) / S(box)` (1/4 for each of a cube's 8 half-size
//! children, so a ray crosses 2 of them on average). Where the bounds are
//! equal (tiles, empty space) merging never adds a collision and always saves steps, so empty
//! space and uniform regions become single large segments; where the density varies the
//! fine cells stay. A node chosen as a leaf overrides every choice below it.
//!
//! The result is flat and GPU-friendly: the pyramid of bounds (level 0 = the per-leaf cells)
//! and one byte per fine cell, the level of the merged node that contains it. The walk
//! ([`AdaptiveMajorantIterator`]) is the per-leaf DDA with a variable cell size: in fine cell
//! `c` with level `l` it emits one segment to the exit of node `c >> l`, then steps into the
//! fine cell just across the exit plane. With every level 0 it IS the per-leaf DDA, bit for bit
//! (tested). Merged bounds are unions of per-leaf bounds, which carry the one-voxel apron, so
//! every reconstructed value in a segment lies in its `[sigma_min, sigma_maj]`.
use std::time::Instant;

use rayon::prelude::*;

use super::bounds::{CellBounds, LeafBounds};
use super::cost::{cell_count, children, coords, split_cost, CostModel};
use super::cull::LeafCulling;
use crate::math::Vec3;

/// Deepest level: a node of level `l` spans `2^l` leaf cells per axis (`8 * 2^l` voxels).
pub const MAX_LEVEL: u32 = 12;

/// How much dearer than per-leaf bounds the model may price the culled global walk (on random
/// chords through the grid, [`CostModel::culled_cost`]) for a per-leaf medium's transmittance
/// flights to take it. Shadow rays start at real collisions, inside the medium, and ratio
/// tracking's roulette ends most of them there: they seldom cross the grid's empty margins,
/// where a chord from outside pays most of the culled walk's culled collisions, so the chord
/// model overprices it for them. They draw no stratified sample (a free flight's first draws
/// are a sampler's point, which the per-leaf walk spends better), and the culled walk's kept
/// collisions ARE the per-leaf walk's process; only the residual ratio tracking control is
/// lost (the culled segment's minorant is 0), which costs a few per cent of variance where the
/// cells' minorants are positive. Fitted to `brume bench render --majorants-only`: culled
/// shadow rays are faster where the model's ratio is below about 1.8, as fast up to about 1.6,
/// and slower from about 2.9 (the plumes, the chromatic smoke).
pub const SHADOW_CULLED_FACTOR: f64 = 2.0;

/// One level of the pyramid: its node grid and where its nodes start in
/// [`AdaptiveMajorants::nodes`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Level {
    pub dims: [u32; 3],
    pub offset: u32,
}

/// The adaptive hierarchy of one medium (built for its density scale and voxel size).
#[derive(Clone, Debug)]
pub struct AdaptiveMajorants {
    /// Level-0 (leaf cell) grid, as [`LeafBounds`].
    pub dims: [u32; 3],
    pub cell_origin: [i32; 3],
    pub levels: Vec<Level>,
    /// Bounds of every node of every level, level 0 first, x fastest within a level.
    pub nodes: Vec<CellBounds>,
    /// Per leaf cell, the level of the merged node containing it.
    pub node_level: Vec<u8>,
    /// Per level: first node and the node grid's x and x*y extents (derived from `levels`,
    /// kept flat for the walk, which reads it at every segment).
    level_index: [[u32; 3]; MAX_LEVEL as usize + 1],
    /// The leaf bounds' walk box ([`LeafBounds::walk_box`]): the walk clips rays to it.
    pub walk_box: (Vec3, Vec3),
    /// Whether the merged nodes are one node, every leaf cell, or a mix.
    pub shape: AdaptiveShape,
    /// Whether transmittance (shadow) flights take the culled global walk while free flights
    /// take the per-leaf DDA ([`SHADOW_CULLED_FACTOR`]).
    pub shadow_culled: bool,
    /// Wall time of [`AdaptiveMajorants::build`].
    pub build_seconds: f64,
    /// The cost model it was built with.
    pub cost: CostModel,
}

/// The two shapes a hierarchy can take that a simpler walk yields bit for bit: one node over
/// the whole grid IS the global bound (its bounds are the union of every cell's, its segment
/// the ray's overlap with the grid's box), and every cell at level 0 IS the per-leaf DDA.
/// The renderer walks those with the simpler walk, which skips the per-step level read and
/// the merged node's plane crossings (on the Cornell smoke, one merged node walked by
/// [`AdaptiveMajorantIterator`] cost 10 % more time per sample than the global walk).
/// `Culled` is one node too (every level byte is the top level), walked as the global bound
/// with its tentative collisions culled by the leaf cells (`volume::cull`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AdaptiveShape {
    OneNode,
    AllLeaves,
    Mixed,
    Culled,
}

impl AdaptiveShape {
    fn of(node_level: &[u8], top: u8) -> Self {
        if node_level.iter().all(|&l| l == top) {
            AdaptiveShape::OneNode
        } else if node_level.iter().all(|&l| l == 0) {
            AdaptiveShape::AllLeaves
        } else {
            AdaptiveShape::Mixed
        }
    }
}

/// What the structure looks like, for `brume info`.
#[derive(Clone, Debug, PartialEq)]
pub struct AdaptiveStats {
    /// Merged nodes (segments a walk can emit), per level.
    pub nodes_per_level: Vec<u64>,
    /// Leaf cells per level of their merged node.
    pub cells_per_level: Vec<u64>,
    /// Model cost per ray through the whole grid for per-leaf, global, culled global (infinite
    /// where culling is not sound or the model has no cost for it) and adaptive bounds.
    pub cost_leaf: f64,
    pub cost_global: f64,
    pub cost_culled: f64,
    pub cost_adaptive: f64,
    pub memory_bytes: usize,
    pub build_seconds: f64,
}

/// The mip pyramid of `leaf`'s bounds: level 0 is the leaf cells, each level above halves the
/// node grid (rounding up) with each node the union of its children, up to one node or
/// [`MAX_LEVEL`]. Returns the levels and every level's nodes, concatenated.
fn pyramid(leaf: &LeafBounds) -> (Vec<Level>, Vec<CellBounds>) {
    let mut levels = vec![Level {
        dims: leaf.dims,
        offset: 0,
    }];
    let mut nodes = leaf.cells.clone();
    while levels.len() as u32 <= MAX_LEVEL && levels.last().unwrap().dims.iter().any(|&d| d > 1) {
        let below = *levels.last().unwrap();
        let dims = below.dims.map(|d| d.div_ceil(2));
        let offset = nodes.len() as u32;
        let next: Vec<CellBounds> = (0..cell_count(dims))
            .into_par_iter()
            .map(|i| {
                children(below.dims, coords(i, dims)).fold(CellBounds::EMPTY, |b, c| {
                    b.union(nodes[below.offset as usize + c])
                })
            })
            .collect();
        nodes.extend(next);
        levels.push(Level { dims, offset });
    }
    (levels, nodes)
}

/// What the bottom-up recursion chose, per node of the level it ended at (the top).
struct MergeChoice {
    /// The cost of the chosen structure below each node.
    costs: Vec<f64>,
    /// The cost of walking every leaf cell below each node (per-leaf bounds).
    fine: Vec<f64>,
    /// Per level (level 0 empty), per node: whether it is taken as one segment.
    merged: Vec<Vec<bool>>,
}

/// The bottom-up recursion: each node of each level above the leaf `cells` is merged where
/// one segment over it (`leaf_cost`) costs no more than walking its children.
fn choose_merges(
    dims: [u32; 3],
    levels: &[Level],
    cells: &[CellBounds],
    nodes: &[CellBounds],
    leaf_cost: &(impl Fn(usize, [usize; 3], CellBounds) -> f64 + Sync),
) -> MergeChoice {
    let mut costs: Vec<f64> = cells
        .par_iter()
        .enumerate()
        .map(|(i, &b)| leaf_cost(0, coords(i, dims), b))
        .collect();
    // Alongside: the cost of walking every leaf cell (per-leaf bounds), for the margin.
    let mut fine = costs.clone();
    let mut merged: Vec<Vec<bool>> = vec![Vec::new()];
    for l in 1..levels.len() {
        let (below, here) = (levels[l - 1], levels[l]);
        let choice: Vec<(f64, bool, f64)> = (0..cell_count(here.dims))
            .into_par_iter()
            .map(|i| {
                let n = coords(i, here.dims);
                let split = split_cost(dims, below.dims, l, n, &costs);
                let all_fine = split_cost(dims, below.dims, l, n, &fine);
                let as_leaf = leaf_cost(l, n, nodes[here.offset as usize + i]);
                if as_leaf <= split {
                    (as_leaf, true, all_fine)
                } else {
                    (split, false, all_fine)
                }
            })
            .collect();
        costs = choice.iter().map(|c| c.0).collect();
        merged.push(choice.iter().map(|c| c.1).collect());
        fine = choice.iter().map(|c| c.2).collect();
    }
    MergeChoice {
        costs,
        fine,
        merged,
    }
}

/// Top-down: each of the `n_cells` leaf cells (a `dims` grid) takes the level of its highest
/// merged ancestor (0 where none is merged).
fn node_levels(dims: [u32; 3], n_cells: usize, levels: &[Level], merged: &[Vec<bool>]) -> Vec<u8> {
    (0..n_cells)
        .into_par_iter()
        .map(|i| {
            let c = coords(i, dims);
            for l in (1..levels.len()).rev() {
                let d = levels[l].dims.map(|d| d as usize);
                let n = c.map(|x| x >> l);
                if merged[l][n[0] + d[0] * (n[1] + d[1] * n[2])] {
                    return l as u8;
                }
            }
            0
        })
        .collect()
}

impl AdaptiveMajorants {
    /// Builds the hierarchy from per-leaf bounds. `scale` turns bound values into majorants
    /// per unit of the ray parameter (as the DDA's `scale`), `index_per_t` is the index-space
    /// distance per unit of `t` (1 / voxel size for a unit world direction).
    pub fn build(leaf: &LeafBounds, scale: f32, index_per_t: f32, cost: CostModel) -> Self {
        let start = Instant::now();
        let (levels, nodes) = pyramid(leaf);
        // Bottom-up costs and choices.
        let dims = leaf.dims;
        let leaf_cost = |l: usize, n: [usize; 3], b: CellBounds| {
            let c = cost.node_cost(dims, l, n, b, scale, index_per_t);
            if c.is_finite() {
                c
            } else {
                f64::MAX
            }
        };
        let choice = choose_merges(
            dims,
            &levels,
            &nodes[..leaf.cells.len()],
            &nodes,
            &leaf_cost,
        );
        let node_level = node_levels(dims, leaf.cells.len(), &levels, &choice.merged);
        let mut level_index = [[0u32; 3]; MAX_LEVEL as usize + 1];
        for (k, lv) in levels.iter().enumerate() {
            level_index[k] = [lv.offset, lv.dims[0], lv.dims[0] * lv.dims[1]];
        }
        let top = levels.len() as u8 - 1;
        let shape = AdaptiveShape::of(&node_level, top);
        let mut a = AdaptiveMajorants {
            dims: leaf.dims,
            cell_origin: leaf.cell_origin,
            walk_box: leaf.walk_box(),
            levels,
            nodes,
            node_level,
            shape,
            shadow_culled: false,
            level_index,
            build_seconds: 0.0,
            cost,
        };
        // An empty grid has no node to price: it stays the one (empty) node.
        if !a.node_level.is_empty() {
            // The recursion's costs at the top node: the chosen structure and every leaf cell;
            // one segment over the whole grid is the top node taken as a leaf.
            let cost_global = leaf_cost(top as usize, [0, 0, 0], a.node(top as usize, [0, 0, 0]));
            let cost_culled = a.culled_cost(scale, index_per_t, cost);
            a.settle_shape(
                top,
                choice.costs[0],
                choice.fine[0],
                cost_global,
                cost_culled,
            );
        }
        a.build_seconds = start.elapsed().as_secs_f64();
        a
    }

    /// Replaces the recursion's structure by a simpler walk where the model prices it
    /// (nearly) as cheap: a mixed structure by one node or every leaf cell within the cost
    /// model's margin, a pure one by the culled global walk when strictly cheaper; then
    /// decides whether shadow flights take the culled walk. `chosen` is the recursion's cost at
    /// the top node, `fine` every leaf cell's, `global` the one node's, `culled` the culled
    /// global walk's.
    fn settle_shape(&mut self, top: u8, chosen: f64, fine: f64, global: f64, culled: f64) {
        if self.shape == AdaptiveShape::Mixed {
            let pure = fine.min(global).min(culled);
            // `>=` on NaN is false: a NaN cost keeps the structure the recursion chose.
            if chosen >= (1.0 - self.cost.mixed_margin as f64) * pure {
                let level = if global <= fine { top } else { 0 };
                self.node_level.iter_mut().for_each(|l| *l = level);
                self.shape = AdaptiveShape::of(&self.node_level, top);
            }
        }
        // A pure walk gives way to the culled global walk only when that models cheaper
        // (strictly: the simpler walk wins ties).
        let pure = match self.shape {
            AdaptiveShape::OneNode => global,
            AdaptiveShape::AllLeaves => fine,
            _ => f64::NEG_INFINITY,
        };
        if culled < pure {
            self.node_level.iter_mut().for_each(|l| *l = top);
            self.shape = AdaptiveShape::Culled;
        }
        self.shadow_culled =
            self.shape == AdaptiveShape::AllLeaves && culled < SHADOW_CULLED_FACTOR * fine;
    }

    /// The model's cost of the culled global walk over this pyramid ([`CostModel::culled_cost`]),
    /// infinite where [`LeafCulling::new`] finds culling unsound for these bounds.
    fn culled_cost(&self, scale: f32, index_per_t: f32, cost: CostModel) -> f64 {
        if self.node_level.is_empty() {
            return f64::INFINITY;
        }
        let top = self.node(self.levels.len() - 1, [0, 0, 0]);
        if !LeafCulling::is_sound(top) {
            return f64::INFINITY;
        }
        let level_dims: Vec<[u32; 3]> = self.levels.iter().map(|l| l.dims).collect();
        cost.culled_cost(
            self.dims,
            &level_dims,
            &self.nodes[..self.node_level.len()],
            top,
            scale,
            index_per_t,
        )
    }

    /// Every leaf cell at level 0: the per-leaf DDA's segments (for tests and `--majorant
    /// leaf` on the same code path).
    pub fn all_leaves(leaf: &LeafBounds) -> Self {
        let mut a = Self::build(leaf, 1.0, 1.0, CostModel::uniform(0.0));
        a.shadow_culled = false;
        a.node_level.iter_mut().for_each(|l| *l = 0);
        a.shape = AdaptiveShape::of(&a.node_level, a.levels.len() as u8 - 1);
        a
    }

    /// Bounds of node `n` of level `l`.
    #[inline(always)]
    pub fn node(&self, l: usize, n: [i32; 3]) -> CellBounds {
        let lv = &self.levels[l];
        let [dx, dy, _] = lv.dims.map(|d| d as usize);
        self.nodes[lv.offset as usize + n[0] as usize + dx * (n[1] as usize + dy * n[2] as usize)]
    }

    #[inline(always)]
    fn level_of(&self, c: [i32; 3]) -> u32 {
        let [nx, ny, _] = self.dims.map(|d| d as usize);
        self.node_level[c[0] as usize + nx * (c[1] as usize + ny * c[2] as usize)] as u32
    }

    /// Bytes held: the pyramid and the level bytes.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<CellBounds>() + self.node_level.len()
    }

    /// Structure statistics and the model's expected cost of a random ray through the top
    /// node for per-leaf bounds, one global bound, the culled global walk and this hierarchy
    /// (what the build minimises, so `cost_adaptive <= min(cost_leaf, cost_global,
    /// cost_culled)` unless the margin rule gave up a mixed hierarchy).
    pub fn stats(&self, scale: f32, index_per_t: f32, cost: CostModel) -> AdaptiveStats {
        let nl = self.levels.len();
        let mut cells_per_level = vec![0u64; nl];
        let mut nodes_per_level = vec![0u64; nl];
        let dims = self.dims;
        for (i, &l) in self.node_level.iter().enumerate() {
            cells_per_level[l as usize] += 1;
            let c = coords(i, dims);
            // Count each merged node once, at its first leaf cell.
            if c.iter().all(|&x| x % (1 << l) == 0) {
                nodes_per_level[l as usize] += 1;
            }
        }
        let leaf_cost = |l: usize, n: [usize; 3], b: CellBounds| {
            cost.node_cost(dims, l, n, b, scale, index_per_t)
        };
        let mut fine: Vec<f64> = self.nodes[..self.node_level.len()]
            .iter()
            .enumerate()
            .map(|(i, &b)| leaf_cost(0, coords(i, dims), b))
            .collect();
        let mut adaptive = fine.clone();
        for l in 1..nl {
            let (below, here) = (self.levels[l - 1], self.levels[l]);
            let count = cell_count(here.dims);
            let mut f = Vec::with_capacity(count);
            let mut a = Vec::with_capacity(count);
            for i in 0..count {
                let n = coords(i, here.dims);
                f.push(split_cost(dims, below.dims, l, n, &fine));
                let first = n.map(|x| (x << l) as i32);
                if self.level_of(first) as usize == l {
                    a.push(leaf_cost(l, n, self.nodes[here.offset as usize + i]));
                } else {
                    a.push(split_cost(dims, below.dims, l, n, &adaptive));
                }
            }
            fine = f;
            adaptive = a;
        }
        let top = self.node(nl - 1, [0, 0, 0]);
        let cost_culled = self.culled_cost(scale, index_per_t, cost);
        AdaptiveStats {
            nodes_per_level,
            cells_per_level,
            cost_leaf: fine[0],
            cost_global: leaf_cost(nl - 1, [0, 0, 0], top),
            cost_culled,
            // The culled walk is one node: the recursion would price it as the global bound.
            cost_adaptive: if self.shape == AdaptiveShape::Culled {
                cost_culled
            } else {
                adaptive[0]
            },
            memory_bytes: self.memory_bytes(),
            build_seconds: self.build_seconds,
        }
    }

    /// Checks the structure's invariants: each node's bounds are the union of its children's,
    /// level 0 equals the leaf bounds, and every leaf cell's level names a node all of whose
    /// leaf cells carry the same level.
    pub fn validate(&self, leaf: &LeafBounds) -> Result<(), String> {
        if self.dims != leaf.dims || self.nodes[..leaf.cells.len()] != leaf.cells[..] {
            return Err("level 0 differs from the per-leaf bounds".into());
        }
        for l in 1..self.levels.len() {
            let (below, here) = (self.levels[l - 1], self.levels[l]);
            for i in 0..cell_count(here.dims) {
                let n = coords(i, here.dims);
                let u = children(below.dims, n).fold(CellBounds::EMPTY, |b, c| {
                    b.union(self.nodes[below.offset as usize + c])
                });
                if u != self.nodes[here.offset as usize + i] {
                    return Err(format!(
                        "level {l} node {n:?}: bounds are not its children's union"
                    ));
                }
            }
        }
        for (i, &l) in self.node_level.iter().enumerate() {
            let c = coords(i, self.dims).map(|x| x as i32);
            let base = c.map(|x| (x >> l) << l);
            for dz in 0..1i32 << l {
                for dy in 0..1i32 << l {
                    for dx in 0..1i32 << l {
                        let o = [base[0] + dx, base[1] + dy, base[2] + dz];
                        if (0..3).any(|a| o[a] >= self.dims[a] as i32) {
                            continue;
                        }
                        if self.level_of(o) != l as u32 {
                            return Err(format!(
                                "leaf cell {o:?} has level {} inside a merged node of level {l}",
                                self.level_of(o)
                            ));
                        }
                    }
                }
            }
        }
        Ok(())
    }
}

mod gpu;
mod walk;
pub use gpu::{GPU_TABLE_LEVELS, GPU_TABLE_PACKED, GPU_TABLE_SLOTS};
pub use walk::AdaptiveMajorantIterator;

#[cfg(test)]
mod tests;
