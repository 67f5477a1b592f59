//! The streaming writer: one pass over the source, every level built in a cascade, bounded
//! memory (see "Memory" in the module documentation of [`crate::dem::pyramid`]).

use std::fs::File;
use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use super::filter::{Downsampler, Level0, Row};
use super::format::{
    self, CODE_MAX, CODE_MIN, Encoding, Extents, Header, LevelGeom, MAX_DESCRIPTION, MAX_TILE_SIZE,
    MIN_TILE_SIZE, TileEntry,
};
use crate::dem::DemError;
use crate::dem::raster::{GeoGrid, RasterSource};

/// The default tile edge, in samples: 256 × 256 × 3 planes × 2 bytes = 384 KiB per tile.
pub const DEFAULT_TILE_SIZE: usize = 256;

/// What the builder does with a source pixel that has no data (`NaN`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum NanPolicy {
    /// Sea level, 0 m (GTOPO30's oceans), counted in the report and the header. Never −9999.
    #[default]
    SeaLevel,
    /// Fail with an error naming the first such pixel.
    Reject,
}

/// Progress of a build, passed to the callback (at most every 100 ms, and once at the end).
#[derive(Clone, Copy, Debug)]
pub struct BuildProgress {
    /// 0 … 1: source rows read (every level is built as the rows stream past).
    pub fraction: f64,
    pub rows_done: usize,
    pub rows_total: usize,
    pub rows_per_s: f64,
    pub elapsed: Duration,
}

/// What a finished build did.
#[derive(Clone, Debug)]
pub struct BuildReport {
    pub path: PathBuf,
    pub levels: usize,
    pub tiles: usize,
    pub file_bytes: u64,
    /// Source pixels without data that the [`NanPolicy`] replaced.
    pub nan_count: u64,
    /// Bounds of all heights stored (level 0's min and max planes), metres.
    pub min_m: f64,
    pub max_m: f64,
    pub elapsed: Duration,
    pub rows_per_s: f64,
    /// Bytes of buffers the builder held at its peak (the memory bound, computed).
    pub buffer_bytes: usize,
    /// Longitude passes (one per fine row and coarse row it overlaps, all levels) whose window
    /// was wider than the coarse footprint (isotropic widening, 1/cos φ), and those widened to
    /// the whole row (the rows nearest the poles).
    pub widened_passes: usize,
    pub full_circle_passes: usize,
}

type ProgressFn<'p> = Box<dyn FnMut(&BuildProgress) + 'p>;

/// Builds a pyramid file from any [`RasterSource`], reading it once, row by row.
///
/// ```no_run
/// # use globe::dem::pyramid::PyramidBuilder;
/// # fn f(src: &dyn globe::dem::RasterSource) -> Result<(), globe::dem::DemError> {
/// let report = PyramidBuilder::new()
///     .tile_size(256)
///     .on_progress(|p| eprint!("\r{:5.1}% {:.0} rows/s", 100.0 * p.fraction, p.rows_per_s))
///     .build(src, "earth.gpyr")?;
/// println!("{} levels, {} NaN replaced", report.levels, report.nan_count);
/// # Ok(()) }
/// ```
pub struct PyramidBuilder<'p> {
    tile_size: usize,
    encoding: Encoding,
    nan_policy: NanPolicy,
    progress: Option<ProgressFn<'p>>,
}

impl Default for PyramidBuilder<'_> {
    fn default() -> Self {
        Self::new()
    }
}

impl<'p> PyramidBuilder<'p> {
    /// Tiles of [`DEFAULT_TILE_SIZE`], whole metres, NaN → sea level.
    pub fn new() -> Self {
        Self {
            tile_size: DEFAULT_TILE_SIZE,
            encoding: Encoding::default(),
            nan_policy: NanPolicy::default(),
            progress: None,
        }
    }

    /// Tile edge in samples ([`MIN_TILE_SIZE`] … [`MAX_TILE_SIZE`]; checked by `build`).
    pub fn tile_size(mut self, samples: usize) -> Self {
        self.tile_size = samples;
        self
    }

