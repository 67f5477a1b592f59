//! Sphere geometry in f64: coordinates, the view frame, the spherical-clipmap map transform and
//! level visibility bounds.
//!
//! Source: `spherical-clipmaps.md` §3.3 (eq. 1–4, the map transform), §4.4 (the seam meridian
//! beyond a pole), §4.5 (eq. 5–8, level visibility) and §5.1 (eq. 9–14, the trigonometric
//! approximation), with the sign and the cancellation-free form of `docs/design.md#conventions` and
//! `docs/design.md#numerics`.
//!
//! Everything here is f64 except the explicit f32 twins of the WGSL map transform in
//! [`map_transform`] (`*_f32`), which exist so that tests can measure what the GPU computes.
//!
//! # Conventions
//!
//! | quantity | definition |
//! | --- | --- |
//! | sphere | radius R (Earth: [`EARTH_RADIUS_M`]); heights in metres above it |
//! | φ (`phi_rad`) | longitude, east positive, wrapped to (−π, π] |
//! | θ (`theta_rad`) | colatitude: 0 at the north pole, π at the south pole |
//! | world frame (ECEF) | u(φ,θ) = (sin θ cos φ, sin θ sin φ, cos θ); +z north pole, +x at φ = 0 on the equator |
//! | map space | (s, t) = (φ, θ); raster rows run north to south |
//! | view frame | viewer at the view-space north pole (0, 0, 1): +x̃ south (increasing θ), +ỹ east, +z̃ up |
//! | view point (eq. 2) | p̃(φ̃, θ̃) = (cos φ̃ sin θ̃, sin φ̃ sin θ̃, cos θ̃); φ̃ = 0 points south, φ̃ = π/2 east, φ̃ = π north |
//! | view → world (φv = 0) | p_x = cos θv·p̃x + sin θv·p̃z, p_y = p̃y, p_z = −sin θv·p̃x + cos θv·p̃z (eq. 10's sign, not eq. 3's) |
//! | map offset | Δφ = φ − φv = atan2(p_y, p_x) ∈ (−π, π], Δθ = θ − θv ∈ [−π, π] |
//! | camera frame | right-handed: +x right, +y up, +z back (looks down −z) |
//! | clip space | wgpu: x, y ∈ [−1, 1] (y up), depth ∈ [0, 1]; reversed-Z, infinite far plane: depth = near/distance |
//! | heading, pitch, roll | heading clockwise from north, pitch negative looks down, roll positive banks right |
//!
//! Matrices are named target-from-source (`world_from_view`, `clip_from_camera`).

pub mod camera;
pub mod map_transform;
pub mod projection;
pub mod sphere;
pub mod trig;
pub mod visibility;

pub use camera::{Camera, ViewFrame, pixel_ray_view};
pub use map_transform::{Stretch, TransformUniformsF32};
pub use projection::{camera_from_clip, clip_from_camera, near_plane_m};
pub use visibility::{pixel_footprint_m, theta_tilde_max, theta_tilde_min};

/// Mean Earth radius in metres (the sphere every scene uses; `docs/design.md#conventions`).
pub const EARTH_RADIUS_M: f64 = 6_371_000.0;
