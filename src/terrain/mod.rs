//! Height sources: the terrain function every LOD method approximates (one terrain
//! function: docs/design.md#one-terrain-function). The analytic test planet is known in closed form at any (φ, θ), so tests can
//! check rendered heights exactly; the DEM pyramid (real elevation data) joins it here.

pub mod analytic;
pub mod at_hand;
pub mod dem;

use std::sync::Arc;

use glam::DVec3;

pub use analytic::AnalyticPlanet;
pub use dem::DemTerrain;

use crate::geo::sphere;
use crate::imagery::Imagery;
use crate::procedural::{Detail, DetailParams, RoughnessMap};

/// Where the terrain's base heights come from.
#[derive(Clone, Debug)]
pub enum Base {
    /// The analytic test planet (boxed: its wave table is large next to a DEM handle).
    Analytic(Box<AnalyticPlanet>),
    /// Real elevation data from a pyramid file.
    Dem(DemTerrain),
}

/// The terrain function every LOD method approximates: the base heights (DEM or analytic)
/// plus, when on, the procedural detail below their resolution (`procedural`).
#[derive(Clone, Debug)]
pub struct Terrain {
    base: Base,
    detail: Option<Arc<Detail>>,
    /// Water level, metres (`None`: no water). The surface is then max(h, level) everywhere
    /// (geometry, reference ray caster and metric alike): the sea is a surface, not a tint.
    water_level_m: Option<f64>,
    /// True colour draped on the surface (`None`: the surface types' rule). Shading only:
    /// it never changes a height.
    imagery: Option<Arc<Imagery>>,
}

impl From<Base> for Terrain {
    fn from(base: Base) -> Self {
        Self {
            base,
            detail: None,
            water_level_m: None,
            imagery: None,
        }
    }
}

/// The rule water adds to any height: the surface is the higher of ground and water.
pub fn with_water(height_m: f64, water_level_m: Option<f64>) -> f64 {
    match water_level_m {
        Some(w) => height_m.max(w),
        None => height_m,
    }
}

/// [`with_water`] on a (min, max) pair: bounds of max(h, w) are the bounds of h, each raised
/// to w.
pub fn bounds_with_water(bounds: (f64, f64), water_level_m: Option<f64>) -> (f64, f64) {
    (
        with_water(bounds.0, water_level_m),
        with_water(bounds.1, water_level_m),
    )
}

impl Terrain {
    /// The real Earth shipped inside the binary (ETOPO5 at 10′), its pyramid built into the
    /// cache on first use.
    pub fn embedded_earth() -> Result<Self, crate::dem::DemError> {
        Ok(Base::Dem(dem::embedded_earth(crate::geo::EARTH_RADIUS_M)?).into())
    }

    /// The analytic test planet on the Earth's sphere.
    pub fn analytic_earth() -> Self {
        Base::Analytic(Box::new(AnalyticPlanet::earth())).into()
    }

    /// A DEM terrain without detail.
    pub fn dem_terrain(dem: DemTerrain) -> Self {
        Base::Dem(dem).into()
    }

    /// The same base with detail of `params` (`None`: off). Builds the relief map from the
    /// base (a fraction of a second).
    pub fn with_detail(self, params: Option<DetailParams>) -> Self {
        let base_only: Terrain = self.base.into();
        let detail = params.map(|p| {
            let cols = (360.0 / RoughnessMap::DEFAULT_CELL_DEG) as u32;
            let radius_m = base_only.radius_m();
            let roughness = RoughnessMap::of_bounds(cols, radius_m, |u, angle| {
                base_only.height_bounds_near_m(u, angle)
            });
            Arc::new(Detail::new(
                p,
                radius_m,
                base_only.data_spacing_m(),
                roughness,
            ))
        });
        Self {
            base: base_only.base,
            detail,
            water_level_m: self.water_level_m,
            imagery: self.imagery,
        }
    }

    /// The same base with a prepared detail.
    pub fn with_detail_of(self, detail: Option<Arc<Detail>>) -> Self {
        Self { detail, ..self }
    }

    /// The same terrain with water at `level_m` (`None`: no water; docs/look.md#the-look).
    pub fn with_water_level(self, level_m: Option<f64>) -> Self {
        Self {
            water_level_m: level_m,
            ..self
        }
    }

    /// The same terrain with `imagery` draped on it (`None`: none).
    pub fn with_imagery(self, imagery: Option<Arc<Imagery>>) -> Self {
        Self { imagery, ..self }
    }

    /// The imagery draped on the surface, if any.
    pub fn imagery(&self) -> Option<&Arc<Imagery>> {
        self.imagery.as_ref()
    }

    /// The water level, metres, when water is on.
    pub fn water_level_m(&self) -> Option<f64> {
        self.water_level_m
    }

    /// Pixel spacing of the base's data at the equator, metres (the analytic planet: half its
    /// shortest wavelength): the detail starts below it.
    pub fn data_spacing_m(&self) -> f64 {
        match &self.base {
            Base::Analytic(p) => {
                let omega = p.scales.iter().map(|s| s.omega).fold(1.0, f64::max);
                std::f64::consts::PI * p.radius_m / omega
            }
            Base::Dem(d) => d.pyramid().grid(0).dlat_deg.to_radians() * d.radius_m(),
        }
    }

    pub fn base(&self) -> &Base {
        &self.base
    }

    pub fn detail(&self) -> Option<&Arc<Detail>> {
        self.detail.as_ref()
    }

    /// The DEM, when that is the base.
    pub fn dem(&self) -> Option<&DemTerrain> {
        match &self.base {
            Base::Dem(d) => Some(d),
            Base::Analytic(_) => None,
        }
    }

