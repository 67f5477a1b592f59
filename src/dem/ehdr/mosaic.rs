//! A folder of EHdr tiles (e.g. GTOPO30's 33, or any subset) as one raster over the bounding
//! grid of their union.

use std::path::{Path, PathBuf};

use super::reader::EhdrRaster;
use super::sample::{self, PixelSource};
use crate::dem::mosaic::{MosaicTile, read_mosaic_row};
use crate::dem::{DemError, GeoGrid, RasterSource};

/// Relative tolerance on XDIM/YDIM between tiles.
const SPACING_TOLERANCE: f64 = 1e-9;
/// Tolerance, in pixels, of tile alignment to the common lattice.
const LATTICE_TOLERANCE_PIXELS: f64 = 1e-3;
/// Relative tolerance for values of overlapping tiles to count as equal.
const OVERLAP_TOLERANCE: f32 = 1e-6;

struct Tile {
    raster: EhdrRaster,
    /// Position of the tile's pixel (0, 0) in the mosaic grid.
    row0: usize,
    col0: usize,
    /// Whether another tile covers some of the same pixels.
    overlaps: bool,
}

impl MosaicTile for Tile {
    fn rows(&self) -> std::ops::Range<usize> {
        self.row0..self.row0 + self.raster.header().nrows
    }

    fn cols(&self) -> std::ops::Range<usize> {
        self.col0..self.col0 + self.raster.header().ncols
    }

    fn may_overlap(&self) -> bool {
        self.overlaps
    }

    fn read_tile_row(&self, row: usize, out: &mut [f32]) -> Result<(), DemError> {
        self.raster.read_row(row, out)
    }
}

impl Tile {
    fn contains(&self, row: usize, col: usize) -> bool {
        self.rows().contains(&row) && self.cols().contains(&col)
    }
}

/// Tiles sharing one pixel lattice, read as one raster: pixels no tile covers (and NODATA) are
/// NaN. Overlapping tiles must agree where they overlap (checked at open; a pixel that is NODATA
/// in one tile and has a value in the other takes the value).
pub struct EhdrMosaic {
    description: String,
    grid: GeoGrid,
    tiles: Vec<Tile>,
}

impl std::fmt::Debug for EhdrMosaic {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EhdrMosaic")
            .field("description", &self.description)
            .field("grid", &self.grid)
            .field("tiles", &self.tiles.len())
            .finish()
    }
}

fn file_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

fn values_agree(a: f32, b: f32) -> bool {
    a == b || (a - b).abs() <= OVERLAP_TOLERANCE * a.abs().max(b.abs()).max(1.0)
}

impl EhdrMosaic {
    /// A mosaic's bounding grid may hold at most this many times the pixels of its tiles: it is
    /// read (and stored in a pyramid) in full, so two small tiles far apart on a fine lattice
    /// would otherwise ask for gigabytes (two 6 × 8 tiles at XDIM 1e-10, 0.5° apart, made a
    /// 5·10⁹-column mosaic: a 20 GB row). GTOPO30's sparsest subset, two opposite corner
    /// tiles, fills 1/17 of its bounding grid.
    pub const MAX_BOUNDING_FACTOR: usize = 64;

