//! GeoTIFF and Cloud-Optimized GeoTIFF (COG) rasters (issue 15 item 3).
//!
//! * [`ifd`]: the first IFD, parsed by us with every value's extent checked against the file,
//!   so a header cannot make anything allocate beyond the file's size, and errors name fields.
//! * [`georef`]: the GeoKey directory and model tags to a [`GeoGrid`](crate::dem::GeoGrid).
//! * [`GeoTiffRaster`]: band 1 of the first image, row by row.
//!
//! What is read: one sample per pixel of Int16, UInt16 or Float32; strips or tiles;
//! uncompressed (rows read straight from the memory map), Deflate, LZW or PackBits (decoded by
//! the `tiff` crate, built without JPEG, ZSTD, WebP or fax); any predictor the crate supports
//! (horizontal, floating point). `GDAL_NODATA` pixels, and NaN in a Float32 raster, read as NaN;
//! ±inf is corruption (an error naming row and column). Georeferencing: ModelPixelScale +
//! ModelTiepoint, or ModelTransformation without rotation; PixelIsPoint shifts the grid by half
//! a pixel as GDAL does (the tiepoint is a pixel centre). The CRS must be geographic (degrees);
//! a projected one is an error that names it.
//!
//! Not read: later IFDs (a COG's overviews and masks: the pyramid builder makes its own
//! levels), more than one band, south-up or rotated grids, ground control points.
//!
//! Memory: a compressed chunk is decoded whole, so the reader keeps one band of chunks (the
//! strip, or one row of tiles across the raster) decoded as `f32`; a chunk must be one its
//! compressed bytes can justify (at most [`max_expansion`] times as large), checked at open.

pub mod georef;
pub(crate) mod ifd;

use std::io::Cursor;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use ifd::{Ifd, tag_name};

use super::mapped::MappedFile;
use crate::dem::{DemError, GeoGrid, RasterSource};

/// The sample types globe reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TiffSample {
    I16,
    U16,
    F32,
}

impl TiffSample {
    pub fn bytes(self) -> usize {
        match self {
            TiffSample::I16 | TiffSample::U16 => 2,
            TiffSample::F32 => 4,
        }
    }
}

/// The largest decoded band a reader will hold (a compressed strip is decoded whole: a
/// 43200-column raster in one Deflate strip would otherwise need 3.7 GB at once).
pub const MAX_BAND_BYTES: u64 = 1 << 30;

/// How many times its compressed size a chunk can decode to: Deflate's limit is 1032:1; LZW's
/// 12-bit codes (strings of at most 4096 bytes, ~1.1 codes per table entry) stay under 1400:1;
/// PackBits under 64:1. A chunk claiming more is corrupt (or a decompression bomb).
pub fn max_expansion(compression: u16) -> u64 {
    match compression {
        1 => 1,
        8 | 32946 => 1032,
        5 => 1400,
        32773 => 64,
        _ => 0,
    }
}

fn compression_name(c: u16) -> &'static str {
    match c {
        1 => "none",
        2 => "CCITT RLE",
        3 => "CCITT Group 3 fax",
        4 => "CCITT Group 4 fax",
        5 => "LZW",
        6 => "old-style JPEG",
        7 => "JPEG",
        8 | 32946 => "Deflate",
        32773 => "PackBits",
        34887 => "LERC",
        34925 => "LZMA",
        50000 => "ZSTD",
        50001 => "WebP",
        50002 => "JPEG XL",
        _ => "unknown",
    }
}

/// How the raster's chunks are laid out.
#[derive(Clone, Debug)]
struct Layout {
    tiled: bool,
    /// Chunk width and height in pixels (strips: the raster's width and RowsPerStrip).
    chunk_w: usize,
    chunk_h: usize,
    across: usize,
    offsets: Vec<u64>,
    counts: Vec<u64>,
}

/// What a GeoTIFF's first image says about itself, for readers of other kinds of raster
/// (imagery): its size, samples per pixel, bits per sample, compression's name and where its
/// pixels lie (the same geographic checks as the elevation reader's).
#[derive(Clone, Debug)]
pub struct TiffHeader {
    pub width: usize,
    pub height: usize,
    pub samples_per_pixel: u64,
    pub bits_per_sample: u64,
    pub compression: &'static str,
    pub georef: georef::Georeference,
}

