//! The reader: a validated memory map of a pyramid file.

use std::borrow::Cow;
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

use super::format::{Encoding, Extents, Header, LevelGeom, TileEntry};
use crate::dem::change::classify;
use crate::dem::mapped::{MappedFile, OpenFile};
use crate::dem::raster::GeoGrid;
use crate::dem::remote::{RemoteOptions, RemoteStore};
use crate::dem::{DemError, FileChange};

/// Reads the stored code of (level, plane, row, col); `None` when the tile holding it is not
/// at hand (a cache of streamed tiles). The map itself always has it.
pub type CodeFn<'a> = &'a dyn Fn(usize, Plane, usize, usize) -> Option<i16>;

/// A code needed for an answer lies in a tile that is not resident.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NotResident;

/// Which plane of a tile.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Plane {
    Avg = 0,
    Min = 1,
    Max = 2,
}

/// A region on the sphere for [`Pyramid::min_max_in`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Region {
    /// A latitude/longitude box, degrees. The box runs east from `west_deg` to `east_deg`
    /// (so `west_deg > east_deg` crosses the antimeridian); a span of 360° or more is every
    /// longitude.
    Box {
        south_deg: f64,
        north_deg: f64,
        west_deg: f64,
        east_deg: f64,
    },
    /// A spherical cap: all points within `radius_rad` (great-circle angle) of the centre.
    /// Bounded through its exact latitude/longitude bounding box.
    Cap {
        lat_deg: f64,
        lon_deg: f64,
        radius_rad: f64,
    },
}

/// Height bounds over a region at one level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeightBounds {
    pub min_m: f64,
    pub max_m: f64,
    /// False when part of the region lies outside the data's extents (where the pyramid has
    /// no data: the bounds then hold for the covered part only).
    pub complete: bool,
    /// Pixels inspected.
    pub pixels: usize,
}

/// One tile: three planes of `tile_size²` codes, rows north to south. Codes beyond
/// `valid_cols` / `valid_rows` repeat the level's last column / row.
#[derive(Clone, Debug)]
pub struct TileView<'a> {
    pub level: usize,
    pub tx: usize,
    pub ty: usize,
    pub tile_size: usize,
    /// Columns and rows of this tile inside the level's grid (edge tiles have fewer).
    pub valid_cols: usize,
    pub valid_rows: usize,
    /// Level pixel of the tile's sample (0, 0).
    pub first_col: usize,
    pub first_row: usize,
    pub encoding: Encoding,
    /// Zero-copy on little-endian machines (the file is little-endian and 2-aligned).
    pub avg: Cow<'a, [i16]>,
    pub min: Cow<'a, [i16]>,
    pub max: Cow<'a, [i16]>,
}

impl TileView<'_> {
    /// Height in metres of plane `p` at tile sample (x, y).
    pub fn get_m(&self, p: Plane, x: usize, y: usize) -> f64 {
        let plane = match p {
            Plane::Avg => &self.avg,
            Plane::Min => &self.min,
            Plane::Max => &self.max,
        };
        self.encoding.decode(plane[y * self.tile_size + x])
    }
}

/// Summary for `globe-data info`.
#[derive(Clone, Debug)]
pub struct PyramidInfo {
    pub path: PathBuf,
    pub version: u32,
    pub file_bytes: u64,
    pub tile_size: usize,
    pub tile_bytes: u64,
    pub tiles: usize,
    pub wraps: bool,
    pub extents: Extents,
    pub encoding: Encoding,
    pub nan_count: u64,
    pub min_m: f64,
    pub max_m: f64,
    pub description: String,
    pub levels: Vec<LevelGeom>,
}

impl fmt::Display for PyramidInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let e = &self.extents;
        writeln!(f, "{}", self.path.display())?;
        writeln!(f, "  source      {}", self.description)?;
        writeln!(
            f,
            "  format      version {}, {} bytes, {} tiles of {}² samples ({} bytes each)",
            self.version, self.file_bytes, self.tiles, self.tile_size, self.tile_bytes
        )?;
        writeln!(
            f,
            "  extents     lat {} … {}°, lon {} … {}°{}",
            e.south_deg,
            e.north_deg,
            e.west_deg,
            e.east_deg,
            if self.wraps { " (whole circle)" } else { "" }
        )?;
        writeln!(
            f,
            "  heights     {} … {} m, stored as i16 × {} m + {} m; {} no-data pixels set to sea level",
            self.min_m, self.max_m, self.encoding.quantum_m, self.encoding.offset_m, self.nan_count
        )?;
        writeln!(
            f,
            "  level  pixels          tiles     spacing (°)  spacing at equator (m)"
        )?;
        for (i, l) in self.levels.iter().enumerate() {
            let metres = l.grid.dlat_deg.to_radians() * crate::geo::EARTH_RADIUS_M;
            writeln!(
                f,
                "  {i:>5}  {:>7} × {:<6} {:>4} × {:<4} {:<12.6} {:.0}",
                l.cols, l.rows, l.tiles_x, l.tiles_y, l.grid.dlat_deg, metres
            )?;
        }
        Ok(())
    }
}

/// Result of [`Pyramid::verify`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VerifyReport {
    pub tiles: usize,
    pub bytes: u64,
}

