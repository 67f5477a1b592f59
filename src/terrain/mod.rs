//! Height sources: the terrain function every LOD method approximates (DESIGN.md "One terrain
//! function"). The analytic test planet is known in closed form at any (φ, θ), so tests can
//! check rendered heights exactly; the DEM pyramid (real elevation data) joins it here.

pub mod analytic;
pub mod dem;

use glam::DVec3;

pub use analytic::AnalyticPlanet;
pub use dem::DemTerrain;

use crate::geo::sphere;

/// The terrain the renderer draws and the measurements compare against.
#[derive(Clone, Debug)]
pub enum Terrain {
    /// The analytic test planet (boxed: its wave table is large next to a DEM handle).
    Analytic(Box<AnalyticPlanet>),
    /// Real elevation data from a pyramid file.
    Dem(DemTerrain),
}

impl Terrain {
    /// The real Earth shipped inside the binary (ETOPO5 at 10′), its pyramid built into the
    /// cache on first use.
    pub fn embedded_earth() -> Result<Self, crate::dem::DemError> {
        Ok(Self::Dem(dem::embedded_earth(crate::geo::EARTH_RADIUS_M)?))
    }

    /// The analytic test planet on the Earth's sphere.
    pub fn analytic_earth() -> Self {
        Self::Analytic(Box::new(AnalyticPlanet::earth()))
    }

    pub fn radius_m(&self) -> f64 {
        match self {
            Self::Analytic(p) => p.radius_m,
            Self::Dem(d) => d.radius_m(),
        }
    }

    /// The terrain function: height in metres above the sphere at unit vector `u` (f64).
    pub fn height_m(&self, u: DVec3) -> f64 {
        match self {
            Self::Analytic(p) => p.height_m(u),
            Self::Dem(d) => d.height_m(u),
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
            Self::Dem(d) => d.height_range_m(),
        }
    }

    /// Bounds of the terrain within an arc of `angle_rad` around `u` (for culling).
    pub fn height_bounds_near_m(&self, u: DVec3, angle_rad: f64) -> (f64, f64) {
        match self {
            Self::Analytic(p) => p.height_bounds_near_m(u, angle_rad),
            Self::Dem(d) => d.height_bounds_near_m(u, angle_rad),
        }
    }

    /// The analytic planet, when that is the source (tests use its closed-form error bounds).
    pub fn analytic(&self) -> Option<&AnalyticPlanet> {
        match self {
            Self::Analytic(p) => Some(p.as_ref()),
            Self::Dem(_) => None,
        }
    }

    pub fn describe(&self) -> String {
        match self {
            Self::Analytic(_) => "analytic test planet".to_string(),
            Self::Dem(d) => d.describe().to_string(),
        }
    }
}

/// The terrain named on a command line (`--dem`): `embedded` (the default real Earth),
/// `analytic` (the test planet), a pyramid file, or any raster globe reads (a folder of EHdr
/// tiles, a `.HDR`/`.DEM`, a netCDF-3 file), imported into the cache first with `progress`
/// called with the fraction done.
pub fn open_terrain(
    spec: &str,
    progress: impl FnMut(f64),
) -> Result<Terrain, crate::dem::DemError> {
    let radius_m = crate::geo::EARTH_RADIUS_M;
    match spec {
        "embedded" => Terrain::embedded_earth(),
        "analytic" => Ok(Terrain::analytic_earth()),
        path => {
            let path = std::path::Path::new(path);
            if path.is_file() && starts_with_pyramid_magic(path) {
                return Ok(Terrain::Dem(DemTerrain::open(path, radius_m)?));
            }
            let source = crate::dem::raster::open_raster(path, None)?;
            let cached = dem::cache_path_for(path)?;
            dem::import_cached(source.as_ref(), &cached, progress)?;
            Ok(Terrain::Dem(DemTerrain::open(&cached, radius_m)?))
        }
    }
}

fn starts_with_pyramid_magic(path: &std::path::Path) -> bool {
    use std::io::Read;
    let mut magic = [0u8; 8];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut magic))
        .is_ok()
        && magic == crate::dem::pyramid::MAGIC
}
