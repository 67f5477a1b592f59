//! Proto-textures (infinite-landscapes-projected-grid.md §4.2): one small tileable texture per
//! surface type, made here procedurally, and their variance-reducing mipmaps.
//!
//! A periodically repeated texture shows its period from afar because of its colour variance;
//! the paper's fix is a custom mipmap whose variance falls faster than plain filtering gives:
//! each level is the 2×2 box of the one above, then moved toward the texture's mean by a
//! weight β ([`MipKind::VarianceReducing`]). Far terrain then neither shimmers nor repeats, and
//! it does not turn grey either: each surface type keeps its own mean colour, and the types
//! vary with height and slope (`material_weights`).
//!
//! The surface types' boundaries are perturbed by value noise over the world lattice
//! (`shaders/common/look.wgsl` `boundary_octave`), not by a tiled texture, so they never repeat.
//!
//! The textures are tileable value noise (a lattice hash taken modulo the period), built once
//! per process in a fraction of a second.

use std::sync::OnceLock;

use crate::procedural::noise::pcg3d;

/// Edge of every proto-texture, texels (a power of two: the mip chain ends at 1×1).
pub const TEXTURE_SIZE: u32 = 256;
/// Mip levels of a [`TEXTURE_SIZE`]² texture.
pub const MIP_LEVELS: u32 = TEXTURE_SIZE.ilog2() + 1;
/// How far each mip level moves toward the texture's mean (the paper's weighting parameter).
pub const VARIANCE_STEP: f32 = 0.25;

/// The surface types, in the albedo array's layer order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Material {
    Grass,
    Forest,
    Sand,
    Rock,
    Snow,
}

impl Material {
    pub const ALL: [Material; 5] = [
        Material::Grass,
        Material::Forest,
        Material::Sand,
        Material::Rock,
        Material::Snow,
    ];

    /// Mean albedo (linear RGB): the colour far terrain of this type takes.
    pub fn base_colour(self) -> [f32; 3] {
        match self {
            Material::Grass => [0.20, 0.36, 0.11],
            Material::Forest => [0.09, 0.20, 0.07],
            Material::Sand => [0.74, 0.66, 0.47],
            Material::Rock => [0.40, 0.37, 0.33],
            Material::Snow => [0.90, 0.92, 0.96],
        }
    }
}

/// How the mip chain is made.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum MipKind {
    /// 2×2 box, then toward the mean by [`VARIANCE_STEP`] per level (§4.2).
    #[default]
    VarianceReducing,
    /// 2×2 box only (the usual mipmap; for the stability comparison).
    Standard,
}

/// An RGBA8 texture and its mip chain, level 0 first.
#[derive(Clone, Debug)]
pub struct MipChain {
    pub levels: Vec<Vec<[u8; 4]>>,
}

/// Surface-type weights (the shader's `material_weights`, same operations in f32): height h
/// (m), slope s = 1 − n·up, sine of the latitude, perturbation q ∈ [−1, 1] and forest patches
/// p ∈ [0, 1] from the noise texture. Returns (forest over grass, sand, rock, snow), each
/// applied over the result so far in that order.
pub fn material_weights(h: f32, s: f32, sin_lat: f32, q: f32, patches: f32) -> [f32; 4] {
    let hp = h + 260.0 * q;
    let sp = s + 0.06 * q;
    let snow_line = 5400.0 - 5600.0 * sin_lat * sin_lat;
    let tree_line = snow_line - 1500.0;
    let forest = smoothstep(120.0, 500.0, hp)
        * (1.0 - smoothstep(tree_line - 250.0, tree_line + 250.0, hp))
        * smoothstep(0.42, 0.58, patches)
        * (1.0 - smoothstep(0.12, 0.2, sp));
    let sand = 1.0 - smoothstep(3.0, 18.0, h + 10.0 * q);
    let rock = smoothstep(0.16, 0.26, sp);
    let snow =
        smoothstep(snow_line - 150.0, snow_line + 150.0, hp) * (1.0 - smoothstep(0.32, 0.45, sp));
    [forest, sand, rock, snow]
}