/// Reads the header and georeferencing of the first image of the GeoTIFF in `bytes` (`path`
/// names it in messages).
pub fn read_header(bytes: &[u8], path: &Path) -> Result<TiffHeader, DemError> {
    let ifd = Ifd::parse(bytes, path)?;
    let width = ifd.scalar(bytes, 256, None, path)? as usize;
    let height = ifd.scalar(bytes, 257, None, path)? as usize;
    if width == 0 || height == 0 || width > u32::MAX as usize || height > u32::MAX as usize {
        return Err(header_err(
            path,
            "ImageWidth",
            format!("{width} × {height} pixels; expected at least one pixel"),
        ));
    }
    let samples_per_pixel = ifd.scalar(bytes, 277, Some(1), path)?;
    // One value per sample (RGB: 8, 8, 8); the largest is reported.
    let bits_per_sample = ifd
        .unsigned(bytes, 258, path)?
        .and_then(|v| v.into_iter().max())
        .unwrap_or(1);
    let compression = compression_name(ifd.scalar(bytes, 259, Some(1), path)? as u16);
    let georef = georef::georeference(bytes, &ifd, width, height, path)?;
    Ok(TiffHeader {
        width,
        height,
        samples_per_pixel,
        bits_per_sample,
        compression,
        georef,
    })
}

/// The mapped file, shared between the reader and the decoder's cursor.
#[derive(Clone)]
struct Shared(Arc<MappedFile>);

impl AsRef<[u8]> for Shared {
    fn as_ref(&self) -> &[u8] {
        &self.0
    }
}

/// One band of decoded rows.
struct Band {
    index: usize,
    data: Vec<f32>,
}

/// Band 1 of the first image of a GeoTIFF, as a [`RasterSource`].
pub struct GeoTiffRaster {
    path: PathBuf,
    bytes: Shared,
    little_endian: bool,
    grid: GeoGrid,
    sample: TiffSample,
    compression: u16,
    predictor: u16,
    nodata: Option<f64>,
    georef: georef::Georeference,
    layout: Layout,
    /// Another IFD follows the first (a COG's overviews or a mask).
    overviews: bool,
    decoder: Option<Mutex<tiff::decoder::Decoder<Cursor<Shared>>>>,
    band: Mutex<Option<Band>>,
}

impl std::fmt::Debug for GeoTiffRaster {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GeoTiffRaster")
            .field("path", &self.path)
            .field("grid", &self.grid)
            .field("sample", &self.sample)
            .field("compression", &self.compression)
            .finish()
    }
}

fn header_err(path: &Path, field: &str, message: String) -> DemError {
    DemError::Header {
        path: path.to_path_buf(),
        field: field.to_string(),
        message,
    }
}

impl GeoTiffRaster {
    /// Maps and validates `path`.
    pub fn open(path: impl AsRef<Path>) -> Result<GeoTiffRaster, DemError> {
        let path = path.as_ref();
        Self::from_mapped(MappedFile::open(path)?)
    }

    /// A file's bytes already in memory (`path` only names it in messages); the same checks.
    pub fn from_bytes(bytes: Vec<u8>, path: impl AsRef<Path>) -> Result<GeoTiffRaster, DemError> {
        Self::from_mapped(MappedFile::from_bytes(path.as_ref(), bytes))
    }

