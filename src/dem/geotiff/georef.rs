//! GeoTIFF georeferencing: the GeoKey directory (which CRS, pixel-is-area or -point) and the
//! model tags (pixel scale + tiepoint, or a transformation without rotation) turned into a
//! [`GeoGrid`] of pixel centres, with GDAL's conventions. A file without a CRS (no
//! GeoKeyDirectory, or one naming neither a model type nor a geographic CRS) is taken as
//! latitude/longitude in degrees when its grid fits the globe, as an EHdr grid is; a projected
//! or geocentric CRS is an error naming it.

use std::collections::BTreeMap;
use std::path::Path;

use super::ifd::Ifd;
use crate::dem::{DemError, GeoGrid};

const MODEL_PIXEL_SCALE: u16 = 33550;
const MODEL_TIEPOINT: u16 = 33922;
const MODEL_TRANSFORMATION: u16 = 34264;
const GEO_KEY_DIRECTORY: u16 = 34735;
const GEO_DOUBLE_PARAMS: u16 = 34736;
const GEO_ASCII_PARAMS: u16 = 34737;

const GT_MODEL_TYPE: u16 = 1024;
const GT_RASTER_TYPE: u16 = 1025;
const GT_CITATION: u16 = 1026;
const GEOGRAPHIC_TYPE: u16 = 2048;
const GEOG_CITATION: u16 = 2049;
const GEOG_ANGULAR_UNITS: u16 = 2054;
const PROJECTED_CS_TYPE: u16 = 3072;
const PCS_CITATION: u16 = 3073;

/// Tolerance, in degrees, of the geographic plausibility checks (as EHdr's).
const GEO_TOLERANCE_DEG: f64 = 1e-6;

/// A GeoKey's value.
#[derive(Clone, Debug)]
enum KeyValue {
    Short(u16),
    /// In GeoDoubleParams (parameters globe does not use).
    Doubles,
    Ascii(String),
}

/// What the georeferencing says, beyond the grid.
#[derive(Clone, Debug)]
pub struct Georeference {
    pub grid: GeoGrid,
    /// GTRasterTypeGeoKey = PixelIsPoint: the tiepoint names a pixel centre (GDAL then shifts
    /// its corner-based geotransform by half a pixel; so do we).
    pub pixel_is_point: bool,
    /// The CRS as the file names it (`EPSG:4326`, or its citation).
    pub crs: String,
}

fn err(path: &Path, field: &str, message: String) -> DemError {
    DemError::Header {
        path: path.to_path_buf(),
        field: field.to_string(),
        message,
    }
}

fn geo_keys(b: &[u8], ifd: &Ifd, path: &Path) -> Result<BTreeMap<u16, KeyValue>, DemError> {
    let Some(dir) = ifd.unsigned(b, GEO_KEY_DIRECTORY, path)? else {
        return Ok(BTreeMap::new());
    };
    if dir.len() < 4 {
        return Err(err(
            path,
            "GeoKeyDirectory",
            format!(
                "{} values; expected at least the 4 of its header",
                dir.len()
            ),
        ));
    }
    // The count is a SHORT in the standard, but a forged file may store the directory as
    // LONG8: the product is checked (found by `fuzz_geotiff`).
    let n = dir[3];
    let needed = n.saturating_mul(4).saturating_add(4);
    if (dir.len() as u64) < needed {
        return Err(err(
            path,
            "GeoKeyDirectory",
            format!("{} values for {n} keys; expected {needed}", dir.len()),
        ));
    }
    let doubles = ifd.doubles(b, GEO_DOUBLE_PARAMS, path)?.unwrap_or_default();
    let ascii = ifd.ascii(b, GEO_ASCII_PARAMS).unwrap_or_default();
    let mut keys = BTreeMap::new();
    for k in 0..n as usize {
        let e = &dir[4 + 4 * k..8 + 4 * k];
        let (id, location, count, value) = (e[0] as u16, e[1] as u16, e[2] as usize, e[3] as usize);
        let v = match location {
            0 => KeyValue::Short(value as u16),
            GEO_DOUBLE_PARAMS => match doubles.get(value..value.saturating_add(count)) {
                Some(_) => KeyValue::Doubles,
                None => continue, // out of range: treated as absent (only citations and
                                  // parameters globe does not use live there)
            },
            GEO_ASCII_PARAMS => {
                let s: String = ascii.chars().skip(value).take(count).collect();
                KeyValue::Ascii(s.trim_end_matches(['|', '\0']).to_string())
            }
            GEO_KEY_DIRECTORY => match dir.get(value) {
                Some(&v) => KeyValue::Short(v as u16),
                None => continue,
            },
            _ => continue,
        };
        keys.insert(id, v);
    }
    Ok(keys)
}

