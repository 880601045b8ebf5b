//! Property checks of a built grid that any test can run, on synthetic grids and on every
//! grid loaded from disk alike:
//! * [`check_lookups`]: fast lookups agree with the brute-force [`VdbReference`];
//! * [`check_ray_bounds`]: DDA segments tile each ray's overlap with the cell box, and every
//!   reconstructed value along a ray lies within the bounds of its segment.
//!
//! Both are seeded and deterministic.
use brume_ffi::FloatGridData;

use super::adaptive::{AdaptiveMajorantIterator, AdaptiveMajorants, AdaptiveShape};
use super::bounds::LeafBounds;
use super::cost::CostModel;
use super::cull::{LeafCulling, VoxelCulling};
use super::dda::DdaMajorantIterator;
use super::grid::SparseGrid;
use super::reference::VdbReference;
use super::segment::MajorantSegment;
use crate::math::{DVec3, Ray, Vec3};

/// SplitMix64 (Steele, Lea and Flood, "Fast splittable pseudorandom number generators",
/// OOPSLA 2014): tiny, fast and good enough to drive property checks reproducibly.
#[derive(Clone, Debug)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)` with 53 random bits.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in `[a, b)`.
    pub fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.uniform()
    }

    /// Uniform integer in `0..n` (`n > 0`).
    pub fn below(&mut self, n: u64) -> u64 {
        self.next_u64() % n
    }

    pub fn coin(&mut self) -> bool {
        self.next_u64() >> 63 == 1
    }

    /// A uniformly distributed unit vector.
    pub fn unit_vector(&mut self) -> DVec3 {
        let z = self.range(-1.0, 1.0);
        let phi = self.range(0.0, std::f64::consts::TAU);
        let r = (1.0 - z * z).max(0.0).sqrt();
        DVec3::new(r * phi.cos(), r * phi.sin(), z)
    }
}

/// What [`check_lookups`] compared.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LookupCheckStats {
    pub points: u64,
    /// Lookups whose result matched the reference bit for bit.
    pub exact: u64,
    /// Largest relative difference seen (0 when all were exact).
    pub max_relative_error: f64,
}

/// Relative tolerance of [`check_lookups`]: OpenVDB's own agreement requirement.
pub const LOOKUP_TOLERANCE: f64 = 1e-6;

