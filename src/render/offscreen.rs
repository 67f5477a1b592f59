//! Offscreen rendering and readback: the headless path of `globe render`, the tests and the
//! benchmarks. The same `TerrainRenderer` draws here and into the window.

use crate::geo::camera::Camera;

use super::formats::{COLOR_FORMAT, DEPTH_FORMAT};
use super::terrain::{FrameInfo, TerrainRenderer};
use super::{GpuContext, RenderError};

/// A colour + depth target of a fixed size.
pub struct OffscreenFrame {
    pub width: u32,
    pub height: u32,
    color: wgpu::Texture,
    depth: wgpu::Texture,
}

/// One rendered frame read back to the CPU.
pub struct RenderedFrame {
    pub width: u32,
    pub height: u32,
    /// RGBA8, sRGB, row-major from the top-left.
    pub rgba: Vec<u8>,
    /// Reversed-Z depth (near/distance along −z; 0 = sky), row-major from the top-left.
    pub depth: Vec<f32>,
    pub info: FrameInfo,
}

impl RenderedFrame {
    pub fn save_png(&self, path: &std::path::Path) -> Result<(), image::ImageError> {
        image::save_buffer(
            path,
            &self.rgba,
            self.width,
            self.height,
            image::ColorType::Rgba8,
        )
    }

    pub fn depth_at(&self, x: u32, y: u32) -> f32 {
        self.depth[(y * self.width + x) as usize]
    }
}

impl OffscreenFrame {
    pub fn new(device: &wgpu::Device, width: u32, height: u32) -> Self {
        let make = |label, format| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            })
        };
        Self {
            width,
            height,
            color: make("offscreen colour", COLOR_FORMAT),
            depth: make("offscreen depth", DEPTH_FORMAT),
        }
    }

    /// Waits until every tile the view needs has streamed in (at most `SETTLE_TIMEOUT`), then
    /// renders `camera` and reads colour and depth back.
    pub fn render(
        &self,
        ctx: &GpuContext,
        renderer: &mut TerrainRenderer,
        camera: &Camera,
    ) -> Result<RenderedFrame, RenderError> {
        self.render_settled_within(ctx, renderer, camera, SETTLE_TIMEOUT)
    }

    /// [`OffscreenFrame::render`], waiting at most `timeout` (`globe render --settle-timeout`).
    pub fn render_settled_within(
        &self,
        ctx: &GpuContext,
        renderer: &mut TerrainRenderer,
        camera: &Camera,
        timeout: std::time::Duration,
    ) -> Result<RenderedFrame, RenderError> {
        renderer.settle_or_explain(ctx, camera, self.width, self.height, timeout)?;
        self.render_now(ctx, renderer, camera)
    }

    /// Renders `camera` with whatever data has arrived (no waiting) and reads it back.
    pub fn render_now(
        &self,
        ctx: &GpuContext,
        renderer: &mut TerrainRenderer,
        camera: &Camera,
    ) -> Result<RenderedFrame, RenderError> {
        let (mut encoder, info) = self.encode(ctx, renderer, camera, wgpu::StoreOp::Store, None);
        let color_buf = ReadbackBuffer::new(&ctx.device, self.width, self.height, 4);
        let depth_buf = ReadbackBuffer::new(&ctx.device, self.width, self.height, 4);
        color_buf.copy_from(&mut encoder, &self.color, wgpu::TextureAspect::All);
        depth_buf.copy_from(&mut encoder, &self.depth, wgpu::TextureAspect::DepthOnly);
        ctx.queue.submit([encoder.finish()]);
        let rgba = color_buf.read(ctx)?;
        let depth_bytes = depth_buf.read(ctx)?;
        let depth = depth_bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        Ok(RenderedFrame {
            width: self.width,
            height: self.height,
            rgba,
            depth,
            info,
        })
    }
}

/// One frame of a benchmark: no readback.
#[derive(Clone, Debug)]
pub struct TimedFrame {
    pub info: FrameInfo,
    /// CPU time to decide, encode and submit the frame (streaming bookkeeping, uploads and
    /// fills included; the GPU's work is not waited for).
    pub cpu_ms: f64,
    /// Wall time until the GPU finished it.
    pub frame_ms: f64,
    /// The terrain pass on the GPU, from timestamp queries (None without them).
    pub gpu_ms: Option<f64>,
    /// The frame's compute fill on the GPU (None without timestamps or without a fill).
    pub fill_gpu_ms: Option<f64>,
}

