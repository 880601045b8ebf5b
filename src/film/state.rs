//! The film's exact accumulator state as `u32` EXR channels: per pixel the sample count and
//! the f64 bits of Welford's mean and `M2` per channel, so that a resume or a merge starts from
//! the very values the renderer held, not from their f32 roundings.
use super::accum::{Film, CHANNELS};

/// The `u32` channels holding the accumulator state: count, then per channel (R, G, B, A) the
/// high and low 32 bits of the f64 mean, then the same of the f64 `M2`.
pub const STATE_CHANNELS: [&str; 1 + 4 * CHANNELS] = [
    "accum.count",
    "accum.mean_hi.R",
    "accum.mean_lo.R",
    "accum.mean_hi.G",
    "accum.mean_lo.G",
    "accum.mean_hi.B",
    "accum.mean_lo.B",
    "accum.mean_hi.A",
    "accum.mean_lo.A",
    "accum.m2_hi.R",
    "accum.m2_lo.R",
    "accum.m2_hi.G",
    "accum.m2_lo.G",
    "accum.m2_hi.B",
    "accum.m2_lo.B",
    "accum.m2_hi.A",
    "accum.m2_lo.A",
];

/// Index in [`STATE_CHANNELS`] of the high half of channel `c`'s mean (the low half follows).
pub const fn mean_channel(c: usize) -> usize {
    1 + 2 * c
}

/// Index in [`STATE_CHANNELS`] of the high half of channel `c`'s `M2` (the low half follows).
pub const fn m2_channel(c: usize) -> usize {
    1 + 2 * CHANNELS + 2 * c
}

/// The state channels of `film`, named as in [`STATE_CHANNELS`].
pub fn state_channels(film: &Film) -> Vec<(String, Vec<u32>)> {
    let px = film.pixels();
    let mut out: Vec<(String, Vec<u32>)> = STATE_CHANNELS
        .iter()
        .map(|n| (n.to_string(), Vec::with_capacity(px.len())))
        .collect();
    for p in px {
        out[0].1.push(p.count);
        for c in 0..CHANNELS {
            let (m, m2) = (p.mean[c].to_bits(), p.m2[c].to_bits());
            out[mean_channel(c)].1.push((m >> 32) as u32);
            out[mean_channel(c) + 1].1.push(m as u32);
            out[m2_channel(c)].1.push((m2 >> 32) as u32);
            out[m2_channel(c) + 1].1.push(m2 as u32);
        }
    }
    if let Some(p) = film.passes() {
        for (k, name) in p.names().iter().enumerate() {
            let mut chans: Vec<(String, Vec<u32>)> = pass_state_channels(name)
                .into_iter()
                .map(|n| (n, Vec::with_capacity(px.len())))
                .collect();
            for i in 0..px.len() {
                let (m, m2) = (p.mean(i, k), p.m2(i, k));
                for c in 0..3 {
                    let (m, m2) = (m[c].to_bits(), m2[c].to_bits());
                    chans[2 * c].1.push((m >> 32) as u32);
                    chans[2 * c + 1].1.push(m as u32);
                    chans[6 + 2 * c].1.push((m2 >> 32) as u32);
                    chans[6 + 2 * c + 1].1.push(m2 as u32);
                }
            }
            out.extend(chans);
        }
    }
    out
}

/// The `u32` state channels of light pass `name`: per R, G, B the high and low halves of the
/// f64 mean, then the same of the f64 `M2` (the pixel's count is the beauty's).
pub fn pass_state_channels(name: &str) -> Vec<String> {
    let mut v = Vec::with_capacity(12);
    for what in ["mean", "m2"] {
        for ch in ["R", "G", "B"] {
            v.push(format!("accum.{name}.{what}_hi.{ch}"));
            v.push(format!("accum.{name}.{what}_lo.{ch}"));
        }
    }
    v
}
