//! Geographic coordinates on a sphere of radius R: latitude/longitude in degrees, spherical
//! (φ, θ) in radians, unit vectors and Earth-centred positions (ECEF), all f64.
//!
//! φ is longitude east, θ colatitude (0 at the north pole); see the table in [`crate::geo`].
//! Every function is finite at the poles: there φ is kept as given (forward) or whatever
//! `atan2(0, 0) = 0` gives (inverse), since it carries no meaning.

use glam::DVec3;
use std::f64::consts::{PI, TAU};

/// Wraps an angle to (−π, π] (the range of `atan2`, and of φ everywhere in this crate).
pub fn wrap_angle_rad(angle_rad: f64) -> f64 {
    if angle_rad > -PI && angle_rad <= PI {
        return angle_rad;
    }
    let wrapped = angle_rad.rem_euclid(TAU);
    if wrapped > PI { wrapped - TAU } else { wrapped }
}

/// (latitude, longitude) in degrees → (φ, θ) in radians: θ = (90° − lat), φ = lon wrapped to
/// (−π, π]. Latitude ±90° gives θ = 0 or π exactly.
pub fn phi_theta_from_lat_lon_deg(lat_deg: f64, lon_deg: f64) -> (f64, f64) {
    let theta_rad = (90.0 - lat_deg).to_radians();
    let phi_rad = wrap_angle_rad(lon_deg.to_radians());
    (phi_rad, theta_rad)
}

/// (φ, θ) in radians → (latitude, longitude) in degrees, longitude in (−180°, 180°].
pub fn lat_lon_deg_from_phi_theta(phi_rad: f64, theta_rad: f64) -> (f64, f64) {
    let lat_deg = 90.0 - theta_rad.to_degrees();
    let lon_deg = wrap_angle_rad(phi_rad).to_degrees();
    (lat_deg, lon_deg)
}

/// World unit vector u(φ, θ) = (sin θ cos φ, sin θ sin φ, cos θ).
pub fn unit_vector(phi_rad: f64, theta_rad: f64) -> DVec3 {
    let (sin_theta, cos_theta) = theta_rad.sin_cos();
    let (sin_phi, cos_phi) = phi_rad.sin_cos();
    DVec3::new(sin_theta * cos_phi, sin_theta * sin_phi, cos_theta)
}

/// Local east unit vector at (φ, θ): ∂u/∂φ normalised, (−sin φ, cos φ, 0). At a pole this is the
/// limit along the meridian φ, so it stays finite.
pub fn east_unit_vector(phi_rad: f64) -> DVec3 {
    let (sin_phi, cos_phi) = phi_rad.sin_cos();
    DVec3::new(-sin_phi, cos_phi, 0.0)
}

/// Local south unit vector at (φ, θ): ∂u/∂θ = (cos θ cos φ, cos θ sin φ, −sin θ) (direction of
/// increasing colatitude). At a pole this is the limit along the meridian φ.
pub fn south_unit_vector(phi_rad: f64, theta_rad: f64) -> DVec3 {
    let (sin_theta, cos_theta) = theta_rad.sin_cos();
    let (sin_phi, cos_phi) = phi_rad.sin_cos();
    DVec3::new(cos_theta * cos_phi, cos_theta * sin_phi, -sin_theta)
}

/// Earth-centred position in metres of the point at (φ, θ) and `height_m` above the sphere of
/// radius `radius_m`: (R + h)·u(φ, θ).
pub fn ecef_m(phi_rad: f64, theta_rad: f64, height_m: f64, radius_m: f64) -> DVec3 {
    (radius_m + height_m) * unit_vector(phi_rad, theta_rad)
}

/// Inverse of [`ecef_m`]: (φ, θ, height above the sphere in metres). φ ∈ (−π, π] by `atan2`
/// (0 on the polar axis, where it is meaningless), θ = atan2(ρ, z) ∈ [0, π], which keeps full
/// precision near the poles where `acos(z/|p|)` would not. The origin gives (0, 0, −R).
pub fn phi_theta_height_from_ecef_m(position_m: DVec3, radius_m: f64) -> (f64, f64, f64) {
    let rho_m = position_m.x.hypot(position_m.y);
    let phi_rad = position_m.y.atan2(position_m.x);
    let theta_rad = rho_m.atan2(position_m.z);
    let height_m = position_m.length() - radius_m;
    (phi_rad, theta_rad, height_m)
}

/// Great-circle distance in metres along the sphere of radius `radius_m` between two unit
/// vectors, computed as atan2(|a × b|, a·b), which is accurate for tiny and near-antipodal angles.
pub fn great_circle_distance_m(a_unit: DVec3, b_unit: DVec3, radius_m: f64) -> f64 {
    radius_m * a_unit.cross(b_unit).length().atan2(a_unit.dot(b_unit))
}

