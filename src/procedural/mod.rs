//! Procedural detail below the data's resolution: the rescale-and-add multifractal of
//! infinite-landscapes-projected-grid.md eq. 1 with domain warping (§2.2), band-limited by
//! distance (§4.1), with its amplitude tied to the data's local relief.
//!
//! # The function
//!
//! Octave k has lattice cells of L_k = L_0·r^−k metres (r: lacunarity) from L_0, one octave
//! below the data's pixel spacing, down to the floor (1 cm by default), and amplitude
//! a_k = r^−kH (H: Hurst exponent, eq. 1's 1/r^kH). With S_k the value noise of octave k over
//! its warped, rotated 3-D lattice ([`noise`], [`warp`]) and Ĥ_k = Σ_{j<k} t_j the height so
//! far:
//!
//! t_k = a_k·(1 + g_h·clamp(Ĥ_k, −1, 1))·S_k            (height-dependent roughness)
//! D(u, λ) = σ(u)·Σ_k w_k(λ)·t_k,   w_k(λ) = clamp(λ − k, 0, 1)
//!
//! σ(u) is the first octave's amplitude from the relief map ([`roughness`]), so plains stay
//! gentle and mountains get rough. λ counts octaves (§4.1: ⌊λ⌋ whole, the next one weighted by
//! the fraction, geomorphing for free). The warp and the roughness read Ĥ_k without the weights,
//! so each octave's shape does not depend on λ: only how much of it is added.
//!
//! # Which octaves are geometry (the rule the metric and the renderer share)
//!
//! At arc distance s from the point under the viewer, geometry holds the octaves whose cells are
//! at least κ·s: λ_geo(s) = log_r(L_0 / (κ·s)) + 1, clamped to [0, n] (κ = `geometry_cut`, 1/8
//! by default). The terrain function the reference ray caster and the metric evaluate for a view
//! is DEM + D(u, λ_geo(s(u))); at the viewer (s = 0) it is every octave down to the floor, which
//! is the ground the camera stands on. Finer octaves are shading only. With κ = 1/8 a clipmap
//! level's finest geometric octave spans at least 8 of its texels at the level's inner edge
//! (spherical-clipmaps.md §4.2: a level holds only what its texels can carry) and at least four
//! vertex spacings, so the ring mesh neither aliases nor loses it.

pub mod delta;
pub mod noise;
pub mod presets;
pub mod roughness;
pub mod warp;

use std::path::{Path, PathBuf};

use glam::{DMat3, DQuat, DVec3};
use serde::{Deserialize, Serialize};

pub use delta::{DeltaBlock, delta_texel_f32};
pub use roughness::{ReliefDab, RoughnessMap};
pub use warp::WarpParams;

/// Octaves at most (the GPU's per-job table); a floor that would need more is raised.
pub const MAX_OCTAVES: usize = 32;
/// Octaves a clipmap level can hold with a weight between 0 and 1 (one RGBA texel).
pub const MAX_PARTIAL: usize = 4;

/// The detail's parameters, as saved in a detail file (JSON). Every field has a default; the
/// allowed ranges are in [`PARAM_RANGES`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DetailParams {
    /// Seed of the lattice hash: another seed, another planet surface.
    pub seed: u32,
    /// H of eq. 1: amplitudes fall by r^−H per octave (1: smooth, 0: rough).
    pub hurst: f64,
    /// r of eq. 1: cells shrink by r per octave.
    pub lacunarity: f64,
    /// Smallest cell, metres (default 1 cm).
    pub floor_m: f64,
    /// How many octaves below the data's pixel spacing the first octave's cell lies.
    pub octaves_below_data: f64,
    /// First octave's amplitude where the data is flat, metres.
    pub amplitude_min_m: f64,
    /// First octave's amplitude per metre of the data's local relief, continued from the
    /// relief map's cell to the first octave's by (L_0/cell)^H.
    pub roughness_gain: f64,
    /// Cap on the first octave's amplitude, metres.
    pub amplitude_max_m: f64,
    /// g_h: how much the height so far roughens (peaks) or smooths (valleys) the next octave.
    pub height_roughness: f64,
    /// κ: geometry holds octaves whose cells are at least κ × the arc distance from the
    /// viewer; finer ones are shading.
    pub geometry_cut: f64,
    pub warp: WarpParams,
    /// The editor's paint on the relief map, applied in order ([`ReliefDab`]); absent from a
    /// file that has none.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub relief_paint: Vec<ReliefDab>,
}

impl Default for DetailParams {
    fn default() -> Self {
        Self {
            seed: 1,
            hurst: 0.85,
            lacunarity: 2.0,
            floor_m: 0.01,
            octaves_below_data: 1.0,
            amplitude_min_m: 4.0,
            roughness_gain: 0.5,
            amplitude_max_m: 600.0,
            height_roughness: 0.3,
            geometry_cut: 0.125,
            warp: WarpParams::default(),
            relief_paint: Vec::new(),
        }
    }
}

/// A detail file that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum DetailError {
    // `cause`, not `source`: the message already quotes it, so an error chain would repeat it.
    #[error("cannot read detail file {path}: {cause}")]
    Read {
        path: PathBuf,
        cause: std::io::Error,
    },
    #[error("cannot write detail file {path}: {cause}")]
    Write {
        path: PathBuf,
        cause: std::io::Error,
    },
    #[error("detail file {path}: {message}")]
    Parse { path: PathBuf, message: String },
    #[error("{origin}: field `{field}` = {value} is outside its allowed range {allowed}")]
    Range {
        origin: String,
        field: &'static str,
        value: f64,
        allowed: String,
    },
}

