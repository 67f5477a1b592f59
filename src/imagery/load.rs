//! Imagery files: a GeoTIFF in geographic coordinates (RGB or RGBA, 8 bits a sample, strips
//! or tiles, uncompressed, Deflate or LZW), or a plain JPEG/PNG plate carrée whose extent is
//! given (`FILE@W,S,E,N`) or global by its 2:1 aspect.

use std::io::Cursor;
use std::path::Path;

use super::{Extent, Imagery, ImageryError};

fn format_err(path: &Path, message: String) -> ImageryError {
    ImageryError::Format {
        path: path.to_path_buf(),
        message,
    }
}

/// Opens `path` by its extension; `extent` only for a plain image.
pub fn open(path: &Path, extent: Option<Extent>) -> Result<Imagery, ImageryError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    if path.is_dir() {
        return Err(format_err(
            path,
            "is a folder; globe reads one imagery file (a GeoTIFF, or a JPEG/PNG with its \
             extent); a folder of tiles is not read yet"
                .into(),
        ));
    }
    let bytes = std::fs::read(path).map_err(|source| ImageryError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let label = path.display().to_string();
    match ext.as_str() {
        "tif" | "tiff" => {
            if extent.is_some() {
                return Err(format_err(
                    path,
                    "a GeoTIFF carries its own georeferencing; drop the @W,S,E,N".into(),
                ));
            }
            geotiff(&bytes, path)
        }
        "jpg" | "jpeg" => decode_plain(&bytes, image::ImageFormat::Jpeg, &label, extent),
        "png" => decode_plain(&bytes, image::ImageFormat::Png, &label, extent),
        _ => Err(format_err(
            path,
            format!(
                "extension '.{ext}': expected .tif/.tiff (GeoTIFF), or .jpg/.jpeg/.png with \
                 its extent as FILE@W,S,E,N"
            ),
        )),
    }
}

/// A plain image's pixels as RGBA; `extent` `None` takes it as global if it is 2:1.
pub fn decode_plain(
    bytes: &[u8],
    format: image::ImageFormat,
    label: &str,
    extent: Option<Extent>,
) -> Result<Imagery, ImageryError> {
    let path = Path::new(label);
    let img = image::load_from_memory_with_format(bytes, format)
        .map_err(|e| format_err(path, format!("cannot decode as {format:?}: {e}")))?;
    let (w, h) = (img.width(), img.height());
    let extent = match extent {
        Some(e) => e,
        None if w == 2 * h => Extent::GLOBAL,
        None => {
            return Err(format_err(
                path,
                format!(
                    "{w} × {h} pixels is not 2:1, so it cannot be taken as the whole Earth; \
                     give its extent as FILE@W,S,E,N (degrees)"
                ),
            ));
        }
    };
    Imagery::new(label, w, h, extent, img.to_rgba8().into_raw())
}

/// A GeoTIFF's first image: its georeferencing read by globe's GeoTIFF header reader (the
/// elevation reader's checks: north up, latitude/longitude in degrees), its pixels by `tiff`.
fn geotiff(bytes: &[u8], path: &Path) -> Result<Imagery, ImageryError> {
    let header = crate::dem::geotiff::read_header(bytes, path)?;
    let spp = header.samples_per_pixel;
    if !(spp == 3 || spp == 4) || header.bits_per_sample != 8 {
        return Err(format_err(
            path,
            format!(
                "{spp} samples of {} bits per pixel; expected RGB or RGBA imagery, 8 bits a \
                 sample (a single-band file is elevation: pass it as --dem)",
                header.bits_per_sample
            ),
        ));
    }
    let bad = |e: tiff::TiffError| {
        format_err(
            path,
            format!(
                "cannot decode its pixels ({} compression): {e}",
                header.compression
            ),
        )
    };
    let mut decoder = tiff::decoder::Decoder::new(Cursor::new(bytes))
        .map_err(bad)?
        .with_limits(tiff::decoder::Limits::unlimited());
    let colour = decoder.colortype().map_err(bad)?;
    let data = match decoder.read_image().map_err(bad)? {
        tiff::decoder::DecodingResult::U8(v) => v,
        _ => return Err(format_err(path, "expected 8-bit samples".into())),
    };
    let rgba: Vec<u8> = match colour {
        tiff::ColorType::RGB(8) => data
            .chunks_exact(3)
            .flat_map(|p| [p[0], p[1], p[2], 255])
            .collect(),
        tiff::ColorType::RGBA(8) => data,
        other => {
            return Err(format_err(
                path,
                format!("colour type {other:?}; expected RGB or RGBA, 8 bits a sample"),
            ));
        }
    };
    let g = header.georef.grid;
    let west = g.lon0_deg - 0.5 * g.dlon_deg;
    let north = g.lat0_deg + 0.5 * g.dlat_deg;
    let extent = Extent {
        west,
        south: north - g.rows as f64 * g.dlat_deg,
        east: west + g.cols as f64 * g.dlon_deg,
        north,
    };
    Imagery::new(
        path.display().to_string(),
        header.width as u32,
        header.height as u32,
        extent,
        rgba,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::imagery::encode;

    fn png(w: u32, h: u32) -> Vec<u8> {
        let img = image::RgbImage::from_fn(w, h, |x, y| image::Rgb([x as u8, y as u8, 7]));
        let mut out = Cursor::new(Vec::new());
        img.write_to(&mut out, image::ImageFormat::Png).unwrap();
        out.into_inner()
    }

    /// A 2:1 image is the whole Earth; any other needs its extent, and says so.
    #[test]
    fn plain_images_need_an_extent_unless_they_are_two_to_one() {
        let global = decode_plain(&png(8, 4), image::ImageFormat::Png, "g.png", None).unwrap();
        assert_eq!(global.extent, Extent::GLOBAL);
        assert_eq!(global.pixel(3, 2), [3, 2, 7, 255]);
        let e = decode_plain(&png(6, 4), image::ImageFormat::Png, "r.png", None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("r.png") && e.contains("FILE@W,S,E,N"), "{e}");
        let extent = Extent::parse("10,40,16,44").unwrap();
        let r = decode_plain(&png(6, 4), image::ImageFormat::Png, "r.png", Some(extent)).unwrap();
        // Pixel (2, 1)'s centre: 12.5° E, 42.5° N.
        assert_eq!(encode(r.sample(42.5, 12.5).unwrap()), [2, 1, 7, 255]);
    }

    #[test]
    fn unknown_extensions_and_folders_are_clear_errors() {
        let dir = std::env::temp_dir();
        let e = open(&dir, None).unwrap_err().to_string();
        assert!(e.contains("is a folder"), "{e}");
        let f = dir.join("globe-imagery-test.bmp");
        std::fs::write(&f, b"x").unwrap();
        let e = open(&f, None).unwrap_err().to_string();
        assert!(e.contains("expected .tif"), "{e}");
    }
}
