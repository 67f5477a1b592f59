//! Elevation data: readers for EHdr/BIL rasters (GTOPO30) and netCDF-3 (ETOPO5), and the tiled
//! pyramid file the viewer memory-maps (docs/design.md#data).
//!
//! Every reader exposes a [`raster::RasterSource`]: a geographic grid of pixel centres and rows
//! of heights in metres, `NaN` where the source has no data. The pyramid builder consumes any
//! source row by row, so memory stays bounded whatever the raster's size.
//!
//! Every reader memory-maps its file through `mapped`, the one `unsafe` site of the layer,
//! which states the safety argument (the SIGBUS risk) once.

#![deny(unsafe_code)]

mod change;
pub mod ehdr;
pub mod embedded;
pub mod frame_reads;
pub mod geotiff;
pub mod hgt;
mod mapped;
pub mod mosaic;
pub mod netcdf;
pub mod open;
pub mod pyramid;
pub mod raster;
pub mod remote;

pub use change::FileChange;
pub use ehdr::{EhdrMosaic, EhdrRaster};
pub use geotiff::GeoTiffRaster;
pub use hgt::HgtRaster;
pub use mosaic::RasterMosaic;
pub use netcdf::{NetcdfFile, NetcdfRaster};
pub use open::open_raster;
pub use pyramid::{Pyramid, PyramidBuilder};
pub use raster::{GeoGrid, RasterSource};

/// Errors of the elevation-data layer. Every variant names the file and, where one applies,
/// the header field or position, and what was expected.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DemError {
    #[error("{path}: {source}")]
    Io {
        path: std::path::PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: field {field}: {message}")]
    Header {
        path: std::path::PathBuf,
        field: String,
        message: String,
    },
    #[error("{path}: {message}")]
    Data {
        path: std::path::PathBuf,
        message: String,
    },
    /// A file that must exist does not (a `.HDR` without its data file, or the reverse).
    #[error("{path}: {message}")]
    Missing {
        path: std::path::PathBuf,
        message: String,
    },
    #[error("{0}")]
    Other(String),
    /// A remote pyramid's request failed (names the URL, the byte range and why).
    #[error("{0}")]
    Remote(String),
    /// A file shorter than its header says (or than the header itself needs).
    #[error("{path}: truncated: {actual} bytes, expected {expected}; missing {what}")]
    Truncated {
        path: std::path::PathBuf,
        actual: u64,
        expected: u64,
        what: String,
    },
    /// A pyramid tile whose payload does not match the CRC in the tile index.
    #[error(
        "{path}: level {level} tile ({tx}, {ty}): checksum mismatch (index {expected:#010x}, payload {actual:#010x}): the tile is corrupt"
    )]
    TileChecksum {
        path: std::path::PathBuf,
        level: usize,
        tx: usize,
        ty: usize,
        expected: u32,
        actual: u32,
    },
    /// A pyramid tile whose payload matches its CRC but breaks the format's rules (min ≤ avg ≤
    /// max, `i16::MIN` never written): a broken writer or a forged file.
    #[error("{path}: level {level} tile ({tx}, {ty}) sample ({x}, {y}): {message}")]
    TileContent {
        path: std::path::PathBuf,
        level: usize,
        tx: usize,
        ty: usize,
        /// The sample within the tile (column, row).
        x: usize,
        y: usize,
        message: String,
    },
}
