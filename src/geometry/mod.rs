//! The geometry the rest builds on: sonars ([`sonar`]: field of view, bins, beams, presets),
//! relative poses ([`pose`]: rotations, `p2 = R p1 + t`, placement, spherical ↔ Cartesian) and
//! rigs ([`rig`]: poses the way vehicles describe their mounts).

pub mod beam_table;
pub mod holoocean;
pub mod pose;
mod presets;
pub mod rig;
pub mod ros;
pub mod sonar;
mod sonar_file;

pub use pose::{RelativePose, Rotation, cart_to_sph, sph_to_cart};
pub use sonar::{BeamLayout, Sonar, SonarKind};