/// The area in square metres enclosed on the sphere of radius `radius_m` by the polygon whose
/// corners are the unit vectors `corners` joined by great-circle arcs (simple, either
/// orientation): R² times the sum of the signed solid angles of the fan triangles from the
/// first corner, each from Van Oosterom and Strackee's formula
/// tan(Ω/2) = a·(b × c) / (1 + a·b + b·c + c·a). Exact for any size below a hemisphere; 0 for
/// fewer than three corners.
pub fn polygon_area_m2(corners: &[DVec3], radius_m: f64) -> f64 {
    if corners.len() < 3 {
        return 0.0;
    }
    let a = corners[0];
    let solid: f64 = corners[1..]
        .windows(2)
        .map(|w| {
            let (b, c) = (w[0], w[1]);
            2.0 * a
                .dot(b.cross(c))
                .atan2(1.0 + a.dot(b) + b.dot(c) + c.dot(a))
        })
        .sum();
    radius_m * radius_m * solid.abs()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The octant (three corners 90° apart) is an eighth of the sphere, 4πR²/8, either way
    /// round; a small square near the equator is its side squared; the square inscribed in
    /// the cap within 1° of the north pole is 2/π of the cap (the plane limit).
    #[test]
    fn polygon_areas_against_closed_forms() {
        let r = 6_371_000.0;
        let u = |lat: f64, lon: f64| {
            let (p, t) = phi_theta_from_lat_lon_deg(lat, lon);
            unit_vector(p, t)
        };
        let octant = polygon_area_m2(&[u(0.0, 0.0), u(0.0, 90.0), u(90.0, 0.0)], r);
        assert!(
            (octant / (PI * r * r / 2.0) - 1.0).abs() < 1e-12,
            "{octant}"
        );
        let reversed = polygon_area_m2(&[u(90.0, 0.0), u(0.0, 90.0), u(0.0, 0.0)], r);
        assert!((reversed - octant).abs() < 1e-3);
        let d: f64 = 1e-4; // degrees: an 11 m square
        let side = r * d.to_radians();
        let square = polygon_area_m2(&[u(0.0, 0.0), u(0.0, d), u(d, d), u(d, 0.0)], r);
        assert!((square / (side * side) - 1.0).abs() < 1e-6, "{square}");
        let cap = 2.0 * PI * r * r * (1.0 - 1f64.to_radians().cos());
        let polar = polygon_area_m2(
            &[u(89.0, 0.0), u(89.0, 90.0), u(89.0, 180.0), u(89.0, 270.0)],
            r,
        );
        // The inscribed square of the cap: 2/π of the circle's area in the plane limit.
        assert!((polar / cap - 2.0 / PI).abs() < 1e-3, "{polar} vs {cap}");
        assert_eq!(polygon_area_m2(&[u(0.0, 0.0), u(1.0, 1.0)], r), 0.0);
    }

    #[test]
    fn poles_are_exact_and_finite() {
        let (phi, theta) = phi_theta_from_lat_lon_deg(90.0, 10.0);
        assert_eq!(theta, 0.0);
        assert!((phi - 10f64.to_radians()).abs() < 1e-15);
        let (_, theta) = phi_theta_from_lat_lon_deg(-90.0, 0.0);
        assert_eq!(theta, PI);
        let (phi, theta, h) = phi_theta_height_from_ecef_m(DVec3::new(0.0, 0.0, 7e6), 6.371e6);
        assert_eq!((phi, theta), (0.0, 0.0));
        assert!((h - 629_000.0).abs() < 1e-6);
        let (phi, theta, h) = phi_theta_height_from_ecef_m(DVec3::ZERO, 6.371e6);
        assert!(phi.is_finite() && theta.is_finite() && h == -6.371e6);
    }

    #[test]
    fn ecef_round_trip() {
        for &(lat, lon, h) in &[
            (45.65, 10.65, 65.0),
            (-33.0, -179.999, 1e-3),
            (89.999_999, 180.0, 1e9),
            (0.0, 0.0, 0.0),
        ] {
            let (phi, theta) = phi_theta_from_lat_lon_deg(lat, lon);
            let p = ecef_m(phi, theta, h, 6.371e6);
            let (phi2, theta2, h2) = phi_theta_height_from_ecef_m(p, 6.371e6);
            assert!(wrap_angle_rad(phi2 - phi).abs() * theta.sin() < 1e-15);
            assert!((theta2 - theta).abs() < 1e-15);
            assert!((h2 - h).abs() < 1e-8 * (6.371e6 + h));
            let (lat2, lon2) = lat_lon_deg_from_phi_theta(phi2, theta2);
            assert!((lat2 - lat).abs() < 1e-12);
            assert!(wrap_angle_rad((lon2 - lon).to_radians()).abs() < 1e-12);
        }
    }

    #[test]
    fn wrap_is_half_open() {
        assert_eq!(wrap_angle_rad(PI), PI);
        assert!((wrap_angle_rad(-PI) - PI).abs() < 1e-15);
        assert!((wrap_angle_rad(3.0 * PI) - PI).abs() < 1e-15);
        assert_eq!(wrap_angle_rad(0.5), 0.5);
    }
}