/// A pyramid file, memory-mapped and validated (magic, version, header CRC, level table,
/// tile index and file length) by [`Pyramid::open`]. `Send + Sync`: share it in an `Arc`.
pub struct Pyramid {
    path: PathBuf,
    /// Kept open to re-check the length ([`Pyramid::check_length`]).
    map: MappedFile,
    header: Header,
    first_tile: Vec<usize>,
    /// Per level and row, the lowest min and highest max code of the whole row, read on first
    /// use by [`Pyramid::min_max_in`]: a cap reaching a pole spans every column, and reading
    /// them all (4320 per row at 5′) on every query made the reference ray caster crawl there.
    row_extremes: Vec<Vec<OnceLock<(i16, i16)>>>,
    /// A pyramid on a server: `map` then holds the header only, tiles come from here.
    remote: Option<RemoteTiles>,
}

/// The tiles of a remote pyramid that the synchronous readers hold: the coarse levels fetched
/// at open and any tile a query touched (fetched once, blocking, and kept).
struct RemoteTiles {
    store: Arc<RemoteStore>,
    resident: Vec<OnceLock<Box<[u8]>>>,
    /// A failed blocking read is reported on stderr once per tile.
    reported: Vec<AtomicBool>,
}

impl fmt::Debug for Pyramid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Pyramid")
            .field("path", &self.path)
            .field("levels", &self.header.levels.len())
            .field("tiles", &self.header.index.len())
            .finish()
    }
}

impl Pyramid {
    /// Opens and validates a pyramid file. Every failure (not a pyramid, another version,
    /// corrupt header, inconsistent level table, truncated or overlong file) is an error that
    /// names the file and what is wrong; nothing here can index past the end of the map.
    /// Tile payloads are checked by [`Pyramid::verify`] (all) or
    /// [`Pyramid::tile_verified`] (one).
    pub fn open(path: impl AsRef<Path>) -> Result<Pyramid, DemError> {
        let path = path.as_ref().to_path_buf();
        let file = OpenFile::open(&path)?;
        if file.len() == 0 {
            return Err(Self::empty(path));
        }
        // Every access below is bounds-checked against the length validated here; see
        // `crate::dem::mapped` for what remains (SIGBUS on a truncation in place).
        Self::validated(path, file.map()?)
    }

    /// A pyramid file's bytes already in memory, validated exactly as [`Pyramid::open`]
    /// validates a file (`name` names them in errors). For tests and the fuzz harness, which
    /// hand the reader bytes without a file.
    pub fn from_bytes(bytes: Vec<u8>, name: impl AsRef<Path>) -> Result<Pyramid, DemError> {
        let path = name.as_ref().to_path_buf();
        if bytes.is_empty() {
            return Err(Self::empty(path));
        }
        let map = MappedFile::from_bytes(&path, bytes);
        Self::validated(path, map)
    }

    /// Opens a pyramid on an HTTP server or an S3 store (`http://`, `https://`,
    /// `s3://bucket/key`; see `crate::dem::remote`): the header, level table and tile index
    /// are fetched and validated exactly as [`Pyramid::open`] validates a file's (header CRC
    /// included, the object's size standing for the file's length), then the coarsest levels
    /// that fit in `options.prefetch_bytes` are fetched in one request, CRC-checked and kept.
    pub fn open_remote(url: &str, options: RemoteOptions) -> Result<Pyramid, DemError> {
        let store = Arc::new(RemoteStore::connect(url, options)?);
        let path = PathBuf::from(url);
        let size = store.size();
        if size == 0 {
            return Err(Self::empty(path));
        }
        // The fixed header says how long the whole header (with the tile index) is.
        let first = store.fetch_blocking(0..size.min(64 << 10))?;
        let header_len = if first.len() >= 16 {
            u32::from_le_bytes([first[12], first[13], first[14], first[15]]) as u64
        } else {
            0
        };
        let head = if header_len > first.len() as u64 && header_len <= size {
            store.fetch_blocking(0..header_len)?
        } else {
            first
        };
        // Validated exactly as a file's, the object's size standing for the file's length.
        let map = MappedFile::from_bytes(&path, head);
        let mut p = Self::validated_len(path, map, size)?;
        // The header is valid, so `header_len` is: its last 4 bytes are the header's CRC, which
        // keys the disk cache (a changed file gets a fresh one).
        let at = header_len as usize - 4;
        let m = &p.map;
        store.open_disk_cache(u32::from_le_bytes([m[at], m[at + 1], m[at + 2], m[at + 3]]));
        let n = p.header.index.len();
        p.remote = Some(RemoteTiles {
            store,
            resident: (0..n).map(|_| OnceLock::new()).collect(),
            reported: (0..n).map(|_| AtomicBool::new(false)).collect(),
        });
        p.prefetch_coarse()?;
        Ok(p)
    }

