//! Imagery: a true-colour raster of the Earth in geographic coordinates, draped on the
//! terrain (issue 36). The viewer's default is the one inside the binary ([`embedded`]: NASA's
//! Blue Marble Next Generation at 4′); a user's GeoTIFF (RGB or RGBA, 8 bits) or a plain
//! JPEG/PNG plate carrée can replace it ([`load`]).
//!
//! Pixels are areas, as GDAL takes them: pixel (col, row) covers longitudes
//! [W + col·Δλ, W + (col + 1)·Δλ] and holds its value at its centre; between centres the
//! value is bilinear, in linear light (the GPU's filtering of an sRGB texture). The coarse
//! levels read mipmaps averaged over each pixel's area ([`Imagery::mips`]): the clipmap's
//! levels and the image are both grids in latitude and longitude, so a level's texel covers
//! the same number of image pixels east–west at every latitude, poles included.

pub mod embedded;
pub mod load;

use std::path::PathBuf;

/// What went wrong opening imagery: which file, which field, what was expected.
#[derive(Debug, thiserror::Error)]
pub enum ImageryError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: {message}")]
    Format { path: PathBuf, message: String },
    #[error("'{spec}': {message}")]
    Spec { spec: String, message: String },
    #[error(transparent)]
    Tiff(#[from] crate::dem::DemError),
}

/// The edges of an image, degrees: west, south, east, north (east > west; east may pass
/// 180° for an image across the antimeridian).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Extent {
    pub west: f64,
    pub south: f64,
    pub east: f64,
    pub north: f64,
}

impl Extent {
    pub const GLOBAL: Extent = Extent {
        west: -180.0,
        south: -90.0,
        east: 180.0,
        north: 90.0,
    };

    /// `W,S,E,N` in degrees, checked.
    pub fn parse(text: &str) -> Result<Extent, String> {
        let v: Vec<f64> = text
            .split(',')
            .map(|t| t.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| format!("extent '{text}': expected four numbers W,S,E,N in degrees"))?;
        let [west, south, east, north] = v[..] else {
            return Err(format!(
                "extent '{text}': {} numbers; expected four, W,S,E,N in degrees",
                v.len()
            ));
        };
        let e = Extent {
            west,
            south,
            east,
            north,
        };
        e.check().map(|_| e)
    }

    fn check(&self) -> Result<(), String> {
        let ok = self.west.is_finite()
            && self.east.is_finite()
            && self.west < self.east
            && self.east - self.west <= 360.0 + 1e-9
            && self.west >= -360.0
            && self.east <= 540.0
            && -90.0 - 1e-9 <= self.south
            && self.south < self.north
            && self.north <= 90.0 + 1e-9;
        if ok {
            Ok(())
        } else {
            Err(format!(
                "extent W {} S {} E {} N {}: expected W < E (at most 360° apart) and \
                 −90 ≤ S < N ≤ 90, degrees",
                self.west, self.south, self.east, self.north
            ))
        }
    }
}

/// A true-colour image in memory: sRGB-encoded RGBA, 8 bits per channel, row 0 northmost,
/// alpha the coverage (0 where the image has no data).
#[derive(Clone, Debug)]
pub struct Imagery {
    /// Where it came from (messages, the panel).
    pub label: String,
    pub width: u32,
    pub height: u32,
    pub extent: Extent,
    pub rgba: Vec<u8>,
}

/// One level of an image's mipmap chain (sRGB-encoded RGBA8, as the GPU holds it).
#[derive(Clone, Debug)]
pub struct Mip {
    pub width: u32,
    pub height: u32,
    pub rgba: Vec<u8>,
}

/// sRGB-encoded 8-bit value → linear light (IEC 61966-2-1).
pub fn srgb_to_linear(v: f64) -> f64 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear light → sRGB-encoded value in [0, 1].
pub fn linear_to_srgb(v: f64) -> f64 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Linear-light RGBA (straight alpha) → stored bytes.
pub fn encode(c: [f64; 4]) -> [u8; 4] {
    let q = |v: f64| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
    [
        q(linear_to_srgb(c[0])),
        q(linear_to_srgb(c[1])),
        q(linear_to_srgb(c[2])),
        q(c[3]),
    ]
}

