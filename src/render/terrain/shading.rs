//! What of the terrain's shading a frame compiles in: the `FAR` and `BUMP` pipeline
//! variants, chosen where the frame's bounds prove the rest invisible.

use crate::plan::ViewPlan;
use crate::render::gpu_data::{BumpUniforms, LevelUniforms};

/// What of the terrain's shading a frame's clipmap pipelines compile in, where the frame's
/// bounds prove the rest invisible (a CPU rasteriser runs the code of a branch no pixel takes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shading {
    /// Not `FAR`: the look's per-pixel texture work ([`FrameInfo::far`]).
    pub far: bool,
    /// `BUMP`: the bump octaves ([`bump_can_show`]).
    pub bump: bool,
}

impl Shading {
    /// Everything compiled in: the pipelines every frame can use.
    pub const ALL: Shading = Shading {
        far: false,
        bump: true,
    };
}

/// The smallest footprint (metres of terrain per pixel) a frame drawn with `FAR` may have.
/// There the look's per-pixel texture work is constant: the boundary octaves are 0 from a
/// quarter of their coarser cell on (`boundary_octave`'s band limit), and the proto-textures'
/// and waves' trilinear reads take their coarsest mip (one texel) once a pixel spans a tile on
/// the texture's plane. The plane projection may shorten a footprint: 16 × the largest tile
/// leaves 4 mips for it (a plane within 86° of the surface; water is level, its planes within
/// 74° of it).
pub const FAR_FOOTPRINT_M: f64 = {
    let boundary = 0.25 * crate::look::BOUNDARY_CELLS_M[0];
    let waves = 16.0 * crate::look::WAVE_TILES_M[0];
    let albedo = 16.0 * crate::look::TEXTURE_TILE_M;
    boundary.max(waves).max(albedo)
};

/// A lower bound on every pixel's footprint on the terrain (metres per pixel, the length of
/// the position's screen derivative along x or y): the nearest terrain is at least the eye's
/// height above the highest, `highest_m`, and a pixel's angle is at least Δ/(1 + t_x² + t_y²)
/// (Δ = 2·t_y/H the pixel's width on the image plane at distance 1, t the half field's
/// tangents: a pinhole's corner pixel); an oblique surface only stretches the footprint.
pub fn far_footprint_m(view: &ViewPlan, highest_m: f64) -> f64 {
    let t_y = (0.5 * view.fov_y_rad).tan();
    let t_x = t_y * view.aspect;
    let pixel = 2.0 * t_y / f64::from(view.height_px.max(1));
    nearest_terrain_m(view, highest_m) * pixel / (1.0 + t_x * t_x + t_y * t_y)
}

/// A lower bound on the distance from the eye to any terrain: its height above the highest.
fn nearest_terrain_m(view: &ViewPlan, highest_m: f64) -> f64 {
    (view.camera.altitude_m - highest_m).max(0.0)
}

/// Whether any pixel can show a bump octave (`bump_gradient`): those are the octaves from the
/// drawn level's `detail_end` (its blend band's coarser level's, if smaller) up to λ_px(d),
/// which falls with the distance d. At the nearest terrain's distance λ_px is at its largest;
/// when that is at most every drawn level's first bump octave, or below 0 (every pixel's then
/// clamps to 0), no pixel shows one (10⁻³ to spare for the shader's f32).
pub fn bump_can_show(
    bump: &BumpUniforms,
    levels: &[LevelUniforms],
    drawn: &[u32],
    view: &ViewPlan,
    highest_m: f64,
) -> bool {
    let [x, y, count, _] = bump.lambda_px.map(f64::from);
    if count <= 0.0 {
        return false;
    }
    let nearest = nearest_terrain_m(view, highest_m).max(1e-6);
    let lambda = x - nearest.ln() * y;
    if lambda < -1e-3 {
        // Every pixel's λ_px clamps to exactly 0, which no octave lies below.
        return false;
    }
    let lambda = lambda.min(count);
    drawn.iter().any(|&l| {
        let end = |l: u32| levels[l as usize].detail_end;
        let first = end(l).min(end(l.saturating_sub(1)));
        lambda > f64::from(first) - 1e-3
    })
}
