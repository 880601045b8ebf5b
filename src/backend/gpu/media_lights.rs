//! The emitting media sampled as lights (`render::media_lights`) as the kernels read them: one
//! table of words (`shaders/common/media_lights.wgsl`), floats as their bits, after the
//! blackbody colours in the emission's tables (`super::buffers`).
//!
//! ```text
//! [0, MAX_MIX)            per VDB medium (RenderScene::vdb order): its record's offset, or NO_INDEX
//! [MAX_MIX, +n)           per item of the light tree: its trail (CellTree::trails)
//! [MAX_MIX + n, +2n)      per item: its medium's record offset and the cell
//! [MAX_MIX + 3n, +6m)     the tree's m = 2n - 1 nodes (TreeNode: centre, power, r^2, link)
//! records                 per emitting medium: RECORD_WORDS of header, then its cells'
//!                         weights e_c, majorants sigma_maj,c and items (NO_INDEX: none)
//! ```
//!
//! A record's header: the VDB medium's index, the cell grid's dims and origin, the offsets of
//! its weights, majorants and items, the cell's world volume `V_c`, a zero word, then the rows
//! of `world_from_index` (twelve floats).
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
    let n = lights.entries.len();
    let mut words = vec![NO_INDEX; GPU_MAX_VDB_MEDIA];
    words.extend(&lights.tree.trails);
    let records_at = media_light_nodes(lights) as usize + 6 * lights.tree.nodes.len();
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
        records.extend([
            weight_at,
            weight_at + cells,
            weight_at + 2 * cells,
            m.volume.to_bits(),
            0,
        ]);
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
        records.extend(&m.entry);
    }
    for &(slot, cell) in &lights.entries {
        words.extend([offsets[slot as usize], cell]);
    }
    debug_assert_eq!(words.len(), GPU_MAX_VDB_MEDIA + 3 * n);
    for node in &lights.tree.nodes {
        words.extend(node.centre.to_array().map(f32::to_bits));
        words.extend([node.power.to_bits(), node.radius2.to_bits(), node.link]);
    }
    debug_assert_eq!(words.len(), records_at);
    words.extend(records);
    words
}

/// The word at which the tree's nodes start in the table of `lights`.
pub(super) fn media_light_nodes(lights: &MediaLights) -> u32 {
    (GPU_MAX_VDB_MEDIA + 3 * lights.entries.len()) as u32
}
