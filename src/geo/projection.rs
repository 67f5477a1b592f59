//! Reversed-Z perspective projection with an infinite far plane, in f64.
//!
//! | space | convention |
//! | --- | --- |
//! | camera | right-handed, +x right, +y up, looks down −z |
//! | clip → NDC | wgpu: x, y ∈ [−1, 1] with +y up, depth ∈ [0, 1] |
//! | depth | near/(−z): 1 on the near plane, → 0 at infinity (never 0 for a finite point) |
//!
//! Reversed-Z stores depth = near/d. An f32 has the same relative precision (2⁻²⁴) at every
//! magnitude and this depth is a power law in d, so distances resolve to about d·6e-8 from the
//! near plane to the whole planet (`docs/design.md#conventions`).

use glam::{DMat4, DVec3, DVec4};

/// Smallest near plane distance in metres (camera 0.2 mm above the ground).
pub const NEAR_PLANE_MIN_M: f64 = 1e-4;
/// Largest near plane distance in metres (keeps nearby aircraft-height terrain unclipped).
pub const NEAR_PLANE_MAX_M: f64 = 100.0;

/// Near plane distance for a camera `height_above_terrain_m` above the terrain below it:
/// clamp(0.5·h, 1e-4 m, 100 m).
///
/// With reversed-Z f32 depth the relative depth precision is roughly constant, so a small near
/// plane costs nothing far away; it only has to stay closer than the nearest visible surface
/// (half the height leaves room for ground rising in front of the camera). The cap keeps it small
/// against terrain seen from high up; the floor keeps it positive for a camera on the ground
/// (1 mm in `docs/design.md#stiff-cases`), or below it, where height is negative.
pub fn near_plane_m(height_above_terrain_m: f64) -> f64 {
    (0.5 * height_above_terrain_m).clamp(NEAR_PLANE_MIN_M, NEAR_PLANE_MAX_M)
}

/// The focal length in pixels of an image `height_px` tall: pixels per radian at its centre,
/// (H/2)/tan(fov_y/2) (λ of error-bounded-projective-grid.md eq. 3, the paper's w/φ). The one
/// copy the planner, the renderer, the metric and the projected grid share.
pub fn focal_length_px(height_px: u32, fov_y_rad: f64) -> f64 {
    0.5 * f64::from(height_px.max(1)) / (0.5 * fov_y_rad).tan()
}

/// Reversed-Z infinite perspective: clip = (x·f/aspect, y·f, near, −z) with f = 1/tan(fov_y/2),
/// so depth = near/(−z) (1 at the near plane, → 0 at infinity). `aspect` is width/height.
pub fn clip_from_camera(fov_y_rad: f64, aspect: f64, near_m: f64) -> DMat4 {
    let focal = 1.0 / (0.5 * fov_y_rad).tan();
    DMat4::from_cols(
        DVec4::new(focal / aspect, 0.0, 0.0, 0.0),
        DVec4::new(0.0, focal, 0.0, 0.0),
        DVec4::new(0.0, 0.0, 0.0, -1.0),
        DVec4::new(0.0, 0.0, near_m, 0.0),
    )
}

/// Exact inverse of [`clip_from_camera`]: maps (ndc_x, ndc_y, depth, 1) to a homogeneous camera
/// point whose division by w gives (ndc_x·aspect/f, ndc_y/f, −1)·near/depth.
pub fn camera_from_clip(fov_y_rad: f64, aspect: f64, near_m: f64) -> DMat4 {
    let focal = 1.0 / (0.5 * fov_y_rad).tan();
    DMat4::from_cols(
        DVec4::new(aspect / focal, 0.0, 0.0, 0.0),
        DVec4::new(0.0, 1.0 / focal, 0.0, 0.0),
        DVec4::new(0.0, 0.0, 0.0, 1.0 / near_m),
        DVec4::new(0.0, 0.0, -1.0, 0.0),
    )
}

/// Projects a camera-space point to (ndc_x, ndc_y, depth). The point must be in front of the
/// camera (z < 0).
pub fn ndc_from_camera_point(clip_from_camera: &DMat4, point_camera_m: DVec3) -> DVec3 {
    clip_from_camera.project_point3(point_camera_m)
}

/// Reconstructs the camera-space point from (ndc_x, ndc_y, depth) with depth > 0 (depth 0 is the
/// point at infinity; use [`ray_camera`] for a direction instead).
pub fn camera_point_from_ndc(camera_from_clip: &DMat4, ndc: DVec3) -> DVec3 {
    camera_from_clip.project_point3(ndc)
}

/// Unit direction in camera space through (ndc_x, ndc_y), for every depth including infinity.
pub fn ray_camera(fov_y_rad: f64, aspect: f64, ndc_x: f64, ndc_y: f64) -> DVec3 {
    let tan_half = (0.5 * fov_y_rad).tan();
    DVec3::new(ndc_x * tan_half * aspect, ndc_y * tan_half, -1.0).normalize()
}
