//! Feeds the clipmap level textures of a DEM from the tile streamer: works out which
//! pyramid tiles each level's new texels need, asks the streamer for the missing ones (coarse
//! levels first, then finer ones nearest the viewer), uploads arrived tiles into the GPU tile
//! cache within a per-frame budget, and fills a level only when every tile it needs is there.
//!
//! The render thread never touches the file: the plan's questions (the camera's height, the
//! culling bounds) are answered from the decoded tiles at hand (`terrain::at_hand`), and the
//! tiles those questions missed are asked for here, with the levels' own.

use std::collections::{HashMap, HashSet, VecDeque};
use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::DVec3;

use crate::clipmap::levels::{GridRect, LevelGrid};
use crate::clipmap::settings::level_outer_theta_rad;
use crate::dem::FileChange;
use crate::geo::sphere;
use crate::plan::LevelFill;
use crate::procedural::Detail;
use crate::stream::open_source;
use crate::stream::{
    Completion, Priority, StreamSettings, StreamStats, TileData, TileKey, TileStreamer,
};
use crate::terrain::DemTerrain;
use crate::terrain::at_hand::{BOUNDS_PRIORITY, TilesAtHand};

use super::RenderError;
use super::detail::DetailResources;
use super::fill_dem::DemFillPass;
use super::gpu_data::{DemFillJob, DemFillParams};
use super::tiles::GpuTileCache;

/// The levels whose DEM fill starts from each block's corner (`DemFillJob::anchor_height_m`):
/// those seen from at most this far (a quarter of their diameter, metres). Farther, the
/// direct interpolation's per-block rounding (ulp of the data's values relative to the
/// reference: at most 10⁻⁴ m) is below 10⁻⁵ of the distance, and the relative path costs a
/// CPU rasteriser half again the fill's time.
const RELATIVE_FILL_REACH_M: f64 = 16.0;

/// What the feed did in one frame, and the pipeline's state (for the UI and `globe bench`).
#[derive(Clone, Debug, Default)]
pub struct FeedFrame {
    pub stream: StreamStats,
    /// Tiles the levels and the CPU queries need this frame.
    pub tiles_needed: u32,
    /// Of those, not yet decoded (asked of the streamer).
    pub tiles_missing: u32,
    pub uploads: u32,
    /// Tiles decoded and waiting for upload budget.
    pub upload_backlog: u32,
    pub cache_bytes: u64,
    pub cache_budget: u64,
    /// Bytes of the cached tiles this frame holds whatever the budget (the camera's ground,
    /// tiles on their way to the GPU): `cache_bytes` ≤ max(`cache_budget`, this).
    pub cache_kept_bytes: u64,
    pub cache_tiles: usize,
    pub cache_hit_rate: Option<f64>,
    pub gpu_tiles: usize,
    pub gpu_capacity: usize,
    pub gpu_bytes_uploaded: u64,
    /// True when every needed tile is on the GPU and every wanted level was filled.
    pub complete: bool,
    /// A level that needs more tiles at once than the GPU tile cache holds (`--gpu-tiles`):
    /// it can never be filled, and the view never completes.
    pub gpu_tiles_short: Option<GpuTilesShort>,
    pub last_error: Option<String>,
    /// What happened to the pyramid file since it was opened, as the watcher last saw it
    /// (None: as opened). The panel shows it.
    pub file_change: Option<FileChange>,
    /// Every change the watcher reported, oldest first (the last 16), and how many in all: a
    /// front end prints those it has not printed yet, so each reaches stderr once.
    pub file_changes: Vec<FileChange>,
    pub file_changes_total: u64,
    /// Bytes read from the source per second, over the last half second or more.
    pub read_mb_per_s: f64,
}

impl FeedFrame {
    /// The reported file changes after the first `printed` (those a front end has not printed
    /// yet; at most the last 16).
    pub fn file_changes_after(&self, printed: u64) -> &[FileChange] {
        let new = self.file_changes_total.saturating_sub(printed) as usize;
        &self.file_changes[self.file_changes.len().saturating_sub(new)..]
    }
}

/// The GPU tile cache is too small for a level of the view: a level is filled from its tiles
/// all resident at once.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GpuTilesShort {
    /// Tiles asked for (`--gpu-tiles`).
    pub asked: u32,
    /// Slots of the GPU tile cache: those asked for, within the device's limit.
    pub capacity: u32,
    /// The most tiles one wanted level reads: the smallest cache that fills every level.
    pub needed: u32,
}

