//! The look of the planet: proto-textured surface types, water and the atmosphere
//! (docs/look.md#the-look).
//!
//! None of it changes what is measured except water, which is part of the terrain function
//! (`Terrain::water_level_m`: the surface is max(h, level) for geometry, reference and metric
//! alike). The rest is shading: the screen-space error ρ is about positions, not colours.

pub mod atmosphere;
pub mod proto;
pub mod sun;

pub use atmosphere::{Atmosphere, SKY_RING_SEGMENTS, SkyRing};
pub use proto::MipKind;
pub use sun::{Sun, TimeError, Utc};

/// Which parts of the look are drawn. Each off gives back the plain image: hypsometric tint,
/// one Lambert light, a flat sky colour (what measurements of raw terrain colour need).
/// Water is not here: it is part of the terrain (`Terrain::with_water_level`), its shading
/// drawn wherever the terrain has it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LookSettings {
    /// Proto-textured surface types (sand, grass, forest, rock, snow) instead of the tint.
    pub textures: bool,
    /// The atmosphere: sky, the glow around the disk, haze over the terrain.
    pub sky: bool,
    /// The proto-textures' mipmaps (§4.2's variance-reducing ones, or plain).
    pub mips: MipKind,
    /// Where the sun stands: the same in every viewer's sky, or the real one at a moment.
    pub sun: Sun,
}

impl Default for LookSettings {
    fn default() -> Self {
        Self {
            textures: true,
            sky: true,
            mips: MipKind::VarianceReducing,
            sun: Sun::Fixed,
        }
    }
}

impl LookSettings {
    /// Everything off: the plain image of earlier versions.
    pub fn plain() -> Self {
        Self {
            textures: false,
            sky: false,
            mips: MipKind::VarianceReducing,
            sun: Sun::Fixed,
        }
    }
}

/// Edge of the proto-textures' tile, metres: 256 texels of 3 cm.
pub const TEXTURE_TILE_M: f64 = 8.0;
/// Cells of the two octaves of value noise that perturb the surface types' boundaries, metres
/// (types change over kilometres and hundreds of metres, not along contour lines).
pub const BOUNDARY_CELLS_M: [f64; 2] = [2_700.0, 610.0];
/// The hash seeds of those two octaves.
pub const BOUNDARY_SEEDS: [u32; 2] = [0x9e37_79b9, 0x7f4a_7c15];
/// Tiles of the two wave scales, metres.
pub const WAVE_TILES_M: [f64; 2] = [37.0, 9.0];
/// The water level `--water on` puts water at, metres: the sea (a DEM's heights are above mean
/// sea level; land below it, such as the Caspian depression, floods too: there is no land mask).
pub const SEA_LEVEL_M: f64 = 0.0;
