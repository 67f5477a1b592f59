//! Real elevation data as the terrain: a tiled pyramid file (`dem::pyramid`), memory-mapped.
//!
//! The terrain function is the finest level interpolated bilinearly between pixel centres
//! (outside a regional file's extents: sea level). A clipmap level texture of ground spacing Δ
//! samples the finest pyramid level at least Δ apart, so a texture never holds more detail than
//! it can carry (spherical-clipmaps.md §4.2–4.3; the pyramid's coarser levels are area-weighted
//! and widened towards the poles). The choice depends on the clipmap level alone, not on the
//! viewer, so nothing pops as the viewer moves. Culling bounds come from the min/max planes.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::DVec3;

use crate::dem::pyramid::{CodeFn, NanPolicy, NotResident, Plane, Pyramid, PyramidBuilder, Region};
use crate::dem::{DemError, RasterSource};
use crate::geo::sphere;

/// A pyramid file as the renderer's height source.
#[derive(Clone)]
pub struct DemTerrain {
    pyramid: Arc<Pyramid>,
    radius_m: f64,
    range_m: (f64, f64),
    description: String,
    /// Per level, the value at each pole when the grid reaches it (see [`PoleCap`]).
    poles: Arc<Vec<[Option<PoleCap>; 2]>>,
    /// How the terrain function (level 0) ends at each pole (north, south).
    ends: [PoleEnd; 2],
}

/// An equirectangular grid has no sample at a pole: its outermost row of pixel centres lies
/// half a pixel short of it, and a sample clamped to that row would depend on the longitude it
/// came from (at 10′, ±70 m a metre from the North Pole: a star of radial ridges). Between that
/// row and the pole the terrain blends linearly to the row's mean, so it has one height at
/// the pole and is continuous across it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoleCap {
    /// Latitude of the outermost row of pixel centres.
    pub row_lat_deg: f64,
    /// The pole's height: the mean of that row.
    pub height_m: f64,
}

/// How the terrain function meets a pole: what the reference ray caster's slope bound may
/// assume there (`measure::reference`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PoleEnd {
    /// The outermost row lies within a pixel short of the pole and the terrain blends to its
    /// mean ([`PoleCap`]).
    Cap(PoleCap),
    /// A row of pixel centres lies on the pole and holds one value all round (ETOPO5: −4290 m
    /// at the North Pole, 2810 m at the South Pole). Bilinear between that row and the next,
    /// the terrain is continuous across the pole and as steep as a cell of the next row.
    ConstantRow { height_m: f64 },
    /// Neither: a regional grid, a grid ending more than a pixel short of the pole, or a row
    /// on the pole whose values differ (the terrain then has no single height at the pole and
    /// no slope bound near it).
    Open,
}

impl std::fmt::Debug for DemTerrain {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DemTerrain")
            .field("file", &self.pyramid.path())
            .field("range_m", &self.range_m)
            .finish()
    }
}

impl DemTerrain {
    /// Opens a pyramid file on a sphere of radius `radius_m`.
    pub fn open(path: &Path, radius_m: f64) -> Result<Self, DemError> {
        Ok(Self::from_pyramid(Pyramid::open(path)?, radius_m))
    }

    /// Opens a pyramid on an HTTP server or an S3 store (`crate::dem::remote`); without a
    /// disk cache folder in `options`, the cache folder's `remote/` holds it.
    pub fn open_remote(
        url: &str,
        mut options: crate::dem::remote::RemoteOptions,
        radius_m: f64,
    ) -> Result<Self, DemError> {
        if options.disk_cache_dir.is_none() {
            options.disk_cache_dir = Some(cache_dir().join("remote"));
        }
        Ok(Self::from_pyramid(
            Pyramid::open_remote(url, options)?,
            radius_m,
        ))
    }

