//! The `.HDR` file: `KEY value` lines, parsed, defaulted (as GDAL's EHdr driver does) and
//! validated. See the module documentation of [`crate::dem::ehdr`] for the rules.

use std::path::Path;

use crate::dem::{DemError, GeoGrid};

/// Headers are a few hundred bytes; anything much larger is not an EHdr header.
pub(crate) const MAX_HEADER_BYTES: u64 = 64 * 1024;

/// Largest NROWS/NCOLS accepted (GDAL's limit too).
const MAX_DIMENSION: i64 = i32::MAX as i64;

/// Largest NBANDS accepted.
const MAX_BANDS: i64 = 65_535;

/// Tolerance, in degrees, of the geographic plausibility checks.
const GEO_TOLERANCE_DEG: f64 = 1e-6;

/// Byte order of multi-byte samples (`BYTEORDER`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ByteOrder {
    /// `BYTEORDER M` (Motorola; GTOPO30).
    BigEndian,
    /// `BYTEORDER I` (Intel).
    LittleEndian,
}

impl ByteOrder {
    /// The value written after `BYTEORDER`.
    pub fn hdr_code(self) -> &'static str {
        match self {
            ByteOrder::BigEndian => "M",
            ByteOrder::LittleEndian => "I",
        }
    }
}

/// How bands are interleaved (`LAYOUT`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Layout {
    /// Band interleaved by line: row r of every band, then row r+1.
    Bil,
    /// Band interleaved by pixel.
    Bip,
    /// Band sequential: all of band 1, then all of band 2.
    Bsq,
}

impl Layout {
    pub fn name(self) -> &'static str {
        match self {
            Layout::Bil => "BIL",
            Layout::Bip => "BIP",
            Layout::Bsq => "BSQ",
        }
    }
}

/// How the bits of a sample are interpreted (`PIXELTYPE`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PixelType {
    SignedInt,
    UnsignedInt,
    Float,
}

impl PixelType {
    pub fn name(self) -> &'static str {
        match self {
            PixelType::SignedInt => "SIGNEDINT",
            PixelType::UnsignedInt => "UNSIGNEDINT",
            PixelType::Float => "FLOAT",
        }
    }
}

/// The stored type of one sample: `NBITS` and `PIXELTYPE` together.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SampleType {
    U8,
    I8,
    U16,
    I16,
    U32,
    I32,
    F32,
}

impl SampleType {
    /// Bytes per sample.
    pub fn bytes(self) -> usize {
        match self {
            SampleType::U8 | SampleType::I8 => 1,
            SampleType::U16 | SampleType::I16 => 2,
            SampleType::U32 | SampleType::I32 | SampleType::F32 => 4,
        }
    }

    /// `NBITS`.
    pub fn nbits(self) -> u32 {
        8 * self.bytes() as u32
    }

    /// `PIXELTYPE`.
    pub fn pixel_type(self) -> PixelType {
        match self {
            SampleType::U8 | SampleType::U16 | SampleType::U32 => PixelType::UnsignedInt,
            SampleType::I8 | SampleType::I16 | SampleType::I32 => PixelType::SignedInt,
            SampleType::F32 => PixelType::Float,
        }
    }

    /// The sample type of `NBITS nbits` + `PIXELTYPE pixel_type`, if there is one.
    pub fn from_parts(nbits: u32, pixel_type: PixelType) -> Option<SampleType> {
        match (nbits, pixel_type) {
            (8, PixelType::UnsignedInt) => Some(SampleType::U8),
            (8, PixelType::SignedInt) => Some(SampleType::I8),
            (16, PixelType::UnsignedInt) => Some(SampleType::U16),
            (16, PixelType::SignedInt) => Some(SampleType::I16),
            (32, PixelType::UnsignedInt) => Some(SampleType::U32),
            (32, PixelType::SignedInt) => Some(SampleType::I32),
            (32, PixelType::Float) => Some(SampleType::F32),
            _ => None,
        }
    }

    /// Inclusive range of the integer types; `None` for FLOAT.
    pub(crate) fn int_range(self) -> Option<(i64, i64)> {
        match self {
            SampleType::U8 => Some((0, u8::MAX as i64)),
            SampleType::I8 => Some((i8::MIN as i64, i8::MAX as i64)),
            SampleType::U16 => Some((0, u16::MAX as i64)),
            SampleType::I16 => Some((i16::MIN as i64, i16::MAX as i64)),
            SampleType::U32 => Some((0, u32::MAX as i64)),
            SampleType::I32 => Some((i32::MIN as i64, i32::MAX as i64)),
            SampleType::F32 => None,
        }
    }

