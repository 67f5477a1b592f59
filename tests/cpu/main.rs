//! CPU-only tests of the library: geometry against closed forms and 60-digit references, the detail's f64 model, frame plans, the Rust↔WGSL contract.
//!
//! One test binary (each module was its own binary once; one link step instead of many).

#[path = "../common/mod.rs"]
mod common;

mod docs_links;
mod frame_plan;
mod geo_math;
mod layers;
mod procedural;
mod shader_contract;