/// The surface type that dominates at these weights (the last one applied at ≥ ½ wins).
pub fn dominant(weights: [f32; 4]) -> Material {
    let mut m = Material::Grass;
    for (w, layer) in weights.iter().zip([
        Material::Forest,
        Material::Sand,
        Material::Rock,
        Material::Snow,
    ]) {
        if *w >= 0.5 {
            m = layer;
        }
    }
    m
}

/// Each surface type as the imagery shows it from orbit (linear RGB; NASA's Blue Marble at 4′
/// averaged over 7 × 7 pixels: grass the Great Plains and European farmland, forest the Amazon,
/// Congo and taiga, sand the Sahara, rock the Tibetan plateau and the Atacama, snow Greenland).
/// Under imagery a pixel takes the types of the prototypes nearest its colour
/// ([`imagery_weights`]); the proto-textures then only add the texture inside an imagery pixel.
pub const IMAGERY_PROTOTYPES: [[f32; 3]; 5] = [
    [0.08, 0.085, 0.025],
    [0.014, 0.024, 0.005],
    [0.58, 0.39, 0.20],
    [0.28, 0.20, 0.11],
    [0.95, 0.96, 0.97],
];

/// How sharply the nearest prototype wins: weight 2^(−k·d²).
pub const IMAGERY_SHARPNESS: f32 = 8.0;

/// Where a colour (linear RGB) lies among the prototypes: (½·log₂ luminance, log₂ r/g,
/// log₂ b/g): brightness and hue apart, so a dark forest and a bright desert are far apart and
/// a shaded dune stays a dune.
pub fn imagery_features(c: [f32; 3]) -> [f32; 3] {
    let v = c.map(|x| x.max(1e-4));
    let l = 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2];
    [0.5 * l.log2(), (v[0] / v[1]).log2(), (v[2] / v[1]).log2()]
}

/// The surface types' weights (in [`Material::ALL`]'s order, not normalised) under imagery of
/// colour `c` (linear RGB), the luminance feature moved by the boundary noise q ∈ [−1, 1] (so
/// a type's edge is not a contour of the bilinear imagery). The shader's `imagery_weights`.
pub fn imagery_weights(c: [f32; 3], q: f32) -> [f32; 5] {
    let f = imagery_features(c);
    let f = [f[0] + 0.25 * q, f[1], f[2]];
    IMAGERY_PROTOTYPES.map(|p| {
        let g = imagery_features(p);
        let d2: f32 = (0..3).map(|i| (f[i] - g[i]).powi(2)).sum();
        (-IMAGERY_SHARPNESS * d2).exp2()
    })
}

/// The type of largest weight under imagery of colour `c`.
pub fn imagery_type(c: [f32; 3]) -> Material {
    let w = imagery_weights(c, 0.0);
    let k = (0..5).fold(0, |b, k| if w[k] > w[b] { k } else { b });
    Material::ALL[k]
}

/// WGSL's smoothstep.
pub fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Tileable value noise in [−1, 1): `px` × `py` lattice cells across the texture.
fn tile_noise(x: f32, y: f32, px: u32, py: u32, seed: u32) -> f32 {
    let fx = x * px as f32;
    let fy = y * py as f32;
    let (x0, y0) = (fx.floor(), fy.floor());
    let (tx, ty) = (fx - x0, fy - y0);
    let fade = |t: f32| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
    let lattice = |i: i64, j: i64| {
        let i = i.rem_euclid(px as i64) as u32;
        let j = j.rem_euclid(py as i64) as u32;
        (pcg3d(i ^ seed, j, seed.wrapping_mul(7919))[0] >> 8) as f32 / 8_388_608.0 - 1.0
    };
    let (i, j) = (x0 as i64, y0 as i64);
    let (wx, wy) = (fade(tx), fade(ty));
    let a = lattice(i, j) + (lattice(i + 1, j) - lattice(i, j)) * wx;
    let b = lattice(i, j + 1) + (lattice(i + 1, j + 1) - lattice(i, j + 1)) * wx;
    a + (b - a) * wy
}

