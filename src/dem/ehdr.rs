//! ESRI EHdr / BIL rasters: GTOPO30's `.DEM` + `.HDR` tiles and any raster described by a `.HDR`
//! of `KEY value` lines (docs/design.md#data, issue 3 items 1 and 2).
//!
//! * [`EhdrHeader`] parses and validates the header: keys are case-insensitive, unknown keys are
//!   ignored, and every value is checked against the data file before a byte of it is read.
//! * [`EhdrRaster`] memory-maps the data file and reads band 1 by row (a whole row is decoded
//!   from the map at once), by pixel, and by latitude/longitude (nearest pixel, or bilinear
//!   between pixel centres; a pixel centre returns its stored value exactly).
//! * [`EhdrMosaic`] joins a folder of tiles (the 33 GTOPO30 tiles or any subset, Antarctica's
//!   7200×3600 shape included) into one [`RasterSource`](crate::dem::RasterSource) over the
//!   bounding grid of their union (which they must cover at least 1/64 of: the grid is read
//!   in full, [`EhdrMosaic::MAX_BOUNDING_FACTOR`]).
//! * [`write_ehdr`] writes GTOPO30-style tiles (`.DEM` + `.HDR`), for tests and `globe-data synth`.
//!
//! # Conventions, and where we follow GDAL's EHdr driver
//!
//! GDAL (`frmts/raw/ehdrdataset.cpp`) is the independent reader we check against, so where the
//! ESRI description leaves something open we do what GDAL does:
//!
//! * `BYTEORDER` defaults to `M` (big-endian); `I`/`INTEL`/`L`/`LSBFIRST` are little-endian,
//!   `M`/`MOTOROLA`/`MSBFIRST` big-endian. (GDAL reads any other value as `M`; we reject it.)
//! * `LAYOUT` defaults to `BIL`. (GDAL reads any unknown layout as BIL; we reject it.)
//! * `PIXELTYPE` absent: a 32-bit data file named `*.FLT` is `FLOAT`; otherwise a **negative
//!   NODATA makes the raster signed** (this is how GTOPO30's `NODATA -9999` tiles become signed
//!   16-bit in GDAL); otherwise it is unsigned. A 16-bit raster with neither PIXELTYPE nor a
//!   negative NODATA is therefore read as unsigned, exactly as GDAL reads it.
//! * `NBITS` absent: `FLOAT` means 32; with neither NBITS nor PIXELTYPE the bytes per pixel are
//!   inferred from the data file's size (1, 2 or 4 bytes; 4 means FLOAT), else 8.
//! * `ULXMAP`/`ULYMAP` are the centre of the upper-left pixel; absent they default to 0.5 and
//!   `XDIM`/`YDIM` to 1. GDAL's alternatives `XLLCORNER`/`YLLCORNER`, `XLLCENTER`/`YLLCENTER`
//!   and `CELLSIZE` are accepted too. A header with no georeferencing at all is an error (GDAL
//!   would fall back to a world file or to pixel coordinates; neither puts data on a globe).
//! * `NODATA_VALUE` is a synonym of `NODATA`.
//! * The nearest pixel to a latitude/longitude is computed with GDAL's own arithmetic (the
//!   inverse of the corner-based geotransform, then `floor`), so it matches
//!   `gdallocationinfo -geoloc` bit for bit, on pixel edges too (the `gdal_cross_check` test).
//!
//! Where we are stricter than GDAL, on purpose (a bad file must be an error, never a silently
//! wrong globe): the data file must be *exactly* as long as the header implies (GDAL accepts
//! longer files); `BANDROWBYTES`/`TOTALROWBYTES` are honoured (GDAL ignores them for 8 bits and
//! more, computing them from NCOLS); a key given twice with different values is an error (GDAL
//! takes the last); FLOAT with NBITS other than 32 is an error; sub-byte NBITS are not supported;
//! the grid must be geographic (pixel centres within ±90° latitude, at most 360° wide).
//!
//! # NODATA and non-finite floats
//!
//! Pixels equal to NODATA read as `NaN` (the importer makes them sea level unless another source
//! covers them; they never become −9999 m). A NaN or ±inf stored in a FLOAT raster is *not*
//! no-data but corruption, reported as [`DemError::Data`](crate::dem::DemError::Data) with the
//! file, row and column — unless the header declares that value as NODATA (`NODATA nan`). Scanning
//! a whole file at open would cost a full read of it, so the check is made where values are
//! decoded: by [`read_row`](crate::dem::RasterSource::read_row) (which reports the first bad column
//! of that row), [`EhdrRaster::value`] and the samplers.
//!
//! The data file is memory-mapped; like every memory map, it must not be truncated by another
//! process while open.

mod header;
mod mosaic;
mod reader;
mod sample;
mod writer;

pub use header::{ByteOrder, EhdrHeader, Layout, PixelType, SampleType};
pub use mosaic::EhdrMosaic;
pub use reader::EhdrRaster;
pub use writer::{EhdrWriteOptions, EhdrWritten, write_ehdr};
