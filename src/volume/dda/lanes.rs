//! The set-up of a walk through a grid of several cells ([`DdaState::enter`]), computed four
//! lanes at a time (x, y, z and a padding lane) with glam's `Vec4` (SSE on every x86-64 CPU).
//!
//! The scalar set-up ([`DdaState::enter_scalar`]) spent about 310 instructions a per-leaf
//! free flight (callgrind, the fire: a tenth of the flight), most of them moving each axis's
//! values between registers. Here the per-axis arithmetic is one vector operation each, and
//! every lane runs exactly the scalar set-up's operations in its order, so the state is the
//! scalar one bit for bit (tested against it on random and degenerate rays):
//!
//! ```text
//! inv   = 1 / d                                   step = 0 where inv is not finite, else sign(d)
//! box   = [max(lo, clip_lo), min(lo + 8 dims, clip_hi)]
//! ta,tb = (box - o) * inv, swapped where ta > tb  t_enter = t0 then max over x, y, z in turn
//!                                                 t_exit  = t1 then min over x, y, z in turn
//! x     = o where d == 0, else o + t_enter * d
//! cell  = min(max((x - lo) * 1/8, 0), dims - 1)   (then truncated: the clamp first makes the
//!                                                  saturating cast and its clamp one convert)
//! plane = lo + (cell + [step > 0]) * 8,  crossing = (plane - o) * inv  (inf where step = 0)
//! ```
//!
//! The box test keeps the scalar one's sequence: `max` and `min` over the axes in order, each
//! as `if a > t { t = a }`, and the early exits of `Aabb::intersect_inv` folded into the final
//! `t_enter < t_exit` (the entry only grows and the exit only shrinks, so an early `>` is still
//! `>` at the end).
use glam::{BVec4A, Vec4};

use super::{CellBox, DdaState, CELL_WIDTH};
use crate::math::{trunc_xyz, Ray, Vec3};

/// `v` with `w` in the padding lane.
#[inline(always)]
fn lanes(v: Vec3, w: f32) -> Vec4 {
    Vec4::new(v.x, v.y, v.z, w)
}

/// `if_true` where `mask`, else `if_false`.
#[inline(always)]
fn pick(mask: BVec4A, if_true: Vec4, if_false: Vec4) -> Vec4 {
    Vec4::select(mask, if_true, if_false)
}

/// The cell of the cell box from `lo` (cells of edge [`CELL_WIDTH`], `last` the last cell's
/// coordinates) that holds index-space point `x`, as floats and as integers: clamped into the
/// box, then truncated, which equals `floor` there and is the scalar set-up's saturating cast
/// and integer clamp. `max(NaN, 0)` is 0 (SSE returns its second operand), as the saturating
/// cast maps NaN. The DDA's entry cell and the leaf culling's cell search
/// (`volume::cull::LeafCulling::bound_at`).
#[inline(always)]
pub(crate) fn cell_of(x: Vec4, lo: Vec4, last: Vec4) -> (Vec4, [i32; 3]) {
    trunc_xyz(((x - lo) * (1.0 / CELL_WIDTH)).max(Vec4::ZERO).min(last))
}

