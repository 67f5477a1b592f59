//! Settings of the spherical clipmap: mesh resolution, texture size, map transform form.
//!
//! The defaults are chosen by measurement (see docs/design.md#choosing-n-m-and-the-texture-size).

/// Which form of the map transform (spherical-clipmaps.md eq. 2–4) the vertex shader uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TransformForm {
    /// The paper's eq. 4 evaluated in f32: `acos(p_z) − θv`. Loses metres near the viewer.
    Direct,
    /// The cancellation-free three-branch form (docs/design.md#numerics). The default: ≤ 1 cm within 1 km.
    Stable,
    /// The paper's approximation (eq. 11, 14) on the inner levels, blended by ring into the
    /// stable form on the outer ones (Fig. 14: blending avoids gaps).
    Approximate,
}

impl TransformForm {
    pub const ALL: [TransformForm; 3] = [Self::Direct, Self::Stable, Self::Approximate];

    /// Value of the `transform_form` uniform the vertex shader switches on.
    pub fn shader_code(self) -> u32 {
        match self {
            Self::Direct => 0,
            Self::Stable => 1,
            Self::Approximate => 2,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Self::Direct => "direct",
            Self::Stable => "stable",
            Self::Approximate => "approximate",
        }
    }
}

impl std::str::FromStr for TransformForm {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|f| f.name() == s)
            .ok_or_else(|| {
                format!("unknown map transform form '{s}' (expected direct, stable or approximate)")
            })
    }
}

/// Resolution and behaviour of the clipmap. All fields are user settings.
#[derive(Clone, Debug, PartialEq)]
pub struct ClipmapSettings {
    /// n: φ̃ steps around every ring (§3.4). Must be a multiple of `2 * sectors`.
    pub phi_steps: u32,
    /// m: rings per level (θ̃_{i,j} = θ̃_{i,0}·2^(−j/m), §3.4).
    pub rings_per_level: u32,
    /// Number of levels i = 0..levels; level i covers θ̃ ∈ (2^−(i+1)π, 2^−iπ]. The most a
    /// frame may draw: the pixel bound and the view (`ClipmapPlan::limit_to_view`) pick how
    /// many it does. 40 reaches 0.07 mm across, what a camera 1 mm above the detail needs.
    pub levels: u32,
    /// Side of each clipmap level texture in texels (square, one array layer per level).
    pub texture_size: u32,
    /// φ̃ sectors per level, culled against the frustum one by one.
    pub sectors: u32,
    /// Fraction of a level (in rings, from its outer edge) over which heights blend into the
    /// next coarser level, so level boundaries neither crack nor pop.
    pub blend_fraction: f32,
    /// Map transform used by the vertex shader.
    pub transform: TransformForm,
    /// First level (counting from the coarsest, 0) that uses the approximation when
    /// `transform` is `Approximate`. The paper used 10; see docs/design.md#the-three-map-transform-forms for our measurement.
    pub approx_start_level: u32,
    /// Target on-screen spacing of the mesh's vertices in pixels: each level is drawn at the
    /// coarsest ring density (every 2^k-th φ̃ step and ring, k ≤ 4 at
    /// the default n, m and sectors: `clipmap::mesh::max_density`) whose vertices stay this
    /// close (`clipmap::density`). 0: every level at full density (the paper's mesh).
    pub target_spacing_px: f32,
}

impl Default for ClipmapSettings {
    fn default() -> Self {
        Self {
            phi_steps: 512,
            rings_per_level: 32,
            levels: 40,
            texture_size: 512,
            sectors: 32,
            blend_fraction: 0.25,
            transform: TransformForm::Stable,
            approx_start_level: 14,
            target_spacing_px: DEFAULT_TARGET_SPACING_PX,
        }
    }
}

/// Default target vertex spacing in pixels: that of the default error budget.
pub const DEFAULT_TARGET_SPACING_PX: f32 = 5.0 * DEFAULT_ERROR_BUDGET_PX;

/// The default of the one error knob, `--error-budget` (docs/design.md#the-error-knob): the cheapest
/// budget of the sweep (0.5, 1, 2, 4, 8 px) that keeps p99 ρ ≤ 1 px and max ρ ≤ 2 px in every
/// named scene, on the embedded Earth and on the analytic planet (8 fails `ground`).
pub const DEFAULT_ERROR_BUDGET_PX: f32 = 4.0;

/// Range of the error budget in pixels.
pub const ERROR_BUDGET_RANGE_PX: (f32, f32) = (0.25, 12.0);

/// The error budget outside its range.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error(
    "error budget {0} px must be between 0.25 and 12 px (the target max ρ at the frame's resolution)"
)]
pub struct BudgetError(pub f32);