    /// `"SIGNEDINT 16"` etc., for messages.
    pub fn describe(self) -> String {
        format!("{} {}", self.pixel_type().name(), self.nbits())
    }
}

/// A parsed and validated `.HDR`. Build it with [`EhdrHeader::parse`] (or by opening a raster);
/// every value has been defaulted and checked.
#[derive(Clone, Debug, PartialEq)]
pub struct EhdrHeader {
    pub nrows: usize,
    pub ncols: usize,
    pub nbands: usize,
    pub layout: Layout,
    pub byte_order: ByteOrder,
    pub sample_type: SampleType,
    pub skip_bytes: u64,
    pub band_row_bytes: u64,
    pub total_row_bytes: u64,
    pub band_gap_bytes: u64,
    /// `NODATA` (or `NODATA_VALUE`); may be NaN (`NODATA nan`).
    pub nodata: Option<f64>,
    /// Longitude of the centre of the upper-left pixel, degrees.
    pub ulxmap: f64,
    /// Latitude of the centre of the upper-left pixel, degrees.
    pub ulymap: f64,
    /// Column spacing, degrees.
    pub xdim: f64,
    /// Row spacing, degrees.
    pub ydim: f64,
    expected_len: u64,
}

/// What the data file tells the header parser (GDAL infers NBITS from the file size and FLOAT
/// from a `.FLT` extension when the header says nothing).
pub(crate) struct DataFileFacts {
    pub len: u64,
    pub is_flt: bool,
}

/// One recognised `KEY value` line.
struct Entry {
    key: &'static str,
    value: String,
    line: usize,
}

/// The keys that describe the data file (the georeferencing keys are [`GEO_KEYS`]).
const DATA_KEYS: &[&str] = &[
    "BYTEORDER",
    "LAYOUT",
    "NROWS",
    "NCOLS",
    "NBANDS",
    "NBITS",
    "PIXELTYPE",
    "BANDROWBYTES",
    "TOTALROWBYTES",
    "BANDGAPBYTES",
    "SKIPBYTES",
    "NODATA",
];

/// Every key that places the grid; at least one must be given.
const GEO_KEYS: &[&str] = &[
    "ULXMAP",
    "ULYMAP",
    "XDIM",
    "YDIM",
    "XLLCORNER",
    "YLLCORNER",
    "XLLCENTER",
    "YLLCENTER",
    "CELLSIZE",
];

fn canonical_key(token: &str) -> Option<&'static str> {
    if token.eq_ignore_ascii_case("NODATA_VALUE") {
        return Some("NODATA");
    }
    DATA_KEYS
        .iter()
        .chain(GEO_KEYS)
        .copied()
        .find(|k| k.eq_ignore_ascii_case(token))
}

fn header_error(path: &Path, field: &str, message: impl Into<String>) -> DemError {
    DemError::Header {
        path: path.to_path_buf(),
        field: field.to_string(),
        message: message.into(),
    }
}

/// The recognised entries of a header, one per key (a key given twice must repeat its value).
struct Entries<'p> {
    path: &'p Path,
    entries: Vec<Entry>,
}

impl<'p> Entries<'p> {
    fn parse(text: &str, path: &'p Path) -> Result<Self, DemError> {
        let mut entries: Vec<Entry> = Vec::new();
        let text = text.strip_prefix('\u{feff}').unwrap_or(text); // a byte-order mark
        for (index, line) in text.lines().enumerate() {
            let line_no = index + 1;
            let mut tokens = line.split_whitespace();
            let Some(first) = tokens.next() else {
                continue;
            };
            let Some(key) = canonical_key(first) else {
                continue; // unknown keys (and stray text) are ignored, as GDAL does
            };
            let Some(value) = tokens.next() else {
                return Err(header_error(
                    path,
                    key,
                    format!("line {line_no}: {key} has no value; expected `{key} <value>`"),
                ));
            };
            if let Some(previous) = entries.iter().find(|e| e.key == key) {
                if !previous.value.eq_ignore_ascii_case(value) {
                    return Err(header_error(
                        path,
                        key,
                        format!(
                            "given twice with different values ({:?} on line {}, {:?} on line \
                             {line_no}); expected one value",
                            previous.value, previous.line, value
                        ),
                    ));
                }
                continue;
            }
            entries.push(Entry {
                key,
                value: value.to_string(),
                line: line_no,
            });
        }
        Ok(Entries { path, entries })
    }

