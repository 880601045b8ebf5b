//! The emitting media sampled as lights (`render::media_lights`) as the kernels read them: one
//! table of words (`shaders/common/media_lights.wgsl`), floats as their bits, after the
//! blackbody colours in the emission's tables (`super::buffers`).
//!
//! ```text
//! [0, MAX_MIX)            per VDB medium (RenderScene::vdb order): its record's offset, or NO_INDEX
//! [MAX_MIX, +n)           the cells' normalised cumulative weights (MediaLights::cdf)
//! [MAX_MIX + n, +2n)      per entry: its medium's record offset and the cell
//! records                 per emitting medium: RECORD_WORDS of header, then its cells'
//!                         weights e_c and majorants sigma_maj,c
//! ```
//!
//! A record's header: the VDB medium's index, the cell grid's dims and origin, the offsets of
//! its weights and majorants, three zero words, then the rows of `world_from_index` (twelve
//! floats).
use crate::gpu_types::GPU_MAX_VDB_MEDIA;
use crate::render::media_lights::MediaLights;
use crate::scene::NO_INDEX;

/// Words of a medium record's header.
pub const MEDIA_LIGHT_RECORD_WORDS: u32 = 24;

/// The table of `lights` (empty without them).
pub(super) fn media_light_words(lights: Option<&MediaLights>) -> Vec<u32> {
    let Some(lights) = lights else {
        return Vec::new();
    };
    let n = lights.cdf.len();
    let mut words = vec![NO_INDEX; GPU_MAX_VDB_MEDIA];
    words.extend(lights.cdf.iter().map(|c| c.to_bits()));
    let records_at = GPU_MAX_VDB_MEDIA + 3 * n;
    let mut records = Vec::new();
    let mut offsets = Vec::new();
    for m in &lights.media {
        let at = (records_at + records.len()) as u32;
        offsets.push(at);
        words[m.vdb as usize] = at;
        let cells = m.weight.len() as u32;
        let weight_at = at + MEDIA_LIGHT_RECORD_WORDS;
        records.push(m.vdb);
        records.extend(m.dims);
        records.extend(m.cell_origin.map(|o| o as u32));
        records.extend([weight_at, weight_at + cells, 0, 0, 0]);
        let f = m.world_from_index;
        let (x, y, z, t) = (
            f.matrix3.x_axis,
            f.matrix3.y_axis,
            f.matrix3.z_axis,
            f.translation,
        );
        for r in 0..3 {
            records.extend([x[r], y[r], z[r], t[r]].map(f32::to_bits));
        }
        records.extend(m.weight.iter().map(|w| w.to_bits()));
        records.extend(m.sigma_maj.iter().map(|s| s.to_bits()));
    }
    for &(slot, cell) in &lights.entries {
        words.extend([offsets[slot as usize], cell]);
    }
    debug_assert_eq!(words.len(), records_at);
    words.extend(records);
    words
}
