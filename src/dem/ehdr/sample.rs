//! Point sampling shared by single rasters and mosaics: nearest pixel (GDAL's rule) and bilinear
//! between pixel centres.

use crate::dem::{DemError, GeoGrid};

/// Positions closer than this (in pixels) to a pixel centre snap onto it, so that the latitude
/// and longitude of a centre, converted back through floating point, return its value exactly.
const SNAP_PIXELS: f64 = 1e-9;

pub(crate) trait PixelSource {
    fn pixel_grid(&self) -> GeoGrid;
    /// `Ok(None)` for no data.
    fn pixel(&self, row: usize, col: usize) -> Result<Option<f32>, DemError>;
}

fn snap(x: f64) -> f64 {
    let r = x.round();
    if (x - r).abs() < SNAP_PIXELS { r } else { x }
}

/// The pixel containing (lat, lon), computed exactly as GDAL does it (`gdallocationinfo
/// -geoloc`): the geotransform's origin is the upper-left pixel *corner* (ULXMAP − ½·XDIM,
/// ULYMAP + ½·YDIM), its inverse is taken term by term (GDALInvGeoTransform's no-rotation case)
/// and the pixel is `floor` of the result, so a point exactly on a pixel edge belongs to the
/// pixel east / south of it and our choice matches GDAL's bit for bit. A longitude more than
/// 180° from the grid's centre is moved by whole turns towards it first, and grids that go round
/// the globe wrap.
pub(crate) fn pixel_of(grid: &GeoGrid, lat_deg: f64, lon_deg: f64) -> Option<(usize, usize)> {
    if !(lat_deg.is_finite() && lon_deg.is_finite()) {
        return None;
    }
    let (rows, cols) = (grid.rows as f64, grid.cols as f64);
    // GDAL's geotransform and its inverse.
    let gt0 = grid.lon0_deg - grid.dlon_deg * 0.5;
    let gt1 = grid.dlon_deg;
    let gt3 = grid.lat0_deg + grid.dlat_deg * 0.5;
    let gt5 = -grid.dlat_deg;
    let (inv0, inv1) = (-gt0 / gt1, 1.0 / gt1);
    let (inv3, inv5) = (-gt3 / gt5, 1.0 / gt5);
    let row = (inv3 + inv5 * lat_deg).floor();
    let col_of = |lon: f64| (inv0 + inv1 * lon).floor();
    let mut col = col_of(lon_deg);
    let centre = grid.lon0_deg + 0.5 * (cols - 1.0) * grid.dlon_deg;
    if !(col >= 0.0 && col < cols) && (lon_deg - centre).abs() > 180.0 {
        // Another copy of the circle; within ±180° of the centre GDAL's answer stands.
        col = col_of(lon_deg + 360.0 * ((centre - lon_deg) / 360.0).round());
    }
    if grid.wraps_in_longitude() {
        col = col.rem_euclid(cols);
    }
    if !(row >= 0.0 && row < rows && col >= 0.0 && col < cols) {
        return None;
    }
    Some((row as usize, col as usize))
}

pub(crate) fn nearest<S: PixelSource>(
    source: &S,
    lat_deg: f64,
    lon_deg: f64,
) -> Result<Option<f32>, DemError> {
    match pixel_of(&source.pixel_grid(), lat_deg, lon_deg) {
        Some((row, col)) => source.pixel(row, col),
        None => Ok(None),
    }
}

/// The two neighbours along one axis and the weight of the second: `x` in pixel coordinates,
/// `n` pixels, `wraps` for longitude round the globe. `None` outside [−½, n − ½).
fn axis(x: f64, n: usize, wraps: bool) -> Option<(usize, usize, f64)> {
    let nf = n as f64;
    let x = snap(x);
    if wraps {
        let mut x = x.rem_euclid(nf);
        if x >= nf {
            x = 0.0; // a tiny negative x rounds up to n
        }
        let i0 = x.floor();
        let f = x - i0;
        let i0 = (i0 as usize).min(n - 1);
        return Some((i0, (i0 + 1) % n, f));
    }
    if !(x >= -0.5 && x < nf - 0.5) {
        return None;
    }
    let x = x.clamp(0.0, nf - 1.0);
    let i0 = x.floor();
    let f = x - i0;
    let i0 = i0 as usize;
    Some((i0, (i0 + 1).min(n - 1), f))
}

pub(crate) fn bilinear<S: PixelSource>(
    source: &S,
    lat_deg: f64,
    lon_deg: f64,
) -> Result<Option<f64>, DemError> {
    if !(lat_deg.is_finite() && lon_deg.is_finite()) {
        return Ok(None);
    }
    let grid = source.pixel_grid();
    let (r, c) = grid.row_col_of(lat_deg, lon_deg);
    let Some((r0, r1, fr)) = axis(r, grid.rows, false) else {
        return Ok(None);
    };
    let Some((c0, c1, fc)) = axis(c, grid.cols, grid.wraps_in_longitude()) else {
        return Ok(None);
    };
    let taps = [
        (r0, c0, (1.0 - fr) * (1.0 - fc)),
        (r0, c1, (1.0 - fr) * fc),
        (r1, c0, fr * (1.0 - fc)),
        (r1, c1, fr * fc),
    ];
    let mut sum = 0.0f64;
    let mut weight = 0.0f64;
    for (row, col, w) in taps {
        if w <= 0.0 {
            continue;
        }
        if let Some(v) = source.pixel(row, col)? {
            sum += w * v as f64;
            weight += w;
        }
    }
    Ok((weight > 0.0).then(|| sum / weight))
}
