//! A folder of SRTM `.hgt` tiles or GeoTIFFs as one raster over the bounding grid of their
//! union (EHdr folders have their own [`EhdrMosaic`](crate::dem::EhdrMosaic), which also checks
//! that overlaps agree).
//!
//! Tiles must share one pixel lattice. Where tiles overlap (SRTM neighbours share their edge
//! row or column) the first tile in name order that has a value there gives it; no data
//! (NaN) never hides a value. Rows are read tile by tile into the caller's buffer, so a
//! mosaic holds nothing beyond its tiles' memory maps (and a compressed GeoTIFF's one band).

use std::path::{Path, PathBuf};

use crate::dem::{DemError, GeoGrid, GeoTiffRaster, HgtRaster, RasterSource};

/// Relative tolerance on the pixel spacing between tiles.
const SPACING_TOLERANCE: f64 = 1e-9;
/// Tolerance, in pixels, of tile alignment to the common lattice.
const LATTICE_TOLERANCE_PIXELS: f64 = 1e-3;

struct Tile {
    name: String,
    source: Box<dyn RasterSource>,
    grid: GeoGrid,
    row0: usize,
    col0: usize,
}

impl MosaicTile for Tile {
    fn rows(&self) -> std::ops::Range<usize> {
        self.row0..self.row0 + self.grid.rows
    }

    fn cols(&self) -> std::ops::Range<usize> {
        self.col0..self.col0 + self.grid.cols
    }

    fn may_overlap(&self) -> bool {
        true
    }

    fn read_tile_row(&self, row: usize, out: &mut [f32]) -> Result<(), DemError> {
        self.source.read_row(row, out)
    }
}

/// One tile of a mosaic as [`read_mosaic_row`] reads it.
pub(crate) trait MosaicTile {
    /// The mosaic rows and columns the tile covers.
    fn rows(&self) -> std::ops::Range<usize>;
    fn cols(&self) -> std::ops::Range<usize>;
    /// Whether another tile may cover some of its pixels (false: its row is read straight
    /// into the mosaic's).
    fn may_overlap(&self) -> bool;
    /// The tile's own row `row` into `out` (its width).
    fn read_tile_row(&self, row: usize, out: &mut [f32]) -> Result<(), DemError>;
}

/// A mosaic's row: NaN, then the row of every tile that covers it, in order; a tile that may
/// overlap another only fills pixels still NaN, so the first value wins and no data never
/// hides a value.
pub(crate) fn read_mosaic_row<T: MosaicTile>(
    description: &str,
    grid: &GeoGrid,
    tiles: &[T],
    row: usize,
    out: &mut [f32],
) -> Result<(), DemError> {
    if row >= grid.rows || out.len() != grid.cols {
        return Err(DemError::Other(format!(
            "{description}: read_row({row}) with a buffer of {} values; expected row < {} and {} values",
            out.len(),
            grid.rows,
            grid.cols
        )));
    }
    out.fill(f32::NAN);
    let mut scratch: Vec<f32> = Vec::new();
    for t in tiles {
        let rows = t.rows();
        if !rows.contains(&row) {
            continue;
        }
        let dst = &mut out[t.cols()];
        if t.may_overlap() {
            scratch.resize(dst.len(), 0.0);
            t.read_tile_row(row - rows.start, &mut scratch)?;
            for (o, &v) in dst.iter_mut().zip(&scratch) {
                if o.is_nan() {
                    *o = v;
                }
            }
        } else {
            t.read_tile_row(row - rows.start, dst)?;
        }
    }
    Ok(())
}

/// Tiles of any [`RasterSource`] sharing one lattice, read as one raster.
pub struct RasterMosaic {
    description: String,
    grid: GeoGrid,
    tiles: Vec<Tile>,
}

impl std::fmt::Debug for RasterMosaic {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RasterMosaic")
            .field("description", &self.description)
            .field("grid", &self.grid)
            .field("tiles", &self.tiles.len())
            .finish()
    }
}

/// Whether a file is one this mosaic opens (`.hgt`, `.tif`, `.tiff`, any case).
pub fn is_mosaic_tile(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| ["hgt", "tif", "tiff"].contains(&e.to_ascii_lowercase().as_str()))
}

/// Opens one `.hgt` or GeoTIFF file.
pub fn open_tile(path: &Path) -> Result<Box<dyn RasterSource>, DemError> {
    let hgt = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("hgt"));
    Ok(if hgt {
        Box::new(HgtRaster::open(path)?)
    } else {
        Box::new(GeoTiffRaster::open(path)?)
    })
}

impl RasterMosaic {
    /// As [`EhdrMosaic::MAX_BOUNDING_FACTOR`](crate::dem::EhdrMosaic::MAX_BOUNDING_FACTOR): the
    /// bounding grid may hold at most this many times the tiles' pixels.
    pub const MAX_BOUNDING_FACTOR: usize = 64;

    /// Every `.hgt`, `.tif` and `.tiff` file in `dir` (not recursively), in name order.
    pub fn open_dir(dir: &Path) -> Result<RasterMosaic, DemError> {
        let io = |source| DemError::Io {
            path: dir.to_path_buf(),
            source,
        };
        let mut files: Vec<PathBuf> = Vec::new();
        for entry in std::fs::read_dir(dir).map_err(io)? {
            let path = entry.map_err(io)?.path();
            if is_mosaic_tile(&path) && path.is_file() {
                files.push(path);
            }
        }
        if files.is_empty() {
            return Err(DemError::Missing {
                path: dir.to_path_buf(),
                message: "no .hgt or .tif files in this folder".into(),
            });
        }
        files.sort();
        let tiles = files
            .iter()
            .map(|f| Ok((f.display().to_string(), open_tile(f)?)))
            .collect::<Result<Vec<_>, DemError>>()?;
        Self::from_sources(tiles, dir.display().to_string())
    }

