//! The byte layout of the pyramid file (see the table in the module documentation of
//! [`crate::dem::pyramid`]): level geometry shared by the writer and the reader, and the header
//! codec with every consistency check the reader performs before it touches a tile.

use std::path::Path;

use crate::dem::DemError;
use crate::dem::raster::GeoGrid;

/// The first eight bytes of every pyramid file.
pub const MAGIC: [u8; 8] = *b"GLOBEPYR";
/// The format version this build writes and reads.
pub const FORMAT_VERSION: u32 = 1;
/// Bytes of the fixed part of the header (before the description).
pub(crate) const FIXED_HEADER_LEN: usize = 136;
/// Bytes of one level-table entry.
pub(crate) const LEVEL_ENTRY_LEN: usize = 64;
/// Bytes of one tile-index entry.
pub(crate) const INDEX_ENTRY_LEN: usize = 16;
/// Tile payloads start at a multiple of this (a page), so a tile never shares a page with the
/// header and the planes are aligned for zero-copy `&[i16]` views.
pub(crate) const DATA_ALIGN: u64 = 4096;
/// The longest source description kept in the header, in bytes.
pub(crate) const MAX_DESCRIPTION: usize = 4096;
/// Sample format 1: three planes (avg, min, max) of little-endian `i16`.
pub(crate) const SAMPLE_FORMAT_I16X3: u32 = 1;
/// Flag bit: the columns cover the whole circle of longitude.
pub(crate) const FLAG_WRAPS: u32 = 1;
/// Allowed tile edge lengths, in samples.
pub const MIN_TILE_SIZE: usize = 4;
pub const MAX_TILE_SIZE: usize = 4096;
/// `i16::MIN` is reserved (never written in version 1), so the code range is symmetric.
pub(crate) const CODE_MIN: i32 = -(i16::MAX as i32);
pub(crate) const CODE_MAX: i32 = i16::MAX as i32;

/// The sample grid of one level: pixel centres as in [`GeoGrid`], cut into square tiles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelGeom {
    pub cols: usize,
    pub rows: usize,
    pub tiles_x: usize,
    pub tiles_y: usize,
    /// Pixel centres, as the raster convention has them (row 0 northernmost).
    pub grid: GeoGrid,
}

impl LevelGeom {
    pub fn tile_count(&self) -> usize {
        self.tiles_x * self.tiles_y
    }
}

/// The footprint of the data: pixel edges (not centres), degrees. Identical for every level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Extents {
    pub west_deg: f64,
    pub east_deg: f64,
    pub south_deg: f64,
    pub north_deg: f64,
}

/// How heights are stored: `metres = offset_m + quantum_m · code`, `code` an `i16`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Encoding {
    pub quantum_m: f64,
    pub offset_m: f64,
}

impl Default for Encoding {
    /// Whole metres: GTOPO30 (integer metres) and ETOPO5 (integer-valued floats) round-trip exactly.
    fn default() -> Self {
        Self {
            quantum_m: 1.0,
            offset_m: 0.0,
        }
    }
}

impl Encoding {
    pub fn decode(&self, code: i16) -> f64 {
        self.offset_m + self.quantum_m * code as f64
    }

    /// True when `(h − offset) / quantum` is exact for every f32 height (a power-of-two
    /// quantum, offset 0): floor and ceil then need no check.
    fn is_exact(&self) -> bool {
        self.offset_m == 0.0 && {
            let (m, _) = frexp(self.quantum_m);
            m == 0.5
        }
    }

    /// Nearest code (ties away from zero), unchecked range.
    pub(crate) fn nearest(&self, h: f64) -> i32 {
        let x = (h - self.offset_m) / self.quantum_m;
        let f = floor_i64(x);
        let d = x - f as f64;
        // Branch-free (a rounding branch mispredicts on half of all real data).
        (f + ((d > 0.5) | ((d == 0.5) & (x > 0.0))) as i64) as i32
    }

    /// The largest code whose height is ≤ `h` (exact in f64, not just in the division).
    pub(crate) fn floor(&self, h: f64) -> i32 {
        let mut c = floor_i64((h - self.offset_m) / self.quantum_m) as i32;
        if self.is_exact() {
            return c;
        }
        while self.offset_m + self.quantum_m * c as f64 > h {
            c -= 1;
        }
        c
    }

