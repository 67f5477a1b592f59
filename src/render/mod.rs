//! Render plumbing (wgpu): device context, shader assembly, the terrain pass with its compute
//! fill, the planar LOD methods' resources, and the offscreen target used by `globe render`, the tests and the benchmarks.
//!
//! Precision boundary (docs/design.md#numerics): everything arriving here is f64; the only f32 values the GPU
//! sees are relative to the viewer (view-space offsets, heights, small map-space offsets).

pub mod aerial;
pub mod context;
pub mod contracts;
pub mod dem_feed;
pub mod detail;
pub mod dispatch;
pub mod fill_analytic;
pub mod fill_dem;
pub mod formats;
pub mod gpu_data;
pub mod imagery;
pub mod look;
pub mod normals;
pub mod offscreen;
pub mod placement;
pub mod planar;
pub mod shader;
pub mod sky;
pub mod terrain;
pub mod tiles;
pub mod timing;
pub mod water_cull;

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
    #[error("procedural detail does not fit these clipmap settings: {0}")]
    Detail(#[from] crate::procedural::DetailError),
    #[error("GPU readback failed: {0}")]
    Readback(String),
    #[error("the GPU reported an error: {0}")]
    Gpu(String),
    #[error("could not start the tile streamer: {0}")]
    StreamerStart(#[source] std::io::Error),
    #[error(
        "streaming did not settle within {timeout_s} s: still waiting for {waiting_for}; last error: {}{}",
        last_error.as_deref().unwrap_or("none"),
        file_change.as_ref().map_or(String::new(), |c| format!("; {c}"))
    )]
    NotSettled {
        timeout_s: f64,
        /// What the last frame still lacked ([`terrain::FrameInfo::waiting_for`]).
        waiting_for: String,
        last_error: Option<String>,
        /// What happened to the pyramid file, when something did (a truncation is why tiles
        /// never arrive). Boxed: it is rare and large, and every render result carries room
        /// for it.
        file_change: Option<Box<crate::dem::FileChange>>,
    },
    /// The view can never complete with these streaming settings (found on its first frames,
    /// instead of waiting out the timeout).
    #[error("{0}")]
    GpuTilesShort(dem_feed::GpuTilesShort),
}

/// A compute pass's storage buffer binding (unsized, no dynamic offset).
pub fn compute_storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A compute pass's uniform buffer binding (no dynamic offset).
pub fn compute_uniform_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}
