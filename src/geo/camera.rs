//! The camera in f64: where it is (latitude, longitude, altitude), where it looks (heading, pitch,
//! roll), and the frames the renderer needs: world-from-view at the viewer and view-from-camera.
//!
//! The GPU works in view space (viewer at the view-space north pole, `spherical-clipmaps.md`
//! §3.3), so the camera orientation is given in view space directly and no world transform ever
//! reaches the GPU (`docs/design.md#numerics`: the GPU only sees quantities relative to the viewer).
//!
//! | frame | axes |
//! | --- | --- |
//! | world (ECEF) | +z north pole, +x at (φ, θ) = (0, π/2) |
//! | local ENU at the viewer | east, north, up |
//! | view | x̃ = south, ỹ = east, z̃ = up (so east = ỹ, north = −x̃, up = z̃) |
//! | camera | x = right, y = up, z = back (looks down −z), right-handed |
//!
//! | angle | meaning |
//! | --- | --- |
//! | heading | clockwise from north, degrees |
//! | pitch | above the horizontal, degrees; negative looks down, −90 straight down |
//! | roll | about the forward axis, degrees; positive banks right (right side down) |

use glam::{DMat3, DMat4, DVec3};

use super::EARTH_RADIUS_M;
use super::projection::{clip_from_camera, ray_camera};
use super::sphere::{
    east_unit_vector, ecef_m, phi_theta_from_lat_lon_deg, south_unit_vector, unit_vector,
};

/// A viewpoint above a sphere of radius [`EARTH_RADIUS_M`], all angles in degrees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Latitude, degrees north, in [−90, 90].
    pub lat_deg: f64,
    /// Longitude, degrees east (any value; wrapped to (−180, 180]).
    pub lon_deg: f64,
    /// Height above the sphere of radius R, metres.
    pub altitude_m: f64,
    /// Clockwise from north, degrees. At a pole "north" is the limit along the meridian
    /// `lon_deg` (towards the pole, i.e. −x̃), so the heading stays meaningful there.
    pub heading_deg: f64,
    /// Above the horizontal, degrees; negative looks down.
    pub pitch_deg: f64,
    /// About the forward axis, degrees; positive banks right.
    pub roll_deg: f64,
    /// Vertical field of view, degrees.
    pub fov_y_deg: f64,
}

/// The view frame at the viewer (`spherical-clipmaps.md` §3.3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewFrame {
    /// Viewer longitude φv in radians, (−π, π].
    pub phi_v: f64,
    /// Viewer colatitude θv in radians, [0, π].
    pub theta_v: f64,
    /// Columns: the world directions of x̃ (south), ỹ (east) and z̃ (up) at the viewer. At a pole
    /// south and east are the limits along the meridian φv, e.g. x̃ = (cos φv, sin φv, 0) at the
    /// north pole, so the frame is finite and continuous as the viewer crosses the pole along a
    /// meridian.
    pub world_from_view: DMat3,
}

/// Maps a local (east, north, up) vector at the viewer to view space: (−north, east, up).
fn view_from_enu(enu: DVec3) -> DVec3 {
    DVec3::new(-enu.y, enu.x, enu.z)
}

impl Camera {
    /// Vertical field of view in radians.
    pub fn fov_y_rad(&self) -> f64 {
        self.fov_y_deg.to_radians()
    }

    /// The viewer's (φv, θv) and the world-from-view rotation.
    pub fn view_frame(&self) -> ViewFrame {
        let (phi_v, theta_v) = phi_theta_from_lat_lon_deg(self.lat_deg, self.lon_deg);
        let world_from_view = DMat3::from_cols(
            south_unit_vector(phi_v, theta_v),
            east_unit_vector(phi_v),
            unit_vector(phi_v, theta_v),
        );
        ViewFrame {
            phi_v,
            theta_v,
            world_from_view,
        }
    }

