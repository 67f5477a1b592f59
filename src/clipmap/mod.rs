//! The spherical geometry clipmap (spherical-clipmaps.md): static ring mesh in view space,
//! per-level map-space texture windows with toroidal updates, and the choice of what to draw.

pub mod density;
pub mod draw_list;
pub mod levels;
pub mod mesh;
pub mod selection;
pub mod settings;

pub use mesh::{RingMesh, RingVertex};
pub use settings::{ClipmapSettings, TransformForm};
