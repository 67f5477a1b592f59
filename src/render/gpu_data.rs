//! The f64 → f32 boundary and the Rust ↔ WGSL contract.
//!
//! Every struct the GPU reads is declared here (or, for the f32 twins the tests share, named
//! here), with its byte layout described by [`GpuStruct`]; `tests/cpu/shader_contract.rs` checks
//! each description against naga's reflection of the assembled shader modules (size, member
//! offsets, member types), with no GPU. The conversions from a frame plan (f64 metres and
//! radians) into these structs are the only place where a frame's metres and radians become f32
//! (the static ring mesh rounds its p̃ once, at build time, in `clipmap::mesh`).

use bytemuck::{Pod, Zeroable};
use glam::DVec3;

use crate::clipmap::density::DensityPlan;
use crate::clipmap::levels::{GridRect, LevelGrid};
use crate::clipmap::{ClipmapSettings, RingVertex};
use crate::geo::map_transform::{Stretch, TransformUniformsF32};
use crate::look::{Atmosphere, BOUNDARY_CELLS_M, BOUNDARY_SEEDS, LookSettings};
use crate::plan::{ClipmapPlan, GeomipPlan, ViewPlan};
use crate::planar::geomip::Patch;
use crate::procedural::{Detail, LevelOctaves, MAX_OCTAVES, OctaveAnchorF32};
use crate::terrain::analytic::{AnalyticPlanet, SCALES, WaveAt};

use super::imagery::ImageryGeometry;
use super::shader::{self, MAX_LEVELS};

// ---------------------------------------------------------------------------------------------
// Layout descriptions

/// One member of a GPU struct as Rust lays it out.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FieldLayout {
    pub name: &'static str,
    pub offset: usize,
    pub size: usize,
    /// The WGSL type this Rust type stands for (`vec4<f32>`, `mat4x4<f32>`, `array<Wave, 10>`).
    pub wgsl_type: String,
}

/// A GPU struct as Rust lays it out: what `tests/cpu/shader_contract.rs` compares with naga.
/// Padding members (names starting with `_`) are not listed: only the size covers them.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StructLayout {
    pub wgsl_name: &'static str,
    pub size: usize,
    pub fields: Vec<FieldLayout>,
}

/// A Rust type that stands for a WGSL type.
pub trait WgslType {
    fn wgsl_type() -> String;
}

/// A `#[repr(C)]` struct with a WGSL twin of the name `WGSL_NAME`.
pub trait GpuStruct: Pod {
    const WGSL_NAME: &'static str;
    fn layout() -> StructLayout;
}

macro_rules! wgsl_types {
    ($($ty:ty => $wgsl:literal),* $(,)?) => {
        $(impl WgslType for $ty {
            fn wgsl_type() -> String {
                $wgsl.to_string()
            }
        })*
    };
}

wgsl_types! {
    f32 => "f32",
    u32 => "u32",
    i32 => "i32",
    [f32; 2] => "vec2<f32>",
    [f32; 3] => "vec3<f32>",
    [f32; 4] => "vec4<f32>",
    [u32; 2] => "vec2<u32>",
    [i32; 2] => "vec2<i32>",
    [i32; 4] => "vec4<i32>",
    [u32; 4] => "vec4<u32>",
    [[f32; 4]; 4] => "mat4x4<f32>",
}

/// The surface types' tables (`LookUniforms::type_means`, `type_features`).
impl WgslType for [[f32; 4]; 5] {
    fn wgsl_type() -> String {
        "array<vec4<f32>, 5>".to_string()
    }
}

/// The detail's amplitude table.
impl WgslType for [[f32; 4]; DETAIL_AMPLITUDE_VECS] {
    fn wgsl_type() -> String {
        format!("array<vec4<f32>, {DETAIL_AMPLITUDE_VECS}>")
    }
}

/// A fixed-size array of GPU structs.
impl<T: GpuStruct, const N: usize> WgslType for [T; N] {
    fn wgsl_type() -> String {
        format!("array<{}, {N}>", T::WGSL_NAME)
    }
}

/// The WGSL type of a field, from its Rust type.
pub fn wgsl_type_of<T: WgslType>(_: &T) -> String {
    T::wgsl_type()
}

/// Declares that `$ty` is the twin of the WGSL struct `$wgsl` with the listed (non-padding)
/// members, in any order: the contract test finds each by name.
#[macro_export]
macro_rules! gpu_struct {
    ($ty:ty as $wgsl:literal { $($field:ident),* $(,)? }) => {
        impl $crate::render::gpu_data::GpuStruct for $ty {
            const WGSL_NAME: &'static str = $wgsl;
            fn layout() -> $crate::render::gpu_data::StructLayout {
                let value = <$ty as ::bytemuck::Zeroable>::zeroed();
                $crate::render::gpu_data::StructLayout {
                    wgsl_name: $wgsl,
                    size: ::std::mem::size_of::<$ty>(),
                    fields: vec![$($crate::render::gpu_data::FieldLayout {
                        name: stringify!($field),
                        offset: ::std::mem::offset_of!($ty, $field),
                        size: ::std::mem::size_of_val(&value.$field),
                        wgsl_type: $crate::render::gpu_data::wgsl_type_of(&value.$field),
                    }),*],
                }
            }
        }
        impl $crate::render::gpu_data::WgslType for $ty {
            fn wgsl_type() -> String {
                $wgsl.to_string()
            }
        }
    };
}

// ---------------------------------------------------------------------------------------------
// The structs

/// `FrameUniforms` in `shaders/terrain.wgsl`: one per frame.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct FrameUniforms {
    pub clip_from_view: [[f32; 4]; 4],
    pub transform: TransformUniformsF32,
    pub sun_view: [f32; 4],
    pub radius_m: f32,
    pub eye_height_m: f32,
    pub blend_fraction: f32,
    pub texture_size: u32,
    pub transform_form: u32,
    pub approx_start_level: u32,
    pub coarsest_level: u32,
    pub finest_level: u32,
    pub overlay: u32,
    /// The eye's altitude minus `eye_height_m` (f64 − f32): a 1 mm climb at 9 km is below
    /// one f32 step of the altitude, so the shader adds this low part after the difference.
    pub eye_height_lo_m: f32,
    /// The ring mesh's n and m (the vertex shader finds a vertex's neighbours by index).
    pub mesh_steps: u32,
    pub mesh_rings: u32,
    /// λ(θ̃) = clamp(x − ln θ̃ · y, 0, z): the detail octaves geometry holds at view angle θ̃
    /// (procedural module docs); all 0 without detail.
    pub detail_lambda: [f32; 4],
}