/// One field's allowed range: what [`DetailParams::validate`] enforces and what the editor's
/// sliders offer (one table, so the two cannot disagree). The seed has no entry: every u32 is
/// a valid seed.
#[derive(Clone, Copy)]
pub struct ParamRange {
    /// The field's name in the detail file (`warp.c1[0]`: the first component of `c1`).
    pub field: &'static str,
    pub min: f64,
    pub max: f64,
    /// What the field does (the field's doc comment, shown as the slider's hover text).
    pub help: &'static str,
    pub get: fn(&DetailParams) -> f64,
    pub get_mut: fn(&mut DetailParams) -> &mut f64,
}

impl ParamRange {
    /// Whether `value` is allowed (false for NaN).
    pub fn contains(&self, value: f64) -> bool {
        self.min <= value && value <= self.max
    }

    /// The range as error messages show it: `[0.05, 1]`, `[0.001, 1e6]`.
    pub fn allowed(&self) -> String {
        let bound = |v: f64| {
            if v.abs() >= 1e5 {
                format!("{v:e}")
            } else {
                format!("{v}")
            }
        };
        format!("[{}, {}]", bound(self.min), bound(self.max))
    }
}

impl std::fmt::Debug for ParamRange {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} in {}", self.field, self.allowed())
    }
}

/// |c| of each warping vector's components at most (the paper's values are below 0.4; larger
/// ones only fold the domain onto itself).
const WARP_C_MAX: f64 = 100.0;

/// Every ranged field of [`DetailParams`], in the order the editor shows them.
pub const PARAM_RANGES: [ParamRange; 16] = [
    ParamRange {
        field: "hurst",
        min: 0.05,
        max: 1.0,
        help: "H of eq. 1: amplitudes fall by r^−H per octave (1: smooth, 0: rough)",
        get: |p| p.hurst,
        get_mut: |p| &mut p.hurst,
    },
    ParamRange {
        field: "lacunarity",
        min: 1.4,
        max: 4.0,
        help: "r of eq. 1: cells shrink by r per octave",
        get: |p| p.lacunarity,
        get_mut: |p| &mut p.lacunarity,
    },
    ParamRange {
        field: "floor_m",
        min: 0.001,
        max: 1e6,
        help: "smallest cell, metres: no octave is finer",
        get: |p| p.floor_m,
        get_mut: |p| &mut p.floor_m,
    },
    ParamRange {
        field: "octaves_below_data",
        min: 0.0,
        max: 4.0,
        help: "how many octaves below the data's pixel spacing the first octave's cell lies",
        get: |p| p.octaves_below_data,
        get_mut: |p| &mut p.octaves_below_data,
    },
    ParamRange {
        field: "amplitude_min_m",
        min: 0.0,
        max: 1e4,
        help: "first octave's amplitude where the data is flat, metres",
        get: |p| p.amplitude_min_m,
        get_mut: |p| &mut p.amplitude_min_m,
    },
    ParamRange {
        field: "roughness_gain",
        min: 0.0,
        max: 10.0,
        help: "first octave's amplitude per metre of the data's local relief",
        get: |p| p.roughness_gain,
        get_mut: |p| &mut p.roughness_gain,
    },
    ParamRange {
        field: "amplitude_max_m",
        min: 0.0,
        max: 1e4,
        help: "cap on the first octave's amplitude, metres",
        get: |p| p.amplitude_max_m,
        get_mut: |p| &mut p.amplitude_max_m,
    },
    ParamRange {
        field: "height_roughness",
        min: 0.0,
        max: 0.95,
        help: "g_h: how much the height so far roughens (peaks) or smooths (valleys) the next octave",
        get: |p| p.height_roughness,
        get_mut: |p| &mut p.height_roughness,
    },
    ParamRange {
        field: "geometry_cut",
        min: 1e-3,
        max: 4.0,
        help: "κ: geometry holds octaves whose cells are at least κ × the distance from the viewer; finer ones are shading",
        get: |p| p.geometry_cut,
        get_mut: |p| &mut p.geometry_cut,
    },
    ParamRange {
        field: "warp.lever_cells",
        min: 0.0,
        max: 64.0,
        help: "warping lever |x| in cells: how far the rotation moves a point (0: no warping)",
        get: |p| p.warp.lever_cells,
        get_mut: |p| &mut p.warp.lever_cells,
    },
    ParamRange {
        field: "warp.c1[0]",
        min: -WARP_C_MAX,
        max: WARP_C_MAX,
        help: "c1 (x): rotation of the warp per unit of roughness",
        get: |p| p.warp.c1[0],
        get_mut: |p| &mut p.warp.c1[0],
    },
    ParamRange {
        field: "warp.c1[1]",
        min: -WARP_C_MAX,
        max: WARP_C_MAX,
        help: "c1 (y): rotation of the warp per unit of roughness",
        get: |p| p.warp.c1[1],
        get_mut: |p| &mut p.warp.c1[1],
    },
    ParamRange {
        field: "warp.c2[0]",
        min: -WARP_C_MAX,
        max: WARP_C_MAX,
        help: "c2 (x): constant rotation of the warp per octave",
        get: |p| p.warp.c2[0],
        get_mut: |p| &mut p.warp.c2[0],
    },
    ParamRange {
        field: "warp.c2[1]",
        min: -WARP_C_MAX,
        max: WARP_C_MAX,
        help: "c2 (y): constant rotation of the warp per octave",
        get: |p| p.warp.c2[1],
        get_mut: |p| &mut p.warp.c2[1],
    },
    ParamRange {
        field: "warp.c3[0]",
        min: -WARP_C_MAX,
        max: WARP_C_MAX,
        help: "c3 (x): translation of each octave's lattice, in cells times r·H",
        get: |p| p.warp.c3[0],
        get_mut: |p| &mut p.warp.c3[0],
    },
    ParamRange {
        field: "warp.c3[1]",
        min: -WARP_C_MAX,
        max: WARP_C_MAX,
        help: "c3 (y): translation of each octave's lattice, in cells times r·H",
        get: |p| p.warp.c3[1],
        get_mut: |p| &mut p.warp.c3[1],
    },
];