fn short(keys: &BTreeMap<u16, KeyValue>, id: u16) -> Option<u16> {
    match keys.get(&id) {
        Some(KeyValue::Short(v)) => Some(*v),
        _ => None,
    }
}

fn text(keys: &BTreeMap<u16, KeyValue>, id: u16) -> Option<String> {
    match keys.get(&id) {
        Some(KeyValue::Ascii(s)) if !s.trim().is_empty() => Some(s.trim().to_string()),
        _ => None,
    }
}

/// Describes a CRS code and citation: `EPSG:32632 ("WGS 84 / UTM zone 32N")`.
fn crs_name(code: Option<u16>, citation: Option<String>) -> String {
    let code = match code {
        Some(32767) | None => "user-defined CRS".to_string(),
        Some(c) => format!("EPSG:{c}"),
    };
    match citation {
        Some(c) => format!("{code} (\"{c}\")"),
        None => code,
    }
}

/// The grid of pixel centres of a `cols` × `rows` GeoTIFF, refusing anything that is not a
/// north-up geographic (latitude/longitude in degrees) raster.
pub(crate) fn georeference(
    b: &[u8],
    ifd: &Ifd,
    cols: usize,
    rows: usize,
    path: &Path,
) -> Result<Georeference, DemError> {
    let keys = geo_keys(b, ifd, path)?;
    let crs = geographic_crs(&keys, path)?;
    let pixel_is_point = raster_type_is_point(&keys, path)?;
    // (x of raster (0, 0), degrees per column, y of raster (0, 0), degrees per row southward),
    // raster (0, 0) being the upper-left pixel's corner (area) or centre (point).
    let (x0, dx, y0, dy) = if let Some(m) = ifd.doubles(b, MODEL_TRANSFORMATION, path)? {
        from_transformation(&m, path)?
    } else {
        from_scale_and_tiepoint(b, ifd, path)?
    };
    let field = if ifd.has(MODEL_TRANSFORMATION) {
        "ModelTransformation"
    } else {
        "ModelPixelScale"
    };
    if !(dx.is_finite() && dx > 0.0 && dy.is_finite() && dy > 0.0) {
        return Err(err(
            path,
            field,
            format!(
                "pixel size {dx} × {dy}; expected positive degrees, rows running north to south"
            ),
        ));
    }
    let half = if pixel_is_point { 0.0 } else { 0.5 };
    let grid = GeoGrid {
        cols,
        rows,
        lon0_deg: x0 + half * dx,
        lat0_deg: y0 - half * dy,
        dlon_deg: dx,
        dlat_deg: dy,
    };
    check_on_globe(&grid, field, &crs, path)?;
    Ok(Georeference {
        grid,
        pixel_is_point,
        crs,
    })
}

/// The CRS's name, refusing a projected or geocentric model and angular units other than
/// degrees. No CRS at all is accepted (and named so): see the module documentation.
fn geographic_crs(keys: &BTreeMap<u16, KeyValue>, path: &Path) -> Result<String, DemError> {
    let model = short(keys, GT_MODEL_TYPE);
    let projected = short(keys, PROJECTED_CS_TYPE);
    if model == Some(1) || projected.is_some() {
        let citation = text(keys, PCS_CITATION).or_else(|| text(keys, GT_CITATION));
        return Err(err(
            path,
            "ProjectedCSTypeGeoKey",
            format!(
                "the raster is in a projected CRS, {}; globe needs geographic latitude/longitude \
                 (reproject it first, e.g. gdalwarp -t_srs EPSG:4326 IN OUT.tif)",
                crs_name(projected, citation)
            ),
        ));
    }
    if model == Some(3) {
        return Err(err(
            path,
            "GTModelTypeGeoKey",
            "3 (geocentric); expected 2 (geographic latitude/longitude)".into(),
        ));
    }
    if let Some(m) = model
        && m != 2
    {
        return Err(err(
            path,
            "GTModelTypeGeoKey",
            format!("{m}; expected 2 (geographic latitude/longitude)"),
        ));
    }
    let geographic = short(keys, GEOGRAPHIC_TYPE);
    // Degrees: 9102 (EPSG "degree") or 9122 ("degree (supplier to define representation)").
    if let Some(u) = short(keys, GEOG_ANGULAR_UNITS)
        && u != 9102
        && u != 9122
    {
        return Err(err(
            path,
            "GeogAngularUnitsGeoKey",
            format!("EPSG unit {u}; expected degrees (9102)"),
        ));
    }
    // No CRS at all (GDAL writes none for a source without one, such as ETOPO5's netCDF): taken
    // as latitude/longitude, as EHdr grids are, if the grid passes the geographic checks.
    if model.is_none() && geographic.is_none() {
        return Ok("no CRS given (taken as latitude/longitude)".to_string());
    }
    Ok(crs_name(
        geographic,
        text(keys, GEOG_CITATION).or_else(|| text(keys, GT_CITATION)),
    ))
}