impl std::fmt::Display for GpuTilesShort {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "--gpu-tiles {} cannot hold the {} tiles one clipmap level of this view reads at \
             once; the smallest that works for this view is --gpu-tiles {}",
            self.asked, self.needed, self.needed
        )?;
        if self.asked > self.capacity {
            write!(f, " (this device holds at most {} tiles)", self.capacity)?;
        }
        Ok(())
    }
}

/// The DEM's streaming pipeline, owned by the terrain renderer.
pub struct DemFeed {
    /// The decoded tiles and what the plan's questions of them touched and missed.
    tiles: TilesAtHand,
    streamer: TileStreamer,
    gpu: GpuTileCache,
    fill: DemFillPass,
    settings: StreamSettings,
    frame: u64,
    /// What the LRU keeps beyond its budget until the next update: the last frame's critical
    /// tiles and its level tiles not yet on the GPU.
    keep: HashSet<TileKey>,
    errors: VecDeque<String>,
    /// The file's state and the changes reported (see [`FeedFrame::file_change`]).
    file_change: Option<FileChange>,
    file_changes: VecDeque<FileChange>,
    file_changes_total: u64,
    pub last: FeedFrame,
    /// (when, bytes read then) of the last rate sample.
    rate_sample: (Instant, u64),
    read_mb_per_s: f64,
}

/// A level's fill jobs and the pyramid tiles they read.
type LevelJobs = (Vec<DemFillJob>, Vec<TileKey>);

/// The levels the GPU tile cache takes this frame (coarse first, those whose tiles fit beside
/// the ones taken before) and the priority of every tile wanted.
struct Admission {
    taken: HashSet<TileKey>,
    /// Per level: its tiles fit.
    admitted: Vec<bool>,
    needed: HashMap<TileKey, Priority>,
    gpu_tiles_short: Option<GpuTilesShort>,
}

impl DemFeed {
    /// The detail the camera's ground and the bounds add (the editor replaces it).
    pub fn set_detail(&mut self, detail: Option<Arc<Detail>>) {
        self.tiles.set_detail(detail);
    }

    pub fn new(
        device: &wgpu::Device,
        dem: DemTerrain,
        settings: StreamSettings,
        fill_capacity: u32,
        detail: &DetailResources,
    ) -> Result<Self, RenderError> {
        let source = open_source(dem.pyramid_arc(), settings.faults);
        let streamer = TileStreamer::new(source, &settings).map_err(RenderError::StreamerStart)?;
        let gpu = GpuTileCache::new(device, dem.pyramid(), settings.gpu_tiles);
        let mut tiles = TilesAtHand::new(dem, settings.cache_bytes);
        tiles.set_detail(detail.detail().cloned());
        Ok(Self {
            tiles,
            gpu,
            fill: DemFillPass::new(device, fill_capacity, detail),
            streamer,
            settings,
            frame: 0,
            keep: HashSet::new(),
            errors: VecDeque::new(),
            file_change: None,
            file_changes: VecDeque::new(),
            file_changes_total: 0,
            last: FeedFrame::default(),
            rate_sample: (Instant::now(), 0),
            read_mb_per_s: 0.0,
        })
    }

    /// A feed writing into the level textures `heights`, its answers raised to `water_level_m`
    /// (the renderer's: [`DemFeed::new`], [`DemFeed::bind`], [`DemFeed::set_water_level`]).
    pub fn for_levels(
        device: &wgpu::Device,
        dem: DemTerrain,
        settings: StreamSettings,
        fill_capacity: u32,
        detail: &DetailResources,
        heights: &wgpu::TextureView,
        water_level_m: Option<f64>,
    ) -> Result<Self, RenderError> {
        let mut feed = Self::new(device, dem, settings, fill_capacity, detail)?;
        feed.bind(device, heights);
        feed.set_water_level(water_level_m);
        Ok(feed)
    }

    /// Sets the water level every terrain answer is raised to (`Terrain::water_level_m`).
    pub fn set_water_level(&mut self, level_m: Option<f64>) {
        self.tiles.set_water_level(level_m);
    }

    pub fn bind(&mut self, device: &wgpu::Device, heights: &wgpu::TextureView) {
        self.fill.bind(device, heights, &self.gpu);
    }