/// Compares `grid`'s voxel, nearest and trilinear lookups with a brute-force evaluation of
/// `data` (from which `grid` was converted) at `n_points` seeded random points: spread over
/// and around the cell box, at voxel centres and near brick boundaries, near leaves and tiles.
pub fn check_lookups(
    grid: &SparseGrid,
    data: &FloatGridData,
    n_points: usize,
    seed: u64,
) -> Result<LookupCheckStats, String> {
    let reference = VdbReference::new(data);
    let mut rng = SplitMix64(seed);
    let mut stats = LookupCheckStats::default();
    let bounds = grid.index_bounds();
    let (lo, hi) = if bounds.is_empty() {
        (DVec3::splat(-16.0), DVec3::splat(16.0))
    } else {
        (bounds.min.as_dvec3(), bounds.max.as_dvec3())
    };
    let margin = DVec3::splat(12.0);
    let mut compare = |what: &str, p: DVec3, got: f32, want: f32| -> Result<(), String> {
        stats.points += 1;
        if got.to_bits() == want.to_bits() || got == want {
            stats.exact += 1;
            return Ok(());
        }
        let rel = ((got - want).abs() as f64) / (want.abs().max(got.abs()) as f64).max(1e-30);
        stats.max_relative_error = stats.max_relative_error.max(rel);
        if rel > LOOKUP_TOLERANCE {
            return Err(format!("{what} at index point {p:?}: grid {got}, reference {want} (relative error {rel:e})"));
        }
        Ok(())
    };
    for n in 0..n_points {
        let p = match n % 4 {
            // Anywhere over and around the box.
            0 => DVec3::new(
                rng.range(lo.x - margin.x, hi.x + margin.x),
                rng.range(lo.y - margin.y, hi.y + margin.y),
                rng.range(lo.z - margin.z, hi.z + margin.z),
            ),
            // Near brick boundaries: within a voxel and a half of a multiple of 8.
            1 => DVec3::from_array([0, 1, 2].map(|a| {
                let cells = ((hi[a] - lo[a]) / 8.0).max(1.0) as u64;
                lo[a] + 8.0 * rng.below(cells + 1) as f64 + rng.range(-1.5, 1.5)
            })),
            // Exactly on voxel centres and half-way points, where floor and round switch.
            2 => DVec3::from_array([0, 1, 2].map(|a| {
                let span = (hi[a] - lo[a] + 4.0).max(1.0) as u64;
                (lo[a] - 2.0 + rng.below(span) as f64) + if rng.coin() { 0.5 } else { 0.0 }
            })),
            // Around a stored leaf or tile.
            _ => {
                let n_leaves = data.leaves.len() as u64;
                let n_tiles = data.tiles.len() as u64;
                if n_leaves + n_tiles == 0 {
                    DVec3::new(
                        rng.range(-20.0, 20.0),
                        rng.range(-20.0, 20.0),
                        rng.range(-20.0, 20.0),
                    )
                } else {
                    let k = rng.below(n_leaves + n_tiles);
                    let (origin, dim) = if k < n_leaves {
                        (data.leaves[k as usize].origin, 8.0)
                    } else {
                        let t = &data.tiles[(k - n_leaves) as usize];
                        (t.origin, t.dim as f64)
                    };
                    DVec3::from_array(
                        [0, 1, 2].map(|a| origin[a] as f64 + rng.range(-2.0, dim + 2.0)),
                    )
                }
            }
        };
        let r = p.round();
        let ijk = [r.x as i64, r.y as i64, r.z as i64];
        if ijk
            .iter()
            .all(|&c| c >= i32::MIN as i64 && c <= i32::MAX as i64)
        {
            let got = grid.voxel(ijk[0] as i32, ijk[1] as i32, ijk[2] as i32);
            compare("voxel", r, got, reference.voxel(ijk))?;
        }
        compare(
            "nearest",
            p,
            grid.sample_nearest(p),
            reference.sample_nearest(p),
        )?;
        compare(
            "trilinear",
            p,
            grid.sample_trilinear(p),
            reference.sample_trilinear(p),
        )?;
    }
    Ok(stats)
}

/// What [`check_ray_bounds`] exercised.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RayCheckStats {
    pub rays: u64,
    /// Rays with a non-empty overlap with the walk box ([`LeafBounds::walk_box`]).
    pub rays_hit: u64,
    pub segments: u64,
    /// Segments whose majorant is 0 (empty space the tracker skips).
    pub zero_majorant_segments: u64,
    /// Reconstructed values checked against their segment's bounds.
    pub samples: u64,
    /// Sum over samples of value / sigma_maj (for the mean tightness of the bounds).
    pub sum_value_over_majorant: f64,
    /// Segments of the merged adaptive structures (all three, summed).
    pub adaptive_segments: u64,
    /// Points of the global segment checked against the per-leaf bound that culls there
    /// (`volume::cull`; none where culling is not sound for the grid).
    pub culled_samples: u64,
    /// Points checked against the per-voxel bound (`volume::cull::VoxelCulling`) that thins
    /// the per-leaf and culled walks' collisions (none where it is not sound).
    pub voxel_samples: u64,
    /// Points of the ray inside the cell box but outside the walk box
    /// ([`LeafBounds::walk_box`]), where every walk clips and the values must be 0.
    pub clipped_samples: u64,
}

impl RayCheckStats {
    /// Mean of sample value over segment majorant: the fraction of real (not null) collisions
    /// a tracker would see.
    pub fn mean_value_over_majorant(&self) -> f64 {
        self.sum_value_over_majorant / self.samples.max(1) as f64
    }
}

/// Samples per ray at uniformly random parameters within random segments.
const SAMPLES_PER_RAY: usize = 4;

