//! Tests that render or compute on the adapter (lavapipe on CI) and check the result against f64 truth, golden images or the metric.
//!
//! One test binary (each module was its own binary once; one link step instead of many).

#[path = "../common/mod.rs"]
mod common;

mod close_up;
mod density;
mod detail_render;
mod golden;
mod gpu_detail;
mod gpu_look;
mod gpu_normals;
mod gpu_transform;
mod imagery;
mod leave_out;
mod measure;
mod mesh_independence;
mod placement;
mod render_earth;
mod render_scenes;
mod shimmer;
mod sky_table;
mod stability;
mod water_cull;
