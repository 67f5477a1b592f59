//! The terrain as the decoded tiles at hand know it: what a frame's plan asks while the DEM
//! streams (the camera's ground, the culling bounds, a close-up's heights), answered from the
//! LRU without ever reading the file, falling back to coarser levels (whose min/max still
//! bound the terrain) until the finer tiles arrive. Every tile a question missed is noted, for
//! the feed (`render::dem_feed`) to ask the streamer for.
//!
//! `plan::TerrainQuery` is answered from here, so the plan asks the terrain layer, not the
//! renderer, for heights.

use std::cell::{Cell, RefCell};
use std::collections::{HashMap, HashSet};
use std::sync::Arc;

use glam::DVec3;

use crate::dem::pyramid::{CodeFn, Plane};
use crate::geo::sphere;
use crate::procedural::Detail;
use crate::stream::{Priority, TileCache, TileData, TileKey};

use super::{DemTerrain, bounds_with_water, with_water};

/// Priority of the camera's own tile (its height picks the near plane and θ̃min).
pub const CAMERA_PRIORITY: Priority = 0;
/// Bounds tiles come after the levels' tiles of the same frame; a frame missing only these
/// is still complete (coarser bounds still bound the terrain).
pub const BOUNDS_PRIORITY: Priority = 1 << 62;

/// The decoded tiles of a streamed DEM and what the questions asked of them since the last
/// frame's update touched, missed and must keep.
pub struct TilesAtHand {
    dem: DemTerrain,
    /// The decoded tiles (the feed inserts what the streamer delivers and trims it).
    pub cache: TileCache,
    /// Tiles the questions found missing since the last update, with their priority.
    missing: RefCell<HashMap<TileKey, Priority>>,
    /// Whether the last camera ground came from a coarser level than the finest (its tile
    /// was missing): such a frame is not settled, whatever has arrived since.
    fell_back: Cell<bool>,
    /// Tiles the questions read since the last update (promoted in the LRU there).
    touched: RefCell<Vec<TileKey>>,
    /// Tiles the camera's ground read or missed since the last update: the LRU keeps them,
    /// whatever its budget (a frame does not settle on a stand-in height).
    critical: RefCell<HashSet<TileKey>>,
    /// The procedural detail on top of the tiles (camera ground, bounds).
    detail: Option<Arc<Detail>>,
    /// The terrain's water level (`Terrain::water_level_m`): every answer is max(h, level).
    water_level_m: Option<f64>,
}

impl TilesAtHand {
    /// No tiles yet, an LRU of `cache_bytes`.
    pub fn new(dem: DemTerrain, cache_bytes: u64) -> Self {
        Self {
            dem,
            cache: TileCache::new(cache_bytes),
            missing: RefCell::new(HashMap::new()),
            fell_back: Cell::new(false),
            touched: RefCell::new(Vec::new()),
            critical: RefCell::new(HashSet::new()),
            detail: None,
            water_level_m: None,
        }
    }

    pub fn dem(&self) -> &DemTerrain {
        &self.dem
    }

    pub fn detail(&self) -> Option<&Arc<Detail>> {
        self.detail.as_ref()
    }

    pub fn water_level_m(&self) -> Option<f64> {
        self.water_level_m
    }

    /// The detail the camera's ground and the bounds add (the editor replaces it).
    pub fn set_detail(&mut self, detail: Option<Arc<Detail>>) {
        self.detail = detail;
    }

    /// Sets the water level every answer is raised to (`Terrain::water_level_m`).
    pub fn set_water_level(&mut self, level_m: Option<f64>) {
        self.water_level_m = level_m;
    }

    /// How many tiles a question (camera height, culling bounds) missed since the last update:
    /// with any, the frame's culling, which runs after the update, used a coarser level's
    /// bounds.
    pub fn queries_missing(&self) -> usize {
        self.missing.borrow().len()
    }

