//! Flights from one view to another (issue 38's fly-to): up, over and down along the great
//! circle instead of a cut, and the view that looks at a picked point from closer (the
//! double-click's target). f64, no window or GPU type, as the controls.
//!
//! Along the flight, with s the eased time (smoothstep of t ∈ [0, 1]):
//! - the position is the spherical interpolation of the two nadirs at s (the shorter arc;
//!   antipodal ends go over the start's north);
//! - the height above the terrain is interpolated in its logarithm, so 2 m → 20 000 km reads
//!   evenly, plus a bump 4s(1 − s)·ln(H_peak / max(h_a, h_b)) toward H_peak = ¼ of the arc's
//!   length (only where that is above both ends): far flights rise to see where they go;
//! - heading (the shorter way round), pitch and roll follow s.
//!
//! The duration grows with the logarithm of the distance and of the height ratio, from
//! [`MIN_SECONDS`] to [`MAX_SECONDS`]. At t ≥ 1 the camera is exactly the target.

use glam::DVec3;

use crate::geo::camera::Camera;
use crate::geo::sphere;

use super::controls::{self, MIN_CLEARANCE_M};

/// The shortest flight.
pub const MIN_SECONDS: f64 = 0.6;
/// The longest flight (half way round the Earth from the ground).
pub const MAX_SECONDS: f64 = 7.0;

/// A flight between two cameras.
#[derive(Clone, Debug, PartialEq)]
pub struct FlyTo {
    from: Camera,
    to: Camera,
    /// The two nadirs (world unit vectors) and the arc between them, radians.
    a: DVec3,
    b: DVec3,
    omega: f64,
    /// Heights above the terrain at the two ends (≥ the controls' clearance).
    from_height_m: f64,
    to_height_m: f64,
    /// ln(H_peak / max(h_a, h_b)) ≥ 0: the bump's size in the logarithm of the height.
    bump: f64,
    duration_s: f64,
}

fn nadir(c: &Camera) -> DVec3 {
    let (phi, theta) = sphere::phi_theta_from_lat_lon_deg(c.lat_deg, c.lon_deg);
    sphere::unit_vector(phi, theta)
}

/// The shorter signed difference b − a of two angles in degrees, in (−180, 180].
fn angle_diff_deg(a: f64, b: f64) -> f64 {
    sphere::wrap_angle_rad((b - a).to_radians()).to_degrees()
}

impl FlyTo {
    /// The flight from `from` to `to` over `terrain(lat_deg, lon_deg) -> metres` on a planet
    /// of radius `radius_m`.
    pub fn new(
        from: &Camera,
        to: &Camera,
        radius_m: f64,
        terrain: impl Fn(f64, f64) -> f64,
    ) -> Self {
        let (a, b) = (nadir(from), nadir(to));
        let omega = a.cross(b).length().atan2(a.dot(b));
        let clear = |c: &Camera| {
            let h = controls::height_above_terrain_m(c, &terrain);
            if h.is_finite() {
                h.max(MIN_CLEARANCE_M)
            } else {
                MIN_CLEARANCE_M
            }
        };
        let (from_height_m, to_height_m) = (clear(from), clear(to));
        let arc_m = omega * radius_m;
        let peak_m = 0.25 * arc_m;
        let high = from_height_m.max(to_height_m);
        let bump = if peak_m > high {
            (peak_m / high).ln()
        } else {
            0.0
        };
        // A second per factor 10 of distance above 100 m, and for every factor 100 of height.
        let over = (arc_m / 100.0).max(1.0).log10();
        let climb = (to_height_m / from_height_m).ln().abs() / std::f64::consts::LN_10 / 2.0;
        let duration_s = (MIN_SECONDS + 0.75 * over + 0.5 * climb).clamp(MIN_SECONDS, MAX_SECONDS);
        Self {
            from: *from,
            to: *to,
            a,
            b,
            omega,
            from_height_m,
            to_height_m,
            bump,
            duration_s,
        }
    }

