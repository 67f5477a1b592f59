//! The terrain's profile along a great circle (issue 38's measure tool and `globe profile`):
//! equally spaced points of the shorter great-circle arc between two places, each with the
//! terrain function's height there (base, detail and water, at full resolution: the surface
//! that is drawn and measured), and the two distances a user asks for: along the sphere and
//! along the terrain.
//!
//! The points are the spherical linear interpolation of the two unit vectors,
//! u(t) = (sin((1 − t)Ω)·a + sin(tΩ)·b) / sin Ω with Ω = atan2(|a × b|, a·b), which is exact at
//! both ends and keeps its precision for short and long arcs alike (Ω is never taken from an
//! acos). Antipodal places have no single great circle between them and are refused.

use glam::DVec3;

use super::reference::HeightField;
use crate::geo::sphere;

/// One point of a profile.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProfilePoint {
    /// Metres from the start along the great circle on the sphere of radius R.
    pub distance_m: f64,
    /// Latitude, degrees north.
    pub lat_deg: f64,
    /// Longitude, degrees east, in (−180, 180].
    pub lon_deg: f64,
    /// The terrain function's height there, metres above the sphere of radius R.
    pub height_m: f64,
}

/// A profile and its totals.
#[derive(Clone, Debug, PartialEq)]
pub struct Profile {
    /// From the start to the end, equally spaced along the great circle.
    pub points: Vec<ProfilePoint>,
    /// The great-circle distance between the ends on the sphere of radius R, metres.
    pub great_circle_m: f64,
    /// The length of the polyline through the points at their heights (radius R + h), metres:
    /// the distance a walker along the terrain covers, to the sampling's resolution.
    pub along_terrain_m: f64,
}

impl Profile {
    /// Lowest and highest height along the profile.
    pub fn height_range_m(&self) -> (f64, f64) {
        self.points
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p.height_m), hi.max(p.height_m))
            })
    }

    /// The end's height minus the start's.
    pub fn height_difference_m(&self) -> f64 {
        match (self.points.first(), self.points.last()) {
            (Some(a), Some(b)) => b.height_m - a.height_m,
            _ => 0.0,
        }
    }
}

/// Why a profile cannot be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProfileError {
    #[error("a profile needs at least 2 samples (got {0})")]
    TooFewSamples(usize),
    #[error("latitude {0}° is outside −90…90°")]
    Latitude(f64),
    #[error("{0} is not a finite number of degrees")]
    NotFinite(f64),
    #[error("the two ends are the same place: a profile needs two places apart")]
    SamePlace,
    #[error(
        "the two ends are antipodal (or within 1 mm of it): every great circle through one passes through the other, so there is no one profile"
    )]
    Antipodal,
}

/// The arc's angle below which its ends count as one place, and its supplement's above
/// which they count as antipodal: 1 mm on the Earth.
const SAME_PLACE_RAD: f64 = 1e-3 / crate::geo::EARTH_RADIUS_M;

/// The profile of `field` along the shorter great circle from `from` to `to` (latitude,
/// longitude in degrees), with `samples` points including both ends.
pub fn great_circle_profile<H: HeightField + ?Sized>(
    field: &H,
    from: (f64, f64),
    to: (f64, f64),
    samples: usize,
) -> Result<Profile, ProfileError> {
    if samples < 2 {
        return Err(ProfileError::TooFewSamples(samples));
    }
    let a = place_unit(from)?;
    let b = place_unit(to)?;
    let omega = a.cross(b).length().atan2(a.dot(b));
    if omega < SAME_PLACE_RAD {
        return Err(ProfileError::SamePlace);
    }
    if omega > std::f64::consts::PI - SAME_PLACE_RAD {
        return Err(ProfileError::Antipodal);
    }
    let r = field.radius_m();
    let sin_omega = omega.sin();
    let mut points = Vec::with_capacity(samples);
    let mut along_terrain_m = 0.0;
    let mut previous: Option<DVec3> = None;
    for k in 0..samples {
        let t = k as f64 / (samples - 1) as f64;
        // The ends exactly as given (no rounding of the interpolation at t = 0 and 1).
        let u = match k {
            0 => a,
            _ if k == samples - 1 => b,
            _ => ((((1.0 - t) * omega).sin() * a + (t * omega).sin() * b) / sin_omega).normalize(),
        };
        let (phi, theta, _) = sphere::phi_theta_height_from_ecef_m(u, 1.0);
        let (lat_deg, lon_deg) = sphere::lat_lon_deg_from_phi_theta(phi, theta);
        let height_m = field.height_m(u);
        let position = (r + height_m) * u;
        if let Some(p) = previous {
            along_terrain_m += (position - p).length();
        }
        previous = Some(position);
        points.push(ProfilePoint {
            distance_m: r * omega * t,
            // The ends keep the latitude and longitude they were given.
            lat_deg: match k {
                0 => from.0,
                _ if k == samples - 1 => to.0,
                _ => lat_deg,
            },
            lon_deg: match k {
                0 => sphere::wrap_angle_rad(from.1.to_radians()).to_degrees(),
                _ if k == samples - 1 => sphere::wrap_angle_rad(to.1.to_radians()).to_degrees(),
                _ => lon_deg,
            },
            height_m,
        });
    }
    Ok(Profile {
        points,
        great_circle_m: r * omega,
        along_terrain_m,
    })
}

