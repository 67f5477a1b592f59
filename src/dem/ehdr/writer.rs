//! Writes single-band BIL rasters with a GTOPO30-style `.HDR` (for tests and `globe-data synth`).

use std::ffi::OsString;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use super::header::{ByteOrder, PixelType, SampleType};
use crate::dem::{DemError, GeoGrid};

/// How [`write_ehdr`] stores samples.
#[derive(Clone, Debug, PartialEq)]
pub struct EhdrWriteOptions {
    pub sample_type: SampleType,
    pub byte_order: ByteOrder,
    /// Written for NaN input; must be representable in `sample_type`.
    pub nodata: Option<f64>,
    /// Extension of the data file, without the dot (`DEM` for GTOPO30, `BIL`, …).
    pub data_extension: String,
}

impl EhdrWriteOptions {
    /// GTOPO30's format: big-endian signed 16-bit, `NODATA -9999`, `.DEM`.
    pub fn gtopo30() -> EhdrWriteOptions {
        EhdrWriteOptions {
            sample_type: SampleType::I16,
            byte_order: ByteOrder::BigEndian,
            nodata: Some(-9999.0),
            data_extension: "DEM".into(),
        }
    }
}

/// The files [`write_ehdr`] wrote.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EhdrWritten {
    pub header_path: PathBuf,
    pub data_path: PathBuf,
}

