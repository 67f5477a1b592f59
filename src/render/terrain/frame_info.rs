//! What the renderer decided and did for one frame, and whether the view is complete.

use crate::clipmap::density::DensityPlan;
use crate::clipmap::draw_list::DrawList;
use crate::clipmap::selection::LevelSelection;
use crate::look::SkyRing;
use crate::plan::HeightSource;
use crate::render::dem_feed::FeedFrame;
use crate::render::planar::PlanarDraw;

use super::shading::Shading;

/// What the renderer decided and did for one frame.
#[derive(Clone, Debug)]
pub struct FrameInfo {
    pub selection: LevelSelection,
    /// The ring density each drawn level was drawn at.
    pub densities: DensityPlan,
    pub draw: DrawList,
    /// Texels the compute pass wrote this frame (toroidal updates).
    pub texels_filled: u64,
    pub near_m: f64,
    pub height_above_terrain_m: f64,
    /// Where the camera's ground height came from.
    pub ground_source: HeightSource,
    /// Linear RGB background: sky blue near the ground, black in space.
    pub sky_linear: [f64; 3],
    /// The directions the sky pass shades from outside the atmosphere (`look::SkyRing`):
    /// every pixel beyond them is black, as the pass would shade it, or terrain. None: the
    /// whole frame (eye inside the shell or just above it, or the sky off).
    pub sky_ring: Option<SkyRing>,
    /// What the clipmap's shading compiles in. `far`: every pixel's footprint on the terrain
    /// is at least [`FAR_FOOTPRINT_M`], so the pipelines' `FAR` leaves out the look's per-pixel
    /// texture work (exact there: see [`far_footprint_m`]). `bump` off: no pixel can show a
    /// bump octave ([`bump_can_show`]).
    pub shading: Shading,
    /// The streaming pipeline's state after this frame (DEM terrain only).
    pub stream: Option<FeedFrame>,
    /// What a planar LOD method draws near the viewer (None: the clipmap alone).
    pub planar: Option<PlanarDraw>,
}

/// How long [`TerrainRenderer::settle_or_explain`] waits, once a frame is settled, for the
/// tiles only its culling bounds still lack when the LRU cannot hold them or a read failed:
/// from the last time fewer were missing than before.
pub(super) const SETTLE_BOUNDS_GRACE: std::time::Duration = std::time::Duration::from_secs(2);

impl FrameInfo {
    /// True when nothing this view needs is still on its way (always, for the analytic
    /// planet, which the GPU evaluates itself), planar patches' errors included.
    pub fn settled(&self) -> bool {
        self.stream.as_ref().is_none_or(|s| s.complete)
            && self.planar.as_ref().is_none_or(|p| p.waiting == 0)
    }

    /// What keeps the frame from settling, in words (for a timeout's message): the levels
    /// waiting and the tiles they lack, a stand-in camera height, uploads held back, planar
    /// patches without their error; "nothing" when settled.
    pub fn waiting_for(&self) -> String {
        let mut parts = Vec::new();
        let waiting = self.selection.waiting();
        if let Some(s) = &self.stream {
            if !waiting.is_empty() || s.tiles_missing > 0 {
                let levels = waiting
                    .iter()
                    .map(u32::to_string)
                    .collect::<Vec<_>>()
                    .join(", ");
                parts.push(format!(
                    "{} tiles ({} queued, {} reading) for clipmap levels [{levels}]",
                    s.tiles_missing, s.stream.queued, s.stream.in_flight
                ));
            }
            if s.upload_backlog > 0 {
                parts.push(format!(
                    "{} decoded tiles waiting for GPU uploads (--uploads-per-frame)",
                    s.upload_backlog
                ));
            }
            if !s.complete && parts.is_empty() {
                parts.push(format!(
                    "level fills ({} of {} GPU tile slots in use)",
                    s.gpu_tiles, s.gpu_capacity
                ));
            }
        } else if !waiting.is_empty() {
            parts.push(format!("clipmap levels {waiting:?}"));
        }
        if self.ground_source == HeightSource::CoarserTiles {
            parts.push("the tile under the camera (its height is a coarser stand-in)".into());
        }
        if let Some(p) = self.planar.as_ref().filter(|p| p.waiting > 0) {
            parts.push(format!("the error of {} close-up patches", p.waiting));
        }
        if parts.is_empty() {
            "nothing".into()
        } else {
            parts.join("; ")
        }
    }

    /// Triangles drawn: the clipmap's (those in a planar square included: they are cut per
    /// fragment) and the planar method's.
    pub fn triangles(&self) -> u64 {
        self.draw.triangles + self.planar.as_ref().map_or(0, |p| p.triangles)
    }
}
