//! Tests of the hierarchy's build, soundness and walk.
use super::*;
use crate::volume::cost::{child_weight, node_cells};
use crate::volume::SparseGrid;

/// A 40^3-voxel grid: an empty half, a uniform block (tiles) and a noisy block.
fn grid() -> (SparseGrid, LeafBounds) {
    let n = 40usize;
    let mut values = vec![0.0f32; n * n * n];
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let v = if x < 16 {
                    0.0
                } else if y < 20 {
                    2.0
                } else {
                    ((x * 7 + y * 13 + z * 29) % 17) as f32 / 17.0
                };
                values[x + n * (y + n * z)] = v;
            }
        }
    }
    let (g, _) = SparseGrid::from_dense([n; 3], [0, 0, 0], &values, 0.0).unwrap();
    let b = LeafBounds::build(&g);
    (g, b)
}

#[test]
fn merging_follows_the_cost_model() {
    let (_, leaf) = grid();
    // Cheap steps: nothing with different bounds merges; equal bounds always do.
    let fine = AdaptiveMajorants::build(&leaf, 1.0, 1.0, CostModel::uniform(1e-6));
    fine.validate(&leaf).unwrap();
    // Dear steps: everything merges into the top node.
    let coarse = AdaptiveMajorants::build(&leaf, 1.0, 1.0, CostModel::uniform(1e9));
    coarse.validate(&leaf).unwrap();
    let top = coarse.levels.len() as u8 - 1;
    assert!(coarse.node_level.iter().all(|&l| l == top));
    assert_eq!(coarse.shape, AdaptiveShape::OneNode);
    assert_eq!(fine.shape, AdaptiveShape::Mixed);
    let s = coarse.stats(1.0, 1.0, CostModel::DEFAULT);
    assert_eq!(s.nodes_per_level.iter().sum::<u64>(), 1);
    let d = AdaptiveMajorants::build(&leaf, 0.1, 1.0, CostModel::DEFAULT);
    d.validate(&leaf).unwrap();
    let s = d.stats(0.1, 1.0, CostModel::DEFAULT);
    assert!(
        s.cost_adaptive <= s.cost_leaf.min(s.cost_global) * 1.0001,
        "{s:?}"
    );
}

#[test]
fn a_node_is_the_box_its_cells_cover_inside_the_grid() {
    // The 40^3-voxel grid with its ring of cells = 7^3 leaf cells; the top node (8^3
    // cells) covers only those 7^3, so the global cost is a chord through a 56-voxel cube
    // (4 V / S = 2 * 56 / 3), and a line through it meets the 4^3-cell child with
    // probability S(child) / S(node).
    let (_, leaf) = grid();
    assert_eq!(leaf.dims, [7, 7, 7]);
    let cost = CostModel::uniform(0.25);
    let a = AdaptiveMajorants::build(&leaf, 0.5, 2.0, cost);
    let s = a.stats(0.5, 2.0, cost);
    let chord = 2.0 * 56.0 / 3.0 / 2.0;
    let want = 0.25 + 0.5 * leaf.global.max as f64 * chord;
    assert!(
        (s.cost_global - want).abs() < 1e-9 * want,
        "{} {want}",
        s.cost_global
    );
    assert_eq!(node_cells(leaf.dims, 3, [0, 0, 0]), [7, 7, 7]);
    assert_eq!(node_cells(leaf.dims, 2, [1, 0, 1]), [3, 4, 3]);
    let w = child_weight(leaf.dims, 3, [0, 0, 0], [0, 0, 0]);
    assert!((w - 16.0 / 49.0).abs() < 1e-12, "{w}");
}

#[test]
fn a_mixed_hierarchy_must_beat_both_pure_walks_by_the_margin() {
    let (_, leaf) = grid();
    let exact = CostModel::uniform(0.3);
    let a = AdaptiveMajorants::build(&leaf, 0.1, 1.0, exact);
    assert_eq!(a.shape, AdaptiveShape::Mixed);
    let s = a.stats(0.1, 1.0, exact);
    let gain = 1.0 - s.cost_adaptive / s.cost_leaf.min(s.cost_global);
    assert!(gain > 0.0, "{s:?}");
    // A margin above the modelled gain: the better pure walk (here per-leaf bounds).
    let wary = CostModel {
        mixed_margin: (gain + 0.01) as f32,
        ..exact
    };
    let b = AdaptiveMajorants::build(&leaf, 0.1, 1.0, wary);
    b.validate(&leaf).unwrap();
    let pure = if s.cost_global <= s.cost_leaf {
        AdaptiveShape::OneNode
    } else {
        AdaptiveShape::AllLeaves
    };
    assert_eq!(b.shape, pure, "{s:?}");
    // A margin below it keeps the mixed structure.
    let keen = CostModel {
        mixed_margin: (gain - 0.01).max(0.0) as f32,
        ..exact
    };
    assert_eq!(
        AdaptiveMajorants::build(&leaf, 0.1, 1.0, keen).shape,
        AdaptiveShape::Mixed
    );
}