    /// The smallest code whose height is ≥ `h`.
    pub(crate) fn ceil(&self, h: f64) -> i32 {
        let mut c = ceil_i64((h - self.offset_m) / self.quantum_m) as i32;
        if self.is_exact() {
            return c;
        }
        while self.offset_m + self.quantum_m * (c as f64) < h {
            c += 1;
        }
        c
    }

    /// Lowest and highest height the codes can hold.
    pub fn range_m(&self) -> (f64, f64) {
        (
            self.offset_m + self.quantum_m * CODE_MIN as f64,
            self.offset_m + self.quantum_m * CODE_MAX as f64,
        )
    }
}

/// Mantissa in [0.5, 1) and exponent of a finite, positive x (x = m·2^e).
fn frexp(x: f64) -> (f64, i32) {
    let bits = x.to_bits();
    let exp = ((bits >> 52) & 0x7ff) as i32;
    if exp == 0 || exp == 0x7ff {
        return (x, 0);
    }
    let m = f64::from_bits((bits & !(0x7ff << 52)) | (1022 << 52));
    (m, exp - 1022)
}

/// ⌊x⌋ without a libm call (x86-64's baseline has no `roundsd`); |x| < 2⁶³, NaN → 0.
#[inline]
pub(crate) fn floor_i64(x: f64) -> i64 {
    let t = x as i64;
    if (t as f64) > x { t - 1 } else { t }
}

/// ⌈x⌉ without a libm call; |x| < 2⁶³, NaN → 0.
#[inline]
pub(crate) fn ceil_i64(x: f64) -> i64 {
    let t = x as i64;
    if (t as f64) < x { t + 1 } else { t }
}

/// One tile-index entry: where the payload is and its CRC-32 (IEEE, as `crc32fast`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TileEntry {
    pub offset: u64,
    pub len: u32,
    pub crc32: u32,
}

/// Footprint extents of a source grid. Longitudes are the source's own (not normalised).
pub(crate) fn extents_of(grid: &GeoGrid) -> Extents {
    let west = grid.lon0_deg - 0.5 * grid.dlon_deg;
    let east = if grid.wraps_in_longitude() {
        west + 360.0
    } else {
        west + grid.cols as f64 * grid.dlon_deg
    };
    let north = grid.lat0_deg + 0.5 * grid.dlat_deg;
    Extents {
        west_deg: west,
        east_deg: east,
        south_deg: north - grid.rows as f64 * grid.dlat_deg,
        north_deg: north,
    }
}

/// The level geometries: level 0 is the source grid itself; each next level has
/// ⌈cols/2⌉ × ⌈rows/2⌉ pixels spread over the same extents; the last level is the first that
/// fits one tile.
pub(crate) fn level_geoms(level0: &GeoGrid, tile_size: usize) -> Vec<LevelGeom> {
    let ext = extents_of(level0);
    let t = tile_size;
    let mut out = vec![LevelGeom {
        cols: level0.cols,
        rows: level0.rows,
        tiles_x: level0.cols.div_ceil(t),
        tiles_y: level0.rows.div_ceil(t),
        grid: *level0,
    }];
    while out.last().is_some_and(|l| l.tiles_x > 1 || l.tiles_y > 1) {
        let prev = out.last().expect("non-empty");
        let cols = prev.cols.div_ceil(2);
        let rows = prev.rows.div_ceil(2);
        let dlon = (ext.east_deg - ext.west_deg) / cols as f64;
        let dlat = (ext.north_deg - ext.south_deg) / rows as f64;
        out.push(LevelGeom {
            cols,
            rows,
            tiles_x: cols.div_ceil(t),
            tiles_y: rows.div_ceil(t),
            grid: GeoGrid {
                cols,
                rows,
                lon0_deg: ext.west_deg + 0.5 * dlon,
                lat0_deg: ext.north_deg - 0.5 * dlat,
                dlon_deg: dlon,
                dlat_deg: dlat,
            },
        });
    }
    out
}