    /// Height encoding: `metres = offset_m + quantum_m · i16`. The default (1 m, 0) holds
    /// −32 767 … 32 767 m; a finer quantum suits a regional DEM of small relief.
    pub fn encoding(mut self, quantum_m: f64, offset_m: f64) -> Self {
        self.encoding = Encoding {
            quantum_m,
            offset_m,
        };
        self
    }

    pub fn nan_policy(mut self, policy: NanPolicy) -> Self {
        self.nan_policy = policy;
        self
    }

    /// Called with the progress at most every 100 ms and once at the end (fraction 1).
    pub fn on_progress(mut self, f: impl FnMut(&BuildProgress) + 'p) -> Self {
        self.progress = Some(Box::new(f));
        self
    }

    /// Builds the pyramid of `source` into `out`. The file is written as `out.partial` and
    /// renamed when complete, so `out` is never a half-written file (nor a file a viewer has
    /// mapped, truncated in place: see "SIGBUS" in the module documentation).
    pub fn build(
        mut self,
        source: &dyn RasterSource,
        out: impl AsRef<Path>,
    ) -> Result<BuildReport, DemError> {
        let out = out.as_ref().to_path_buf();
        let mut name = out.file_name().unwrap_or_default().to_os_string();
        name.push(".partial");
        let partial = out.with_file_name(name);
        let result = self.build_into(source, &out, &partial);
        if result.is_err() {
            let _ = std::fs::remove_file(&partial);
        }
        result
    }

    fn build_into(
        &mut self,
        source: &dyn RasterSource,
        out: &Path,
        partial: &Path,
    ) -> Result<BuildReport, DemError> {
        let start = Instant::now();
        let grid = source.grid();
        let src_name = PathBuf::from(source.describe());
        self.check_request(&grid, &src_name)?;
        let t = self.tile_size;
        let enc = self.encoding;
        let wraps = grid.wraps_in_longitude();
        let extents = format::extents_of(&grid);
        let levels = format::level_geoms(&grid, t);
        let description = header_description(source);
        let lay = format::layout(&levels, t, description.len());
        let mut sink = Sink::create(partial, &lay)?;
        let mut stages = cascade(&levels, t, extents, wraps);
        let buffer_bytes = buffer_bytes(&stages, &lay, grid.cols);

        let nan_count =
            self.stream_source(source, &grid, &src_name, &mut stages, &mut sink, start)?;
        if let Some(bad) = sink.written.iter().position(|w| !w) {
            let (level, tx, ty) = format::tile_position(&levels, &lay.first_tile, bad);
            return Err(DemError::Other(format!(
                "internal error: level {level} tile ({tx}, {ty}) was never written"
            )));
        }
        let (widened_passes, full_circle_passes) = stages
            .iter()
            .filter_map(|s| s.down.as_ref())
            .fold((0, 0), |(a, b), d| {
                (a + d.widened_passes, b + d.full_circle_passes)
            });

        let header = Header {
            tile_size: t,
            wraps,
            encoding: enc,
            extents,
            tile_data_offset: lay.tile_data_offset,
            file_len: lay.file_len,
            nan_count,
            min_m: enc.decode(sink.min_code as i16),
            max_m: enc.decode(sink.max_code as i16),
            description,
            levels: levels.clone(),
            index: std::mem::take(&mut sink.index),
        };
        let bytes = header.encode();
        debug_assert_eq!(bytes.len(), lay.header_len);
        sink.finish(&bytes)?;
        std::fs::rename(partial, out).map_err(|source| DemError::Io {
            path: out.to_path_buf(),
            source,
        })?;
        let elapsed = start.elapsed();
        let last = progress(grid.rows, grid.rows, elapsed);
        if let Some(cb) = self.progress.as_mut() {
            cb(&last);
        }
        Ok(BuildReport {
            path: out.to_path_buf(),
            levels: levels.len(),
            tiles: lay.tile_count,
            file_bytes: lay.file_len,
            nan_count,
            min_m: header.min_m,
            max_m: header.max_m,
            elapsed,
            rows_per_s: last.rows_per_s,
            buffer_bytes,
            widened_passes,
            full_circle_passes,
        })
    }