    fn get(&self, key: &str) -> Option<&Entry> {
        self.entries.iter().find(|e| e.key == key)
    }

    fn has(&self, key: &str) -> bool {
        self.get(key).is_some()
    }

    fn err(&self, field: &str, message: impl Into<String>) -> DemError {
        header_error(self.path, field, message)
    }

    /// The value of `key` parsed as `T`; an error saying it expected `what` when it is not one.
    fn parsed<T: std::str::FromStr>(&self, key: &str, what: &str) -> Result<Option<T>, DemError> {
        let Some(e) = self.get(key) else {
            return Ok(None);
        };
        e.value.parse::<T>().map(Some).map_err(|_| {
            self.err(
                key,
                format!("line {}: expected {what}, found {:?}", e.line, e.value),
            )
        })
    }

    fn int(&self, key: &str) -> Result<Option<i64>, DemError> {
        self.parsed(key, "an integer")
    }

    /// An integer within `lo..=hi`; outside it, an error saying it expected `expected`.
    fn int_within(
        &self,
        key: &str,
        lo: i64,
        hi: i64,
        expected: &str,
    ) -> Result<Option<i64>, DemError> {
        let Some(v) = self.int(key)? else {
            return Ok(None);
        };
        if v < lo || v > hi {
            let line = self.get(key).map_or(0, |e| e.line);
            return Err(self.err(key, format!("line {line}: expected {expected}, found {v}")));
        }
        Ok(Some(v))
    }

    /// A required integer in `1..=max`.
    fn positive(&self, key: &str, max: i64) -> Result<Option<usize>, DemError> {
        let expected = format!("a positive integer no larger than {max}");
        Ok(self.int_within(key, 1, max, &expected)?.map(|v| v as usize))
    }

    fn non_negative(&self, key: &str) -> Result<Option<u64>, DemError> {
        Ok(self
            .int_within(key, 0, i64::MAX, "a non-negative integer")?
            .map(|v| v as u64))
    }

    fn float(&self, key: &str) -> Result<Option<f64>, DemError> {
        self.parsed(key, "a number")
    }

    fn finite(&self, key: &str) -> Result<Option<f64>, DemError> {
        match self.float(key)? {
            Some(v) if !v.is_finite() => Err(self.err(
                key,
                format!("expected a finite number (degrees), found {v}"),
            )),
            other => Ok(other),
        }
    }

    fn pixel_size(&self, key: &str) -> Result<Option<f64>, DemError> {
        match self.float(key)? {
            Some(v) if !(v.is_finite() && v > 0.0) => Err(self.err(
                key,
                format!("expected a pixel size in degrees > 0, found {v}"),
            )),
            other => Ok(other),
        }
    }
}

fn checked(path: &Path, v: Option<u64>, what: &str) -> Result<u64, DemError> {
    v.ok_or_else(|| {
        header_error(
            path,
            "NROWS",
            format!("{what} overflows 64 bits; expected a header describing a file that can exist"),
        )
    })
}

/// `NROWS`, `NCOLS` (required) and `NBANDS` (default 1).
struct Dimensions {
    nrows: usize,
    ncols: usize,
    nbands: usize,
}

fn dimensions(e: &Entries) -> Result<Dimensions, DemError> {
    let nrows = e.positive("NROWS", MAX_DIMENSION)?.ok_or_else(|| {
        e.err(
            "NROWS",
            "missing required field; expected `NROWS <rows>` (is this an EHdr .HDR file?)",
        )
    })?;
    let ncols = e.positive("NCOLS", MAX_DIMENSION)?.ok_or_else(|| {
        e.err(
            "NCOLS",
            "missing required field; expected `NCOLS <columns>` (is this an EHdr .HDR file?)",
        )
    })?;
    let nbands = e.positive("NBANDS", MAX_BANDS)?.unwrap_or(1);
    Ok(Dimensions {
        nrows,
        ncols,
        nbands,
    })
}