/// `LookUniforms` in `shaders/common/look.wgsl`: the atmosphere, the proto-textures' and the
/// water's anchors (one per frame; docs/look.md#the-look).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct LookUniforms {
    pub view_from_clip: [[f32; 4]; 4],
    pub world0: [f32; 4],
    pub world1: [f32; 4],
    pub world2: [f32; 4],
    /// frac(E/L) of the eye's ECEF position for each texture tile L (xyz), and 1/L (w).
    pub tex_anchor: [f32; 4],
    pub boundary_cell0: [i32; 4],
    pub boundary_frac0: [f32; 4],
    pub boundary_cell1: [i32; 4],
    pub boundary_frac1: [f32; 4],
    pub wave_anchor0: [f32; 4],
    pub wave_anchor1: [f32; 4],
    /// β_R (rgb), 1/H_R.
    pub rayleigh: [f32; 4],
    /// β_M (rgb), 1/H_M.
    pub mie: [f32; 4],
    /// R, top radius, Mie extinction/scattering, Mie g.
    pub shell: [f32; 4],
    /// Sun radiance scale, tone-map exposure, direct light, ambient light.
    pub light: [f32; 4],
    pub sky_zenith: [f32; 4],
    pub sky_horizon: [f32; 4],
    pub sun: [f32; 4],
    pub eye_radius_m: f32,
    pub water_level_m: f32,
    /// Cosine of the sun disk's angular radius.
    pub sun_cos: f32,
    pub time_s: f32,
    /// View → clip (the sky ring's vertices).
    pub clip_from_view: [[f32; 4]; 4],
    /// Frame width and height in pixels, 2/width, 2/height (a fragment's NDC from its pixel).
    pub viewport: [f32; 4],
    /// The sky ring (`look::SkyRing`): tan of its inner and outer vertices' angle from −z̃,
    /// the distance its vertices are placed at (beyond all terrain: their depth stays behind
    /// it), 0.
    pub sky_ring: [f32; 4],
    /// The aerial-perspective volume's slices (`render::aerial::slice_range`): the first
    /// slice's distance d0 (m), 1/ln(d1/d0), ln(d1/d0), 0.
    pub aerial: [f32; 4],
    /// Each surface type's proto-texture mean (linear RGB, as sampled at its coarsest mip):
    /// under imagery a texel's colour is the imagery's times the texture over this.
    pub type_means: [[f32; 4]; 5],
    /// Each type's imagery prototype's features (`look::proto::imagery_features`).
    pub type_features: [[f32; 4]; 5],
}

/// `LevelUniforms` in `shaders/terrain.wgsl`: one per level, `MAX_LEVELS` of them.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct LevelUniforms {
    pub grid_x_viewer: f32,
    pub grid_y_viewer: f32,
    pub inv_dphi: f32,
    pub inv_dtheta: f32,
    pub dtheta_rad: f32,
    /// Index of the first partial octave (the whole ones are in the heights).
    pub detail_full: u32,
    /// One past the last octave the level's textures hold (its normals include them all).
    pub detail_end: u32,
    /// Ring density k of the level's body, its outer and its inner ring (`clipmap::density`).
    pub density: u32,
    pub outer_density: u32,
    pub inner_density: u32,
    /// How far the vertices the next density drops have moved (0..1), for each of the three.
    pub morph: f32,
    pub outer_morph: f32,
    pub inner_morph: f32,
    /// The level's reference height minus the eye's altitude (f64, then f32): a texel's
    /// height relative to the eye is its stored h − ref plus this (`LevelGrid::ref_m`).
    pub ref_eye_m: f32,
    pub _pad: [u32; 2],
}

/// One scale as the fill shader gets it. `Wave` in `shaders/fill_analytic.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct WaveParams {
    /// ω·a (xyz) and the band-limited amplitude in metres (w).
    pub omega_a: [f32; 4],
    /// ω·b (xyz), w unused.
    pub omega_b: [f32; 4],
    /// sin, cos of the phase of wave a at the reference point, then of wave b.
    pub phases: [f32; 4],
}

/// `FillParams` in `shaders/fill_analytic.wgsl`: one per dispatch of the analytic fill.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct FillParams {
    pub ref_trig: [f32; 4],
    pub spacing: [f32; 4],
    pub slot0: [u32; 2],
    pub extent: [u32; 2],
    pub layer: u32,
    pub size: u32,
    /// The first texel, in grid steps from the reference point (the anchor).
    pub offset: [u32; 2],
    /// The level's reference height (`LevelGrid::ref_m`, exact in f32), subtracted.
    pub ref_m: f32,
    pub _pad: [u32; 3],
    pub waves: [WaveParams; SCALES],
}

/// `DemFillParams` in `shaders/fill_dem.wgsl`: one per dispatch of the DEM fill.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct DemFillParams {
    pub base: [i32; 2],
    pub frac: [f32; 2],
    pub step: [f32; 2],
    pub slot0: [u32; 2],
    pub extent: [u32; 2],
    pub layer: u32,
    pub size: u32,
    pub page_base: u32,
    pub tiles_x: u32,
    pub cols: i32,
    pub rows: i32,
    pub tile_size: i32,
    pub wraps: u32,
    pub cap_north: [f32; 2],
    pub cap_south: [f32; 2],
    /// metres − the level's reference height = decode[0] + decode[1] · (code − code_ref).
    pub decode: [f32; 2],
    /// The first texel, in grid steps from the point `base`/`frac` give (the anchor).
    pub offset: [u32; 2],
    /// Sea level (outside a regional grid) less the level's reference height.
    pub sea_m: f32,
    /// The code nearest the reference height: subtracted as an integer, so that neither
    /// term of `decode` is large where the ground is (f32 steps of 0.5 mm at 6 km depth).
    pub code_ref: i32,
    /// The anchor's fraction below `frac`'s f32: the shader adds it to the texel's small
    /// offset, never to `frac` (shaders/fill_dem.wgsl).
    pub frac_lo: [f32; 2],
    /// The data's height at the anchor less the reference (`DemFillJob::anchor_height_m`),
    /// and whether it is given (1): the texels then add their change from the anchor.
    pub anchor_m: f32,
    pub relative: u32,
}

/// `WaterCullParams` in `shaders/water_cull.wgsl`: one per frame.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct WaterCullParams {
    /// A level is dry when its lowest texel is at least this (`render::water_cull::dry_from_m`).
    pub dry_from_m: f32,
    pub block: u32,
    pub blocks_per_row: u32,
    pub job_count: u32,
    pub draw_count: u32,
    pub _pad: [u32; 3],
}

