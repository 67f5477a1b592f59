//! The terrain pass: the static ring mesh drawn with the level textures (spherical-clipmaps.md).
//!
//! Per frame the CPU (f64) decides what to draw and which texels moved; the GPU does the
//! per-texel (compute fill) and per-vertex (map transform, displacement) work.

use std::f64::consts::PI;

use glam::{DMat4, DVec3};
use wgpu::util::DeviceExt;

use crate::clipmap::levels::LevelGrid;
use crate::clipmap::selection::{DrawList, Frustum, LevelSelection, SectorBounds};
use crate::clipmap::{ClipmapSettings, RingMesh, RingVertex};
use crate::geo::camera::Camera;
use crate::geo::map_transform::{Stretch, TransformUniformsF32};
use crate::geo::{projection, sphere, visibility};
use crate::terrain::Terrain;

use super::RenderError;
use super::dem_feed::{DemFeed, FeedFrame, LevelJob};
use super::fill::{FillJob, FillPass};
use super::shader::{self, MAX_LEVELS};
use crate::stream::StreamSettings;

pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

pub mod gpu_data {
    use bytemuck::{Pod, Zeroable};

    use crate::geo::map_transform::TransformUniformsF32;

    /// GPU twin: `FrameUniforms` in `shaders/terrain.wgsl`.
    #[repr(C)]
    #[derive(Clone, Copy, Debug, Pod, Zeroable)]
    pub struct FrameUniforms {
        pub clip_from_view: [[f32; 4]; 4],
        pub transform: TransformUniformsF32,
        pub sun_view: [f32; 4],
        pub radius_m: f32,
        pub eye_height_m: f32,
        pub blend_fraction: f32,
        pub texture_size: u32,
        pub transform_form: u32,
        pub approx_start_level: u32,
        pub coarsest_level: u32,
        pub finest_level: u32,
        pub overlay: u32,
        /// The eye's altitude minus `eye_height_m` (f64 − f32): a 1 mm climb at 9 km is below
        /// one f32 step of the altitude, so the shader adds this low part after the difference.
        pub eye_height_lo_m: f32,
        pub _pad: [u32; 2],
    }

    /// GPU twin: `LevelUniforms` in `shaders/terrain.wgsl`.
    #[repr(C)]
    #[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
    pub struct LevelUniforms {
        pub grid_x_viewer: f32,
        pub grid_y_viewer: f32,
        pub inv_dphi: f32,
        pub inv_dtheta: f32,
        pub dtheta_rad: f32,
        pub _pad: [f32; 3],
    }
}

use gpu_data::{FrameUniforms, LevelUniforms};

/// Debug overlays drawn by the terrain pass.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Overlays {
    /// Each level in its own colour (`--overlay levels`).
    pub levels: bool,
}

impl Overlays {
    fn bits(self) -> u32 {
        self.levels as u32
    }
}

/// What the renderer decided and did for one frame.
#[derive(Clone, Debug)]
pub struct FrameInfo {
    pub selection: LevelSelection,
    pub draw: DrawList,
    /// Texels the compute pass wrote this frame (toroidal updates).
    pub texels_filled: u64,
    pub near_m: f64,
    pub height_above_terrain_m: f64,
    /// Linear RGB background: sky blue near the ground, black in space.
    pub sky_linear: [f64; 3],
    /// The streaming pipeline's state after this frame (DEM terrain only).
    pub stream: Option<FeedFrame>,
}

impl FrameInfo {
    /// True when nothing this view needs is still on its way (always, for the analytic
    /// planet, which the GPU evaluates itself).
    pub fn settled(&self) -> bool {
        self.stream.as_ref().is_none_or(|s| s.complete)
    }
}

/// Direction to the sun in the viewer's local frame: 35° above the horizon in the south-east,
/// so every named scene is lit from the same side (a fixed world sun would leave some dark).
pub const SUN_ELEVATION_DEG: f64 = 35.0;
pub const SUN_AZIMUTH_DEG: f64 = 135.0;

