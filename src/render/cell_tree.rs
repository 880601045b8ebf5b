//! A binary tree of boxes with powers, for choosing one of many small emitters (the emitting
//! media's cells, `render::media_lights`) in proportion to what each may send to a point.
//!
//! A light tree after Conty Estevez and Kulla 2018 ("Importance Sampling of Many Lights with
//! Adaptive Tree Splitting") and pbrt-v4's `BVHLightSampler`, without orientation cones: the
//! emitters are isotropic volumes, and the same importance serves points in media and on
//! surfaces (so the density of a choice needs only the shading point). A node's importance
//! from point `p` is
//!
//! ```text
//! I(node, p) = Phi / max(|p - c|^2, r^2)
//! ```
//!
//! (`Phi` the power under the node, `c` its box's centre and `r` half its diagonal: inside or
//! next to the box the distance is no longer a guide). The walk from the root takes the left
//! child with probability
//!
//! ```text
//! I_l / (I_l + I_r) = Phi_l D_r / (Phi_l D_r + Phi_r D_l),    D = max(|p - c|^2, r^2)
//! ```
//!
//! (one division a level); the probability of a leaf is the product
//! along its path, which [`CellTree::pmf`] recomputes from the leaf's trail of left/right bits.
//! The estimate stays unbiased whatever the importance says, as long as a leaf that may emit
//! keeps a nonzero probability: `I > 0` wherever `Phi > 0`.
use glam::Vec3;

/// A node, depth first: an inner node's left child follows it, `link` is its right child; a
/// leaf's `link` is `LEAF | item`. The GPU reads the same six words
/// (`backend::gpu::media_lights`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TreeNode {
    /// The centre `c` of the box around its items.
    pub centre: Vec3,
    /// `Phi`, the power under it.
    pub power: f32,
    /// `r^2`, the squared half diagonal of the box.
    pub radius2: f32,
    pub link: u32,
}

/// Marks a leaf's `link`.
pub const LEAF: u32 = 1 << 31;

/// The deepest a leaf may be: its trail is one bit per level in a `u32`.
const MAX_DEPTH: usize = 32;

/// The tree over items `0..n` ([module doc](self)).
#[derive(Clone, Debug)]
pub struct CellTree {
    pub nodes: Vec<TreeNode>,
    /// Per item: the bits of its path from the root (bit `k` set: right at depth `k`).
    pub trails: Vec<u32>,
}

/// `D(node, p)` of the module doc.
#[inline(always)]
fn distance2(node: &TreeNode, p: Vec3) -> f32 {
    (p - node.centre).length_squared().max(node.radius2)
}

/// The probability of taking the left child `l` rather than `r` from `p` (module doc); `None`
/// where neither has any importance that a float can hold.
#[inline(always)]
pub fn left_probability(l: &TreeNode, r: &TreeNode, p: Vec3) -> Option<f32> {
    let a = l.power * distance2(r, p);
    let b = r.power * distance2(l, p);
    let sum = a + b;
    (sum > 0.0 && sum.is_finite()).then(|| a / sum)
}

impl CellTree {
    /// The tree over items with world boxes `boxes` and powers `power` (all positive and
    /// finite); `None` without items.
    pub fn build(boxes: &[(Vec3, Vec3)], power: &[f32]) -> Option<CellTree> {
        if boxes.is_empty() || boxes.len() != power.len() {
            return None;
        }
        let mut tree = CellTree {
            nodes: Vec::with_capacity(2 * boxes.len() - 1),
            trails: vec![0; boxes.len()],
        };
        let mut items: Vec<u32> = (0..boxes.len() as u32).collect();
        tree.split(&mut items, boxes, power, 0, 0);
        Some(tree)
    }