/// `NormalParams` in `shaders/fill_normals.wgsl`: one per dispatch of the normal pass.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct NormalParams {
    pub slot0: [u32; 2],
    pub extent: [u32; 2],
    pub layer: u32,
    pub size: u32,
    pub partial_count: u32,
    pub quarter: u32,
    /// φ0, θ0 (radians, f32: they only orient the frame), dφ, dθ.
    pub angles: [f32; 4],
    /// sin θ0, cos θ0, sin φ0, cos φ0, from f64.
    pub trig: [f32; 4],
    pub radius_m: f32,
    /// Job rows of θ = 0 and θ = π, −1 where the job has none.
    pub pole_north: i32,
    pub pole_south: i32,
    /// The first texel, in grid steps from the anchor (`angles`, `trig`).
    pub offset_x: u32,
    pub offset_y: u32,
    /// The level's reference height: the texture holds h − ref (`LevelGrid::ref_m`).
    pub ref_m: f32,
    pub _pad: [u32; 2],
    /// The boundary noise's two lattices around the anchor's point at the reference height
    /// (cell and seed, remainder and 1/cell: `LookUniforms::boundary_*`'s form).
    pub boundary_cell0: [i32; 4],
    pub boundary_frac0: [f32; 4],
    pub boundary_cell1: [i32; 4],
    pub boundary_frac1: [f32; 4],
    /// The imagery's pixel coordinates of the anchor (x unfolded, modulo the period; y
    /// unfolded) and its pixels per grid step (`render::imagery::ImageryGeometry`).
    pub imagery_xy: [f32; 4],
    /// The image's width and height (pixels), its mip level for this level's texel, and 1
    /// when there is imagery (0: the pass writes none).
    pub imagery_size: [f32; 4],
    /// Pixel rows of 90° N and 90° S, the period in columns (360°), unused.
    pub imagery_fold: [f32; 4],
}

impl NormalParams {
    /// The same dispatch sampling `imagery` (its anchor `anchor` of `grid`).
    pub fn with_imagery(
        self,
        imagery: Option<&ImageryGeometry>,
        grid: &LevelGrid,
        anchor: [i64; 2],
    ) -> Self {
        let Some(g) = imagery else {
            return self;
        };
        let (dx, dy) = g.steps(grid.dphi_rad, grid.dtheta_rad);
        let period = 360.0 / g.dlon_deg;
        let x0 = (anchor[0] as f64 * dx - g.west_deg / g.dlon_deg).rem_euclid(period);
        let y0 = anchor[1] as f64 * dy + (g.north_deg - 90.0) / g.dlat_deg;
        let (north, south) = g.pole_rows();
        Self {
            imagery_xy: [x0 as f32, y0 as f32, dx as f32, dy as f32],
            imagery_size: [
                g.width as f32,
                g.height as f32,
                ImageryGeometry::lod(dx, dy) as f32,
                1.0,
            ],
            imagery_fold: [north as f32, south as f32, period as f32, 0.0],
            ..self
        }
    }

    /// The normals of `rect` of `grid` (rows past a pole unfolded), whose level holds
    /// `partial_count` partial octaves; `rect` lies in one anchor block, whose corner
    /// `anchor` the angles are taken from (the same f32 sums whichever dispatch it is).
    pub fn new(
        grid: &LevelGrid,
        rect: &GridRect,
        anchor: [i64; 2],
        radius_m: f64,
        partial_count: u32,
    ) -> Self {
        let phi0 = anchor[0] as f64 * grid.dphi_rad;
        let theta0 = anchor[1] as f64 * grid.dtheta_rad;
        let (st, ct) = theta0.sin_cos();
        let (sp, cp) = phi0.sin_cos();
        // The anchor's point at the reference height, in the world frame (ECEF), f64.
        let anchor_world = DVec3::new(st * cp, st * sp, ct) * (radius_m + grid.ref_m);
        let boundary = BOUNDARY_CELLS_M
            .iter()
            .zip(BOUNDARY_SEEDS)
            .map(|(&cell_m, seed)| world_lattice(anchor_world, cell_m, seed))
            .collect::<Vec<_>>();
        let s = grid.size as i64;
        // θ = π is grid row S·2^level/4 (dθ = 4·2^−level·π/S).
        let south = (s << grid.level) / 4;
        let row = |gy: i64| {
            let j = gy - rect.gy0;
            if (0..rect.height as i64).contains(&j) {
                j as i32
            } else {
                -1
            }
        };
        Self {
            slot0: [rect.gx0.rem_euclid(s) as u32, rect.gy0.rem_euclid(s) as u32],
            extent: [rect.width, rect.height],
            layer: grid.level,
            size: grid.size,
            partial_count,
            quarter: grid.size / 4,
            angles: [
                phi0 as f32,
                theta0 as f32,
                grid.dphi_rad as f32,
                grid.dtheta_rad as f32,
            ],
            trig: [st as f32, ct as f32, sp as f32, cp as f32],
            radius_m: radius_m as f32,
            pole_north: row(0),
            pole_south: row(south),
            offset_x: (rect.gx0 - anchor[0]) as u32,
            offset_y: (rect.gy0 - anchor[1]) as u32,
            ref_m: grid.ref_m as f32,
            _pad: [0; 2],
            boundary_cell0: boundary[0].0,
            boundary_frac0: boundary[0].1,
            boundary_cell1: boundary[1].0,
            boundary_frac1: boundary[1].1,
            imagery_xy: [0.0; 4],
            imagery_size: [0.0; 4],
            imagery_fold: [0.0; 4],
        }
    }
}

/// `DetailOctave` in `shaders/common/detail_fill.wgsl`: one octave's lattice around a job's
/// first grid point.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct DetailOctaveParams {
    /// Rows of M = Q·R/L (xyz) and the anchor's remainder (w).
    pub m0: [f32; 4],
    pub m1: [f32; 4],
    pub m2: [f32; 4],
    /// Anchor cell (xyz) and the hash seed's bit pattern (w).
    pub cell: [i32; 4],
}

/// `DeltaOctave` in `shaders/common/detail_fill.wgsl`: a relative octave's values at the
/// block's reference point ([`crate::procedural::delta`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct DeltaOctaveParams {
    /// The reference's remainder below f32 (xyz), S(ref) − S(cell + f_hi) (w).
    pub lo: [f32; 4],
    /// 1 + g_h·clamp(Ĥ), Ĥ − clamp(Ĥ), −1 − clamp(Ĥ), 1 − clamp(Ĥ).
    pub chain: [f32; 4],
    /// The warp's vector (xy) and its length (z), S (w) at the reference.
    pub warp_ref: [f32; 4],
}

/// Vectors of four amplitudes a_k in [`DetailFillParams`].
pub const DETAIL_AMPLITUDE_VECS: usize = MAX_OCTAVES / 4;

