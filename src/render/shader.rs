//! Shader assembly: constants generated from Rust, then the shared WGSL library, then the pass.
//!
//! Every module-scope constant of the assembled shaders is written here from its Rust value,
//! so the two sides cannot drift; `tests/cpu/shader_contract.rs` fails if a shader file declares a
//! module-scope `const` of its own.

use crate::clipmap::settings::TransformForm;
use crate::procedural::MAX_OCTAVES;
use crate::terrain::analytic::SCALES;

/// Largest level count any settings may use (size of the per-level uniform array).
pub const MAX_LEVELS: u32 = 48;
/// Edge of a compute fill's square workgroup (`@workgroup_size`); the dispatch counts divide
/// each rectangle by it.
pub const WORKGROUP_SIZE: u32 = 8;
/// Page-table entry of a pyramid tile that is not on the GPU.
pub const NO_SLOT: u32 = u32::MAX;
/// `@workgroup_size` of the vertex pre-pass `cs_place` (`render::placement`).
pub const PLACE_WORKGROUP: u32 = 64;
/// Padding of the pre-pass's work list: no vertex.
pub const PLACE_NONE: u32 = u32::MAX;
/// Bit of `FrameUniforms::overlay`: tint each level in its own colour.
pub const OVERLAY_LEVELS: u32 = 1;
/// Bit of the wireframe overlay (barycentric edges).
pub const OVERLAY_WIREFRAME: u32 = 2;

/// The aerial-perspective volume (`render::aerial`): cells across the frame (x, y) and slices
/// along each cell's ray (z); 10 × 10 pixels a cell at 1920×1080 (the haze is smooth across
/// the image; at the limb the slices' distance carries it).
pub const AERIAL_SIZE: [u32; 3] = [160, 90, 32];

const TRIG: &str = include_str!("../../shaders/common/trig.wgsl");
const MAP_TRANSFORM: &str = include_str!("../../shaders/common/map_transform.wgsl");
const NOISE: &str = include_str!("../../shaders/common/noise.wgsl");
const DETAIL_FILL: &str = include_str!("../../shaders/common/detail_fill.wgsl");
/// The look's library (`common/look.wgsl`): the pass declares `look` itself.
pub const LOOK: &str = include_str!("../../shaders/common/look.wgsl");
pub const TERRAIN: &str = include_str!("../../shaders/terrain.wgsl");
pub const FILL_ANALYTIC: &str = include_str!("../../shaders/fill_analytic.wgsl");
pub const FILL_DEM: &str = include_str!("../../shaders/fill_dem.wgsl");
pub const FILL_NORMALS: &str = include_str!("../../shaders/fill_normals.wgsl");
pub const SKY: &str = include_str!("../../shaders/sky.wgsl");
/// The aerial-perspective volume (`render::aerial`).
pub const AERIAL: &str = include_str!("../../shaders/aerial.wgsl");
/// Which terrain draws may leave the water's shading out (`render::water_cull`).
pub const WATER_CULL: &str = include_str!("../../shaders/water_cull.wgsl");
/// Appended to [`TERRAIN`] (one module): the planar LOD methods' vertex stages.
pub const PLANAR: &str = include_str!("../../shaders/planar.wgsl");

/// A `u32` constant shared by Rust and WGSL.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SharedConstant {
    pub name: &'static str,
    pub value: u32,
}

/// Every constant the shaders may use, with its Rust value.
pub fn shared_constants() -> Vec<SharedConstant> {
    let c = |name, value| SharedConstant { name, value };
    vec![
        c("MAX_LEVELS", MAX_LEVELS),
        c("ANALYTIC_SCALES", SCALES as u32),
        c("WORKGROUP_SIZE", WORKGROUP_SIZE),
        c("NO_SLOT", NO_SLOT),
        c("OVERLAY_LEVELS", OVERLAY_LEVELS),
        c("OVERLAY_WIREFRAME", OVERLAY_WIREFRAME),
        c("GRID_TAG", crate::planar::projgrid::GRID_TAG),
        c("RAY_STEPS", crate::planar::projgrid::RAY_STEPS),
        c("RAY_BISECTIONS", crate::planar::projgrid::RAY_BISECTIONS),
        c("MAX_OCTAVES", MAX_OCTAVES as u32),
        c("PLACE_WORKGROUP", PLACE_WORKGROUP),
        c("PLACE_NONE", PLACE_NONE),
        c("PROTO_TEXTURE_SIZE", crate::look::proto::TEXTURE_SIZE),
        c("PROTO_MIP_LEVELS", crate::look::proto::MIP_LEVELS),
        c("SKY_RING_SEGMENTS", crate::look::SKY_RING_SEGMENTS),
        c("AERIAL_SIZE_X", AERIAL_SIZE[0]),
        c("AERIAL_SIZE_Y", AERIAL_SIZE[1]),
        c("AERIAL_SIZE_Z", AERIAL_SIZE[2]),
        c("DETAIL_AMPLITUDE_VECS", (MAX_OCTAVES / 4) as u32),
        c("TRANSFORM_DIRECT", TransformForm::Direct.shader_code()),
        c("TRANSFORM_STABLE", TransformForm::Stable.shader_code()),
        c(
            "TRANSFORM_APPROXIMATE",
            TransformForm::Approximate.shader_code(),
        ),
    ]
}