fn place_unit((lat_deg, lon_deg): (f64, f64)) -> Result<DVec3, ProfileError> {
    for v in [lat_deg, lon_deg] {
        if !v.is_finite() {
            return Err(ProfileError::NotFinite(v));
        }
    }
    if !(-90.0..=90.0).contains(&lat_deg) {
        return Err(ProfileError::Latitude(lat_deg));
    }
    let (phi, theta) = sphere::phi_theta_from_lat_lon_deg(lat_deg, lon_deg);
    Ok(sphere::unit_vector(phi, theta))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geo::EARTH_RADIUS_M;
    use crate::measure::ConstantHeight;

    fn flat(height_m: f64) -> ConstantHeight {
        ConstantHeight {
            radius_m: EARTH_RADIUS_M,
            height_m,
        }
    }

    /// Along the equator a quarter of the way round: longitude grows linearly, latitude stays
    /// 0, each distance is R·Δλ, and over a constant height h the terrain path is the chord
    /// polyline at radius R + h (closed form: n chords of 2(R + h)·sin(Ω / 2n)).
    #[test]
    fn a_quarter_of_the_equator() {
        let n = 90;
        let p = great_circle_profile(&flat(100.0), (0.0, 0.0), (0.0, 90.0), n + 1).unwrap();
        assert_eq!(p.points.len(), n + 1);
        for (k, q) in p.points.iter().enumerate() {
            assert!(q.lat_deg.abs() < 1e-12, "{q:?}");
            assert!((q.lon_deg - k as f64).abs() < 1e-10, "{q:?}");
            let d = EARTH_RADIUS_M * (k as f64).to_radians();
            assert!((q.distance_m - d).abs() < 1e-6, "{q:?}");
            assert_eq!(q.height_m, 100.0);
        }
        let omega = std::f64::consts::FRAC_PI_2;
        assert!((p.great_circle_m - EARTH_RADIUS_M * omega).abs() < 1e-6);
        let chords = n as f64 * 2.0 * (EARTH_RADIUS_M + 100.0) * (omega / (2.0 * n as f64)).sin();
        assert!(
            (p.along_terrain_m - chords).abs() < 1e-6,
            "{}",
            p.along_terrain_m
        );
        assert_eq!(p.height_difference_m(), 0.0);
    }

    /// Across the antimeridian the shorter arc is taken (179° E to 179° W is 2° of longitude,
    /// not 358°), and over a pole the profile runs through it.
    #[test]
    fn the_shorter_arc_across_the_antimeridian_and_over_a_pole() {
        let p = great_circle_profile(&flat(0.0), (0.0, 179.0), (0.0, -179.0), 3).unwrap();
        assert!((p.great_circle_m - EARTH_RADIUS_M * 2f64.to_radians()).abs() < 1e-6);
        assert!(
            (p.points[1].lon_deg.abs() - 180.0).abs() < 1e-10,
            "{:?}",
            p.points[1]
        );
        let p = great_circle_profile(&flat(0.0), (80.0, 0.0), (80.0, 180.0), 3).unwrap();
        assert!((p.great_circle_m - EARTH_RADIUS_M * 20f64.to_radians()).abs() < 1e-6);
        assert!(
            (p.points[1].lat_deg - 90.0).abs() < 1e-10,
            "{:?}",
            p.points[1]
        );
    }

    #[test]
    fn impossible_profiles_are_refused() {
        let f = flat(0.0);
        let e = |from, to, n| great_circle_profile(&f, from, to, n).unwrap_err();
        assert_eq!(e((0.0, 0.0), (1.0, 1.0), 1), ProfileError::TooFewSamples(1));
        assert_eq!(e((91.0, 0.0), (1.0, 1.0), 2), ProfileError::Latitude(91.0));
        assert!(matches!(
            e((f64::NAN, 0.0), (1.0, 1.0), 2),
            ProfileError::NotFinite(_)
        ));
        assert_eq!(e((10.0, 20.0), (10.0, 380.0), 2), ProfileError::SamePlace);
        assert_eq!(e((10.0, 20.0), (-10.0, -160.0), 2), ProfileError::Antipodal);
        // The error says what is wrong in words a user reads.
        assert!(ProfileError::Antipodal.to_string().contains("antipodal"));
    }
}
