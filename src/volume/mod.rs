//! Brume's sparse volume layout, per-leaf bounds and the majorant DDA.
pub mod segment;
pub use segment::MajorantSegment;