/// The generated WGSL declarations of [`shared_constants`].
pub fn constants() -> String {
    shared_constants()
        .iter()
        .map(|c| format!("const {}: u32 = {}u;\n", c.name, c.value))
        .collect()
}

/// Full source of a pass: constants, shared library, pass body. A fill (`FILL_ANALYTIC`,
/// `FILL_DEM`) also gets the detail's fill code and its bindings (group 1); the terrain and the
/// sky pass get the look's (`common/look.wgsl`).
///
/// With `GLOBE_COARSE_TRIG=1` in the environment every builtin `sin`/`cos` is made as coarse
/// as NVIDIA's ([`with_coarse_builtin_trig`]): a software adapter then shows the error a real
/// GPU would give any code that still used them.
pub fn assemble(pass: &str) -> String {
    let fill = if pass == FILL_ANALYTIC || pass == FILL_DEM {
        DETAIL_FILL
    } else {
        ""
    };
    let look = if pass == TERRAIN || pass == SKY || pass == AERIAL {
        LOOK
    } else {
        ""
    };
    let planar = if pass == TERRAIN { PLANAR } else { "" };
    let source = format!(
        "{}\n{TRIG}\n{MAP_TRANSFORM}\n{NOISE}\n{fill}\n{look}\n{pass}\n{planar}",
        constants()
    );
    if coarse_trig_requested() {
        with_coarse_builtin_trig(&source)
    } else {
        source
    }
}

/// Whether `GLOBE_COARSE_TRIG` asks for [`with_coarse_builtin_trig`] (read once).
fn coarse_trig_requested() -> bool {
    static REQUESTED: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *REQUESTED
        .get_or_init(|| std::env::var("GLOBE_COARSE_TRIG").is_ok_and(|v| !v.is_empty() && v != "0"))
}

/// The WGSL builtins whose precision Vulkan leaves to the driver and [`with_coarse_builtin_trig`]
/// replaces.
pub const COARSE_BUILTINS: [&str; 2] = ["sin", "cos"];

/// `source` with every call of the builtin `sin` and `cos` replaced by the form of NVIDIA's
/// hardware (argument rounded to 2^-22 revolutions, 7.5e-7 rad, then exact; Rust twin
/// [`crate::geo::trig::coarse_sin_f32`]). A software adapter's builtins are exact to rounding,
/// so without this a test there cannot see code that only a real GPU breaks.
/// `trig.wgsl`'s functions use no builtin trig and come out unchanged.
pub fn with_coarse_builtin_trig(source: &str) -> String {
    if source.contains("fn coarse_sin(") {
        // Already made coarse (assemble under GLOBE_COARSE_TRIG).
        return source.to_string();
    }
    let mut out = String::from(
        "fn coarse_sin(x: f32) -> f32 { return sin(round(x * 0.15915494 * 4194304.0) * 1.4980281e-6); }\n\
         fn coarse_cos(x: f32) -> f32 { return cos(round(x * 0.15915494 * 4194304.0) * 1.4980281e-6); }\n",
    );
    let bytes = source.as_bytes();
    let mut i = 0;
    'scan: while i < source.len() {
        let boundary = i == 0 || !(bytes[i - 1].is_ascii_alphanumeric() || bytes[i - 1] == b'_');
        if boundary {
            for name in COARSE_BUILTINS {
                if source[i..].starts_with(name) && source[i + name.len()..].starts_with('(') {
                    out.push_str("coarse_");
                    out.push_str(name);
                    i += name.len();
                    continue 'scan;
                }
            }
        }
        let ch = source[i..].chars().next().expect("i is on a char boundary");
        out.push(ch);
        i += ch.len_utf8();
    }
    out
}