pub struct TerrainRenderer {
    pub settings: ClipmapSettings,
    pub terrain: Terrain,
    pub overlays: Overlays,
    /// Debug: draw every level of the mesh regardless of the visibility bounds (tests use it to
    /// show that the levels the bounds skip contribute nothing to the image).
    pub draw_all_levels: bool,
    /// Debug: draw every sector, including those outside the frustum.
    pub draw_all_sectors: bool,
    mesh: RingMesh,
    bounds: SectorBounds,
    vertex_buffer: wgpu::Buffer,
    index_buffer: wgpu::Buffer,
    frame_buffer: wgpu::Buffer,
    levels_buffer: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    pipeline: wgpu::RenderPipeline,
    /// Same vertices and triangles, flat and untextured (benchmark reference).
    passthrough: wgpu::RenderPipeline,
    /// Debug/benchmark: draw with the pass-through pipeline instead of the terrain's.
    pub use_passthrough: bool,
    /// Benchmark: a timestamp query set whose queries 2–3 bracket the frame's compute fill.
    pub fill_timestamps: Option<wgpu::QuerySet>,
    fill: FillPass,
    /// The map-space window each level texture currently holds (None: never filled).
    grids: Vec<Option<LevelGrid>>,
    /// The DEM's streaming pipeline (None for the analytic planet).
    feed: Option<DemFeed>,
    heights: wgpu::Texture,
}

impl TerrainRenderer {
    /// A renderer with the default streaming settings.
    pub fn new(
        device: &wgpu::Device,
        settings: ClipmapSettings,
        terrain: Terrain,
        color_format: wgpu::TextureFormat,
    ) -> Result<Self, RenderError> {
        Self::with_streaming(
            device,
            settings,
            terrain,
            color_format,
            StreamSettings::default(),
        )
    }