    /// Opens every `.HDR` (any case) in `dir` (not recursively) with its data file, as one
    /// mosaic. The tiles must share XDIM/YDIM and one pixel lattice; see [`Self::from_rasters`].
    pub fn open_dir(dir: &Path) -> Result<EhdrMosaic, DemError> {
        if !dir.is_dir() {
            return Err(DemError::Missing {
                path: dir.to_path_buf(),
                message: "folder not found; expected a folder of EHdr tiles (.HDR + .DEM)".into(),
            });
        }
        let listing = std::fs::read_dir(dir).map_err(|source| DemError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
        let mut headers: Vec<PathBuf> = Vec::new();
        for entry in listing {
            let entry = entry.map_err(|source| DemError::Io {
                path: dir.to_path_buf(),
                source,
            })?;
            let path = entry.path();
            if path
                .extension()
                .is_some_and(|x| x.eq_ignore_ascii_case("hdr"))
                && path.is_file()
            {
                headers.push(path);
            }
        }
        if headers.is_empty() {
            return Err(DemError::Missing {
                path: dir.to_path_buf(),
                message: "no .HDR files in this folder; expected EHdr tiles such as W020N40.HDR \
                          + W020N40.DEM"
                    .into(),
            });
        }
        headers.sort();
        let rasters = headers
            .iter()
            .map(|h| EhdrRaster::open(h))
            .collect::<Result<Vec<_>, _>>()?;
        Self::from_rasters(rasters, format!("{}", dir.display()))
    }

    /// Joins opened rasters into one mosaic. The first raster's lattice is the reference: every
    /// other must have the same XDIM/YDIM (relative 1e-9) and sit a whole number of pixels
    /// from it (within 1e-3 pixel), else the error names both files. The bounding grid may
    /// hold at most [`Self::MAX_BOUNDING_FACTOR`] × the tiles' pixels. Overlaps are compared
    /// pixel by pixel here.
    pub fn from_rasters(
        rasters: Vec<EhdrRaster>,
        description: impl Into<String>,
    ) -> Result<EhdrMosaic, DemError> {
        let description = description.into();
        let Some(reference) = rasters.first() else {
            return Err(DemError::Other(format!(
                "{description}: a mosaic needs at least one tile"
            )));
        };
        let rg = reference.grid();
        let ref_name = file_name(reference.header_path());
        let offsets = rasters
            .iter()
            .map(|t| lattice_offset(t, &rg, &ref_name))
            .collect::<Result<Vec<_>, _>>()?;
        let bounds = Bounds::of(&rasters, &offsets);
        bounds.check_size(&rasters, &rg, &description)?;
        let grid = GeoGrid {
            cols: bounds.cols(),
            rows: bounds.rows(),
            lon0_deg: rasters[bounds.west].grid().lon0_deg,
            lat0_deg: rasters[bounds.north].grid().lat0_deg,
            dlon_deg: rg.dlon_deg,
            dlat_deg: rg.dlat_deg,
        };
        let mut tiles: Vec<Tile> = rasters
            .into_iter()
            .zip(offsets)
            .map(|(raster, (kr, kc))| Tile {
                raster,
                row0: (kr - bounds.min_r) as usize,
                col0: (kc - bounds.min_c) as usize,
                overlaps: false,
            })
            .collect();
        mark_overlaps(&mut tiles, &grid)?;
        Ok(EhdrMosaic {
            description,
            grid,
            tiles,
        })
    }

    /// The grid of pixel centres of the union's bounding box.
    pub fn grid(&self) -> GeoGrid {
        self.grid
    }

    /// The tiles, in the order given (for `open_dir`, sorted by file name).
    pub fn tiles(&self) -> impl Iterator<Item = &EhdrRaster> {
        self.tiles.iter().map(|t| &t.raster)
    }

    /// Where a tile's pixel (0, 0) sits in the mosaic grid, as (row, col).
    pub fn tile_origins(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.tiles.iter().map(|t| (t.row0, t.col0))
    }

    /// The value at mosaic (row, col): `Ok(None)` for NODATA or where no tile covers it.
    pub fn value(&self, row: usize, col: usize) -> Result<Option<f32>, DemError> {
        if row >= self.grid.rows || col >= self.grid.cols {
            return Err(DemError::Other(format!(
                "{}: row {row}, column {col} is outside the mosaic ({} rows, {} columns)",
                self.description, self.grid.rows, self.grid.cols
            )));
        }
        for t in &self.tiles {
            if t.contains(row, col)
                && let Some(v) = t.raster.value(row - t.row0, col - t.col0)?
            {
                return Ok(Some(v));
            }
        }
        Ok(None)
    }

    /// The mosaic pixel containing (lat, lon) (GDAL's nearest-pixel rule); `None` outside.
    pub fn pixel_of(&self, lat_deg: f64, lon_deg: f64) -> Option<(usize, usize)> {
        sample::pixel_of(&self.grid, lat_deg, lon_deg)
    }

    /// The value of the pixel containing (lat, lon); `Ok(None)` for no data or outside.
    pub fn sample_nearest(&self, lat_deg: f64, lon_deg: f64) -> Result<Option<f32>, DemError> {
        sample::nearest(self, lat_deg, lon_deg)
    }

    /// Bilinear between pixel centres, across tile boundaries; as
    /// [`EhdrRaster::sample_bilinear`].
    pub fn sample_bilinear(&self, lat_deg: f64, lon_deg: f64) -> Result<Option<f64>, DemError> {
        sample::bilinear(self, lat_deg, lon_deg)
    }
}

/// Where tile `t` sits on the reference lattice `rg` (of the tile `ref_name`), as (row,
/// column) offsets in pixels: it must share XDIM/YDIM and lie a whole number of pixels away.
fn lattice_offset(t: &EhdrRaster, rg: &GeoGrid, ref_name: &str) -> Result<(i64, i64), DemError> {
    let g = t.grid();
    let err = |field: &str, message: String| DemError::Header {
        path: t.header_path().to_path_buf(),
        field: field.to_string(),
        message,
    };
    for (field, mine, theirs) in [
        ("XDIM", g.dlon_deg, rg.dlon_deg),
        ("YDIM", g.dlat_deg, rg.dlat_deg),
    ] {
        if (mine - theirs).abs() > SPACING_TOLERANCE * theirs {
            return Err(err(
                field,
                format!(
                    "{field} {mine} differs from {field} {theirs} of {ref_name}; \
                     expected the tiles of a mosaic to share XDIM and YDIM"
                ),
            ));
        }
    }
    let kc = (g.lon0_deg - rg.lon0_deg) / rg.dlon_deg;
    let kr = (rg.lat0_deg - g.lat0_deg) / rg.dlat_deg;
    for (field, k, axis) in [("ULXMAP", kc, "columns"), ("ULYMAP", kr, "rows")] {
        if !k.is_finite()
            || k.abs() >= 2f64.powi(40)
            || (k - k.round()).abs() > LATTICE_TOLERANCE_PIXELS
        {
            return Err(err(
                field,
                format!(
                    "not on the pixel lattice of {ref_name}: its {axis} are offset by \
                     {k} pixels from that tile's; expected a whole number (the tiles of \
                     a mosaic must share one grid)"
                ),
            ));
        }
    }
    Ok((kr.round() as i64, kc.round() as i64))
}

/// The bounding box of the tiles on the reference lattice (pixel offsets, end exclusive), and
/// which tiles set its north, west and east edges (their files name the edges in messages).
struct Bounds {
    min_r: i64,
    min_c: i64,
    max_r: i64,
    max_c: i64,
    north: usize,
    west: usize,
    east: usize,
}

impl Bounds {
    /// The box around `rasters` placed at `offsets` (first tile wins ties).
    fn of(rasters: &[EhdrRaster], offsets: &[(i64, i64)]) -> Bounds {
        let mut b = Bounds {
            min_r: i64::MAX,
            min_c: i64::MAX,
            max_r: i64::MIN,
            max_c: i64::MIN,
            north: 0,
            west: 0,
            east: 0,
        };
        for (i, (t, &(kr, kc))) in rasters.iter().zip(offsets).enumerate() {
            let h = t.header();
            if kr < b.min_r {
                b.min_r = kr;
                b.north = i;
            }
            if kc < b.min_c {
                b.min_c = kc;
                b.west = i;
            }
            b.max_r = b.max_r.max(kr + h.nrows as i64);
            if kc + h.ncols as i64 > b.max_c {
                b.max_c = kc + h.ncols as i64;
                b.east = i;
            }
        }
        b
    }