/// The 256 linear values of the sRGB bytes (built once).
fn decode_table() -> &'static [f32; 256] {
    static TABLE: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|i| srgb_to_linear(i as f64 / 255.0) as f32))
}

impl Imagery {
    /// Checks the sizes; `label` names the source in messages.
    pub fn new(
        label: impl Into<String>,
        width: u32,
        height: u32,
        extent: Extent,
        rgba: Vec<u8>,
    ) -> Result<Imagery, ImageryError> {
        let label = label.into();
        let bad = |message: String| ImageryError::Format {
            path: PathBuf::from(&label),
            message,
        };
        if width == 0 || height == 0 {
            return Err(bad(format!(
                "{width} × {height} pixels; expected at least one"
            )));
        }
        if rgba.len() != width as usize * height as usize * 4 {
            return Err(bad(format!(
                "{} bytes for {width} × {height} RGBA pixels; expected {}",
                rgba.len(),
                width as usize * height as usize * 4
            )));
        }
        extent.check().map_err(bad)?;
        Ok(Imagery {
            label,
            width,
            height,
            extent,
            rgba,
        })
    }

    /// Pixel size, degrees (east–west, north–south).
    pub fn pixel_deg(&self) -> (f64, f64) {
        (
            (self.extent.east - self.extent.west) / self.width as f64,
            (self.extent.north - self.extent.south) / self.height as f64,
        )
    }

    /// Whether the columns go once round the globe (the last one's neighbour is the first).
    pub fn wraps(&self) -> bool {
        (self.extent.east - self.extent.west - 360.0).abs() < 1e-9
    }

    /// Continuous pixel coordinates (x east from the west edge, y south from the north edge;
    /// pixel edges at integers, centres at +½) of a point, longitude taken modulo 360° from
    /// the west edge. Not clipped to the image.
    pub fn pixel_coords(&self, lat_deg: f64, lon_deg: f64) -> (f64, f64) {
        let (dx, dy) = self.pixel_deg();
        let lon = (lon_deg - self.extent.west).rem_euclid(360.0);
        (lon / dx, (self.extent.north - lat_deg) / dy)
    }

    /// The stored bytes of pixel (col, row).
    pub fn pixel(&self, col: u32, row: u32) -> [u8; 4] {
        let i = (row as usize * self.width as usize + col as usize) * 4;
        self.rgba[i..i + 4].try_into().unwrap()
    }

    /// The image at a point in linear light (straight alpha), bilinear between pixel centres
    /// (columns wrap on a global image, clamp otherwise; rows clamp); `None` outside it.
    pub fn sample(&self, lat_deg: f64, lon_deg: f64) -> Option<[f64; 4]> {
        let (x, y) = self.pixel_coords(lat_deg, lon_deg);
        let (w, h) = (self.width as f64, self.height as f64);
        let eps = 1e-9;
        if !(-eps..=h + eps).contains(&y) || (!self.wraps() && x > w + eps) {
            return None;
        }
        let mip = Mip {
            width: self.width,
            height: self.height,
            rgba: Vec::new(),
        };
        Some(mip.bilinear(&self.rgba, x / w, y / h, self.wraps(), decode_table()))
    }

    /// The mipmap chain: level 0 this image, each next one half as large (rounded down, at
    /// least 1) with every pixel the average, in linear light weighted by coverage, of the
    /// area it covers in the level before.
    pub fn mips(&self) -> Vec<Mip> {
        let table = decode_table();
        let mut chain = vec![Mip {
            width: self.width,
            height: self.height,
            rgba: self.rgba.clone(),
        }];
        while let Some(last) = chain.last().filter(|m| m.width > 1 || m.height > 1) {
            let next = last.halved(table);
            chain.push(next);
        }
        chain
    }
}