    fn from_pyramid(pyramid: Pyramid, radius_m: f64) -> Self {
        let path = pyramid.path().to_path_buf();
        let info = pyramid.info();
        // Heights outside a regional file's extents are sea level, so 0 is in the range.
        let range_m = (info.min_m.min(0.0), info.max_m.max(0.0));
        let description = format!("{} ({})", info.description, path.display());
        let poles: Vec<_> = (0..pyramid.level_count())
            .map(|level| pole_caps(&pyramid, level))
            .collect();
        let ends = pole_ends(&pyramid, poles.first().copied().unwrap_or([None, None]));
        Self {
            pyramid: Arc::new(pyramid),
            radius_m,
            range_m,
            description,
            poles: Arc::new(poles),
            ends,
        }
    }

    /// How the terrain function (the finest level) ends at the North and the South Pole.
    pub fn pole_ends(&self) -> [PoleEnd; 2] {
        self.ends
    }

    /// The avg plane of `level` at (lat, lon), bilinear, blended to the pole's value beyond the
    /// outermost row (see [`PoleCap`]); sea level outside the data.
    pub fn sample_m(&self, lat_deg: f64, lon_deg: f64, level: usize) -> f64 {
        let code = |l, p, r, c| self.pyramid.pixel_code(l, p, r, c);
        self.sample_m_with(lat_deg, lon_deg, level, &code)
            .unwrap_or(0.0)
    }

    /// As [`DemTerrain::sample_m`], reading codes through `code` (a cache of streamed tiles,
    /// which may lack the tile needed).
    pub fn sample_m_with(
        &self,
        lat_deg: f64,
        lon_deg: f64,
        level: usize,
        code: CodeFn<'_>,
    ) -> Result<f64, NotResident> {
        let [north, south] = self.poles.get(level).copied().unwrap_or([None, None]);
        let plane = |lat: f64| {
            self.pyramid
                .sample_plane_with(lat, lon_deg, level, Plane::Avg, code)
                .map(|v| v.unwrap_or(0.0))
        };
        let towards = |cap: PoleCap, pole_lat: f64| -> Result<f64, NotResident> {
            let t = ((lat_deg - cap.row_lat_deg) / (pole_lat - cap.row_lat_deg)).clamp(0.0, 1.0);
            let row = plane(cap.row_lat_deg)?;
            Ok(row + (cap.height_m - row) * t)
        };
        match (north, south) {
            (Some(cap), _) if lat_deg > cap.row_lat_deg => towards(cap, 90.0),
            (_, Some(cap)) if lat_deg < cap.row_lat_deg => towards(cap, -90.0),
            _ => plane(lat_deg),
        }
    }

    /// The pole caps of `level` (north, south), where its grid reaches a pole.
    pub fn pole_caps(&self, level: usize) -> [Option<PoleCap>; 2] {
        self.poles.get(level).copied().unwrap_or([None, None])
    }

    pub fn radius_m(&self) -> f64 {
        self.radius_m
    }

    pub fn pyramid(&self) -> &Pyramid {
        &self.pyramid
    }

    /// The shared pyramid (the tile streamer reads it on other threads).
    pub fn pyramid_arc(&self) -> Arc<Pyramid> {
        self.pyramid.clone()
    }

    pub fn describe(&self) -> &str {
        &self.description
    }

    pub fn height_range_m(&self) -> (f64, f64) {
        self.range_m
    }

    /// The terrain function at a point: finest level, bilinear.
    pub fn height_at_m(&self, lat_deg: f64, lon_deg: f64) -> f64 {
        self.sample_m(lat_deg, lon_deg, 0)
    }

    pub fn height_m(&self, u: DVec3) -> f64 {
        let (phi, theta, _) = sphere::phi_theta_height_from_ecef_m(u, 1.0);
        let (lat, lon) = sphere::lat_lon_deg_from_phi_theta(phi, theta);
        self.height_at_m(lat, lon)
    }

    /// The pyramid level a texture of ground spacing `texel_m` samples.
    pub fn level_for_texel(&self, texel_m: f64) -> usize {
        self.pyramid
            .level_for_spacing((texel_m / self.radius_m).to_degrees())
    }