    fn rows(&self) -> usize {
        (self.max_r - self.min_r) as usize
    }

    fn cols(&self) -> usize {
        (self.max_c - self.min_c) as usize
    }

    /// Refuses a box wider than 360° of longitude, or one the tiles fill less than
    /// 1/[`EhdrMosaic::MAX_BOUNDING_FACTOR`] of: checked before anything allocates or reads by
    /// the bounding grid.
    fn check_size(
        &self,
        rasters: &[EhdrRaster],
        rg: &GeoGrid,
        description: &str,
    ) -> Result<(), DemError> {
        let rows = self.rows();
        let cols = self.cols();
        let width = cols as f64 * rg.dlon_deg;
        if width > 360.0 + 1e-6 {
            return Err(DemError::Data {
                path: rasters[self.west].header_path().to_path_buf(),
                message: format!(
                    "the tiles of {description} span {width}° of longitude from this, the \
                     westernmost tile; expected at most 360° (mixed longitude conventions?)"
                ),
            });
        }
        let tile_pixels: u128 = rasters
            .iter()
            .map(|t| t.header().nrows as u128 * t.header().ncols as u128)
            .sum();
        let bounding = rows as u128 * cols as u128;
        if bounding > EhdrMosaic::MAX_BOUNDING_FACTOR as u128 * tile_pixels {
            return Err(DemError::Data {
                path: description.into(),
                message: format!(
                    "the tiles hold {tile_pixels} pixels but span a bounding grid of {cols} × \
                     {rows} = {bounding} pixels at XDIM {}, YDIM {} ({} is the westernmost \
                     tile, {} the easternmost); expected tiles covering at least 1/{} of their \
                     bounding grid: a mosaic is read and stored in full, so tiles far apart on \
                     a fine lattice would make a mostly empty raster",
                    rg.dlon_deg,
                    rg.dlat_deg,
                    file_name(rasters[self.west].header_path()),
                    file_name(rasters[self.east].header_path()),
                    EhdrMosaic::MAX_BOUNDING_FACTOR,
                ),
            });
        }
        Ok(())
    }
}

/// Checks every pair of overlapping tiles agrees (pairs in order (0, 1), (0, 2), (1, 2), …)
/// and marks both as overlapping, so reads let a value beat NODATA.
fn mark_overlaps(tiles: &mut [Tile], grid: &GeoGrid) -> Result<(), DemError> {
    for j in 0..tiles.len() {
        for i in 0..j {
            let (a, b) = (&tiles[i], &tiles[j]);
            let rows = a.rows().start.max(b.rows().start)..a.rows().end.min(b.rows().end);
            let cols = a.cols().start.max(b.cols().start)..a.cols().end.min(b.cols().end);
            if rows.is_empty() || cols.is_empty() {
                continue;
            }
            check_overlap(a, b, rows, cols, grid)?;
            tiles[i].overlaps = true;
            tiles[j].overlaps = true;
        }
    }
    Ok(())
}

/// Compares tiles `a` and `b` over their common mosaic rows and columns.
fn check_overlap(
    a: &Tile,
    b: &Tile,
    rows: std::ops::Range<usize>,
    cols: std::ops::Range<usize>,
    grid: &GeoGrid,
) -> Result<(), DemError> {
    let mut row_a = vec![0.0f32; a.raster.header().ncols];
    let mut row_b = vec![0.0f32; b.raster.header().ncols];
    for row in rows {
        a.raster.read_row(row - a.row0, &mut row_a)?;
        b.raster.read_row(row - b.row0, &mut row_b)?;
        let sa = &row_a[cols.start - a.col0..cols.end - a.col0];
        let sb = &row_b[cols.start - b.col0..cols.end - b.col0];
        for (k, (&va, &vb)) in sa.iter().zip(sb).enumerate() {
            if va.is_nan() || vb.is_nan() || values_agree(va, vb) {
                continue;
            }
            let col = cols.start + k;
            return Err(DemError::Data {
                path: b.raster.data_path().to_path_buf(),
                message: format!(
                    "overlaps {} inconsistently: at lat {:.6}°, lon {:.6}° (row {}, column {} \
                     here; row {}, column {} there) this tile holds {vb} and that one {va}; \
                     expected overlapping tiles to agree",
                    a.raster.data_path().display(),
                    grid.lat_of_row(row as f64),
                    grid.lon_of_col(col as f64),
                    row - b.row0,
                    col - b.col0,
                    row - a.row0,
                    col - a.col0,
                ),
            });
        }
    }
    Ok(())
}

impl PixelSource for EhdrMosaic {
    fn pixel_grid(&self) -> GeoGrid {
        self.grid
    }

    fn pixel(&self, row: usize, col: usize) -> Result<Option<f32>, DemError> {
        self.value(row, col)
    }
}

impl RasterSource for EhdrMosaic {
    fn grid(&self) -> GeoGrid {
        self.grid
    }

    /// Fills `out` with NaN, then copies in the row of every tile that covers it (tiles that
    /// overlap another only fill pixels still NaN, so a value beats NODATA).
    fn read_row(&self, row: usize, out: &mut [f32]) -> Result<(), DemError> {
        read_mosaic_row(&self.description, &self.grid, &self.tiles, row, out)
    }

    fn describe(&self) -> String {
        format!(
            "EHdr mosaic of {} tile{} in {} ({}×{})",
            self.tiles.len(),
            if self.tiles.len() == 1 { "" } else { "s" },
            self.description,
            self.grid.cols,
            self.grid.rows
        )
    }
}