/// One random ray and parameter interval, mixing the cases a DDA gets wrong: generic rays,
/// axis-parallel rays with `±0.0` components, rays in cell faces and along cell edges, rays
/// from far outside aimed at the box, diagonal rays through cell corners, and odd intervals.
fn random_ray(rng: &mut SplitMix64, lo: Vec3, hi: Vec3) -> (Ray, f32, f32) {
    let lo = lo.as_dvec3();
    let hi = hi.as_dvec3();
    let ext = hi - lo;
    let margin = ext * 0.25 + 8.0;
    let in_box = |rng: &mut SplitMix64, m: DVec3| {
        DVec3::new(
            rng.range(lo.x - m.x, hi.x + m.x),
            rng.range(lo.y - m.y, hi.y + m.y),
            rng.range(lo.z - m.z, hi.z + m.z),
        )
    };
    let plane =
        |rng: &mut SplitMix64, a: usize| lo[a] + 8.0 * rng.below((ext[a] / 8.0) as u64 + 1) as f64;
    let signed_zero = |rng: &mut SplitMix64| if rng.coin() { 0.0 } else { -0.0 };
    let length = 10f64.powf(rng.range(-1.0, 1.0));

    let (o, mut d) = match rng.below(6) {
        0 => (in_box(rng, margin), rng.unit_vector()),
        1 => {
            let a = rng.below(3) as usize;
            let mut d = DVec3::new(signed_zero(rng), signed_zero(rng), signed_zero(rng));
            d[a] = if rng.coin() { 1.0 } else { -1.0 };
            (in_box(rng, margin), d)
        }
        2 => {
            let a = rng.below(3) as usize;
            let mut o = in_box(rng, margin);
            o[a] = plane(rng, a);
            let mut d = rng.unit_vector();
            if rng.coin() {
                d[a] = signed_zero(rng);
            }
            (o, d)
        }
        3 => {
            let a = rng.below(3) as usize;
            let b = (a + 1 + rng.below(2) as usize) % 3;
            let mut o = in_box(rng, margin);
            o[a] = plane(rng, a);
            o[b] = plane(rng, b);
            let mut d = rng.unit_vector();
            if rng.coin() {
                d[a] = signed_zero(rng);
                d[b] = signed_zero(rng);
            }
            (o, d)
        }
        4 => {
            let centre = (lo + hi) * 0.5;
            let o = centre + rng.unit_vector() * (ext.length() + 8.0) * rng.range(1.0, 3.0);
            let target = in_box(rng, DVec3::ZERO);
            (o, target - o)
        }
        _ => {
            let o = DVec3::new(plane(rng, 0), plane(rng, 1), plane(rng, 2));
            let pick = |rng: &mut SplitMix64| match rng.below(4) {
                0 => 1.0,
                1 => -1.0,
                2 => 0.0,
                _ => -0.0,
            };
            (o, DVec3::new(pick(rng), pick(rng), pick(rng)))
        }
    };
    if d.x != 0.0 || d.y != 0.0 || d.z != 0.0 {
        d = d.normalize() * length;
    }
    let ray = Ray::new(o.as_vec3(), d.as_vec3());

    let span = (ext.length() + 16.0) / length;
    let (t0, t1) = match rng.below(8) {
        0 => (f32::NEG_INFINITY, f32::INFINITY),
        1 => (0.0, f32::INFINITY),
        2 => {
            let t0 = rng.range(-span, span) as f32;
            (t0, t0 - rng.range(0.0, span) as f32)
        }
        3 => {
            let t = rng.range(-span, span) as f32;
            (t, t)
        }
        _ => {
            let t0 = rng.range(-span, span) as f32;
            (t0, t0 + rng.range(0.0, 2.0 * span) as f32)
        }
    };
    (ray, t0, t1)
}