/// `DetailFillParams` in `shaders/common/detail_fill.wgsl`: the detail of one fill dispatch
/// (either fill; bound at group 1 with the same dynamic index as the fill's own block).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct DetailFillParams {
    pub ref_trig: [f32; 4],
    pub ref_angles: [f32; 4],
    pub warp: [f32; 4],
    pub warp2: [f32; 4],
    pub sigma: [f32; 4],
    pub counts: [u32; 4],
    /// Relative octaves, relief mode, relief cell (bit patterns).
    pub delta: [u32; 4],
    /// Ĥ and the warp's vector after the relative octaves, their sum F_r.
    pub delta_end: [f32; 4],
    /// σ_raw − σ_r, −σ_r, cap − σ_r, gain at the reference.
    pub delta_sigma: [f32; 4],
    /// The reference's relief remainder: f32 part (xy), below it (zw).
    pub relief_ref: [f32; 4],
    /// Relief cells per radian of φ and θ, R(ref) − R(cell + f_hi), σ_r.
    pub relief_ref2: [f32; 4],
    pub amplitudes: [[f32; 4]; DETAIL_AMPLITUDE_VECS],
    pub octaves: [DetailOctaveParams; MAX_OCTAVES],
    pub deltas: [DeltaOctaveParams; MAX_OCTAVES],
}

impl DetailFillParams {
    /// The detail of the grid points of `grid` from (gx, gy) on (unfolded: rows past a pole
    /// keep going, as the fills' rows do). No detail: every count 0.
    pub fn new(detail: Option<&Detail>, grid: &LevelGrid, gx: i64, gy: i64, blend: f64) -> Self {
        Self::with_offset(detail, grid, gx, gy, blend).0
    }

    /// As [`DetailFillParams::new`], with the detail at the block's reference point that the
    /// texels leave out (metres, f64: σ_r·F_r of the relative octaves, `procedural::delta`):
    /// the fill takes it off its reference height.
    pub fn with_offset(
        detail: Option<&Detail>,
        grid: &LevelGrid,
        gx: i64,
        gy: i64,
        blend: f64,
    ) -> (Self, f64) {
        let mut p: Self = Zeroable::zeroed();
        let Some(detail) = detail else {
            return (p, 0.0);
        };
        let octaves = detail.level_octaves(grid.level, blend);
        let count = (octaves.full + octaves.partial) as usize;
        let phi = gx as f64 * grid.dphi_rad;
        let theta = gy as f64 * grid.dtheta_rad;
        p.ref_trig = [
            theta.sin() as f32,
            theta.cos() as f32,
            phi.sin() as f32,
            phi.cos() as f32,
        ];
        p.ref_angles = [
            phi.rem_euclid(std::f64::consts::TAU) as f32,
            theta as f32,
            grid.dphi_rad as f32,
            grid.dtheta_rad as f32,
        ];
        let c = detail.constants_f32();
        p.warp = [c.lever, c.t[0], c.t[1], c.height_roughness];
        p.warp2 = [c.c1r0[0], c.c1r0[1], c.c2[0], c.c2[1]];
        p.sigma = sigma_params(detail, 0.0);
        let map = detail.roughness();
        p.counts = [octaves.full, octaves.partial, map.cols, map.rows];
        p.amplitudes = amplitude_table(detail);
        let block = delta_block_at(detail, grid, gx, gy, octaves);
        debug_assert_eq!(block.anchors.len(), count);
        for (o, a) in p.octaves.iter_mut().zip(&block.anchors) {
            *o = DetailOctaveParams::from(a);
        }
        for (o, d) in p.deltas.iter_mut().zip(&block.octaves) {
            *o = DeltaOctaveParams {
                lo: [d.f_lo[0], d.f_lo[1], d.f_lo[2], d.corr],
                chain: [d.m_r, d.e_h, d.lo_h, d.hi_h],
                warp_ref: [d.v_r[0], d.v_r[1], d.len_r, d.s_r],
            };
        }
        let r = &block.relief;
        p.delta = [
            block.count as u32,
            r.mode,
            r.cell[0] as u32,
            r.cell[1] as u32,
        ];
        p.delta_end = [block.h_end, block.v_end[0], block.v_end[1], block.f_r];
        p.delta_sigma = block.sigma;
        p.relief_ref = [r.f_hi[0], r.f_hi[1], r.f_lo[0], r.f_lo[1]];
        p.relief_ref2 = [r.scale[0], r.scale[1], r.corr, block.sigma_r];
        (p, block.offset_m)
    }
}

/// The relative form (`procedural::delta`) of the fill block of `grid` whose corner is grid
/// point (gx, gy): its texels lie within one anchor block from there.
pub fn delta_block_at(
    detail: &Detail,
    grid: &LevelGrid,
    gx: i64,
    gy: i64,
    octaves: LevelOctaves,
) -> crate::procedural::DeltaBlock {
    let steps = grid.anchor_block() as f64;
    detail.delta_block(
        gx as f64 * grid.dphi_rad,
        gy as f64 * grid.dtheta_rad,
        [steps * grid.dphi_rad, steps * grid.dtheta_rad],
        octaves,
    )
}

/// a_k, four to a vector.
fn amplitude_table(detail: &Detail) -> [[f32; 4]; DETAIL_AMPLITUDE_VECS] {
    let mut t = [[0.0; 4]; DETAIL_AMPLITUDE_VECS];
    for (k, a) in detail.amplitudes_f32().into_iter().enumerate() {
        t[k / 4][k % 4] = a;
    }
    t
}

/// σ = clamp(x + y·relief, 0, z) as the shaders evaluate it; `w` is the caller's.
fn sigma_params(detail: &Detail, w: f32) -> [f32; 4] {
    let p = detail.params();
    [
        p.amplitude_min_m as f32,
        (p.roughness_gain * detail.relief_scale()) as f32,
        p.amplitude_max_m as f32,
        w,
    ]
}

impl From<&OctaveAnchorF32> for DetailOctaveParams {
    fn from(a: &OctaveAnchorF32) -> Self {
        let row = |i: usize| [a.m[i][0], a.m[i][1], a.m[i][2], a.frac[i]];
        Self {
            m0: row(0),
            m1: row(1),
            m2: row(2),
            cell: [a.cell[0], a.cell[1], a.cell[2], a.seed as i32],
        }
    }
}

/// `BumpUniforms` in `shaders/terrain.wgsl`: the detail's octaves anchored at the viewer, for
/// the fragment's bump octaves, and the frame's rotation (one per frame).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct BumpUniforms {
    pub octaves: [DetailOctaveParams; MAX_OCTAVES],
    pub amplitudes: [[f32; 4]; DETAIL_AMPLITUDE_VECS],
    pub sigma: [f32; 4],
    pub lambda_px: [f32; 4],
    pub world0: [f32; 4],
    pub world1: [f32; 4],
    pub world2: [f32; 4],
}