/// Checks that a grid can be the level 0 of a pyramid: finite, positive spacing, centres on the
/// sphere, at most one turn of longitude. Returns a message naming the problem.
pub(crate) fn check_source_grid(g: &GeoGrid) -> Result<(), String> {
    let fields = [
        ("lon0_deg", g.lon0_deg),
        ("lat0_deg", g.lat0_deg),
        ("dlon_deg", g.dlon_deg),
        ("dlat_deg", g.dlat_deg),
    ];
    for (name, v) in fields {
        if !v.is_finite() {
            return Err(format!("{name} = {v} is not finite"));
        }
    }
    if g.cols == 0 || g.rows == 0 {
        return Err(format!("empty grid ({} × {})", g.cols, g.rows));
    }
    if g.cols > u32::MAX as usize || g.rows > u32::MAX as usize {
        return Err(format!("grid {} × {} too large", g.cols, g.rows));
    }
    if g.dlon_deg <= 0.0 || g.dlat_deg <= 0.0 {
        return Err(format!(
            "spacing must be positive (dlon {}, dlat {})",
            g.dlon_deg, g.dlat_deg
        ));
    }
    let last_lat = g.lat_of_row(g.rows as f64 - 1.0);
    let tol = 1e-9;
    if g.lat0_deg > 90.0 + tol || last_lat < -90.0 - tol {
        return Err(format!(
            "pixel centres must lie within ±90° latitude (rows span {} … {})",
            g.lat0_deg, last_lat
        ));
    }
    if g.cols as f64 * g.dlon_deg > 360.0 + 1e-6 * g.dlon_deg {
        return Err(format!(
            "{} columns of {}° span more than 360°",
            g.cols, g.dlon_deg
        ));
    }
    Ok(())
}

/// Everything the header holds.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Header {
    pub tile_size: usize,
    pub wraps: bool,
    pub encoding: Encoding,
    pub extents: Extents,
    pub tile_data_offset: u64,
    pub file_len: u64,
    pub nan_count: u64,
    /// Lowest stored min and highest stored max of level 0, metres.
    pub min_m: f64,
    pub max_m: f64,
    pub description: String,
    pub levels: Vec<LevelGeom>,
    /// Every tile, level by level, rows of tiles north to south, west to east within a row.
    pub index: Vec<TileEntry>,
}

/// Where everything goes, derived from the level geometry alone (so the writer knows every
/// offset before it has read a single row).
#[derive(Clone, Debug)]
pub(crate) struct Layout {
    pub level_table_offset: usize,
    pub index_offset: usize,
    /// Bytes from 0 to the end of the header CRC.
    pub header_len: usize,
    pub tile_data_offset: u64,
    pub tile_bytes: u64,
    pub tile_count: usize,
    pub file_len: u64,
    /// Index of each level's first tile in the tile index.
    pub first_tile: Vec<usize>,
}

pub(crate) fn tile_bytes(tile_size: usize) -> u64 {
    3 * 2 * (tile_size * tile_size) as u64
}

pub(crate) fn layout(levels: &[LevelGeom], tile_size: usize, description_len: usize) -> Layout {
    let level_table_offset = FIXED_HEADER_LEN + description_len.next_multiple_of(8);
    let index_offset = level_table_offset + LEVEL_ENTRY_LEN * levels.len();
    let mut first_tile = Vec::with_capacity(levels.len());
    let mut tile_count = 0;
    for l in levels {
        first_tile.push(tile_count);
        tile_count += l.tile_count();
    }
    let header_len = index_offset + INDEX_ENTRY_LEN * tile_count + 4;
    let tile_data_offset = (header_len as u64).next_multiple_of(DATA_ALIGN);
    let tb = tile_bytes(tile_size);
    Layout {
        level_table_offset,
        index_offset,
        header_len,
        tile_data_offset,
        tile_bytes: tb,
        tile_count,
        file_len: tile_data_offset + tb * tile_count as u64,
        first_tile,
    }
}