/// A setting that cannot produce a valid clipmap.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SettingsError {
    #[error("phi_steps (n) = {n} must be a positive multiple of 2 × sectors = {}", 2 * sectors)]
    PhiSteps { n: u32, sectors: u32 },
    #[error("rings_per_level (m) = {0} must be between 1 and 1024")]
    Rings(u32),
    #[error("levels = {0} must be between 2 and 48 (level 47 is 0.3 µm across)")]
    Levels(u32),
    #[error("texture_size = {0} must be a power of two between 16 and 4096")]
    TextureSize(u32),
    #[error("blend_fraction = {0} must be in (0, 1]")]
    Blend(f32),
    #[error("target vertex spacing = {0} px must be 0 (full density) or between 0.5 and 64")]
    Spacing(f32),
}

impl ClipmapSettings {
    /// Checks every field; the renderer only accepts validated settings.
    pub fn validate(&self) -> Result<(), SettingsError> {
        let n = self.phi_steps;
        if self.sectors == 0 || n == 0 || !n.is_multiple_of(2 * self.sectors) {
            return Err(SettingsError::PhiSteps {
                n,
                sectors: self.sectors,
            });
        }
        if !(1..=1024).contains(&self.rings_per_level) {
            return Err(SettingsError::Rings(self.rings_per_level));
        }
        if !(2..=48).contains(&self.levels) {
            return Err(SettingsError::Levels(self.levels));
        }
        let s = self.texture_size;
        if !s.is_power_of_two() || !(16..=4096).contains(&s) {
            return Err(SettingsError::TextureSize(s));
        }
        if !(self.blend_fraction > 0.0 && self.blend_fraction <= 1.0) {
            return Err(SettingsError::Blend(self.blend_fraction));
        }
        let t = self.target_spacing_px;
        if !(t == 0.0 || (0.5..=64.0).contains(&t)) {
            return Err(SettingsError::Spacing(t));
        }
        Ok(())
    }

    /// Triangles of one full level: 2·n·m (§3.4: every quad is two triangles).
    pub fn triangles_per_level(&self) -> u64 {
        2 * self.phi_steps as u64 * self.rings_per_level as u64
    }

    /// Triangles of a fill cap (a fan of n triangles closing the finest drawn level).
    pub fn triangles_per_cap(&self) -> u64 {
        self.phi_steps as u64
    }
}

impl ClipmapSettings {
    /// The settings of one error knob (issue 14): `budget_px` is the target max ρ at the
    /// frame's resolution. The vertex spacing is 5 × the budget (the mesh is not what limits ρ
    /// in the named scenes: `globe report` shows ρ against the budget); the texture size and,
    /// below a pixel, the full-density mesh step with it (docs/design.md#choosing-n-m-and-the-texture-size:
    /// texture 256 → 512 cuts ρ by a third, n = 1024, m = 64 with 1024² halves it).
    pub fn for_error_budget(budget_px: f32) -> Result<Self, BudgetError> {
        let (lo, hi) = ERROR_BUDGET_RANGE_PX;
        if !(lo..=hi).contains(&budget_px) {
            return Err(BudgetError(budget_px));
        }
        let (texture_size, phi_steps, rings_per_level) = match budget_px {
            b if b < 0.5 => (2048, 1024, 64),
            b if b < 1.0 => (1024, 1024, 64),
            // 256² textures only from 8 px: at 4 px they miss the target on the analytic
            // planet (`aircraft` p99 1.70, max 2.62 px), 512² meets it (0.94 / 1.47 px).
            b if b < 8.0 => (512, 512, 32),
            _ => (256, 512, 32),
        };
        Ok(Self {
            texture_size,
            phi_steps,
            rings_per_level,
            target_spacing_px: (5.0 * budget_px).min(64.0),
            ..Self::default()
        })
    }
}

/// Outer edge θ̃_{i,0} = 2^−i·π of level i (§3.4).
pub fn level_outer_theta_rad(level: u32) -> f64 {
    std::f64::consts::PI * (-(level as f64)).exp2()
}

/// θ̃_{i,j} = θ̃_{i,0}·2^(−j/m) (§3.4).
pub fn ring_theta_rad(level: u32, ring: u32, rings_per_level: u32) -> f64 {
    level_outer_theta_rad(level) * (-(ring as f64) / rings_per_level as f64).exp2()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The default settings are those of the default budget, and every budget in range makes
    /// valid settings, denser or with larger textures as it shrinks.
    #[test]
    fn the_error_budget_spans_valid_settings() {
        assert_eq!(
            ClipmapSettings::for_error_budget(DEFAULT_ERROR_BUDGET_PX),
            Ok(ClipmapSettings::default())
        );
        let mut last: Option<ClipmapSettings> = None;
        for b in [12.0, 8.0, 4.0, 2.0, 1.0, 0.5, 0.25] {
            let s = ClipmapSettings::for_error_budget(b).unwrap();
            s.validate().unwrap();
            if let Some(l) = &last {
                assert!(s.target_spacing_px <= l.target_spacing_px);
                assert!(s.texture_size >= l.texture_size);
            }
            last = Some(s);
        }
        assert_eq!(
            ClipmapSettings::for_error_budget(0.1),
            Err(BudgetError(0.1))
        );
    }
}
