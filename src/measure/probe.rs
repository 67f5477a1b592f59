//! What lies under one pixel: the f64 reference ray caster's hit on the terrain function, as
//! latitude, longitude and height (issue 38's pick and `globe probe`). The answer is the
//! surface that is drawn and measured (base, detail and water), not a depth read-back, so it
//! is as exact as the metric's truth.

use glam::DVec3;

use super::reference::{HeightField, RayCaster, RayHit};
use crate::geo::camera::Camera;
use crate::geo::sphere;

/// The surface point seen through a pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeHit {
    /// Latitude, degrees north.
    pub lat_deg: f64,
    /// Longitude, degrees east, in (−180, 180].
    pub lon_deg: f64,
    /// The terrain function's height there, metres above the sphere of radius R.
    pub height_m: f64,
    /// Metres from the eye along the pixel's ray.
    pub distance_m: f64,
}

/// The hit through the centre of pixel (`x`, `y`) of a `width` × `height` view (row 0 at the
/// top), or `None` where the ray meets only sky.
pub fn probe_pixel<H: HeightField + ?Sized>(
    field: &H,
    camera: &Camera,
    width: u32,
    height: u32,
    x: u32,
    y: u32,
) -> Option<ProbeHit> {
    let caster = RayCaster::new(field, camera, width, height);
    match caster.cast_pixel(x, y) {
        RayHit::Sky => None,
        RayHit::Terrain {
            distance_m,
            point_view_m,
        } => Some(hit_at(field, camera, point_view_m, distance_m)),
    }
}

/// The hit at view-space point `point_view_m` (planet centre at the origin).
fn hit_at<H: HeightField + ?Sized>(
    field: &H,
    camera: &Camera,
    point_view_m: DVec3,
    distance_m: f64,
) -> ProbeHit {
    hit_at_world(
        field,
        camera.view_frame().world_from_view * point_view_m,
        distance_m,
    )
}

/// The hit at world point `point_world_m` (planet centre at the origin), `distance_m` from
/// the eye: its direction gives latitude and longitude, the terrain function there the height
/// (exact at that direction; |p| − R agrees with it to the caster's refinement).
pub fn hit_at_world<H: HeightField + ?Sized>(
    field: &H,
    point_world_m: DVec3,
    distance_m: f64,
) -> ProbeHit {
    let u = point_world_m.normalize();
    let (phi, theta, _) = sphere::phi_theta_height_from_ecef_m(u, 1.0);
    let (lat_deg, lon_deg) = sphere::lat_lon_deg_from_phi_theta(phi, theta);
    ProbeHit {
        lat_deg,
        lon_deg,
        height_m: field.height_m(u),
        distance_m,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::ConstantHeight;

    fn down(lat_deg: f64, lon_deg: f64, altitude_m: f64) -> Camera {
        Camera {
            lat_deg,
            lon_deg,
            altitude_m,
            heading_deg: 0.0,
            pitch_deg: -90.0,
            roll_deg: 0.0,
            fov_y_deg: 60.0,
        }
    }

    /// Straight down onto a sphere of constant height: the centre pixel is the nadir, its
    /// distance the altitude above that height (closed form).
    #[test]
    fn the_centre_pixel_looking_down_is_the_nadir() {
        let field = ConstantHeight {
            radius_m: crate::geo::EARTH_RADIUS_M,
            height_m: 100.0,
        };
        for (lat, lon) in [
            (0.0, 0.0),
            (45.5, -120.25),
            (89.9999, 10.0),
            (-30.0, 179.999),
        ] {
            let hit = probe_pixel(&field, &down(lat, lon, 102.0), 101, 101, 50, 50).unwrap();
            assert!((hit.lat_deg - lat).abs() < 1e-7, "{hit:?}");
            let dlon = sphere::wrap_angle_rad((hit.lon_deg - lon).to_radians()).to_degrees();
            assert!(dlon.abs() * lat.to_radians().cos() < 1e-7, "{hit:?}");
            assert!((hit.distance_m - 2.0).abs() < 1e-3, "{hit:?}");
            assert_eq!(hit.height_m, 100.0);
        }
    }

    /// Looking up at the sky is no hit.
    #[test]
    fn a_ray_above_the_horizon_is_sky() {
        let field = ConstantHeight {
            radius_m: crate::geo::EARTH_RADIUS_M,
            height_m: 0.0,
        };
        let mut camera = down(10.0, 10.0, 1000.0);
        camera.pitch_deg = 30.0;
        assert_eq!(probe_pixel(&field, &camera, 64, 64, 32, 32), None);
    }

    /// On the analytic planet, each reported hit lies on the closed-form surface: the point
    /// the reported distance reaches along the pixel's ray is at the reported height, and
    /// that height is the closed form at the reported latitude and longitude.
    #[test]
    fn hits_on_the_analytic_planet_lie_on_its_closed_form() {
        let terrain = crate::terrain::Terrain::analytic_earth();
        let planet = terrain.analytic().unwrap().clone();
        let mut camera = down(20.0, 30.0, 0.0);
        camera.altitude_m = planet.height_m(crate::geo::sphere::unit_vector(
            30f64.to_radians(),
            70f64.to_radians(),
        )) + 1500.0;
        camera.pitch_deg = -25.0;
        let (w, h) = (64, 48);
        let mut hits = 0;
        for (x, y) in [(0, 47), (32, 24), (63, 40), (10, 30), (50, 20)] {
            let Some(hit) = probe_pixel(&terrain, &camera, w, h, x, y) else {
                continue;
            };
            hits += 1;
            let (phi, theta) = sphere::phi_theta_from_lat_lon_deg(hit.lat_deg, hit.lon_deg);
            let closed = planet.height_m(sphere::unit_vector(phi, theta));
            assert!((hit.height_m - closed).abs() < 1e-6, "{hit:?} vs {closed}");
            let ray = crate::geo::camera::pixel_ray_view(&camera, x, y, w, h);
            let eye = camera.eye_view_at_radius_m(planet.radius_m);
            let r = (eye + hit.distance_m * ray).length() - planet.radius_m;
            assert!((r - hit.height_m).abs() < 0.01, "{hit:?}: radius says {r}");
        }
        assert!(hits >= 4, "only {hits} of the pixels hit the ground");
    }
}