impl Header {
    /// The header bytes, header CRC included (`layout().header_len` bytes).
    pub fn encode(&self) -> Vec<u8> {
        let desc = self.description.as_bytes();
        let lay = layout(&self.levels, self.tile_size, desc.len());
        let mut b = Vec::with_capacity(lay.header_len);
        b.extend_from_slice(&MAGIC);
        put_u32(&mut b, FORMAT_VERSION);
        put_u32(&mut b, lay.header_len as u32);
        put_u32(&mut b, self.tile_size as u32);
        put_u32(&mut b, self.levels.len() as u32);
        put_u32(&mut b, if self.wraps { FLAG_WRAPS } else { 0 });
        put_u32(&mut b, SAMPLE_FORMAT_I16X3);
        put_f64(&mut b, self.encoding.quantum_m);
        put_f64(&mut b, self.encoding.offset_m);
        put_f64(&mut b, self.extents.west_deg);
        put_f64(&mut b, self.extents.east_deg);
        put_f64(&mut b, self.extents.south_deg);
        put_f64(&mut b, self.extents.north_deg);
        put_u64(&mut b, self.tile_data_offset);
        put_u64(&mut b, self.file_len);
        put_u64(&mut b, self.index.len() as u64);
        put_u64(&mut b, self.nan_count);
        put_f64(&mut b, self.min_m);
        put_f64(&mut b, self.max_m);
        put_u32(&mut b, desc.len() as u32);
        put_u32(&mut b, 0);
        debug_assert_eq!(b.len(), FIXED_HEADER_LEN);
        b.extend_from_slice(desc);
        b.resize(lay.level_table_offset, 0);
        let mut index_at = lay.index_offset;
        for l in &self.levels {
            put_u32(&mut b, l.cols as u32);
            put_u32(&mut b, l.rows as u32);
            put_u32(&mut b, l.tiles_x as u32);
            put_u32(&mut b, l.tiles_y as u32);
            put_f64(&mut b, l.grid.lon0_deg);
            put_f64(&mut b, l.grid.lat0_deg);
            put_f64(&mut b, l.grid.dlon_deg);
            put_f64(&mut b, l.grid.dlat_deg);
            put_u64(&mut b, index_at as u64);
            put_u64(&mut b, 0);
            index_at += INDEX_ENTRY_LEN * l.tile_count();
        }
        debug_assert_eq!(b.len(), lay.index_offset);
        for e in &self.index {
            put_u64(&mut b, e.offset);
            put_u32(&mut b, e.len);
            put_u32(&mut b, e.crc32);
        }
        let crc = crc32fast::hash(&b);
        put_u32(&mut b, crc);
        debug_assert_eq!(b.len(), lay.header_len);
        b
    }

    /// Parses and validates a header from the start of a file of `actual_len` bytes
    /// (`bytes` may be the whole file). Every failure names the file and what is wrong.
    ///
    /// The sections are checked in file order, each before anything depends on it: magic and
    /// version, the fixed header's lengths, the header CRC, the storage fields, the description,
    /// the level table, the layout it implies, the tile index, and last the file's length.
    pub fn decode(bytes: &[u8], actual_len: u64, path: &Path) -> Result<Header, DemError> {
        let d = Decoder {
            bytes,
            actual_len,
            path,
        };
        d.magic_and_version()?;
        let fixed = d.fixed_header()?;
        d.header_crc(&fixed)?;
        // From here on the bytes are what the writer wrote (or a deliberate forgery): check that
        // they are consistent, so that nothing later can index out of bounds.
        d.storage(&fixed)?;
        let description = d.description(&fixed)?;
        let (levels, index_offsets) = d.level_table(&fixed);
        let wraps = d.check_levels(&fixed, &levels)?;
        let lay = d.check_layout(&fixed, &levels, &index_offsets)?;
        let index = d.tile_index(&fixed, &levels, &lay)?;
        d.check_file_len(&fixed, &levels, &lay, &index)?;
        Ok(Header {
            tile_size: fixed.tile_size,
            wraps,
            encoding: fixed.encoding,
            extents: fixed.extents,
            tile_data_offset: fixed.tile_data_offset,
            file_len: fixed.file_len,
            nan_count: fixed.nan_count,
            min_m: fixed.min_m,
            max_m: fixed.max_m,
            description,
            levels,
            index,
        })
    }
}

/// One header being decoded: the bytes, the file's real length and its path (for errors).
struct Decoder<'a> {
    bytes: &'a [u8],
    actual_len: u64,
    path: &'a Path,
}

/// The fields of the fixed part of the header, as stored (checked by the sections that use
/// them).
struct FixedHeader {
    header_len: usize,
    tile_size: usize,
    level_count: usize,
    flags: u32,
    sample_format: u32,
    encoding: Encoding,
    extents: Extents,
    tile_data_offset: u64,
    file_len: u64,
    tile_count: u64,
    nan_count: u64,
    min_m: f64,
    max_m: f64,
    desc_len: usize,
    /// The shortest header the description and level count allow (an empty tile index).
    min_len: usize,
}

