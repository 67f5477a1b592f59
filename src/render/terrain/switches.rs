//! What tests, benchmarks and measurements switch in the terrain pass: each either draws more
//! than the frame needs (to show that what the plan leaves out contributes nothing) or draws
//! as globe did before an optimisation (to compare against it).

use crate::plan::clipmap::DensityMap;

/// All off by default: the frame as the plan decides it.
#[derive(Clone, Copy, Debug, Default)]
pub struct Switches {
    /// Debug: draw every level of the mesh regardless of the visibility bounds (tests use it to
    /// show that the levels the bounds skip contribute nothing to the image).
    pub draw_all_levels: bool,
    /// Debug: draw every sector, including those outside the frustum.
    pub draw_all_sectors: bool,
    /// Test hook: changes every drawn level's ring density after the plan chose it.
    pub density_map: Option<DensityMap>,
    /// Debug/benchmark: draw with the pass-through pipeline instead of the terrain's.
    pub use_passthrough: bool,
    /// Tests: integrate the sky per pixel even where the sky-view table would serve.
    pub sky_per_pixel: bool,
    /// Tests: shade every frame with everything compiled in ([`super::Shading::ALL`]), as
    /// before [`super::FrameInfo::shading`].
    pub all_shading: bool,
    /// Tests: shade the sky over the whole frame, as before the ring
    /// ([`super::FrameInfo::sky_ring`]).
    pub sky_whole_frame: bool,
    /// Tests: draw every range with the water's shading, as before the water cull (which
    /// still runs; only the draws ignore it).
    pub ignore_water_cull: bool,
    /// Measurement: shade every bump octave whatever its size on screen (the naive policy the
    /// shimmer measurement compares against).
    pub naive_bump: bool,
}