impl BumpUniforms {
    /// The bump of `view` (none without detail: λ_px's range is 0).
    pub fn new(view: &ViewPlan, detail: Option<&Detail>) -> Self {
        let mut b: Self = Zeroable::zeroed();
        let w = view.camera.view_frame().world_from_view;
        let row = |i: usize, extra: f32| {
            [
                w.x_axis[i] as f32,
                w.y_axis[i] as f32,
                w.z_axis[i] as f32,
                extra,
            ]
        };
        // The frame's rotation (the normals are world vectors), with or without detail.
        b.world0 = row(0, 0.0);
        b.world1 = row(1, 0.0);
        b.world2 = row(2, 0.0);
        let Some(detail) = detail else {
            return b;
        };
        let viewer_u = w * glam::DVec3::Z;
        let n = detail.octave_count();
        // N = M·W: lattice cells per unit of view-space Δu.
        for (o, a) in b.octaves.iter_mut().zip(detail.anchors_in(viewer_u, n, w)) {
            *o = DetailOctaveParams::from(&a);
        }
        b.amplitudes = amplitude_table(detail);
        b.sigma = sigma_params(detail, detail.radius_m() as f32);
        let p = detail.params();
        // Octaves of cells at least two pixels: λ_px(d) = log_r(L_0·focal/(2d)) + 1.
        let focal_px = crate::geo::projection::focal_length_px(view.height_px, view.fov_y_rad);
        let first = detail.octaves().first().map_or(1.0, |o| o.cell_m);
        let y = 1.0 / p.lacunarity.ln();
        b.lambda_px = [
            ((first * focal_px / 2.0).ln() * y + 1.0) as f32,
            y as f32,
            n as f32,
            0.0,
        ];
        let map = detail.roughness();
        b.world0 = row(0, map.cols as f32);
        b.world1 = row(1, map.rows as f32);
        b.world2 = row(2, 0.0);
        b
    }
}

/// `PlanarUniforms` in `shaders/planar.wgsl`: the tangent frame of a planar LOD method in view
/// space (the per-frame f64 → f32 step of `planar::LocalFrame::view_basis`) and the square the
/// clipmap leaves to it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct PlanarUniforms {
    pub anchor: [f32; 4],
    pub east: [f32; 4],
    pub north: [f32; 4],
    pub cut: [f32; 4],
    pub spacing_m: f32,
    pub patch_cells: u32,
    pub skirt_m: f32,
    pub drawing: u32,
    pub grid_cols: u32,
    pub grid_rows: u32,
    pub ray_step_px: f32,
    pub px_per_rad: f32,
}

/// `PatchGpu` in `shaders/planar.wgsl`: one geomipmapping patch of the frame.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct PatchGpu {
    pub corner: [i32; 2],
    pub level: f32,
    /// Δφ of the patch's centre from the viewer's, in (−π, π]: a vertex's Δφ is taken on the
    /// same side of the ±π cut, so no triangle around a pole interpolates across it.
    pub centre_dphi: f32,
    pub sides: [f32; 4],
}

impl PlanarUniforms {
    /// Nothing planar this frame: the clipmap draws everywhere.
    pub fn inactive() -> Self {
        Self::zeroed()
    }

    /// The geomipmapping plan's frame in view space, its square and skirt depth.
    pub fn from_geomip(view: &ViewPlan, plan: &GeomipPlan, patch_cells: u32) -> Self {
        let view_from_world = view.camera.view_frame().world_from_view.transpose();
        let [a, e, n] = plan.frame.view_basis(&view_from_world);
        let v4 = |v: DVec3| [v.x as f32, v.y as f32, v.z as f32, 0.0];
        let lo = plan.square_m[0];
        let [clo, chi] = plan.cut_m();
        let band = clo - lo;
        // Deep enough to hide any step between the two surfaces at the square's edge: the
        // band's width (a slope of 1 across the band).
        let skirt_m = band.x.max(band.y);
        Self {
            anchor: v4(a),
            east: v4(e),
            north: v4(n),
            cut: [clo.x as f32, clo.y as f32, chi.x as f32, chi.y as f32],
            spacing_m: plan.spacing_m as f32,
            patch_cells,
            skirt_m: skirt_m as f32,
            drawing: 1,
            ..Self::zeroed()
        }
    }
}

impl PlanarUniforms {
    /// The projected grid's: its size, the ray march's step and λ; the clipmap cuts nothing
    /// (it draws nothing beside the grid).
    pub fn from_grid(view: &ViewPlan, cols: u32, rows: u32) -> Self {
        Self {
            grid_cols: cols,
            grid_rows: rows,
            ray_step_px: crate::planar::projgrid::RAY_STEP_PX as f32,
            px_per_rad: crate::geo::projection::focal_length_px(view.height_px, view.fov_y_rad)
                as f32,
            ..Self::zeroed()
        }
    }
}

impl PatchGpu {
    pub fn new(view: &ViewPlan, plan: &GeomipPlan, patch: &Patch, patch_cells: u32) -> Self {
        let half = 0.5 * patch_cells as f64;
        let centre = glam::DVec2::new(patch.corner[0] as f64 + half, patch.corner[1] as f64 + half);
        let u = plan.frame.unit_at(centre * plan.spacing_m);
        let dphi = crate::geo::sphere::wrap_angle_rad(u.y.atan2(u.x) - view.phi_v_rad);
        Self {
            corner: [patch.corner[0] as i32, patch.corner[1] as i32],
            level: patch.level as f32,
            centre_dphi: dphi as f32,
            sides: patch.sides.map(|s| s as f32),
        }
    }
}

gpu_struct!(PlanarUniforms as "PlanarUniforms" {
    anchor, east, north, cut, spacing_m, patch_cells, skirt_m, drawing, grid_cols, grid_rows,
    ray_step_px, px_per_rad,
});
gpu_struct!(PatchGpu as "PatchGpu" { corner, level, centre_dphi, sides });
gpu_struct!(DetailOctaveParams as "DetailOctave" { m0, m1, m2, cell });
gpu_struct!(BumpUniforms as "BumpUniforms" {
    octaves, amplitudes, sigma, lambda_px, world0, world1, world2,
});
gpu_struct!(DeltaOctaveParams as "DeltaOctave" { lo, chain, warp_ref });
gpu_struct!(DetailFillParams as "DetailFillParams" {
    ref_trig, ref_angles, warp, warp2, sigma, counts, delta, delta_end, delta_sigma, relief_ref,
    relief_ref2, amplitudes, octaves, deltas,
});

