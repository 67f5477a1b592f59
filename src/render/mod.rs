//! Render plumbing (wgpu): device context, shader assembly, the terrain pass with its compute
//! fill, and the offscreen target used by `globe render`, the tests and the benchmarks.
//!
//! Precision boundary (DESIGN.md): everything arriving here is f64; the only f32 values the GPU
//! sees are relative to the viewer (view-space offsets, heights, small map-space offsets).

pub mod context;
pub mod dem_feed;
pub mod fill;
pub mod gpu_data;
pub mod offscreen;
pub mod shader;
pub mod terrain;
pub mod tiles;
pub mod timing;

pub use context::GpuContext;
pub use offscreen::{OffscreenFrame, RenderedFrame};
pub use terrain::{FrameInfo, TerrainRenderer};

/// Errors of the render layer.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(
        "no graphics adapter found ({0}); on a machine without a GPU install a software Vulkan driver (Debian: apt-get install mesa-vulkan-drivers)"
    )]
    NoAdapter(String),
    #[error("could not open the graphics device on {adapter}: {source}")]
    Device {
        adapter: String,
        source: wgpu::RequestDeviceError,
    },
    #[error("invalid clipmap settings: {0}")]
    Settings(#[from] crate::clipmap::settings::SettingsError),
    #[error("GPU readback failed: {0}")]
    Readback(String),
    #[error("the GPU reported an error: {0}")]
    Gpu(String),
    #[error("{0}")]
    Stream(String),
}