impl Decoder<'_> {
    fn field_err(&self, field: &str, message: String) -> DemError {
        DemError::Header {
            path: self.path.to_path_buf(),
            field: field.to_string(),
            message,
        }
    }

    fn truncated(&self, expected: u64, what: String) -> DemError {
        DemError::Truncated {
            path: self.path.to_path_buf(),
            actual: self.actual_len,
            expected,
            what,
        }
    }

    /// The magic bytes, then the format version.
    fn magic_and_version(&self) -> Result<(), DemError> {
        let bytes = self.bytes;
        if bytes.len() < MAGIC.len() {
            return Err(self.truncated(
                FIXED_HEADER_LEN as u64,
                "the magic bytes and the fixed header".into(),
            ));
        }
        if bytes[..8] != MAGIC {
            return Err(self.field_err(
                "magic",
                format!(
                    "not a globe pyramid file: the first bytes are {:?}, expected {:?}",
                    String::from_utf8_lossy(&bytes[..8]),
                    String::from_utf8_lossy(&MAGIC)
                ),
            ));
        }
        if bytes.len() < 12 {
            return Err(self.truncated(FIXED_HEADER_LEN as u64, "the format version".into()));
        }
        let version = get_u32(bytes, 8);
        if version != FORMAT_VERSION {
            return Err(self.field_err(
                "version",
                format!(
                    "format version {version}; this build reads version {FORMAT_VERSION} (rebuild the file with this build's importer)"
                ),
            ));
        }
        Ok(())
    }

    /// The fixed header: present in full, a description and level count in range, and a
    /// header length that can hold them.
    fn fixed_header(&self) -> Result<FixedHeader, DemError> {
        let bytes = self.bytes;
        if bytes.len() < FIXED_HEADER_LEN {
            return Err(self.truncated(
                FIXED_HEADER_LEN as u64,
                format!("the fixed header ({FIXED_HEADER_LEN} bytes)"),
            ));
        }
        let header_len = get_u32(bytes, 12) as usize;
        let level_count = get_u32(bytes, 20) as usize;
        let desc_len = get_u32(bytes, 128) as usize;
        if desc_len > MAX_DESCRIPTION {
            return Err(self.field_err(
                "description length",
                format!("{desc_len} bytes, at most {MAX_DESCRIPTION} expected"),
            ));
        }
        if level_count == 0 || level_count > 64 {
            return Err(self.field_err("level count", format!("{level_count}, expected 1 … 64")));
        }
        let min_len =
            FIXED_HEADER_LEN + desc_len.next_multiple_of(8) + LEVEL_ENTRY_LEN * level_count + 4;
        if header_len < min_len || header_len > (1 << 31) {
            return Err(self.field_err(
                "header length",
                format!("{header_len} bytes, but {level_count} levels need at least {min_len}"),
            ));
        }
        Ok(FixedHeader {
            header_len,
            tile_size: get_u32(bytes, 16) as usize,
            level_count,
            flags: get_u32(bytes, 24),
            sample_format: get_u32(bytes, 28),
            encoding: Encoding {
                quantum_m: get_f64(bytes, 32),
                offset_m: get_f64(bytes, 40),
            },
            extents: Extents {
                west_deg: get_f64(bytes, 48),
                east_deg: get_f64(bytes, 56),
                south_deg: get_f64(bytes, 64),
                north_deg: get_f64(bytes, 72),
            },
            tile_data_offset: get_u64(bytes, 80),
            file_len: get_u64(bytes, 88),
            tile_count: get_u64(bytes, 96),
            nan_count: get_u64(bytes, 104),
            min_m: get_f64(bytes, 112),
            max_m: get_f64(bytes, 120),
            desc_len,
            min_len,
        })
    }

    /// The whole header is present and its CRC matches.
    fn header_crc(&self, f: &FixedHeader) -> Result<(), DemError> {
        let header_len = f.header_len;
        if self.bytes.len() < header_len {
            return Err(self.truncated(
                header_len as u64,
                format!("the end of the header (level table and tile index, {header_len} bytes)"),
            ));
        }
        let stored_crc = get_u32(self.bytes, header_len - 4);
        let crc = crc32fast::hash(&self.bytes[..header_len - 4]);
        if crc != stored_crc {
            return Err(self.field_err(
                "header CRC",
                format!(
                    "header checksum mismatch (stored {stored_crc:#010x}, computed {crc:#010x}): the header is corrupt"
                ),
            ));
        }
        Ok(())
    }

    /// How samples are stored: tile size, flags, sample format and height encoding.
    fn storage(&self, f: &FixedHeader) -> Result<(), DemError> {
        let tile_size = f.tile_size;
        if !(MIN_TILE_SIZE..=MAX_TILE_SIZE).contains(&tile_size) {
            return Err(self.field_err(
                "tile size",
                format!("{tile_size}, expected {MIN_TILE_SIZE} … {MAX_TILE_SIZE}"),
            ));
        }
        if f.flags & !FLAG_WRAPS != 0 {
            return Err(self.field_err("flags", format!("unknown flag bits {:#x}", f.flags)));
        }
        if f.sample_format != SAMPLE_FORMAT_I16X3 {
            return Err(self.field_err(
                "sample format",
                format!(
                    "{}, expected {SAMPLE_FORMAT_I16X3} (i16 avg/min/max planes)",
                    f.sample_format
                ),
            ));
        }
        let e = f.encoding;
        let (lowest, highest) = e.range_m();
        if !(e.quantum_m.is_finite()
            && e.quantum_m > 0.0
            && e.offset_m.is_finite()
            && lowest.is_finite()
            && highest.is_finite())
        {
            return Err(self.field_err(
                "encoding",
                format!(
                    "quantum {} m, offset {} m: expected a finite quantum > 0 and a finite offset \
                     whose codes ±{CODE_MAX} are finite heights",
                    e.quantum_m, e.offset_m
                ),
            ));
        }
        // The range of level 0 (what a reader takes as the terrain's height range): heights
        // the codes can hold, lowest first.
        if !(lowest <= f.min_m && f.min_m <= f.max_m && f.max_m <= highest) {
            return Err(self.field_err(
                "height range",
                format!(
                    "lowest min {} m, highest max {} m; expected finite heights, lowest first, \
                     within the encoding's {lowest} … {highest} m",
                    f.min_m, f.max_m
                ),
            ));
        }
        Ok(())
    }

    fn description(&self, f: &FixedHeader) -> Result<String, DemError> {
        String::from_utf8(self.bytes[FIXED_HEADER_LEN..FIXED_HEADER_LEN + f.desc_len].to_vec())
            .map_err(|_| self.field_err("description", "not UTF-8".into()))
    }

    /// The level table as stored, and each level's stored tile-index offset. In bounds: the
    /// header length was checked to hold it.
    fn level_table(&self, f: &FixedHeader) -> (Vec<LevelGeom>, Vec<u64>) {
        let bytes = self.bytes;
        let lay_prefix = FIXED_HEADER_LEN + f.desc_len.next_multiple_of(8);
        let mut levels = Vec::with_capacity(f.level_count);
        let mut index_offsets = Vec::with_capacity(f.level_count);
        for i in 0..f.level_count {
            let o = lay_prefix + LEVEL_ENTRY_LEN * i;
            levels.push(LevelGeom {
                cols: get_u32(bytes, o) as usize,
                rows: get_u32(bytes, o + 4) as usize,
                tiles_x: get_u32(bytes, o + 8) as usize,
                tiles_y: get_u32(bytes, o + 12) as usize,
                grid: GeoGrid {
                    cols: get_u32(bytes, o) as usize,
                    rows: get_u32(bytes, o + 4) as usize,
                    lon0_deg: get_f64(bytes, o + 16),
                    lat0_deg: get_f64(bytes, o + 24),
                    dlon_deg: get_f64(bytes, o + 32),
                    dlat_deg: get_f64(bytes, o + 40),
                },
            });
            index_offsets.push(get_u64(bytes, o + 48));
        }
        (levels, index_offsets)
    }

    /// The level table is the one level 0's grid implies: level count, wrap flag, extents and
    /// every level's geometry. Returns the wrap flag.
    fn check_levels(&self, f: &FixedHeader, levels: &[LevelGeom]) -> Result<bool, DemError> {
        let (tile_size, level_count, extents) = (f.tile_size, f.level_count, f.extents);
        let level0 = levels[0].grid;
        check_source_grid(&level0).map_err(|m| self.field_err("level 0 grid", m))?;
        let expected = level_geoms(&level0, tile_size);
        if expected.len() != level_count {
            return Err(self.field_err(
                "level count",
                format!(
                    "{level_count}, but a {} × {} level 0 in tiles of {tile_size} needs {} levels",
                    level0.cols,
                    level0.rows,
                    expected.len()
                ),
            ));
        }
        let wraps = f.flags & FLAG_WRAPS != 0;
        if wraps != level0.wraps_in_longitude() {
            return Err(self.field_err(
                "flags",
                format!(
                    "wrap flag {wraps}, but {} columns of {}° {} the circle",
                    level0.cols,
                    level0.dlon_deg,
                    if wraps { "do not cover" } else { "cover" }
                ),
            ));
        }
        let ext = extents_of(&level0);
        if !(close(ext.west_deg, extents.west_deg)
            && close(ext.east_deg, extents.east_deg)
            && close(ext.south_deg, extents.south_deg)
            && close(ext.north_deg, extents.north_deg))
        {
            return Err(self.field_err(
                "extents",
                format!("{extents:?} do not match the level-0 grid's footprint {ext:?}"),
            ));
        }
        for (i, (got, want)) in levels.iter().zip(&expected).enumerate() {
            let g = &got.grid;
            let w = &want.grid;
            if got.cols != want.cols
                || got.rows != want.rows
                || got.tiles_x != want.tiles_x
                || got.tiles_y != want.tiles_y
                || !close(g.lon0_deg, w.lon0_deg)
                || !close(g.lat0_deg, w.lat0_deg)
                || !close(g.dlon_deg, w.dlon_deg)
                || !close(g.dlat_deg, w.dlat_deg)
            {
                return Err(self.field_err(
                    &format!("level {i}"),
                    format!(
                        "{} × {} px in {} × {} tiles at ({}, {}) step ({}, {}); expected {} × {} px in {} × {} tiles at ({}, {}) step ({}, {})",
                        got.cols,
                        got.rows,
                        got.tiles_x,
                        got.tiles_y,
                        g.lon0_deg,
                        g.lat0_deg,
                        g.dlon_deg,
                        g.dlat_deg,
                        want.cols,
                        want.rows,
                        want.tiles_x,
                        want.tiles_y,
                        w.lon0_deg,
                        w.lat0_deg,
                        w.dlon_deg,
                        w.dlat_deg
                    ),
                ));
            }
        }
        Ok(wraps)
    }

    /// The stored lengths and offsets are the ones the level table implies: header length,
    /// tile count, each level's index offset, where tile data starts and the file's length.
    fn check_layout(
        &self,
        f: &FixedHeader,
        levels: &[LevelGeom],
        index_offsets: &[u64],
    ) -> Result<Layout, DemError> {
        let (header_len, tile_count) = (f.header_len, f.tile_count);
        // Guard the arithmetic below against a forged level table (tile counts that overflow).
        let tiles: Option<usize> = levels.iter().try_fold(0usize, |acc, l| {
            acc.checked_add(l.tiles_x.checked_mul(l.tiles_y)?)
        });
        if tiles.is_none_or(|t| t > (header_len - f.min_len) / INDEX_ENTRY_LEN) {
            return Err(self.field_err(
                "tile count",
                format!(
                    "the level table implies more tiles than a {header_len}-byte header can index"
                ),
            ));
        }
        let lay = layout(levels, f.tile_size, f.desc_len);
        if header_len != lay.header_len || tile_count != lay.tile_count as u64 {
            return Err(self.field_err(
                "header length",
                format!(
                    "{header_len} bytes and {tile_count} tiles; the level table implies {} bytes and {} tiles",
                    lay.header_len, lay.tile_count
                ),
            ));
        }
        for (i, (&got, &first)) in index_offsets.iter().zip(&lay.first_tile).enumerate() {
            let want = (lay.index_offset + INDEX_ENTRY_LEN * first) as u64;
            if got != want {
                return Err(self.field_err(
                    &format!("level {i} index offset"),
                    format!("{got}, expected {want}"),
                ));
            }
        }
        if f.tile_data_offset != lay.tile_data_offset || f.file_len != lay.file_len {
            return Err(self.field_err(
                "tile data",
                format!(
                    "tiles at {}, file length {}; the level table implies {} and {}",
                    f.tile_data_offset, f.file_len, lay.tile_data_offset, lay.file_len
                ),
            ));
        }
        Ok(lay)
    }

    /// The tile index: every payload in bounds, in order, not overlapping.
    fn tile_index(
        &self,
        f: &FixedHeader,
        levels: &[LevelGeom],
        lay: &Layout,
    ) -> Result<Vec<TileEntry>, DemError> {
        let file_len = f.file_len;
        let mut index = Vec::with_capacity(lay.tile_count);
        let mut end = f.tile_data_offset;
        for i in 0..lay.tile_count {
            let o = lay.index_offset + INDEX_ENTRY_LEN * i;
            let e = TileEntry {
                offset: get_u64(self.bytes, o),
                len: get_u32(self.bytes, o + 8),
                crc32: get_u32(self.bytes, o + 12),
            };
            if e.len as u64 != lay.tile_bytes
                || e.offset < end
                || !e.offset.is_multiple_of(2)
                || e.offset
                    .checked_add(e.len as u64)
                    .is_none_or(|x| x > file_len)
            {
                let (level, tx, ty) = tile_position(levels, &lay.first_tile, i);
                return Err(self.field_err(
                    "tile index",
                    format!(
                        "level {level} tile ({tx}, {ty}): offset {} length {} is out of place (expected length {}, from {end} on, within {file_len} bytes)",
                        e.offset, e.len, lay.tile_bytes
                    ),
                ));
            }
            end = e.offset + e.len as u64;
            index.push(e);
        }
        Ok(index)
    }

    /// The file is exactly as long as the header says. Checked last, so that a short file's
    /// message can say which tiles are missing.
    fn check_file_len(
        &self,
        f: &FixedHeader,
        levels: &[LevelGeom],
        lay: &Layout,
        index: &[TileEntry],
    ) -> Result<(), DemError> {
        let (actual_len, file_len) = (self.actual_len, f.file_len);
        if actual_len < file_len {
            let first_missing = index
                .iter()
                .position(|e| e.offset + e.len as u64 > actual_len)
                .unwrap_or(index.len() - 1);
            let (level, tx, ty) = tile_position(levels, &lay.first_tile, first_missing);
            let missing = index.len() - first_missing;
            return Err(self.truncated(
                file_len,
                format!(
                    "{} bytes of tile data: level {level} tile ({tx}, {ty}) onwards ({missing} of {} tiles incomplete)",
                    file_len - actual_len,
                    index.len()
                ),
            ));
        }
        if actual_len > file_len {
            return Err(DemError::Data {
                path: self.path.to_path_buf(),
                message: format!(
                    "{actual_len} bytes, but the header says {file_len}: {} unexpected bytes at the end (not this pyramid's file?)",
                    actual_len - file_len
                ),
            });
        }
        Ok(())
    }
}

