//! The integrity checksum of a Brume EXR (`brume:checksum`): what lets `--resume` and
//! `brume merge` refuse a checkpoint or part that was damaged on disk or in transfer, where
//! OpenEXR itself has no checksum and a flipped bit in uncompressed data reads back as another
//! valid number.
//!
//! It covers every channel (name and sample bits, in name order) and every `brume:*` header
//! attribute but itself (name, type and value), so a change to the pixels, to the accumulator
//! state or to what the part says it holds is caught. It is FNV-1a 64 taken over 32-bit words
//! rather than bytes: each step (xor a word, multiply by an odd constant) is a bijection of
//! the state, so any single changed word changes the result, at a quarter of the byte-wise
//! cost. It detects accidents; it is no defence against deliberate forgery.
use exr::prelude::FlatSamples;

use super::metadata::{AttrValue, Metadata};

/// The header attribute that holds the checksum, as 16 hex digits.
pub const CHECKSUM_ATTRIBUTE: &str = "brume:checksum";

const OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
const PRIME: u64 = 0x0000_0100_0000_01b3;

struct WordHash(u64);

impl WordHash {
    fn word(&mut self, w: u32) {
        self.0 ^= w as u64;
        self.0 = self.0.wrapping_mul(PRIME);
    }
    /// Bytes, length first, zero-padded to whole words.
    fn bytes(&mut self, b: &[u8]) {
        self.word(b.len() as u32);
        for c in b.chunks(4) {
            let mut w = [0u8; 4];
            w[..c.len()].copy_from_slice(c);
            self.word(u32::from_le_bytes(w));
        }
    }
    /// A type tag, then the value's words.
    fn tagged(&mut self, tag: u32, words: impl IntoIterator<Item = u32>) {
        self.word(tag);
        words.into_iter().for_each(|w| self.word(w));
    }
}

/// The checksum of `channels` (any order: they are taken by name) and of `metadata`'s
/// `brume:*` attributes other than [`CHECKSUM_ATTRIBUTE`].
pub fn checksum<'a>(
    channels: impl IntoIterator<Item = (&'a str, &'a FlatSamples)>,
    metadata: &Metadata,
) -> u64 {
    let mut h = WordHash(OFFSET);
    let mut channels: Vec<(&str, &FlatSamples)> = channels.into_iter().collect();
    channels.sort_by(|a, b| a.0.cmp(b.0));
    for (name, samples) in channels {
        h.bytes(name.as_bytes());
        match samples {
            FlatSamples::F16(v) => h.tagged(16, v.iter().map(|x| x.to_bits() as u32)),
            FlatSamples::F32(v) => h.tagged(32, v.iter().map(|x| x.to_bits())),
            FlatSamples::U32(v) => h.tagged(0x7533_3200, v.iter().copied()),
        }
    }
    let mut attributes: Vec<(&str, &AttrValue)> = metadata
        .iter()
        .filter(|(n, _)| n.starts_with("brume:") && *n != CHECKSUM_ATTRIBUTE)
        .collect();
    attributes.sort_by(|a, b| a.0.cmp(b.0));
    for (name, value) in attributes {
        h.bytes(name.as_bytes());
        match value {
            AttrValue::Text(s) => {
                h.word(1);
                h.bytes(s.as_bytes());
            }
            AttrValue::Float(v) => h.tagged(2, [v.to_bits()]),
            AttrValue::Double(v) => {
                let b = v.to_bits();
                h.tagged(3, [(b >> 32) as u32, b as u32]);
            }
            AttrValue::Int(v) => h.tagged(4, [*v as u32]),
        }
    }
    h.0
}

/// The checksum as the attribute's text.
pub fn to_text(sum: u64) -> String {
    format!("{sum:016x}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn any_changed_word_name_or_attribute_changes_the_checksum() {
        let meta = Metadata::new()
            .with("brume:seed", AttrValue::Int(3))
            .with("other", AttrValue::Int(1));
        let a = FlatSamples::F32(vec![1.0, 2.0, 3.0]);
        let b = FlatSamples::U32(vec![7, 8, 9]);
        let base = checksum([("R", &a), ("accum.count", &b)], &meta);
        assert_eq!(base, checksum([("accum.count", &b), ("R", &a)], &meta));
        // Attributes outside `brume:` and the checksum itself are not covered.
        let with_sum = meta
            .clone()
            .with(CHECKSUM_ATTRIBUTE, AttrValue::Text(to_text(base)))
            .with("other", AttrValue::Int(2));
        assert_eq!(base, checksum([("R", &a), ("accum.count", &b)], &with_sum));
        let a2 = FlatSamples::F32(vec![1.0, 2.0, 3.000_000_2]);
        assert_ne!(base, checksum([("R", &a2), ("accum.count", &b)], &meta));
        let b2 = FlatSamples::U32(vec![7, 8, 9 ^ 1 << 31]);
        assert_ne!(base, checksum([("R", &a), ("accum.count", &b2)], &meta));
        assert_ne!(base, checksum([("G", &a), ("accum.count", &b)], &meta));
        let meta2 = Metadata::new().with("brume:seed", AttrValue::Int(4));
        assert_ne!(base, checksum([("R", &a), ("accum.count", &b)], &meta2));
    }
}