/// Tileable fractal sum of `octaves` octaves from `px` × `py` cells, gain ½, roughly in
/// [−1, 1].
fn tile_fbm2(x: f32, y: f32, px: u32, py: u32, octaves: u32, seed: u32) -> f32 {
    let (mut sum, mut amp, mut norm) = (0.0, 1.0, 0.0);
    for k in 0..octaves {
        sum += amp * tile_noise(x, y, px << k, py << k, seed.wrapping_add(k * 101));
        norm += amp;
        amp *= 0.5;
    }
    sum / norm * 1.6
}

/// [`tile_fbm2`] with square cells.
fn tile_fbm(x: f32, y: f32, period: u32, octaves: u32, seed: u32) -> f32 {
    tile_fbm2(x, y, period, period, octaves, seed)
}

fn to_u8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

/// Level 0 of a surface type's texture (linear RGB in RGBA8, alpha 255).
pub fn material_texture(m: Material) -> Vec<[u8; 4]> {
    let n = TEXTURE_SIZE;
    let base = m.base_colour();
    let seed = 17 + m as u32 * 1000;
    let mut out = Vec::with_capacity((n * n) as usize);
    for j in 0..n {
        for i in 0..n {
            let (x, y) = ((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            let coarse = tile_fbm(x, y, 4, 5, seed);
            let fine = tile_fbm(x, y, 32, 3, seed + 7);
            // (brightness factor, yellow/grey tint) per type.
            let (k, tint) = match m {
                Material::Grass => (1.0 + 0.25 * coarse + 0.12 * fine, 0.5 + 0.5 * coarse),
                Material::Forest => {
                    let canopy = tile_fbm(x, y, 24, 3, seed + 3);
                    (
                        0.55 + 0.9 * smoothstep(-0.3, 0.5, canopy) + 0.1 * coarse,
                        0.3,
                    )
                }
                Material::Sand => {
                    let ripple = tile_fbm2(x, y, 4, 16, 2, seed + 5);
                    (1.0 + 0.08 * coarse + 0.06 * fine + 0.05 * ripple, 0.5)
                }
                Material::Rock => {
                    // Strata: noise stretched across, cracks where a fine noise crosses zero.
                    let strata = tile_fbm2(x, y, 4, 32, 2, seed + 9);
                    let crack = 1.0 - 0.35 * (1.0 - (fine * 6.0).abs().min(1.0));
                    (
                        (1.0 + 0.2 * coarse + 0.15 * strata) * crack,
                        0.5 + 0.3 * strata,
                    )
                }
                Material::Snow => (1.0 + 0.04 * coarse + 0.03 * fine, 0.5),
            };
            let tint = tint.clamp(0.0, 1.0);
            let c = [
                base[0] * k * (0.92 + 0.16 * tint),
                base[1] * k,
                base[2] * k * (1.08 - 0.16 * tint),
            ];
            out.push([to_u8(c[0]), to_u8(c[1]), to_u8(c[2]), 255]);
        }
    }
    out
}

/// Level 0 of the wave texture: r and g are the slopes of small waves along the texture's two
/// axes, as ½ + ½·slope (their average, far away, is flat water); b, a unused.
pub fn wave_texture() -> Vec<[u8; 4]> {
    let n = TEXTURE_SIZE;
    let wave = |x: f32, y: f32| tile_fbm(x, y, 8, 4, 4242);
    let step = 1.0 / n as f32;
    let mut out = Vec::with_capacity((n * n) as usize);
    for j in 0..n {
        for i in 0..n {
            let (x, y) = ((i as f32 + 0.5) * step, (j as f32 + 0.5) * step);
            // Slopes per texture width, scaled so that steep ripples reach ±1.
            let sx = (wave(x + step, y) - wave(x - step, y)) / (2.0 * step) / 40.0;
            let sy = (wave(x, y + step) - wave(x, y - step)) / (2.0 * step) / 40.0;
            out.push([to_u8(0.5 + 0.5 * sx), to_u8(0.5 + 0.5 * sy), 128, 255]);
        }
    }
    out
}

/// The mip chain of a square RGBA8 image of edge [`TEXTURE_SIZE`].
pub fn mip_chain(level0: Vec<[u8; 4]>, kind: MipKind) -> MipChain {
    let texels = level0.len() as f32;
    let mut mean = [0f32; 4];
    for t in &level0 {
        for c in 0..4 {
            mean[c] += t[c] as f32 / texels;
        }
    }
    let beta = match kind {
        MipKind::VarianceReducing => VARIANCE_STEP,
        MipKind::Standard => 0.0,
    };
    let mut levels = vec![level0];
    let mut size = TEXTURE_SIZE;
    // The chain in f32 (no rounding builds up), each level rounded to bytes on the way out.
    let mut current: Vec<[f32; 4]> = levels[0].iter().map(|t| t.map(|v| v as f32)).collect();
    while size > 1 {
        let half = size / 2;
        let mut next = vec![[0f32; 4]; (half * half) as usize];
        for j in 0..half {
            for i in 0..half {
                let at = |x: u32, y: u32| current[(y * size + x) as usize];
                let quad = [
                    at(2 * i, 2 * j),
                    at(2 * i + 1, 2 * j),
                    at(2 * i, 2 * j + 1),
                    at(2 * i + 1, 2 * j + 1),
                ];
                let out = &mut next[(j * half + i) as usize];
                for c in 0..4 {
                    let boxed = quad.iter().map(|q| q[c]).sum::<f32>() / 4.0;
                    out[c] = boxed + (mean[c] - boxed) * beta;
                }
            }
        }
        levels.push(
            next.iter()
                .map(|t| t.map(|v| (v + 0.5).clamp(0.0, 255.0) as u8))
                .collect(),
        );
        current = next;
        size = half;
    }
    MipChain { levels }
}

/// The proto-textures of every surface type and the wave texture, each with its mips.
#[derive(Clone, Debug)]
pub struct ProtoTextures {
    /// One chain per [`Material::ALL`] entry.
    pub albedo: Vec<MipChain>,
    pub waves: MipChain,
}

/// The textures for `kind` of mipmap (built once per process per kind).
pub fn textures(kind: MipKind) -> &'static ProtoTextures {
    static VARIANCE: OnceLock<ProtoTextures> = OnceLock::new();
    static STANDARD: OnceLock<ProtoTextures> = OnceLock::new();
    let cell = match kind {
        MipKind::VarianceReducing => &VARIANCE,
        MipKind::Standard => &STANDARD,
    };
    cell.get_or_init(|| ProtoTextures {
        albedo: Material::ALL
            .iter()
            .map(|&m| mip_chain(material_texture(m), kind))
            .collect(),
        // The waves' mips are always plain: far away they must average to flat water.
        waves: mip_chain(wave_texture(), MipKind::Standard),
    })
}

/// Variance of one channel of a mip level (tests, the stability measurement).
pub fn channel_variance(level: &[[u8; 4]], channel: usize) -> f64 {
    let n = level.len() as f64;
    let mean = level.iter().map(|t| t[channel] as f64).sum::<f64>() / n;
    level
        .iter()
        .map(|t| (t[channel] as f64 - mean).powi(2))
        .sum::<f64>()
        / n
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Colours the Blue Marble shows (7 × 7-pixel means, linear RGB, measured off
    /// `assets/imagery-bmng-4min.jpg` at places not used for the prototypes) make the type a
    /// person expects there.
    #[test]
    fn imagery_colours_make_the_types_one_expects() {
        let cases = [
            (
                "Sahara at 27° N 27° E",
                [0.594, 0.413, 0.201],
                Material::Sand,
            ),
            (
                "Arabia at 22° N 48° E",
                [0.543, 0.342, 0.177],
                Material::Sand,
            ),
            (
                "the Congo at 0° 20° E",
                [0.010, 0.020, 0.004],
                Material::Forest,
            ),
            (
                "the taiga at 60° N 100° E",
                [0.013, 0.022, 0.004],
                Material::Forest,
            ),
            (
                "Antarctica at 80° S 0°",
                [0.943, 0.968, 0.978],
                Material::Snow,
            ),
            (
                "the Atacama at 24° S 69° W",
                [0.274, 0.177, 0.100],
                Material::Rock,
            ),
        ];
        for (place, c, expected) in cases {
            assert_eq!(
                imagery_type(c),
                expected,
                "{place}: {:?}",
                imagery_weights(c, 0.0)
            );
        }
    }

    #[test]
    fn surface_types_follow_height_slope_and_latitude() {
        // Flat lowland at the equator: grass (no patch) or forest (in a patch).
        assert_eq!(
            dominant(material_weights(300.0, 0.0, 0.0, 0.0, 0.0)),
            Material::Grass
        );
        assert_eq!(
            dominant(material_weights(800.0, 0.0, 0.0, 0.0, 1.0)),
            Material::Forest
        );
        // A beach, a cliff, a high peak, the polar lowland.
        assert_eq!(
            dominant(material_weights(2.0, 0.0, 0.0, 0.0, 1.0)),
            Material::Sand
        );
        assert_eq!(
            dominant(material_weights(800.0, 0.3, 0.0, 0.0, 1.0)),
            Material::Rock
        );
        assert_eq!(
            dominant(material_weights(6000.0, 0.05, 0.0, 0.0, 0.0)),
            Material::Snow
        );
        assert_eq!(
            dominant(material_weights(50.0, 0.0, 0.98, 0.0, 0.0)),
            Material::Snow
        );
        // A very steep face above the snow line sheds its snow.
        assert_eq!(
            dominant(material_weights(6000.0, 0.6, 0.0, 0.0, 0.0)),
            Material::Rock
        );
    }

    #[test]
    fn the_perturbation_moves_the_boundaries() {
        // Just below the snow line: snow where q is high, not where it is low.
        let h = 5400.0 - 100.0;
        assert_eq!(
            dominant(material_weights(h, 0.0, 0.0, 1.0, 0.0)),
            Material::Snow
        );
        assert_ne!(
            dominant(material_weights(h, 0.0, 0.0, -1.0, 0.0)),
            Material::Snow
        );
    }

    #[test]
    fn textures_tile() {
        // The last column continues into the first: neighbours across the seam differ no
        // more than neighbours inside.
        let t = material_texture(Material::Rock);
        let n = TEXTURE_SIZE as usize;
        let diff = |a: [u8; 4], b: [u8; 4]| (a[1] as i32 - b[1] as i32).abs();
        let across: i32 = (0..n).map(|j| diff(t[j * n + n - 1], t[j * n])).sum();
        let inside: i32 = (0..n)
            .map(|j| diff(t[j * n + n / 2 - 1], t[j * n + n / 2]))
            .sum();
        assert!(
            across < 3 * inside.max(1),
            "across {across}, inside {inside}"
        );
    }

    #[test]
    fn variance_falls_faster_with_the_reducing_mipmap_and_the_mean_stays() {
        let base = material_texture(Material::Grass);
        let plain = mip_chain(base.clone(), MipKind::Standard);
        let reduced = mip_chain(base, MipKind::VarianceReducing);
        assert_eq!(plain.levels.len(), MIP_LEVELS as usize);
        for level in 1..6 {
            let vp = channel_variance(&plain.levels[level], 1);
            let vr = channel_variance(&reduced.levels[level], 1);
            assert!(vr < vp, "level {level}: {vr} vs {vp}");
        }
        let mean = |l: &[[u8; 4]]| l.iter().map(|t| t[1] as f64).sum::<f64>() / l.len() as f64;
        let top = mean(&plain.levels[0]);
        for level in [4, 8] {
            assert!(
                (mean(&reduced.levels[level]) - top).abs() < 1.5,
                "level {level}"
            );
        }
    }
}