    /// Camera orientation in view space: columns are the camera's right, up and back axes.
    ///
    /// In local ENU, forward = (sin hd·cos p, cos hd·cos p, sin p), up = ∂forward/∂p =
    /// (−sin hd·sin p, −cos hd·sin p, cos p) and right = forward × up = (cos hd, −sin hd, 0). Up is
    /// taken from the heading rather than from a world "up" cross product, so looking straight
    /// down or up (p = ±90°) stays finite and continuous. Roll r then turns right and up about
    /// forward: right' = right·cos r − up·sin r, up' = right·sin r + up·cos r. Orthonormal with
    /// determinant +1.
    pub fn view_from_camera(&self) -> DMat3 {
        let (sin_heading, cos_heading) = self.heading_deg.to_radians().sin_cos();
        let (sin_pitch, cos_pitch) = self.pitch_deg.to_radians().sin_cos();
        let (sin_roll, cos_roll) = self.roll_deg.to_radians().sin_cos();
        let forward_enu = DVec3::new(sin_heading * cos_pitch, cos_heading * cos_pitch, sin_pitch);
        let up_enu = DVec3::new(
            -sin_heading * sin_pitch,
            -cos_heading * sin_pitch,
            cos_pitch,
        );
        let right_enu = DVec3::new(cos_heading, -sin_heading, 0.0);
        let rolled_right_enu = right_enu * cos_roll - up_enu * sin_roll;
        let rolled_up_enu = right_enu * sin_roll + up_enu * cos_roll;
        DMat3::from_cols(
            view_from_enu(rolled_right_enu),
            view_from_enu(rolled_up_enu),
            view_from_enu(-forward_enu),
        )
    }

    /// Camera orientation in the world frame: world_from_view · view_from_camera (CPU only).
    pub fn world_from_camera(&self) -> DMat3 {
        self.view_frame().world_from_view * self.view_from_camera()
    }

    /// The unit forward (viewing) direction in view space.
    pub fn forward_view(&self) -> DVec3 {
        -self.view_from_camera().z_axis
    }

    /// Earth-centred position of the eye in metres on the sphere of radius [`EARTH_RADIUS_M`].
    pub fn eye_world_m(&self) -> DVec3 {
        self.eye_world_at_radius_m(EARTH_RADIUS_M)
    }

    /// Earth-centred position of the eye in metres on a sphere of radius `radius_m`.
    pub fn eye_world_at_radius_m(&self, radius_m: f64) -> DVec3 {
        let (phi_v, theta_v) = phi_theta_from_lat_lon_deg(self.lat_deg, self.lon_deg);
        ecef_m(phi_v, theta_v, self.altitude_m, radius_m)
    }

    /// Position of the eye in view space (centre of the sphere at the origin): (0, 0, R + h).
    pub fn eye_view_m(&self) -> DVec3 {
        self.eye_view_at_radius_m(EARTH_RADIUS_M)
    }

    /// As [`Camera::eye_view_m`] on a sphere of radius `radius_m`.
    pub fn eye_view_at_radius_m(&self, radius_m: f64) -> DVec3 {
        DVec3::new(0.0, 0.0, radius_m + self.altitude_m)
    }

    /// The reversed-Z infinite projection for this camera's field of view
    /// ([`clip_from_camera`]).
    pub fn clip_from_camera(&self, aspect: f64, near_m: f64) -> DMat4 {
        clip_from_camera(self.fov_y_rad(), aspect, near_m)
    }
}

/// Unit direction in view space of the ray through the centre of pixel (`px`, `py`) of a
/// `width_px` × `height_px` image (row 0 at the top, as wgpu's framebuffer), for predicting where
/// things land on screen.
pub fn pixel_ray_view(camera: &Camera, px: u32, py: u32, width_px: u32, height_px: u32) -> DVec3 {
    let width = f64::from(width_px.max(1));
    let height = f64::from(height_px.max(1));
    let ndc_x = 2.0 * (f64::from(px) + 0.5) / width - 1.0;
    let ndc_y = 1.0 - 2.0 * (f64::from(py) + 0.5) / height;
    let direction_camera = ray_camera(camera.fov_y_rad(), width / height, ndc_x, ndc_y);
    camera.view_from_camera() * direction_camera
}
