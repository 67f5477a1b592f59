//! The small real Earth shipped inside the binary: ETOPO5 (NOAA, public domain) decimated to
//! 10′ (2160 × 1080 pixels, bathymetry included), stored as a 16-bit greyscale PNG of
//! h + 32768 metres. Made by `globe-data earth` (see docs/data.md#the-embedded-earth).

use crate::dem::{DemError, GeoGrid, RasterSource};

/// The PNG compiled into the binary.
pub const EARTH_PNG: &[u8] = include_bytes!("../../assets/earth-10min.png");

/// Pixel spacing of the embedded Earth, degrees (10′).
pub const SPACING_DEG: f64 = 10.0 / 60.0;
/// Offset added to heights so they fit an unsigned 16-bit PNG.
pub const HEIGHT_OFFSET_M: i32 = 32768;

/// The grid of the embedded Earth: whole globe, pixel centres half a pixel in from 180° W, 90° N.
pub fn grid() -> GeoGrid {
    GeoGrid {
        cols: 2160,
        rows: 1080,
        lon0_deg: -180.0 + 0.5 * SPACING_DEG,
        lat0_deg: 90.0 - 0.5 * SPACING_DEG,
        dlon_deg: SPACING_DEG,
        dlat_deg: SPACING_DEG,
    }
}

/// The embedded Earth's heights in memory, as a raster source.
pub struct EmbeddedEarth {
    heights: Vec<i16>,
}

impl EmbeddedEarth {
    /// Decodes the PNG compiled into the binary.
    pub fn load() -> Result<Self, DemError> {
        Self::from_png(EARTH_PNG)
    }

    /// Decodes an Earth PNG (16-bit greyscale of h + 32768, 2160 × 1080).
    pub fn from_png(bytes: &[u8]) -> Result<Self, DemError> {
        let bad = |message: String| DemError::Data {
            path: "assets/earth-10min.png".into(),
            message,
        };
        let image = image::load_from_memory_with_format(bytes, image::ImageFormat::Png)
            .map_err(|e| bad(format!("cannot decode: {e}")))?;
        let g = grid();
        if image.width() as usize != g.cols || image.height() as usize != g.rows {
            return Err(bad(format!(
                "is {}×{}, expected {}×{}",
                image.width(),
                image.height(),
                g.cols,
                g.rows
            )));
        }
        let image::DynamicImage::ImageLuma16(luma) = image else {
            return Err(bad("expected a 16-bit greyscale PNG".into()));
        };
        let heights = luma
            .into_raw()
            .into_iter()
            .map(|v| (v as i32 - HEIGHT_OFFSET_M) as i16)
            .collect();
        Ok(Self { heights })
    }

    /// Encodes heights (row-major over [`grid`], metres) as the Earth PNG.
    pub fn encode_png(heights_m: &[i16]) -> Result<Vec<u8>, image::ImageError> {
        let g = grid();
        let raw: Vec<u16> = heights_m
            .iter()
            .map(|&h| (h as i32 + HEIGHT_OFFSET_M) as u16)
            .collect();
        let luma = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(
            g.cols as u32,
            g.rows as u32,
            raw,
        )
        .expect("heights cover the grid");
        let mut out = std::io::Cursor::new(Vec::new());
        image::DynamicImage::ImageLuma16(luma).write_to(&mut out, image::ImageFormat::Png)?;
        Ok(out.into_inner())
    }
}

impl RasterSource for EmbeddedEarth {
    fn grid(&self) -> GeoGrid {
        grid()
    }

    fn read_row(&self, row: usize, out: &mut [f32]) -> Result<(), DemError> {
        let cols = grid().cols;
        for (o, h) in out
            .iter_mut()
            .zip(&self.heights[row * cols..(row + 1) * cols])
        {
            *o = *h as f32;
        }
        Ok(())
    }

    fn describe(&self) -> String {
        "embedded Earth (ETOPO5 decimated to 10′, NOAA, public domain)".into()
    }
}