impl DetailParams {
    /// Checks every field against its allowed range in [`PARAM_RANGES`] (`origin` names the
    /// file in errors).
    pub fn validate(&self, origin: &str) -> Result<(), DetailError> {
        for range in &PARAM_RANGES {
            let value = (range.get)(self);
            // `contains` is false for NaN too.
            if !range.contains(value) {
                return Err(DetailError::Range {
                    origin: origin.to_string(),
                    field: range.field,
                    value,
                    allowed: range.allowed(),
                });
            }
        }
        for (i, dab) in self.relief_paint.iter().enumerate() {
            if let Some((field, value, allowed)) = dab.out_of_range() {
                return Err(DetailError::Range {
                    origin: format!("{origin} (relief_paint[{i}])"),
                    field,
                    value,
                    allowed,
                });
            }
        }
        Ok(())
    }

    /// Reads and validates a detail file.
    pub fn load(path: &Path) -> Result<Self, DetailError> {
        let text = std::fs::read_to_string(path).map_err(|cause| DetailError::Read {
            path: path.to_path_buf(),
            cause,
        })?;
        Self::parse(&text, path)
    }

    /// Parses and validates the text of a detail file (`path` names it in errors).
    pub fn parse(text: &str, path: &Path) -> Result<Self, DetailError> {
        let params: Self = serde_json::from_str(text).map_err(|e| DetailError::Parse {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        params.validate(&path.display().to_string())?;
        Ok(params)
    }

    /// Writes the parameters as pretty JSON.
    pub fn save(&self, path: &Path) -> Result<(), DetailError> {
        let text = serde_json::to_string_pretty(self).expect("parameters serialize");
        std::fs::write(path, text + "\n").map_err(|cause| DetailError::Write {
            path: path.to_path_buf(),
            cause,
        })
    }

    /// R_0 = 1/(r·H) (§2.2).
    pub fn r0_roughness(&self) -> f64 {
        1.0 / (self.lacunarity * self.hurst)
    }
}

/// `--detail off|default|FILE`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum DetailSpec {
    Off,
    Default,
    File(PathBuf),
}

impl std::str::FromStr for DetailSpec {
    type Err = std::convert::Infallible;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s {
            "off" => Self::Off,
            "default" | "on" => Self::Default,
            path => Self::File(PathBuf::from(path)),
        })
    }
}

impl DetailSpec {
    /// The parameters it names (`None`: detail off).
    pub fn params(&self) -> Result<Option<DetailParams>, DetailError> {
        match self {
            Self::Off => Ok(None),
            Self::Default => Ok(Some(DetailParams::default())),
            Self::File(path) => DetailParams::load(path).map(Some),
        }
    }
}

/// One octave as every evaluation uses it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Octave {
    /// L_k, metres.
    pub cell_m: f64,
    /// a_k = r^−kH.
    pub amplitude: f64,
    /// Q_k: the lattice's orientation (a fixed random rotation per octave, so no two octaves
    /// share lattice planes).
    pub rotation: DMat3,
    /// The lattice hash's seed.
    pub seed: u32,
}

/// The lattice of one octave as the GPU sees it around a reference point: x = frac + M·Δu,
/// cell = anchor + ⌊x⌋ (M = Q_k·R/L_k; Δu: unit-vector offset from the reference point).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OctaveAnchorF32 {
    pub m: [[f32; 3]; 3],
    pub frac: [f32; 3],
    pub cell: [i32; 3],
    pub seed: u32,
}

/// Bounds of the detail split into coarse and fine octaves, for each split point
/// ([`Detail::split_bounds`]); entries 0..=`count` are set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitBounds {
    pub count: usize,
    /// Bound of |Σ_{j ≥ k} w_j t_j|: the fine octaves' amplitude (units of σ).
    pub amplitude: [f64; MAX_OCTAVES + 1],
    /// Bound of |∇ Σ_{j < k} w_j t_j| per metre: the coarse octaves' slope (units of σ).
    pub slope: [f64; MAX_OCTAVES + 1],
    /// Bound of |Σ_{j < k} w_j t_j|: the coarse octaves' amplitude (units of σ).
    pub coarse: [f64; MAX_OCTAVES + 1],
}

/// The octaves a clipmap level holds: `full` whole ones (summed into its heights) and
/// `partial` ones after them, kept apart so the vertex can weight them by its own λ.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct LevelOctaves {
    pub full: u32,
    pub partial: u32,
}

/// The detail of one terrain: parameters, octave table and relief map.
#[derive(Clone, Debug)]
pub struct Detail {
    params: DetailParams,
    radius_m: f64,
    octaves: Vec<Octave>,
    /// The relief map with the parameters' paint applied.
    roughness: RoughnessMap,
    /// The relief map before the paint (None: no paint, it is `roughness`).
    unpainted: Option<RoughnessMap>,
    /// (L_0 / relief cell)^H: relief at the map's scale continued to the first octave's.
    relief_scale: f64,
    /// The data's pixel spacing, metres (as given to [`Detail::new`]).
    data_spacing_m: f64,
}