    /// Joins named sources into one mosaic. The first is the reference lattice: every other
    /// must share its spacing (relative 1e-9) and sit a whole number of pixels from it (within
    /// 1e-3 pixel), else the error names both.
    pub fn from_sources(
        sources: Vec<(String, Box<dyn RasterSource>)>,
        description: impl Into<String>,
    ) -> Result<RasterMosaic, DemError> {
        let description = description.into();
        let Some((ref_name, reference)) = sources.first() else {
            return Err(DemError::Other(format!(
                "{description}: a mosaic needs at least one tile"
            )));
        };
        let rg = reference.grid();
        let ref_name = ref_name.clone();
        let mut placed = Vec::with_capacity(sources.len());
        for (name, source) in sources {
            let g = source.grid();
            let err = |field: &str, message: String| DemError::Header {
                path: PathBuf::from(&name),
                field: field.to_string(),
                message,
            };
            for (field, mine, theirs) in [
                ("pixel width", g.dlon_deg, rg.dlon_deg),
                ("pixel height", g.dlat_deg, rg.dlat_deg),
            ] {
                if (mine - theirs).abs() > SPACING_TOLERANCE * theirs {
                    return Err(err(
                        field,
                        format!(
                            "{mine}° differs from the {theirs}° of {ref_name}; expected the \
                             tiles of a mosaic to share one resolution"
                        ),
                    ));
                }
            }
            let kc = (g.lon0_deg - rg.lon0_deg) / rg.dlon_deg;
            let kr = (rg.lat0_deg - g.lat0_deg) / rg.dlat_deg;
            for (field, k, axis) in [("west edge", kc, "columns"), ("north edge", kr, "rows")] {
                if !k.is_finite()
                    || k.abs() >= 2f64.powi(40)
                    || (k - k.round()).abs() > LATTICE_TOLERANCE_PIXELS
                {
                    return Err(err(
                        field,
                        format!(
                            "not on the pixel lattice of {ref_name}: its {axis} are offset by \
                             {k} pixels from that tile's; expected a whole number"
                        ),
                    ));
                }
            }
            placed.push((name, source, g, kr.round() as i64, kc.round() as i64));
        }
        let min_r = placed.iter().map(|p| p.3).min().expect("one tile");
        let min_c = placed.iter().map(|p| p.4).min().expect("one tile");
        let max_r = placed
            .iter()
            .map(|p| p.3 + p.2.rows as i64)
            .max()
            .expect("one");
        let max_c = placed
            .iter()
            .map(|p| p.4 + p.2.cols as i64)
            .max()
            .expect("one");
        let rows = (max_r - min_r) as usize;
        let cols = (max_c - min_c) as usize;
        let width = cols as f64 * rg.dlon_deg;
        // One column more than 360° is a full circle of SRTM tiles sharing their edges.
        if width > 360.0 + rg.dlon_deg + 1e-6 {
            return Err(DemError::Data {
                path: description.clone().into(),
                message: format!(
                    "the tiles span {width}° of longitude; expected at most 360° (mixed \
                     longitude conventions?)"
                ),
            });
        }
        let tile_pixels: u128 = placed
            .iter()
            .map(|p| p.2.rows as u128 * p.2.cols as u128)
            .sum();
        let bounding = rows as u128 * cols as u128;
        if bounding > Self::MAX_BOUNDING_FACTOR as u128 * tile_pixels {
            return Err(DemError::Data {
                path: description.clone().into(),
                message: format!(
                    "the tiles hold {tile_pixels} pixels but span a bounding grid of {cols} × \
                     {rows} = {bounding}; expected tiles covering at least 1/{} of it (a \
                     mosaic is read and stored in full)",
                    Self::MAX_BOUNDING_FACTOR
                ),
            });
        }
        let grid = GeoGrid {
            cols,
            rows,
            lon0_deg: rg.lon0_deg + min_c as f64 * rg.dlon_deg,
            lat0_deg: rg.lat0_deg - min_r as f64 * rg.dlat_deg,
            dlon_deg: rg.dlon_deg,
            dlat_deg: rg.dlat_deg,
        };
        let tiles = placed
            .into_iter()
            .map(|(name, source, g, kr, kc)| Tile {
                name,
                source,
                grid: g,
                row0: (kr - min_r) as usize,
                col0: (kc - min_c) as usize,
            })
            .collect();
        Ok(RasterMosaic {
            description,
            grid,
            tiles,
        })
    }

    /// The tiles' names and where their pixel (0, 0) sits in the mosaic (row, col).
    pub fn tiles(&self) -> impl Iterator<Item = (&str, usize, usize)> {
        self.tiles.iter().map(|t| (t.name.as_str(), t.row0, t.col0))
    }
}

impl RasterSource for RasterMosaic {
    fn grid(&self) -> GeoGrid {
        self.grid
    }

    fn read_row(&self, row: usize, out: &mut [f32]) -> Result<(), DemError> {
        read_mosaic_row(&self.description, &self.grid, &self.tiles, row, out)
    }

    fn describe(&self) -> String {
        format!(
            "mosaic of {} tile{} in {} ({}×{})",
            self.tiles.len(),
            if self.tiles.len() == 1 { "" } else { "s" },
            self.description,
            self.grid.cols,
            self.grid.rows
        )
    }
}
