//! The CF raster adaptor: a 2-D latitude × longitude variable of a [`NetcdfFile`] as a
//! [`RasterSource`] of heights in metres. Rows run north → south whatever the file's order,
//! coordinate axes close to a regular grid are replaced by the exact regular values (reported
//! by [`NetcdfRaster::notes`]), `scale_factor`/`add_offset` and `_FillValue`/`missing_value`
//! (and `valid_range`/`valid_min`/`valid_max`) are applied (no data → `NaN`), and heights in
//! feet or kilometres become metres.

use std::fmt;
use std::path::Path;

use super::format::{AttrValue, NcType, NetcdfFile, Variable};
use crate::dem::DemError;
use crate::dem::raster::{GeoGrid, RasterSource};
/// A regular axis fitted to a stored coordinate variable.
#[derive(Clone, Copy, Debug)]
struct Axis {
    /// Value at index 0 of the axis as stored.
    first: f64,
    /// Signed step per index as stored (negative for a descending axis).
    step: f64,
    /// A longitude axis whose last value repeats the first one 360° on (n − 1 steps span the
    /// circle): the last column duplicates the first.
    repeats_first: bool,
}

/// How far (in units of the spacing) a stored coordinate may be from the regular grid and still
/// be taken as that grid.
pub const AXIS_TOLERANCE: f64 = 0.1;

/// Relative difference within which a stored spacing is taken as a round value (a whole number
/// of arc-seconds, or 1/k degree).
const SPACING_SNAP: f64 = 1e-5;

/// Fits an exact regular axis to stored coordinates (values in degrees).
///
/// - Spacing: 360/n for a longitude axis that covers the circle (360/(n−1) when the last value
///   repeats the first), 180/(n−1) for a latitude axis from pole to pole, else a whole number of
///   arc-seconds or 1/k degree when within [`SPACING_SNAP`], else as stored.
/// - First value: rounded to the nearest multiple of half the spacing when close (pixel centres
///   sit on whole or half steps from 0° in every common grid); ±90° exactly for pole to pole.
/// - Every stored value must then lie within [`AXIS_TOLERANCE`] spacing of the regular grid.
///
/// Returns the axis and, when the regular values differ from the stored ones, a note.
fn fit_axis(name: &str, values: &[f64], is_lon: bool) -> Result<(Axis, Option<String>), String> {
    let n = values.len();
    if n < 2 {
        return Err(format!(
            "coordinate {name:?} has {n} value(s); at least 2 are needed for a spacing"
        ));
    }
    if values.iter().any(|v| !v.is_finite()) {
        return Err(format!("coordinate {name:?} has non-finite values"));
    }
    let (a, b) = (values[0], values[n - 1]);
    let raw = (b - a) / (n - 1) as f64;
    if raw == 0.0 {
        return Err(format!("coordinate {name:?} is constant ({a})"));
    }
    let sign = raw.signum();
    let mag = raw.abs();
    let close = |x: f64, y: f64| (x - y).abs() <= AXIS_TOLERANCE * mag;

    let full_circle = is_lon && close(n as f64 * mag, 360.0);
    let repeats_first = is_lon && !full_circle && close((n - 1) as f64 * mag, 360.0);
    let pole_to_pole = !is_lon && close(a.abs(), 90.0) && close(b.abs(), 90.0) && a * b < 0.0;
    let (d, how) = if full_circle {
        (360.0 / n as f64, "covers the circle: spacing 360°/n")
    } else if repeats_first {
        (
            360.0 / (n - 1) as f64,
            "last value repeats the first 360° on: spacing 360°/(n−1)",
        )
    } else if pole_to_pole {
        (180.0 / (n - 1) as f64, "pole to pole: spacing 180°/(n−1)")
    } else {
        let arcsec = (mag * 3600.0).round() / 3600.0;
        let k = (1.0 / mag).round();
        if arcsec > 0.0 && (arcsec - mag).abs() <= SPACING_SNAP * mag {
            (arcsec, "spacing a whole number of arc-seconds")
        } else if k >= 1.0 && (1.0 / k - mag).abs() <= SPACING_SNAP * mag {
            (1.0 / k, "spacing 1/k degree")
        } else {
            (mag, "")
        }
    };
    let half = d / 2.0;
    let snapped = (a / half).round() * half;
    let first = if pole_to_pole {
        90.0_f64.copysign(a)
    } else if close(snapped, a) {
        snapped
    } else {
        a
    };
    let step = d * sign;
    let mut worst: f64 = 0.0;
    for (i, &v) in values.iter().enumerate() {
        worst = worst.max((v - (first + i as f64 * step)).abs());
    }
    if worst > AXIS_TOLERANCE * d {
        return Err(format!(
            "coordinate {name:?} is not a regular grid: a value is {worst:.6}° from the best \
             regular fit (first {first}, spacing {d}); the tolerance is {AXIS_TOLERANCE} spacing"
        ));
    }
    let note = (worst > 0.0 || first != a || step != raw).then(|| {
        format!(
            "coordinate {name:?} ({n} values, stored {a}…{b}, step {raw}) taken as the regular \
             grid {first} + i·{step}{}; largest stored deviation {worst:.3e}° ({:.2e} of a spacing)",
            if how.is_empty() {
                String::new()
            } else {
                format!(" ({how})")
            },
            worst / d
        )
    });
    Ok((
        Axis {
            first,
            step,
            repeats_first,
        },
        note,
    ))
}

