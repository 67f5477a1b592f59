//! globe: a planetary globe viewer built on spherical geometry clipmaps.
//!
//! Data flows downward: a module uses only modules on its layer or below (`ARCHITECTURE.md`
//! "Layers", held by `tests/cpu/layers.rs`). Lowest first:
//!
//! | module | concern |
//! | --- | --- |
//! | [`geo`] | f64 sphere math, camera, the map transform (3 forms) and visibility bounds |
//! | [`progress`] | progress of long work on stderr: a bar on a terminal, plain lines in logs |
//! | [`dem`] | elevation rasters (EHdr/BIL, netCDF-3) and the tiled pyramid file |
//! | [`imagery`] | true-colour imagery draped on the terrain: the embedded Blue Marble, GeoTIFF and plate-carrée files, area-averaged mipmaps |
//! | [`clipmap`] | ring mesh, level texture windows, level and sector selection |
//! | [`planar`] | close-up LOD methods in a local tangent frame: geomipmapping with geomorphing, the error-bounded projected grid, geometry-image warping |
//! | [`stream`] | tile streaming: sources (mmap, fault injection), tokio streamer, LRU cache |
//! | [`procedural`] | detail below the data: multifractal value noise over a 3-D integer lattice, domain warping, the data's relief, the geometry rule λ(s) |
//! | [`look`] | the look: surface types and their proto-textures, the atmosphere (single scattering) |
//! | [`terrain`] | the terrain function: base heights (the analytic test planet or the DEM pyramid) plus the procedural detail, and water (max(h, level)) |
//! | [`scenes`] | the named views of docs/design.md#scenes, the flight and the soak's random path |
//! | [`plan`] | one frame planned in f64 (view, clipmap levels, fills, sectors, waiting), no GPU |
//! | [`render`] | wgpu plumbing: the plan → f32 GPU data step and the Rust ↔ WGSL contract (`gpu_data`), context, terrain pass, compute fill, offscreen target |
//! | [`measure`] | f64 reference ray caster and the per-pixel screen-space error (error-bounded paper, eq. 2–3) |
//! | [`instruments`] | `globe bench`, `globe report`, the soak and the plots |
//! | [`ui`] | the window: winit + egui |

#![warn(clippy::too_many_lines)]

pub mod clipmap;
pub mod dem;
pub mod geo;
pub mod imagery;
pub mod instruments;
pub mod look;
pub mod measure;
pub mod plan;
pub mod planar;
pub mod procedural;
pub mod progress;
pub mod render;
pub mod scenes;
pub mod stream;
pub mod terrain;
pub mod ui;