/// [`DdaState::enter`] for a box of cells of edge [`CELL_WIDTH`] with every `dims` at least 1
/// and not all 1 (the one-cell walk and an empty box take the scalar path).
#[inline]
pub(super) fn enter_cells(cb: &CellBox, ray: &Ray, t0: f32, t1: f32) -> DdaState {
    let CellBox { lo, dims, clip, .. } = *cb;
    debug_assert!(dims.iter().all(|&n| n >= 1) && dims != [1; 3]);
    // The padding lane: a unit direction at the origin in a unit box, so no lane divides by 0.
    let o = lanes(ray.o, 0.0);
    let d = lanes(ray.d, 1.0);
    let inv = Vec4::ONE / d;
    // `reciprocal_and_step`: an axis steps only where `1 / d` is finite (NaN is not).
    let steps = inv.abs().cmplt(Vec4::INFINITY);
    let forward = steps & d.cmpgt(Vec4::ZERO);
    let backward = steps & !d.cmpgt(Vec4::ZERO);

    // `enter_box`: the slab test against the cell box clipped to the walk box.
    let dims_f = Vec4::new(dims[0] as f32, dims[1] as f32, dims[2] as f32, 1.0);
    let lo4 = lanes(lo, 0.0);
    let hi4 = lo4 + Vec4::splat(CELL_WIDTH) * dims_f;
    let box_lo = lo4.max(lanes(clip.0, 0.0));
    let box_hi = hi4.min(lanes(clip.1, CELL_WIDTH));
    let ta = (box_lo - o) * inv;
    let tb = (box_hi - o) * inv;
    let swap = ta.cmpgt(tb);
    let near = pick(swap, tb, ta).to_array();
    let far = pick(swap, ta, tb).to_array();
    let (mut t_enter, mut t_exit) = (t0, t1);
    for a in 0..3 {
        // `x > NaN` is false, so a NaN bound never shrinks the interval.
        if near[a] > t_enter {
            t_enter = near[a];
        }
        if far[a] < t_exit {
            t_exit = far[a];
        }
    }

    // Written out: array `map`s here compiled to element-by-element loops (`array::drain`)
    // that cost as much as the vector arithmetic.
    let step_of = |a| forward.test(a) as i32 - backward.test(a) as i32;
    let step = [step_of(0), step_of(1), step_of(2)];
    let inv_d = [inv.x, inv.y, inv.z];
    let flat = [
        1isize,
        dims[0] as isize,
        dims[0] as isize * dims[1] as isize,
    ];
    let mut state = DdaState {
        dims,
        lo: lo.to_array(),
        width: [CELL_WIDTH; 3],
        o: ray.o.to_array(),
        d: ray.d.to_array(),
        inv_d,
        step,
        index: 0,
        stride: [
            step[0] as isize * flat[0],
            step[1] as isize * flat[1],
            step[2] as isize * flat[2],
        ],
        left: [0; 3],
        fixed: [0; 3],
        plane: [0.0; 3],
        plane_step: [
            step[0] as f32 * CELL_WIDTH,
            step[1] as f32 * CELL_WIDTH,
            step[2] as f32 * CELL_WIDTH,
        ],
        next_crossing: [f32::INFINITY; 3],
        t: 0.0,
        t_exit: 0.0,
        done: true,
    };
    // Written positively so NaN parameters are rejected too; an empty overlap yields nothing.
    if !(t_enter < t_exit) {
        return state;
    }

    // The entry cell; on an axis the ray does not move along, `t_enter` may be infinite and
    // `t * 0` NaN: the coordinate is simply the origin's.
    let p = o + Vec4::splat(t_enter) * d;
    let x = pick(d.cmpeq(Vec4::ZERO), o, p);
    let last = dims_f - Vec4::ONE;
    let (cell_f, cell) = cell_of(x, lo4, last);
    let plane = lo4 + (cell_f + pick(forward, Vec4::ONE, Vec4::ZERO)) * CELL_WIDTH;
    let crossing = pick(steps, (plane - o) * inv, Vec4::INFINITY).to_array();
    let plane = pick(steps, plane, Vec4::ZERO).to_array();
    let left = trunc_xyz(pick(
        forward,
        last - cell_f,
        pick(backward, cell_f, Vec4::ZERO),
    ))
    .1;

    let (nx, ny) = (dims[0] as usize, dims[1] as usize);
    state.index = cell[0] as usize + nx * (cell[1] as usize + ny * cell[2] as usize);
    state.fixed = cell;
    state.left = left;
    state.plane = [plane[0], plane[1], plane[2]];
    state.next_crossing = [crossing[0], crossing[1], crossing[2]];
    state.t = t_enter;
    state.t_exit = t_exit;
    state.done = false;
    state
}

#[cfg(test)]
mod tests {
    use super::super::{CellBox, DdaState};
    use crate::math::{Ray, Vec3};
    use crate::sampling::Rng;

    /// Every field of a state as bits, floats by their bit patterns (so `-0.0 != 0.0` and NaNs
    /// compare by payload).
    fn bits(s: &DdaState) -> Vec<u64> {
        let f = |a: &[f32]| a.iter().map(|x| x.to_bits() as u64).collect::<Vec<_>>();
        let i = |a: &[i32]| a.iter().map(|&x| x as u32 as u64).collect::<Vec<_>>();
        let mut v = Vec::new();
        v.extend(i(&s.dims));
        v.extend(f(&s.lo));
        v.extend(f(&s.width));
        v.extend(f(&s.o));
        v.extend(f(&s.d));
        v.extend(f(&s.inv_d));
        v.extend(i(&s.step));
        v.push(s.index as u64);
        v.extend(s.stride.iter().map(|&x| x as u64));
        v.extend(i(&s.left));
        v.extend(i(&s.fixed));
        v.extend(f(&s.plane));
        v.extend(f(&s.plane_step));
        v.extend(f(&s.next_crossing));
        v.extend(f(&[s.t, s.t_exit]));
        v.push(s.done as u64);
        v
    }