/// Unit conversion to metres of a height variable's `units` attribute, or `None` if unknown.
fn metres_per_unit(units: &str) -> Option<f64> {
    let u = units.trim().to_ascii_lowercase();
    match u.as_str() {
        "m" | "meter" | "meters" | "metre" | "metres" => Some(1.0),
        "ft" | "feet" | "foot" | "international_foot" | "international_feet" => Some(0.3048),
        "km" | "kilometer" | "kilometers" | "kilometre" | "kilometres" => Some(1000.0),
        _ => None,
    }
}

/// Which role a dimension's coordinate plays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    Lat,
    Lon,
}

fn role_of(nc: &NetcdfFile, dim_name: &str) -> Option<Role> {
    let coord = nc.variable(dim_name);
    let text = |a: &str| {
        coord
            .and_then(|v| v.attribute(a))
            .and_then(AttrValue::as_text)
            .map(|s| s.trim().to_ascii_lowercase())
    };
    if let Some(u) = text("units") {
        if u.starts_with("degrees_north") || u == "degree_north" || u == "degrees_n" {
            return Some(Role::Lat);
        }
        if u.starts_with("degrees_east") || u == "degree_east" || u == "degrees_e" {
            return Some(Role::Lon);
        }
    }
    if let Some(s) = text("standard_name") {
        match s.as_str() {
            "latitude" => return Some(Role::Lat),
            "longitude" => return Some(Role::Lon),
            _ => {}
        }
    }
    if let Some(ax) = text("axis") {
        match ax.as_str() {
            "y" => return Some(Role::Lat),
            "x" => return Some(Role::Lon),
            _ => {}
        }
    }
    let n = dim_name.to_ascii_lowercase();
    if n.starts_with("lat") || n == "y" || n.ends_with("_y") {
        return Some(Role::Lat);
    }
    if n.starts_with("lon") || n == "x" || n.ends_with("_x") {
        return Some(Role::Lon);
    }
    None
}

/// A 2-D latitude × longitude variable of a netCDF-3 file as a [`RasterSource`] of heights in
/// metres, rows north → south.
pub struct NetcdfRaster {
    nc: NetcdfFile,
    /// Index of the height variable in [`NetcdfFile::variables`].
    var: usize,
    place: Placement,
    unpack: Unpacking,
    notes: Vec<String>,
}

impl fmt::Debug for NetcdfRaster {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("NetcdfRaster")
            .field("path", &self.nc.path())
            .field("variable", &self.variable_name())
            .field("grid", &self.place.grid)
            .field("notes", &self.notes)
            .finish()
    }
}

/// Where the output grid lies in the variable's flat (row-major) element order.
#[derive(Clone, Copy, Debug)]
struct Placement {
    grid: GeoGrid,
    /// Flat element index of output (row 0, col 0), and strides per output row / column.
    origin: isize,
    row_stride: isize,
    col_stride: isize,
}

/// How a raw stored value becomes metres: CF packing, no-data values and units.
#[derive(Clone, Debug)]
struct Unpacking {
    scale: f64,
    offset: f64,
    /// Raw values that mean "no data".
    fills: Vec<f64>,
    /// Raw values outside `[valid_min, valid_max]` are no data.
    valid: (f64, f64),
    to_metres: f64,
}

fn numeric(v: &Variable) -> bool {
    v.nc_type != NcType::Char
}