/// (level, tx, ty) of the tile at position `i` of the index.
pub(crate) fn tile_position(
    levels: &[LevelGeom],
    first_tile: &[usize],
    i: usize,
) -> (usize, usize, usize) {
    let level = first_tile.iter().rposition(|&f| f <= i).unwrap_or(0);
    let k = i - first_tile[level];
    let tx = levels[level].tiles_x.max(1);
    (level, k % tx, k / tx)
}

/// Equal within a relative 1e-9; never for an infinity (whose difference is within any
/// infinite tolerance) or NaN.
fn close(a: f64, b: f64) -> bool {
    a.is_finite() && b.is_finite() && (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0)
}

fn put_u32(b: &mut Vec<u8>, v: u32) {
    b.extend_from_slice(&v.to_le_bytes());
}
fn put_u64(b: &mut Vec<u8>, v: u64) {
    b.extend_from_slice(&v.to_le_bytes());
}
fn put_f64(b: &mut Vec<u8>, v: f64) {
    b.extend_from_slice(&v.to_le_bytes());
}
fn get_u32(b: &[u8], o: usize) -> u32 {
    u32::from_le_bytes(b[o..o + 4].try_into().expect("4 bytes"))
}
fn get_u64(b: &[u8], o: usize) -> u64 {
    u64::from_le_bytes(b[o..o + 8].try_into().expect("8 bytes"))
}
fn get_f64(b: &[u8], o: usize) -> f64 {
    f64::from_le_bytes(b[o..o + 8].try_into().expect("8 bytes"))
}
