//! The phase function of a VDB medium as the GPU reads it ([`GpuPhase`]): a kind and the
//! parameters of `volume::phases::Phase`, evaluated and sampled by `shaders/common/phase.wgsl`.
use bytemuck::{Pod, Zeroable};
use std::mem::size_of;

use super::GPU_MAX_VDB_MEDIA;
use crate::volume::phases::Phase;

wgsl_enum! {
    /// Which phase function a [`GpuPhase`] holds; values of [`GpuPhase::kind`].
    pub enum GpuPhaseKind {
        /// `Phase::HenyeyGreenstein`: `g_a`.
        HenyeyGreenstein = 0 => "PHASE_HG",
        /// `Phase::TwoLobe`: `w HG_{g_a} + (1 - w) HG_{g_b}`.
        TwoLobe = 1 => "PHASE_TWO_LOBE",
        /// `Phase::Draine`: `g_a`, `alpha`.
        Draine = 2 => "PHASE_DRAINE",
        /// `Phase::Mie`: `(1 - w) HG_{g_a} + w Draine_{g_b, alpha}`.
        Mie = 3 => "PHASE_MIE",
        /// `Phase::Rayleigh`.
        Rayleigh = 4 => "PHASE_RAYLEIGH",
    }
}

/// A phase function: its [`GpuPhaseKind`] and parameters (unused ones zero).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuPhase {
    pub kind: u32,
    /// The Henyey-Greenstein lobe's `g` (Mie: the HG part's; Draine: Draine's own).
    pub g_a: f32,
    /// The second lobe's `g` (two-lobe: lobe `b`; Mie: the Draine part's).
    pub g_b: f32,
    /// The first lobe's weight (two-lobe: `w`; Mie: the Draine part's `w_d`).
    pub w: f32,
    /// Draine's `alpha` (Draine and Mie).
    pub alpha: f32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}
const _: () = assert!(size_of::<GpuPhase>() == 32);

impl GpuPhase {
    /// The GPU record of `phase`.
    pub fn of(phase: &Phase) -> GpuPhase {
        let (kind, g_a, g_b, w, alpha) = match *phase {
            Phase::HenyeyGreenstein(hg) => (GpuPhaseKind::HenyeyGreenstein, hg.g, 0.0, 0.0, 0.0),
            Phase::TwoLobe { a, b, w } => (GpuPhaseKind::TwoLobe, a.g, b.g, w, 0.0),
            Phase::Draine(d) => (GpuPhaseKind::Draine, d.hg.g, 0.0, 0.0, d.alpha),
            Phase::Mie { hg, draine, w_d } => {
                (GpuPhaseKind::Mie, hg.g, draine.hg.g, w_d, draine.alpha)
            }
            Phase::Rayleigh => (GpuPhaseKind::Rayleigh, 0.0, 0.0, 0.0, 0.0),
        };
        GpuPhase {
            kind: kind as u32,
            g_a,
            g_b,
            w,
            alpha,
            ..Default::default()
        }
    }

    /// The records of up to [`GPU_MAX_VDB_MEDIA`] media's phase functions, in order (the rest
    /// zero: Henyey-Greenstein with `g = 0`).
    pub fn table<'a>(phases: impl Iterator<Item = &'a Phase>) -> [GpuPhase; GPU_MAX_VDB_MEDIA] {
        let mut t = [GpuPhase::default(); GPU_MAX_VDB_MEDIA];
        for (r, phase) in t.iter_mut().zip(phases) {
            *r = GpuPhase::of(phase);
        }
        t
    }
}
