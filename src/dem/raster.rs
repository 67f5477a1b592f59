//! The common shape of every elevation raster: a regular latitude/longitude grid of pixel
//! centres, read one row at a time.

/// A regular geographic grid. Row 0 is the northernmost; pixel (row, col) is centred at
/// (lat0 − row·dlat, lon0 + col·dlon), in degrees (EHdr's ULXMAP/ULYMAP convention).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GeoGrid {
    pub cols: usize,
    pub rows: usize,
    /// Longitude of the centre of column 0, degrees east.
    pub lon0_deg: f64,
    /// Latitude of the centre of row 0, degrees north.
    pub lat0_deg: f64,
    /// Column spacing, degrees (> 0).
    pub dlon_deg: f64,
    /// Row spacing, degrees (> 0; rows run north to south).
    pub dlat_deg: f64,
}

impl GeoGrid {
    /// A grid of `cols` × `rows` pixels covering the globe, pixel edges on ±180° and ±90°.
    pub fn global(cols: usize, rows: usize) -> Self {
        let dlon = 360.0 / cols as f64;
        let dlat = 180.0 / rows as f64;
        Self {
            cols,
            rows,
            lon0_deg: -180.0 + 0.5 * dlon,
            lat0_deg: 90.0 - 0.5 * dlat,
            dlon_deg: dlon,
            dlat_deg: dlat,
        }
    }

    pub fn lon_of_col(&self, col: f64) -> f64 {
        self.lon0_deg + col * self.dlon_deg
    }

    pub fn lat_of_row(&self, row: f64) -> f64 {
        self.lat0_deg - row * self.dlat_deg
    }

    /// Continuous (row, col) of a point, pixel centres at integers. Longitude is taken modulo
    /// 360° to the copy nearest the grid's columns.
    pub fn row_col_of(&self, lat_deg: f64, lon_deg: f64) -> (f64, f64) {
        let row = (self.lat0_deg - lat_deg) / self.dlat_deg;
        let centre = self.lon0_deg + 0.5 * (self.cols as f64 - 1.0) * self.dlon_deg;
        let lon = centre + (lon_deg - centre + 180.0).rem_euclid(360.0) - 180.0;
        (row, (lon - self.lon0_deg) / self.dlon_deg)
    }

    /// True when the columns cover the whole circle (the last column's neighbour is column 0).
    pub fn wraps_in_longitude(&self) -> bool {
        (self.cols as f64 * self.dlon_deg - 360.0).abs() < 1e-6 * self.dlon_deg
    }
}

/// A raster of heights in metres, read row by row (so a 30″ global raster never needs to be in
/// memory at once). `NaN` marks "no data" (GTOPO30's −9999 over the oceans, etc.).
pub trait RasterSource: Send + Sync {
    fn grid(&self) -> GeoGrid;

    /// Fills `out` (length `grid().cols`) with row `row`.
    fn read_row(&self, row: usize, out: &mut [f32]) -> Result<(), crate::dem::DemError>;

    /// Where the data comes from, for messages and the pyramid header.
    fn describe(&self) -> String;
}

/// Bilinear sampling of a [`RasterSource`] with a small cache of decoded rows, for callers that
/// walk the raster roughly row by row (resampling, tile synthesis). Pixel centres return their
/// stored value exactly; longitude wraps on full-circle grids and clamps otherwise; latitude
/// clamps to the first and last rows. NaN (no data) propagates only where it has weight.
pub struct BilinearSampler<'a> {
    source: &'a dyn RasterSource,
    grid: GeoGrid,
    rows: Vec<(usize, Vec<f32>)>,
}

impl<'a> BilinearSampler<'a> {
    /// Rows kept decoded: two for the current pair plus slack for a caller that steps back.
    const CACHED_ROWS: usize = 4;

    pub fn new(source: &'a dyn RasterSource) -> Self {
        Self {
            grid: source.grid(),
            source,
            rows: Vec::new(),
        }
    }

    fn row(&mut self, row: usize) -> Result<&[f32], crate::dem::DemError> {
        if let Some(i) = self.rows.iter().position(|(r, _)| *r == row) {
            return Ok(&self.rows[i].1);
        }
        let mut data = if self.rows.len() >= Self::CACHED_ROWS {
            let (_, old) = self.rows.remove(0);
            old
        } else {
            vec![0.0; self.grid.cols]
        };
        self.source.read_row(row, &mut data)?;
        self.rows.push((row, data));
        Ok(&self.rows.last().expect("just pushed").1)
    }

    /// The height at (lat, lon) in metres, NaN where the source has no data.
    pub fn sample(&mut self, lat_deg: f64, lon_deg: f64) -> Result<f64, crate::dem::DemError> {
        let g = self.grid;
        let (r, c) = g.row_col_of(lat_deg, lon_deg);
        let r = r.clamp(0.0, (g.rows - 1) as f64);
        let r0 = r.floor() as usize;
        let r1 = (r0 + 1).min(g.rows - 1);
        let fr = r - r0 as f64;
        let (c0, c1, fc) = if g.wraps_in_longitude() {
            let c = c.rem_euclid(g.cols as f64);
            let c0 = (c.floor() as usize).min(g.cols - 1);
            (c0, (c0 + 1) % g.cols, c - c0 as f64)
        } else {
            let c = c.clamp(0.0, (g.cols - 1) as f64);
            let c0 = c.floor() as usize;
            ((c0), (c0 + 1).min(g.cols - 1), c - c0 as f64)
        };
        let lerp = |a: f64, b: f64, t: f64| {
            if t == 0.0 {
                a
            } else if t == 1.0 {
                b
            } else {
                a + (b - a) * t
            }
        };
        let top = {
            let row = self.row(r0)?;
            lerp(row[c0] as f64, row[c1] as f64, fc)
        };
        if fr == 0.0 {
            return Ok(top);
        }
        let bottom = {
            let row = self.row(r1)?;
            lerp(row[c0] as f64, row[c1] as f64, fc)
        };
        Ok(lerp(top, bottom, fr))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Ramp(GeoGrid);
    impl RasterSource for Ramp {
        fn grid(&self) -> GeoGrid {
            self.0
        }
        fn read_row(&self, row: usize, out: &mut [f32]) -> Result<(), crate::dem::DemError> {
            for (c, v) in out.iter_mut().enumerate() {
                *v = (row * 1000 + c) as f32;
            }
            Ok(())
        }
        fn describe(&self) -> String {
            "ramp".into()
        }
    }

    #[test]
    fn bilinear_is_exact_at_centres_and_linear_between_and_wraps() {
        let grid = GeoGrid {
            cols: 36,
            rows: 19,
            lon0_deg: 0.0,
            lat0_deg: 90.0,
            dlon_deg: 10.0,
            dlat_deg: 10.0,
        };
        let src = Ramp(grid);
        let mut s = BilinearSampler::new(&src);
        assert_eq!(s.sample(80.0, 20.0).unwrap(), 1002.0);
        assert_eq!(s.sample(75.0, 25.0).unwrap(), 1502.5);
        // Between the last column (350°) and the first (0°/360°).
        assert_eq!(s.sample(90.0, 355.0).unwrap(), 17.5);
        assert_eq!(s.sample(90.0, -5.0).unwrap(), 17.5);
    }
}