    pub fn settings(&self) -> &StreamSettings {
        &self.settings
    }

    /// The decoded tiles: what the frame's plan asks its terrain questions of.
    pub fn tiles(&self) -> &TilesAtHand {
        &self.tiles
    }

    /// The terrain height at (lat, lon) from the finest level at hand (see
    /// [`TilesAtHand::height_at_m`]).
    pub fn height_at_m(&self, lat_deg: f64, lon_deg: f64) -> f64 {
        self.tiles.height_at_m(lat_deg, lon_deg)
    }

    /// One frame: takes what the streamer delivered, uploads within the budget, fills the
    /// levels whose tiles are all on the GPU, and tells the streamer what is still missing.
    /// `levels` runs from coarse to fine; returns, per level, whether it was filled (its
    /// texture now holds `grid`), and the texels written.
    pub fn update(
        &mut self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        levels: &[LevelFill],
        nadir_phi_theta: (f64, f64),
        detail: &DetailResources,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> (Vec<bool>, u64) {
        self.frame += 1;
        let frame = self.frame;
        let (touched, critical, aux) = self.tiles.take_marks();
        for key in &touched {
            self.tiles.cache.promote(key);
        }

        let nadir = sphere::unit_vector(nadir_phi_theta.0, nadir_phi_theta.1);
        let per_level = self.level_jobs(levels);
        let Admission {
            taken,
            admitted,
            mut needed,
            gpu_tiles_short,
        } = self.admit_levels(&per_level, nadir);
        // Tiles the CPU queries (camera height, culling bounds) missed: they are needed decoded,
        // in the LRU, even when a copy sits on the GPU (which the CPU cannot read).
        for (&k, &p) in &aux {
            needed
                .entry(k)
                .and_modify(|q| *q = (*q).min(p))
                .or_insert(p);
        }

        // What the LRU keeps whatever its budget: the camera's ground tiles and the level
        // tiles this frame still has to upload.
        let gpu = &self.gpu;
        let to_upload = taken.iter().filter(|k| !gpu.contains(k));
        self.keep = critical.iter().chain(to_upload).copied().collect();
        for done in self.streamer.poll() {
            match done {
                Completion::Loaded(tile) => {
                    let keep = &self.keep;
                    self.tiles.cache.insert_keeping(tile, |k| keep.contains(k));
                }
                Completion::Failed(_, e) => self.note_error(&e.to_string()),
                Completion::Cancelled(_) => {}
            }
        }

        // On the GPU already, decoded and waiting for upload, or missing. Only the levels'
        // tiles go to the GPU; the CPU's are read from the LRU.
        let mut order: Vec<(Priority, TileKey)> = needed.iter().map(|(k, p)| (*p, *k)).collect();
        order.sort_unstable();
        let mut missing: HashMap<TileKey, Priority> = HashMap::new();
        let mut to_upload: Vec<Arc<TileData>> = Vec::new();
        for &(p, k) in &order {
            // Only the levels' tiles hold their slots this frame (the CPU's never need one).
            let on_gpu = if taken.contains(&k) {
                self.gpu.touch(&k, frame)
            } else {
                self.gpu.contains(&k)
            };
            if on_gpu && !aux.contains_key(&k) {
                continue;
            }
            match self.tiles.cache.get(&k) {
                Some(tile) if !on_gpu && taken.contains(&k) => to_upload.push(tile),
                Some(_) => {}
                None => {
                    missing.insert(k, p);
                }
            }
        }
        let budget = self.settings.uploads_per_frame as usize;
        let mut uploads = 0;
        for tile in to_upload.iter().take(budget) {
            if self.gpu.upload(queue, tile, frame) {
                uploads += 1;
            } else {
                self.note_error("the GPU tile cache is too small for this view (--gpu-tiles)");
                break;
            }
        }
        // Uploaded tiles need no decoded copy any more (unless the CPU reads them).
        let gpu = &self.gpu;
        let to_upload_later = taken.iter().filter(|k| !gpu.contains(k));
        self.keep = critical.iter().chain(to_upload_later).copied().collect();
        let keep = &self.keep;
        self.tiles.cache.trim_keeping(|k| keep.contains(k));
        if let Some(short) = gpu_tiles_short {
            self.note_error(&short.to_string());
        }

        let (filled, texels) = self.encode_ready_fills(
            queue, encoder, levels, &per_level, &admitted, detail, timestamps,
        );

        self.streamer.want(&missing);
        let stream = self.watch_file_and_rate();
        self.last = FeedFrame {
            stream,
            read_mb_per_s: self.read_mb_per_s,
            tiles_needed: needed.len() as u32,
            tiles_missing: missing.len() as u32,
            uploads,
            upload_backlog: (to_upload.len() - uploads as usize) as u32,
            cache_bytes: self.tiles.cache.bytes(),
            cache_budget: self.tiles.cache.budget(),
            cache_kept_bytes: self.tiles.cache.bytes_kept(|k| self.keep.contains(k)),
            cache_tiles: self.tiles.cache.len(),
            cache_hit_rate: self.tiles.cache.hit_rate(),
            gpu_tiles: self.gpu.resident_count(),
            gpu_capacity: self.gpu.capacity(),
            gpu_bytes_uploaded: self.gpu.bytes_uploaded,
            // Tiles wanted only for culling bounds do not hold the frame back (see
            // `height_bounds_near_m`).
            complete: missing.values().all(|&p| p == BOUNDS_PRIORITY)
                && to_upload.len() == uploads as usize
                && filled.iter().all(|f| *f),
            gpu_tiles_short,
            last_error: self.errors.back().cloned(),
            file_change: self.file_change.clone(),
            file_changes: self.file_changes.iter().cloned().collect(),
            file_changes_total: self.file_changes_total,
        };
        (filled, texels)
    }

    /// The fill jobs of each level of `levels` and the pyramid tiles they read (coarse first).
    fn level_jobs(&self, levels: &[LevelFill]) -> Vec<LevelJobs> {
        let mut per_level: Vec<LevelJobs> = Vec::new();
        for job in levels {
            let dem = self.tiles.dem();
            let level = dem.level_for_texel(job.grid.band_limit_texel_m(dem.radius_m()));
            let mut params = Vec::new();
            let mut tiles = Vec::new();
            for rect in &job.rects {
                self.jobs_for_rect(&job.grid, rect, level, &mut params, &mut tiles);
            }
            tiles.sort_unstable();
            tiles.dedup();
            per_level.push((params, tiles));
        }
        per_level
    }

    /// The levels the GPU tile cache takes this frame and every tile's priority (level rank,
    /// then distance from the nadir).
    fn admit_levels(&self, per_level: &[LevelJobs], nadir: DVec3) -> Admission {
        let mut needed: HashMap<TileKey, Priority> = HashMap::new();
        // The levels the GPU tile cache takes this frame, coarse first: those whose tiles fit
        // beside the ones taken before. The others wait (their tiles are neither kept on the
        // GPU nor read), so a cache smaller than the whole view still fills it level by level
        // instead of filling with parts of every level; a level larger than the cache can
        // never be filled (`gpu_tiles_short`).
        let capacity = self.gpu.capacity();
        let mut taken: HashSet<TileKey> = HashSet::new();
        let mut admitted = Vec::with_capacity(per_level.len());
        let mut largest = 0;
        for (_, tiles) in per_level {
            largest = largest.max(tiles.len());
            let new = tiles.iter().filter(|k| !taken.contains(k)).count();
            let fits = taken.len() + new <= capacity;
            if fits {
                taken.extend(tiles.iter().copied());
            }
            admitted.push(fits);
        }
        for (rank, ((_, tiles), &fits)) in per_level.iter().zip(&admitted).enumerate() {
            if !fits {
                continue;
            }
            for &k in tiles {
                let p = ((rank as u64) << 40) | self.distance_rank(k, nadir);
                needed
                    .entry(k)
                    .and_modify(|q| *q = (*q).min(p))
                    .or_insert(p);
            }
        }
        let gpu_tiles_short = (largest > capacity).then_some(GpuTilesShort {
            asked: self.settings.gpu_tiles,
            capacity: capacity as u32,
            needed: largest as u32,
        });
        Admission {
            taken,
            admitted,
            needed,
            gpu_tiles_short,
        }
    }

    /// Fills the levels whose tiles are all resident (in order, within the fill's capacity);
    /// per level whether it was filled, and the texels written.
    #[allow(clippy::too_many_arguments)] // the frame's encoder and the plan's pieces, one for one
    fn encode_ready_fills(
        &mut self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        levels: &[LevelFill],
        per_level: &[LevelJobs],
        admitted: &[bool],
        detail: &DetailResources,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> (Vec<bool>, u64) {
        let mut filled = Vec::with_capacity(levels.len());
        let mut jobs = Vec::new();
        for (((params, tiles), &fits), job) in per_level.iter().zip(admitted).zip(levels) {
            let ready = fits
                && !job.defer
                && tiles.iter().all(|k| self.gpu.contains(k))
                && jobs.len() + params.len() <= self.fill.capacity() as usize;
            if ready {
                jobs.extend_from_slice(params);
            }
            filled.push(ready);
        }
        let (details, offsets): (Vec<_>, Vec<_>) = jobs
            .iter()
            .map(|j| detail.block(&j.grid, j.origin[0], j.origin[1]))
            .unzip();
        let params: Vec<DemFillParams> = jobs
            .iter()
            .zip(&offsets)
            .map(|(j, &offset)| DemFillParams::new(j, offset))
            .collect();
        let texels = self
            .fill
            .encode(queue, encoder, &params, detail, &details, timestamps);
        (filled, texels)
    }

    /// Takes the file watcher's reports and updates the read rate (every half second); the
    /// streamer's counters.
    fn watch_file_and_rate(&mut self) -> StreamStats {
        for state in self.streamer.poll_file() {
            if let Some(change) = &state {
                self.file_changes.push_back(change.clone());
                self.file_changes_total += 1;
                if self.file_changes.len() > 16 {
                    self.file_changes.pop_front();
                }
            }
            self.file_change = state;
        }
        let stream = self.streamer.stats();
        let dt = self.rate_sample.0.elapsed().as_secs_f64();
        if dt >= 0.5 {
            let bytes = stream.bytes_read - self.rate_sample.1;
            self.read_mb_per_s = bytes as f64 / (1 << 20) as f64 / dt;
            self.rate_sample = (Instant::now(), stream.bytes_read);
        }
        stream
    }

    fn note_error(&mut self, e: &str) {
        if self.errors.back().map(String::as_str) != Some(e) {
            self.errors.push_back(e.to_string());
            if self.errors.len() > 8 {
                self.errors.pop_front();
            }
        }
    }

    /// Blocks up to `timeout` for the next tile (headless rendering waiting for data).
    pub fn wait_for_tile(&mut self, timeout: Duration) {
        if let Some(done) = self.streamer.wait(timeout) {
            if let Completion::Loaded(tile) = done {
                let keep = &self.keep;
                self.tiles.cache.insert_keeping(tile, |k| keep.contains(k));
            } else if let Completion::Failed(_, e) = done {
                // The error names its tile.
                self.note_error(&e.to_string());
            }
        }
    }

    /// Tile distance from the nadir in 1/1000 degree (lower is sooner).
    fn distance_rank(&self, k: TileKey, nadir: DVec3) -> u64 {
        let g = self.tiles.dem().pyramid().grid(k.level as usize);
        let t = self.tiles.dem().pyramid().tile_size() as f64;
        let lat = g.lat_of_row((k.ty as f64 + 0.5) * t);
        let lon = g.lon_of_col((k.tx as f64 + 0.5) * t);
        let (phi, theta) = sphere::phi_theta_from_lat_lon_deg(lat.clamp(-90.0, 90.0), lon);
        let angle = nadir.angle_between(sphere::unit_vector(phi, theta));
        ((angle.to_degrees() * 1000.0) as u64).min((1 << 40) - 1)
    }

    /// The dispatches (one per piece of `rect` within a block of the level's anchor lattice,
    /// between the poles' fold lines and, for a regional grid, the 360° wrap) and the tiles
    /// they read.
    fn jobs_for_rect(
        &self,
        grid: &LevelGrid,
        rect: &GridRect,
        level: usize,
        out: &mut Vec<DemFillJob>,
        tiles: &mut Vec<TileKey>,
    ) {
        for (piece, anchor) in rect.anchored_pieces(grid.anchor_block()) {
            self.jobs_for_piece(grid, &piece, anchor, level, out, tiles);
        }
    }

    /// [`DemFeed::jobs_for_rect`] for a piece within one block: every parameter is computed
    /// at the block's corner `anchor`, so a texel's f32 arithmetic does not depend on which
    /// dispatch filled it (a settled view is the same whatever the path to it).
    fn jobs_for_piece(
        &self,
        grid: &LevelGrid,
        rect: &GridRect,
        anchor: [i64; 2],
        level: usize,
        out: &mut Vec<DemFillJob>,
        tiles: &mut Vec<TileKey>,
    ) {
        let [ax, ay] = anchor;
        use std::f64::consts::PI;
        let pyr = self.tiles.dem().pyramid();
        let g = pyr.grid(level);
        let west = pyr.extents().west_deg;
        let wraps = pyr.wraps();
        let t = pyr.tile_size() as i64;
        let (cols, rows) = (g.cols as i64, g.rows as i64);
        let s = grid.size as i64;
        let south_row = (PI / grid.dtheta_rad).round() as i64;
        let end = rect.gy0 + rect.height as i64;
        // Row pieces: beyond the north pole, between the poles, beyond the south pole.
        let pieces = [
            (rect.gy0, end.min(0), Fold::North),
            (rect.gy0.max(0), end.min(south_row + 1), Fold::None),
            (rect.gy0.max(south_row + 1), end, Fold::South),
        ];
        let [cap_n, cap_s] = self.tiles.dem().pole_caps(level);
        let cap = |c: Option<crate::terrain::dem::PoleCap>, rows_to_pole: fn(f64) -> f64| {
            c.map_or([0.0, 0.0], |c| {
                [rows_to_pole(c.row_lat_deg) / g.dlat_deg, c.height_m]
            })
        };
        let caps = (cap(cap_n, |lat| 90.0 - lat), cap(cap_s, |lat| lat + 90.0));
        let enc = pyr.encoding();
        let (page_base, tiles_x) = self.gpu.level_page(level);
        let dphi_deg = grid.dphi_rad.to_degrees();
        let dcol = dphi_deg / g.dlon_deg;
        for (ya, yb, fold) in pieces {
            if yb <= ya {
                continue;
            }
            // The piece's rows are linear in gy within its fold: continued to the anchor's row.
            let theta = ay as f64 * grid.dtheta_rad;
            let (theta, extra_phi, sign) = match fold {
                Fold::None => (theta, 0.0, 1.0),
                Fold::North => (-theta, PI, -1.0),
                Fold::South => (2.0 * PI - theta, PI, -1.0),
            };
            let lat = 90.0 - theta.to_degrees();
            let drow = sign * grid.dtheta_rad.to_degrees() / g.dlat_deg;
            let row_anchor = (g.lat0_deg - lat) / g.dlat_deg;
            let row = row_anchor + (ya - ay) as f64 * drow;
            let h = (yb - ya) as u32;
            // Column pieces: one for a wrapping grid (the shader wraps), split at the 360°
            // wrap for a regional one.
            let lon0 = (rect.gx0 as f64 * grid.dphi_rad + extra_phi).to_degrees();
            let d0 = (lon0 - west).rem_euclid(360.0);
            let col_pieces = column_pieces(rect.width, d0, dphi_deg, wraps);
            for (x_off, w, d) in col_pieces {
                let col = d / g.dlon_deg - 0.5;
                // The same column line continued back to the anchor's column.
                let offset_x = rect.gx0 + x_off as i64 - ax;
                let col_anchor = col - offset_x as f64 * dcol;
                let (col_floor, row_floor) = (col_anchor.floor(), row_anchor.floor());
                let mut base_col = col_floor as i64;
                if wraps {
                    base_col = base_col.rem_euclid(cols);
                }
                let frac = [col_anchor - col_floor, row_anchor - row_floor];
                // A block well inside one pixel of a global grid, away from its edge rows, on a
                // level seen from at most RELATIVE_FILL_REACH_M: the fill interpolates relative
                // to the anchor, whose height the CPU gives.
                let block = grid.anchor_block() as f64;
                let quarter_m =
                    0.5 * level_outer_theta_rad(grid.level) * self.tiles.dem().radius_m();
                let anchor_height_m = (wraps
                    && quarter_m <= RELATIVE_FILL_REACH_M
                    && matches!(fold, Fold::None)
                    && block * dcol.abs() <= 0.5
                    && block * drow.abs() <= 0.5
                    && row_floor >= 1.0
                    && row_floor + 3.0 <= rows as f64)
                    // At the anchor's f32 point, from which the shader adds frac_lo + k·step.
                    .then(|| {
                        let frac_f32 = frac.map(|f| f as f32 as f64);
                        self.tiles
                            .bilinear_m(level, [base_col, row_floor as i64], frac_f32)
                    })
                    .flatten();
                out.push(DemFillJob {
                    grid: *grid,
                    origin: anchor,
                    offset: [offset_x as u32, (ya - ay) as u32],
                    base: [base_col, row_floor as i64],
                    frac,
                    anchor_height_m,
                    step: [dcol, drow],
                    slot0: [
                        (rect.gx0 + x_off as i64).rem_euclid(s) as u32,
                        ya.rem_euclid(s) as u32,
                    ],
                    extent: [w, h],
                    layer: grid.level,
                    size: grid.size,
                    page_base,
                    tiles_x,
                    cols,
                    rows,
                    tile_size: t,
                    wraps,
                    cap_north: caps.0,
                    cap_south: caps.1,
                    decode_offset_m: enc.offset_m,
                    decode_quantum_m: enc.quantum_m,
                });

                // Tiles: every pixel the bilinear footprints of this piece touch.
                let r_last = row + (h as f64 - 1.0) * drow;
                let c_last = col + (w as f64 - 1.0) * dcol;
                let span = PixelSpan {
                    rows: [row.min(r_last), row.max(r_last)],
                    cols: [col, c_last],
                };
                span.push_tiles(level as u32, [cols, rows], t, wraps, tiles);
            }
        }
    }
}

#[derive(Clone, Copy)]
enum Fold {
    None,
    North,
    South,
}

/// The column pieces of a rectangle `width` columns wide whose first column lies `d0_deg` east
/// of the grid's west edge: one for a wrapping grid (the shader wraps), split at the 360° wrap
/// for a regional one. Each is (first column, columns, degrees east of the west edge).
fn column_pieces(width: u32, d0: f64, dphi_deg: f64, wraps: bool) -> Vec<(u32, u32, f64)> {
    let mut col_pieces = vec![(0u32, width, d0)];
    if !wraps {
        let last = d0 + (width as f64 - 1.0) * dphi_deg;
        if last >= 360.0 {
            let split = ((360.0 - d0) / dphi_deg).ceil().clamp(1.0, width as f64) as u32;
            let d1 = d0 + split as f64 * dphi_deg - 360.0;
            col_pieces = vec![(0, split, d0)];
            if split < width {
                col_pieces.push((split, width - split, d1));
            }
        }
    }
    col_pieces
}

/// The pyramid pixels (fractional rows and columns, lowest and highest) a fill piece's
/// bilinear footprints span.
struct PixelSpan {
    rows: [f64; 2],
    cols: [f64; 2],
}

impl PixelSpan {
    /// Pushes the tiles of `level` holding every pixel the span touches (and its bilinear
    /// neighbour) onto `tiles`; `size` is the level's (cols, rows), `t` its tile edge.
    fn push_tiles(
        &self,
        level: u32,
        size: [i64; 2],
        t: i64,
        wraps: bool,
        tiles: &mut Vec<TileKey>,
    ) {
        let [cols, rows] = size;
        let r_lo = (self.rows[0].floor() as i64).clamp(0, rows - 1);
        let r_hi = (self.rows[1].floor() as i64 + 1).clamp(0, rows - 1);
        let c_lo = self.cols[0].floor() as i64;
        let c_hi = self.cols[1].floor() as i64 + 1;
        let mut col_tiles = Vec::new();
        if wraps {
            if c_hi - c_lo + 1 >= cols {
                col_tiles.extend(0..(cols + t - 1) / t);
            } else {
                let mut c = c_lo;
                while c <= c_hi {
                    let m = c.rem_euclid(cols);
                    col_tiles.push(m / t);
                    c += (t - m % t).min(cols - m);
                }
            }
        } else {
            let (a, b) = (c_lo.clamp(0, cols - 1), c_hi.clamp(0, cols - 1));
            col_tiles.extend(a / t..=b / t);
        }
        for ty in r_lo / t..=r_hi / t {
            for &tx in &col_tiles {
                tiles.push(TileKey {
                    level,
                    tx: tx as u32,
                    ty: ty as u32,
                });
            }
        }
    }
}