/// `LAYOUT`, BIL when absent.
fn layout(e: &Entries) -> Result<Layout, DemError> {
    let Some(v) = e.get("LAYOUT") else {
        return Ok(Layout::Bil);
    };
    match v.value.to_ascii_uppercase().as_str() {
        "BIL" => Ok(Layout::Bil),
        "BIP" => Ok(Layout::Bip),
        "BSQ" => Ok(Layout::Bsq),
        _ => Err(e.err(
            "LAYOUT",
            format!("unknown layout {:?}; expected BIL, BIP or BSQ", v.value),
        )),
    }
}

/// `BYTEORDER`, big-endian (Motorola) when absent.
fn byte_order(e: &Entries) -> Result<ByteOrder, DemError> {
    let Some(v) = e.get("BYTEORDER") else {
        return Ok(ByteOrder::BigEndian);
    };
    match v.value.to_ascii_uppercase().as_str() {
        "M" | "MOTOROLA" | "MSBFIRST" => Ok(ByteOrder::BigEndian),
        "I" | "INTEL" | "L" | "LSBFIRST" => Ok(ByteOrder::LittleEndian),
        _ => Err(e.err(
            "BYTEORDER",
            format!(
                "unknown byte order {:?}; expected M (big-endian) or I (little-endian)",
                v.value
            ),
        )),
    }
}

/// `NBITS` + `PIXELTYPE`, with GDAL's defaults (inferred from the data file's size and name,
/// and from NODATA's sign, when absent).
fn sample_type(
    e: &Entries,
    dims: &Dimensions,
    nodata: Option<f64>,
    data: Option<&DataFileFacts>,
) -> Result<SampleType, DemError> {
    let given_type = match e.get("PIXELTYPE") {
        None => None,
        Some(v) => Some(match v.value.to_ascii_uppercase().as_str() {
            "SIGNEDINT" => PixelType::SignedInt,
            "UNSIGNEDINT" => PixelType::UnsignedInt,
            "FLOAT" => PixelType::Float,
            _ => {
                return Err(e.err(
                    "PIXELTYPE",
                    format!(
                        "unknown pixel type {:?}; expected SIGNEDINT, UNSIGNEDINT or FLOAT",
                        v.value
                    ),
                ));
            }
        }),
    };
    let given_bits = match e.int("NBITS")? {
        None => None,
        Some(b @ (8 | 16 | 32)) => Some(b as u32),
        Some(b) => {
            return Err(e.err(
                "NBITS",
                format!(
                    "unsupported NBITS {b}; expected 8, 16 or 32 (sub-byte, 24- and 64-bit \
                     samples are not supported)"
                ),
            ));
        }
    };
    let mut inferred_float = false;
    let nbits = match (given_bits, given_type) {
        (Some(b), _) => b,
        (None, Some(PixelType::Float)) => 32,
        (None, Some(_)) => 8,
        (None, None) => {
            // GDAL: bytes per pixel from the file size (integer division), 4 means FLOAT.
            let per_pixel = data.map_or(0, |d| {
                d.len / dims.ncols as u64 / dims.nrows as u64 / dims.nbands as u64
            });
            match per_pixel {
                1 | 2 => 8 * per_pixel as u32,
                4 => {
                    inferred_float = true;
                    32
                }
                _ => 8,
            }
        }
    };
    let pixel_type = match given_type {
        Some(t) => t,
        None if nbits == 32 && (inferred_float || data.is_some_and(|d| d.is_flt)) => {
            PixelType::Float
        }
        None if nodata.is_some_and(|v| v < 0.0) => PixelType::SignedInt,
        None => PixelType::UnsignedInt,
    };
    SampleType::from_parts(nbits, pixel_type).ok_or_else(|| {
        e.err(
            "NBITS",
            format!("PIXELTYPE FLOAT needs NBITS 32, found NBITS {nbits}"),
        )
    })
}

/// Row and band geometry in bytes, and the data file's exact length.
struct RowGeometry {
    band_row_bytes: u64,
    total_row_bytes: u64,
    band_gap_bytes: u64,
    skip_bytes: u64,
    expected_len: u64,
}