    fn from_mapped(file: MappedFile) -> Result<GeoTiffRaster, DemError> {
        let path = file.path().to_path_buf();
        let p = path.as_path();
        let b: &[u8] = &file;
        let ifd = Ifd::parse(b, p)?;
        let width = ifd.scalar(b, 256, None, p)? as usize;
        let height = ifd.scalar(b, 257, None, p)? as usize;
        if width == 0 || height == 0 || width > u32::MAX as usize || height > u32::MAX as usize {
            return Err(header_err(
                p,
                "ImageWidth",
                format!("{width} × {height} pixels; expected at least one pixel"),
            ));
        }
        let spp = ifd.scalar(b, 277, Some(1), p)?;
        if spp != 1 {
            return Err(header_err(
                p,
                "SamplesPerPixel",
                format!("{spp}; expected 1 (globe reads single-band elevation rasters)"),
            ));
        }
        let compression = supported_compression(b, &ifd, p)?;
        let sample = sample_type(b, &ifd, p)?;
        let predictor = supported_predictor(b, &ifd, sample, p)?;
        let layout = chunk_layout(b, &ifd, width, height, sample, compression, p)?;
        let georef = georef::georeference(b, &ifd, width, height, p)?;
        let nodata = gdal_nodata(b, &ifd, p)?;
        let little_endian = b[0] == b'I';
        let bytes = Shared(Arc::new(file));
        let decoder = if compression == 1 && predictor == 1 {
            None
        } else {
            Some(Mutex::new(chunk_decoder(&bytes, &layout, sample, p)?))
        };
        Ok(GeoTiffRaster {
            path,
            bytes,
            little_endian,
            grid: georef.grid,
            sample,
            compression,
            predictor,
            nodata,
            georef,
            layout,
            overviews: ifd.next != 0,
            decoder,
            band: Mutex::new(None),
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    pub fn sample_type(&self) -> TiffSample {
        self.sample
    }

    pub fn nodata(&self) -> Option<f64> {
        self.nodata
    }

    pub fn pixel_is_point(&self) -> bool {
        self.georef.pixel_is_point
    }

    /// The CRS as the file names it.
    pub fn crs(&self) -> &str {
        &self.georef.crs
    }

    /// The compression's name.
    pub fn compression(&self) -> &'static str {
        compression_name(self.compression)
    }

    pub fn tiled(&self) -> bool {
        self.layout.tiled
    }

    /// The chunk (tile or strip) size in pixels.
    pub fn chunk_size(&self) -> (usize, usize) {
        (self.layout.chunk_w, self.layout.chunk_h)
    }

    /// Bytes of the decoded band the reader holds (0 for an uncompressed raster, read in place).
    pub fn band_bytes(&self) -> usize {
        if self.decoder.is_none() {
            0
        } else {
            self.grid.cols * self.layout.chunk_h * 4
        }
    }

    /// Whether the file holds more images after the first (a COG's overviews), which globe
    /// ignores.
    pub fn has_overviews(&self) -> bool {
        self.overviews
    }

    /// Decodes one stored value to metres (NaN for no data).
    fn to_metres(&self, raw: f64, row: usize, col: usize) -> Result<f32, DemError> {
        if raw.is_nan() {
            return Ok(f32::NAN);
        }
        if let Some(nd) = self.nodata {
            let hit = match self.sample {
                TiffSample::F32 => raw as f32 == nd as f32,
                _ => raw == nd,
            };
            if hit {
                return Ok(f32::NAN);
            }
        }
        if raw.is_infinite() {
            return Err(DemError::Data {
                path: self.path.clone(),
                message: format!(
                    "row {row}, column {col}: {raw} is not a height; expected finite Float32 \
                     values (or the GDAL_NODATA value)"
                ),
            });
        }
        Ok(raw as f32)
    }

    /// Uncompressed without a predictor: a row straight from the map.
    fn read_row_in_place(&self, row: usize, out: &mut [f32]) -> Result<(), DemError> {
        let l = &self.layout;
        let b: &[u8] = self.bytes.as_ref();
        let size = self.sample.bytes();
        let band = row / l.chunk_h;
        let within = row % l.chunk_h;
        for chunk_col in 0..l.across {
            let idx = band * l.across + chunk_col;
            let c0 = chunk_col * l.chunk_w;
            let n = l.chunk_w.min(self.grid.cols - c0);
            let start = l.offsets[idx] as usize + within * l.chunk_w * size;
            let src = &b[start..start + n * size];
            for (k, (o, v)) in out[c0..c0 + n]
                .iter_mut()
                .zip(src.chunks_exact(size))
                .enumerate()
            {
                let raw = match (self.sample, self.little_endian) {
                    (TiffSample::I16, true) => i16::from_le_bytes([v[0], v[1]]) as f64,
                    (TiffSample::I16, false) => i16::from_be_bytes([v[0], v[1]]) as f64,
                    (TiffSample::U16, true) => u16::from_le_bytes([v[0], v[1]]) as f64,
                    (TiffSample::U16, false) => u16::from_be_bytes([v[0], v[1]]) as f64,
                    (TiffSample::F32, true) => f32::from_le_bytes([v[0], v[1], v[2], v[3]]) as f64,
                    (TiffSample::F32, false) => f32::from_be_bytes([v[0], v[1], v[2], v[3]]) as f64,
                };
                *o = self.to_metres(raw, row, c0 + k)?;
            }
        }
        Ok(())
    }

    /// An LZW chunk, decoded here with `weezl` (the codec the `tiff` crate uses) rather than by
    /// the crate: tiff 0.11.3 fails on LZW tiles with horizontal padding (GDAL's edge tiles:
    /// "no lzw end code found" while skipping the padding of the last row). The whole stored
    /// chunk (`stored_rows` × the chunk width) is decoded, the predictor undone, and the
    /// `w` × `rows` data returned.
    fn lzw_chunk(
        &self,
        idx: usize,
        stored_rows: usize,
        w: usize,
        rows: usize,
    ) -> Result<tiff::decoder::DecodingResult, DemError> {
        use tiff::decoder::DecodingResult as D;
        let l = &self.layout;
        let what = if l.tiled { "tile" } else { "strip" };
        let size = self.sample.bytes();
        let row_bytes = l.chunk_w * size;
        let need = row_bytes * stored_rows;
        let (off, count) = (l.offsets[idx] as usize, l.counts[idx] as usize);
        let mut input = &self.bytes.as_ref()[off..off + count];
        let mut out = vec![0u8; need];
        let mut got = 0;
        let mut lzw = weezl::decode::Decoder::with_tiff_size_switch(weezl::BitOrder::Msb, 8);
        while got < need {
            let r = lzw.decode_bytes(input, &mut out[got..]);
            input = &input[r.consumed_in..];
            got += r.consumed_out;
            match r.status {
                Ok(weezl::LzwStatus::Ok) if r.consumed_in + r.consumed_out > 0 => {}
                Ok(_) if got == need => {}
                Ok(_) => {
                    return Err(DemError::Data {
                        path: self.path.clone(),
                        message: format!(
                            "{what} {idx}: its LZW data ends after {got} of the {need} bytes                              of its samples; the file is truncated or corrupt"
                        ),
                    });
                }
                Err(e) => {
                    return Err(DemError::Data {
                        path: self.path.clone(),
                        message: format!("{what} {idx}: LZW data is corrupt ({e})"),
                    });
                }
            }
        }
        let n = l.chunk_w;
        let le = self.little_endian;
        let crop = |r: usize, c: usize| r < rows && c < w;
        Ok(match (self.sample, self.predictor) {
            (TiffSample::F32, 3) => {
                // Floating-point predictor: per row, bytes differenced, then planes of the
                // samples' bytes, most significant first, whatever the file's byte order.
                let mut v = Vec::with_capacity(w * rows);
                for row in out.chunks_exact_mut(row_bytes).take(rows) {
                    for i in 1..row.len() {
                        row[i] = row[i].wrapping_add(row[i - 1]);
                    }
                    for c in 0..w {
                        v.push(f32::from_be_bytes([
                            row[c],
                            row[n + c],
                            row[2 * n + c],
                            row[3 * n + c],
                        ]));
                    }
                }
                D::F32(v)
            }
            (TiffSample::F32, _) => {
                let mut v = Vec::with_capacity(w * rows);
                for (r, row) in out.chunks_exact(row_bytes).enumerate() {
                    for (c, b) in row.chunks_exact(4).enumerate() {
                        let b = [b[0], b[1], b[2], b[3]];
                        if crop(r, c) {
                            v.push(if le {
                                f32::from_le_bytes(b)
                            } else {
                                f32::from_be_bytes(b)
                            });
                        }
                    }
                }
                D::F32(v)
            }
            (sample, predictor) => {
                let mut v: Vec<u16> = Vec::with_capacity(w * rows);
                for (r, row) in out.chunks_exact(row_bytes).enumerate().take(rows) {
                    let mut prev = 0u16;
                    for (c, b) in row.chunks_exact(2).enumerate() {
                        let b = [b[0], b[1]];
                        let mut x = if le {
                            u16::from_le_bytes(b)
                        } else {
                            u16::from_be_bytes(b)
                        };
                        if predictor == 2 {
                            x = x.wrapping_add(prev);
                            prev = x;
                        }
                        if crop(r, c) {
                            v.push(x);
                        }
                    }
                }
                if sample == TiffSample::I16 {
                    D::I16(v.into_iter().map(|x| x as i16).collect())
                } else {
                    D::U16(v)
                }
            }
        })
    }

    /// Decodes every chunk of band `index` into `data` (cols × chunk_h values).
    fn decode_band(&self, index: usize, data: &mut Vec<f32>) -> Result<(), DemError> {
        let l = &self.layout;
        let g = self.grid;
        let rows = l.chunk_h.min(g.rows - index * l.chunk_h);
        data.clear();
        data.resize(g.cols * rows, f32::NAN);
        let mut decoder = self
            .decoder
            .as_ref()
            .expect("compressed rasters have a decoder")
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        for chunk_col in 0..l.across {
            let idx = index * l.across + chunk_col;
            let c0 = chunk_col * l.chunk_w;
            let w = l.chunk_w.min(g.cols - c0);
            let what = if l.tiled { "tile" } else { "strip" };
            let decoded = if self.compression == 5 {
                let stored_rows = if l.tiled { l.chunk_h } else { rows };
                self.lzw_chunk(idx, stored_rows, w, rows)?
            } else {
                decoder
                    .read_chunk(idx as u32)
                    .map_err(|e| tiff_err(&self.path, &format!("{what} {idx}"), e))?
            };
            use tiff::decoder::DecodingResult as D;
            let n = match &decoded {
                D::I16(v) => v.len(),
                D::U16(v) => v.len(),
                D::F32(v) => v.len(),
                _ => {
                    return Err(DemError::Data {
                        path: self.path.clone(),
                        message: format!(
                            "{what} {idx} decoded to another sample type than {:?}",
                            self.sample
                        ),
                    });
                }
            };
            // The crate returns the chunk without its padding: w × rows values.
            if n != w * rows {
                return Err(DemError::Data {
                    path: self.path.clone(),
                    message: format!("{what} {idx} decoded to {n} values; expected {w} × {rows}"),
                });
            }
            let value = |i: usize| -> f64 {
                match &decoded {
                    D::I16(v) => v[i] as f64,
                    D::U16(v) => v[i] as f64,
                    D::F32(v) => v[i] as f64,
                    _ => f64::NAN, // excluded above
                }
            };
            for r in 0..rows {
                let row = index * l.chunk_h + r;
                for c in 0..w {
                    data[r * g.cols + c0 + c] = self.to_metres(value(r * w + c), row, c0 + c)?;
                }
            }
        }
        Ok(())
    }
}

/// The Compression tag, refusing a scheme globe's TIFF decoder is not built with.
fn supported_compression(b: &[u8], ifd: &Ifd, p: &Path) -> Result<u16, DemError> {
    let compression = ifd.scalar(b, 259, Some(1), p)? as u16;
    if max_expansion(compression) == 0 {
        return Err(header_err(
            p,
            "Compression",
            format!(
                "{} ({compression}) is not supported (globe's TIFF decoder is built with \
                 Deflate, LZW and PackBits only); expected one of those or none (re-save \
                 with gdal_translate -co COMPRESS=DEFLATE)",
                compression_name(compression)
            ),
        ));
    }
    Ok(compression)
}

/// The sample type from SampleFormat and BitsPerSample: Int16, UInt16 or Float32.
fn sample_type(b: &[u8], ifd: &Ifd, p: &Path) -> Result<TiffSample, DemError> {
    let bits = ifd.scalar(b, 258, Some(1), p)?;
    let format = ifd.scalar(b, 339, Some(1), p)?;
    match (format, bits) {
        (2, 16) => Ok(TiffSample::I16),
        (1, 16) => Ok(TiffSample::U16),
        (3, 32) => Ok(TiffSample::F32),
        _ => {
            let kind = match format {
                1 => "UInt",
                2 => "Int",
                3 => "Float",
                _ => "unknown format ",
            };
            Err(header_err(
                p,
                "SampleFormat",
                format!(
                    "{kind}{bits} samples (SampleFormat {format}, BitsPerSample {bits}) are \
                     not supported; expected Int16, UInt16 or Float32 (gdal_translate -ot \
                     Float32)"
                ),
            ))
        }
    }
}

/// The Predictor tag, refusing one that does not apply to `sample` (horizontal differencing is
/// for integers, the floating-point predictor for Float32).
fn supported_predictor(b: &[u8], ifd: &Ifd, sample: TiffSample, p: &Path) -> Result<u16, DemError> {
    let predictor = ifd.scalar(b, 317, Some(1), p)? as u16;
    match (predictor, sample) {
        (1, _) | (2, TiffSample::I16 | TiffSample::U16) | (3, TiffSample::F32) => Ok(predictor),
        _ => Err(header_err(
            p,
            "Predictor",
            format!(
                "{predictor} for {sample:?} samples; expected 1 (none), 2 (horizontal, \
                 integers) or 3 (floating point, Float32)"
            ),
        )),
    }
}

/// The GDAL_NODATA tag's value (`nan` included), `None` when absent; text that is not a number
/// is an error.
fn gdal_nodata(b: &[u8], ifd: &Ifd, p: &Path) -> Result<Option<f64>, DemError> {
    let Some(s) = ifd.ascii(b, 42113) else {
        return Ok(None);
    };
    let t = s.trim();
    let v = if t.eq_ignore_ascii_case("nan") {
        Some(f64::NAN)
    } else {
        t.parse::<f64>().ok()
    };
    match v {
        Some(v) => Ok(Some(v)),
        None => Err(header_err(
            p,
            "GDAL_NODATA",
            format!("{t:?} is not a number; expected the no-data value"),
        )),
    }
}

/// The `tiff` crate's decoder over the mapped file, its limits set so that no buffer exceeds
/// one chunk's samples or the file's size.
fn chunk_decoder(
    bytes: &Shared,
    layout: &Layout,
    sample: TiffSample,
    p: &Path,
) -> Result<tiff::decoder::Decoder<Cursor<Shared>>, DemError> {
    let max_chunk = layout
        .chunk_w
        .saturating_mul(layout.chunk_h)
        .saturating_mul(sample.bytes())
        .max(1);
    let mut limits = tiff::decoder::Limits::default();
    limits.decoding_buffer_size = max_chunk;
    limits.ifd_value_size = bytes.0.len();
    limits.intermediate_buffer_size = bytes.0.len();
    Ok(tiff::decoder::Decoder::new(Cursor::new(bytes.clone()))
        .map_err(|e| tiff_err(p, "first IFD", e))?
        .with_limits(limits))
}

/// A `tiff` crate error as ours, naming the file and what was being read.
fn tiff_err(path: &Path, what: &str, e: tiff::TiffError) -> DemError {
    match e {
        tiff::TiffError::IoError(source) if source.kind() == std::io::ErrorKind::UnexpectedEof => {
            DemError::Data {
                path: path.to_path_buf(),
                message: format!("{what}: the data ends early ({source}); the file is truncated"),
            }
        }
        other => DemError::Data {
            path: path.to_path_buf(),
            message: format!("{what}: {other}; expected a valid GeoTIFF"),
        },
    }
}

/// The chunk layout, checked against the file: every chunk inside it, and no chunk claiming
/// to decode to more than its bytes can hold.
fn chunk_layout(
    b: &[u8],
    ifd: &Ifd,
    width: usize,
    height: usize,
    sample: TiffSample,
    compression: u16,
    p: &Path,
) -> Result<Layout, DemError> {
    let tiled = ifd.has(322) || ifd.has(323);
    let (chunk_w, chunk_h, offsets_tag, counts_tag) = if tiled {
        let tw = ifd.scalar(b, 322, None, p)? as usize;
        let th = ifd.scalar(b, 323, None, p)? as usize;
        (tw, th, 324u16, 325u16)
    } else {
        let rps = ifd.scalar(b, 278, Some(u32::MAX as u64), p)? as usize;
        (width, rps.min(height), 273, 279)
    };
    if chunk_w == 0 || chunk_h == 0 {
        return Err(header_err(
            p,
            &tag_name(if tiled { 322 } else { 278 }),
            format!("chunks of {chunk_w} × {chunk_h} pixels; expected at least 1 × 1"),
        ));
    }
    let across = width.div_ceil(chunk_w);
    let down = height.div_ceil(chunk_h);
    let expected = (across as u64).saturating_mul(down as u64);
    let offsets = ifd.unsigned(b, offsets_tag, p)?.unwrap_or_default();
    let counts = ifd.unsigned(b, counts_tag, p)?.unwrap_or_default();
    for (tag, v) in [(offsets_tag, &offsets), (counts_tag, &counts)] {
        if (v.len() as u64) < expected {
            return Err(header_err(
                p,
                &tag_name(tag),
                format!(
                    "{} values; expected {expected} ({across} × {down} {} of {chunk_w} × \
                     {chunk_h} pixels)",
                    v.len(),
                    if tiled { "tiles" } else { "strips" }
                ),
            ));
        }
    }
    let chunk_bytes = (chunk_w as u64)
        .saturating_mul(chunk_h as u64)
        .saturating_mul(sample.bytes() as u64);
    let band_bytes = (width as u64)
        .saturating_mul(chunk_h as u64)
        .saturating_mul(4);
    if compression != 1 && band_bytes > MAX_BAND_BYTES {
        return Err(header_err(
            p,
            &tag_name(if tiled { 323 } else { 278 }),
            format!(
                "{} of {chunk_h} rows decode to {band_bytes} bytes across the raster; expected \
                 at most {MAX_BAND_BYTES} (re-save tiled: gdal_translate -co TILED=YES)",
                if tiled { "a row of tiles" } else { "a strip" }
            ),
        ));
    }
    let ratio = max_expansion(compression);
    let len = b.len() as u64;
    let what = if tiled { "tile" } else { "strip" };
    for i in 0..expected as usize {
        let (off, count) = (offsets[i], counts[i]);
        let end = off.saturating_add(count);
        if end > len {
            return Err(DemError::Truncated {
                path: p.to_path_buf(),
                actual: len,
                expected: end,
                what: format!(
                    "{what} {i} ({count} bytes at offset {off}, {} / {})",
                    tag_name(offsets_tag),
                    tag_name(counts_tag)
                ),
            });
        }
        // The bytes a chunk decodes to: strips are cropped at the image's end; tiles are
        // stored whole (padded) in the file.
        let rows = if tiled {
            chunk_h
        } else {
            chunk_h.min(height - (i / across) * chunk_h)
        };
        let need = (chunk_w as u64)
            .saturating_mul(rows as u64)
            .saturating_mul(sample.bytes() as u64);
        let need = need.min(chunk_bytes);
        if count.saturating_mul(ratio) < need {
            return Err(DemError::Data {
                path: p.to_path_buf(),
                message: format!(
                    "{what} {i}: {count} bytes ({}) cannot hold the {need} bytes of its {} × \
                     {rows} samples; expected a complete {what} ({}, {})",
                    compression_name(compression),
                    chunk_w,
                    tag_name(offsets_tag),
                    tag_name(counts_tag)
                ),
            });
        }
    }
    Ok(Layout {
        tiled,
        chunk_w,
        chunk_h,
        across,
        offsets,
        counts,
    })
}

impl RasterSource for GeoTiffRaster {
    fn grid(&self) -> GeoGrid {
        self.grid
    }

    fn read_row(&self, row: usize, out: &mut [f32]) -> Result<(), DemError> {
        if row >= self.grid.rows || out.len() != self.grid.cols {
            return Err(DemError::Other(format!(
                "{}: read_row({row}) with a buffer of {} values; expected row < {} and {} values",
                self.path.display(),
                out.len(),
                self.grid.rows,
                self.grid.cols
            )));
        }
        if self.decoder.is_none() {
            return self.read_row_in_place(row, out);
        }
        let index = row / self.layout.chunk_h;
        let mut band = self.band.lock().unwrap_or_else(|e| e.into_inner());
        if band.as_ref().is_none_or(|b| b.index != index) {
            let mut data = band.take().map(|b| b.data).unwrap_or_default();
            self.decode_band(index, &mut data)?;
            *band = Some(Band { index, data });
        }
        let b = band.as_ref().expect("decoded above");
        let r = row - index * self.layout.chunk_h;
        out.copy_from_slice(&b.data[r * self.grid.cols..(r + 1) * self.grid.cols]);
        Ok(())
    }

    fn describe(&self) -> String {
        format!(
            "GeoTIFF {} ({:?}, {}{}, {} {}×{}, {}{})",
            self.path.display(),
            self.sample,
            self.compression(),
            match self.predictor {
                2 => " + horizontal predictor",
                3 => " + floating-point predictor",
                _ => "",
            },
            if self.layout.tiled { "tiles" } else { "strips" },
            self.layout.chunk_w,
            self.layout.chunk_h,
            self.georef.crs,
            if self.has_overviews() {
                ", overviews ignored"
            } else {
                ""
            }
        )
    }
}
