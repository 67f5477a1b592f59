//! Settings of the spherical clipmap: mesh resolution, texture size, map transform form.
//!
//! The defaults are chosen by measurement (see README "Choosing n, m and the texture size").

/// Which form of the map transform (spherical-clipmaps.md eq. 2–4) the vertex shader uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TransformForm {
    /// The paper's eq. 4 evaluated in f32: `acos(p_z) − θv`. Loses metres near the viewer.
    Direct,
    /// DESIGN.md's cancellation-free three-branch form. The default: ≤ 1 cm within 1 km.
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
    /// Number of levels i = 0..levels; level i covers θ̃ ∈ (2^−(i+1)π, 2^−iπ].
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
    /// `transform` is `Approximate`. The paper used 10; see README for our measurement.
    pub approx_start_level: u32,
}

impl Default for ClipmapSettings {
    fn default() -> Self {
        Self {
            phi_steps: 512,
            rings_per_level: 32,
            levels: 30,
            texture_size: 512,
            sectors: 32,
            blend_fraction: 0.25,
            transform: TransformForm::Stable,
            approx_start_level: 14,
        }
    }
}

/// A setting that cannot produce a valid clipmap.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SettingsError {
    #[error("phi_steps (n) = {n} must be a positive multiple of 2 × sectors = {}", 2 * sectors)]
    PhiSteps { n: u32, sectors: u32 },
    #[error("rings_per_level (m) = {0} must be between 1 and 1024")]
    Rings(u32),
    #[error("levels = {0} must be between 2 and 48 (level 48 is 0.07 mm across)")]
    Levels(u32),
    #[error("texture_size = {0} must be a power of two between 16 and 4096")]
    TextureSize(u32),
    #[error("blend_fraction = {0} must be in (0, 1]")]
    Blend(f32),
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

/// Outer edge θ̃_{i,0} = 2^−i·π of level i (§3.4).
pub fn level_outer_theta_rad(level: u32) -> f64 {
    std::f64::consts::PI * (-(level as f64)).exp2()
}

/// θ̃_{i,j} = θ̃_{i,0}·2^(−j/m) (§3.4).
pub fn ring_theta_rad(level: u32, ring: u32, rings_per_level: u32) -> f64 {
    level_outer_theta_rad(level) * (-(ring as f64) / rings_per_level as f64).exp2()
}