impl Detail {
    /// The detail below data of pixel spacing `data_spacing_m` with relief `roughness` (before
    /// the parameters' `relief_paint`, which is applied here).
    pub fn new(
        params: DetailParams,
        radius_m: f64,
        data_spacing_m: f64,
        roughness: RoughnessMap,
    ) -> Self {
        let r = params.lacunarity;
        let first_cell_m = data_spacing_m / r.powf(params.octaves_below_data);
        // Lattice indices are i32 (the GPU's): cells below R/2³⁰ would overflow them at the
        // far side of the planet, so the floor is at least that (5.9 mm on Earth).
        let floor_m = params.floor_m.max(radius_m / (1u64 << 30) as f64);
        let count = if floor_m > first_cell_m {
            0
        } else {
            (((first_cell_m / floor_m).ln() / r.ln()).floor() as usize + 1).min(MAX_OCTAVES)
        };
        let octaves = (0..count)
            .map(|k| {
                let h = noise::pcg3d(params.seed, k as u32, 0x5eed);
                let q = DQuat::from_xyzw(
                    unit(h[0]) - 0.5,
                    unit(h[1]) - 0.5,
                    unit(h[2]) - 0.5,
                    unit(noise::pcg3d(h[2], h[1], h[0])[0]) - 0.5 + 1e-3,
                )
                .normalize();
                Octave {
                    cell_m: first_cell_m * r.powi(-(k as i32)),
                    amplitude: r.powf(-(k as f64) * params.hurst),
                    rotation: DMat3::from_quat(q),
                    seed: noise::pcg3d(params.seed, k as u32, 1)[0],
                }
            })
            .collect();
        let relief_cell_m = 1.5 * roughness.cell_m();
        let relief_scale = (first_cell_m / relief_cell_m).min(1.0).powf(params.hurst);
        let (roughness, unpainted) = if params.relief_paint.is_empty() {
            (roughness, None)
        } else {
            (roughness.painted(&params.relief_paint), Some(roughness))
        };
        Self {
            params,
            radius_m,
            octaves,
            roughness,
            unpainted,
            relief_scale,
            data_spacing_m,
        }
    }

    pub fn params(&self) -> &DetailParams {
        &self.params
    }

    pub fn octaves(&self) -> &[Octave] {
        &self.octaves
    }

    /// The relief map the detail uses (painted).
    pub fn roughness(&self) -> &RoughnessMap {
        &self.roughness
    }

    /// The relief map before the paint: what [`Detail::new`] was given.
    pub fn unpainted_roughness(&self) -> &RoughnessMap {
        self.unpainted.as_ref().unwrap_or(&self.roughness)
    }

    /// The same detail with other parameters (same radius, data spacing and unpainted relief):
    /// what the editor rebuilds on every change. Cheap next to building the relief map (an
    /// octave table and, with paint, one pass over the map per dab).
    pub fn with_params(&self, params: DetailParams) -> Self {
        let data_spacing_m = self.data_spacing_m();
        Self::new(
            params,
            self.radius_m,
            data_spacing_m,
            self.unpainted_roughness().clone(),
        )
    }

    /// The data's pixel spacing, metres: the first octave's cell is it over r^(octaves below
    /// data).
    pub fn data_spacing_m(&self) -> f64 {
        self.data_spacing_m
    }

    pub fn radius_m(&self) -> f64 {
        self.radius_m
    }

    /// (L_0/relief cell)^H.
    pub fn relief_scale(&self) -> f64 {
        self.relief_scale
    }

    /// n: octaves from the first to the floor.
    pub fn octave_count(&self) -> usize {
        self.octaves.len()
    }

    /// σ for a relief of `relief_m`: the first octave's amplitude.
    pub fn amplitude_for_relief_m(&self, relief_m: f64) -> f64 {
        let p = &self.params;
        (p.amplitude_min_m + p.roughness_gain * relief_m * self.relief_scale)
            .clamp(0.0, p.amplitude_max_m)
    }

    /// σ(u).
    pub fn amplitude_m(&self, u: DVec3) -> f64 {
        self.amplitude_for_relief_m(self.roughness.relief_at_m(u))
    }

    /// λ_geo at arc distance `arc_m` from the point under the viewer (module docs).
    pub fn lambda_at_arc_m(&self, arc_m: f64) -> f64 {
        let n = self.octaves.len() as f64;
        let Some(first) = self.octaves.first() else {
            return 0.0;
        };
        if arc_m <= 0.0 {
            return n;
        }
        let l = (first.cell_m / (self.params.geometry_cut * arc_m)).ln()
            / self.params.lacunarity.ln()
            + 1.0;
        l.clamp(0.0, n)
    }

    /// (x, y, n) with λ(θ̃) = clamp(x − y·ln θ̃, 0, n): [`Detail::lambda_at_angle`] as the
    /// vertex shader evaluates it.
    pub fn lambda_constants(&self) -> (f64, f64, f64) {
        let n = self.octaves.len() as f64;
        let Some(first) = self.octaves.first() else {
            return (0.0, 0.0, 0.0);
        };
        let y = 1.0 / self.params.lacunarity.ln();
        let x = (first.cell_m / (self.params.geometry_cut * self.radius_m)).ln() * y + 1.0;
        (x, y, n)
    }

    /// λ at view-space angle θ̃ from the viewer.
    pub fn lambda_at_angle(&self, theta_tilde_rad: f64) -> f64 {
        self.lambda_at_arc_m(theta_tilde_rad * self.radius_m)
    }

