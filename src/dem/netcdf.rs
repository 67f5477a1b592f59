//! netCDF-3 classic files (CDF-1, and CDF-2 "64-bit offset") and a raster adaptor for
//! ETOPO-style global grids (docs/design.md#data: ETOPO5 from Debian's `ferret-datasets`), in two
//! concerns:
//!
//! * [`format`]: the file format — a reader of our own for the header (dimensions, attributes,
//!   variables) and bounds-checked access to the memory-mapped data ([`NetcdfFile`]). It knows
//!   nothing of latitudes or heights.
//! * [`raster`]: the CF conventions that turn one 2-D variable into a
//!   [`RasterSource`](crate::dem::RasterSource) of heights in metres ([`NetcdfRaster`]): which
//!   dimension is latitude, regular axes fitted to the coordinates, `scale_factor`/`add_offset`,
//!   fill values and units.

pub mod format;
pub mod raster;

pub use format::{AttrValue, Attribute, Dimension, NcType, NetcdfFile, Variable};
pub use raster::{AXIS_TOLERANCE, NetcdfRaster};
