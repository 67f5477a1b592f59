//! Which clipmap levels can be visible: bounds on the view-space angle θ̃ from the viewer
//! (`spherical-clipmaps.md` §4.5, eq. 5–8).
//!
//! Level i covers θ̃ ∈ (2^−(i+1)·π, 2^−i·π] (§3.4), so a level is drawn only if its θ̃ range meets
//! [θ̃min, θ̃max]: beyond θ̃max everything is behind the horizon, below θ̃min a ring is smaller
//! than a pixel.

use std::f64::consts::PI;

/// Smallest height above the surface used by the pixel bounds: keeps θ̃min positive (and level
/// counts finite) for a camera on or under the surface.
pub const MIN_HEIGHT_FOR_FOOTPRINT_M: f64 = 1e-6;

/// Angle at the centre between the point straight below a viewer at radius `viewer_radius_m` and
/// its horizon (tangent point) on a sphere of radius `occluder_radius_m`: acos(Ro/r), computed as
/// atan2(√((r − Ro)(r + Ro)), Ro) to stay accurate for r barely above Ro (heights of a millimetre).
/// 0 when r ≤ Ro.
fn horizon_angle_rad(occluder_radius_m: f64, viewer_radius_m: f64) -> f64 {
    let above_m = (viewer_radius_m - occluder_radius_m).max(0.0);
    let tangent_length_m = (above_m * (viewer_radius_m + occluder_radius_m)).sqrt();
    tangent_length_m.atan2(occluder_radius_m)
}

/// Largest θ̃ that can be visible (the coarse end of the level range): eq. 6,
/// θ̃max = acos(r/(r + h)), made safe for relief (§4.5's "safety factor").
///
/// The horizon is the tangent from the viewer to the occluding sphere of radius
/// Ro = R + `terrain_min_m` (the lowest terrain anywhere, so no lower ground can hide less):
/// acos(Ro/(R + h)). Beyond that tangent point a peak of height `terrain_max_m` still pokes above
/// the horizon line out to a further acos(Ro/(R + Hmax)). So
/// θ̃max = acos(Ro/(R + h)) + acos(Ro/(R + Hmax)), clamped to π. The viewer radius is clamped to
/// ≥ Ro (a viewer under the lowest terrain sees no further than one standing on it) and Ro to
/// ≥ 0. Finite for every finite input.
pub fn theta_tilde_max(
    radius_m: f64,
    viewer_height_m: f64,
    terrain_min_m: f64,
    terrain_max_m: f64,
) -> f64 {
    let occluder_radius_m = (radius_m + terrain_min_m).max(0.0);
    let viewer_radius_m = (radius_m + viewer_height_m).max(occluder_radius_m);
    let peak_radius_m = (radius_m + terrain_max_m).max(occluder_radius_m);
    let viewer_side_rad = horizon_angle_rad(occluder_radius_m, viewer_radius_m);
    let peak_side_rad = horizon_angle_rad(occluder_radius_m, peak_radius_m);
    (viewer_side_rad + peak_side_rad).min(PI)
}

/// Size in metres of one pixel on the ground straight below a viewer `height_above_surface_m`
/// above it: eq. 7, s ≈ h·tan(fov/#p), with h clamped to ≥ [`MIN_HEIGHT_FOR_FOOTPRINT_M`].
pub fn pixel_footprint_m(height_above_surface_m: f64, fov_y_rad: f64, pixels_y: u32) -> f64 {
    let height_m = height_above_surface_m.max(MIN_HEIGHT_FOR_FOOTPRINT_M);
    height_m * (fov_y_rad / f64::from(pixels_y.max(1))).tan()
}

/// Smallest θ̃ worth drawing (the fine end of the level range): eq. 8, θ̃min = s/R with the pixel
/// footprint s of eq. 7 ([`pixel_footprint_m`]). Grows linearly with height.
pub fn theta_tilde_min(
    radius_m: f64,
    height_above_surface_m: f64,
    fov_y_rad: f64,
    pixels_y: u32,
) -> f64 {
    pixel_footprint_m(height_above_surface_m, fov_y_rad, pixels_y) / radius_m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plain_eq6_without_relief() {
        let r: f64 = 6.371e6;
        let h: f64 = 1e5;
        let expected = (r / (r + h)).acos();
        assert!((theta_tilde_max(r, h, 0.0, 0.0) - expected).abs() < 1e-12);
        assert_eq!(theta_tilde_max(r, -5.0, 0.0, 0.0), 0.0);
    }

    #[test]
    fn clamps_to_pi() {
        assert_eq!(theta_tilde_max(1.0, 1e300, -2.0, 1e300), PI);
    }
}
