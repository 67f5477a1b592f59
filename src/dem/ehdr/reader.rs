//! One EHdr raster: the header, its memory-mapped data file, and band 1 decoded by row.

use std::path::{Path, PathBuf};

use super::header::{ByteOrder, DataFileFacts, EhdrHeader, MAX_HEADER_BYTES, SampleType};
use super::sample::{self, PixelSource};
use crate::dem::mapped::{MappedFile, OpenFile};
use crate::dem::{DemError, GeoGrid, RasterSource};

/// Extensions (any case) a data file next to a `.HDR` may have.
const DATA_EXTENSIONS: &[&str] = &["DEM", "BIL", "FLT", "BIP", "BSQ"];

/// How NODATA is recognised in decoded samples.
#[derive(Clone, Copy, Debug)]
struct NodataRule {
    /// For integer rasters: NODATA when it is a whole number within the type's range.
    int: Option<i64>,
    /// For FLOAT rasters: NODATA rounded to f32 (compared bit-for-bit as a value).
    float: Option<f32>,
    /// `NODATA nan`: NaN samples are no-data rather than errors.
    nan: bool,
}

impl NodataRule {
    fn new(nodata: Option<f64>, sample_type: SampleType) -> NodataRule {
        let Some(v) = nodata else {
            return NodataRule {
                int: None,
                float: None,
                nan: false,
            };
        };
        let int = match sample_type.int_range() {
            Some((lo, hi)) if v.fract() == 0.0 && v >= lo as f64 && v <= hi as f64 => {
                Some(v as i64)
            }
            _ => None,
        };
        NodataRule {
            int,
            float: if v.is_nan() { None } else { Some(v as f32) },
            nan: v.is_nan(),
        }
    }
}

/// An EHdr/BIL raster (band 1), memory-mapped.
pub struct EhdrRaster {
    header: EhdrHeader,
    hdr_path: PathBuf,
    data_path: PathBuf,
    map: MappedFile,
    nodata: NodataRule,
}

impl std::fmt::Debug for EhdrRaster {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EhdrRaster")
            .field("hdr_path", &self.hdr_path)
            .field("data_path", &self.data_path)
            .field("header", &self.header)
            .finish()
    }
}

