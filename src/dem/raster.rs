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