/// GTRasterTypeGeoKey: whether the tiepoint names a pixel centre (PixelIsPoint) rather than
/// its corner (PixelIsArea, the default).
fn raster_type_is_point(keys: &BTreeMap<u16, KeyValue>, path: &Path) -> Result<bool, DemError> {
    match short(keys, GT_RASTER_TYPE) {
        None | Some(1) => Ok(false),
        Some(2) => Ok(true),
        Some(other) => Err(err(
            path,
            "GTRasterTypeGeoKey",
            format!("{other}; expected 1 (PixelIsArea) or 2 (PixelIsPoint)"),
        )),
    }
}

/// (x0, dx, y0, dy) from a ModelTransformation, which must be a 4 × 4 matrix without rotation
/// or shear.
fn from_transformation(m: &[f64], path: &Path) -> Result<(f64, f64, f64, f64), DemError> {
    if m.len() != 16 {
        return Err(err(
            path,
            "ModelTransformation",
            format!("{} values; expected 16 (a 4 × 4 matrix)", m.len()),
        ));
    }
    if m[1] != 0.0 || m[4] != 0.0 {
        return Err(err(
            path,
            "ModelTransformation",
            format!(
                "rotated or sheared (terms {} and {}); expected a north-up grid without \
                 rotation (gdalwarp it to one)",
                m[1], m[4]
            ),
        ));
    }
    Ok((m[3], m[0], m[7], -m[5]))
}

/// (x0, dx, y0, dy) from ModelPixelScale and one ModelTiepoint, both required when there is no
/// ModelTransformation.
fn from_scale_and_tiepoint(
    b: &[u8],
    ifd: &Ifd,
    path: &Path,
) -> Result<(f64, f64, f64, f64), DemError> {
    let scale = ifd.doubles(b, MODEL_PIXEL_SCALE, path)?;
    let tie = ifd.doubles(b, MODEL_TIEPOINT, path)?;
    let (Some(scale), Some(tie)) = (scale, tie) else {
        return Err(err(
            path,
            "ModelPixelScale",
            "absent (with ModelTiepoint), and no ModelTransformation: the raster is not \
             georeferenced; expected a GeoTIFF"
                .into(),
        ));
    };
    if scale.len() < 2 {
        return Err(err(
            path,
            "ModelPixelScale",
            format!("{} values; expected 3 (x, y, z)", scale.len()),
        ));
    }
    if tie.len() != 6 {
        return Err(err(
            path,
            "ModelTiepoint",
            format!(
                "{} values; expected one tiepoint of 6 (ground control points are not \
                 supported: gdalwarp the file to a regular grid)",
                tie.len()
            ),
        ));
    }
    Ok((
        tie[3] - tie[0] * scale[0],
        scale[0],
        tie[4] + tie[1] * scale[1],
        scale[1],
    ))
}

/// Refuses a grid that cannot be latitude/longitude in degrees: pixel centres beyond the poles,
/// more than 360° wide, or starting beyond ±360°. `field` names the tag that placed it.
fn check_on_globe(grid: &GeoGrid, field: &str, crs: &str, path: &Path) -> Result<(), DemError> {
    let north = grid.lat0_deg;
    let south = grid.lat_of_row(grid.rows as f64 - 1.0);
    if !(north <= 90.0 + GEO_TOLERANCE_DEG && south >= -90.0 - GEO_TOLERANCE_DEG) {
        return Err(err(
            path,
            field,
            format!(
                "pixel centres from latitude {north}° to {south}°; expected them within [-90°, \
                 90°]: is the CRS ({crs}) really geographic degrees?"
            ),
        ));
    }
    let (cols, dx) = (grid.cols, grid.dlon_deg);
    let width = cols as f64 * dx;
    if width > 360.0 + GEO_TOLERANCE_DEG {
        return Err(err(
            path,
            field,
            format!("the grid is {width}° wide ({cols} columns × {dx}°); expected at most 360°"),
        ));
    }
    if !(-360.0..=360.0).contains(&grid.lon0_deg) {
        return Err(err(
            path,
            field,
            format!(
                "first longitude {}; expected a value within ±360°",
                grid.lon0_deg
            ),
        ));
    }
    Ok(())
}