/// Checks the segments of one ray and the values along it.
/// Points of `ray` in the cell box `box_` but outside `walk` (its overlap with the walk box,
/// `None` for none), which no walk visits: every value there must be exactly 0.
#[allow(clippy::too_many_arguments)]
fn check_clipped(
    grid: &SparseGrid,
    box_: &crate::math::Aabb,
    walk: Option<(f32, f32)>,
    ray: &Ray,
    t0: f32,
    t1: f32,
    rng: &mut SplitMix64,
    stats: &mut RayCheckStats,
) -> Result<(), String> {
    let Some((a, b)) = box_.intersect(ray, t0, t1).filter(|(a, b)| a < b) else {
        return Ok(());
    };
    if !(a.is_finite() && b.is_finite()) {
        return Ok(());
    }
    for _ in 0..SAMPLES_PER_RAY {
        let t = a + (b - a) * rng.uniform() as f32;
        if walk.is_some_and(|(wa, wb)| t >= wa && t <= wb) {
            continue;
        }
        let p = ray.at(t).as_dvec3();
        let (trilinear, nearest) = (grid.sample_trilinear(p), grid.sample_nearest(p));
        if trilinear != 0.0 || nearest != 0.0 {
            return Err(format!(
                "t = {t} lies outside the walk box {walk:?} but reads {trilinear} (trilinear), \
                 {nearest} (nearest)"
            ));
        }
        stats.clipped_samples += 1;
    }
    Ok(())
}

fn check_one_ray(
    grid: &SparseGrid,
    segments: &[MajorantSegment],
    expected: Option<(f32, f32)>,
    ray: &Ray,
    rng: &mut SplitMix64,
    stats: &mut RayCheckStats,
) -> Result<(), String> {
    let Some((t_enter, t_exit)) = expected else {
        return match segments.first() {
            None => Ok(()),
            Some(s) => Err(format!(
                "{} segment(s) for a ray that misses the box, first {s:?}",
                segments.len()
            )),
        };
    };
    let (first, last) = match (segments.first(), segments.last()) {
        (Some(f), Some(l)) => (f, l),
        _ => {
            return Err(format!(
                "no segments, but the ray overlaps the box over [{t_enter}, {t_exit}]"
            ))
        }
    };
    if first.t_min.to_bits() != t_enter.to_bits() || last.t_max.to_bits() != t_exit.to_bits() {
        return Err(format!(
            "segments span [{}, {}], box overlap is [{t_enter}, {t_exit}]",
            first.t_min, last.t_max
        ));
    }
    for (n, s) in segments.iter().enumerate() {
        // Written positively so NaN fails too.
        let well_formed = s.t_min < s.t_max && s.sigma_min <= s.sigma_maj;
        if !well_formed {
            return Err(format!("segment {n} is empty or has min above max: {s:?}"));
        }
        if let Some(next) = segments.get(n + 1) {
            if s.t_max.to_bits() != next.t_min.to_bits() {
                return Err(format!(
                    "segment {n} ends at {} but segment {} starts at {}",
                    s.t_max,
                    n + 1,
                    next.t_min
                ));
            }
        }
        stats.zero_majorant_segments += (s.sigma_maj == 0.0) as u64;
    }
    stats.segments += segments.len() as u64;

    let check_t = |t: f32, stats: &mut RayCheckStats| -> Result<(), String> {
        if !t.is_finite() {
            return Ok(());
        }
        // Exactly the point a renderer computes.
        let p = ray.at(t).as_dvec3();
        let trilinear = grid.sample_trilinear(p);
        let nearest = grid.sample_nearest(p);
        // Every segment containing t (two at a shared end) must bound the values.
        let start = segments.partition_point(|s| s.t_max < t);
        for s in segments[start..].iter().take_while(|s| s.t_min <= t) {
            for (what, v) in [("trilinear", trilinear), ("nearest", nearest)] {
                if !(s.sigma_min <= v && v <= s.sigma_maj) {
                    return Err(format!(
                        "{what} value {v} at t = {t} (index point {p:?}) outside segment {s:?}"
                    ));
                }
            }
            stats.samples += 1;
            if s.sigma_maj > 0.0 {
                stats.sum_value_over_majorant += (trilinear / s.sigma_maj) as f64;
            }
        }
        Ok(())
    };
    for s in segments {
        check_t(s.t_min, stats)?;
    }
    check_t(last.t_max, stats)?;
    for _ in 0..SAMPLES_PER_RAY {
        let s = segments[rng.below(segments.len() as u64) as usize];
        if s.t_min.is_finite() && s.t_max.is_finite() {
            let t = (s.t_min as f64 + rng.uniform() * (s.t_max as f64 - s.t_min as f64)) as f32;
            check_t(t.clamp(s.t_min, s.t_max), stats)?;
        }
    }
    Ok(())
}

