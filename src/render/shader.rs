//! Shader assembly: constants generated from Rust, then the shared WGSL library, then the pass.
//!
//! Constants live in Rust only and are written into the source as WGSL, so they cannot drift.

use crate::terrain::analytic::SCALES;

/// Largest level count any settings may use (size of the per-level uniform array).
pub const MAX_LEVELS: u32 = 48;

const MAP_TRANSFORM: &str = include_str!("../../shaders/common/map_transform.wgsl");
pub const TERRAIN: &str = include_str!("../../shaders/terrain.wgsl");
pub const FILL_ANALYTIC: &str = include_str!("../../shaders/fill_analytic.wgsl");
pub const FILL_DEM: &str = include_str!("../../shaders/fill_dem.wgsl");

/// Generated constants every pass may use.
pub fn constants() -> String {
    format!("const MAX_LEVELS: u32 = {MAX_LEVELS}u;\nconst ANALYTIC_SCALES: u32 = {SCALES}u;\n")
}

/// Full source of a pass: constants, shared library, pass body.
pub fn assemble(pass: &str) -> String {
    format!("{}\n{MAP_TRANSFORM}\n{pass}", constants())
}