fn with_suffix(stem: &Path, ext: &str) -> PathBuf {
    let mut s: OsString = stem.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

/// The header text: GTOPO30's keys in GTOPO30's order, plus `PIXELTYPE` where GDAL's default
/// would read the samples otherwise (FLOAT; signed types without a negative NODATA).
fn header_text(grid: &GeoGrid, options: &EhdrWriteOptions) -> String {
    let st = options.sample_type;
    let row_bytes = grid.cols * st.bytes();
    let needs_pixeltype = match st.pixel_type() {
        PixelType::Float => true,
        PixelType::SignedInt => !options.nodata.is_some_and(|v| v < 0.0),
        PixelType::UnsignedInt => false,
    };
    let mut lines: Vec<(&str, String)> = vec![
        ("BYTEORDER", options.byte_order.hdr_code().to_string()),
        ("LAYOUT", "BIL".into()),
        ("NROWS", grid.rows.to_string()),
        ("NCOLS", grid.cols.to_string()),
        ("NBANDS", "1".into()),
        ("NBITS", st.nbits().to_string()),
    ];
    if needs_pixeltype {
        lines.push(("PIXELTYPE", st.pixel_type().name().into()));
    }
    lines.extend([
        ("BANDROWBYTES", row_bytes.to_string()),
        ("TOTALROWBYTES", row_bytes.to_string()),
        ("BANDGAPBYTES", "0".into()),
    ]);
    if let Some(v) = options.nodata {
        lines.push((
            "NODATA",
            if v.is_nan() {
                "nan".into()
            } else {
                v.to_string()
            },
        ));
    }
    lines.extend([
        ("ULXMAP", grid.lon0_deg.to_string()),
        ("ULYMAP", grid.lat0_deg.to_string()),
        ("XDIM", grid.dlon_deg.to_string()),
        ("YDIM", grid.dlat_deg.to_string()),
    ]);
    lines.iter().map(|(k, v)| format!("{k:<14}{v}\n")).collect()
}

/// Appends one sample to `buf`.
fn push_sample(buf: &mut Vec<u8>, st: SampleType, order: ByteOrder, v: f64) {
    macro_rules! put {
        ($t:ty) => {{
            let x = v as $t;
            match order {
                ByteOrder::BigEndian => buf.extend_from_slice(&x.to_be_bytes()),
                ByteOrder::LittleEndian => buf.extend_from_slice(&x.to_le_bytes()),
            }
        }};
    }
    match st {
        SampleType::U8 => put!(u8),
        SampleType::I8 => put!(i8),
        SampleType::U16 => put!(u16),
        SampleType::I16 => put!(i16),
        SampleType::U32 => put!(u32),
        SampleType::I32 => put!(i32),
        SampleType::F32 => put!(f32),
    }
}

/// Writes `rows` (north to south, `grid.cols` values each, metres, NaN for no data) as
/// `<path_stem>.<data_extension>` plus `<path_stem>.HDR`, single-band BIL. Integer types round
/// to the nearest whole number; a value out of the type's range, a NaN without a NODATA, a
/// value that would read back as NODATA, or ±inf is an error (and no files are left). The
/// header is written last, so an interrupted write leaves no readable raster.
pub fn write_ehdr<I, R>(
    path_stem: &Path,
    grid: &GeoGrid,
    options: &EhdrWriteOptions,
    rows: I,
) -> Result<EhdrWritten, DemError>
where
    I: IntoIterator<Item = R>,
    R: AsRef<[f32]>,
{
    let header_path = with_suffix(path_stem, "HDR");
    let data_path = with_suffix(path_stem, &options.data_extension);
    check_request(grid, options, &header_path, &data_path)?;
    match write_files(grid, options, rows, &header_path, &data_path) {
        Ok(()) => Ok(EhdrWritten {
            header_path,
            data_path,
        }),
        Err(e) => {
            let _ = std::fs::remove_file(&data_path);
            let _ = std::fs::remove_file(&header_path);
            Err(e)
        }
    }
}

/// An error about the data file being written.
fn data_err(data_path: &Path, message: String) -> DemError {
    DemError::Data {
        path: data_path.to_path_buf(),
        message,
    }
}

/// Refuses, before any file is touched, a grid a header cannot describe, a NODATA the sample
/// type cannot store, and a data file that would be the header.
fn check_request(
    grid: &GeoGrid,
    options: &EhdrWriteOptions,
    header_path: &Path,
    data_path: &Path,
) -> Result<(), DemError> {
    let fail = |message: String| data_err(data_path, message);
    if grid.rows == 0
        || grid.cols == 0
        || grid.rows > i32::MAX as usize
        || grid.cols > i32::MAX as usize
        || !(grid.dlon_deg.is_finite() && grid.dlon_deg > 0.0)
        || !(grid.dlat_deg.is_finite() && grid.dlat_deg > 0.0)
        || !(grid.lon0_deg.is_finite() && grid.lat0_deg.is_finite())
    {
        return Err(fail(format!(
            "cannot write grid {grid:?}; expected 1 to 2147483647 rows and columns, spacings > 0 \
             and a finite origin"
        )));
    }
    let st = options.sample_type;
    if let Some(nd) = options.nodata {
        let representable = match st.int_range() {
            Some((lo, hi)) => nd.fract() == 0.0 && nd >= lo as f64 && nd <= hi as f64,
            None => nd.is_nan() || nd == nd as f32 as f64,
        };
        if !representable {
            return Err(fail(format!(
                "NODATA {nd} cannot be stored as {}",
                st.describe()
            )));
        }
    }
    if header_path == data_path {
        return Err(fail("the data file's extension must not be HDR".into()));
    }
    Ok(())
}

/// Writes the data file row by row, then the header; on error the caller removes both.
fn write_files<I, R>(
    grid: &GeoGrid,
    options: &EhdrWriteOptions,
    rows: I,
    header_path: &Path,
    data_path: &Path,
) -> Result<(), DemError>
where
    I: IntoIterator<Item = R>,
    R: AsRef<[f32]>,
{
    let fail = |message: String| data_err(data_path, message);
    let io = |e: std::io::Error| DemError::Io {
        path: data_path.to_path_buf(),
        source: e,
    };
    // A header left from an earlier write must not describe a half-written file.
    if header_path.exists() {
        std::fs::remove_file(header_path).map_err(|e| DemError::Io {
            path: header_path.to_path_buf(),
            source: e,
        })?;
    }
    let file = std::fs::File::create(data_path).map_err(io)?;
    let mut out = BufWriter::with_capacity(1 << 20, file);
    let mut buf: Vec<u8> = Vec::with_capacity(grid.cols * options.sample_type.bytes());
    let mut count = 0usize;
    for row in rows {
        let row = row.as_ref();
        if count >= grid.rows {
            return Err(fail(format!(
                "more than NROWS {} rows were given",
                grid.rows
            )));
        }
        if row.len() != grid.cols {
            return Err(fail(format!(
                "row {count} has {} values; expected NCOLS {}",
                row.len(),
                grid.cols
            )));
        }
        buf.clear();
        for (col, &v) in row.iter().enumerate() {
            let stored = stored_value(v, count, col, options, data_path)?;
            push_sample(&mut buf, options.sample_type, options.byte_order, stored);
        }
        out.write_all(&buf).map_err(io)?;
        count += 1;
    }
    if count != grid.rows {
        return Err(fail(format!(
            "{count} rows were given; expected NROWS {}",
            grid.rows
        )));
    }
    out.flush().map_err(io)?;
    std::fs::write(header_path, header_text(grid, options)).map_err(|e| DemError::Io {
        path: header_path.to_path_buf(),
        source: e,
    })
}

/// The value stored for height `v` at (`row`, `col`): NODATA for NaN, rounded for integer
/// types; an error for ±inf, a NaN without NODATA, a value out of the type's range, or one
/// that would read back as NODATA.
fn stored_value(
    v: f32,
    row: usize,
    col: usize,
    options: &EhdrWriteOptions,
    data_path: &Path,
) -> Result<f64, DemError> {
    let fail = |message: String| data_err(data_path, message);
    if v.is_nan() {
        return options.nodata.ok_or_else(|| {
            fail(format!(
                "row {row}, column {col} is NaN (no data) but no NODATA value was given"
            ))
        });
    }
    if v.is_infinite() {
        return Err(fail(format!(
            "row {row}, column {col} is {v}; expected finite heights"
        )));
    }
    let range = options.sample_type.int_range();
    let x = match range {
        Some(_) => (v as f64).round(),
        None => v as f64,
    };
    if let Some((lo, hi)) = range
        && !(x >= lo as f64 && x <= hi as f64)
    {
        return Err(fail(format!(
            "row {row}, column {col}: {v} does not fit {} ({lo}…{hi})",
            options.sample_type.describe()
        )));
    }
    if options.nodata == Some(x) {
        return Err(fail(format!(
            "row {row}, column {col}: {v} would read back as NODATA {x}"
        )));
    }
    Ok(x)
}