fn io_error(path: &Path, source: std::io::Error) -> DemError {
    DemError::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn file_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

/// Files in `dir` whose stem is `stem` and whose extension is one of `exts` (any case). Exact
/// stem matches win over case-insensitive ones.
fn siblings(dir: &Path, stem: &str, exts: &[&str]) -> Result<Vec<PathBuf>, DemError> {
    let listing = std::fs::read_dir(dir).map_err(|e| io_error(dir, e))?;
    let mut exact = Vec::new();
    let mut loose = Vec::new();
    for entry in listing {
        let entry = entry.map_err(|e| io_error(dir, e))?;
        let path = entry.path();
        let (Some(s), Some(x)) = (path.file_stem(), path.extension()) else {
            continue;
        };
        let (s, x) = (s.to_string_lossy(), x.to_string_lossy());
        if !exts.iter().any(|e| e.eq_ignore_ascii_case(&x)) || !path.is_file() {
            continue;
        }
        if s == stem {
            exact.push(path);
        } else if s.eq_ignore_ascii_case(stem) {
            loose.push(path);
        }
    }
    let mut found = if exact.is_empty() { loose } else { exact };
    found.sort();
    Ok(found)
}

/// The (header, data file) pair for a path naming either of them.
fn locate(path: &Path) -> Result<(PathBuf, PathBuf), DemError> {
    if path.is_dir() {
        return Err(DemError::Data {
            path: path.to_path_buf(),
            message: "is a folder; expected a .HDR or its data file (open a folder of tiles \
                      with EhdrMosaic::open_dir)"
                .into(),
        });
    }
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let is_hdr = path
        .extension()
        .is_some_and(|x| x.eq_ignore_ascii_case("hdr"));
    if is_hdr {
        if !path.is_file() {
            return Err(DemError::Missing {
                path: path.to_path_buf(),
                message: "header file not found; expected an EHdr .HDR file".into(),
            });
        }
        let data = siblings(&dir, &stem, DATA_EXTENSIONS)?;
        match data.as_slice() {
            [one] => Ok((path.to_path_buf(), one.clone())),
            [] => Err(DemError::Missing {
                path: path.to_path_buf(),
                message: format!(
                    "data file missing: expected {stem}.DEM (or .BIL, .FLT, .BIP, .BSQ, any \
                     case) next to this header"
                ),
            }),
            [a, b, ..] => Err(DemError::Data {
                path: path.to_path_buf(),
                message: format!(
                    "ambiguous data file: both {} and {} match this header; expected exactly one",
                    file_name(a),
                    file_name(b)
                ),
            }),
        }
    } else {
        if !path.is_file() {
            return Err(DemError::Missing {
                path: path.to_path_buf(),
                message: "data file not found; expected an EHdr data file (.DEM, .BIL, …) \
                          with a .HDR next to it"
                    .into(),
            });
        }
        let headers = siblings(&dir, &stem, &["HDR"])?;
        match headers.as_slice() {
            [one] => Ok((one.clone(), path.to_path_buf())),
            [] => Err(DemError::Missing {
                path: dir.join(format!("{stem}.HDR")),
                message: format!(
                    "header file missing: expected {stem}.HDR (or .hdr) next to data file {}",
                    file_name(path)
                ),
            }),
            [a, b, ..] => Err(DemError::Data {
                path: path.to_path_buf(),
                message: format!(
                    "ambiguous header: both {} and {} match this data file; expected exactly one",
                    file_name(a),
                    file_name(b)
                ),
            }),
        }
    }
}

fn read_header_text(path: &Path) -> Result<String, DemError> {
    let len = std::fs::metadata(path)
        .map_err(|e| io_error(path, e))?
        .len();
    if len > MAX_HEADER_BYTES {
        return Err(header_too_long(path, len));
    }
    let bytes = std::fs::read(path).map_err(|e| io_error(path, e))?;
    header_text(&bytes, path)
}

fn header_too_long(path: &Path, len: u64) -> DemError {
    DemError::Header {
        path: path.to_path_buf(),
        field: "(file)".into(),
        message: format!(
            "header is {len} bytes; expected a short text file of `KEY value` lines (at most \
             {MAX_HEADER_BYTES} bytes) — is this an EHdr .HDR?"
        ),
    }
}

/// The header's text (invalid UTF-8 replaced: only ASCII keys and numbers matter).
fn header_text(bytes: &[u8], path: &Path) -> Result<String, DemError> {
    if bytes.len() as u64 > MAX_HEADER_BYTES {
        return Err(header_too_long(path, bytes.len() as u64));
    }
    Ok(String::from_utf8_lossy(bytes).into_owned())
}

/// One decoding loop: `conv` turns a sample's bytes into a value, NODATA becomes NaN.
macro_rules! run_int {
    ($chunks:expr, $out:expr, $conv:expr, $nd:expr) => {
        match $nd {
            None => {
                for (o, c) in $out.iter_mut().zip($chunks) {
                    *o = $conv(c) as f32;
                }
            }
            Some(nd) => {
                for (o, c) in $out.iter_mut().zip($chunks) {
                    let v = $conv(c);
                    *o = if v == nd { f32::NAN } else { v as f32 };
                }
            }
        }
    };
}

/// Decodes integer samples, one per `stride` bytes. Contiguous samples (the usual case) go
/// through `chunks_exact`, which the compiler turns into a vectorised loop.
macro_rules! decode_int {
    ($t:ty, $n:literal, $bytes:expr, $stride:expr, $out:expr, $order:expr, $nd:expr) => {{
        let nd: Option<$t> = $nd.and_then(|v: i64| <$t>::try_from(v).ok());
        let raw = |c: &[u8]| -> [u8; $n] { c.first_chunk::<$n>().copied().unwrap_or([0; $n]) };
        let be = |c: &[u8]| <$t>::from_be_bytes(raw(c));
        let le = |c: &[u8]| <$t>::from_le_bytes(raw(c));
        match ($stride == $n, $order) {
            (true, ByteOrder::BigEndian) => run_int!($bytes.chunks_exact($n), $out, be, nd),
            (true, ByteOrder::LittleEndian) => run_int!($bytes.chunks_exact($n), $out, le, nd),
            (false, ByteOrder::BigEndian) => run_int!($bytes.chunks($stride), $out, be, nd),
            (false, ByteOrder::LittleEndian) => run_int!($bytes.chunks($stride), $out, le, nd),
        }
        None
    }};
}

/// Decodes `out.len()` samples from `bytes` (one every `stride` bytes). NODATA becomes NaN.
/// For FLOAT rasters, returns the first position holding a non-finite value that is not NODATA
/// (with the value), after decoding the whole row (bad samples become NaN).
fn decode(
    sample_type: SampleType,
    order: ByteOrder,
    bytes: &[u8],
    stride: usize,
    nodata: NodataRule,
    out: &mut [f32],
) -> Option<(usize, f32)> {
    match sample_type {
        SampleType::U8 => {
            let nd = nodata.int.and_then(|v| u8::try_from(v).ok());
            for (o, c) in out.iter_mut().zip(bytes.chunks(stride)) {
                let v = c.first().copied().unwrap_or(0);
                *o = if Some(v) == nd { f32::NAN } else { v as f32 };
            }
            None
        }
        SampleType::I8 => {
            let nd = nodata.int.and_then(|v| i8::try_from(v).ok());
            for (o, c) in out.iter_mut().zip(bytes.chunks(stride)) {
                let v = c.first().copied().unwrap_or(0) as i8;
                *o = if Some(v) == nd { f32::NAN } else { v as f32 };
            }
            None
        }
        SampleType::U16 => decode_int!(u16, 2, bytes, stride, out, order, nodata.int),
        SampleType::I16 => decode_int!(i16, 2, bytes, stride, out, order, nodata.int),
        SampleType::U32 => decode_int!(u32, 4, bytes, stride, out, order, nodata.int),
        SampleType::I32 => decode_int!(i32, 4, bytes, stride, out, order, nodata.int),
        SampleType::F32 => {
            // Decode the bits first (a vectorisable loop), then map NODATA and catch non-finite
            // values.
            let raw = |c: &[u8]| c.first_chunk::<4>().copied().unwrap_or([0; 4]);
            let be = |c: &[u8]| f32::from_bits(u32::from_be_bytes(raw(c)));
            let le = |c: &[u8]| f32::from_bits(u32::from_le_bytes(raw(c)));
            let none: Option<f32> = None;
            match (stride == 4, order) {
                (true, ByteOrder::BigEndian) => run_int!(bytes.chunks_exact(4), out, be, none),
                (true, ByteOrder::LittleEndian) => run_int!(bytes.chunks_exact(4), out, le, none),
                (false, ByteOrder::BigEndian) => run_int!(bytes.chunks(stride), out, be, none),
                (false, ByteOrder::LittleEndian) => run_int!(bytes.chunks(stride), out, le, none),
            }
            let mut bad = None;
            for (i, o) in out.iter_mut().enumerate() {
                let v = *o;
                if Some(v) == nodata.float {
                    *o = f32::NAN;
                } else if !v.is_finite() {
                    if !(v.is_nan() && nodata.nan) && bad.is_none() {
                        bad = Some((i, v));
                    }
                    *o = f32::NAN;
                }
            }
            bad
        }
    }
}

/// The header, parsed with GDAL's inferences from the data file and checked against the data
/// file's length `len`, which must be exactly what the header implies.
fn checked_header(
    text: &str,
    hdr_path: &Path,
    data_path: &Path,
    len: u64,
) -> Result<EhdrHeader, DemError> {
    let facts = DataFileFacts {
        len,
        is_flt: data_path
            .extension()
            .is_some_and(|x| x.eq_ignore_ascii_case("flt")),
    };
    let header = EhdrHeader::parse_inner(text, hdr_path, Some(&facts))?;
    let expected = header.expected_data_len();
    if len != expected {
        let verdict = if len < expected {
            "shorter than that (truncated?)".to_string()
        } else {
            format!(
                "{} bytes longer than that (GDAL tolerates trailing bytes; we reject them: the \
                 header may not describe this file)",
                len - expected
            )
        };
        return Err(DemError::Data {
            path: data_path.to_path_buf(),
            message: format!(
                "data file is {len} bytes but {} implies exactly {expected} bytes ({}, {}); it \
                 is {verdict}",
                file_name(hdr_path),
                header.describe_data_len(),
                header.sample_type.describe(),
            ),
        });
    }
    Ok(header)
}

impl EhdrRaster {
    /// Opens a raster from its `.HDR` or its data file (`.DEM`, `.BIL`, `.FLT`, `.BIP`, `.BSQ`,
    /// any case), validating the header against the data file; see the module documentation.
    pub fn open(path: &Path) -> Result<EhdrRaster, DemError> {
        let (hdr_path, data_path) = locate(path)?;
        let text = read_header_text(&hdr_path)?;
        let file = OpenFile::open(&data_path)?;
        let header = checked_header(&text, &hdr_path, &data_path, file.len())?;
        // The map is checked to be as long as measured above, which the header was checked
        // against.
        let map = file.map()?;
        Ok(EhdrRaster::with(header, hdr_path, data_path, map))
    }

    /// A raster whose header and data file are already in memory, validated exactly as
    /// [`EhdrRaster::open`] validates files (the paths name them in errors; the data file's
    /// extension counts, as for a file: `.FLT` implies FLOAT). For tests and the fuzz harness,
    /// which hand the reader bytes without files.
    pub fn from_bytes(
        header: &[u8],
        hdr_path: impl AsRef<Path>,
        data: Vec<u8>,
        data_path: impl AsRef<Path>,
    ) -> Result<EhdrRaster, DemError> {
        let (hdr_path, data_path) = (hdr_path.as_ref(), data_path.as_ref());
        let text = header_text(header, hdr_path)?;
        let header = checked_header(&text, hdr_path, data_path, data.len() as u64)?;
        let map = MappedFile::from_bytes(data_path, data);
        Ok(EhdrRaster::with(
            header,
            hdr_path.to_path_buf(),
            data_path.to_path_buf(),
            map,
        ))
    }

    fn with(header: EhdrHeader, hdr_path: PathBuf, data_path: PathBuf, map: MappedFile) -> Self {
        let nodata = NodataRule::new(header.nodata, header.sample_type);
        EhdrRaster {
            header,
            hdr_path,
            data_path,
            map,
            nodata,
        }
    }

    pub fn header(&self) -> &EhdrHeader {
        &self.header
    }

    pub fn header_path(&self) -> &Path {
        &self.hdr_path
    }

    pub fn data_path(&self) -> &Path {
        &self.data_path
    }

    /// The grid of pixel centres.
    pub fn grid(&self) -> GeoGrid {
        self.header.grid()
    }

    fn out_of_range(&self, row: usize, col: usize) -> DemError {
        DemError::Data {
            path: self.data_path.clone(),
            message: format!(
                "row {row}, column {col} is outside the raster; expected row < NROWS {} and \
                 column < NCOLS {}",
                self.header.nrows, self.header.ncols
            ),
        }
    }

    fn non_finite(&self, row: usize, col: usize, v: f32) -> DemError {
        let g = self.grid();
        DemError::Data {
            path: self.data_path.clone(),
            message: format!(
                "row {row}, column {col} (lat {:.6}°, lon {:.6}°) holds {v} in a FLOAT raster; \
                 expected finite heights (declare `NODATA nan` in {} if NaN marks missing data)",
                g.lat_of_row(row as f64),
                g.lon_of_col(col as f64),
                file_name(&self.hdr_path)
            ),
        }
    }

    /// The bytes of row `row` of band 1, from its first sample to the end of its last.
    fn row_bytes(&self, row: usize) -> Result<&[u8], DemError> {
        let h = &self.header;
        let start = h.skip_bytes + row as u64 * h.row_stride();
        let end = start + h.row_span();
        self.map
            .get(start as usize..end as usize)
            .ok_or_else(|| self.out_of_range(row, 0))
    }

    /// The value at (row, col): `Ok(None)` for NODATA, an error outside the raster or for a
    /// non-finite FLOAT sample.
    pub fn value(&self, row: usize, col: usize) -> Result<Option<f32>, DemError> {
        let h = &self.header;
        if row >= h.nrows || col >= h.ncols {
            return Err(self.out_of_range(row, col));
        }
        let bytes = self.row_bytes(row)?;
        let start = col * h.pixel_stride() as usize;
        let Some(sample) = bytes.get(start..start + h.sample_type.bytes()) else {
            return Err(self.out_of_range(row, col));
        };
        let mut out = [0.0f32];
        if let Some((_, v)) = decode(
            h.sample_type,
            h.byte_order,
            sample,
            h.sample_type.bytes(),
            self.nodata,
            &mut out,
        ) {
            return Err(self.non_finite(row, col, v));
        }
        Ok(Some(out[0]).filter(|v| !v.is_nan()))
    }

    /// The nearest pixel to (lat, lon), GDAL's rule (`floor` of the continuous pixel
    /// coordinate, pixel edges belonging to the pixel east/south of them); `None` outside.
    pub fn pixel_of(&self, lat_deg: f64, lon_deg: f64) -> Option<(usize, usize)> {
        sample::pixel_of(&self.grid(), lat_deg, lon_deg)
    }

    /// The value of the pixel containing (lat, lon); `Ok(None)` for NODATA or outside.
    pub fn sample_nearest(&self, lat_deg: f64, lon_deg: f64) -> Result<Option<f32>, DemError> {
        sample::nearest(self, lat_deg, lon_deg)
    }

    /// Bilinear interpolation between the four surrounding pixel centres (a pixel centre returns
    /// its stored value exactly; NODATA neighbours are left out and the weights renormalised;
    /// within half a pixel of the edge the edge pixels are extended). `Ok(None)` outside the
    /// raster or where all contributing pixels are NODATA.
    pub fn sample_bilinear(&self, lat_deg: f64, lon_deg: f64) -> Result<Option<f64>, DemError> {
        sample::bilinear(self, lat_deg, lon_deg)
    }
}

impl PixelSource for EhdrRaster {
    fn pixel_grid(&self) -> GeoGrid {
        self.grid()
    }

    fn pixel(&self, row: usize, col: usize) -> Result<Option<f32>, DemError> {
        self.value(row, col)
    }
}

impl RasterSource for EhdrRaster {
    fn grid(&self) -> GeoGrid {
        self.header.grid()
    }

    /// Decodes row `row` of band 1 from the memory map in one pass. NODATA becomes NaN; a NaN
    /// or ±inf in a FLOAT raster (not declared NODATA) is an error naming its first column.
    fn read_row(&self, row: usize, out: &mut [f32]) -> Result<(), DemError> {
        let h = &self.header;
        if row >= h.nrows {
            return Err(self.out_of_range(row, 0));
        }
        if out.len() != h.ncols {
            return Err(DemError::Data {
                path: self.data_path.clone(),
                message: format!(
                    "read_row was given a buffer of {} values; expected NCOLS {}",
                    out.len(),
                    h.ncols
                ),
            });
        }
        let bytes = self.row_bytes(row)?;
        match decode(
            h.sample_type,
            h.byte_order,
            bytes,
            h.pixel_stride() as usize,
            self.nodata,
            out,
        ) {
            Some((col, v)) => Err(self.non_finite(row, col, v)),
            None => Ok(()),
        }
    }

    fn describe(&self) -> String {
        let h = &self.header;
        format!(
            "EHdr {} ({}×{}, {}, BYTEORDER {}, LAYOUT {})",
            self.data_path.display(),
            h.ncols,
            h.nrows,
            h.sample_type.describe(),
            h.byte_order.hdr_code(),
            h.layout.name()
        )
    }
}
