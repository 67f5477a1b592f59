//! Height sources: the terrain function every LOD method approximates (DESIGN.md "One terrain
//! function"). The analytic test planet is known in closed form at any (φ, θ), so tests can
//! check rendered heights exactly; the DEM pyramid (real elevation data) joins it here.

pub mod analytic;

use glam::DVec3;

pub use analytic::AnalyticPlanet;

use crate::geo::sphere;

/// The terrain the renderer draws and the measurements compare against.
#[derive(Clone, Debug)]
pub enum Terrain {
    Analytic(AnalyticPlanet),
}

impl Terrain {
    /// The analytic test planet on the Earth's sphere.
    pub fn analytic_earth() -> Self {
        Self::Analytic(AnalyticPlanet::earth())
    }

    pub fn radius_m(&self) -> f64 {
        match self {
            Self::Analytic(p) => p.radius_m,
        }
    }

    /// The terrain function: height in metres above the sphere at unit vector `u` (f64).
    pub fn height_m(&self, u: DVec3) -> f64 {
        match self {
            Self::Analytic(p) => p.height_m(u),
        }
    }

    pub fn height_at_lat_lon_m(&self, lat_deg: f64, lon_deg: f64) -> f64 {
        let (phi, theta) = sphere::phi_theta_from_lat_lon_deg(lat_deg, lon_deg);
        self.height_m(sphere::unit_vector(phi, theta))
    }

    /// Lowest and highest terrain anywhere (for the horizon bound, eq. 6).
    pub fn height_range_m(&self) -> (f64, f64) {
        match self {
            Self::Analytic(p) => p.height_range_m(),
        }
    }

    /// Bounds of the terrain within an arc of `angle_rad` around `u` (for culling).
    pub fn height_bounds_near_m(&self, u: DVec3, angle_rad: f64) -> (f64, f64) {
        match self {
            Self::Analytic(p) => p.height_bounds_near_m(u, angle_rad),
        }
    }

    /// The analytic planet, when that is the source (tests use its closed-form error bounds).
    pub fn analytic(&self) -> Option<&AnalyticPlanet> {
        match self {
            Self::Analytic(p) => Some(p),
        }
    }

    pub fn describe(&self) -> String {
        match self {
            Self::Analytic(_) => "analytic test planet".to_string(),
        }
    }
}
