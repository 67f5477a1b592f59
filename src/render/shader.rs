//! Shader assembly: constants generated from Rust, then the shared WGSL library, then the pass.
//!
//! Every module-scope constant of the assembled shaders is written here from its Rust value,
//! so the two sides cannot drift; `tests/shader_contract.rs` fails if a shader file declares a
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
/// Bit of `FrameUniforms::overlay`: tint each level in its own colour.
pub const OVERLAY_LEVELS: u32 = 1;

const MAP_TRANSFORM: &str = include_str!("../../shaders/common/map_transform.wgsl");
const NOISE: &str = include_str!("../../shaders/common/noise.wgsl");
const DETAIL_FILL: &str = include_str!("../../shaders/common/detail_fill.wgsl");
pub const TERRAIN: &str = include_str!("../../shaders/terrain.wgsl");
pub const FILL_ANALYTIC: &str = include_str!("../../shaders/fill_analytic.wgsl");
pub const FILL_DEM: &str = include_str!("../../shaders/fill_dem.wgsl");
pub const FILL_NORMALS: &str = include_str!("../../shaders/fill_normals.wgsl");

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
        c("MAX_OCTAVES", MAX_OCTAVES as u32),
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
/// `FILL_DEM`) also gets the detail's fill code and its bindings (group 1).
pub fn assemble(pass: &str) -> String {
    let fill = if pass == FILL_ANALYTIC || pass == FILL_DEM {
        DETAIL_FILL
    } else {
        ""
    };
    format!("{}\n{MAP_TRANSFORM}\n{NOISE}\n{fill}\n{pass}", constants())
}
