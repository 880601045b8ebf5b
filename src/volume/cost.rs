//! The cost model of the adaptive hierarchy (`volume::adaptive`): what a segment, a tentative
//! collision and a culled collision cost, and the geometry of random chords it prices them on.
use super::bounds::{CellBounds, CELL_WIDTH};

/// Relative costs of the walk, in units of one tentative collision (an exponential step, a
/// density lookup and the event choice).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CostModel {
    /// One level-0 segment: an incremental DDA step and the tracking loop's per-segment work.
    pub step: f32,
    /// One segment over a merged node: three plane crossings, the exit point's cell and a
    /// fresh DDA state, and the tracking loop's per-segment work.
    pub node_step: f32,
    /// One tentative collision.
    pub collision: f32,
    /// One tentative collision of the culled global walk that the per-leaf bound at its point
    /// may cull (`volume::cull`): the exponential step, the point's cell and its bound, and
    /// the uniform that decides. The kept ones cost `collision` on top. Infinite: the build
    /// never takes the culled walk.
    pub cull: f32,
    /// How much cheaper (relative) a mixed hierarchy must model than the better pure walk
    /// (every cell at level 0, or one node) to be kept; otherwise the build takes that pure
    /// walk. The model's costs are accurate to a few per cent in time, and a mixed walk pays
    /// for its per-step level read and its merged nodes' plane crossings in ways the model
    /// does not see: on the cloud, the furnace, the fire and the textured backdrop a mixed
    /// hierarchy modelled 2-4 % cheaper than per-leaf bounds measured 1-6 % slower.
    pub mixed_margin: f32,
}

impl CostModel {
    /// The same cost for every segment, and no culled walk.
    pub const fn uniform(step: f32) -> Self {
        CostModel {
            step,
            node_step: step,
            collision: 1.0,
            cull: f32::INFINITY,
            mixed_margin: 0.0,
        }
    }

    /// The model's cost of one segment over node `n` of level `l`, with bounds `b`, in a grid
    /// of `dims` leaf cells: a step plus the expected tentative collisions on a random chord
    /// through the box the node covers inside the grid (mean length `4 V / S`).
    pub fn node_cost(
        &self,
        dims: [u32; 3],
        l: usize,
        n: [usize; 3],
        b: CellBounds,
        scale: f32,
        index_per_t: f32,
    ) -> f64 {
        let chord = mean_chord(node_cells(dims, l, n)) / index_per_t as f64;
        let step = if l == 0 { self.step } else { self.node_step };
        step as f64 + self.collision as f64 * (scale * b.max).max(0.0) as f64 * chord
    }

    /// The model's cost of a random chord through the grid walked as ONE segment with the
    /// global bound `global`, its tentative collisions culled by the per-leaf bounds `cells`
    /// (`level_dims`: the pyramid's node grids, level 0 = `dims`):
    ///
    /// ```text
    /// c_node_step + c_cull * sigma_maj(grid) * chord(grid)
    ///             + c_collision * sum_cells P(cell) * sigma_maj(cell) * chord(cell)
    /// ```
    ///
    /// The last term is the per-leaf walk's expected collisions (the kept ones), summed with
    /// the same surface weights as the hierarchy's split cost.
    #[allow(clippy::too_many_arguments)]
    pub fn culled_cost(
        &self,
        dims: [u32; 3],
        level_dims: &[[u32; 3]],
        cells: &[CellBounds],
        global: CellBounds,
        scale: f32,
        index_per_t: f32,
    ) -> f64 {
        if !self.cull.is_finite() {
            return f64::INFINITY;
        }
        let collisions = |l: usize, n: [usize; 3], b: CellBounds| {
            let chord = mean_chord(node_cells(dims, l, n)) / index_per_t as f64;
            (scale * b.max).max(0.0) as f64 * chord
        };
        let mut kept: Vec<f64> = cells
            .iter()
            .enumerate()
            .map(|(i, &b)| collisions(0, coords(i, dims), b))
            .collect();
        for l in 1..level_dims.len() {
            let (below, here) = (level_dims[l - 1], level_dims[l]);
            kept = (0..cell_count(here))
                .map(|i| split_cost(dims, below, l, coords(i, here), &kept))
                .collect();
        }
        let top = level_dims.len() - 1;
        self.node_step as f64
            + self.cull as f64 * collisions(top, [0, 0, 0], global)
            + self.collision as f64 * kept[0]
    }