/// The trilinear and nearest values at index point `p` (as the renderer's lookups read it)
/// are at most `bound`.
fn check_below(grid: &SparseGrid, p: Vec3, bound: f32) -> Result<(), String> {
    let pd = p.as_dvec3();
    for (what, v) in [
        ("trilinear", grid.sample_trilinear(pd)),
        ("nearest", grid.sample_nearest(pd)),
    ] {
        if !(v <= bound) {
            return Err(format!(
                "{what} value {v} at index point {p:?} above {bound}"
            ));
        }
    }
    Ok(())
}

/// The finite ends of `seg` and, when both are finite, [`SAMPLES_PER_RAY`] random parameters
/// inside it: where the culling checks read the bounds.
fn segment_parameters(seg: &MajorantSegment, rng: &mut SplitMix64) -> Vec<f32> {
    let (t_min, t_max) = (seg.t_min, seg.t_max);
    let mut ts = vec![t_min, t_max];
    if t_min.is_finite() && t_max.is_finite() {
        for _ in 0..SAMPLES_PER_RAY {
            let t = (t_min as f64 + rng.uniform() * (t_max as f64 - t_min as f64)) as f32;
            ts.push(t.clamp(t_min, t_max));
        }
    }
    ts.retain(|t| t.is_finite());
    ts
}

/// The culled global walk's bound at the ends of the global segment `seg` and at random
/// parameters in it: the per-leaf bound of the point's cell must bound the trilinear and
/// nearest values there (the point exactly as the renderer computes it) and lie within the
/// global bound.
fn check_culling(
    grid: &SparseGrid,
    cull: &LeafCulling,
    global_max: f32,
    ray: &Ray,
    seg: &MajorantSegment,
    rng: &mut SplitMix64,
    stats: &mut RayCheckStats,
) -> Result<(), String> {
    for t in segment_parameters(seg, rng) {
        let p = ray.at(t);
        let bound = cull.bound_at(p);
        let ratio = cull.ratio(p);
        if !(bound <= global_max && (0.0..=1.0).contains(&ratio)) {
            return Err(format!(
                "cell bound {bound} (ratio {ratio}) at t = {t} above the global {global_max}"
            ));
        }
        check_below(grid, p, bound).map_err(|e| format!("{e} at t = {t}: the cell bound"))?;
        stats.culled_samples += 1;
    }
    Ok(())
}

/// The per-voxel culling at random parameters of each segment of `segments` (and their
/// ends), against the raw majorant `bound(p, seg)` a collision there was kept with: the
/// voxel's bound must bound the trilinear and nearest values at the point exactly as the
/// renderer computes it, and the ratio lie in `[0, 1]` (1 where there is no voxel bound).
fn check_voxel_culling(
    grid: &SparseGrid,
    voxel: &VoxelCulling,
    ray: &Ray,
    segments: &[MajorantSegment],
    bound: impl Fn(Vec3, &MajorantSegment) -> f32,
    rng: &mut SplitMix64,
    stats: &mut RayCheckStats,
) -> Result<(), String> {
    for seg in segments.iter().filter(|s| s.sigma_maj > 0.0) {
        for t in segment_parameters(seg, rng) {
            let p = ray.at(t);
            let b = bound(p, seg);
            let r = voxel.ratio(p, b);
            let fine = voxel.bound_at(p);
            if !(0.0..=1.0).contains(&r) || (fine.is_none() && r != 1.0) {
                return Err(format!(
                    "voxel ratio {r} of {b} (voxel bound {fine:?}) at t = {t} (index point {p:?})"
                ));
            }
            let Some(fine) = fine else {
                continue;
            };
            check_below(grid, p, fine).map_err(|e| format!("{e} at t = {t}: the voxel bound"))?;
            stats.voxel_samples += 1;
        }
    }
    Ok(())
}