    /// Every octave (the ground a camera stands on).
    pub fn lambda_full(&self) -> f64 {
        self.octaves.len() as f64
    }

    /// w_k(λ) = clamp(λ − k, 0, 1).
    pub fn weight(k: usize, lambda: f64) -> f64 {
        (lambda - k as f64).clamp(0.0, 1.0)
    }

    /// D(u, λ) in metres (f64, the reference).
    pub fn height_m(&self, u: DVec3, lambda: f64) -> f64 {
        let sigma = self.amplitude_m(u);
        if sigma == 0.0 {
            return 0.0;
        }
        sigma * self.normalized(u, lambda)
    }

    /// Σ_k w_k(λ)·t_k (units of σ).
    pub fn normalized(&self, u: DVec3, lambda: f64) -> f64 {
        self.normalized_first(u, lambda, usize::MAX)
    }

    /// Σ_{k < count} w_k(λ)·t_k: the first `count` octaves (units of σ).
    pub fn normalized_first(&self, u: DVec3, lambda: f64, count: usize) -> f64 {
        let mut out = 0.0;
        self.weighted_octaves(u, lambda, count, |_, wt| out += wt);
        out
    }

    /// Every prefix of [`Detail::normalized`]: `out[k]` = Σ_{j < k} w_j(λ)·t_j for
    /// k = 0..=n (units of σ), for the cost of the whole sum. The reference ray caster splits
    /// the detail there into coarse octaves it evaluates and fine ones it bounds.
    pub fn normalized_prefixes(&self, u: DVec3, lambda: f64, out: &mut [f64; MAX_OCTAVES + 1]) {
        let n = self.octaves.len();
        out[0] = 0.0;
        let mut sum = 0.0;
        let mut done = 0;
        self.weighted_octaves(u, lambda, n, |k, wt| {
            sum += wt;
            out[k + 1] = sum;
            done = k + 1;
        });
        // Past the first octave of weight 0 every prefix is the whole sum.
        out[done + 1..=n].fill(sum);
    }

    /// Calls `each(k, w_k·t_k)` for the first `count` octaves, up to the first of weight 0.
    fn weighted_octaves(
        &self,
        u: DVec3,
        lambda: f64,
        count: usize,
        mut each: impl FnMut(usize, f64),
    ) {
        let p = &self.params;
        let r0 = p.r0_roughness();
        let mut state = warp::WarpState::start();
        let mut h_all = 0f64;
        let position = u * self.radius_m;
        for (k, o) in self.octaves.iter().enumerate().take(count) {
            let w = Self::weight(k, lambda);
            if w == 0.0 {
                break;
            }
            let d = state.displacement(&p.warp, r0);
            let x = o.rotation * position / o.cell_m + DVec3::new(d[0], d[1], 0.0);
            let (cell, frac) = noise::split(x.to_array());
            let s = noise::value_noise(cell, frac, o.seed);
            let m = 1.0 + p.height_roughness * h_all.clamp(-1.0, 1.0);
            let t = o.amplitude * m * s;
            h_all += t;
            each(k, w * t);
            state.advance(&p.warp, r0, h_all);
        }
    }

    /// Bound of |Σ w_k t_k| for octaves up to λ (units of σ).
    pub fn normalized_bound(&self, lambda: f64) -> f64 {
        self.normalized_bound_from(lambda, 0)
    }

    /// Bound of |Σ_{k ≥ first} w_k t_k| (units of σ).
    pub fn normalized_bound_from(&self, lambda: f64, first: usize) -> f64 {
        let m = 1.0 + self.params.height_roughness;
        self.octaves
            .iter()
            .enumerate()
            .skip(first)
            .map(|(k, o)| Self::weight(k, lambda) * o.amplitude * m)
            .sum()
    }

    /// Bound of |∇ Σ w_k t_k| per metre along the sphere for octaves up to λ (units of σ): the
    /// chain rule through the warp and the height-dependent roughness (module docs of
    /// [`warp`]), with |∇S| ≤ [`noise::GRADIENT_MAX`] per cell.
    pub fn normalized_slope_bound(&self, lambda: f64) -> f64 {
        self.normalized_slope_bound_first(lambda, usize::MAX)
    }

    /// As [`Detail::normalized_slope_bound`] for the first `count` octaves.
    pub fn normalized_slope_bound_first(&self, lambda: f64, count: usize) -> f64 {
        let mut g_out = 0.0;
        self.octave_slope_bounds(lambda, count, |_, wg| g_out += wg);
        g_out
    }

    /// Calls `each(k, w_k·|∇t_k| bound)` for the first `count` octaves, up to the first of
    /// weight 0: the chain rule of [`Detail::normalized_slope_bound`], octave by octave.
    fn octave_slope_bounds(&self, lambda: f64, count: usize, mut each: impl FnMut(usize, f64)) {
        let p = &self.params;
        let r0 = p.r0_roughness();
        let c1 = (p.warp.c1[0].powi(2) + p.warp.c1[1].powi(2)).sqrt();
        let m = 1.0 + p.height_roughness;
        let (mut g_all, mut g_v) = (0.0, 0.0);
        for (k, o) in self.octaves.iter().enumerate().take(count) {
            let w = Self::weight(k, lambda);
            if w == 0.0 {
                break;
            }
            // |∂(v / max(|v|, ½))| ≤ |∂v| / ½.
            let dx = 1.0 / o.cell_m + p.warp.lever_cells * g_v / warp::NORMALIZE_FLOOR;
            let g_t = o.amplitude * (m * noise::GRADIENT_MAX * dx + p.height_roughness * g_all);
            g_all += g_t;
            each(k, w * g_t);
            g_v += c1 * r0 * g_all;
        }
    }