    /// Adds the subtree over `items` (their trail so far `trail`, at `depth`); returns its
    /// root's power. Splits at the median centre along the centres' widest axis.
    fn split(
        &mut self,
        items: &mut [u32],
        boxes: &[(Vec3, Vec3)],
        power: &[f32],
        trail: u32,
        depth: usize,
    ) -> f32 {
        let at = self.nodes.len();
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for &i in items.iter() {
            lo = lo.min(boxes[i as usize].0);
            hi = hi.max(boxes[i as usize].1);
        }
        self.nodes.push(TreeNode {
            centre: (lo + hi) * 0.5,
            power: 0.0,
            radius2: (hi - lo).length_squared() * 0.25,
            link: 0,
        });
        if items.len() == 1 || depth + 1 >= MAX_DEPTH {
            // MAX_DEPTH is only reached past 2^31 items; the leaf then keeps the first.
            let i = items[0];
            self.trails[i as usize] = trail;
            self.nodes[at].power = power[i as usize];
            self.nodes[at].link = LEAF | i;
            return power[i as usize];
        }
        let centre = |i: u32| (boxes[i as usize].0 + boxes[i as usize].1) * 0.5;
        let (mut c_lo, mut c_hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for &i in items.iter() {
            c_lo = c_lo.min(centre(i));
            c_hi = c_hi.max(centre(i));
        }
        let axis = (c_hi - c_lo).max_position();
        let mid = items.len() / 2;
        items.select_nth_unstable_by(mid, |&a, &b| {
            centre(a)[axis].total_cmp(&centre(b)[axis]).then(a.cmp(&b))
        });
        let (left, right) = items.split_at_mut(mid);
        let p_left = self.split(left, boxes, power, trail, depth + 1);
        self.nodes[at].link = self.nodes.len() as u32;
        let p_right = self.split(right, boxes, power, trail | 1 << depth, depth + 1);
        self.nodes[at].power = p_left + p_right;
        self.nodes[at].power
    }

    /// The item drawn for point `p` by `u` in [0, 1), and its probability; `None` where no item
    /// has any importance from `p` (only where every power is zero).
    pub fn sample(&self, p: Vec3, mut u: f32) -> Option<(u32, f32)> {
        self.descend(p, |p_l| {
            let right = u >= p_l;
            u = if right {
                (u - p_l) / (1.0 - p_l)
            } else {
                u / p_l
            }
            .min(ONE_MINUS_EPSILON);
            right
        })
    }

    /// The probability that [`sample`](Self::sample) draws `item` for point `p`.
    pub fn pmf(&self, p: Vec3, item: u32) -> f32 {
        let trail = self.trails[item as usize];
        let mut depth = 0;
        self.descend(p, |_| {
            depth += 1;
            trail >> (depth - 1) & 1 != 0
        })
        .map_or(0.0, |(_, pmf)| pmf)
    }

    /// The walk from the root to a leaf, `go_right(P(left))` choosing each step; the leaf's item
    /// and the product of the probabilities taken.
    #[inline(always)]
    fn descend(&self, p: Vec3, mut go_right: impl FnMut(f32) -> bool) -> Option<(u32, f32)> {
        let mut at = 0usize;
        let mut pmf = 1.0f32;
        loop {
            let node = &self.nodes[at];
            if node.link & LEAF != 0 {
                return Some((node.link & !LEAF, pmf));
            }
            let (left, right) = (at + 1, node.link as usize);
            let p_l = left_probability(&self.nodes[left], &self.nodes[right], p)?;
            if go_right(p_l) {
                pmf *= 1.0 - p_l;
                at = right;
            } else {
                pmf *= p_l;
                at = left;
            }
        }
    }
}

/// The largest f32 below 1.
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    fn grid_of_boxes() -> (Vec<(Vec3, Vec3)>, Vec<f32>) {
        let mut boxes = Vec::new();
        let mut power = Vec::new();
        for i in 0..37u32 {
            let lo = Vec3::new((i % 4) as f32, (i / 4 % 3) as f32, (i / 12) as f32) * 0.5;
            boxes.push((lo, lo + 0.5));
            power.push(1.0 + (i * 7 % 5) as f32);
        }
        (boxes, power)
    }

    #[test]
    fn every_leaf_holds_one_item_and_the_probabilities_sum_to_one() {
        let (boxes, power) = grid_of_boxes();
        let tree = CellTree::build(&boxes, &power).unwrap();
        assert_eq!(tree.nodes.len(), 2 * boxes.len() - 1);
        let mut seen: Vec<u32> = tree
            .nodes
            .iter()
            .filter(|n| n.link & LEAF != 0)
            .map(|n| n.link & !LEAF)
            .collect();
        seen.sort();
        assert_eq!(seen, (0..boxes.len() as u32).collect::<Vec<_>>());
        for p in [
            Vec3::new(0.7, 0.3, 0.9),
            Vec3::new(5.0, -2.0, 1.0),
            Vec3::splat(100.0),
        ] {
            let sum: f64 = (0..boxes.len() as u32).map(|i| tree.pmf(p, i) as f64).sum();
            assert!((sum - 1.0).abs() < 1e-5, "sum {sum} at {p}");
        }
    }

    /// Draws against `pmf` by chi-square, and `sample`'s probability equals `pmf`'s.
    #[test]
    fn sampling_follows_the_pmf() {
        let (boxes, power) = grid_of_boxes();
        let tree = CellTree::build(&boxes, &power).unwrap();
        let p = Vec3::new(-0.5, 0.6, 0.4);
        let n = 200_000;
        let mut counts = vec![0u32; boxes.len()];
        let mut rng = Rng::new(7, 0, 1);
        for _ in 0..n {
            let (i, pmf) = tree.sample(p, rng.uniform_f32()).unwrap();
            assert_eq!(pmf, tree.pmf(p, i));
            counts[i as usize] += 1;
        }
        let chi2: f64 = (0..boxes.len())
            .map(|i| {
                let e = tree.pmf(p, i as u32) as f64 * n as f64;
                (counts[i] as f64 - e).powi(2) / e
            })
            .sum();
        // 36 degrees of freedom: the 0.999 quantile is 67.98.
        assert!(chi2 < 67.98, "chi-square {chi2}");
    }

    #[test]
    fn nearer_boxes_are_drawn_more_often() {
        let (boxes, power) = grid_of_boxes();
        let tree = CellTree::build(&boxes, &power).unwrap();
        let p = Vec3::new(-3.0, 0.0, 0.0);
        let near = tree.pmf(p, 0) / power[0];
        let far = tree.pmf(p, 3) / power[3];
        assert!(near > far, "near {near}, far {far}");
    }
}