/// Shoots `n_rays` seeded random rays (in index space) at `grid` and checks, for each, that the
/// DDA over `bounds` tiles the ray's overlap with the cell box exactly (first `t_min` is the
/// entry, each `t_max` equals the next `t_min` bit for bit, the last `t_max` is the exit, no
/// empty segments, nothing for a miss) and that trilinear and nearest values at each segment's
/// ends and at random parameters inside lie in `[sigma_min, sigma_maj]` of every segment
/// containing that parameter. The global variant is checked for the same overlap and bounds.
pub fn check_ray_bounds(
    grid: &SparseGrid,
    bounds: &LeafBounds,
    n_rays: usize,
    seed: u64,
) -> Result<RayCheckStats, String> {
    let mut rng = SplitMix64(seed);
    let mut stats = RayCheckStats::default();
    let box_ = grid.index_bounds();
    let (lo, hi) = ray_target_box(grid, bounds);
    let walks = RayWalks::new(grid, bounds)?;
    let mut segments = Vec::new();
    let mut adaptive = Vec::new();
    // Every walk clips to the walk box: the segments tile the ray's overlap with it.
    let (walk_lo, walk_hi) = bounds.walk_box();
    let walk_box = crate::math::Aabb::new(box_.min.max(walk_lo), box_.max.min(walk_hi));
    for n in 0..n_rays {
        let (ray, t0, t1) = random_ray(&mut rng, lo, hi);
        let expected = if box_.is_empty() {
            None
        } else {
            walk_box.intersect(&ray, t0, t1).filter(|(a, b)| a < b)
        };
        if !box_.is_empty() {
            check_clipped(grid, &box_, expected, &ray, t0, t1, &mut rng, &mut stats)
                .map_err(|e| format!("ray {n} {ray:?} over [{t0}, {t1}]: {e}"))?;
        }
        segments.clear();
        segments.extend(DdaMajorantIterator::new(bounds, &ray, t0, t1, 1.0));
        stats.rays += 1;
        stats.rays_hit += expected.is_some() as u64;
        let context = |e: String| format!("ray {n} {ray:?} over [{t0}, {t1}]: {e}");
        check_one_ray(grid, &segments, expected, &ray, &mut rng, &mut stats).map_err(context)?;
        let global: Vec<MajorantSegment> =
            DdaMajorantIterator::global(bounds, &ray, t0, t1, 1.0).collect();
        walks
            .check_adaptive_walks(
                grid,
                &segments,
                &global,
                expected,
                (&ray, t0, t1),
                &mut adaptive,
                &mut rng,
                &mut stats,
            )
            .map_err(context)?;

        let want: Vec<MajorantSegment> = expected
            .map(|(a, b)| MajorantSegment {
                t_min: a,
                t_max: b,
                sigma_maj: bounds.global.max,
                sigma_min: bounds.global.min,
            })
            .into_iter()
            .collect();
        if global != want {
            return Err(context(format!(
                "global variant gave {global:?}, expected {want:?}"
            )));
        }
        walks
            .check_culled_walks(grid, &segments, &want, &ray, &mut rng, &mut stats)
            .map_err(context)?;
    }
    Ok(stats)
}

/// The box random rays are aimed at: the walk box (the non-zero cells,
/// [`LeafBounds::walk_box`]), where the walks run, else the grid's index box, else a fixed box
/// for an empty grid; the rays' starts and ends spread a margin around it, into the clipped
/// cells.
fn ray_target_box(grid: &SparseGrid, bounds: &LeafBounds) -> (Vec3, Vec3) {
    let box_ = grid.index_bounds();
    let (walk_lo, walk_hi) = bounds.walk_box();
    if box_.is_empty() {
        (Vec3::splat(-16.0), Vec3::splat(16.0))
    } else if walk_lo.cmplt(walk_hi).all() {
        (walk_lo, walk_hi)
    } else {
        (box_.min, box_.max)
    }
}

/// The walk structures [`check_ray_bounds`] checks every ray's DDA segments against, built
/// once per grid.
struct RayWalks<'a> {
    bounds: &'a LeafBounds,
    /// The adaptive hierarchy with every cell at level 0: must reproduce the DDA bit for bit.
    leaves: AdaptiveMajorants,
    /// Merged hierarchies (a sparse-ish scale, a dense one, and steps so dear that everything
    /// merges): must tile the ray and bound it like the DDA.
    merged: [AdaptiveMajorants; 3],
    culling: Option<LeafCulling<'a>>,
    voxel: Option<VoxelCulling<'a>>,
}

