//! The data formats and the streaming that reads them: each reader against GDAL or a published layout, the pyramid, local and remote streaming.
//!
//! One test binary (each module was its own binary once; one link step instead of many).

#[path = "../common/mod.rs"]
mod common;

mod ehdr;
mod embedded_earth;
mod file_changes;
mod geotiff;
mod hgt;
mod imagery;
mod netcdf;
mod pyramid;
mod remote;
mod streaming;