/// `BANDROWBYTES`, `TOTALROWBYTES`, `BANDGAPBYTES` and `SKIPBYTES`: defaulted, checked against
/// what the samples need, and summed (without overflow) into the data file's length.
fn row_geometry(
    e: &Entries,
    dims: &Dimensions,
    layout: Layout,
    sample_type: SampleType,
) -> Result<RowGeometry, DemError> {
    let path = e.path;
    let Dimensions {
        nrows,
        ncols,
        nbands,
    } = *dims;
    let item = sample_type.bytes() as u64;
    let min_band_row = checked(path, (ncols as u64).checked_mul(item), "NCOLS × bytes")?;
    let band_row_bytes = match e.non_negative("BANDROWBYTES")? {
        None => min_band_row,
        Some(v) if v < min_band_row => {
            return Err(e.err(
                "BANDROWBYTES",
                format!(
                    "BANDROWBYTES {v} is less than NCOLS {ncols} × {item} bytes = \
                     {min_band_row}; expected at least {min_band_row}"
                ),
            ));
        }
        Some(v) => v,
    };
    let min_total = match layout {
        Layout::Bip if nbands > 1 => checked(
            path,
            min_band_row.checked_mul(nbands as u64),
            "NCOLS × NBANDS × bytes",
        )?,
        _ => checked(
            path,
            band_row_bytes.checked_mul(nbands as u64),
            "NBANDS × BANDROWBYTES",
        )?,
    };
    let total_row_bytes = match e.non_negative("TOTALROWBYTES")? {
        None => min_total,
        Some(v) if v < min_total && layout != Layout::Bsq => {
            return Err(e.err(
                "TOTALROWBYTES",
                format!(
                    "TOTALROWBYTES {v} is less than NBANDS {nbands} × BANDROWBYTES \
                     {band_row_bytes} = {min_total}; expected at least {min_total}"
                ),
            ));
        }
        Some(v) => v,
    };
    let band_gap_bytes = e.non_negative("BANDGAPBYTES")?.unwrap_or(0);
    if band_gap_bytes != 0 && layout != Layout::Bsq {
        return Err(e.err(
            "BANDGAPBYTES",
            format!(
                "BANDGAPBYTES {band_gap_bytes} applies to LAYOUT BSQ only; expected 0 for \
                 LAYOUT {}",
                layout.name()
            ),
        ));
    }
    let skip_bytes = e.non_negative("SKIPBYTES")?.unwrap_or(0);
    let body = match layout {
        Layout::Bil | Layout::Bip => checked(
            path,
            (nrows as u64).checked_mul(total_row_bytes),
            "NROWS × TOTALROWBYTES",
        )?,
        Layout::Bsq => {
            let band = checked(
                path,
                (nrows as u64).checked_mul(band_row_bytes),
                "NROWS × BANDROWBYTES",
            )?;
            let bands = checked(
                path,
                band.checked_mul(nbands as u64),
                "NBANDS × NROWS × BANDROWBYTES",
            )?;
            let gaps = checked(
                path,
                band_gap_bytes.checked_mul(nbands as u64 - 1),
                "(NBANDS − 1) × BANDGAPBYTES",
            )?;
            checked(path, bands.checked_add(gaps), "the band data")?
        }
    };
    let expected_len = checked(path, body.checked_add(skip_bytes), "SKIPBYTES + data")?;
    Ok(RowGeometry {
        band_row_bytes,
        total_row_bytes,
        band_gap_bytes,
        skip_bytes,
        expected_len,
    })
}

/// The upper-left pixel centre and the pixel size, degrees.
struct Georeference {
    ulxmap: f64,
    ulymap: f64,
    xdim: f64,
    ydim: f64,
}

/// Pixel size, upper-left pixel centre (from ULXMAP/ULYMAP or GDAL's corner and centre
/// alternatives), and a check that the grid is geographic.
fn georeferencing(e: &Entries, dims: &Dimensions) -> Result<Georeference, DemError> {
    if !GEO_KEYS.iter().any(|k| e.has(k)) {
        return Err(e.err(
            "ULXMAP",
            "no georeferencing: ULXMAP, ULYMAP, XDIM and YDIM are all absent; expected the \
             longitude/latitude of the upper-left pixel centre and the pixel size in degrees",
        ));
    }
    let (xdim, ydim) = pixel_size(e)?;
    let (ulxmap, ulymap) = upper_left_centre(e, dims.nrows, xdim, ydim)?;
    let geo = Georeference {
        ulxmap,
        ulymap,
        xdim,
        ydim,
    };
    check_geographic(e, dims, &geo)?;
    Ok(geo)
}