    /// The coarsest levels whose tiles fit in the prefetch budget (the tiles lie in index
    /// order, so those levels are the file's last bytes: one request), and the polar tile rows
    /// of a global pyramid, fetched together and kept.
    fn prefetch_coarse(&self) -> Result<(), DemError> {
        let Some(r) = &self.remote else {
            return Ok(());
        };
        let budget = r.store.options().prefetch_bytes;
        let mut first_index = self.header.index.len();
        let mut bytes = 0u64;
        for level in (0..self.header.levels.len()).rev() {
            let start = self.first_tile[level];
            let level_bytes: u64 = self.header.index[start..first_index]
                .iter()
                .map(|e| e.len as u64)
                .sum();
            if bytes + level_bytes > budget {
                break;
            }
            bytes += level_bytes;
            first_index = start;
        }
        let mut wanted: Vec<usize> = (first_index..self.header.index.len()).collect();
        // The rows at the poles of every level: `DemTerrain` reads them at open (the poles'
        // heights), so they go out together here rather than one blocking request each.
        if self.header.wraps {
            for (level, l) in self.header.levels.iter().enumerate() {
                let first = self.first_tile[level];
                let last_row = first + (l.tiles_y - 1) * l.tiles_x;
                wanted.extend(first..first + l.tiles_x);
                wanted.extend(last_row..last_row + l.tiles_x);
            }
        }
        wanted.sort_unstable();
        wanted.dedup();
        wanted.retain(|&i| r.resident[i].get().is_none());
        // What the disk cache holds (and checks) needs no request.
        wanted.retain(|&index| {
            let (level, tx, ty) = self.tile_of_index(index);
            let e = self.header.index[index];
            match r
                .store
                .disk_get(index, e.crc32, &|b| self.check_payload(level, tx, ty, b))
            {
                Some(b) => {
                    let _ = r.resident[index].set(b.into());
                    false
                }
                None => true,
            }
        });
        let ranges: Vec<_> = wanted
            .iter()
            .map(|&i| {
                let e = self.header.index[i];
                e.offset..e.offset + e.len as u64
            })
            .collect();
        let got = r.store.fetch_many_blocking(&ranges)?;
        for (&index, payload) in wanted.iter().zip(got) {
            let (level, tx, ty) = self.tile_of_index(index);
            self.check_payload(level, tx, ty, &payload)?;
            r.store.disk_put(index, &payload);
            let _ = r.resident[index].set(payload.into());
        }
        Ok(())
    }

    /// (level, tx, ty) of a tile-index position.
    fn tile_of_index(&self, index: usize) -> (usize, usize, usize) {
        let level = self.first_tile.partition_point(|&f| f <= index) - 1;
        let i = index - self.first_tile[level];
        let tiles_x = self.header.levels[level].tiles_x;
        (level, i % tiles_x, i / tiles_x)
    }

    /// The store of a remote pyramid; None for a file.
    pub fn remote(&self) -> Option<&Arc<RemoteStore>> {
        self.remote.as_ref().map(|r| &r.store)
    }

    /// A remote pyramid's tile payload for the streamer: from memory when resident, else
    /// through the store (disk cache or a batched range request), CRC and codes checked.
    /// Not kept here (the streamer's cache holds it).
    pub fn remote_tile_payload(
        &self,
        level: usize,
        tx: usize,
        ty: usize,
    ) -> Result<Vec<u8>, DemError> {
        let index = self.index_of(level, tx, ty)?;
        let r = self.remote.as_ref().ok_or_else(|| {
            DemError::Other(format!("{}: not a remote pyramid", self.path.display()))
        })?;
        if let Some(b) = r.resident[index].get() {
            r.store.count_resident_hit();
            return Ok(b.to_vec());
        }
        let e = self.header.index[index];
        r.store.tile_payload(
            index,
            e.offset..e.offset + e.len as u64,
            e.crc32,
            true,
            &|b| self.check_payload(level, tx, ty, b),
        )
    }

    /// A remote tile for the synchronous readers: resident, or fetched now (blocking, with
    /// retries) and kept. None when every attempt failed (reported once on stderr).
    fn remote_resident<'a>(&'a self, r: &'a RemoteTiles, index: usize) -> Option<&'a [u8]> {
        if let Some(b) = r.resident[index].get() {
            return Some(b);
        }
        let (level, tx, ty) = self.tile_of_index(index);
        let e = self.header.index[index];
        let attempts = r.store.options().sync_attempts.max(1);
        let mut backoff = std::time::Duration::from_millis(20);
        let mut last = None;
        for attempt in 0..attempts {
            if attempt > 0 {
                std::thread::sleep(backoff);
                backoff *= 2;
            }
            match r.store.tile_payload(
                index,
                e.offset..e.offset + e.len as u64,
                e.crc32,
                false,
                &|b| self.check_payload(level, tx, ty, b),
            ) {
                Ok(b) => {
                    let _ = r.resident[index].set(b.into());
                    return r.resident[index].get().map(|b| &b[..]);
                }
                Err(err) => last = Some(err),
            }
        }
        if !r.reported[index].swap(true, Ordering::Relaxed)
            && let Some(err) = last
        {
            eprintln!("globe: {err} (after {attempts} attempts; the query reads no data there)");
        }
        None
    }

    /// Checks a tile payload against its index entry's CRC and the format's rules.
    fn check_payload(
        &self,
        level: usize,
        tx: usize,
        ty: usize,
        bytes: &[u8],
    ) -> Result<(), DemError> {
        let e = self.tile_entry(level, tx, ty)?;
        if bytes.len() != e.len as usize {
            return Err(DemError::Truncated {
                path: self.path.clone(),
                actual: bytes.len() as u64,
                expected: e.len as u64,
                what: format!("part of level {level} tile ({tx}, {ty})"),
            });
        }
        let crc = crc32fast::hash(bytes);
        if crc != e.crc32 {
            return Err(self.checksum_error(level, tx, ty, e.crc32, crc));
        }
        self.check_codes(level, tx, ty, bytes)?;
        Ok(())
    }