impl Mip {
    /// Bilinear at (u, v) ∈ [0, 1]² of `rgba` (this mip's bytes), pixel centres at
    /// ((i + ½)/w, (j + ½)/h), colour in linear light, alpha straight: as the GPU filters an
    /// sRGB texture.
    fn bilinear(&self, rgba: &[u8], u: f64, v: f64, wrap: bool, table: &[f32; 256]) -> [f64; 4] {
        let (w, h) = (self.width as i64, self.height as i64);
        let x = u * w as f64 - 0.5;
        let y = v * h as f64 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (tx, ty) = (x - x0, y - y0);
        let col = |i: i64| {
            if wrap {
                i.rem_euclid(w)
            } else {
                i.clamp(0, w - 1)
            }
        };
        let row = |j: i64| j.clamp(0, h - 1);
        let mut out = [0.0f64; 4];
        for (dj, wy) in [(0i64, 1.0 - ty), (1, ty)] {
            for (di, wx) in [(0i64, 1.0 - tx), (1, tx)] {
                let i = ((row(y0 as i64 + dj) * w + col(x0 as i64 + di)) * 4) as usize;
                let wgt = wx * wy;
                for (c, o) in out.iter_mut().take(3).enumerate() {
                    *o += wgt * table[rgba[i + c] as usize] as f64;
                }
                out[3] += wgt * rgba[i + 3] as f64 / 255.0;
            }
        }
        out
    }

    /// Bilinear at (u, v) of this mip (its own bytes).
    pub fn sample_uv(&self, u: f64, v: f64, wrap: bool) -> [f64; 4] {
        self.bilinear(&self.rgba, u, v, wrap, decode_table())
    }

    /// The next mip: each pixel the coverage-weighted linear average of the area it spans.
    fn halved(&self, table: &[f32; 256]) -> Mip {
        let (w1, h1) = (self.width as usize, self.height as usize);
        let (w2, h2) = ((w1 / 2).max(1), (h1 / 2).max(1));
        // Source pixels a destination pixel spans, with their overlap (1D, separable).
        let spans = |n1: usize, n2: usize| -> Vec<Vec<(usize, f64)>> {
            let r = n1 as f64 / n2 as f64;
            (0..n2)
                .map(|i| {
                    let (a, b) = (i as f64 * r, (i + 1) as f64 * r);
                    (a.floor() as usize..(b.ceil() as usize).min(n1))
                        .map(|k| (k, ((k + 1) as f64).min(b) - (k as f64).max(a)))
                        .filter(|&(_, o)| o > 0.0)
                        .collect()
                })
                .collect()
        };
        let (sx, sy) = (spans(w1, w2), spans(h1, h2));
        let mut rgba = vec![0u8; w2 * h2 * 4];
        for (j, ry) in sy.iter().enumerate() {
            for (i, rx) in sx.iter().enumerate() {
                let mut acc = [0.0f64; 4];
                let mut area = 0.0;
                for &(y, oy) in ry {
                    for &(x, ox) in rx {
                        let k = (y * w1 + x) * 4;
                        let a = self.rgba[k + 3] as f64 / 255.0;
                        let wgt = ox * oy;
                        for c in 0..3 {
                            acc[c] += wgt * a * table[self.rgba[k + c] as usize] as f64;
                        }
                        acc[3] += wgt * a;
                        area += wgt;
                    }
                }
                let cov = acc[3].max(1e-12);
                let px = encode([acc[0] / cov, acc[1] / cov, acc[2] / cov, acc[3] / area]);
                rgba[(j * w2 + i) * 4..(j * w2 + i) * 4 + 4].copy_from_slice(&px);
            }
        }
        Mip {
            width: w2 as u32,
            height: h2 as u32,
            rgba,
        }
    }
}

/// Where the imagery comes from (`--imagery`).
#[derive(Clone, Debug, PartialEq)]
pub enum ImagerySource {
    /// None: the surface types' colours by height, slope and latitude.
    Off,
    /// The Blue Marble inside the binary.
    Embedded,
    /// A GeoTIFF, or a JPEG/PNG with its extent (`None`: global, if its aspect is 2:1).
    File {
        path: PathBuf,
        extent: Option<Extent>,
    },
}

impl ImagerySource {
    /// `embedded`, `off`, `FILE` or `FILE@W,S,E,N`.
    pub fn parse(spec: &str) -> Result<ImagerySource, ImageryError> {
        match spec {
            "embedded" => return Ok(ImagerySource::Embedded),
            "off" => return Ok(ImagerySource::Off),
            _ => {}
        }
        let (path, extent) = match spec.rsplit_once('@') {
            Some((p, e)) if !p.is_empty() => (
                p,
                Some(Extent::parse(e).map_err(|message| ImageryError::Spec {
                    spec: spec.to_string(),
                    message,
                })?),
            ),
            _ => (spec, None),
        };
        Ok(ImagerySource::File {
            path: PathBuf::from(path),
            extent,
        })
    }

