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
//! near plane to the whole planet (`DESIGN.md`, "Conventions").

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
/// (1 mm in `DESIGN.md`'s stiff cases), or below it, where height is negative.
pub fn near_plane_m(height_above_terrain_m: f64) -> f64 {
    (0.5 * height_above_terrain_m).clamp(NEAR_PLANE_MIN_M, NEAR_PLANE_MAX_M)
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

/// A rectangle of whole pixels, row 0 at the top (wgpu's scissor rectangle).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelRect {
    pub x: u32,
    pub y: u32,
    pub width: u32,
    pub height: u32,
}

/// The pixels a sphere (centre in camera space, radius in metres) can cover in a `width_px` ×
/// `height_px` image, widened by `margin_px`: the rectangle between the sphere's four tangent
/// planes through the eye that contain the camera's x or y axis. None when the sphere reaches
/// the eye's plane or behind it (its projection is unbounded); an empty rectangle when it lies
/// beside the view.
///
/// For the x axis the planes are x = k·d (d = −z, the depth): the centre's distance to one is
/// |c_x − k·c_d|/√(1 + k²) = r, so (c_d² − r²)·k² − 2·c_x·c_d·k + c_x² − r² = 0, whose roots are
/// k = (c_x·c_d ± r·√(c_x² + c_d² − r²))/(c_d² − r²); ndc_x = k·f/aspect (f = 1/tan(fov_y/2)).
pub fn sphere_pixel_rect(
    fov_y_rad: f64,
    width_px: u32,
    height_px: u32,
    centre_camera_m: DVec3,
    radius_m: f64,
    margin_px: f64,
) -> Option<PixelRect> {
    let depth = -centre_camera_m.z;
    let a = depth * depth - radius_m * radius_m;
    if depth <= radius_m || a <= 0.0 {
        return None;
    }
    let focal = 1.0 / (0.5 * fov_y_rad).tan();
    let (width, height) = (f64::from(width_px), f64::from(height_px));
    let slopes = |c: f64| {
        let root = radius_m * (c * c + a).sqrt();
        ((c * depth - root) / a, (c * depth + root) / a)
    };
    let (x0, x1) = slopes(centre_camera_m.x);
    let (y0, y1) = slopes(centre_camera_m.y);
    let aspect = width / height.max(1.0);
    // NDC → pixels: x right from the left edge, y down from the top edge.
    let px = |k: f64| (k * focal / aspect + 1.0) * 0.5 * width;
    let py = |k: f64| (1.0 - k * focal) * 0.5 * height;
    let span = |lo: f64, hi: f64, size: f64| {
        let lo = (lo - margin_px).floor().clamp(0.0, size);
        let hi = (hi + margin_px).ceil().clamp(0.0, size);
        (lo as u32, (hi - lo).max(0.0) as u32)
    };
    let (x, w) = span(px(x0), px(x1), width);
    let (y, h) = span(py(y1), py(y0), height);
    Some(PixelRect {
        x,
        y,
        width: w,
        height: h,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every point of the sphere lands inside the rectangle, and the rectangle is no wider than
    /// the points' extent plus the margin and a pixel of rounding: it bounds the silhouette
    /// tightly wherever the sphere sits in the view, including off-centre and half outside.
    #[test]
    fn the_rectangle_bounds_a_sphere_tightly() {
        let (fov, w, h) = (60f64.to_radians(), 1920u32, 1080u32);
        let clip = clip_from_camera(fov, f64::from(w) / f64::from(h), 1.0);
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for case in 0..200 {
            let depth = 2.0 + 50.0 * next();
            let centre = DVec3::new((next() - 0.5) * depth * 1.6, (next() - 0.5) * depth, -depth);
            let radius = (depth - 1.0) * next();
            let rect = sphere_pixel_rect(fov, w, h, centre, radius, 2.0).unwrap();
            let (mut lo, mut hi) = (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN));
            for i in 0..200 {
                for j in 0..100 {
                    let (az, el) = (
                        i as f64 * std::f64::consts::TAU / 200.0,
                        (j as f64 + 0.5) * std::f64::consts::PI / 100.0
                            - 0.5 * std::f64::consts::PI,
                    );
                    let p = centre
                        + radius * DVec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
                    let ndc = ndc_from_camera_point(&clip, p);
                    let x = (ndc.x + 1.0) * 0.5 * f64::from(w);
                    let y = (1.0 - ndc.y) * 0.5 * f64::from(h);
                    lo = lo.min(DVec3::new(x, y, 0.0));
                    hi = hi.max(DVec3::new(x, y, 0.0));
                }
            }
            let inside = |v: f64, start: u32, len: u32, size: u32| {
                v.clamp(0.0, f64::from(size)) >= f64::from(start)
                    && v.clamp(0.0, f64::from(size)) <= f64::from(start + len)
            };
            for (x, y) in [(lo.x, lo.y), (hi.x, hi.y)] {
                assert!(
                    inside(x, rect.x, rect.width, w) && inside(y, rect.y, rect.height, h),
                    "case {case}: ({x}, {y}) outside {rect:?}"
                );
            }
            // Tight: each edge within the margin, a pixel of rounding and the sampling's half pixel
            // of the sampled extent (where on screen).
            let slack = |edge: f64, extent: f64, size: u32| {
                (edge - extent.clamp(0.0, f64::from(size))).abs() <= 3.5
            };
            assert!(
                slack(f64::from(rect.x), lo.x, w),
                "case {case}: left {rect:?} vs {lo}"
            );
            assert!(
                slack(f64::from(rect.x + rect.width), hi.x, w),
                "case {case}: right {rect:?} vs {hi}"
            );
            assert!(
                slack(f64::from(rect.y), lo.y, h),
                "case {case}: top {rect:?} vs {lo}"
            );
            assert!(
                slack(f64::from(rect.y + rect.height), hi.y, h),
                "case {case}: bottom {rect:?} vs {hi}"
            );
        }
        // The eye's plane through the sphere: no bound.
        assert!(sphere_pixel_rect(fov, w, h, DVec3::new(0.0, 0.0, -1.0), 2.0, 2.0).is_none());
        // Beside the view: empty.
        let beside = sphere_pixel_rect(fov, w, h, DVec3::new(100.0, 0.0, -10.0), 1.0, 2.0).unwrap();
        assert_eq!(beside.width, 0);
    }
}