gpu_struct!(TransformUniformsF32 as "TransformUniforms" {
    sin_theta_v, cos_theta_v, theta_v, pi_minus_theta_v, stretch,
});
gpu_struct!(FrameUniforms as "FrameUniforms" {
    clip_from_view, transform, sun_view, radius_m, eye_height_m, blend_fraction, texture_size,
    transform_form, approx_start_level, coarsest_level, finest_level, overlay, eye_height_lo_m,
    mesh_steps, mesh_rings, detail_lambda,
});
gpu_struct!(LookUniforms as "LookUniforms" {
    view_from_clip, world0, world1, world2, tex_anchor, boundary_cell0, boundary_frac0,
    boundary_cell1, boundary_frac1, wave_anchor0, wave_anchor1,
    rayleigh, mie, shell, light, sky_zenith, sky_horizon, sun, eye_radius_m, water_level_m,
    sun_cos, time_s, clip_from_view, viewport, sky_ring, aerial, type_means, type_features,
});
gpu_struct!(LevelUniforms as "LevelUniforms" {
    grid_x_viewer, grid_y_viewer, inv_dphi, inv_dtheta, dtheta_rad, detail_full, detail_end,
    density, outer_density, inner_density, morph, outer_morph, inner_morph, ref_eye_m,
});
gpu_struct!(NormalParams as "NormalParams" {
    slot0, extent, layer, size, partial_count, quarter, angles, trig, radius_m, pole_north,
    pole_south, offset_x, offset_y, ref_m, boundary_cell0, boundary_frac0,
    boundary_cell1, boundary_frac1, imagery_xy, imagery_size, imagery_fold,
});
gpu_struct!(WaterCullParams as "WaterCullParams" {
    dry_from_m, block, blocks_per_row, job_count, draw_count,
});
gpu_struct!(WaveParams as "Wave" { omega_a, omega_b, phases });
gpu_struct!(FillParams as "FillParams" {
    ref_trig, spacing, slot0, extent, layer, size, offset, ref_m, waves,
});
gpu_struct!(DemFillParams as "DemFillParams" {
    base, frac, step, slot0, extent, layer, size, page_base, tiles_x, cols, rows, tile_size,
    wraps, cap_north, cap_south, decode, offset, sea_m, code_ref, frac_lo, anchor_m, relative,
});
/// `PlacedVertex` in `shaders/terrain.wgsl`: one ring vertex placed by the vertex pre-pass
/// (`render::placement`), which the clipmap's draws read as their vertex buffer.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct PlacedVertex {
    /// Position relative to the eye (m), the level (as f32).
    pub rel_level: [f32; 4],
    /// p̃, the bump octaves' σ.
    pub p_sigma: [f32; 4],
    /// Δφ, Δθ, coarse blend, 0.
    pub map_blend: [f32; 4],
}

gpu_struct!(PlacedVertex as "PlacedVertex" {
    rel_level, p_sigma, map_blend,
});

/// The vertex buffer layout of [`PlacedVertex`]: `PlacedIn` (locations 0–2) in
/// `shaders/terrain.wgsl`, one `vec4<f32>` per field in field order.
pub const PLACED_VERTEX_ATTRIBUTES: [wgpu::VertexAttribute; 3] =
    wgpu::vertex_attr_array![0 => Float32x4, 1 => Float32x4, 2 => Float32x4];

gpu_struct!(RingVertex as "RingVertex" {
    p_tilde, one_minus_cos, theta_tilde_rad, ring_t, level, seam_side,
});

/// The vertex buffer layout of [`RingVertex`] (locations as in `shaders/terrain.wgsl`).
pub const RING_VERTEX_ATTRIBUTES: [wgpu::VertexAttribute; 6] = wgpu::vertex_attr_array![
    0 => Float32x3, 1 => Float32, 2 => Float32, 3 => Float32, 4 => Uint32, 5 => Float32
];

// ---------------------------------------------------------------------------------------------
// Plan → GPU data (f64 → f32)

/// Debug overlays drawn by the terrain pass.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Overlays {
    /// Each level in its own colour (`--overlay levels`); geomipmapping patches by level.
    pub levels: bool,
    /// Every triangle's edges (`--overlay wireframe`), for every LOD method.
    pub wireframe: bool,
}

impl Overlays {
    /// The `overlay` bit field of [`FrameUniforms`] (bits are generated WGSL constants).
    pub fn bits(self) -> u32 {
        let bit = |on: bool, b: u32| if on { b } else { 0 };
        bit(self.levels, shader::OVERLAY_LEVELS) | bit(self.wireframe, shader::OVERLAY_WIREFRAME)
    }
}

impl FrameUniforms {
    /// The frame's uniforms from its plan.
    pub fn from_plan(
        view: &ViewPlan,
        clipmap: &ClipmapPlan,
        settings: &ClipmapSettings,
        overlays: Overlays,
        detail: Option<&Detail>,
    ) -> Self {
        let altitude_m = view.camera.altitude_m;
        let sun = view.sun_view.as_vec3();
        Self {
            clip_from_view: view.clip_from_view.as_mat4().to_cols_array_2d(),
            transform: TransformUniformsF32::from_theta_v(view.theta_v_rad, Stretch::Exact),
            sun_view: [sun.x, sun.y, sun.z, 0.0],
            radius_m: view.radius_m as f32,
            eye_height_m: altitude_m as f32,
            blend_fraction: settings.blend_fraction,
            texture_size: settings.texture_size,
            transform_form: settings.transform.shader_code(),
            // Beyond every level: the stable form everywhere.
            approx_start_level: clipmap.approx_start_level.unwrap_or(u32::MAX / 2),
            coarsest_level: clipmap.selection.coarsest,
            finest_level: clipmap.selection.finest,
            overlay: overlays.bits(),
            eye_height_lo_m: (altitude_m - altitude_m as f32 as f64) as f32,
            mesh_steps: settings.phi_steps,
            mesh_rings: settings.rings_per_level,
            detail_lambda: detail.map_or([0.0; 4], |d| {
                let (x, y, z) = d.lambda_constants();
                [x as f32, y as f32, z as f32, 0.0]
            }),
        }
    }
}

/// The cell of a world lattice of cell `cell_m` holding `point` (world frame, m) with the hash
/// seed, and the remainder with 1/cell, in f64: the GPU adds only a small offset over the cell.
pub fn world_lattice(point: DVec3, cell_m: f64, seed: u32) -> ([i32; 4], [f32; 4]) {
    let e = point / cell_m;
    let c = e.floor();
    let f = e - c;
    (
        [c.x as i32, c.y as i32, c.z as i32, seed as i32],
        [f.x as f32, f.y as f32, f.z as f32, (1.0 / cell_m) as f32],
    )
}