    /// The cap whose nodes the drawn terrain within `angle_rad` of a point `arc_rad` from the
    /// viewer reads: widened by a pixel diagonal of the coarsest pyramid level a clipmap
    /// texture there samples (the nodes of every pixel the cap touches). The level drawn at an arc reaches at most twice as far, over at
    /// least 128 texels, so its texel is at most arc·R/32.
    pub fn drawn_cap_rad(&self, angle_rad: f64, arc_rad: f64) -> f64 {
        let level = self.level_for_texel(arc_rad.max(0.0) * self.radius_m / 32.0);
        let g = self.pyramid.grid(level);
        angle_rad + g.dlat_deg.hypot(g.dlon_deg).to_radians()
    }

    /// A bound on the drawn terrain's slope (metres per metre) within `angle_rad` of `u`,
    /// where the nodes it reads span `range_m` ([`DemTerrain::drawn_cap_rad`]). A bilinear
    /// cell's partial derivatives are at most its nodes' range over its side, √2 for the
    /// two; a texture resampling it bilinearly, √2 again. Longitude pixels narrow as cos(lat):
    /// the most poleward latitude of the cap sets the side, and within a pixel of a pole there
    /// is no bound (∞).
    pub fn slope_bound(&self, u: DVec3, angle_rad: f64, range_m: f64) -> f64 {
        let g = self.pyramid.grid(0);
        let (_, theta, _) = sphere::phi_theta_height_from_ecef_m(u, 1.0);
        let lat_max =
            (std::f64::consts::FRAC_PI_2 - theta).abs() + angle_rad + g.dlat_deg.to_radians();
        if lat_max >= std::f64::consts::FRAC_PI_2 {
            return f64::INFINITY;
        }
        let side_rad = g
            .dlat_deg
            .to_radians()
            .min(g.dlon_deg.to_radians() * lat_max.cos());
        2.0 * std::f64::consts::SQRT_2 * range_m.max(0.0) / (self.radius_m * side_rad)
    }

    /// Height at (φ, θ) as a texture of ground spacing `texel_m` holds it.
    pub fn height_band_limited_m(&self, phi_rad: f64, theta_rad: f64, level: usize) -> f64 {
        let (lat, lon) = sphere::lat_lon_deg_from_phi_theta(phi_rad, theta_rad);
        self.sample_m(lat, lon, level)
    }

    /// Bounds of the terrain within an arc of `angle_rad` around `u`, from the min/max planes
    /// of a level a few pixels across the cap (conservative: each coarse min/max bounds every
    /// finer sample under it). Outside the data, sea level.
    pub fn height_bounds_near_m(&self, u: DVec3, angle_rad: f64) -> (f64, f64) {
        let code = |l, p, r, c| self.pyramid.pixel_code(l, p, r, c);
        self.height_bounds_near_m_with(u, angle_rad, &code)
            .unwrap_or(self.range_m)
    }

    /// As [`DemTerrain::height_bounds_near_m`], reading codes through `code`.
    pub fn height_bounds_near_m_with(
        &self,
        u: DVec3,
        angle_rad: f64,
        code: CodeFn<'_>,
    ) -> Result<(f64, f64), NotResident> {
        self.height_bounds_near_m_at_level_with(u, angle_rad, self.bounds_level(angle_rad), code)
    }

    /// Bounds within `angle_rad` of `u` from the min/max planes of `level` (any level bounds
    /// the terrain; coarser ones more loosely).
    pub fn height_bounds_near_m_at_level_with(
        &self,
        u: DVec3,
        angle_rad: f64,
        level: usize,
        code: CodeFn<'_>,
    ) -> Result<(f64, f64), NotResident> {
        let (phi, theta, _) = sphere::phi_theta_height_from_ecef_m(u, 1.0);
        let (lat, lon) = sphere::lat_lon_deg_from_phi_theta(phi, theta);
        let region = Region::Cap {
            lat_deg: lat,
            lon_deg: lon,
            radius_rad: angle_rad,
        };
        Ok(match self.pyramid.min_max_in_with(region, level, code)? {
            Some(b) if b.complete => (b.min_m, b.max_m),
            Some(b) => (b.min_m.min(0.0), b.max_m.max(0.0)),
            None => (0.0, 0.0),
        })
    }

    /// The level whose min/max planes bound a cap of `angle_rad`: a few pixels across it.
    pub fn bounds_level(&self, angle_rad: f64) -> usize {
        self.pyramid.level_for_spacing(angle_rad.to_degrees() / 4.0)
    }