    /// For every split of the detail at octave k = 0..=n (units of σ, octaves up to λ):
    /// `amplitude[k]` bounds |Σ_{j ≥ k} w_j t_j| (what is left out) and `slope[k]` bounds
    /// |∇ Σ_{j < k} w_j t_j| per metre, `coarse[k]` bounds |Σ_{j < k} w_j t_j|.
    pub fn split_bounds(&self, lambda: f64) -> SplitBounds {
        let n = self.octaves.len();
        let mut b = SplitBounds {
            count: n,
            amplitude: [0.0; MAX_OCTAVES + 1],
            slope: [0.0; MAX_OCTAVES + 1],
            coarse: [0.0; MAX_OCTAVES + 1],
        };
        let m = 1.0 + self.params.height_roughness;
        let mut done = 0;
        let mut coarse = 0.0;
        for (k, o) in self.octaves.iter().enumerate() {
            let w = Self::weight(k, lambda);
            if w == 0.0 {
                break;
            }
            coarse += w * o.amplitude * m;
            b.coarse[k + 1] = coarse;
            done = k + 1;
        }
        b.coarse[done + 1..=n].fill(coarse);
        for k in 0..=n {
            b.amplitude[k] = coarse - b.coarse[k];
        }
        let mut slope = 0.0;
        self.octave_slope_bounds(lambda, n, |k, wg| {
            slope += wg;
            b.slope[k + 1] = slope;
        });
        b.slope[done + 1..=n].fill(slope);
        b
    }

    /// Bounds of D over a cap of `angle_rad` around `u` for octaves up to λ: (|D| max,
    /// |∇D| max in metres per metre).
    pub fn bounds_near(&self, u: DVec3, angle_rad: f64, lambda: f64) -> (f64, f64) {
        let (_, relief, relief_slope) = self.roughness.bounds_near(u, angle_rad);
        let sigma = self.amplitude_for_relief_m(relief);
        let sigma_slope = self.params.roughness_gain * self.relief_scale * relief_slope;
        let hb = self.normalized_bound(lambda);
        (
            hb * sigma,
            sigma * self.normalized_slope_bound(lambda) + sigma_slope * hb,
        )
    }

    /// Tight bounds of D over a cap: the octaves much larger than the cap (cells ≥ 4× its
    /// radius) evaluated at its centre, ± their slope bound times the radius; the finer ones
    /// by their amplitude. `relief`: the relief map's bounds over the cap
    /// ([`RoughnessMap::bounds_near`], which the caller also needs). Returns (min, max, |∇D|
    /// max) in metres.
    pub fn bounds_near_tight(
        &self,
        u: DVec3,
        angle_rad: f64,
        lambda: f64,
        relief: (f64, f64, f64),
    ) -> (f64, f64, f64) {
        let (relief_lo, relief_hi, relief_slope) = relief;
        let (s_lo, s_hi) = (
            self.amplitude_for_relief_m(relief_lo),
            self.amplitude_for_relief_m(relief_hi),
        );
        let radius_m = angle_rad * self.radius_m;
        let coarse = self
            .octaves
            .iter()
            .take_while(|o| o.cell_m >= 4.0 * radius_m)
            .count();
        let centre = self.normalized_first(u, lambda, coarse);
        let spread = self.normalized_slope_bound_first(lambda, coarse) * radius_m
            + self.normalized_bound_from(lambda, coarse);
        let (h_lo, h_hi) = (centre - spread, centre + spread);
        let lo = (s_lo * h_lo).min(s_hi * h_lo);
        let hi = (s_lo * h_hi).max(s_hi * h_hi);
        let sigma_slope = self.params.roughness_gain * self.relief_scale * relief_slope;
        let slope =
            s_hi * self.normalized_slope_bound(lambda) + sigma_slope * h_lo.abs().max(h_hi.abs());
        (lo, hi, slope)
    }

    /// The octaves level `level` holds, for a ring blend over the outer `blend_fraction` of
    /// each level: whole where every point of the level (and the blend of the next finer
    /// level, which reads this one) has weight 1, partial where some has less.
    pub fn level_octaves(&self, level: u32, blend_fraction: f64) -> LevelOctaves {
        let outer = crate::clipmap::settings::level_outer_theta_rad(level);
        let lo = self.lambda_at_angle(outer);
        let hi = self.lambda_at_angle(outer * (-(1.0 + blend_fraction)).exp2());
        let n = self.octaves.len() as u32;
        let full = (lo.floor() as u32).min(n);
        let partial = ((hi.ceil() as u32).saturating_sub(full)).min(MAX_PARTIAL as u32);
        LevelOctaves {
            full,
            partial: partial.min(n - full),
        }
    }

    /// Whether every level can hold its partial octaves (at most [`MAX_PARTIAL`]) with a ring
    /// blend over `blend_fraction` of each level: λ spans (1 + b)·ln 2/ln r over a level and
    /// the finer level's blend band, which must stay within 3 octaves.
    pub fn check_blend(&self, blend_fraction: f64) -> Result<(), DetailError> {
        let span = (1.0 + blend_fraction) * std::f64::consts::LN_2 / self.params.lacunarity.ln();
        if span > (MAX_PARTIAL - 1) as f64 {
            return Err(DetailError::Range {
                origin: format!("with blend_fraction {blend_fraction}"),
                field: "lacunarity",
                value: self.params.lacunarity,
                allowed: "≥ 2^((1 + blend_fraction)/3) (a level holds at most 4 partial octaves)"
                    .to_string(),
            });
        }
        Ok(())
    }