    pub fn radius_m(&self) -> f64 {
        match &self.base {
            Base::Analytic(p) => p.radius_m,
            Base::Dem(d) => d.radius_m(),
        }
    }

    /// The base heights alone at unit vector `u` (f64).
    pub fn base_height_m(&self, u: DVec3) -> f64 {
        match &self.base {
            Base::Analytic(p) => p.height_m(u),
            Base::Dem(d) => d.height_m(u),
        }
    }

    /// The ground: base plus every octave of detail down to its floor, at unit vector `u`
    /// (f64). This is where a camera stands ("2 m above terrain").
    pub fn height_m(&self, u: DVec3) -> f64 {
        let detail = self
            .detail
            .as_ref()
            .map_or(0.0, |d| d.height_m(u, d.lambda_full()));
        with_water(self.base_height_m(u) + detail, self.water_level_m)
    }

    /// The terrain function as geometry for a viewer above `viewer_u`: base plus the detail
    /// octaves geometry holds at that arc distance (`procedural` module docs).
    pub fn height_for_viewer_m(&self, u: DVec3, viewer_u: DVec3) -> f64 {
        let base = self.base_height_m(u);
        let h = match &self.detail {
            None => base,
            Some(d) => {
                let arc = sphere::great_circle_distance_m(u, viewer_u, 1.0);
                base + d.height_m(u, d.lambda_at_angle(arc))
            }
        };
        with_water(h, self.water_level_m)
    }

    pub fn height_at_lat_lon_m(&self, lat_deg: f64, lon_deg: f64) -> f64 {
        let (phi, theta) = sphere::phi_theta_from_lat_lon_deg(lat_deg, lon_deg);
        self.height_m(sphere::unit_vector(phi, theta))
    }

    /// Largest |detail| anywhere (0 without detail).
    pub fn detail_bound_m(&self) -> f64 {
        self.detail.as_ref().map_or(0.0, |d| {
            d.amplitude_for_relief_m(d.roughness().max_relief_m())
                * d.normalized_bound(d.lambda_full())
        })
    }

    /// Lowest and highest terrain anywhere (for the horizon bound, eq. 6).
    pub fn height_range_m(&self) -> (f64, f64) {
        let (lo, hi) = match &self.base {
            Base::Analytic(p) => p.height_range_m(),
            Base::Dem(d) => d.height_range_m(),
        };
        let b = self.detail_bound_m();
        bounds_with_water((lo - b, hi + b), self.water_level_m)
    }

    /// Bounds of the terrain within an arc of `angle_rad` around `u` (for culling).
    pub fn height_bounds_near_m(&self, u: DVec3, angle_rad: f64) -> (f64, f64) {
        let (lo, hi) = match &self.base {
            Base::Analytic(p) => p.height_bounds_near_m(u, angle_rad),
            Base::Dem(d) => d.height_bounds_near_m(u, angle_rad),
        };
        let b = self
            .detail
            .as_ref()
            .map_or(0.0, |d| d.bounds_near(u, angle_rad, d.lambda_full()).0);
        bounds_with_water((lo - b, hi + b), self.water_level_m)
    }

    /// The analytic planet, when that is the source (tests use its closed-form error bounds).
    pub fn analytic(&self) -> Option<&AnalyticPlanet> {
        match &self.base {
            Base::Analytic(p) => Some(p.as_ref()),
            Base::Dem(_) => None,
        }
    }

    pub fn describe(&self) -> String {
        let base = match &self.base {
            Base::Analytic(_) => "analytic test planet".to_string(),
            Base::Dem(d) => d.describe().to_string(),
        };
        let detail = match &self.detail {
            Some(_) => format!("{base} + procedural detail"),
            None => base,
        };
        match self.water_level_m {
            Some(w) => format!("{detail}, water at {w} m"),
            None => detail,
        }
    }
}

/// The terrain named on a command line (`--dem`): `embedded` (the default real Earth),
/// `analytic` (the test planet), a pyramid file, or any raster globe reads (a folder of EHdr
/// tiles, of SRTM `.hgt` tiles or of GeoTIFFs, a `.HDR`/`.DEM`, a netCDF-3 file, a GeoTIFF/COG,
/// an `.hgt` tile: `dem::open_raster`), imported into the cache first with `progress`
/// called with the fraction done.
pub fn open_terrain(
    spec: &str,
    progress: impl FnMut(f64),
) -> Result<Terrain, crate::dem::DemError> {
    open_terrain_with(spec, crate::dem::remote::RemoteOptions::default(), progress)
}

/// As [`open_terrain`]; `remote` says how a pyramid named by URL (`http://`, `https://`,
/// `s3://`) is read.
pub fn open_terrain_with(
    spec: &str,
    remote: crate::dem::remote::RemoteOptions,
    progress: impl FnMut(f64),
) -> Result<Terrain, crate::dem::DemError> {
    let radius_m = crate::geo::EARTH_RADIUS_M;
    if crate::dem::remote::is_remote_url(spec) {
        return Ok(Terrain::dem_terrain(DemTerrain::open_remote(
            spec, remote, radius_m,
        )?));
    }
    match spec {
        "embedded" => Terrain::embedded_earth(),
        "analytic" => Ok(Terrain::analytic_earth()),
        path => {
            let path = std::path::Path::new(path);
            if path.is_file() && starts_with_pyramid_magic(path) {
                return Ok(Terrain::dem_terrain(DemTerrain::open(path, radius_m)?));
            }
            let source = crate::dem::open_raster(path, None)?;
            let cached = dem::cache_path_for(path)?;
            dem::import_cached(source.as_ref(), &cached, progress)?;
            Ok(Terrain::dem_terrain(DemTerrain::open(&cached, radius_m)?))
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