/// The height variable: the one named, which must be 2-D and numeric, or else the only 2-D
/// numeric variable whose dimensions both have coordinate variables (or, failing that, the only
/// 2-D numeric variable).
fn pick_variable(nc: &NetcdfFile, variable: Option<&str>) -> Result<usize, DemError> {
    let vars = nc.variables();
    if let Some(name) = variable {
        let i = vars
            .iter()
            .position(|v| v.name == name)
            .ok_or_else(|| nc.missing_var_err(name))?;
        let v = &vars[i];
        if v.dim_ids.len() != 2 || !numeric(v) {
            return Err(nc.header_err(
                &format!("var_list[{name:?}]"),
                format!(
                    "expected a 2-D numeric variable, found {}-D {}",
                    v.dim_ids.len(),
                    v.nc_type
                ),
            ));
        }
        return Ok(i);
    }
    let two_d: Vec<usize> = (0..vars.len())
        .filter(|&i| vars[i].dim_ids.len() == 2 && numeric(&vars[i]))
        .collect();
    let with_coords: Vec<usize> = two_d
        .iter()
        .copied()
        .filter(|&i| {
            vars[i].dim_ids.iter().all(|&d| {
                nc.variable(&nc.dimensions()[d].name)
                    .is_some_and(|c| c.dim_ids == [d])
            })
        })
        .collect();
    match (with_coords.as_slice(), two_d.as_slice()) {
        ([one], _) | ([], [one]) => Ok(*one),
        _ => {
            let names: Vec<&str> = two_d.iter().map(|&i| vars[i].name.as_str()).collect();
            Err(nc.header_err(
                "var_list",
                format!(
                    "cannot pick the height variable: expected exactly one 2-D numeric variable, \
                     found {names:?}; name one"
                ),
            ))
        }
    }
}

/// Whether the variable's first dimension is latitude (else its second is).
fn latitude_first(
    nc: &NetcdfFile,
    v: &Variable,
    notes: &mut Vec<String>,
) -> Result<bool, DemError> {
    let dnames: Vec<String> = v
        .dim_ids
        .iter()
        .map(|&d| nc.dimensions()[d].name.clone())
        .collect();
    let roles = [role_of(nc, &dnames[0]), role_of(nc, &dnames[1])];
    match roles {
        [Some(Role::Lat), Some(Role::Lon) | None] | [None, Some(Role::Lon)] => Ok(true),
        [Some(Role::Lon), Some(Role::Lat) | None] | [None, Some(Role::Lat)] => Ok(false),
        [None, None] => {
            notes.push(format!(
                "dimensions {dnames:?} not recognised as latitude/longitude; assumed \
                 (latitude, longitude)"
            ));
            Ok(true)
        }
        _ => Err(nc.header_err(
            &format!("var_list[{:?}].dimensions", v.name),
            format!(
                "expected one latitude and one longitude dimension, found {dnames:?} taken as \
                 {roles:?}"
            ),
        )),
    }
}

/// The regular axis of dimension `dim`, fitted to its 1-D coordinate variable (unpacked with
/// the coordinate's own `scale_factor`/`add_offset`).
fn coordinate_axis(
    nc: &NetcdfFile,
    dim: usize,
    is_lon: bool,
    notes: &mut Vec<String>,
) -> Result<Axis, DemError> {
    let dname = &nc.dimensions()[dim].name;
    let field = format!("var_list[{dname:?}]");
    let c = nc
        .variable(dname)
        .filter(|c| c.dim_ids == [dim] && numeric(c))
        .ok_or_else(|| {
            nc.header_err(
                &field,
                format!(
                    "no 1-D coordinate variable for dimension {dname:?}, so the {} of the nodes \
                     are unknown",
                    if is_lon { "longitudes" } else { "latitudes" }
                ),
            )
        })?;
    let mut vals = nc.read_f64(&c.name)?;
    let s = c.attribute("scale_factor").and_then(AttrValue::first_f64);
    let o = c.attribute("add_offset").and_then(AttrValue::first_f64);
    for x in &mut vals {
        *x = *x * s.unwrap_or(1.0) + o.unwrap_or(0.0);
    }
    let (a, note) = fit_axis(dname, &vals, is_lon).map_err(|m| nc.header_err(&field, m))?;
    notes.extend(note);
    Ok(a)
}