    /// The lattices of octaves `first..first + count` around the unit vector `u_ref`, for
    /// the GPU: integer anchor cells in f64, the small remainder and the matrix in f32.
    pub fn anchors(&self, u_ref: DVec3, count: usize) -> Vec<OctaveAnchorF32> {
        self.anchors_in(u_ref, count, DMat3::IDENTITY)
    }

    /// As [`Detail::anchors`] for offsets Δu given in another frame (`world_from_frame`):
    /// M·world_from_frame (the fragment's bump works in view space).
    pub fn anchors_in(
        &self,
        u_ref: DVec3,
        count: usize,
        world_from_frame: DMat3,
    ) -> Vec<OctaveAnchorF32> {
        let position = u_ref * self.radius_m;
        self.octaves
            .iter()
            .take(count)
            .map(|o| {
                let m = o.rotation * (self.radius_m / o.cell_m) * world_from_frame;
                let x = o.rotation * position / o.cell_m;
                let (cell, frac) = noise::split(x.to_array());
                let row = |i: usize| [m.x_axis[i] as f32, m.y_axis[i] as f32, m.z_axis[i] as f32];
                OctaveAnchorF32 {
                    m: [row(0), row(1), row(2)],
                    frac: frac.map(|f| f as f32),
                    cell,
                    seed: o.seed,
                }
            })
            .collect()
    }
}

/// The output of a fill texel (f32 twin of the WGSL `detail_texel`).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct DetailTexelF32 {
    /// σ·Σ of the whole octaves, metres.
    pub full_m: f32,
    /// σ·t_k of each partial octave, metres.
    pub partial_m: [f32; MAX_PARTIAL],
}

/// The constants every evaluation of a detail reads, in f32 (the GPU's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DetailConstantsF32 {
    pub lever: f32,
    pub t: [f32; 2],
    pub c1r0: [f32; 2],
    pub c2: [f32; 2],
    pub height_roughness: f32,
}

impl Detail {
    pub fn constants_f32(&self) -> DetailConstantsF32 {
        let p = &self.params;
        let r0 = p.r0_roughness();
        DetailConstantsF32 {
            lever: p.warp.lever_cells as f32,
            t: [(p.warp.c3[0] / r0) as f32, (p.warp.c3[1] / r0) as f32],
            c1r0: [(p.warp.c1[0] * r0) as f32, (p.warp.c1[1] * r0) as f32],
            c2: [p.warp.c2[0] as f32, p.warp.c2[1] as f32],
            height_roughness: p.height_roughness as f32,
        }
    }

    pub fn amplitudes_f32(&self) -> Vec<f32> {
        self.octaves.iter().map(|o| o.amplitude as f32).collect()
    }
}

/// The f32 twin of the fill's detail (shaders/common/detail_fill.wgsl `detail_texel`): octaves
/// `0..full + partial` at Δu from the anchors' reference point, amplitude `sigma`.
pub fn detail_texel_f32(
    anchors: &[OctaveAnchorF32],
    amplitudes: &[f32],
    c: &DetailConstantsF32,
    du: [f32; 3],
    sigma: f32,
    octaves: LevelOctaves,
) -> DetailTexelF32 {
    let mut out = DetailTexelF32::default();
    let chain = (0, warp::WarpStateF32::start(), 0.0);
    let full = direct_octaves_f32(anchors, amplitudes, c, du, sigma, octaves, chain, &mut out);
    out.full_m = sigma * full;
    out
}

/// The held octaves from `chain.0` on, each lattice point an f32 fraction of its cell (the
/// WGSL loop `detail_texel` ends with), from the warp state `chain.1` and Ĥ `chain.2` there:
/// stores σ·t_k of the partial ones in `out` and returns the whole ones' sum (units of σ).
#[allow(clippy::too_many_arguments)] // the WGSL loop's inputs, one for one
pub(crate) fn direct_octaves_f32(
    anchors: &[OctaveAnchorF32],
    amplitudes: &[f32],
    c: &DetailConstantsF32,
    du: [f32; 3],
    sigma: f32,
    octaves: LevelOctaves,
    chain: (usize, warp::WarpStateF32, f32),
    out: &mut DetailTexelF32,
) -> f32 {
    let (first, mut state, mut h_all) = chain;
    let mut full = 0f32;
    let count = (octaves.full + octaves.partial) as usize;
    let held = anchors.iter().zip(amplitudes).enumerate();
    for (k, (a, &amplitude)) in held.take(count).skip(first) {
        let d = state.displacement(c.lever, c.t);
        let mut x = [0f32; 3];
        for (i, xi) in x.iter_mut().enumerate() {
            let row = a.m[i];
            *xi = a.frac[i] + (row[0] * du[0] + row[1] * du[1] + row[2] * du[2]);
        }
        x[0] += d[0];
        x[1] += d[1];
        let fl = x.map(f32::floor);
        let cell = [
            a.cell[0].wrapping_add(fl[0] as i32),
            a.cell[1].wrapping_add(fl[1] as i32),
            a.cell[2].wrapping_add(fl[2] as i32),
        ];
        let frac = [x[0] - fl[0], x[1] - fl[1], x[2] - fl[2]];
        let s = noise::value_noise_f32(cell, frac, a.seed);
        let m = 1.0 + c.height_roughness * h_all.clamp(-1.0, 1.0);
        let t = amplitude * m * s;
        h_all += t;
        if (k as u32) < octaves.full {
            full += t;
        } else {
            out.partial_m[k - octaves.full as usize] = sigma * t;
        }
        state.advance(c.c1r0, c.c2, h_all);
    }
    full
}

