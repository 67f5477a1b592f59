//! SRTM `.hgt` tiles (issue 15 item 3): one degree square, 1201 × 1201 (3″) or 3601 × 3601 (1″)
//! big-endian `i16` heights, row 0 northernmost, −32768 for voids (read as NaN).
//!
//! The file has no header: the size gives the resolution and the name the position. The name
//! (`N46E010.hgt`, `s01w072.hgt`; case-insensitive, anything may follow the first seven
//! characters, as in NASA's `N46E010.SRTMGL1.hgt`) is the south-west corner. Pixel centres lie
//! on the degree lines (pixel-is-point), so the grid spans corner − ½ pixel … corner + 1° +
//! ½ pixel and neighbouring tiles share their edge rows and columns, as GDAL's SRTMHGT driver
//! reports them. A folder of tiles is one [`RasterMosaic`](crate::dem::RasterMosaic).

use std::path::{Path, PathBuf};

use super::mapped::{MappedFile, OpenFile};
use crate::dem::{DemError, GeoGrid, RasterSource};

/// The void value of SRTM.
pub const VOID: i16 = i16::MIN;

/// Samples per side of the two SRTM resolutions.
pub const SIDES: [usize; 2] = [1201, 3601];

/// An SRTM `.hgt` tile.
pub struct HgtRaster {
    path: PathBuf,
    map: MappedFile,
    grid: GeoGrid,
}

impl std::fmt::Debug for HgtRaster {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("HgtRaster")
            .field("path", &self.path)
            .field("grid", &self.grid)
            .finish()
    }
}

/// The south-west corner (latitude, longitude) a tile's file name gives.
pub fn corner_of_name(path: &Path) -> Result<(i32, i32), DemError> {
    let bad = |why: &str| DemError::Header {
        path: path.to_path_buf(),
        field: "file name".into(),
        message: format!(
            "{why}; expected the tile's south-west corner as in N46E010.hgt or S01W072.hgt \
             (N/S, 2-digit latitude, E/W, 3-digit longitude)"
        ),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let b = name.as_bytes();
    if b.len() < 7 {
        return Err(bad(&format!("{name:?} is too short")));
    }
    let digits = |s: &[u8]| -> Option<i32> {
        s.iter()
            .all(u8::is_ascii_digit)
            .then(|| s.iter().fold(0, |a, d| a * 10 + (d - b'0') as i32))
    };
    let lat_sign = match b[0].to_ascii_uppercase() {
        b'N' => 1,
        b'S' => -1,
        _ => return Err(bad(&format!("{name:?} does not start with N or S"))),
    };
    let lon_sign = match b[3].to_ascii_uppercase() {
        b'E' => 1,
        b'W' => -1,
        _ => return Err(bad(&format!("{name:?} has no E or W as its 4th character"))),
    };
    let (Some(lat), Some(lon)) = (digits(&b[1..3]), digits(&b[4..7])) else {
        return Err(bad(&format!("{name:?} has no digits where the degrees go")));
    };
    let (lat, lon) = (lat_sign * lat, lon_sign * lon);
    if !(-90..90).contains(&lat) || !(-180..=180).contains(&lon) {
        return Err(bad(&format!(
            "{name:?} names latitude {lat}°, longitude {lon}°, off the globe"
        )));
    }
    Ok((lat, lon))
}

/// The side of a tile of `len` bytes, or an error naming the sizes expected.
fn side_of_len(path: &Path, len: u64) -> Result<usize, DemError> {
    SIDES
        .into_iter()
        .find(|&n| (n * n * 2) as u64 == len)
        .ok_or_else(|| DemError::Header {
            path: path.to_path_buf(),
            field: "size".into(),
            message: format!(
                "{len} bytes; expected {} (1201 × 1201 samples, 3″) or {} (3601 × 3601, 1″) of \
                 big-endian 16-bit heights",
                1201 * 1201 * 2,
                3601 * 3601 * 2
            ),
        })
}

fn grid_of(corner: (i32, i32), side: usize) -> GeoGrid {
    let d = 1.0 / (side - 1) as f64;
    GeoGrid {
        cols: side,
        rows: side,
        lon0_deg: corner.1 as f64,
        lat0_deg: corner.0 as f64 + 1.0,
        dlon_deg: d,
        dlat_deg: d,
    }
}

impl HgtRaster {
    /// Opens a tile: the name gives the corner, the size the resolution (checked before
    /// mapping).
    pub fn open(path: impl AsRef<Path>) -> Result<HgtRaster, DemError> {
        let path = path.as_ref();
        let corner = corner_of_name(path)?;
        let file = OpenFile::open(path)?;
        let side = side_of_len(path, file.len())?;
        Ok(HgtRaster {
            path: path.to_path_buf(),
            map: file.map()?,
            grid: grid_of(corner, side),
        })
    }

    /// A tile's bytes already in memory; `path` gives the name (and so the corner).
    pub fn from_bytes(bytes: Vec<u8>, path: impl AsRef<Path>) -> Result<HgtRaster, DemError> {
        let path = path.as_ref();
        let corner = corner_of_name(path)?;
        let side = side_of_len(path, bytes.len() as u64)?;
        Ok(HgtRaster {
            path: path.to_path_buf(),
            map: MappedFile::from_bytes(path, bytes),
            grid: grid_of(corner, side),
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The stored value at (row, col), `None` for a void.
    pub fn value(&self, row: usize, col: usize) -> Option<i16> {
        let n = self.grid.cols;
        if row >= n || col >= n {
            return None;
        }
        let at = 2 * (row * n + col);
        let v = i16::from_be_bytes([self.map[at], self.map[at + 1]]);
        (v != VOID).then_some(v)
    }
}

impl RasterSource for HgtRaster {
    fn grid(&self) -> GeoGrid {
        self.grid
    }

    fn read_row(&self, row: usize, out: &mut [f32]) -> Result<(), DemError> {
        let n = self.grid.cols;
        if row >= n || out.len() != n {
            return Err(DemError::Other(format!(
                "{}: read_row({row}) with a buffer of {} values; expected row < {n} and {n} \
                 values",
                self.path.display(),
                out.len()
            )));
        }
        let bytes = &self.map[2 * row * n..2 * (row + 1) * n];
        for (o, v) in out.iter_mut().zip(bytes.chunks_exact(2)) {
            let v = i16::from_be_bytes([v[0], v[1]]);
            *o = if v == VOID { f32::NAN } else { v as f32 };
        }
        Ok(())
    }

    fn describe(&self) -> String {
        format!(
            "SRTM {} ({}″, {}×{})",
            self.path.display(),
            if self.grid.cols == 1201 { 3 } else { 1 },
            self.grid.cols,
            self.grid.rows
        )
    }
}