    pub fn duration_s(&self) -> f64 {
        self.duration_s
    }

    /// The target view.
    pub fn target(&self) -> &Camera {
        &self.to
    }

    /// The nadir at eased time `s`: the shorter great-circle arc, or for antipodal ends the
    /// one over the start's north.
    fn nadir_at(&self, s: f64) -> DVec3 {
        let sin_omega = self.omega.sin();
        if sin_omega > 1e-9 {
            return ((((1.0 - s) * self.omega).sin() * self.a + (s * self.omega).sin() * self.b)
                / sin_omega)
                .normalize();
        }
        if self.a.dot(self.b) > 0.0 {
            return self.a; // the same place: only the height and the view change
        }
        // Antipodal: rotate a about the axis through the start's east by s·π.
        let (phi, theta) = sphere::phi_theta_from_lat_lon_deg(self.from.lat_deg, self.from.lon_deg);
        let north = -sphere::south_unit_vector(phi, theta);
        let angle = s * std::f64::consts::PI;
        (angle.cos() * self.a + angle.sin() * north).normalize()
    }

    /// The camera `elapsed_s` into the flight, and whether it has arrived (then it is the
    /// target exactly). `terrain` is the ground the flight keeps its height above.
    pub fn at(&self, elapsed_s: f64, terrain: impl Fn(f64, f64) -> f64) -> (Camera, bool) {
        let t = if elapsed_s.is_finite() {
            (elapsed_s / self.duration_s).clamp(0.0, 1.0)
        } else {
            1.0
        };
        if t >= 1.0 {
            return (self.to, true);
        }
        let s = t * t * (3.0 - 2.0 * t);
        let u = self.nadir_at(s);
        let (phi, theta, _) = sphere::phi_theta_height_from_ecef_m(u, 1.0);
        let (lat_deg, lon_deg) = sphere::lat_lon_deg_from_phi_theta(phi, theta);
        let ln_h = (1.0 - s) * self.from_height_m.ln()
            + s * self.to_height_m.ln()
            + 4.0 * s * (1.0 - s) * self.bump;
        let (f, g) = (&self.from, &self.to);
        let mut camera = Camera {
            lat_deg,
            lon_deg,
            altitude_m: terrain(lat_deg, lon_deg) + ln_h.exp(),
            heading_deg: f.heading_deg + s * angle_diff_deg(f.heading_deg, g.heading_deg),
            pitch_deg: f.pitch_deg + s * (g.pitch_deg - f.pitch_deg),
            roll_deg: f.roll_deg + s * angle_diff_deg(f.roll_deg, g.roll_deg),
            fov_y_deg: f.fov_y_deg + s * (g.fov_y_deg - f.fov_y_deg),
        };
        controls::normalize(&mut camera, terrain);
        (camera, false)
    }
}

/// The camera at `eye_world_m` (planet centre at the origin, sphere of radius `radius_m`)
/// looking straight at `target_world_m`, level (no roll), with `template`'s field of view.
pub fn camera_looking_at(
    eye_world_m: DVec3,
    target_world_m: DVec3,
    radius_m: f64,
    template: &Camera,
) -> Camera {
    let (phi, theta, altitude_m) = sphere::phi_theta_height_from_ecef_m(eye_world_m, radius_m);
    let (lat_deg, lon_deg) = sphere::lat_lon_deg_from_phi_theta(phi, theta);
    let d = (target_world_m - eye_world_m).normalize_or_zero();
    let up = eye_world_m.normalize();
    let east = sphere::east_unit_vector(phi);
    let north = -sphere::south_unit_vector(phi, theta);
    let heading_deg = controls::wrap_heading_deg(d.dot(east).atan2(d.dot(north)).to_degrees());
    let pitch_deg = d.dot(up).clamp(-1.0, 1.0).asin().to_degrees();
    Camera {
        lat_deg,
        lon_deg,
        altitude_m,
        heading_deg,
        pitch_deg,
        roll_deg: 0.0,
        fov_y_deg: template.fov_y_deg,
    }
}

