//! Brume's sparse volume layout, per-leaf bounds and the majorant DDA.