fn unit(h: u32) -> f64 {
    h as f64 / 4_294_967_296.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `validate` enforces exactly the table: each range's ends are accepted, a value just
    /// outside either end (and NaN) is refused naming that field and the table's range.
    #[test]
    fn ranges_table_is_what_validate_enforces() {
        for range in &PARAM_RANGES {
            for end in [range.min, range.max] {
                let mut p = DetailParams::default();
                *(range.get_mut)(&mut p) = end;
                assert_eq!((range.get)(&p), end, "{range:?}");
                p.validate("test")
                    .unwrap_or_else(|e| panic!("{range:?}: end {end} refused: {e}"));
            }
            let step = |v: f64| 1e-9 * v.abs().max(1.0);
            for outside in [
                range.min - step(range.min),
                range.max + step(range.max),
                f64::NAN,
            ] {
                let mut p = DetailParams::default();
                *(range.get_mut)(&mut p) = outside;
                match p.validate("test") {
                    Err(DetailError::Range { field, allowed, .. }) => {
                        assert_eq!(field, range.field);
                        assert_eq!(allowed, range.allowed());
                    }
                    other => panic!("{range:?}: {outside} gave {other:?}"),
                }
            }
        }
        // Every field of the file but the seed has an entry (warp vectors per component).
        let names: Vec<_> = PARAM_RANGES.iter().map(|r| r.field).collect();
        let json = serde_json::to_value(DetailParams::default()).unwrap();
        for (key, value) in json.as_object().unwrap() {
            match value {
                serde_json::Value::Object(warp) => {
                    for (k, v) in warp {
                        let n = v.as_array().map_or(1, |a| a.len());
                        for i in 0..n {
                            let name = if v.is_array() {
                                format!("{key}.{k}[{i}]")
                            } else {
                                format!("{key}.{k}")
                            };
                            assert!(names.contains(&name.as_str()), "{name} has no range");
                        }
                    }
                }
                _ if key == "seed" => {}
                _ => assert!(names.contains(&key.as_str()), "{key} has no range"),
            }
        }
        assert_eq!(PARAM_RANGES[0].allowed(), "[0.05, 1]");
        assert_eq!(PARAM_RANGES[2].allowed(), "[0.001, 1e6]");
    }

    fn flat_relief(relief_m: f32) -> RoughnessMap {
        let (cols, rows) = (72, 36);
        let values = vec![relief_m; (cols * rows) as usize];
        RoughnessMap::from_values(cols, rows, values, crate::geo::EARTH_RADIUS_M)
    }

    fn unit_at(lat_deg: f64, lon_deg: f64) -> DVec3 {
        let (phi, theta) = crate::geo::sphere::phi_theta_from_lat_lon_deg(lat_deg, lon_deg);
        crate::geo::sphere::unit_vector(phi, theta)
    }

    /// A dab raises the amplitude under it by its factor (where σ is not capped) and leaves
    /// a far cell alone; the unpainted map is kept for the next rebuild.
    #[test]
    fn painting_changes_the_amplitude_under_the_brush_only() {
        let params = DetailParams::default();
        let plain = Detail::new(params.clone(), 6.371e6, 1000.0, flat_relief(10_000.0));
        let dab = ReliefDab {
            lat_deg: 47.5,
            lon_deg: 12.5,
            radius_deg: 5.0,
            factor: 3.0,
        };
        let painted = plain.with_params(DetailParams {
            relief_paint: vec![dab],
            ..params.clone()
        });
        // At a cell centre under the dab's centre (cells of 5°: centres at 2.5 + 5k).
        let (here, far) = (unit_at(47.5, 12.5), unit_at(-42.5, -167.5));
        let relief_here = painted.roughness().relief_at_m(here);
        assert!(
            (relief_here - 30_000.0).abs() < 1e-2,
            "relief {relief_here}"
        );
        // σ = a_min + gain·relief·scale: the relief's share triples.
        let a_min = params.amplitude_min_m;
        let (before, after) = (plain.amplitude_m(here), painted.amplitude_m(here));
        assert!(before > a_min + 1.0, "σ {before}");
        assert!(
            ((after - a_min) / (before - a_min) - 3.0).abs() < 1e-5,
            "σ {before} → {after}"
        );
        assert_eq!(painted.amplitude_m(far), plain.amplitude_m(far));
        assert_eq!(painted.roughness().relief_at_m(far), 10_000.0);
        assert_eq!(painted.unpainted_roughness(), plain.roughness());
        // Lowering by the inverse factor brings the centre back.
        let undone = plain.with_params(DetailParams {
            relief_paint: vec![
                dab,
                ReliefDab {
                    factor: 1.0 / 3.0,
                    ..dab
                },
            ],
            ..params
        });
        let back = undone.roughness().relief_at_m(here);
        assert!((back - 10_000.0).abs() < 1e-2, "{back}");
    }

    /// A dab out of range is refused with its index and field.
    #[test]
    fn bad_dab_is_refused() {
        let p = DetailParams {
            relief_paint: vec![ReliefDab {
                lat_deg: 0.0,
                lon_deg: 0.0,
                radius_deg: 0.0,
                factor: 2.0,
            }],
            ..Default::default()
        };
        let e = p.validate("f.json").unwrap_err().to_string();
        assert!(
            e.contains("relief_paint[0]") && e.contains("radius_deg"),
            "{e}"
        );
    }
}
