//! The window's GPU side: the wgpu surface and depth buffer, the terrain renderer, the egui
//! renderer, and one frame's encoding and presentation (terrain pass, then egui over it).

use std::sync::Arc;

use winit::dpi::{LogicalSize, PhysicalSize};
use winit::event_loop::{ActiveEventLoop, OwnedDisplayHandle};
use winit::window::Window;

use crate::render::formats;
use crate::render::formats::DEPTH_FORMAT;
use crate::render::{FrameInfo, GpuContext, TerrainRenderer};
use crate::terrain::Terrain;

use super::UiError;

/// Everything that needs the window: created in `resumed`.
pub(super) struct Gpu {
    // Declared (and so dropped) before `window`.
    pub(super) egui_renderer: egui_wgpu::Renderer,
    pub(super) egui_state: egui_winit::State,
    pub(super) terrain: TerrainRenderer,
    pub(super) depth: wgpu::TextureView,
    pub(super) surface: wgpu::Surface<'static>,
    pub(super) config: wgpu::SurfaceConfiguration,
    pub(super) ctx: GpuContext,
    pub(super) adapter_text: String,
    pub(super) surface_text: String,
    pub(super) window: Arc<Window>,
}

impl Gpu {
    pub(super) fn new(
        event_loop: &ActiveEventLoop,
        display: &OwnedDisplayHandle,
        settings: crate::clipmap::ClipmapSettings,
        planet: Terrain,
        overlay_levels: bool,
        stream: crate::stream::StreamSettings,
    ) -> Result<Self, UiError> {
        let attributes = Window::default_attributes()
            .with_title("globe")
            .with_inner_size(LogicalSize::new(1280.0, 800.0));
        let window = Arc::new(
            event_loop
                .create_window(attributes)
                .map_err(|e| UiError::no_display(format!("could not open a window: {e}")))?,
        );
        let instance = wgpu::Instance::new(
            wgpu::InstanceDescriptor::new_with_display_handle_from_env(Box::new(display.clone())),
        );
        let surface = instance
            .create_surface(wgpu::SurfaceTarget::from_window_without_display(
                window.clone(),
            ))
            .map_err(|e| UiError::Surface(e.to_string()))?;
        let adapter = pollster::block_on(GpuContext::pick_adapter(&instance, Some(&surface)))?;
        let ctx = GpuContext::with_adapter(instance, adapter)?;
        let size = window.inner_size();
        let config = surface_config(&surface, &ctx.adapter, size)?;
        surface.configure(&ctx.device, &config);
        let depth = depth_view(&ctx.device, config.width, config.height);

        let mut terrain =
            TerrainRenderer::with_streaming(&ctx.device, settings, planet, config.format, stream)?;
        terrain.overlays.levels = overlay_levels;

        let max_texture_side = ctx.device.limits().max_texture_dimension_2d as usize;
        let egui_ctx = egui::Context::default();
        let egui_state = egui_winit::State::new(
            egui_ctx,
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            window.theme(),
            Some(max_texture_side),
        );
        let egui_renderer = egui_wgpu::Renderer::new(
            &ctx.device,
            config.format,
            egui_wgpu::RendererOptions::default(),
        );
        let adapter_text = ctx.adapter_description();
        let surface_text = format!("surface {:?}, {:?}", config.format, config.present_mode);
        Ok(Self {
            egui_renderer,
            egui_state,
            terrain,
            depth,
            surface,
            config,
            ctx,
            adapter_text,
            surface_text,
            window,
        })
    }

    /// Reconfigures the surface (and the depth buffer) at the window's current size.
    pub(super) fn resize(&mut self, size: PhysicalSize<u32>) {
        if size.width == 0 || size.height == 0 {
            return; // minimised: keep the old configuration until the window is back
        }
        self.config.width = size.width;
        self.config.height = size.height;
        self.surface.configure(&self.ctx.device, &self.config);
        self.depth = depth_view(&self.ctx.device, size.width, size.height);
    }

    /// Replaces a lost surface.
    pub(super) fn recreate_surface(&mut self) -> Result<(), UiError> {
        self.surface = self
            .ctx
            .instance
            .create_surface(wgpu::SurfaceTarget::from_window_without_display(
                self.window.clone(),
            ))
            .map_err(|e| UiError::Surface(e.to_string()))?;
        self.surface.configure(&self.ctx.device, &self.config);
        Ok(())
    }

    /// A renderer with `settings`, or the GPU's complaint (out of memory, limits) as text.
    pub(super) fn build_renderer(
        &self,
        settings: crate::clipmap::ClipmapSettings,
        format: wgpu::TextureFormat,
    ) -> Result<TerrainRenderer, String> {
        let device = &self.ctx.device;
        let oom = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let built = TerrainRenderer::with_streaming(
            device,
            settings,
            self.terrain.terrain.clone(),
            format,
            self.terrain
                .feed()
                .map(|f| *f.settings())
                .unwrap_or_default(),
        );
        let validation = pollster::block_on(validation.pop());
        let oom = pollster::block_on(oom.pop());
        let mut renderer = built.map_err(|e| e.to_string())?;
        if let Some(e) = validation.or(oom) {
            return Err(e.to_string());
        }
        renderer.overlays = self.terrain.overlays;
        renderer.set_look(device, self.terrain.look());
        renderer.set_lod(device, self.terrain.lod());
        renderer.set_wireframe(device, self.terrain.overlays.wireframe);
        Ok(renderer)
    }