    /// Refuses, before any file is created, a source grid the format cannot hold, a tile size
    /// out of range and a height encoding that is not finite and positive (in that order).
    fn check_request(&self, grid: &GeoGrid, src_name: &Path) -> Result<(), DemError> {
        format::check_source_grid(grid).map_err(|message| DemError::Header {
            path: src_name.to_path_buf(),
            field: "grid".into(),
            message,
        })?;
        let t = self.tile_size;
        if !(MIN_TILE_SIZE..=MAX_TILE_SIZE).contains(&t) {
            return Err(DemError::Other(format!(
                "tile size {t}: expected {MIN_TILE_SIZE} … {MAX_TILE_SIZE}"
            )));
        }
        let enc = self.encoding;
        if !(enc.quantum_m.is_finite() && enc.quantum_m > 0.0 && enc.offset_m.is_finite()) {
            return Err(DemError::Other(format!(
                "height encoding quantum {} m, offset {} m: expected a finite quantum > 0",
                enc.quantum_m, enc.offset_m
            )));
        }
        Ok(())
    }

    /// The one pass over the source: every row read, checked ([`Self::check_row`]), and fed
    /// through level 0's filter into the cascade of levels, with progress reports on the way.
    /// Returns how many NaN pixels were replaced.
    fn stream_source(
        &mut self,
        source: &dyn RasterSource,
        grid: &GeoGrid,
        src_name: &Path,
        stages: &mut [Stage],
        sink: &mut Sink,
        start: Instant,
    ) -> Result<u64, DemError> {
        let enc = self.encoding;
        let mut level0 = Level0::new(grid.wraps_in_longitude());
        let mut nan_count = 0u64;
        let range_m = enc.range_m();
        let mut last_report = Instant::now();
        let mut emitted = 0usize;
        for r in 0..grid.rows {
            let mut values = vec![0.0f32; grid.cols];
            source.read_row(r, &mut values)?;
            nan_count += self.check_row(&mut values, r, grid, src_name, range_m)?;
            if let Some(row) = level0.push(values) {
                feed(stages, emitted, row, sink, &enc)?;
                emitted += 1;
            }
            if let Some(cb) = self.progress.as_mut() {
                let now = Instant::now();
                if now.duration_since(last_report) >= Duration::from_millis(100)
                    && r + 1 < grid.rows
                {
                    last_report = now;
                    cb(&progress(r + 1, grid.rows, start.elapsed()));
                }
            }
        }
        if let Some(row) = level0.finish() {
            feed(stages, emitted, row, sink, &enc)?;
        }
        Ok(nan_count)
    }

    /// Source row `r`, checked in column order: NaN becomes 0 m (counted, and returned) or is an
    /// error under [`NanPolicy::Reject`]; a height outside `range_m`, the encoding's, is an
    /// error naming the pixel.
    fn check_row(
        &self,
        values: &mut [f32],
        r: usize,
        grid: &GeoGrid,
        src_name: &Path,
        (lo_m, hi_m): (f64, f64),
    ) -> Result<u64, DemError> {
        let mut nan_count = 0u64;
        for (c, v) in values.iter_mut().enumerate() {
            if v.is_nan() {
                if self.nan_policy == NanPolicy::Reject {
                    return Err(DemError::Data {
                        path: src_name.to_path_buf(),
                        message: format!(
                            "row {r}, column {c} (lat {:.6}°, lon {:.6}°): no data (NaN), and the NaN policy is Reject",
                            grid.lat_of_row(r as f64),
                            grid.lon_of_col(c as f64)
                        ),
                    });
                }
                nan_count += 1;
                *v = 0.0;
            } else if !(v.is_finite() && (*v as f64) >= lo_m && (*v as f64) <= hi_m) {
                return Err(DemError::Data {
                    path: src_name.to_path_buf(),
                    message: format!(
                        "row {r}, column {c} (lat {:.6}°, lon {:.6}°): height {v} m is outside what the encoding holds ({lo_m} … {hi_m} m at {} m per step; choose a coarser quantum)",
                        grid.lat_of_row(r as f64),
                        grid.lon_of_col(c as f64),
                        self.encoding.quantum_m
                    ),
                });
            }
        }
        Ok(nan_count)
    }
}

