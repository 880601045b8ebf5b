//! The CPU path tracer, the reference every backend is checked against: one path per camera
//! sample ([`path::radiance`]) over the tiles of the image ([`tile`]), its free flights through
//! the media ([`media`], [`homogeneous`], [`mixture`], [`nested`], [`views`]), the scattering
//! distances it samples towards point lights ([`equiangular`]), its light samples on emitting
//! media ([`emitters`]), the directions surfaces draw towards the media those light
//! ([`lit_media`]) and its BSDFs
//! ([`bsdf`]), each compiled for the scene's [`features`]. What it renders, the prepared scene
//! and settings, is `crate::render`.
pub mod bsdf;
pub mod emitters;
pub mod equiangular;
pub mod features;
pub mod flight;
pub mod glow;
pub mod homogeneous;
pub mod lit_media;
pub mod media;
pub mod mixture;
pub mod nested;
pub mod next_event;
pub mod path;
pub mod path_state;
pub mod tile;
pub mod views;