/// The output grid (rows north → south, columns west → east, a repeated wrap-around column
/// dropped) and where it lies in the stored element order.
fn place_grid(
    nc: &NetcdfFile,
    v: &Variable,
    notes: &mut Vec<String>,
) -> Result<Placement, DemError> {
    let lat_first = latitude_first(nc, v, notes)?;
    let (lat_dim, lon_dim) = if lat_first {
        (v.dim_ids[0], v.dim_ids[1])
    } else {
        (v.dim_ids[1], v.dim_ids[0])
    };
    let dims = nc.dimensions();
    let (nlat, nlon_stored) = (dims[lat_dim].len, dims[lon_dim].len);
    if nlat < 2 || nlon_stored < 2 {
        return Err(nc.header_err(
            &format!("var_list[{:?}].dimensions", v.name),
            format!("need at least 2×2 nodes, found {nlon_stored} longitudes × {nlat} latitudes"),
        ));
    }
    let lat = coordinate_axis(nc, lat_dim, false, notes)?;
    let lon = coordinate_axis(nc, lon_dim, true, notes)?;
    let dlat = lat.step.abs();
    let dlon = lon.step.abs();
    // A repeated wrap-around column is dropped (the output's last column).
    let nlon = nlon_stored - usize::from(lon.repeats_first);
    if lon.repeats_first {
        notes.push(format!(
            "the last of the {nlon_stored} longitudes repeats the first 360° on; that column is \
             dropped, leaving {nlon} that cover the circle"
        ));
    }
    // Output rows run north → south, columns west → east.
    let lat_idx0 = if lat.step > 0.0 { nlat - 1 } else { 0 };
    let lon_idx0 = if lon.step > 0.0 { 0 } else { nlon_stored - 1 };
    let lat0 = lat.first + lat_idx0 as f64 * lat.step;
    let lon0 = lon.first + lon_idx0 as f64 * lon.step;
    if lat.step > 0.0 {
        notes.push("latitude runs south → north in the file; rows flipped".into());
    }
    if lon.step < 0.0 {
        notes.push("longitude runs east → west in the file; columns flipped".into());
    }
    if lat0 > 90.0 + 1e-9 || lat0 - (nlat - 1) as f64 * dlat < -90.0 - 1e-9 {
        return Err(nc.header_err(
            &format!("var_list[{:?}]", dims[lat_dim].name),
            format!(
                "latitudes {}…{lat0} leave [−90°, 90°]",
                lat0 - (nlat - 1) as f64 * dlat
            ),
        ));
    }
    // Element strides in the file for one step south / east.
    let (s_lat, s_lon) = if lat_first {
        (nlon_stored as isize, 1isize)
    } else {
        (1isize, nlat as isize)
    };
    Ok(Placement {
        grid: GeoGrid {
            cols: nlon,
            rows: nlat,
            lon0_deg: lon0,
            lat0_deg: lat0,
            dlon_deg: dlon,
            dlat_deg: dlat,
        },
        origin: lat_idx0 as isize * s_lat + lon_idx0 as isize * s_lon,
        row_stride: if lat.step > 0.0 { -s_lat } else { s_lat },
        col_stride: if lon.step > 0.0 { s_lon } else { -s_lon },
    })
}

impl Unpacking {
    /// From the variable's `scale_factor`/`add_offset`, `_FillValue`/`missing_value` (the
    /// type's default fill when there is no `_FillValue`), `valid_*` and `units` attributes.
    fn of(v: &Variable, notes: &mut Vec<String>) -> Unpacking {
        let num = |a: &str| v.attribute(a).and_then(AttrValue::first_f64);
        let scale = num("scale_factor").unwrap_or(1.0);
        let offset = num("add_offset").unwrap_or(0.0);
        if scale != 1.0 || offset != 0.0 {
            notes.push(format!("values unpacked as raw·{scale} + {offset}"));
        }
        let mut fills = Vec::new();
        for a in ["_FillValue", "missing_value"] {
            if let Some(vals) = v.attribute(a).and_then(AttrValue::as_f64s) {
                fills.extend(vals);
            }
        }
        if v.attribute("_FillValue").is_none() && v.nc_type != NcType::Byte {
            fills.push(v.nc_type.default_fill());
        }
        // Compare in the variable's own type (a double attribute on a float variable).
        if v.nc_type == NcType::Float {
            for f in &mut fills {
                *f = f64::from(*f as f32);
            }
        }
        let mut valid = (f64::NEG_INFINITY, f64::INFINITY);
        if let Some(r) = v.attribute("valid_range").and_then(AttrValue::as_f64s)
            && r.len() == 2
        {
            valid = (r[0], r[1]);
        }
        if let Some(x) = num("valid_min") {
            valid.0 = x;
        }
        if let Some(x) = num("valid_max") {
            valid.1 = x;
        }
        Unpacking {
            scale,
            offset,
            fills,
            valid,
            to_metres: to_metres(v, notes),
        }
    }

    fn convert(&self, raw: f64) -> f32 {
        if raw.is_nan() || self.fills.contains(&raw) || raw < self.valid.0 || raw > self.valid.1 {
            return f32::NAN;
        }
        ((raw * self.scale + self.offset) * self.to_metres) as f32
    }
}