/// The source's description as the header stores it: cut to [`MAX_DESCRIPTION`] bytes, at a
/// character boundary.
fn header_description(source: &dyn RasterSource) -> String {
    let mut description = source.describe();
    if description.len() > MAX_DESCRIPTION {
        let mut cut = MAX_DESCRIPTION;
        while !description.is_char_boundary(cut) {
            cut -= 1;
        }
        description.truncate(cut);
    }
    description
}

fn progress(done: usize, total: usize, elapsed: Duration) -> BuildProgress {
    let secs = elapsed.as_secs_f64();
    BuildProgress {
        fraction: done as f64 / total.max(1) as f64,
        rows_done: done,
        rows_total: total,
        rows_per_s: if secs > 0.0 { done as f64 / secs } else { 0.0 },
        elapsed,
    }
}

struct Stage {
    writer: LevelWriter,
    /// To the next coarser level (none for the last level).
    down: Option<Downsampler>,
}

/// One stage per level, each writing its level and (but the last) downsampling to the next.
fn cascade(levels: &[LevelGeom], t: usize, extents: Extents, wraps: bool) -> Vec<Stage> {
    levels
        .iter()
        .enumerate()
        .map(|(i, g)| Stage {
            writer: LevelWriter::new(i, *g, t),
            down: levels
                .get(i + 1)
                .map(|c| Downsampler::new(*g, *c, extents, wraps)),
        })
        .collect()
}

/// The bytes the builder holds at its peak: every stage's buffers, one tile, the tile index
/// and level 0's rows of `cols` values (the reported memory bound).
fn buffer_bytes(stages: &[Stage], lay: &format::Layout, cols: usize) -> usize {
    stages
        .iter()
        .map(|s| s.writer.buffer_bytes() + s.down.as_ref().map_or(0, |d| d.buffer_bytes()))
        .sum::<usize>()
        + lay.tile_bytes as usize
        + 16 * lay.tile_count
        + 9 * 4 * cols
}

/// Row `r` of a level: store it, and pass it down to the next level.
fn feed(
    stages: &mut [Stage],
    r: usize,
    row: Row,
    sink: &mut Sink,
    enc: &Encoding,
) -> Result<(), DemError> {
    let Some((stage, rest)) = stages.split_first_mut() else {
        return Ok(());
    };
    stage.writer.push(r, &row, enc, sink)?;
    if let Some(down) = stage.down.as_mut() {
        let mut coarse = Vec::new();
        down.push(r, &row, &mut coarse);
        drop(row);
        for (cr, crow) in coarse {
            feed(rest, cr, crow, sink, enc)?;
        }
    }
    Ok(())
}

/// The output file: tiles go to their precomputed offsets as their bands complete.
struct Sink {
    file: File,
    path: PathBuf,
    index: Vec<TileEntry>,
    written: Vec<bool>,
    first_tile: Vec<usize>,
    tile_buf: Vec<u8>,
    /// Lowest min code and highest max code of level 0.
    min_code: i32,
    max_code: i32,
}

impl Sink {
    /// Creates `path` at the file's full length, with every tile's index entry placed (CRCs
    /// filled in as tiles are written).
    fn create(path: &Path, lay: &format::Layout) -> Result<Sink, DemError> {
        let io = |source| DemError::Io {
            path: path.to_path_buf(),
            source,
        };
        let index: Vec<TileEntry> = (0..lay.tile_count)
            .map(|i| TileEntry {
                offset: lay.tile_data_offset + i as u64 * lay.tile_bytes,
                len: lay.tile_bytes as u32,
                crc32: 0,
            })
            .collect();
        let file = File::create(path).map_err(io)?;
        file.set_len(lay.file_len).map_err(io)?;
        Ok(Sink {
            file,
            path: path.to_path_buf(),
            written: vec![false; lay.tile_count],
            index,
            first_tile: lay.first_tile.clone(),
            tile_buf: vec![0; lay.tile_bytes as usize],
            min_code: i32::MAX,
            max_code: i32::MIN,
        })
    }

    /// Writes the encoded header at the start of the file, once every tile is in, and syncs
    /// the file to disk before the caller renames it into place.
    fn finish(mut self, header: &[u8]) -> Result<(), DemError> {
        let io = |source| DemError::Io {
            path: self.path.clone(),
            source,
        };
        self.file.seek(SeekFrom::Start(0)).map_err(io)?;
        self.file.write_all(header).map_err(io)?;
        self.file.sync_all().map_err(io)
    }
}

