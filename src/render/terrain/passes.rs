//! The compute passes that write and read the level textures before the terrain pass: the
//! analytic fill or the DEM's feed (the streamer → GPU tile cache → fill), the detail's
//! resources they share, the normals derived after each fill and, with water, the cull that
//! proves levels dry.

use crate::clipmap::ClipmapSettings;
use crate::render::RenderError;
use crate::render::dem_feed::DemFeed;
use crate::render::detail::DetailResources;
use crate::render::fill_analytic::FillPass;
use crate::render::imagery::ImageryTexture;
use crate::render::normals::NormalPass;
use crate::render::water_cull::WaterCull;
use crate::stream::StreamSettings;
use crate::terrain::{Base, Terrain};

use super::resources::LevelTextures;

/// Fill dispatches a level may need in one frame. A level rewrites at most 2 rectangles of
/// at most S × S texels, each cut along the anchor lattice of S/2 blocks
/// (`GridRect::anchored_pieces`): 3 × 3 pieces; the DEM fill cuts further at the poles' fold
/// lines (2 more rows of pieces) and, for a regional grid, at the 360° wrap (1 more column);
/// a normal rectangle is widened by a texel (4 × 4 pieces).
const ANALYTIC_JOBS_PER_LEVEL: u32 = 2 * 3 * 3;
const DEM_JOBS_PER_LEVEL: u32 = 2 * 4 * 5;
const NORMAL_JOBS_PER_LEVEL: u32 = 2 * 4 * 4;

/// The level textures' compute passes, each in its own file beside its WGSL.
pub(super) struct Passes {
    /// The analytic planet's fill (`shaders/fill_analytic.wgsl`).
    pub(super) fill: FillPass,
    /// The DEM's streaming pipeline and fill (None for the analytic planet).
    pub(super) feed: Option<DemFeed>,
    /// The procedural detail's fill resources (both fills add its octaves).
    pub(super) detail: DetailResources,
    /// Per-level world-frame normals (`render::normals`), filled after the heights.
    pub(super) normals: NormalPass,
    /// With water: which draws may leave its shading out (`render::water_cull`).
    pub(super) water_cull: Option<WaterCull>,
}

impl Passes {
    /// The passes for `terrain` writing into `textures`; a DEM's tiles stream with `stream`.
    pub(super) fn new(
        device: &wgpu::Device,
        settings: &ClipmapSettings,
        terrain: &Terrain,
        textures: &LevelTextures,
        stream: StreamSettings,
    ) -> Result<Self, RenderError> {
        let mut detail = DetailResources::new(
            device,
            terrain.detail().cloned(),
            settings.blend_fraction as f64,
            DEM_JOBS_PER_LEVEL * settings.levels,
        );
        detail.bind(device, &textures.partials_view);
        let mut fill = FillPass::new(device, ANALYTIC_JOBS_PER_LEVEL * settings.levels, &detail);
        fill.set_target(device, &textures.heights_view);
        let feed = match terrain.base() {
            Base::Dem(dem) => Some(DemFeed::for_levels(
                device,
                dem.clone(),
                stream,
                DEM_JOBS_PER_LEVEL * settings.levels,
                &detail,
                &textures.heights_view,
                terrain.water_level_m(),
            )?),
            Base::Analytic(_) => None,
        };
        let normals = NormalPass::new(
            device,
            NORMAL_JOBS_PER_LEVEL * settings.levels,
            &textures.heights_view,
            &textures.partials_view,
            [
                &textures.normals_view,
                &textures.boundary_noise_view,
                &textures.imagery_view,
            ],
            ImageryTexture::new(device, terrain.imagery().map(|i| i.as_ref())),
        );
        let water_cull = terrain.water_level_m().is_some().then(|| {
            WaterCull::new(
                device,
                &textures.normals_view,
                settings.levels,
                settings.texture_size,
            )
        });
        Ok(Self {
            fill,
            feed,
            detail,
            normals,
            water_cull,
        })
    }
}
