//! The homogeneous media a path is inside: a small stack per path, following the containment
//! rule of glTF's `KHR_materials_volume` ("the medium of a closed mesh is inside it; the
//! surrounding medium is outside").
//!
//! Crossing the closed mesh of a material with an interior medium pushes that medium when the
//! path enters and removes it when the path leaves, so after leaving an inner mesh the path is
//! back in the outer one (a glass of water in fog: fog, glass, water, glass, fog). The current
//! medium is the innermost, the top: nested meshes replace, not add, their container's medium,
//! as the spec's containment implies. Thin-walled surfaces and materials without a medium are
//! not volume boundaries and leave the stack alone. VDB media (`BRUME_medium_vdb`) are not
//! bounded by meshes; they add to whatever homogeneous medium surrounds them
//! (`integrator::mixture`).
//!
//! Leaving removes the topmost entry of that medium, not blindly the top, so meshes that
//! intersect instead of nesting cannot corrupt the stack; leaving a medium the stack does not
//! hold (a path that started on a boundary) changes nothing.
use crate::scene::NO_INDEX;

/// How many nested media a path can be inside at once. `RenderScene::new` refuses scenes
/// whose closed media meshes nest deeper, naming the file and the innermost mesh's node, so a
/// path of a valid scene never overflows. The GPU mirror holds the same four entries in one
/// `vec4<u32>`.
pub const MAX_NESTED_MEDIA: usize = 4;

/// The media a path is inside, outermost first.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MediumStack {
    media: [u32; MAX_NESTED_MEDIA],
    len: u8,
}

impl Default for MediumStack {
    fn default() -> Self {
        MediumStack::EMPTY
    }
}

impl MediumStack {
    pub const EMPTY: MediumStack = MediumStack {
        media: [NO_INDEX; MAX_NESTED_MEDIA],
        len: 0,
    };

    /// A stack holding `media`, outermost first (at most [`MAX_NESTED_MEDIA`] are kept: the
    /// innermost ones).
    pub fn from_outermost(media: &[u32]) -> MediumStack {
        let mut s = MediumStack::EMPTY;
        let skip = media.len().saturating_sub(MAX_NESTED_MEDIA);
        for &m in &media[skip..] {
            s.push(m);
        }
        s
    }

    /// The innermost medium: the one the path is in.
    #[inline]
    pub fn top(&self) -> Option<u32> {
        (self.len > 0).then(|| self.media[self.len as usize - 1])
    }

    /// The media, outermost first.
    pub fn entries(&self) -> &[u32] {
        &self.media[..self.len as usize]
    }

    pub fn len(&self) -> usize {
        self.len as usize
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Enters a medium. A full stack keeps its entries and ignores the push (only reachable
    /// with intersecting, non-nested meshes: valid scenes are checked at preparation).
    #[inline]
    fn push(&mut self, m: u32) {
        if (self.len as usize) < MAX_NESTED_MEDIA {
            self.media[self.len as usize] = m;
            self.len += 1;
        }
    }

    /// Leaves a medium: removes its topmost entry, if any.
    #[inline]
    fn remove(&mut self, m: u32) {
        let n = self.len as usize;
        if let Some(i) = self.media[..n].iter().rposition(|&x| x == m) {
            self.media.copy_within(i + 1..n, i);
            self.media[n - 1] = NO_INDEX;
            self.len -= 1;
        }
    }

    /// Crosses the boundary of a material whose interior medium is `interior` (`NO_INDEX`:
    /// none, the stack is unchanged), `entering` its closed mesh or leaving it.
    #[inline]
    pub fn cross(&mut self, interior: u32, entering: bool) {
        if interior == NO_INDEX {
            return;
        }
        if entering {
            self.push(interior);
        } else {
            self.remove(interior);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn leaving_an_inner_mesh_returns_to_the_outer_medium() {
        let mut s = MediumStack::from_outermost(&[0]);
        s.cross(1, true);
        assert_eq!(s.top(), Some(1));
        s.cross(NO_INDEX, true);
        assert_eq!(s.top(), Some(1));
        s.cross(1, false);
        assert_eq!(s.top(), Some(0));
        s.cross(0, false);
        assert_eq!(s.top(), None);
        // Leaving a medium the path is not in changes nothing.
        s.cross(3, false);
        assert!(s.is_empty());
    }

    #[test]
    fn intersecting_meshes_remove_their_own_entry() {
        let mut s = MediumStack::EMPTY;
        s.cross(0, true);
        s.cross(1, true);
        s.cross(0, false);
        assert_eq!((s.top(), s.len()), (Some(1), 1));
        for m in 0..6 {
            s.cross(m, true);
        }
        assert_eq!(s.len(), MAX_NESTED_MEDIA);
    }
}