    /// [`DemTerrain::bounds_level`] for a cap around `u`, coarsened until the cap covers at
    /// most [`MAX_BOUNDS_PIXELS`] pixels. Near a pole a small cap spans every longitude: at the
    /// finest level that was all 2160 columns of the embedded Earth (43 200 at 30″) for every
    /// drawn level, 8 ms of CPU per frame at `north-pole`. Any level's planes bound the
    /// terrain, a coarser one more loosely, so culling stays conservative. For culling only
    /// (`TilesAtHand::dem_bounds_near_m`): the detail's relief map takes the finest bounds of
    /// [`DemTerrain::height_bounds_near_m`], which set its amplitude.
    pub fn bounds_level_at(&self, u: DVec3, angle_rad: f64) -> usize {
        let (_, theta, _) = sphere::phi_theta_height_from_ecef_m(u, 1.0);
        let lat = std::f64::consts::FRAC_PI_2 - theta;
        // The cap's extent in latitude and longitude, degrees (as `Pyramid::min_max_in` reads it).
        let lat_span = 2.0 * angle_rad.to_degrees();
        let lon_span = if lat.abs() + angle_rad >= std::f64::consts::FRAC_PI_2 {
            360.0
        } else {
            2.0 * (angle_rad.sin() / lat.cos())
                .clamp(-1.0, 1.0)
                .asin()
                .to_degrees()
        };
        let last = self.pyramid.level_count() - 1;
        let mut level = self.bounds_level(angle_rad).min(last);
        while level < last {
            let g = self.pyramid.grid(level);
            let pixels =
                (lat_span / g.dlat_deg + 3.0) * ((lon_span / g.dlon_deg).min(g.cols as f64) + 3.0);
            if pixels <= MAX_BOUNDS_PIXELS {
                break;
            }
            level += 1;
        }
        level
    }
}

/// Pixels a culling-bounds query may read ([`DemTerrain::bounds_level_at`]); away from the
/// poles a cap takes about 8 × 8 at its own level, so only high latitudes are coarsened.
pub const MAX_BOUNDS_PIXELS: f64 = 1024.0;

/// A row of pixel centres this close to a pole lies on it (the readers accept a first row up
/// to 1e-9° past a pole); a cap over a narrower gap would make the slope bound near the pole
/// (Δlat: the gap) as good as none.
const POLE_TOLERANCE_DEG: f64 = 1e-9;

/// The pole caps of a level whose grid covers the circle and reaches within one pixel of a pole.
fn pole_caps(pyramid: &Pyramid, level: usize) -> [Option<PoleCap>; 2] {
    let g = pyramid.grid(level);
    if !pyramid.wraps() || g.rows == 0 {
        return [None, None];
    }
    let cap = |row: usize, pole_lat: f64| {
        let row_lat_deg = g.lat_of_row(row as f64);
        // A row within 1e-9° of the pole lies on it (the readers' tolerance; [`PoleEnd`]).
        let gap = (pole_lat - row_lat_deg).abs();
        if gap > g.dlat_deg || gap <= POLE_TOLERANCE_DEG || row_lat_deg.abs() >= 90.0 {
            return None;
        }
        let sum: f64 = (0..g.cols)
            .filter_map(|c| pyramid.pixel_m(level, Plane::Avg, row, c))
            .sum();
        Some(PoleCap {
            row_lat_deg,
            height_m: sum / g.cols as f64,
        })
    };
    [cap(0, 90.0), cap(g.rows - 1, -90.0)]
}