    /// The surface texture to draw this frame into, or why there is none.
    pub(super) fn acquire(&mut self) -> Acquired {
        match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(texture) => Acquired::Frame {
                texture,
                suboptimal: false,
            },
            wgpu::CurrentSurfaceTexture::Suboptimal(texture) => Acquired::Frame {
                texture,
                suboptimal: true,
            },
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => {
                Acquired::Skip
            }
            wgpu::CurrentSurfaceTexture::Outdated => {
                let size = self.window.inner_size();
                self.resize(size);
                Acquired::Skip
            }
            wgpu::CurrentSurfaceTexture::Lost => match self.recreate_surface() {
                Ok(()) => Acquired::Skip,
                Err(e) => Acquired::Failed(e),
            },
            wgpu::CurrentSurfaceTexture::Validation => Acquired::Validation,
        }
    }

    /// Encodes the terrain pass (prepared into `encoder` as `info`) and the panel's egui output
    /// over it into `texture`, submits and presents; reconfigures a suboptimal surface.
    pub(super) fn present(
        &mut self,
        texture: wgpu::SurfaceTexture,
        suboptimal: bool,
        mut encoder: wgpu::CommandEncoder,
        info: &FrameInfo,
        mut output: egui::FullOutput,
    ) {
        let device = &self.ctx.device;
        let queue = &self.ctx.queue;
        let egui_ctx = self.egui_state.egui_ctx().clone();
        self.egui_state
            .handle_platform_output(&self.window, output.platform_output);
        let paint_jobs = egui_ctx.tessellate(output.shapes, output.pixels_per_point);
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [self.config.width, self.config.height],
            pixels_per_point: output.pixels_per_point,
        };
        // Every delta must be applied (egui asserts that none is dropped).
        let mut textures = std::mem::take(&mut output.textures_delta);
        for (id, deltas) in textures.set.drain() {
            for delta in &deltas {
                self.egui_renderer.update_texture(device, queue, id, delta);
            }
        }
        let egui_commands =
            self.egui_renderer
                .update_buffers(device, queue, &mut encoder, &paint_jobs, &screen);

        let view = texture.texture.create_view(&Default::default());
        self.terrain.encode_pass(
            &mut encoder,
            info,
            &view,
            &self.depth,
            wgpu::StoreOp::Discard,
            None,
        );
        {
            let pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("egui"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Load,
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            self.egui_renderer
                .render(&mut pass.forget_lifetime(), &paint_jobs, &screen);
        }
        queue.submit(egui_commands.into_iter().chain([encoder.finish()]));
        self.window.pre_present_notify();
        queue.present(texture);
        for id in textures.free.drain() {
            self.egui_renderer.free_texture(&id);
        }
        if suboptimal {
            let size = self.window.inner_size();
            self.resize(size);
        }
    }
}

/// sRGB if the surface has it (Rgba8UnormSrgb first: screenshots then reuse the renderer),
/// vsync presentation.
fn surface_config(
    surface: &wgpu::Surface<'_>,
    adapter: &wgpu::Adapter,
    size: PhysicalSize<u32>,
) -> Result<wgpu::SurfaceConfiguration, UiError> {
    let caps = surface.get_capabilities(adapter);
    let mut config = surface
        .get_default_config(adapter, size.width.max(1), size.height.max(1))
        .ok_or_else(|| {
            UiError::Surface(format!(
                "the window surface is not supported by {}",
                adapter.get_info().name
            ))
        })?;
    let preferred = [formats::COLOR_FORMAT, wgpu::TextureFormat::Bgra8UnormSrgb];
    config.format = preferred
        .into_iter()
        .find(|f| caps.formats.contains(f))
        .or_else(|| caps.formats.iter().copied().find(|f| f.is_srgb()))
        .unwrap_or(config.format);
    config.present_mode = if caps.present_modes.contains(&wgpu::PresentMode::Fifo) {
        wgpu::PresentMode::Fifo
    } else {
        wgpu::PresentMode::AutoVsync
    };
    Ok(config)
}

fn depth_view(device: &wgpu::Device, width: u32, height: u32) -> wgpu::TextureView {
    device
        .create_texture(&wgpu::TextureDescriptor {
            label: Some("window depth"),
            size: wgpu::Extent3d {
                width: width.max(1),
                height: height.max(1),
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: DEPTH_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            view_formats: &[],
        })
        .create_view(&Default::default())
}

/// What [`Gpu::acquire`] found.
pub(super) enum Acquired {
    /// Draw into this texture.
    Frame {
        texture: wgpu::SurfaceTexture,
        /// Present, then reconfigure the surface.
        suboptimal: bool,
    },
    /// No frame this time (timeout, occluded, or the surface was just reconfigured/recreated).
    Skip,
    /// The surface reported a validation error.
    Validation,
    /// The lost surface could not be recreated.
    Failed(UiError),
}