    /// A renderer whose DEM tiles stream with `stream` (cache sizes, upload budget, faults).
    pub fn with_streaming(
        device: &wgpu::Device,
        settings: ClipmapSettings,
        terrain: Terrain,
        color_format: wgpu::TextureFormat,
        stream: StreamSettings,
    ) -> Result<Self, RenderError> {
        settings.validate()?;
        if settings.levels > MAX_LEVELS {
            return Err(RenderError::Settings(
                crate::clipmap::settings::SettingsError::Levels(settings.levels),
            ));
        }
        let mesh = RingMesh::build(&settings);
        let bounds = SectorBounds::new(&mesh);

        let vertex_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("ring vertices"),
            contents: bytemuck::cast_slice(&mesh.vertices),
            usage: wgpu::BufferUsages::VERTEX,
        });
        let index_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("ring indices"),
            contents: bytemuck::cast_slice(&mesh.indices),
            usage: wgpu::BufferUsages::INDEX,
        });
        let frame_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("frame uniforms"),
            size: std::mem::size_of::<FrameUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let levels_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("level uniforms"),
            size: (std::mem::size_of::<LevelUniforms>() * MAX_LEVELS as usize) as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let heights = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("clipmap heights"),
            size: wgpu::Extent3d {
                width: settings.texture_size,
                height: settings.texture_size,
                depth_or_array_layers: settings.levels,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::R32Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::STORAGE_BINDING
                | wgpu::TextureUsages::COPY_DST
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let heights_view = heights.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });

        let uniform_entry = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("terrain layout"),
            entries: &[
                uniform_entry(0),
                uniform_entry(1),
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                        multisampled: false,
                    },
                    count: None,
                },
            ],
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("terrain bind group"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: frame_buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: levels_buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(&heights_view),
                },
            ],
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("terrain.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shader::assemble(shader::TERRAIN).into()),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("terrain pipeline layout"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let attributes = wgpu::vertex_attr_array![
            0 => Float32x3, 1 => Float32, 2 => Float32, 3 => Float32, 4 => Uint32, 5 => Float32
        ];
        let make_pipeline = |label, vs, fs| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some(vs),
                    compilation_options: Default::default(),
                    buffers: &[Some(wgpu::VertexBufferLayout {
                        array_stride: std::mem::size_of::<RingVertex>() as u64,
                        step_mode: wgpu::VertexStepMode::Vertex,
                        attributes: &attributes,
                    })],
                },
                primitive: wgpu::PrimitiveState {
                    topology: wgpu::PrimitiveTopology::TriangleList,
                    front_face: wgpu::FrontFace::Ccw,
                    cull_mode: Some(wgpu::Face::Back),
                    ..Default::default()
                },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(true),
                    // Reversed-Z: nearer is larger.
                    depth_compare: Some(wgpu::CompareFunction::Greater),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(fs),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format: color_format,
                        blend: None,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let pipeline = make_pipeline("terrain pipeline", "vs_main", "fs_main");
        let passthrough =
            make_pipeline("pass-through pipeline", "vs_passthrough", "fs_passthrough");
        let mut fill = FillPass::new(device, 2 * settings.levels);
        fill.set_target(device, &heights_view);
        let grids = vec![None; settings.levels as usize];
        let feed = match &terrain {
            Terrain::Dem(dem) => {
                // Up to 2 rectangles per level, each split in up to 3 row and 2 column pieces.
                let mut feed = DemFeed::new(device, dem.clone(), stream, 12 * settings.levels)?;
                feed.bind(device, &heights_view);
                Some(feed)
            }
            Terrain::Analytic(_) => None,
        };
        Ok(Self {
            settings,
            terrain,
            overlays: Overlays::default(),
            draw_all_levels: false,
            draw_all_sectors: false,
            mesh,
            bounds,
            vertex_buffer,
            index_buffer,
            frame_buffer,
            levels_buffer,
            bind_group,
            pipeline,
            passthrough,
            use_passthrough: false,
            fill_timestamps: None,
            fill,
            grids,
            feed,
            heights,
        })
    }

    /// The grid a level's texture holds and its heights in grid order (row gy0 first, column
    /// gx0 first), read back from the GPU: tests compare the fill with the terrain function.
    pub fn read_level(
        &self,
        ctx: &super::GpuContext,
        level: u32,
    ) -> Result<Option<(LevelGrid, Vec<f32>)>, RenderError> {
        let Some(grid) = self.grids.get(level as usize).copied().flatten() else {
            return Ok(None);
        };
        let size = self.settings.texture_size;
        let row_bytes = (size * 4).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
            * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("level readback"),
            size: row_bytes as u64 * size as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &self.heights,
                mip_level: 0,
                origin: wgpu::Origin3d {
                    x: 0,
                    y: 0,
                    z: level,
                },
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row_bytes),
                    rows_per_image: Some(size),
                },
            },
            wgpu::Extent3d {
                width: size,
                height: size,
                depth_or_array_layers: 1,
            },
        );
        ctx.queue.submit([encoder.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        buffer.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        ctx.wait_idle()?;
        rx.recv()
            .map_err(|e| RenderError::Readback(e.to_string()))?
            .map_err(|e| RenderError::Readback(e.to_string()))?;
        let data = buffer
            .get_mapped_range(..)
            .map_err(|e| RenderError::Readback(e.to_string()))?;
        let s = size as i64;
        let mut out = Vec::with_capacity((size * size) as usize);
        for j in 0..s {
            let ty = (grid.gy0 + j).rem_euclid(s) as usize;
            for i in 0..s {
                let tx = (grid.gx0 + i).rem_euclid(s) as usize;
                let at = ty * row_bytes as usize + 4 * tx;
                out.push(f32::from_le_bytes([
                    data[at],
                    data[at + 1],
                    data[at + 2],
                    data[at + 3],
                ]));
            }
        }
        Ok(Some((grid, out)))
    }

    /// The streaming pipeline, for a DEM.
    pub fn feed(&self) -> Option<&DemFeed> {
        self.feed.as_ref()
    }

    /// Renders nothing but runs frames for `camera` (streaming, uploads, fills) until every
    /// tile the view needs has arrived or `timeout` passes; returns whether it settled. The
    /// headless renderer calls it before the frame it keeps (`globe render` without
    /// `--no-wait`).
    pub fn settle(
        &mut self,
        ctx: &super::GpuContext,
        camera: &Camera,
        width_px: u32,
        height_px: u32,
        timeout: std::time::Duration,
    ) -> bool {
        let deadline = std::time::Instant::now() + timeout;
        loop {
            let mut encoder = ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("settle"),
                });
            let info = self.prepare(&ctx.queue, &mut encoder, camera, width_px, height_px);
            ctx.queue.submit([encoder.finish()]);
            if info.settled() {
                return true;
            }
            let now = std::time::Instant::now();
            if now >= deadline {
                return false;
            }
            let backlog = info.stream.as_ref().is_some_and(|s| s.upload_backlog > 0);
            if let Some(feed) = &mut self.feed
                && !backlog
            {
                feed.wait_for_tile((deadline - now).min(std::time::Duration::from_millis(50)));
            }
        }
    }

    /// The terrain height at (lat, lon), from the height source (f64).
    pub fn terrain_height_m(&self, lat_deg: f64, lon_deg: f64) -> f64 {
        self.terrain.height_at_lat_lon_m(lat_deg, lon_deg)
    }

    /// Decides what to draw, records the texture updates into `encoder` and writes this
    /// frame's uniforms. Call before `draw`, with the same viewport.
    pub fn prepare(
        &mut self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        camera: &Camera,
        width_px: u32,
        height_px: u32,
    ) -> FrameInfo {
        let radius_m = self.terrain.radius_m();
        let frame = camera.view_frame();
        let phi_v = frame.phi_v.rem_euclid(std::f64::consts::TAU);
        let theta_v = frame.theta_v;
        // From the tiles at hand when streaming: a frame never waits for the file.
        if let Some(feed) = &self.feed {
            feed.begin_frame();
        }
        let ground_m = match &self.feed {
            Some(feed) => feed.height_at_m(camera.lat_deg, camera.lon_deg),
            None => self.terrain_height_m(camera.lat_deg, camera.lon_deg),
        };
        let height_above_terrain_m = camera.altitude_m - ground_m;
        let near_m = projection::near_plane_m(height_above_terrain_m);
        let aspect = width_px as f64 / height_px.max(1) as f64;
        let fov_y_rad = camera.fov_y_rad();

        // Levels: eq. 6 (with the mountain term) and eq. 7–8.
        let (hmin, hmax) = self.terrain.height_range_m();
        let theta_max = visibility::theta_tilde_max(radius_m, camera.altitude_m, hmin, hmax);
        let theta_min =
            visibility::theta_tilde_min(radius_m, height_above_terrain_m, fov_y_rad, height_px);
        let mut selection = LevelSelection::new(self.settings.levels, theta_max, theta_min);
        if self.draw_all_levels {
            selection.coarsest = 0;
            selection.finest = self.settings.levels - 1;
        }

        // Texture windows: the drawn levels and the one their outer rings blend into.
        let first = selection.coarsest.saturating_sub(1);
        let mut targets = Vec::new();
        for level in first..=selection.finest {
            let old = self.grids[level as usize];
            let grid = LevelGrid::for_viewer(
                level,
                self.settings.texture_size,
                phi_v,
                theta_v,
                old.as_ref(),
            );
            targets.push((grid, grid.dirty_since(old.as_ref())));
        }
        let timestamps = self
            .fill_timestamps
            .as_ref()
            .map(|q| wgpu::ComputePassTimestampWrites {
                query_set: q,
                beginning_of_pass_write_index: Some(2),
                end_of_pass_write_index: Some(3),
            });
        let (texels_filled, stream) = match &self.terrain {
            Terrain::Analytic(planet) => {
                let jobs: Vec<FillJob> = targets
                    .iter()
                    .flat_map(|(grid, rects)| {
                        rects.iter().map(|rect| FillJob {
                            grid: *grid,
                            rect: *rect,
                        })
                    })
                    .collect();
                for (grid, _) in &targets {
                    self.grids[grid.level as usize] = Some(*grid);
                }
                (
                    self.fill.encode(queue, encoder, planet, &jobs, timestamps),
                    None,
                )
            }
            Terrain::Dem(_) => {
                let feed = self.feed.as_mut().expect("a DEM has a feed");
                let jobs: Vec<LevelJob> = targets
                    .iter()
                    .map(|(grid, rects)| LevelJob {
                        grid: *grid,
                        rects: rects.clone(),
                    })
                    .collect();
                let (filled, texels) =
                    feed.update(queue, encoder, &jobs, (phi_v, theta_v), timestamps);
                for ((grid, _), ok) in targets.iter().zip(&filled) {
                    if *ok {
                        self.grids[grid.level as usize] = Some(*grid);
                    }
                }
                // Draw down to the last level that, like every coarser one, holds its target.
                let ready = |l: u32| {
                    targets
                        .iter()
                        .find(|(g, _)| g.level == l)
                        .is_some_and(|(g, _)| self.grids[l as usize] == Some(*g))
                };
                let mut ready_finest = None;
                if (first..selection.coarsest).all(ready) {
                    for l in selection.coarsest..=selection.finest {
                        if !ready(l) {
                            break;
                        }
                        ready_finest = Some(l);
                    }
                }
                selection.limit_to_ready(ready_finest);
                (texels, Some(feed.last.clone()))
            }
        };

        // Sectors inside the frustum.
        let camera_from_view = camera.view_from_camera().transpose();
        let eye_view_m = DVec3::new(0.0, 0.0, radius_m + camera.altitude_m);
        let frustum = Frustum::new(camera_from_view, eye_view_m, fov_y_rad, aspect, near_m);
        // Terrain radii within each level's outer ring, from the height source's local bounds
        // (the tiles at hand when streaming).
        let nadir = sphere::unit_vector(frame.phi_v, theta_v);
        let terrain = &self.terrain;
        let feed = self.feed.as_ref();
        let radius_range_m = |level: u32| {
            let angle = crate::clipmap::settings::level_outer_theta_rad(level);
            let (lo, hi) = match feed {
                Some(f) => f.height_bounds_near_m(nadir, angle),
                None => terrain.height_bounds_near_m(nadir, angle),
            };
            (radius_m + lo, radius_m + hi)
        };
        let draw = if selection.any_drawn() {
            DrawList::build(
                &self.mesh,
                &self.bounds,
                &selection,
                (!self.draw_all_sectors).then_some(&frustum),
                radius_range_m,
            )
        } else {
            DrawList::default()
        };

        let mut levels = vec![LevelUniforms::default(); MAX_LEVELS as usize];
        for (level, grid) in self.grids.iter().enumerate() {
            if let Some(g) = grid {
                let (gx, gy) = g.viewer_texel(phi_v, theta_v);
                levels[level] = LevelUniforms {
                    grid_x_viewer: gx as f32,
                    grid_y_viewer: gy as f32,
                    inv_dphi: (1.0 / g.dphi_rad) as f32,
                    inv_dtheta: (1.0 / g.dtheta_rad) as f32,
                    dtheta_rad: g.dtheta_rad as f32,
                    _pad: [0.0; 3],
                };
            }
        }
        queue.write_buffer(&self.levels_buffer, 0, bytemuck::cast_slice(&levels));

        let clip_from_view =
            camera.clip_from_camera(aspect, near_m) * DMat4::from_mat3(camera_from_view);
        // The approximation is only valid away from the poles (paper: π/48 < θv < 47π/48).
        let approx_ok = theta_v > PI / 48.0 && theta_v < 47.0 * PI / 48.0;
        let approx_start_level = if approx_ok {
            self.settings.approx_start_level
        } else {
            u32::MAX / 2
        };
        let (el, az) = (SUN_ELEVATION_DEG.to_radians(), SUN_AZIMUTH_DEG.to_radians());
        // Local east-north-up → view space: east = ỹ, north = −x̃, up = z̃.
        let sun_view = DVec3::new(-el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
        let uniforms = FrameUniforms {
            clip_from_view: clip_from_view.as_mat4().to_cols_array_2d(),
            transform: TransformUniformsF32::from_theta_v(theta_v, Stretch::Exact),
            sun_view: [sun_view.x as f32, sun_view.y as f32, sun_view.z as f32, 0.0],
            radius_m: radius_m as f32,
            eye_height_m: camera.altitude_m as f32,
            blend_fraction: self.settings.blend_fraction,
            texture_size: self.settings.texture_size,
            transform_form: self.settings.transform.shader_code(),
            approx_start_level,
            coarsest_level: selection.coarsest,
            finest_level: selection.finest,
            overlay: self.overlays.bits(),
            eye_height_lo_m: (camera.altitude_m - camera.altitude_m as f32 as f64) as f32,
            _pad: [0; 2],
        };
        queue.write_buffer(&self.frame_buffer, 0, bytemuck::bytes_of(&uniforms));

        // A frame whose camera height or culling bounds came from coarser tiles than its own
        // is not settled, even if those tiles have arrived meanwhile.
        let mut stream = stream;
        if let (Some(st), Some(feed)) = (&mut stream, &self.feed) {
            st.complete &= !feed.fell_back();
        }
        FrameInfo {
            selection,
            draw,
            texels_filled,
            near_m,
            height_above_terrain_m,
            sky_linear: sky_colour(camera.altitude_m),
            stream,
        }
    }

    /// Records a whole terrain pass: colour cleared to the sky, depth cleared to 0 (reversed-Z),
    /// then the draw calls of `info`. `depth_store` keeps the depth for readback or discards it;
    /// `timestamps` times the pass on the GPU.
    pub fn encode_pass(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        info: &FrameInfo,
        color: &wgpu::TextureView,
        depth: &wgpu::TextureView,
        depth_store: wgpu::StoreOp,
        timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let [r, g, b] = info.sky_linear;
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("terrain"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: color,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color { r, g, b, a: 1.0 }),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: depth,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(0.0),
                    store: depth_store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: timestamps,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        self.draw(&mut pass, info);
    }

    /// Records the terrain draw calls of `info` into `pass`.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, info: &FrameInfo) {
        pass.set_pipeline(if self.use_passthrough {
            &self.passthrough
        } else {
            &self.pipeline
        });
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.set_vertex_buffer(0, self.vertex_buffer.slice(..));
        pass.set_index_buffer(self.index_buffer.slice(..), wgpu::IndexFormat::Uint32);
        for range in &info.draw.ranges {
            pass.draw_indexed(range.clone(), 0, 0..1);
        }
    }
}

/// Background: blue sky low down, fading to black between 10 km and 1000 km.
fn sky_colour(altitude_m: f64) -> [f64; 3] {
    let t = ((altitude_m.max(1.0).log10() - 4.0) / 2.0).clamp(0.0, 1.0);
    let low = [0.30, 0.50, 0.80];
    let high = [0.002, 0.002, 0.006];
    std::array::from_fn(|i| low[i] + (high[i] - low[i]) * t)
}