/// Metres per unit of the variable's `units` (metres when absent or unknown, with a note).
fn to_metres(v: &Variable, notes: &mut Vec<String>) -> f64 {
    match v.attribute("units").and_then(AttrValue::as_text) {
        Some(u) => match metres_per_unit(u) {
            Some(k) => {
                if k != 1.0 {
                    notes.push(format!("heights in {u:?} converted to metres (×{k})"));
                }
                k
            }
            None => {
                notes.push(format!("unknown height units {u:?}; taken as metres"));
                1.0
            }
        },
        None => {
            notes.push("no units attribute; heights taken as metres".into());
            1.0
        }
    }
}

impl NetcdfRaster {
    /// Opens a netCDF-3 file as a raster. `variable` names the height variable; `None` picks the
    /// only 2-D numeric variable whose dimensions both have coordinate variables (or, failing
    /// that, the only 2-D numeric variable).
    pub fn open(path: impl AsRef<Path>, variable: Option<&str>) -> Result<NetcdfRaster, DemError> {
        Self::from_file(NetcdfFile::open(path)?, variable)
    }

    /// As [`NetcdfRaster::open`], from an already opened file.
    pub fn from_file(nc: NetcdfFile, variable: Option<&str>) -> Result<NetcdfRaster, DemError> {
        let var = pick_variable(&nc, variable)?;
        let v = &nc.variables()[var];
        let mut notes = Vec::new();
        let place = place_grid(&nc, v, &mut notes)?;
        let unpack = Unpacking::of(v, &mut notes);
        Ok(NetcdfRaster {
            nc,
            var,
            place,
            unpack,
            notes,
        })
    }

    /// The underlying file (header, attributes, other variables).
    pub fn file(&self) -> &NetcdfFile {
        &self.nc
    }

    /// The height variable's name.
    pub fn variable_name(&self) -> &str {
        &self.variable().name
    }

    fn variable(&self) -> &Variable {
        &self.nc.variables()[self.var]
    }

    /// What the adaptor did beyond reading values: axes snapped to exact regular grids, rows
    /// flipped, units converted, values unpacked.
    pub fn notes(&self) -> &[String] {
        &self.notes
    }

    /// Height in metres at node (row, col) (row 0 northernmost).
    pub fn value(&self, row: usize, col: usize) -> Result<f32, DemError> {
        let p = &self.place;
        if row >= p.grid.rows || col >= p.grid.cols {
            return Err(self.nc.data_err(format!(
                "node ({row}, {col}) outside the {}×{} grid",
                p.grid.rows, p.grid.cols
            )));
        }
        let flat = p.origin + row as isize * p.row_stride + col as isize * p.col_stride;
        let mut x = [0.0];
        self.nc
            .read_var_with(self.variable(), flat as usize, 1, |_, v| x[0] = v)?;
        Ok(self.unpack.convert(x[0]))
    }
}

impl RasterSource for NetcdfRaster {
    fn grid(&self) -> GeoGrid {
        self.place.grid
    }

    fn read_row(&self, row: usize, out: &mut [f32]) -> Result<(), DemError> {
        let p = &self.place;
        let g = p.grid;
        if row >= g.rows || out.len() != g.cols {
            return Err(self.nc.data_err(format!(
                "read_row({row}) with a buffer of {} on a {}×{} grid (rows × cols)",
                out.len(),
                g.rows,
                g.cols
            )));
        }
        let v = self.variable();
        let u = &self.unpack;
        let start = p.origin + row as isize * p.row_stride;
        if p.col_stride == 1 {
            self.nc.read_var_with(v, start as usize, g.cols, |i, x| {
                out[i] = u.convert(x);
            })
        } else if p.col_stride == -1 {
            let first = start as usize + 1 - g.cols;
            self.nc.read_var_with(v, first, g.cols, |i, x| {
                out[g.cols - 1 - i] = u.convert(x);
            })
        } else {
            for (c, o) in out.iter_mut().enumerate() {
                let flat = start + c as isize * p.col_stride;
                let mut x = 0.0;
                self.nc
                    .read_var_with(v, flat as usize, 1, |_, val| x = val)?;
                *o = u.convert(x);
            }
            Ok(())
        }
    }

    fn describe(&self) -> String {
        let g = self.place.grid;
        format!(
            "netCDF-3 (CDF-{}) {} variable {:?}, {}×{} nodes at {}°",
            self.nc.version(),
            self.nc.path().display(),
            self.variable_name(),
            g.cols,
            g.rows,
            g.dlon_deg
        )
    }
}
