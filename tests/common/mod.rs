//! Shared GPU access for the rendering tests: one adapter (a software one on CI: lavapipe),
//! a clear skip when none exists, and a hard failure instead when `GLOBE_REQUIRE_GPU=1` (set by
//! the test script, so CI can never pass by skipping).
#![allow(dead_code)]

pub mod gdal;

use std::sync::{Mutex, MutexGuard, OnceLock};

use globe::render::GpuContext;

static CONTEXT: OnceLock<Option<GpuContext>> = OnceLock::new();
static SERIAL: Mutex<()> = Mutex::new(());

/// The shared context and a guard that serialises GPU tests (a software rasteriser on two
/// cores gains nothing from running them side by side).
pub fn gpu() -> Option<(&'static GpuContext, MutexGuard<'static, ()>)> {
    let ctx = CONTEXT.get_or_init(|| match GpuContext::headless() {
        Ok(ctx) => {
            eprintln!("GPU tests on {}", ctx.adapter_description());
            Some(ctx)
        }
        Err(e) => {
            if std::env::var("GLOBE_REQUIRE_GPU").as_deref() == Ok("1") {
                panic!("GLOBE_REQUIRE_GPU=1 but no adapter: {e}");
            }
            eprintln!("SKIPPED: no graphics adapter ({e}); run ./scripts/test.sh to install one");
            None
        }
    });
    let guard = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
    ctx.as_ref().map(|c| (c, guard))
}

use glam::DVec3;
use globe::geo::camera::Camera;
use globe::geo::projection;
use globe::render::TerrainRenderer;
use globe::render::offscreen::{OffscreenFrame, RenderedFrame};

/// Renders `camera` into a fresh `w`×`h` offscreen target and reads it back.
pub fn render(
    ctx: &GpuContext,
    r: &mut TerrainRenderer,
    camera: &Camera,
    w: u32,
    h: u32,
) -> RenderedFrame {
    OffscreenFrame::new(&ctx.device, w, h)
        .render(ctx, r, camera)
        .unwrap()
}

/// The surface point under pixel (x, y), in view space (planet centre at the origin), from the
/// rendered reversed-Z depth, in f64. None where the pixel shows sky.
pub fn surface_point_view(
    camera: &Camera,
    frame: &RenderedFrame,
    x: u32,
    y: u32,
    radius_m: f64,
) -> Option<DVec3> {
    let depth = frame.depth_at(x, y) as f64;
    if depth <= 0.0 {
        return None;
    }
    let aspect = frame.width as f64 / frame.height as f64;
    let ndc = DVec3::new(
        (x as f64 + 0.5) / frame.width as f64 * 2.0 - 1.0,
        1.0 - (y as f64 + 0.5) / frame.height as f64 * 2.0,
        depth,
    );
    let camera_from_clip =
        projection::camera_from_clip(camera.fov_y_rad(), aspect, frame.info.near_m);
    let p_cam = projection::camera_point_from_ndc(&camera_from_clip, ndc);
    Some(DVec3::new(0.0, 0.0, radius_m + camera.altitude_m) + camera.view_from_camera() * p_cam)
}

/// Fails unless every named scene is in `covered`: a scene added to the registry must add its
/// test to `file` too.
pub fn assert_covers_every_scene(covered: &[&str], file: &str) {
    for scene in globe::scenes::SCENES {
        assert!(
            covered.contains(&scene.name),
            "scene {} has no test in {file}",
            scene.name
        );
    }
}

/// The compute pipeline of `source`'s entry point `cs_main` (bind group layout derived from the
/// shader).
pub fn compute_pipeline(ctx: &GpuContext, source: String, label: &str) -> wgpu::ComputePipeline {
    let module = ctx
        .device
        .create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(label),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
    ctx.device
        .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(label),
            layout: None,
            module: &module,
            entry_point: Some("cs_main"),
            compilation_options: Default::default(),
            cache: None,
        })
}

/// A storage buffer of `size` bytes the shader writes and the test reads back.
pub fn output_buffer(ctx: &GpuContext, size: u64) -> wgpu::Buffer {
    ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("compute output"),
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    })
}

/// Dispatches `pipeline` over `workgroups` (x) with `buffers` bound at group 0, bindings 0, 1, …
/// in order, and returns the bytes of `output` (one of them, made by [`output_buffer`]).
pub fn run_compute(
    ctx: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    buffers: &[&wgpu::Buffer],
    output: &wgpu::Buffer,
    workgroups: u32,
) -> Vec<u8> {
    let device = &ctx.device;
    let entries: Vec<wgpu::BindGroupEntry> = buffers
        .iter()
        .enumerate()
        .map(|(i, b)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: b.as_entire_binding(),
        })
        .collect();
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    });
    let size = output.size();
    let back = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("compute readback"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups(workgroups, 1, 1);
    }
    encoder.copy_buffer_to_buffer(output, 0, &back, 0, size);
    ctx.queue.submit([encoder.finish()]);
    back.map_async(wgpu::MapMode::Read, .., |r| r.unwrap());
    ctx.wait_idle().unwrap();
    let bytes = back.slice(..).get_mapped_range().unwrap().to_vec();
    back.unmap();
    bytes
}

/// Every tile key of a pyramid, level by level, row by row.
pub fn all_tile_keys(p: &globe::dem::pyramid::Pyramid) -> Vec<globe::stream::TileKey> {
    let mut keys = Vec::new();
    for (level, l) in p.levels().iter().enumerate() {
        for ty in 0..l.tiles_y {
            for tx in 0..l.tiles_x {
                keys.push(globe::stream::TileKey {
                    level: level as u32,
                    tx: tx as u32,
                    ty: ty as u32,
                });
            }
        }
    }
    keys
}

/// A fresh renderer over `terrain` with the default settings.
pub fn default_renderer(ctx: &GpuContext, terrain: &globe::terrain::Terrain) -> TerrainRenderer {
    TerrainRenderer::new(
        &ctx.device,
        globe::clipmap::settings::ClipmapSettings::default(),
        terrain.clone(),
        globe::render::formats::COLOR_FORMAT,
    )
    .unwrap()
}

/// A fresh renderer over the embedded Earth with water at sea level, the full look and, if
/// `detail`, the default procedural detail.
pub fn full_look_renderer(ctx: &GpuContext, detail: bool) -> TerrainRenderer {
    let terrain = globe::terrain::Terrain::embedded_earth()
        .expect("embedded Earth")
        .with_detail(detail.then(globe::procedural::DetailParams::default))
        .with_water_level(Some(globe::look::SEA_LEVEL_M));
    let mut r = default_renderer(ctx, &terrain);
    r.set_look(&ctx.device, globe::look::LookSettings::default());
    r
}
