//! Brume's sparse volume layout, per-leaf bounds and the majorant DDA.
pub mod phase;
pub mod segment;
pub mod tracking;
pub use segment::MajorantSegment;