/// The double-click's target: the view from a third of the way from the picked point back to
/// the eye, looking at the point (so it stays under the cursor's ray, now at the centre).
pub fn closer_look(camera: &Camera, point_world_m: DVec3, radius_m: f64) -> Camera {
    let eye = camera.eye_world_at_radius_m(radius_m);
    let toward = eye - point_world_m;
    camera_looking_at(
        point_world_m + toward / 3.0,
        point_world_m,
        radius_m,
        camera,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geo::EARTH_RADIUS_M;

    const R: f64 = EARTH_RADIUS_M;

    fn cam(lat_deg: f64, lon_deg: f64, altitude_m: f64, heading_deg: f64) -> Camera {
        Camera {
            lat_deg,
            lon_deg,
            altitude_m,
            heading_deg,
            pitch_deg: -30.0,
            roll_deg: 0.0,
            fov_y_deg: 60.0,
        }
    }

    fn hills(lat: f64, lon: f64) -> f64 {
        500.0 + 300.0 * (lat * 0.7).sin() * (lon * 1.3).cos()
    }

    /// It starts where it is, ends exactly at the target, and moves continuously between.
    #[test]
    fn a_flight_starts_here_ends_there_and_does_not_jump() {
        let (from, to) = (
            cam(46.5, 8.0, 3000.0, 10.0),
            cam(-33.9, 151.2, 2000.0, 350.0),
        );
        let f = FlyTo::new(&from, &to, R, hills);
        let (start, done) = f.at(0.0, hills);
        assert!(!done);
        assert!((start.lat_deg - from.lat_deg).abs() < 1e-9, "{start:?}");
        assert!(
            (start.altitude_m - from.altitude_m).abs() < 1e-6,
            "{start:?}"
        );
        assert_eq!(f.at(f.duration_s(), hills), (to, true));
        assert_eq!(f.at(f.duration_s() + 5.0, hills), (to, true));
        let steps = 2000;
        let mut previous = start;
        for k in 1..steps {
            let (c, _) = f.at(f.duration_s() * k as f64 / steps as f64, hills);
            let moved = sphere::great_circle_distance_m(nadir(&previous), nadir(&c), R);
            // Smoothstep's steepest step: 1.5× the mean; the whole arc is ~16 600 km.
            assert!(
                moved < 1.5 * f.omega * R / steps as f64 + 1.0,
                "step {k}: {moved} m"
            );
            assert!(
                c.altitude_m > hills(c.lat_deg, c.lon_deg),
                "step {k}: under the ground"
            );
            assert!(
                angle_diff_deg(previous.heading_deg, c.heading_deg).abs() < 0.1,
                "step {k}"
            );
            previous = c;
        }
    }

    /// Far flights rise to a quarter of the arc's length in the middle; short ones stay low.
    #[test]
    fn far_flights_go_up_and_over() {
        let (from, to) = (cam(0.0, 0.0, 2.0, 0.0), cam(0.0, 90.0, 2.0, 0.0));
        let f = FlyTo::new(&from, &to, R, |_, _| 0.0);
        let (mid, _) = f.at(0.5 * f.duration_s(), |_, _| 0.0);
        let quarter_arc = 0.25 * R * std::f64::consts::FRAC_PI_2;
        assert!((mid.altitude_m / quarter_arc - 1.0).abs() < 1e-9, "{mid:?}");
        assert!((mid.lon_deg - 45.0).abs() < 1e-9, "{mid:?}");
        let near = FlyTo::new(&from, &cam(0.0, 0.0001, 50.0, 0.0), R, |_, _| 0.0);
        let (mid, _) = near.at(0.5 * near.duration_s(), |_, _| 0.0);
        assert!(mid.altitude_m <= 50.0, "{mid:?}");
    }

    /// The duration grows with the distance and stays within its bounds.
    #[test]
    fn longer_flights_take_longer() {
        let from = cam(10.0, 10.0, 1000.0, 0.0);
        let mut last = 0.0;
        for lon in [10.0001, 10.01, 11.0, 20.0, 100.0, 189.0] {
            let d = FlyTo::new(&from, &cam(10.0, lon, 1000.0, 0.0), R, |_, _| 0.0).duration_s();
            assert!(
                d >= last && (MIN_SECONDS..=MAX_SECONDS).contains(&d),
                "{lon}: {d}"
            );
            last = d;
        }
        assert!(last > 3.0 * MIN_SECONDS, "{last}");
    }

    /// Across the antimeridian the short way, over a pole through it, and between antipodes
    /// along some great circle, always with a valid camera.
    #[test]
    fn the_antimeridian_the_pole_and_antipodes() {
        let ground = |_: f64, _: f64| 0.0;
        let f = FlyTo::new(
            &cam(0.0, 179.0, 100.0, 0.0),
            &cam(0.0, -179.0, 100.0, 0.0),
            R,
            ground,
        );
        let (mid, _) = f.at(0.5 * f.duration_s(), ground);
        assert!((mid.lon_deg.abs() - 180.0).abs() < 1e-9, "{mid:?}");
        let f = FlyTo::new(
            &cam(80.0, 0.0, 100.0, 0.0),
            &cam(80.0, 180.0, 100.0, 0.0),
            R,
            ground,
        );
        let (mid, _) = f.at(0.5 * f.duration_s(), ground);
        assert!((mid.lat_deg - 90.0).abs() < 1e-9, "{mid:?}");
        let f = FlyTo::new(
            &cam(10.0, 20.0, 100.0, 0.0),
            &cam(-10.0, -160.0, 100.0, 0.0),
            R,
            ground,
        );
        for k in 0..=10 {
            let (c, _) = f.at(f.duration_s() * f64::from(k) / 10.0, ground);
            assert!(c.lat_deg.is_finite() && c.altitude_m.is_finite(), "{c:?}");
        }
        let (mid, _) = f.at(0.5 * f.duration_s(), ground);
        let apart =
            sphere::great_circle_distance_m(nadir(&mid), nadir(&cam(10.0, 20.0, 0.0, 0.0)), R);
        assert!(
            (apart / (R * std::f64::consts::FRAC_PI_2) - 1.0).abs() < 1e-9,
            "{mid:?}"
        );
    }

    /// The camera built to look at a point does: its forward axis points at it, at the pole too.
    #[test]
    fn looking_at_a_point_points_at_it() {
        let template = cam(0.0, 0.0, 0.0, 0.0);
        for (eye, target) in [
            ((46.0, 7.0, 3000.0), (46.01, 7.02, 1500.0)),
            ((89.99, 30.0, 500.0), (-89.0, 10.0, 0.0)),
            ((-20.0, 179.9, 10.0), (-20.0, -179.9, 0.0)),
        ] {
            let p = |(lat, lon, h): (f64, f64, f64)| {
                let (phi, theta) = sphere::phi_theta_from_lat_lon_deg(lat, lon);
                sphere::ecef_m(phi, theta, h, R)
            };
            let (e, t) = (p(eye), p(target));
            let c = camera_looking_at(e, t, R, &template);
            assert!((c.eye_world_at_radius_m(R) - e).length() < 1e-6, "{c:?}");
            let forward = c.view_frame().world_from_view * c.forward_view();
            assert!(forward.dot((t - e).normalize()) > 1.0 - 1e-12, "{c:?}");
        }
        let c = cam(46.0, 7.0, 3000.0, 45.0);
        let point = {
            let (phi, theta) = sphere::phi_theta_from_lat_lon_deg(46.01, 7.01);
            sphere::ecef_m(phi, theta, 600.0, R)
        };
        let closer = closer_look(&c, point, R);
        let before = (c.eye_world_at_radius_m(R) - point).length();
        let after = (closer.eye_world_at_radius_m(R) - point).length();
        assert!((after / before - 1.0 / 3.0).abs() < 1e-9);
    }
}