    /// Measured on the example grids (x86-64, random rays and renders): a tentative
    /// collision in a brick (exponential step, blended lookup, event) about 35 ns, a merged
    /// node about 40 ns, a level-0 segment 11-16 ns alone and about 18 ns with the tracking
    /// loop's per-segment work in a render (fitted to `brume bench render --majorants-only`:
    /// per-leaf against global bounds on the furnace and the cloud). A culled collision costs
    /// 1.2-1.4 level-0 segments (fitted to the same table, culled against per-leaf rows:
    /// the time difference against the global walk's collisions and the per-leaf segments
    /// per sample on the plumes, the Cornell smoke, the fire, the furnace, the cloud and the
    /// dense fog).
    pub const DEFAULT: CostModel = CostModel {
        step: 0.5,
        node_step: 1.2,
        collision: 1.0,
        cull: 0.6,
        mixed_margin: 0.1,
    };
}

/// Mean chord length `4 V / S` (index units) of a box of `cells` leaf cells per axis.
pub(super) fn mean_chord(cells: [u32; 3]) -> f64 {
    let [x, y, z] = cells.map(|c| c as f64 * CELL_WIDTH as f64);
    4.0 * x * y * z / surface([x, y, z])
}

pub(super) fn surface([x, y, z]: [f64; 3]) -> f64 {
    2.0 * (x * y + y * z + z * x)
}

/// Leaf cells per axis that node `n` of level `l` covers inside a grid of `dims` cells.
pub(super) fn node_cells(dims: [u32; 3], l: usize, n: [usize; 3]) -> [u32; 3] {
    [0, 1, 2].map(|a| {
        let first = (n[a] << l) as u32;
        (((n[a] + 1) << l) as u32)
            .min(dims[a])
            .saturating_sub(first)
    })
}

/// Probability that a random line meeting node `n` of level `l` (as clipped to the grid)
/// also meets its child `c` (of level `l - 1`): the ratio of their surfaces.
pub(super) fn child_weight(dims: [u32; 3], l: usize, n: [usize; 3], c: [usize; 3]) -> f64 {
    let s = |cells: [u32; 3]| surface(cells.map(|c| c as f64));
    s(node_cells(dims, l - 1, c)) / s(node_cells(dims, l, n))
}

/// Flat indices (within the level below) of the up to 8 children of node `n`.
pub(super) fn children(below: [u32; 3], n: [usize; 3]) -> impl Iterator<Item = usize> {
    children_at(below, n).map(|(i, _)| i)
}

/// The up to 8 children of node `n`: flat index within the level below and coordinates.
pub(super) fn children_at(
    below: [u32; 3],
    n: [usize; 3],
) -> impl Iterator<Item = (usize, [usize; 3])> {
    let [bx, by, bz] = below.map(|d| d as usize);
    (0..8).filter_map(move |k| {
        let c = [
            2 * n[0] + (k & 1),
            2 * n[1] + (k >> 1 & 1),
            2 * n[2] + (k >> 2),
        ];
        (c[0] < bx && c[1] < by && c[2] < bz).then(|| (c[0] + bx * (c[1] + by * c[2]), c))
    })
}

/// The model's cost of walking the children of node `n` of level `l` instead of one segment
/// over it: each child's cost weighted by the chance a line through `n` meets it.
pub(super) fn split_cost(
    dims: [u32; 3],
    below: [u32; 3],
    l: usize,
    n: [usize; 3],
    cost: &[f64],
) -> f64 {
    children_at(below, n)
        .map(|(i, c)| child_weight(dims, l, n, c) * cost[i])
        .sum()
}

/// Coordinates of flat index `i` (x fastest) in a grid of `dims`.
pub(super) fn coords(i: usize, dims: [u32; 3]) -> [usize; 3] {
    let [nx, ny, _] = dims.map(|d| d as usize);
    [i % nx, i / nx % ny, i / (nx * ny)]
}

/// Number of entries of a grid of `dims`.
pub(super) fn cell_count(dims: [u32; 3]) -> usize {
    dims.iter().map(|&d| d as usize).product()
}