impl<'a> RayWalks<'a> {
    /// Builds the hierarchies and cullings of `bounds`, validating each merged hierarchy.
    fn new(grid: &'a SparseGrid, bounds: &'a LeafBounds) -> Result<Self, String> {
        let leaves = AdaptiveMajorants::all_leaves(bounds);
        let merged = [0.05f32, 2.0, 1e6]
            .map(|step| AdaptiveMajorants::build(bounds, 1.0, 1.0, CostModel::uniform(step)));
        for m in &merged {
            m.validate(bounds)?;
        }
        Ok(RayWalks {
            bounds,
            leaves,
            merged,
            culling: LeafCulling::new(bounds),
            voxel: VoxelCulling::new(bounds, &grid.cells, 1.0),
        })
    }

    /// The adaptive walks of one ray against its DDA `segments` and its `global` walk: level 0
    /// equal to the DDA, each merged walk tiling and bounding the ray, and a one-node (or
    /// culled) hierarchy equal to the global walk, which the renderer takes for it.
    #[allow(clippy::too_many_arguments)]
    fn check_adaptive_walks(
        &self,
        grid: &SparseGrid,
        segments: &[MajorantSegment],
        global: &[MajorantSegment],
        expected: Option<(f32, f32)>,
        (ray, t0, t1): (&Ray, f32, f32),
        adaptive: &mut Vec<MajorantSegment>,
        rng: &mut SplitMix64,
        stats: &mut RayCheckStats,
    ) -> Result<(), String> {
        adaptive.clear();
        adaptive.extend(AdaptiveMajorantIterator::new(
            &self.leaves,
            ray,
            t0,
            t1,
            1.0,
        ));
        if adaptive[..] != segments[..] {
            return Err(format!(
                "the adaptive walk at level 0 gave {adaptive:?}, the DDA {segments:?}"
            ));
        }
        for m in &self.merged {
            adaptive.clear();
            adaptive.extend(AdaptiveMajorantIterator::new(m, ray, t0, t1, 1.0));
            stats.adaptive_segments += adaptive.len() as u64;
            let mut sub = RayCheckStats::default();
            check_one_ray(grid, adaptive, expected, ray, rng, &mut sub)
                .map_err(|e| format!("adaptive: {e}"))?;
            // The renderer walks a one-node hierarchy (and the culled one) as the global
            // bound (`WalkPlan::of`): the two must agree bit for bit.
            let one_node = matches!(m.shape, AdaptiveShape::OneNode | AdaptiveShape::Culled);
            if one_node && adaptive[..] != global[..] {
                return Err(format!(
                    "the one-node adaptive walk gave {adaptive:?}, the global walk {global:?}"
                ));
            }
        }
        Ok(())
    }

    /// The leaf and voxel cullings along one ray: the cell bound over the global segment
    /// `want`, and the voxel bound over the per-leaf walk's `segments` and the culled global
    /// walk's.
    fn check_culled_walks(
        &self,
        grid: &SparseGrid,
        segments: &[MajorantSegment],
        want: &[MajorantSegment],
        ray: &Ray,
        rng: &mut SplitMix64,
        stats: &mut RayCheckStats,
    ) -> Result<(), String> {
        let g = self.bounds.global.max;
        if let (Some(cull), Some(seg)) = (&self.culling, want.first()) {
            check_culling(grid, cull, g, ray, seg, rng, stats)
                .map_err(|e| format!("culling: {e}"))?;
        }
        let Some(v) = &self.voxel else {
            return Ok(());
        };
        // The per-leaf walk keeps every collision of its segment before the voxel stage;
        // the culled global walk keeps those its cell test kept, at r * G.
        check_voxel_culling(grid, v, ray, segments, |_, s| s.sigma_maj, rng, stats)
            .map_err(|e| format!("voxel culling, per-leaf walk: {e}"))?;
        if let Some(cull) = &self.culling {
            check_voxel_culling(grid, v, ray, want, |p, _| cull.ratio(p) * g, rng, stats)
                .map_err(|e| format!("voxel culling, culled walk: {e}"))?;
        }
        Ok(())
    }
}
