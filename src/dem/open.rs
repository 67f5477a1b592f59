//! Which reader opens a path: by folder contents, extension and, for TIFFs under other names,
//! the file's signature. Apart from the readers so that each of them can share
//! `dem::raster`'s grid and trait without importing the others.

use std::path::Path;

use super::raster::RasterSource;
use super::{
    DemError, EhdrMosaic, EhdrRaster, GeoTiffRaster, HgtRaster, NetcdfRaster, RasterMosaic,
};

/// Opens any raster globe reads: a folder of SRTM `.hgt` tiles or GeoTIFFs (one
/// [`RasterMosaic`]) or of EHdr tiles (one [`EhdrMosaic`]), a netCDF-3 file (`.nc`, `.cdf`;
/// `variable` picks the 2-D variable, default the only one), a GeoTIFF/COG (`.tif`, `.tiff`, or any file that
/// starts as a TIFF does), an SRTM `.hgt` tile, or an EHdr raster (its `.HDR` or data file).
pub fn open_raster(path: &Path, variable: Option<&str>) -> Result<Box<dyn RasterSource>, DemError> {
    if path.is_dir() {
        let has_tiles = std::fs::read_dir(path)
            .map(|d| {
                d.filter_map(Result::ok)
                    .any(|e| super::mosaic::is_mosaic_tile(&e.path()))
            })
            .unwrap_or(false);
        if has_tiles {
            return Ok(Box::new(RasterMosaic::open_dir(path)?));
        }
        return Ok(Box::new(EhdrMosaic::open_dir(path)?));
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("nc") | Some("cdf") => Ok(Box::new(NetcdfRaster::open(path, variable)?)),
        Some("tif") | Some("tiff") => Ok(Box::new(GeoTiffRaster::open(path)?)),
        Some("hgt") => Ok(Box::new(HgtRaster::open(path)?)),
        _ if starts_as_tiff(path) => Ok(Box::new(GeoTiffRaster::open(path)?)),
        _ => Ok(Box::new(EhdrRaster::open(path)?)),
    }
}

/// Whether a file begins with a TIFF or BigTIFF signature (`II*\0`, `MM\0*`, `II+\0`, `MM\0+`).
fn starts_as_tiff(path: &Path) -> bool {
    use std::io::Read;
    let mut magic = [0u8; 4];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut magic))
        .is_ok()
        && matches!(&magic, b"II*\0" | b"MM\0*" | b"II+\0" | b"MM\0+")
}