impl LookUniforms {
    /// The frame's look: `water_level_m` is the terrain's (`None`: no water), `time_s` moves
    /// the waves (0 in PNGs and measurements).
    pub fn from_plan(
        view: &ViewPlan,
        atmosphere: &Atmosphere,
        look: LookSettings,
        water_level_m: Option<f64>,
        time_s: f64,
    ) -> Self {
        let w = view.camera.view_frame().world_from_view;
        let row = |i: usize| {
            [
                w.x_axis[i] as f32,
                w.y_axis[i] as f32,
                w.z_axis[i] as f32,
                0.0,
            ]
        };
        let eye_radius_m = view.radius_m + view.camera.altitude_m;
        let eye_world = w * DVec3::Z * eye_radius_m;
        // frac(E/L) in f64: the GPU adds only the eye-relative part (W·rel)/L.
        let anchor = |tile_m: f64| {
            let e = eye_world / tile_m;
            let f = e - e.floor();
            [f.x as f32, f.y as f32, f.z as f32, (1.0 / tile_m) as f32]
        };
        let lattice = |cell_m: f64, seed: u32| world_lattice(eye_world, cell_m, seed);
        let sun = view.sun_view;
        let o = DVec3::new(0.0, 0.0, eye_radius_m);
        let (zenith, horizon) = if look.sky {
            // The horizon's colour averaged over four azimuths, just above it.
            let zenith = atmosphere.sky_radiance(o, DVec3::Z, sun, 16);
            let horizon = [0.0f64, 0.5, 1.0, 1.5]
                .iter()
                .map(|a| {
                    let az = a * std::f64::consts::PI;
                    let d = DVec3::new(az.cos(), az.sin(), 0.05).normalize();
                    atmosphere.sky_radiance(o, d, sun, 16)
                })
                .fold(DVec3::ZERO, |acc, c| acc + c / 4.0);
            (zenith, horizon)
        } else {
            let flat = DVec3::from_array(view.sky_linear);
            (flat, flat)
        };
        let v4 = |v: DVec3, w: f64| [v.x as f32, v.y as f32, v.z as f32, w as f32];
        let (direct, ambient) = if look.sky { (1.0, 0.25) } else { (0.72, 0.28) };
        Self {
            view_from_clip: view.clip_from_view.inverse().as_mat4().to_cols_array_2d(),
            world0: row(0),
            world1: row(1),
            world2: row(2),
            tex_anchor: anchor(crate::look::TEXTURE_TILE_M),
            boundary_cell0: lattice(BOUNDARY_CELLS_M[0], BOUNDARY_SEEDS[0]).0,
            boundary_frac0: lattice(BOUNDARY_CELLS_M[0], BOUNDARY_SEEDS[0]).1,
            boundary_cell1: lattice(BOUNDARY_CELLS_M[1], BOUNDARY_SEEDS[1]).0,
            boundary_frac1: lattice(BOUNDARY_CELLS_M[1], BOUNDARY_SEEDS[1]).1,
            wave_anchor0: anchor(crate::look::WAVE_TILES_M[0]),
            wave_anchor1: anchor(crate::look::WAVE_TILES_M[1]),
            rayleigh: v4(atmosphere.rayleigh, 1.0 / atmosphere.rayleigh_height_m),
            mie: v4(DVec3::splat(atmosphere.mie), 1.0 / atmosphere.mie_height_m),
            shell: [
                atmosphere.radius_m as f32,
                atmosphere.top_radius_m() as f32,
                atmosphere.mie_extinction_ratio as f32,
                atmosphere.mie_g as f32,
            ],
            light: [atmosphere.sun_radiance as f32, 2.2, direct, ambient],
            sky_zenith: v4(zenith, 0.0),
            sky_horizon: v4(horizon, 0.0),
            sun: v4(sun, 0.0),
            eye_radius_m: eye_radius_m as f32,
            water_level_m: water_level_m.unwrap_or(f64::NEG_INFINITY).max(-1e30) as f32,
            // The sun's disk: 0.27° of angular radius.
            sun_cos: 0.27f64.to_radians().cos() as f32,
            clip_from_view: view.clip_from_view.as_mat4().to_cols_array_2d(),
            viewport: {
                let (w, h) = (
                    f64::from(view.width_px.max(1)),
                    f64::from(view.height_px.max(1)),
                );
                [w as f32, h as f32, (2.0 / w) as f32, (2.0 / h) as f32]
            },
            sky_ring: [0.0; 4],
            aerial: [1.0, 1.0, 1.0, 0.0],
            type_means: {
                let t = crate::look::proto::textures(look.mips);
                std::array::from_fn(|k| {
                    let top = t.albedo[k].levels.last().unwrap()[0];
                    [
                        top[0] as f32 / 255.0,
                        top[1] as f32 / 255.0,
                        top[2] as f32 / 255.0,
                        0.0,
                    ]
                })
            },
            type_features: crate::look::proto::IMAGERY_PROTOTYPES.map(|p| {
                let f = crate::look::proto::imagery_features(p);
                [f[0], f[1], f[2], 0.0]
            }),
            time_s: time_s as f32,
        }
    }
}

/// Per level, where the viewer sits in the texture it holds (texel units, modulo the size) and
/// its spacing; zero for levels never filled.
pub fn level_uniforms(
    view: &ViewPlan,
    held: &[Option<LevelGrid>],
    densities: &DensityPlan,
    detail: Option<&Detail>,
    blend_fraction: f64,
) -> Vec<LevelUniforms> {
    let mut levels = vec![LevelUniforms::default(); MAX_LEVELS as usize];
    for ((uniforms, grid), d) in levels.iter_mut().zip(held).zip(&densities.levels) {
        if let Some(g) = grid {
            let (gx, gy) = g.viewer_texel(view.phi_v_rad, view.theta_v_rad);
            let octaves = detail.map_or(LevelOctaves::default(), |d| {
                d.level_octaves(g.level, blend_fraction)
            });
            *uniforms = LevelUniforms {
                grid_x_viewer: gx as f32,
                grid_y_viewer: gy as f32,
                inv_dphi: (1.0 / g.dphi_rad) as f32,
                inv_dtheta: (1.0 / g.dtheta_rad) as f32,
                dtheta_rad: g.dtheta_rad as f32,
                detail_full: octaves.full,
                detail_end: octaves.full + octaves.partial,
                density: d.body.k,
                outer_density: d.outer.k,
                inner_density: d.inner.k,
                morph: d.body.morph,
                outer_morph: d.outer.morph,
                inner_morph: d.inner.morph,
                ref_eye_m: (g.ref_m - view.camera.altitude_m) as f32,
                _pad: [0; 2],
            };
        }
    }
    levels
}

