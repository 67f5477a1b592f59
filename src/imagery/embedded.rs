//! The imagery inside the binary: NASA's Blue Marble Next Generation at 4′ (5400 × 2700,
//! plate carrée, whole Earth; `assets/LICENSE-imagery.txt` says where it comes from).

use super::{Extent, Imagery, ImageryError};

/// The JPEG compiled into the binary.
pub const BMNG_JPEG: &[u8] = include_bytes!("../../assets/imagery-bmng-4min.jpg");

/// Decodes the embedded image (about 0.1 s).
pub fn load() -> Result<Imagery, ImageryError> {
    super::load::decode_plain(
        BMNG_JPEG,
        image::ImageFormat::Jpeg,
        "assets/imagery-bmng-4min.jpg",
        Some(Extent::GLOBAL),
    )
}