    /// A view of a tile payload read elsewhere (a remote tile), checked as
    /// [`Pyramid::tile_verified`] checks the map's.
    pub fn tile_of_payload<'a>(
        &self,
        level: usize,
        tx: usize,
        ty: usize,
        bytes: &'a [u8],
    ) -> Result<TileView<'a>, DemError> {
        self.check_payload(level, tx, ty, bytes)?;
        Ok(self.view(level, tx, ty, bytes))
    }

    fn empty(path: PathBuf) -> DemError {
        DemError::Truncated {
            path,
            actual: 0,
            expected: super::format::FIXED_HEADER_LEN as u64,
            what: "everything: the file is empty".into(),
        }
    }

    fn validated(path: PathBuf, map: MappedFile) -> Result<Pyramid, DemError> {
        let len = map.len() as u64;
        Self::validated_len(path, map, len)
    }

    /// As `validated`, for `map` holding the first bytes (at least the header) of an object
    /// `actual_len` bytes long.
    fn validated_len(path: PathBuf, map: MappedFile, actual_len: u64) -> Result<Pyramid, DemError> {
        let header = Header::decode(&map, actual_len, &path)?;
        let lay = super::format::layout(&header.levels, header.tile_size, header.description.len());
        let row_extremes = header
            .levels
            .iter()
            .map(|l| (0..l.rows).map(|_| OnceLock::new()).collect())
            .collect();
        Ok(Pyramid {
            path,
            map,
            first_tile: lay.first_tile,
            header,
            row_extremes,
            remote: None,
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    pub fn level_count(&self) -> usize {
        self.header.levels.len()
    }

    pub fn levels(&self) -> &[LevelGeom] {
        &self.header.levels
    }

    /// The pixel-centre grid of a level.
    pub fn grid(&self, level: usize) -> GeoGrid {
        self.header.levels[level].grid
    }

    pub fn tile_size(&self) -> usize {
        self.header.tile_size
    }

    pub fn extents(&self) -> Extents {
        self.header.extents
    }

    pub fn encoding(&self) -> Encoding {
        self.header.encoding
    }

    /// True when the columns cover the whole circle of longitude.
    pub fn wraps(&self) -> bool {
        self.header.wraps
    }

    /// Source pixels without data that the builder set to sea level.
    pub fn nan_count(&self) -> u64 {
        self.header.nan_count
    }

    pub fn info(&self) -> PyramidInfo {
        let h = &self.header;
        PyramidInfo {
            path: self.path.clone(),
            version: super::format::FORMAT_VERSION,
            file_bytes: h.file_len,
            tile_size: h.tile_size,
            tile_bytes: super::format::tile_bytes(h.tile_size),
            tiles: h.index.len(),
            wraps: h.wraps,
            extents: h.extents,
            encoding: h.encoding,
            nan_count: h.nan_count,
            min_m: h.min_m,
            max_m: h.max_m,
            description: h.description.clone(),
            levels: h.levels.clone(),
        }
    }

    /// The finest level whose pixel spacing (in latitude) is at least `spacing_deg`; the
    /// coarsest level if none is that coarse.
    pub fn level_for_spacing(&self, spacing_deg: f64) -> usize {
        self.header
            .levels
            .iter()
            .position(|l| l.grid.dlat_deg >= spacing_deg)
            .unwrap_or(self.header.levels.len() - 1)
    }

    /// Fails if the file's length is no longer what was validated at open (truncated or
    /// extended in place by another process). Cheap (one `fstat`); the streamer can call it
    /// before a batch of reads to narrow the SIGBUS window described in the module docs.
    pub fn check_length(&self) -> Result<(), DemError> {
        if self.remote.is_some() {
            // The object's size was checked at open; a changed object fails its tiles' CRCs.
            return Ok(());
        }
        let len = self.map.current_len()?;
        let expected = self.header.file_len;
        if len < expected {
            return Err(DemError::Truncated {
                path: self.path.clone(),
                actual: len,
                expected,
                what: format!(
                    "{} bytes: the file shrank after it was opened (rewritten in place?)",
                    expected - len
                ),
            });
        }
        if len > expected {
            return Err(DemError::Data {
                path: self.path.clone(),
                message: format!(
                    "the file grew from {expected} to {len} bytes after it was opened (rewritten in place?)"
                ),
            });
        }
        Ok(())
    }

    /// Fails, naming the tile, when the file no longer reaches to the tile's end (truncated in
    /// place after the open): touching those mapped pages would raise SIGBUS. One `fstat`, the
    /// streamer's check before every read. A file that grew still holds the tile where it was,
    /// and the tile's CRC says whether it still holds what it held, so growth is no error here
    /// ([`Pyramid::check_length`], for `verify`, still calls it one).
    pub fn check_tile_in_file(&self, level: usize, tx: usize, ty: usize) -> Result<(), DemError> {
        let e = self.tile_entry(level, tx, ty)?;
        if self.remote.is_some() {
            return Ok(());
        }
        let end = e.offset + e.len as u64;
        let len = self.map.current_len()?;
        if len < end {
            return Err(DemError::Truncated {
                path: self.path.clone(),
                actual: len,
                expected: end,
                what: format!(
                    "level {level} tile ({tx}, {ty}): the file was truncated in place after it \
                     was opened (from {} bytes), so the tile is not read",
                    self.header.file_len
                ),
            });
        }
        Ok(())
    }

    /// What happened to the file since it was opened (one `fstat` of the mapping's descriptor,
    /// one `stat` of the path), or None when nothing did or the bytes are in memory. The
    /// streamer's watcher asks about once a second; see [`FileChange`].
    pub fn file_change(&self) -> Option<FileChange> {
        let seen = self.map.observe()?;
        classify(&self.path, seen, |len| {
            let mut levels = Vec::new();
            let mut unavailable = 0;
            for (level, l) in self.header.levels.iter().enumerate() {
                let first = self.first_tile[level];
                let gone = self.header.index[first..first + l.tile_count()]
                    .iter()
                    .filter(|e| e.offset + e.len as u64 > len)
                    .count();
                if gone > 0 {
                    levels.push(level as u32);
                    unavailable += gone;
                }
            }
            (unavailable, self.header.index.len(), levels)
        })
    }

    fn index_of(&self, level: usize, tx: usize, ty: usize) -> Result<usize, DemError> {
        let l = self.header.levels.get(level).ok_or_else(|| {
            DemError::Other(format!(
                "{}: level {level} does not exist ({} levels)",
                self.path.display(),
                self.header.levels.len()
            ))
        })?;
        if tx >= l.tiles_x || ty >= l.tiles_y {
            return Err(DemError::Other(format!(
                "{}: level {level} has {} × {} tiles, no tile ({tx}, {ty})",
                self.path.display(),
                l.tiles_x,
                l.tiles_y
            )));
        }
        Ok(self.first_tile[level] + ty * l.tiles_x + tx)
    }

    /// The index entry (offset, length, CRC) of a tile.
    pub fn tile_entry(&self, level: usize, tx: usize, ty: usize) -> Result<TileEntry, DemError> {
        Ok(self.header.index[self.index_of(level, tx, ty)?])
    }

    /// The raw payload of a tile (three planes of little-endian `i16`), unchecked.
    /// For a remote pyramid: fetched (blocking) and kept, CRC-checked.
    pub fn tile_bytes(&self, level: usize, tx: usize, ty: usize) -> Result<&[u8], DemError> {
        let e = self.tile_entry(level, tx, ty)?;
        crate::dem::frame_reads::note_read();
        if let Some(r) = &self.remote {
            let index = self.index_of(level, tx, ty)?;
            return self.remote_resident(r, index).ok_or_else(|| {
                DemError::Remote(format!(
                    "{}: level {level} tile ({tx}, {ty}) could not be fetched",
                    self.path.display()
                ))
            });
        }
        Ok(&self.map[e.offset as usize..e.offset as usize + e.len as usize])
    }

    /// A view of a tile, without checking its CRC.
    pub fn tile(&self, level: usize, tx: usize, ty: usize) -> Result<TileView<'_>, DemError> {
        let bytes = self.tile_bytes(level, tx, ty)?;
        Ok(self.view(level, tx, ty, bytes))
    }

    fn view<'a>(&self, level: usize, tx: usize, ty: usize, bytes: &'a [u8]) -> TileView<'a> {
        let t = self.header.tile_size;
        let l = &self.header.levels[level];
        let plane = |p: usize| -> Cow<'a, [i16]> {
            let b = &bytes[p * 2 * t * t..(p + 1) * 2 * t * t];
            #[cfg(target_endian = "little")]
            if let Ok(s) = bytemuck::try_cast_slice::<u8, i16>(b) {
                return Cow::Borrowed(s);
            }
            Cow::Owned(
                b.chunks_exact(2)
                    .map(|c| i16::from_le_bytes([c[0], c[1]]))
                    .collect(),
            )
        };
        TileView {
            level,
            tx,
            ty,
            tile_size: t,
            valid_cols: (l.cols - tx * t).min(t),
            valid_rows: (l.rows - ty * t).min(t),
            first_col: tx * t,
            first_row: ty * t,
            encoding: self.header.encoding,
            avg: plane(0),
            min: plane(1),
            max: plane(2),
        }
    }

    /// A view of a tile whose payload matches its CRC (the streamer's read path).
    pub fn tile_verified(
        &self,
        level: usize,
        tx: usize,
        ty: usize,
    ) -> Result<TileView<'_>, DemError> {
        let e = self.tile_entry(level, tx, ty)?;
        let bytes = self.tile_bytes(level, tx, ty)?;
        let crc = crc32fast::hash(bytes);
        if crc != e.crc32 {
            return Err(self.checksum_error(level, tx, ty, e.crc32, crc));
        }
        self.check_codes(level, tx, ty, bytes)?;
        self.tile(level, tx, ty)
    }

    /// Checks a tile's codes against the format's rules, which its CRC cannot vouch for (a
    /// broken writer or a forged file computes a matching CRC): min ≤ avg ≤ max at every sample
    /// and `i16::MIN` (reserved) nowhere. Returns the lowest min and highest max of the samples
    /// inside the level's grid.
    fn check_codes(
        &self,
        level: usize,
        tx: usize,
        ty: usize,
        bytes: &[u8],
    ) -> Result<(i16, i16), DemError> {
        let t = self.header.tile_size;
        let l = &self.header.levels[level];
        let (valid_cols, valid_rows) = ((l.cols - tx * t).min(t), (l.rows - ty * t).min(t));
        let plane_bytes = 2 * t * t;
        let (mut lowest, mut highest) = (i16::MAX, i16::MIN);
        for y in 0..t {
            // Row y of plane p, decoded (the payload's length was checked at open).
            let row = |p: usize| {
                let at = p * plane_bytes + 2 * y * t;
                bytes[at..at + 2 * t]
                    .chunks_exact(2)
                    .map(|c| i16::from_le_bytes([c[0], c[1]]))
            };
            for (x, ((avg, min), max)) in row(0).zip(row(1)).zip(row(2)).enumerate() {
                if min == i16::MIN || !(min <= avg && avg <= max) {
                    return Err(DemError::TileContent {
                        path: self.path.clone(),
                        level,
                        tx,
                        ty,
                        x,
                        y,
                        message: format!(
                            "codes min {min}, avg {avg}, max {max}; expected min ≤ avg ≤ max \
                             and none {} (reserved)",
                            i16::MIN
                        ),
                    });
                }
                if x < valid_cols && y < valid_rows {
                    lowest = lowest.min(min);
                    highest = highest.max(max);
                }
            }
        }
        Ok((lowest, highest))
    }

    fn checksum_error(
        &self,
        level: usize,
        tx: usize,
        ty: usize,
        expected: u32,
        actual: u32,
    ) -> DemError {
        DemError::TileChecksum {
            path: self.path.clone(),
            level,
            tx,
            ty,
            expected,
            actual,
        }
    }

    /// Checks the file length again, every tile's CRC and codes, in file order (the first bad
    /// tile is the error, with its level and tile x/y), and that the header's height range is
    /// level 0's.
    pub fn verify(&self) -> Result<VerifyReport, DemError> {
        self.check_length()?;
        let mut bytes = 0u64;
        let (mut lowest, mut highest) = (i16::MAX, i16::MIN);
        for (level, l) in self.header.levels.iter().enumerate() {
            for ty in 0..l.tiles_y {
                for tx in 0..l.tiles_x {
                    let e = self.tile_entry(level, tx, ty)?;
                    let payload = self.tile_bytes(level, tx, ty)?;
                    let crc = crc32fast::hash(payload);
                    if crc != e.crc32 {
                        return Err(self.checksum_error(level, tx, ty, e.crc32, crc));
                    }
                    let (lo, hi) = self.check_codes(level, tx, ty, payload)?;
                    if level == 0 {
                        lowest = lowest.min(lo);
                        highest = highest.max(hi);
                    }
                    bytes += e.len as u64;
                }
            }
        }
        let enc = self.header.encoding;
        let (min_m, max_m) = (enc.decode(lowest), enc.decode(highest));
        if (min_m, max_m) != (self.header.min_m, self.header.max_m) {
            return Err(DemError::Header {
                path: self.path.clone(),
                field: "height range".into(),
                message: format!(
                    "lowest min {} m, highest max {} m; level 0's tiles hold {min_m} … {max_m} m",
                    self.header.min_m, self.header.max_m
                ),
            });
        }
        Ok(VerifyReport {
            tiles: self.header.index.len(),
            bytes,
        })
    }

    /// The stored code of plane `p` at pixel (row, col) of a level (in range: unchecked).
    /// None only for a remote tile that could not be fetched.
    fn code(&self, level: usize, p: Plane, row: usize, col: usize) -> Option<i16> {
        let t = self.header.tile_size;
        let l = &self.header.levels[level];
        let i = self.first_tile[level] + (row / t) * l.tiles_x + col / t;
        let within = 2 * (p as usize * t * t + (row % t) * t + col % t);
        crate::dem::frame_reads::note_read();
        if let Some(r) = &self.remote {
            let b = self.remote_resident(r, i)?;
            return Some(i16::from_le_bytes([b[within], b[within + 1]]));
        }
        let at = self.header.index[i].offset as usize + within;
        Some(i16::from_le_bytes([self.map[at], self.map[at + 1]]))
    }

    /// The stored code of plane `p` at pixel (row, col) of a level, `None` out of range.
    pub fn pixel_code(&self, level: usize, p: Plane, row: usize, col: usize) -> Option<i16> {
        let l = self.header.levels.get(level)?;
        (row < l.rows && col < l.cols)
            .then(|| self.code(level, p, row, col))
            .flatten()
    }

    /// Height in metres of plane `p` at pixel (row, col) of a level.
    pub fn pixel_m(&self, level: usize, p: Plane, row: usize, col: usize) -> Option<f64> {
        let l = self.header.levels.get(level)?;
        (row < l.rows && col < l.cols)
            .then(|| self.code(level, p, row, col))
            .flatten()
            .map(|c| self.header.encoding.decode(c))
    }

    /// True when (lat, lon) lies within the data's extents (always, in longitude, for a
    /// grid that wraps).
    pub fn covers(&self, lat_deg: f64, lon_deg: f64) -> bool {
        self.lon_offset(lon_deg).is_some() && self.lat_ok(lat_deg)
    }

    fn lat_ok(&self, lat: f64) -> bool {
        let e = &self.header.extents;
        let tol = 1e-9;
        (-90.0..=90.0).contains(&lat) && lat >= e.south_deg - tol && lat <= e.north_deg + tol
    }

    /// Degrees east of the western edge, in [0, east − west], or None outside.
    fn lon_offset(&self, lon: f64) -> Option<f64> {
        if !lon.is_finite() {
            return None;
        }
        let e = &self.header.extents;
        let d = (lon - e.west_deg).rem_euclid(360.0);
        if self.header.wraps {
            return Some(d);
        }
        let span = e.east_deg - e.west_deg;
        let tol = 1e-9;
        if d <= span + tol {
            Some(d.min(span))
        } else if d >= 360.0 - tol {
            Some(0.0)
        } else {
            None
        }
    }

    /// Continuous (row, col) of a point at a level, pixel centres at integers, snapped to a
    /// centre within 1e-7 pixel (so that a centre computed in floating point hits it).
    fn pixel_coords(&self, level: usize, lat: f64, lon: f64) -> Option<(f64, f64)> {
        if !self.lat_ok(lat) {
            return None;
        }
        let d = self.lon_offset(lon)?;
        let g = &self.header.levels[level].grid;
        let snap = |x: f64| {
            let r = x.round();
            if (x - r).abs() < 1e-7 { r } else { x }
        };
        let row = snap((g.lat0_deg - lat) / g.dlat_deg);
        let col = snap(d / g.dlon_deg - 0.5);
        Some((row, col))
    }

    /// The avg height at (lat, lon) at a level, bilinear between pixel centres: a pixel centre
    /// returns its stored value exactly. Longitude wraps for a grid that covers the circle;
    /// latitude clamps to the first/last row towards the poles (and near a regional grid's
    /// edges). `None` outside the data's extents or for a level that does not exist.
    pub fn sample(&self, lat_deg: f64, lon_deg: f64, level: usize) -> Option<f64> {
        self.sample_plane(lat_deg, lon_deg, level, Plane::Avg)
    }

    /// As [`Pyramid::sample`], of any plane.
    pub fn sample_plane(&self, lat_deg: f64, lon_deg: f64, level: usize, p: Plane) -> Option<f64> {
        let code = |l, p, r, c| self.code(l, p, r, c);
        self.sample_plane_with(lat_deg, lon_deg, level, p, &code)
            .unwrap_or(None)
    }

    /// As [`Pyramid::sample_plane`], reading codes through `code` (level, plane, row, col),
    /// which may lack some tiles (the streamer's resident set): `Err(NotResident)` then.
    pub fn sample_plane_with(
        &self,
        lat_deg: f64,
        lon_deg: f64,
        level: usize,
        p: Plane,
        code: CodeFn<'_>,
    ) -> Result<Option<f64>, NotResident> {
        let Some(l) = self.header.levels.get(level).copied() else {
            return Ok(None);
        };
        let Some((row, col)) = self.pixel_coords(level, lat_deg, lon_deg) else {
            return Ok(None);
        };
        let row = row.clamp(0.0, (l.rows - 1) as f64);
        let r0 = (row as usize).min(l.rows - 1);
        let fr = row - r0 as f64;
        let r1 = (r0 + 1).min(l.rows - 1);
        let (c0, c1, fc) = if self.header.wraps {
            let n = l.cols as f64;
            let mut c = col.rem_euclid(n);
            if c >= n {
                c = 0.0;
            }
            let c0 = (c as usize).min(l.cols - 1);
            (c0, (c0 + 1) % l.cols, c - c0 as f64)
        } else {
            let c = col.clamp(0.0, (l.cols - 1) as f64);
            let c0 = (c as usize).min(l.cols - 1);
            (c0, (c0 + 1).min(l.cols - 1), c - c0 as f64)
        };
        let v = |r, c| -> Result<f64, NotResident> {
            Ok(self
                .header
                .encoding
                .decode(code(level, p, r, c).ok_or(NotResident)?))
        };
        let top = if fc == 0.0 {
            v(r0, c0)?
        } else {
            lerp_within(v(r0, c0)?, v(r0, c1)?, fc)
        };
        if fr == 0.0 {
            return Ok(Some(top));
        }
        let bottom = if fc == 0.0 {
            v(r1, c0)?
        } else {
            lerp_within(v(r1, c0)?, v(r1, c1)?, fc)
        };
        Ok(Some(lerp_within(top, bottom, fr)))
    }

    /// Bounds of the terrain over a region at a level, from the min/max planes: they hold for
    /// the level-0 bilinear surface and for every coarser level's bilinear avg surface at every
    /// point of the region (the pixels read are all those whose centre is within one pixel of
    /// the region). `None` when the region misses the data or the level does not exist.
    ///
    /// Whole rows (a region reaching a pole, or wider than the circle) are read once per row
    /// and remembered.
    pub fn min_max_in(&self, region: Region, level: usize) -> Option<HeightBounds> {
        let code = |l, p, r, c| self.code(l, p, r, c);
        self.min_max_in_impl(region, level, &code, true)
            .unwrap_or(None)
    }

    /// As [`Pyramid::min_max_in`], reading codes through `code`, which may lack some tiles:
    /// `Err(NotResident)` then.
    pub fn min_max_in_with(
        &self,
        region: Region,
        level: usize,
        code: CodeFn<'_>,
    ) -> Result<Option<HeightBounds>, NotResident> {
        self.min_max_in_impl(region, level, code, false)
    }

    /// The lowest min and highest max code of a whole row of a level (read once).
    /// None when a remote tile of the row could not be fetched (not remembered).
    fn row_extremes(&self, level: usize, row: usize) -> Option<(i16, i16)> {
        if let Some(v) = self.row_extremes[level][row].get() {
            return Some(*v);
        }
        let cols = self.header.levels[level].cols;
        let (mut lo, mut hi) = (i16::MAX, i16::MIN);
        for c in 0..cols {
            lo = lo.min(self.code(level, Plane::Min, row, c)?);
            hi = hi.max(self.code(level, Plane::Max, row, c)?);
        }
        Some(*self.row_extremes[level][row].get_or_init(|| (lo, hi)))
    }

    /// [`Pyramid::min_max_in_with`]; `whole_rows` reads a row spanning every column through
    /// [`Pyramid::row_extremes`] (the map's own codes: only for `code` reading the map).
    fn min_max_in_impl(
        &self,
        region: Region,
        level: usize,
        code: CodeFn<'_>,
        whole_rows: bool,
    ) -> Result<Option<HeightBounds>, NotResident> {
        let Some(l) = self.header.levels.get(level).copied() else {
            return Ok(None);
        };
        let (south, north, west, span) = match region {
            Region::Box {
                south_deg,
                north_deg,
                west_deg,
                east_deg,
            } => {
                if south_deg.is_nan() || north_deg.is_nan() || south_deg > north_deg {
                    return Ok(None);
                }
                let span = if east_deg - west_deg >= 360.0 {
                    360.0
                } else {
                    (east_deg - west_deg).rem_euclid(360.0)
                };
                (south_deg, north_deg, west_deg, span)
            }
            Region::Cap {
                lat_deg,
                lon_deg,
                radius_rad,
            } => {
                if radius_rad.is_nan() || radius_rad < 0.0 {
                    return Ok(None);
                }
                let r = radius_rad.to_degrees();
                let (s, n) = (lat_deg - r, lat_deg + r);
                if n >= 90.0 || s <= -90.0 || radius_rad >= std::f64::consts::FRAC_PI_2 {
                    (s.max(-90.0), n.min(90.0), lon_deg, 360.0)
                } else {
                    let half = (radius_rad.sin() / lat_deg.to_radians().cos())
                        .clamp(-1.0, 1.0)
                        .asin()
                        .to_degrees();
                    (s, n, lon_deg - half, 2.0 * half)
                }
            }
        };
        let e = self.header.extents;
        let g = l.grid;
        let (south, north) = (south.max(-90.0), north.min(90.0));
        let (s_c, n_c) = (south.max(e.south_deg), north.min(e.north_deg));
        if s_c > n_c {
            return Ok(None);
        }
        let tol = 1e-9;
        let mut complete = s_c <= south + tol && n_c >= north - tol;
        // Rows whose centre is within one pixel of [s_c, n_c].
        let row_a = (((g.lat0_deg - n_c) / g.dlat_deg).floor().max(0.0) as usize).min(l.rows - 1);
        let row_b = (((g.lat0_deg - s_c) / g.dlat_deg).ceil().max(0.0) as usize).min(l.rows - 1);
        // Column ranges (a pixel range in "columns east of the western edge" units).
        let mut col_ranges: Vec<(isize, isize)> = Vec::new();
        let to_col = |d: f64| d / g.dlon_deg - 0.5;
        if self.header.wraps {
            if span >= 360.0 {
                col_ranges.push((0, l.cols as isize - 1));
            } else {
                let d = (west - e.west_deg).rem_euclid(360.0);
                let a = to_col(d).floor() as isize;
                let b = to_col(d + span).ceil() as isize;
                if b - a + 1 >= l.cols as isize {
                    col_ranges.push((0, l.cols as isize - 1));
                } else {
                    col_ranges.push((a, b));
                }
            }
        } else {
            let width = e.east_deg - e.west_deg;
            let d0 = (west - e.west_deg).rem_euclid(360.0) - 360.0;
            let mut covered = 0.0;
            for k in 0..3 {
                let a = d0 + 360.0 * k as f64;
                let b = a + span;
                let (ca, cb) = (a.max(0.0), b.min(width));
                if ca <= cb {
                    covered += cb - ca;
                    let lo = to_col(ca).floor().max(0.0) as isize;
                    let hi = (to_col(cb).ceil() as isize).min(l.cols as isize - 1);
                    col_ranges.push((lo, hi));
                }
            }
            if col_ranges.is_empty() {
                return Ok(None);
            }
            if covered < span - 1e-9 {
                complete = false;
            }
        }
        let (mut lo, mut hi) = (i16::MAX, i16::MIN);
        let mut pixels = 0;
        let n = l.cols as isize;
        let every_column = col_ranges == [(0, n - 1)];
        for row in row_a..=row_b {
            if whole_rows && every_column {
                let (row_lo, row_hi) = self.row_extremes(level, row).ok_or(NotResident)?;
                (lo, hi) = (lo.min(row_lo), hi.max(row_hi));
                pixels += l.cols;
                continue;
            }
            for &(a, b) in &col_ranges {
                for c in a..=b {
                    let col = c.rem_euclid(n) as usize;
                    lo = lo.min(code(level, Plane::Min, row, col).ok_or(NotResident)?);
                    hi = hi.max(code(level, Plane::Max, row, col).ok_or(NotResident)?);
                    pixels += 1;
                }
            }
        }
        Ok(Some(HeightBounds {
            min_m: self.header.encoding.decode(lo),
            max_m: self.header.encoding.decode(hi),
            complete,
            pixels,
        }))
    }
}

/// Linear interpolation from `a` to `b` that never leaves [min(a, b), max(a, b)]. The textbook
/// `(1 − t)·a + t·b` rounds past both ends (a = b = 32767 gives 32767.000000000004 at
/// t = 0.3633), which puts a sample above the max plane that bounds it and outside the data's
/// range.
fn lerp_within(a: f64, b: f64, t: f64) -> f64 {
    (a + (b - a) * t).clamp(a.min(b), a.max(b))
}