impl FillParams {
    /// One rectangle of the analytic planet's fill, within one anchor block: its waves
    /// relative to the block's corner `anchor`, so the GPU adds only small angle offsets, the
    /// same ones whichever dispatch fills a texel.
    pub fn new(
        planet: &AnalyticPlanet,
        grid: &LevelGrid,
        rect: &GridRect,
        anchor: [i64; 2],
    ) -> Self {
        let phi_r = anchor[0] as f64 * grid.dphi_rad;
        let theta_r = anchor[1] as f64 * grid.dtheta_rad;
        let (st, ct) = theta_r.sin_cos();
        let (sp, cp) = phi_r.sin_cos();
        let s = grid.size as i64;
        Self {
            ref_trig: [st as f32, ct as f32, sp as f32, cp as f32],
            spacing: [grid.dphi_rad as f32, grid.dtheta_rad as f32, 0.0, 0.0],
            slot0: [rect.gx0.rem_euclid(s) as u32, rect.gy0.rem_euclid(s) as u32],
            extent: [rect.width, rect.height],
            layer: grid.level,
            size: grid.size,
            offset: [(rect.gx0 - anchor[0]) as u32, (rect.gy0 - anchor[1]) as u32],
            ref_m: grid.ref_m as f32,
            _pad: [0; 3],
            waves: planet
                .waves_at(phi_r, theta_r, grid.band_limit_texel_m(planet.radius_m))
                .map(|w| WaveParams::from(&w)),
        }
    }

    /// The same with the detail block leaving out `detail_offset_m`
    /// ([`DetailFillParams::with_offset`]): taken off the reference height in f64.
    pub fn with_detail_offset(mut self, grid: &LevelGrid, detail_offset_m: f64) -> Self {
        self.ref_m = (grid.ref_m - detail_offset_m) as f32;
        self
    }
}

impl From<&WaveAt> for WaveParams {
    fn from(w: &WaveAt) -> Self {
        let (oa, ob) = (w.omega_a.as_vec3(), w.omega_b.as_vec3());
        Self {
            omega_a: [oa.x, oa.y, oa.z, w.amplitude_m as f32],
            omega_b: [ob.x, ob.y, ob.z, 0.0],
            phases: [
                w.alpha_a_rad.sin() as f32,
                w.alpha_a_rad.cos() as f32,
                w.alpha_b_rad.sin() as f32,
                w.alpha_b_rad.cos() as f32,
            ],
        }
    }
}

/// One dispatch of the DEM fill in f64: a rectangle of a level texture whose pyramid pixel
/// coordinates are linear in the grid indices (the feed splits rectangles where rows fold over
/// a pole and at a regional grid's 360° wrap).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DemFillJob {
    /// The level's grid and the grid point (gx, gy) every parameter is computed at: the
    /// corner of the anchor block the job lies in (the detail's reference point; rows past a
    /// pole unfolded).
    pub grid: LevelGrid,
    pub origin: [i64; 2],
    /// The job's first texel, in grid steps from `origin`.
    pub offset: [u32; 2],
    /// Pyramid pixel (col, row) of `origin`: integer part and fraction.
    pub base: [i64; 2],
    pub frac: [f64; 2],
    /// The data's height (f64) at `base` + `frac` with `frac` rounded to f32 (the shader's
    /// starting point), where the job lies well inside one pixel of a global grid: the fill
    /// then adds each texel's change from there (no large terms).
    pub anchor_height_m: Option<f64>,
    /// Pixels per grid step (d col / d gx, d row / d gy).
    pub step: [f64; 2],
    /// Texel of the first grid point (toroidal) and the rectangle's size.
    pub slot0: [u32; 2],
    pub extent: [u32; 2],
    /// Level texture (layer) and its size.
    pub layer: u32,
    pub size: u32,
    /// First page-table entry of the pyramid level and its tiles per row.
    pub page_base: u32,
    pub tiles_x: u32,
    /// The pyramid level's grid.
    pub cols: i64,
    pub rows: i64,
    pub tile_size: i64,
    pub wraps: bool,
    /// Pole caps: rows from the outermost row to the pole (0: no cap) and the pole's height.
    pub cap_north: [f64; 2],
    pub cap_south: [f64; 2],
    /// metres = offset + quantum · code
    pub decode_offset_m: f64,
    pub decode_quantum_m: f64,
}

impl From<&DemFillJob> for DemFillParams {
    fn from(j: &DemFillJob) -> Self {
        Self::new(j, 0.0)
    }
}

impl DemFillParams {
    /// The job's parameters when its detail block leaves out `detail_offset_m`
    /// ([`DetailFillParams::with_offset`]).
    pub fn new(j: &DemFillJob, detail_offset_m: f64) -> Self {
        let pair = |v: [f64; 2]| [v[0] as f32, v[1] as f32];
        // Heights from the level's reference, subtracted in f64 (LevelGrid::ref_m), less the
        // detail the texels leave out.
        let r = j.grid.ref_m - detail_offset_m;
        let cap = |c: [f64; 2]| [c[0] as f32, (c[1] - r) as f32];
        let code_ref = if j.decode_quantum_m != 0.0 {
            ((r - j.decode_offset_m) / j.decode_quantum_m)
                .round()
                .clamp(i32::MIN as f64 / 2.0, i32::MAX as f64 / 2.0) as i32
        } else {
            0
        };
        Self {
            base: [j.base[0] as i32, j.base[1] as i32],
            frac: pair(j.frac),
            frac_lo: [
                (j.frac[0] - j.frac[0] as f32 as f64) as f32,
                (j.frac[1] - j.frac[1] as f32 as f64) as f32,
            ],
            anchor_m: j.anchor_height_m.map_or(0.0, |h| (h - r) as f32),
            relative: j.anchor_height_m.is_some() as u32,
            step: pair(j.step),
            slot0: j.slot0,
            extent: j.extent,
            layer: j.layer,
            size: j.size,
            page_base: j.page_base,
            tiles_x: j.tiles_x,
            cols: j.cols as i32,
            rows: j.rows as i32,
            tile_size: j.tile_size as i32,
            wraps: j.wraps as u32,
            cap_north: cap(j.cap_north),
            cap_south: cap(j.cap_south),
            decode: [
                (j.decode_offset_m + j.decode_quantum_m * code_ref as f64 - r) as f32,
                j.decode_quantum_m as f32,
            ],
            offset: j.offset,
            sea_m: -r as f32,
            code_ref,
        }
    }
}