    /// A coordinate: mostly ordinary, sometimes one of the values that break walks.
    fn coord(rng: &mut Rng, scale: f32) -> f32 {
        let special = [
            0.0,
            -0.0,
            f32::from_bits(1),
            -f32::from_bits(1),
            1e-30,
            f32::NAN,
        ];
        if rng.uniform_f32() < 0.15 {
            special[(rng.uniform_f32() * special.len() as f32) as usize]
        } else {
            (rng.uniform_f32() * 2.0 - 1.0) * scale
        }
    }

    /// The four-lane set-up is the scalar one bit for bit, on random boxes and rays with zero,
    /// negative zero, subnormal and NaN direction components, origins inside and outside, rays
    /// along the box's planes, and every kind of parameter range.
    #[test]
    fn lanes_match_the_scalar_set_up_bit_for_bit() {
        let mut rng = Rng::new(7, 0, 13);
        let mut entered = 0;
        for i in 0..200_000 {
            let dims = loop {
                let d = [0; 3].map(|_| 1 + (rng.uniform_f32() * 6.0) as i32);
                if d != [1; 3] {
                    break d;
                }
            };
            let origin = [0; 3].map(|_| (rng.uniform_f32() * 12.0) as i32 - 6);
            let lo = Vec3::from_array(origin.map(|c| c as f32 * 8.0));
            let hi = lo + 8.0 * Vec3::from_array(dims.map(|n| n as f32));
            // The walk box: whole cells inside the cell box, or (sometimes) past it.
            let clip = if i % 7 == 0 {
                (lo - 8.0, hi + 8.0)
            } else {
                let a = [0, 1, 2].map(|k| (rng.uniform_f32() * dims[k] as f32) as i32);
                let b = [0, 1, 2].map(|k| {
                    (a[k] + 1 + (rng.uniform_f32() * (dims[k] - a[k]) as f32) as i32).min(dims[k])
                });
                (
                    lo + 8.0 * Vec3::from_array(a.map(|c| c as f32)),
                    lo + 8.0 * Vec3::from_array(b.map(|c| c as f32)),
                )
            };
            let centre = (lo + hi) * 0.5;
            let extent = (hi - lo).max_element();
            let mut o = centre
                + Vec3::new(
                    coord(&mut rng, extent),
                    coord(&mut rng, extent),
                    coord(&mut rng, extent),
                );
            if i % 11 == 0 {
                // On a cell plane.
                o.x = lo.x + 8.0 * (rng.uniform_f32() * dims[0] as f32).floor();
            }
            let mut d = Vec3::new(
                coord(&mut rng, 1.0),
                coord(&mut rng, 1.0),
                coord(&mut rng, 1.0),
            );
            if i % 3 != 0 {
                // Towards a point of the walk box (keeping any special component).
                let u = Vec3::new(rng.uniform_f32(), rng.uniform_f32(), rng.uniform_f32());
                let aim = clip.0 + u * (clip.1 - clip.0) - o;
                for k in 0..3 {
                    if d[k].is_normal() {
                        d[k] = aim[k];
                    }
                }
            }
            let ray = Ray { o, d };
            let ranges = [
                (0.0, f32::INFINITY),
                (0.0, 1e3),
                (-1e3, 1e3),
                (rng.uniform_f32() * 10.0, 10.0 + rng.uniform_f32() * 10.0),
                (f32::NAN, 1.0),
                (0.0, f32::NAN),
                (5.0, 1.0),
            ];
            let (t0, t1) = ranges[i % ranges.len()];
            let cb = CellBox {
                lo,
                width: Vec3::splat(8.0),
                dims,
                clip,
            };
            let lanes = DdaState::enter(&cb, &ray, t0, t1);
            let scalar = DdaState::enter_scalar(&cb, &ray, t0, t1);
            assert_eq!(
                bits(&lanes),
                bits(&scalar),
                "dims {dims:?} lo {lo} clip {clip:?} ray {ray:?} t {t0}..{t1}\n{lanes:?}\n{scalar:?}"
            );
            entered += !scalar.done as u32;
        }
        // The cases above enter the box often enough to test the cell set-up.
        assert!(entered > 40_000, "only {entered} rays entered");
    }
}