/// `XDIM`, `YDIM` (default 1) or `CELLSIZE` for both; a CELLSIZE must agree with them.
fn pixel_size(e: &Entries) -> Result<(f64, f64), DemError> {
    let cellsize = e.pixel_size("CELLSIZE")?;
    let mut xdim = e.pixel_size("XDIM")?;
    let mut ydim = e.pixel_size("YDIM")?;
    if let Some(c) = cellsize {
        for (key, dim) in [("XDIM", &mut xdim), ("YDIM", &mut ydim)] {
            match *dim {
                Some(d) if d != c => {
                    return Err(e.err(
                        key,
                        format!("{key} {d} disagrees with CELLSIZE {c}; expected one of them"),
                    ));
                }
                _ => *dim = Some(c),
            }
        }
    }
    Ok((xdim.unwrap_or(1.0), ydim.unwrap_or(1.0)))
}

/// Longitude and latitude of the upper-left pixel centre, from one of ULXMAP / XLLCORNER /
/// XLLCENTER and one of ULYMAP / YLLCORNER / YLLCENTER (corners with corners); 0.5 when absent.
fn upper_left_centre(
    e: &Entries,
    nrows: usize,
    xdim: f64,
    ydim: f64,
) -> Result<(f64, f64), DemError> {
    let one_of = |keys: [&'static str; 3]| -> Result<Option<&'static str>, DemError> {
        let given: Vec<&str> = keys.iter().copied().filter(|k| e.has(k)).collect();
        match given.as_slice() {
            [] => Ok(None),
            [k] => Ok(Some(k)),
            [a, b, ..] => Err(e.err(
                a,
                format!(
                    "{a} and {b} both given; expected one of {}",
                    keys.join(", ")
                ),
            )),
        }
    };
    let x_key = one_of(["ULXMAP", "XLLCORNER", "XLLCENTER"])?;
    let y_key = one_of(["ULYMAP", "YLLCORNER", "YLLCENTER"])?;
    let corner = |k: Option<&str>| k.map(|k| k.ends_with("CORNER"));
    if let (Some(xc), Some(yc)) = (corner(x_key), corner(y_key))
        && xc != yc
    {
        return Err(e.err(
            y_key.unwrap_or("ULYMAP"),
            format!(
                "{} mixed with {}: expected both pixel corners (XLLCORNER/YLLCORNER) or both \
                 pixel centres",
                x_key.unwrap_or("?"),
                y_key.unwrap_or("?")
            ),
        ));
    }
    let ulxmap = match x_key {
        None => 0.5,
        Some(k) => {
            let v = e.finite(k)?.unwrap_or(0.5);
            if k == "XLLCORNER" { v + 0.5 * xdim } else { v }
        }
    };
    let span_y = (nrows - 1) as f64 * ydim;
    let ulymap = match y_key {
        None => 0.5,
        Some(k) => {
            let v = e.finite(k)?.unwrap_or(0.5);
            match k {
                "YLLCORNER" => v + span_y + 0.5 * ydim,
                "YLLCENTER" => v + span_y,
                _ => v,
            }
        }
    };
    Ok((ulxmap, ulymap))
}

/// Only geographic grids make sense on a globe: pixel centres within ±90° latitude, at most
/// 360° of longitude, a first longitude within ±360°.
fn check_geographic(e: &Entries, dims: &Dimensions, geo: &Georeference) -> Result<(), DemError> {
    let Georeference {
        ulxmap,
        ulymap,
        xdim,
        ydim,
    } = *geo;
    let (nrows, ncols) = (dims.nrows, dims.ncols);
    let bottom = ulymap - (nrows - 1) as f64 * ydim;
    if !(ulymap <= 90.0 + GEO_TOLERANCE_DEG && bottom >= -90.0 - GEO_TOLERANCE_DEG) {
        return Err(e.err(
            "ULYMAP",
            format!(
                "pixel centres span latitudes {ulymap}° to {bottom}° (ULYMAP {ulymap}, YDIM \
                 {ydim}, NROWS {nrows}); expected them within [-90°, 90°]: only geographic \
                 latitude/longitude grids are supported"
            ),
        ));
    }
    let width = ncols as f64 * xdim;
    if width > 360.0 + GEO_TOLERANCE_DEG {
        return Err(e.err(
            "XDIM",
            format!(
                "the grid is {width}° wide (NCOLS {ncols} × XDIM {xdim}); expected at most 360° \
                 of longitude"
            ),
        ));
    }
    if !(-360.0..=360.0).contains(&ulxmap) {
        return Err(e.err(
            "ULXMAP",
            format!("ULXMAP {ulxmap} is not a longitude; expected a value within ±360°"),
        ));
    }
    Ok(())
}

impl EhdrHeader {
    /// Parses and validates a header on its own. Without the data file, NBITS absent means 8
    /// (32 for FLOAT) and PIXELTYPE absent is decided from NODATA's sign; opening a raster also
    /// applies GDAL's inferences from the data file (see the module documentation).
    pub fn parse(text: &str, hdr_path: &Path) -> Result<EhdrHeader, DemError> {
        Self::parse_inner(text, hdr_path, None)
    }

    pub(crate) fn parse_inner(
        text: &str,
        path: &Path,
        data: Option<&DataFileFacts>,
    ) -> Result<EhdrHeader, DemError> {
        let e = Entries::parse(text, path)?;
        let dims = dimensions(&e)?;
        let layout = layout(&e)?;
        let byte_order = byte_order(&e)?;
        let nodata = e.float("NODATA")?;
        let sample_type = sample_type(&e, &dims, nodata, data)?;
        let rows = row_geometry(&e, &dims, layout, sample_type)?;
        let geo = georeferencing(&e, &dims)?;
        Ok(EhdrHeader {
            nrows: dims.nrows,
            ncols: dims.ncols,
            nbands: dims.nbands,
            layout,
            byte_order,
            sample_type,
            skip_bytes: rows.skip_bytes,
            band_row_bytes: rows.band_row_bytes,
            total_row_bytes: rows.total_row_bytes,
            band_gap_bytes: rows.band_gap_bytes,
            nodata,
            ulxmap: geo.ulxmap,
            ulymap: geo.ulymap,
            xdim: geo.xdim,
            ydim: geo.ydim,
            expected_len: rows.expected_len,
        })
    }

    /// The grid of pixel centres (row 0 northernmost).
    pub fn grid(&self) -> GeoGrid {
        GeoGrid {
            cols: self.ncols,
            rows: self.nrows,
            lon0_deg: self.ulxmap,
            lat0_deg: self.ulymap,
            dlon_deg: self.xdim,
            dlat_deg: self.ydim,
        }
    }

    /// The exact length of the data file this header describes, in bytes.
    pub fn expected_data_len(&self) -> u64 {
        self.expected_len
    }

    /// How the expected length is made up, for messages.
    pub fn describe_data_len(&self) -> String {
        let body = match self.layout {
            Layout::Bil | Layout::Bip => format!(
                "NROWS {} × TOTALROWBYTES {}",
                self.nrows, self.total_row_bytes
            ),
            Layout::Bsq => format!(
                "NBANDS {} × NROWS {} × BANDROWBYTES {} + (NBANDS − 1) × BANDGAPBYTES {}",
                self.nbands, self.nrows, self.band_row_bytes, self.band_gap_bytes
            ),
        };
        format!("SKIPBYTES {} + {body}", self.skip_bytes)
    }

    /// Bytes from one sample of band 1 to the next along a row.
    pub(crate) fn pixel_stride(&self) -> u64 {
        match self.layout {
            Layout::Bip => (self.sample_type.bytes() * self.nbands) as u64,
            Layout::Bil | Layout::Bsq => self.sample_type.bytes() as u64,
        }
    }

    /// Bytes from one row of band 1 to the next.
    pub(crate) fn row_stride(&self) -> u64 {
        match self.layout {
            Layout::Bil | Layout::Bip => self.total_row_bytes,
            Layout::Bsq => self.band_row_bytes,
        }
    }

    /// Bytes spanned by one row of band 1, from its first sample to the end of its last.
    pub(crate) fn row_span(&self) -> u64 {
        (self.ncols as u64 - 1) * self.pixel_stride() + self.sample_type.bytes() as u64
    }
}
