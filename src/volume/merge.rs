//! The majorant of overlapping media: several segment streams merged into one whose bounds are
//! the sums.
//!
//! Extinction adds where media overlap (`sigma_t = sum_k sigma_t,k`), so on any piece of the
//! ray where stream `k` gives the bounds `[sigma_min,k, sigma_maj,k]` the sum lies in
//! `[sum_k sigma_min,k, sum_k sigma_maj,k]`: the sum of majorants is a majorant, the sum of
//! minorants a minorant (the control extinction of decomposition tracking). [`MergedSegments`]
//! cuts the ray at every boundary of every stream and emits one segment per piece with those
//! sums, so the free-flight loop and every estimator run unchanged on the sum (pbrt-v4 has
//! one medium per ray; Cycles and Mitsuba add overlapping volumes' coefficients the same way).
//!
//! Each input must be sorted by `t_min` with disjoint segments (gaps are empty space), which
//! every majorant iterator of `volume` yields; so is the output. A piece covered by no stream
//! is a gap in the output. Ends may be infinite.
// Comparisons such as `!(x > 0.0)` are written negated on purpose: NaN takes the safe branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::MajorantSegment;

/// One input stream and the segment it is in (or the next one it will enter).
#[derive(Clone)]
struct Stream<I> {
    it: I,
    cur: Option<MajorantSegment>,
}

/// The merge of several majorant segment streams (see the module doc).
#[derive(Clone)]
pub struct MergedSegments<I> {
    streams: Vec<Stream<I>>,
    /// Where the next output segment starts: everything before is emitted.
    t: f32,
}

impl<I: Iterator<Item = MajorantSegment>> MergedSegments<I> {
    pub fn new(streams: impl IntoIterator<Item = I>) -> Self {
        let streams: Vec<Stream<I>> = streams
            .into_iter()
            .map(|mut it| {
                let cur = it.next();
                Stream { it, cur }
            })
            .collect();
        MergedSegments {
            streams,
            t: f32::NEG_INFINITY,
        }
    }
}

impl<I: Iterator<Item = MajorantSegment>> Iterator for MergedSegments<I> {
    type Item = MajorantSegment;

    fn next(&mut self) -> Option<MajorantSegment> {
        let t = self.t;
        // Leave behind every segment that ends at or before `t` (and any empty or NaN one:
        // `!(t_max > t)` is true for NaN, so a broken stream cannot stall the merge).
        let mut start = f32::INFINITY;
        for s in &mut self.streams {
            while let Some(seg) = s.cur {
                if !(seg.t_max > t) || !(seg.t_max > seg.t_min) {
                    s.cur = s.it.next();
                } else {
                    break;
                }
            }
            if let Some(seg) = s.cur {
                start = start.min(seg.t_min.max(t));
            }
        }
        if start == f32::INFINITY {
            return None;
        }
        // The piece from `start` to the nearest boundary of any stream.
        let mut end = f32::INFINITY;
        let (mut sigma_maj, mut sigma_min) = (0.0f32, 0.0f32);
        for seg in self.streams.iter().filter_map(|s| s.cur) {
            if seg.t_min > start {
                end = end.min(seg.t_min);
            } else {
                end = end.min(seg.t_max);
                sigma_maj += seg.sigma_maj;
                sigma_min += seg.sigma_min;
            }
        }
        self.t = end;
        Some(MajorantSegment {
            t_min: start,
            t_max: end,
            sigma_maj,
            sigma_min,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seg(t_min: f32, t_max: f32, sigma_maj: f32, sigma_min: f32) -> MajorantSegment {
        MajorantSegment {
            t_min,
            t_max,
            sigma_maj,
            sigma_min,
        }
    }

    #[test]
    fn overlapping_streams_sum_their_bounds_piece_by_piece() {
        let a = vec![seg(0.0, 2.0, 1.0, 0.5), seg(3.0, 5.0, 2.0, 1.0)];
        let b = vec![seg(1.0, 4.0, 10.0, 0.0), seg(4.0, f32::INFINITY, 20.0, 3.0)];
        let m: Vec<_> = MergedSegments::new([a.into_iter(), b.into_iter()]).collect();
        assert_eq!(
            m,
            vec![
                seg(0.0, 1.0, 1.0, 0.5),
                seg(1.0, 2.0, 11.0, 0.5),
                seg(2.0, 3.0, 10.0, 0.0),
                seg(3.0, 4.0, 12.0, 1.0),
                seg(4.0, 5.0, 22.0, 4.0),
                seg(5.0, f32::INFINITY, 20.0, 3.0),
            ]
        );
    }

    #[test]
    fn one_stream_passes_through_and_gaps_stay_gaps() {
        let a = vec![seg(0.0, 1.0, 1.0, 0.0), seg(2.0, 3.0, 4.0, 1.0)];
        let m: Vec<_> = MergedSegments::new([a.clone().into_iter()]).collect();
        assert_eq!(m, a);
        let none: Vec<MajorantSegment> = Vec::new();
        let m: Vec<_> =
            MergedSegments::new([none.clone().into_iter(), a.clone().into_iter()]).collect();
        assert_eq!(m, a);
        assert_eq!(MergedSegments::new([none.into_iter()]).count(), 0);
    }

    #[test]
    fn the_majorant_optical_depth_is_the_sum_of_the_streams() {
        // Irregular streams: the merged optical depth over any prefix equals the sum.
        let a: Vec<_> = (0..37)
            .map(|i| seg(i as f32 * 0.3, i as f32 * 0.3 + 0.2, (i % 5) as f32, 0.0))
            .collect();
        let b: Vec<_> = (0..23)
            .map(|i| {
                seg(
                    i as f32 * 0.47 + 0.1,
                    i as f32 * 0.47 + 0.5,
                    1.5 + (i % 3) as f32,
                    0.0,
                )
            })
            .collect();
        let depth = |s: &[MajorantSegment], t_max: f32| -> f64 {
            s.iter()
                .map(|g| (g.t_max.min(t_max) - g.t_min).max(0.0) as f64 * g.sigma_maj as f64)
                .sum()
        };
        let m: Vec<_> =
            MergedSegments::new([a.clone().into_iter(), b.clone().into_iter()]).collect();
        for w in m.windows(2) {
            assert!(w[0].t_max <= w[1].t_min && w[0].t_min < w[0].t_max);
        }
        for t_max in [0.05f32, 1.0, 3.3, 7.7, 100.0] {
            let want = depth(&a, t_max) + depth(&b, t_max);
            assert!(
                (depth(&m, t_max) - want).abs() < 1e-4 * (1.0 + want),
                "{t_max}"
            );
        }
    }
}