/// How level 0 ends at each pole: its [`PoleCap`]s, or a row on the pole holding one code.
fn pole_ends(pyramid: &Pyramid, caps: [Option<PoleCap>; 2]) -> [PoleEnd; 2] {
    let g = pyramid.grid(0);
    let on_pole_row = |row: usize, pole_lat: f64| -> PoleEnd {
        let gap = (g.lat_of_row(row as f64) - pole_lat).abs();
        if !pyramid.wraps() || g.rows == 0 || gap > POLE_TOLERANCE_DEG {
            return PoleEnd::Open;
        }
        let first = pyramid.pixel_code(0, Plane::Avg, row, 0);
        let constant = (1..g.cols).all(|c| pyramid.pixel_code(0, Plane::Avg, row, c) == first);
        match pyramid.pixel_m(0, Plane::Avg, row, 0) {
            Some(height_m) if constant => PoleEnd::ConstantRow { height_m },
            _ => PoleEnd::Open,
        }
    };
    let end = |cap: Option<PoleCap>, row: usize, pole_lat: f64| match cap {
        Some(c) => PoleEnd::Cap(c),
        None => on_pole_row(row, pole_lat),
    };
    [
        end(caps[0], 0, 90.0),
        end(caps[1], g.rows.saturating_sub(1), -90.0),
    ]
}

/// Where imported pyramids are cached: `$XDG_CACHE_HOME/globe` or `~/.cache/globe`, else the
/// system temporary folder.
pub fn cache_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("XDG_CACHE_HOME").filter(|d| !d.is_empty()) {
        return PathBuf::from(d).join("globe");
    }
    if let Some(h) = std::env::var_os("HOME").filter(|h| !h.is_empty()) {
        return PathBuf::from(h).join(".cache").join("globe");
    }
    std::env::temp_dir().join("globe-cache")
}

/// Builds the pyramid of `source` at `path` unless a valid one is already there. `progress`
/// gets the fraction done. Safe when several threads or processes import the same source at
/// once: each builds under its own temporary name and renames it into place (atomic; identical
/// results), and within a process one import at a time runs.
pub fn import_cached(
    source: &dyn RasterSource,
    path: &Path,
    mut progress: impl FnMut(f64),
) -> Result<(), DemError> {
    static IMPORT: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _one_at_a_time = IMPORT.lock().unwrap_or_else(|p| p.into_inner());
    if Pyramid::open(path).is_ok() {
        return Ok(());
    }
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|source| DemError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
    }
    let mut unique = path.as_os_str().to_owned();
    unique.push(format!(".{}.tmp", std::process::id()));
    let unique = PathBuf::from(unique);
    PyramidBuilder::new()
        .nan_policy(NanPolicy::SeaLevel)
        .on_progress(|p| progress(p.fraction))
        .build(source, &unique)?;
    std::fs::rename(&unique, path).map_err(|source| DemError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    Ok(())
}

/// The embedded Earth's pyramid, built into the cache on first use (well under a second).
pub fn embedded_earth(radius_m: f64) -> Result<DemTerrain, DemError> {
    let bytes = crate::dem::embedded::EARTH_PNG;
    let path = cache_dir().join(format!(
        "embedded-earth-{:08x}.globepyr",
        crc32fast::hash(bytes)
    ));
    let earth = crate::dem::embedded::EmbeddedEarth::from_png(bytes)?;
    import_cached(&earth, &path, |_| {})?;
    DemTerrain::open(&path, radius_m)
}

/// A cache file name for `source_path`: its canonical path and, for every file it names (the
/// tiles of a folder), size and modification time, hashed, so a changed input is re-imported.
pub fn cache_path_for(source_path: &Path) -> Result<PathBuf, DemError> {
    let io = |source| DemError::Io {
        path: source_path.to_path_buf(),
        source,
    };
    let canonical = source_path.canonicalize().map_err(io)?;
    let mut key = canonical.to_string_lossy().into_owned();
    let mut files: Vec<PathBuf> = if canonical.is_dir() {
        std::fs::read_dir(&canonical)
            .map_err(io)?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .collect()
    } else {
        vec![canonical.clone()]
    };
    files.sort();
    for f in files {
        if let Ok(m) = std::fs::metadata(&f) {
            let mtime = m
                .modified()
                .ok()
                .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok());
            key.push_str(&format!("|{}|{}|{:?}", f.display(), m.len(), mtime));
        }
    }
    let stem = canonical
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "dem".into());
    Ok(cache_dir().join(format!(
        "{stem}-{:08x}.globepyr",
        crc32fast::hash(key.as_bytes())
    )))
}