#[test]
fn the_gpu_layout_holds_the_table_the_nodes_and_the_levels() {
    let (_, leaf) = grid();
    let a = AdaptiveMajorants::build(&leaf, 0.5, 1.0, CostModel::DEFAULT);
    let g = a.gpu_bounds(&leaf).unwrap();
    let n0 = leaf.cells.len();
    assert_eq!(&g[..n0], &leaf.cells[..]);
    assert_eq!(g[n0], leaf.global);
    assert_eq!(g[n0 + 1..n0 + 4], leaf.gpu_walk_box());
    let slot = |s: usize| {
        let b = g[n0 + 1 + crate::volume::bounds::GPU_WALK_BOX_ENTRIES + s / 2];
        (if s % 2 == 0 { b.min } else { b.max }) as usize
    };
    assert_eq!(slot(GPU_TABLE_LEVELS), a.levels.len());
    for (l, lv) in a.levels.iter().enumerate() {
        let [dx, dy, dz] = lv.dims;
        for i in 0..(dx * dy * dz) as usize {
            assert_eq!(g[slot(l) + i], a.nodes[lv.offset as usize + i]);
        }
    }
    for (i, &l) in a.node_level.iter().enumerate() {
        let b = g[slot(GPU_TABLE_PACKED) + i / 8];
        let w = (if (i / 4) % 2 == 0 { b.min } else { b.max }) as u32;
        assert_eq!((w >> (4 * (i % 4))) & 15, l as u32, "cell {i}");
    }
}

/// 16^3 leaf cells, empty but for one dense cell: `min` everywhere is `floor`.
fn speck(floor: f32) -> LeafBounds {
    let n = 16u32;
    let mut cells = vec![CellBounds::point(floor); (n * n * n) as usize];
    cells[7 + 16 * (7 + 16 * 7)] = CellBounds {
        min: floor,
        max: 1.0,
    };
    LeafBounds::from_cells(cells, [n; 3], [0; 3])
}

#[test]
fn a_speck_in_empty_space_takes_the_culled_global_walk() {
    // Few global collisions, fewer kept ones, and 16 cells a ray for per-leaf bounds: the
    // culled walk models cheapest, and the build takes it, walked as one node.
    let leaf = speck(0.0);
    let a = AdaptiveMajorants::build(&leaf, 0.005, 1.0, CostModel::DEFAULT);
    a.validate(&leaf).unwrap();
    let s = a.stats(0.005, 1.0, CostModel::DEFAULT);
    assert_eq!(a.shape, AdaptiveShape::Culled, "{s:?}");
    assert!(a
        .node_level
        .iter()
        .all(|&l| l as usize == a.levels.len() - 1));
    assert!(s.cost_culled < s.cost_leaf.min(s.cost_global), "{s:?}");
    assert_eq!(s.cost_adaptive, s.cost_culled);
    // Without a cost for it (the uniform models) it is never taken.
    let u = AdaptiveMajorants::build(&leaf, 0.05, 1.0, CostModel::uniform(0.5));
    assert_ne!(u.shape, AdaptiveShape::Culled);
    assert!(u
        .stats(0.05, 1.0, CostModel::uniform(0.5))
        .cost_culled
        .is_infinite());
}

/// 16^3 leaf cells of a dense, smooth medium: every cell's maximum between 0.5 and 1.
fn dense(min: f32) -> LeafBounds {
    let n = 16u32;
    let cells: Vec<CellBounds> = (0..n * n * n)
        .map(|i| CellBounds {
            min,
            max: 0.5 + 0.5 * ((i * 7919) % 101) as f32 / 100.0,
        })
        .collect();
    LeafBounds::from_cells(cells, [n; 3], [0; 3])
}

#[test]
fn shadow_rays_take_the_culled_walk_where_it_models_within_the_factor() {
    // Dense and smooth: per-leaf bounds model cheapest, and the culled walk within
    // SHADOW_CULLED_FACTOR of them, so shadow rays take it.
    let leaf = dense(0.0);
    let a = AdaptiveMajorants::build(&leaf, 0.5, 1.0, CostModel::DEFAULT);
    let s = a.stats(0.5, 1.0, CostModel::DEFAULT);
    assert_eq!(a.shape, AdaptiveShape::AllLeaves, "{s:?}");
    assert!(s.cost_culled > s.cost_leaf, "{s:?}");
    assert!(s.cost_culled < SHADOW_CULLED_FACTOR * s.cost_leaf, "{s:?}");
    assert!(a.shadow_culled, "{s:?}");
    // A speck in empty space, dense enough for per-leaf bounds (no mixed hierarchy: its
    // margin is the whole cost): the culled walk's collisions in the empty space model
    // far dearer, and shadow rays keep the cells.
    let leaf = speck(0.0);
    let pure = CostModel {
        mixed_margin: 1.0,
        ..CostModel::DEFAULT
    };
    let a = AdaptiveMajorants::build(&leaf, 1.0, 1.0, pure);
    let s = a.stats(1.0, 1.0, pure);
    assert_eq!(a.shape, AdaptiveShape::AllLeaves, "{s:?}");
    assert!(s.cost_culled >= SHADOW_CULLED_FACTOR * s.cost_leaf, "{s:?}");
    assert!(!a.shadow_culled, "{s:?}");
    // Unsound culling (the global minimum is not 0) is never taken, nor is it by a test
    // hierarchy of leaf cells only.
    let leaf = dense(0.01);
    assert!(!AdaptiveMajorants::build(&leaf, 0.5, 1.0, CostModel::DEFAULT).shadow_culled);
    assert!(!AdaptiveMajorants::all_leaves(&dense(0.0)).shadow_culled);
}

#[test]
fn no_culled_walk_where_the_global_minimum_is_not_zero() {
    // The same speck in a faint fog: the segment's control (its minorant) would not
    // vanish, so culling is unsound and the build never prices or takes it.
    let leaf = speck(0.01);
    let a = AdaptiveMajorants::build(&leaf, 0.05, 1.0, CostModel::DEFAULT);
    assert_ne!(a.shape, AdaptiveShape::Culled);
    assert!(a
        .stats(0.05, 1.0, CostModel::DEFAULT)
        .cost_culled
        .is_infinite());
    assert!(crate::volume::LeafCulling::new(&leaf).is_none());
    assert!(crate::volume::LeafCulling::new(&speck(0.0)).is_some());
}