impl OffscreenFrame {
    /// Records one frame into a new encoder: the renderer's preparation (streaming, fills) and
    /// the terrain pass into this target, timed by `timer` where given.
    fn encode(
        &self,
        ctx: &GpuContext,
        renderer: &mut TerrainRenderer,
        camera: &Camera,
        depth_store: wgpu::StoreOp,
        timer: Option<&super::timing::GpuTimer>,
    ) -> (wgpu::CommandEncoder, FrameInfo) {
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        renderer.fill_timestamps = timer.map(|t| t.query_set().clone());
        let info = renderer.prepare(&ctx.queue, &mut encoder, camera, self.width, self.height);
        renderer.fill_timestamps = None;
        let color_view = self.color.create_view(&Default::default());
        let depth_view = self.depth.create_view(&Default::default());
        renderer.encode_pass(
            &mut encoder,
            &info,
            &color_view,
            &depth_view,
            depth_store,
            timer.map(|t| t.pass_writes()),
        );
        (encoder, info)
    }

    /// Renders `camera` with whatever data has arrived, waits for the GPU, and times it.
    pub fn draw_timed(
        &self,
        ctx: &GpuContext,
        renderer: &mut TerrainRenderer,
        camera: &Camera,
        timer: Option<&super::timing::GpuTimer>,
    ) -> Result<TimedFrame, RenderError> {
        let started = std::time::Instant::now();
        let (mut encoder, info) = self.encode(ctx, renderer, camera, wgpu::StoreOp::Discard, timer);
        if let Some(t) = timer {
            t.resolve(&mut encoder);
        }
        ctx.queue.submit([encoder.finish()]);
        let cpu_ms = started.elapsed().as_secs_f64() * 1e3;
        let (gpu_ms, fill_gpu_ms) = match timer {
            Some(t) => {
                let (pass, fill) = t.read_ms(ctx)?;
                (Some(pass), (info.texels_filled > 0).then_some(fill))
            }
            None => {
                ctx.wait_idle()?;
                (None, None)
            }
        };
        Ok(TimedFrame {
            info,
            cpu_ms,
            frame_ms: started.elapsed().as_secs_f64() * 1e3,
            gpu_ms,
            fill_gpu_ms,
        })
    }
}

/// How long `render` waits for streaming to settle.
pub const SETTLE_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(300);

/// A mappable buffer holding one texture copy, rows padded to wgpu's 256-byte alignment.
struct ReadbackBuffer {
    buffer: wgpu::Buffer,
    width: u32,
    height: u32,
    bytes_per_texel: u32,
    padded_row: u32,
}

impl ReadbackBuffer {
    fn new(device: &wgpu::Device, width: u32, height: u32, bytes_per_texel: u32) -> Self {
        let row = width * bytes_per_texel;
        let padded_row =
            row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: padded_row as u64 * height as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            buffer,
            width,
            height,
            bytes_per_texel,
            padded_row,
        }
    }

    fn copy_from(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        texture: &wgpu::Texture,
        aspect: wgpu::TextureAspect,
    ) {
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &self.buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(self.padded_row),
                    rows_per_image: Some(self.height),
                },
            },
            wgpu::Extent3d {
                width: self.width,
                height: self.height,
                depth_or_array_layers: 1,
            },
        );
    }

    fn read(&self, ctx: &GpuContext) -> Result<Vec<u8>, RenderError> {
        let (tx, rx) = std::sync::mpsc::channel();
        self.buffer.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        ctx.wait_idle()?;
        rx.recv()
            .map_err(|e| RenderError::Readback(e.to_string()))?
            .map_err(|e| RenderError::Readback(e.to_string()))?;
        let row = (self.width * self.bytes_per_texel) as usize;
        let mut out = Vec::with_capacity(row * self.height as usize);
        {
            let data = self
                .buffer
                .get_mapped_range(..)
                .map_err(|e| RenderError::Readback(e.to_string()))?;
            for y in 0..self.height as usize {
                let at = y * self.padded_row as usize;
                out.extend_from_slice(&data[at..at + row]);
            }
        }
        self.buffer.unmap();
        Ok(out)
    }
}