    /// The image, decoded (`None` for `off`).
    pub fn open(&self) -> Result<Option<Imagery>, ImageryError> {
        match self {
            ImagerySource::Off => Ok(None),
            ImagerySource::Embedded => embedded::load().map(Some),
            ImagerySource::File { path, extent } => load::open(path, *extent).map(Some),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker(w: u32, h: u32, extent: Extent) -> Imagery {
        let rgba = (0..w * h)
            .flat_map(|k| {
                let (i, j) = (k % w, k / w);
                [
                    (i * 37 % 256) as u8,
                    (j * 53 % 256) as u8,
                    ((i + j) * 11 % 256) as u8,
                    255,
                ]
            })
            .collect();
        Imagery::new("test", w, h, extent, rgba).unwrap()
    }

    /// At a pixel's centre the sample is that pixel; halfway between two centres, the mean in
    /// linear light; across the antimeridian of a global image, its last and first columns.
    #[test]
    fn samples_are_exact_at_centres_and_linear_between() {
        let img = checker(36, 18, Extent::GLOBAL);
        for (col, row) in [(0u32, 0u32), (35, 17), (17, 9), (3, 11)] {
            let lon = -180.0 + (col as f64 + 0.5) * 10.0;
            let lat = 90.0 - (row as f64 + 0.5) * 10.0;
            assert_eq!(encode(img.sample(lat, lon).unwrap()), img.pixel(col, row));
        }
        let mid = img.sample(85.0, -170.0).unwrap();
        let (a, b) = (img.pixel(0, 0), img.pixel(1, 0));
        let lin = |v: u8| srgb_to_linear(v as f64 / 255.0);
        assert!((mid[0] - 0.5 * (lin(a[0]) + lin(b[0]))).abs() < 1e-6);
        let seam = img.sample(85.0, 180.0).unwrap();
        let (a, b) = (img.pixel(35, 0), img.pixel(0, 0));
        assert!((seam[1] - 0.5 * (lin(a[1]) + lin(b[1]))).abs() < 1e-6);
    }

    /// A regional image across the antimeridian (170° E to 170° W) covers 180° and not 0°.
    #[test]
    fn a_regional_image_across_the_antimeridian() {
        let e = Extent::parse("170,-10,190,10").unwrap();
        let img = checker(20, 20, e);
        assert!(img.sample(0.0, 180.0).is_some());
        assert!(img.sample(0.0, -175.0).is_some());
        assert!(img.sample(0.0, 0.0).is_none());
        assert!(img.sample(20.0, 175.0).is_none());
    }

    /// Every mip's mean in linear light is the image's (areas weighted exactly, odd sizes too).
    #[test]
    fn mips_keep_the_mean() {
        let img = checker(45, 23, Extent::GLOBAL);
        let t = decode_table();
        let mean = |m: &Mip| {
            m.rgba
                .chunks(4)
                .map(|p| t[p[0] as usize] as f64)
                .sum::<f64>()
                / (m.width * m.height) as f64
        };
        let chain = img.mips();
        assert_eq!((chain[1].width, chain[1].height), (22, 11));
        assert_eq!(
            (chain.last().unwrap().width, chain.last().unwrap().height),
            (1, 1)
        );
        let m0 = mean(&chain[0]);
        for m in &chain {
            assert!(
                (mean(m) - m0).abs() < 0.004,
                "{}×{}: {} vs {m0}",
                m.width,
                m.height,
                mean(m)
            );
        }
    }

    #[test]
    fn specs_parse_and_bad_extents_say_what_was_expected() {
        assert_eq!(ImagerySource::parse("off").unwrap(), ImagerySource::Off);
        let s = ImagerySource::parse("a/b.png@-10,20,30,40").unwrap();
        assert_eq!(
            s,
            ImagerySource::File {
                path: "a/b.png".into(),
                extent: Some(Extent {
                    west: -10.0,
                    south: 20.0,
                    east: 30.0,
                    north: 40.0
                })
            }
        );
        let e = ImagerySource::parse("x.png@10,20,5,40")
            .unwrap_err()
            .to_string();
        assert!(e.contains("expected W < E"), "{e}");
        let e = ImagerySource::parse("x.png@10,20").unwrap_err().to_string();
        assert!(e.contains("expected four"), "{e}");
    }
}