    /// The update's start: the tiles read since the last one (sorted, once each), those the
    /// camera's ground read or missed, and those missed with their priority; each set empties.
    pub fn take_marks(&self) -> (Vec<TileKey>, HashSet<TileKey>, HashMap<TileKey, Priority>) {
        let mut touched = self.touched.take();
        touched.sort_unstable();
        touched.dedup();
        (touched, self.critical.take(), self.missing.take())
    }

    fn key(&self, level: usize, row: usize, col: usize) -> TileKey {
        let t = self.dem.pyramid().tile_size();
        TileKey {
            level: level as u32,
            tx: (col / t) as u32,
            ty: (row / t) as u32,
        }
    }

    /// Runs `f` with a code reader over the decoded tiles; missing tiles are noted (with
    /// `priority`) when `note` is true.
    fn with_codes<R>(
        &self,
        note: bool,
        priority: Priority,
        critical: bool,
        f: impl FnOnce(CodeFn<'_>) -> R,
    ) -> R {
        let t = self.dem.pyramid().tile_size();
        // The last tile read: a query reads runs of codes from one tile, and a hash lookup
        // (plus the bookkeeping below) per code was most of a projected grid's plan.
        let last: Cell<Option<(TileKey, &TileData)>> = Cell::new(None);
        let code = |level: usize, p: Plane, row: usize, col: usize| -> Option<i16> {
            let key = self.key(level, row, col);
            if let Some((k, tile)) = last.get()
                && k == key
            {
                return Some(tile.code(p, col % t, row % t));
            }
            if critical {
                self.critical.borrow_mut().insert(key);
            }
            match self.cache.peek(&key) {
                Some(tile) => {
                    self.touched.borrow_mut().push(key);
                    last.set(Some((key, tile.as_ref())));
                    Some(tile.code(p, col % t, row % t))
                }
                None => {
                    if critical {
                        self.fell_back.set(true);
                    }
                    if note {
                        self.missing.borrow_mut().insert(key, priority);
                    }
                    None
                }
            }
        };
        f(&code)
    }

    /// The terrain height at (lat, lon) from the finest level at hand (the finest level's tile
    /// is asked for first); sea level before anything has arrived.
    pub fn height_at_m(&self, lat_deg: f64, lon_deg: f64) -> f64 {
        self.height_from_tiles_m(lat_deg, lon_deg, true)
    }

    /// The height a close-up mesh's vertex takes: as [`TilesAtHand::height_at_m`], but
    /// neither asking for tiles nor holding them as the camera's own (the clipmap's levels ask
    /// for what is drawn; a grid's tens of thousands of vertices are not the camera's ground).
    pub fn height_drawn_base_m(&self, lat_deg: f64, lon_deg: f64) -> f64 {
        self.height_from_tiles_m(lat_deg, lon_deg, false)
    }

    /// The height from the finest level at hand; `camera`: the camera's own ground (its
    /// finest tile asked for, and held as critical).
    fn height_from_tiles_m(&self, lat_deg: f64, lon_deg: f64, camera: bool) -> f64 {
        for level in 0..self.dem.pyramid().level_count() {
            let got = self.with_codes(camera && level == 0, CAMERA_PRIORITY, camera, |code| {
                self.dem.sample_m_with(lat_deg, lon_deg, level, code)
            });
            if let Ok(h) = got {
                return h;
            }
        }
        0.0
    }

    /// The camera's ground at (lat, lon): the tiles' height with every octave of the detail
    /// (exact on the CPU), raised to the water; and whether it came from coarser tiles.
    pub fn ground_m(&self, lat_deg: f64, lon_deg: f64) -> (f64, bool) {
        self.fell_back.set(false);
        let mut h = self.height_at_m(lat_deg, lon_deg);
        if let Some(d) = &self.detail {
            let (phi, theta) = sphere::phi_theta_from_lat_lon_deg(lat_deg, lon_deg);
            h += d.height_m(sphere::unit_vector(phi, theta), d.lambda_full());
        }
        (with_water(h, self.water_level_m), self.fell_back.get())
    }

    /// The height the GPU draws at unit vector `u`, `arc_rad` from the viewer (the detail's
    /// octaves limited by the geometry rule there), raised to the water.
    pub fn height_drawn_m(&self, u: DVec3, arc_rad: f64) -> f64 {
        let (phi, theta) = (u.y.atan2(u.x), u.x.hypot(u.y).atan2(u.z));
        let (lat, lon) = sphere::lat_lon_deg_from_phi_theta(phi, theta);
        let base = self.height_drawn_base_m(lat, lon);
        let detail = self
            .detail
            .as_ref()
            .map_or(0.0, |d| d.height_m(u, d.lambda_at_angle(arc_rad)));
        with_water(base + detail, self.water_level_m)
    }

    /// Lowest and highest terrain anywhere: the DEM's range widened by the detail's largest
    /// amplitude, raised to the water.
    pub fn height_range_m(&self) -> (f64, f64) {
        let (lo, hi) = self.dem.height_range_m();
        let b = self.detail.as_ref().map_or(0.0, |d| {
            d.amplitude_for_relief_m(d.roughness().max_relief_m())
                * d.normalized_bound(d.lambda_full())
        });
        bounds_with_water((lo - b, hi + b), self.water_level_m)
    }

    /// The DEM's bounds within `angle_rad` of `u` (no detail, no water): from the level that
    /// `DemTerrain::height_bounds_near_m` uses when its tiles are here, else from a coarser
    /// level (its min/max bound every finer sample), else the global range.
    pub fn dem_bounds_near_m(&self, u: DVec3, angle_rad: f64) -> (f64, f64) {
        let first = self.dem.bounds_level_at(u, angle_rad);
        for level in first..self.dem.pyramid().level_count() {
            // Coarser bounds still bound the terrain: culling stays conservative and the image
            // the same, so a fallback here does not keep the frame from settling.
            let got = self.with_codes(level == first, BOUNDS_PRIORITY, false, |code| {
                self.dem
                    .height_bounds_near_m_at_level_with(u, angle_rad, level, code)
            });
            if let Ok(b) = got {
                return b;
            }
        }
        self.dem.height_range_m()
    }

    /// Terrain bounds within `angle_rad` of `u` (culling): the DEM's from the tiles at hand,
    /// widened by the detail's amplitude there, raised to the water.
    pub fn height_bounds_near_m(&self, u: DVec3, angle_rad: f64) -> (f64, f64) {
        let (lo, hi) = self.dem_bounds_near_m(u, angle_rad);
        let b = self
            .detail
            .as_ref()
            .map_or(0.0, |d| d.bounds_near(u, angle_rad, d.lambda_full()).0);
        bounds_with_water((lo - b, hi + b), self.water_level_m)
    }

    /// The data's bilinear height at pixel `base` + `frac` of pyramid level `level` (f64, the
    /// DEM fill's own interpolation), if its four codes are at hand; columns wrap.
    pub fn bilinear_m(&self, level: usize, base: [i64; 2], frac: [f64; 2]) -> Option<f64> {
        let pyr = self.dem.pyramid();
        let cols = pyr.grid(level).cols as i64;
        let enc = pyr.encoding();
        self.with_codes(false, BOUNDS_PRIORITY, false, |code| {
            let at = |dc: i64, dr: i64| {
                let c = (base[0] + dc).rem_euclid(cols) as usize;
                code(level, Plane::Avg, (base[1] + dr) as usize, c).map(f64::from)
            };
            let (a, b, c, d) = (at(0, 0)?, at(1, 0)?, at(0, 1)?, at(1, 1)?);
            let (fc, fr) = (frac[0], frac[1]);
            let top = a + fc * (b - a);
            let bottom = c + fc * (d - c);
            Some(enc.offset_m + enc.quantum_m * (top + fr * (bottom - top)))
        })
    }
}
