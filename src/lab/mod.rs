//! The lab: what Brume is measured and checked with, beside rendering. Benchmarks of the
//! estimators, majorants, walks, the GPU and the peers (`brume bench`, [`bench`]), and the
//! reference renderers: driving Cycles and Mitsuba 3 on a Brume scene, translating the scene
//! for them, importing a `.blend`, and comparing their images with Brume's ([`reference`]).
pub mod bench;
pub mod reference;

use crate::backend::cpu;

/// [`cpu::render_scene`] with its preparation error as the lab reports errors.
pub fn render_cpu(
    scene: &crate::scene::Scene,
    settings: &crate::render::RenderSettings,
) -> anyhow::Result<cpu::RenderOutput> {
    cpu::render_scene(scene, settings).map_err(anyhow::Error::msg)
}