/// One band (tile height) of quantised rows of a level, flushed as a row of tiles.
struct LevelWriter {
    level: usize,
    geom: LevelGeom,
    t: usize,
    planes: [Vec<i16>; 3],
    band_first_row: usize,
    rows_in_band: usize,
}

impl LevelWriter {
    fn new(level: usize, geom: LevelGeom, t: usize) -> Self {
        let band = t.min(geom.rows) * geom.cols;
        Self {
            level,
            geom,
            t,
            planes: [vec![0; band], vec![0; band], vec![0; band]],
            band_first_row: 0,
            rows_in_band: 0,
        }
    }

    fn buffer_bytes(&self) -> usize {
        3 * 2 * self.planes[0].len()
    }

    fn push(
        &mut self,
        r: usize,
        row: &Row,
        enc: &Encoding,
        sink: &mut Sink,
    ) -> Result<(), DemError> {
        debug_assert_eq!(r, self.band_first_row + self.rows_in_band, "rows in order");
        let cols = self.geom.cols;
        let at = self.rows_in_band * cols;
        let clamp = |c: i32| c.clamp(CODE_MIN, CODE_MAX) as i16;
        let [avg, min, max] = &mut self.planes;
        let (mut lowest, mut highest) = (i32::MAX, i32::MIN);
        let out = avg[at..at + cols]
            .iter_mut()
            .zip(&mut min[at..at + cols])
            .zip(&mut max[at..at + cols]);
        let values = row.avg.iter().zip(&row.min).zip(&row.max);
        for (((a, lo_out), hi_out), ((&va, &vlo), &vhi)) in out.zip(values) {
            let lo = enc.floor(vlo as f64);
            let hi = enc.ceil(vhi as f64);
            let mid = enc.nearest(va as f64).clamp(lo, hi);
            *a = clamp(mid);
            *lo_out = clamp(lo);
            *hi_out = clamp(hi);
            lowest = lowest.min(lo);
            highest = highest.max(hi);
        }
        if self.level == 0 {
            sink.min_code = sink.min_code.min(lowest);
            sink.max_code = sink.max_code.max(highest);
        }
        self.rows_in_band += 1;
        if self.rows_in_band == self.t || r + 1 == self.geom.rows {
            self.flush(sink)?;
            self.band_first_row += self.rows_in_band;
            self.rows_in_band = 0;
        }
        Ok(())
    }

    /// Writes the band as one row of tiles, padding the edge tiles by repeating the last
    /// column / row.
    fn flush(&mut self, sink: &mut Sink) -> Result<(), DemError> {
        let t = self.t;
        let cols = self.geom.cols;
        let ty = self.band_first_row / t;
        let plane_bytes = 2 * t * t;
        for tx in 0..self.geom.tiles_x {
            let x0 = tx * t;
            for (p, plane) in self.planes.iter().enumerate() {
                let out = &mut sink.tile_buf[p * plane_bytes..(p + 1) * plane_bytes];
                let valid = (cols - x0).min(t);
                for y in 0..t {
                    let sy = y.min(self.rows_in_band - 1);
                    let src = &plane[sy * cols + x0..sy * cols + x0 + valid];
                    let dst = &mut out[y * 2 * t..(y + 1) * 2 * t];
                    let (body, pad) = dst.split_at_mut(2 * valid);
                    for (d, v) in body.chunks_exact_mut(2).zip(src) {
                        d.copy_from_slice(&v.to_le_bytes());
                    }
                    let last = src[valid - 1].to_le_bytes();
                    for d in pad.chunks_exact_mut(2) {
                        d.copy_from_slice(&last);
                    }
                }
            }
            let i = sink.first_tile[self.level] + ty * self.geom.tiles_x + tx;
            let entry = &mut sink.index[i];
            entry.crc32 = crc32fast::hash(&sink.tile_buf);
            let io = |source| DemError::Io {
                path: sink.path.clone(),
                source,
            };
            sink.file.seek(SeekFrom::Start(entry.offset)).map_err(io)?;
            sink.file.write_all(&sink.tile_buf).map_err(io)?;
            sink.written[i] = true;
        }
        Ok(())
    }
}
