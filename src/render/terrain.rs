//! The terrain pass: the static ring mesh drawn with the level textures (spherical-clipmaps.md).
//!
//! Per frame the CPU plans in f64 what to draw and which texels moved (`crate::plan`),
//! `gpu_data` turns the plan into f32 uniforms, and the GPU does the per-texel (compute fill)
//! and per-vertex (map transform, displacement) work.

use super::dem_feed::FeedFrame;
use super::gpu_data::LevelUniforms;
use super::normals::SlotRect;
use super::planar::PlanarDraw;

use crate::clipmap::draw_list::{SectorBounds, Variant};
use crate::clipmap::levels::LevelGrid;
use crate::clipmap::{ClipmapSettings, RingMesh};
use crate::geo::camera::Camera;
use crate::look::{Atmosphere, LookSettings, SkyRing};
use crate::plan::clipmap::DensityMap;
use crate::plan::{
    ClipmapPlan, GeomipState, HeightSource, LodMode, LodSettings, TerrainQuery, ViewPlan,
};
use crate::stream::StreamSettings;
use crate::terrain::{Base, Terrain};

use super::RenderError;
use super::dem_feed::DemFeed;
use super::detail::DetailResources;
use super::fill::{FillJob, FillPass};
use super::gpu_data::{self, BumpUniforms, FrameUniforms, LookUniforms};
use super::look::LookResources;
use super::normals::NormalPass;
use super::placement::Placement;
use super::planar::PlanarResources;
use super::shader::MAX_LEVELS;
use super::water_cull::WaterCull;

pub use super::gpu_data::Overlays;

mod frame_info;
mod pipelines;
mod readback;
mod resources;
mod shading;

pub use frame_info::FrameInfo;
pub use readback::{LevelNormals, LevelPartials};
pub use shading::{FAR_FOOTPRINT_M, Shading, bump_can_show, far_footprint_m};

use frame_info::SETTLE_BOUNDS_GRACE;
use pipelines::{ClipmapPipelines, GridPipelines, PipelineParts, PlanarPipelines, WirePipelines};
use resources::{FrameBuffers, LevelTextures};

pub struct TerrainRenderer {
    pub settings: ClipmapSettings,
    pub terrain: Terrain,
    pub overlays: Overlays,
    /// Debug: draw every level of the mesh regardless of the visibility bounds (tests use it to
    /// show that the levels the bounds skip contribute nothing to the image).
    pub draw_all_levels: bool,
    /// Debug: draw every sector, including those outside the frustum.
    pub draw_all_sectors: bool,
    /// Test hook: changes every drawn level's ring density after the plan chose it.
    pub density_map: Option<DensityMap>,
    mesh: RingMesh,
    bounds: SectorBounds,
    vertex_buffer: wgpu::Buffer,
    index_buffer: wgpu::Buffer,
    frame_buffer: wgpu::Buffer,
    levels_buffer: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    /// One per shader variant: plain, with the coarse-level blend, with the density morph
    /// (`clipmap::draw_list::Variant`, in that order), with and without the water's shading.
    pipelines: ClipmapPipelines,
    /// Same vertices and triangles, flat and untextured (benchmark reference).
    passthrough: wgpu::RenderPipeline,
    /// The vertex pre-pass (`render::placement`): its buffers and, per variant, its pipeline
    /// (None while the vertex stage places the vertices itself).
    placement: Option<Placement>,
    place_pipelines: Option<[wgpu::ComputePipeline; 3]>,
    /// This frame's terrain timing started before the pass (query 0 written by `prepare`).
    timing_started: bool,
    /// The last frame's vertices came from the pre-pass.
    frame_placed: bool,
    pipeline_parts: PipelineParts,
    /// What of the look is drawn (`set_look`).
    look: LookSettings,
    look_resources: LookResources,
    /// The atmosphere's media (the sky and the haze).
    pub atmosphere: Atmosphere,
    /// Seconds of wave motion (0 in PNGs and measurements; the viewer's clock).
    pub look_time_s: f64,
    /// The camera of the last frame prepared (a camera at rest drops the φ-span hysteresis).
    last_camera: Option<Camera>,
    /// Debug/benchmark: draw with the pass-through pipeline instead of the terrain's.
    pub use_passthrough: bool,
    /// Tests: integrate the sky per pixel even where the sky-view table would serve.
    pub sky_per_pixel: bool,
    /// Tests: shade every frame with everything compiled in ([`Shading::ALL`]), as before
    /// [`FrameInfo::shading`].
    pub all_shading: bool,
    /// Tests: shade the sky over the whole frame, as before the ring ([`FrameInfo::sky_ring`]).
    pub sky_whole_frame: bool,
    /// Tests: draw every range with the water's shading, as before the water cull (which
    /// still runs; only the draws ignore it).
    pub ignore_water_cull: bool,
    /// Measurement: shade every bump octave whatever its size on screen (the naive policy the
    /// shimmer measurement compares against).
    pub naive_bump: bool,
    /// Benchmark: a timestamp query set whose queries 2–3 bracket the frame's compute fill.
    pub fill_timestamps: Option<wgpu::QuerySet>,
    fill: FillPass,
    /// The map-space window each level texture currently holds (None: never filled).
    grids: Vec<Option<LevelGrid>>,
    /// The DEM's streaming pipeline (None for the analytic planet).
    feed: Option<DemFeed>,
    heights: wgpu::Texture,
    /// The procedural detail's fill resources and the partial-octave level textures.
    detail: DetailResources,
    partials: wgpu::Texture,
    bump_buffer: wgpu::Buffer,
    /// Per-level world-frame normals (`render::normals`), filled after the heights.
    normals: wgpu::Texture,
    normal_pass: NormalPass,
    /// With water: which draws may leave its shading out (`render::water_cull`).
    water_cull: Option<WaterCull>,
    /// Which LOD method draws near the ground (`set_lod`).
    lod: LodSettings,
    /// `auto`'s current choice (hysteresis).
    auto_planar: bool,
    geomip_state: GeomipState,
    planar: PlanarResources,
    /// The clipmap variants that cut out the planar square, and the geomipmapping pipeline
    /// (built on first use).
    planar_pipelines: Option<PlanarPipelines>,
    /// The projected grid's (built on first use).
    grid_pipelines: Option<GridPipelines>,
    /// The wireframe overlay's (built when it is first switched on).
    wire_pipelines: Option<WirePipelines>,
    /// The clipmap's for frames that leave some shading out ([`Shading`]: each built on the
    /// first frame that needs it).
    shading_pipelines: Vec<(Shading, ClipmapPipelines)>,
}

/// Pixels added on each side of the sky ring ([`FrameInfo::sky_ring`]): the shader's f32 test
/// against the shell and the ring's f64 cones may disagree at their edges' pixels.
const SKY_RING_MARGIN_PX: f64 = 2.0;
/// Metres the sky ring's inner sphere lies below the terrain's lowest point: the mesh's chords
/// and the error budget keep the drawn surface within it.
const SKY_RING_INNER_MARGIN_M: f64 = 1000.0;
/// Distance of the sky ring's vertices from the eye: beyond all terrain (a planet's far side
/// from the Moon is 4·10⁸ m away), so their depth lies behind every terrain pixel.
const SKY_RING_DISTANCE_M: f64 = 1e10;

/// Fill dispatches a level may need in one frame. A level rewrites at most 2 rectangles of
/// at most S × S texels, each cut along the anchor lattice of S/2 blocks
/// (`GridRect::anchored_pieces`): 3 × 3 pieces; the DEM fill cuts further at the poles' fold
/// lines (2 more rows of pieces) and, for a regional grid, at the 360° wrap (1 more column);
/// a normal rectangle is widened by a texel (4 × 4 pieces).
const ANALYTIC_JOBS_PER_LEVEL: u32 = 2 * 3 * 3;
const DEM_JOBS_PER_LEVEL: u32 = 2 * 4 * 5;
const NORMAL_JOBS_PER_LEVEL: u32 = 2 * 4 * 4;

/// Settings the renderer can draw with `terrain`: valid on their own, within the per-level
/// uniform array, and a blend band the detail's octaves can follow.
fn check_settings(settings: &ClipmapSettings, terrain: &Terrain) -> Result<(), RenderError> {
    settings.validate()?;
    if settings.levels > MAX_LEVELS {
        return Err(RenderError::Settings(
            crate::clipmap::settings::SettingsError::Levels(settings.levels),
        ));
    }
    if let Some(d) = terrain.detail() {
        d.check_blend(settings.blend_fraction as f64)?;
    }
    Ok(())
}

/// The passes that read the level textures after each fill: the normals and, where the terrain
/// has water, the cull that proves levels dry.
fn derived_passes(
    device: &wgpu::Device,
    settings: &ClipmapSettings,
    terrain: &Terrain,
    textures: &LevelTextures,
) -> (NormalPass, Option<WaterCull>) {
    let normal_pass = NormalPass::new(
        device,
        NORMAL_JOBS_PER_LEVEL * settings.levels,
        &textures.heights_view,
        &textures.partials_view,
        &textures.normals_view,
    );

    let water_cull = terrain.water_level_m().is_some().then(|| {
        WaterCull::new(
            device,
            &textures.normals_view,
            settings.levels,
            settings.texture_size,
        )
    });
    (normal_pass, water_cull)
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
        check_settings(&settings, &terrain)?;
        let radius_m = terrain.radius_m();
        let mesh = RingMesh::build(&settings);
        let bounds = SectorBounds::new(&mesh);

        let buffers = FrameBuffers::new(device, &mesh);
        let textures = LevelTextures::new(device, &settings);
        let mut detail_resources = DetailResources::new(
            device,
            terrain.detail().cloned(),
            settings.blend_fraction as f64,
            DEM_JOBS_PER_LEVEL * settings.levels,
        );
        detail_resources.bind(device, &textures.partials_view);
        let (normal_pass, water_cull) = derived_passes(device, &settings, &terrain, &textures);
        let look_resources = LookResources::new(device, color_format);
        let layout = resources::bind_group_layout(device);
        let lod = LodSettings::default();
        let planar = PlanarResources::new(device, lod.geomip.patch_size);
        let bind_group = resources::bind_group(
            device,
            &layout,
            &buffers,
            &textures,
            &detail_resources,
            &look_resources,
        );
        let placement = Placement::new(device, &mesh);
        let pipeline_parts = PipelineParts::new(
            device,
            &layout,
            planar.layout(),
            placement.as_ref(),
            color_format,
            &terrain,
            &settings,
        );
        let look = LookSettings::default();
        let (pipelines, passthrough, place_pipelines) = pipeline_parts.build(device, look);
        let mut fill = FillPass::new(
            device,
            ANALYTIC_JOBS_PER_LEVEL * settings.levels,
            &detail_resources,
        );
        fill.set_target(device, &textures.heights_view);
        let grids = vec![None; settings.levels as usize];
        let feed = match terrain.base() {
            Base::Dem(dem) => Some(DemFeed::for_levels(
                device,
                dem.clone(),
                stream,
                DEM_JOBS_PER_LEVEL * settings.levels,
                &detail_resources,
                &textures.heights_view,
                terrain.water_level_m(),
            )?),
            Base::Analytic(_) => None,
        };
        Ok(Self {
            settings,
            terrain,
            overlays: Overlays::default(),
            draw_all_levels: false,
            draw_all_sectors: false,
            density_map: None,
            mesh,
            bounds,
            vertex_buffer: buffers.vertices,
            index_buffer: buffers.indices,
            frame_buffer: buffers.frame,
            levels_buffer: buffers.levels,
            bind_group,
            pipelines,
            passthrough,
            placement,
            place_pipelines,
            timing_started: false,
            frame_placed: false,
            pipeline_parts,
            look,
            look_resources,
            atmosphere: Atmosphere::earth(radius_m),
            look_time_s: 0.0,
            last_camera: None,
            use_passthrough: false,
            sky_whole_frame: false,
            all_shading: false,
            ignore_water_cull: false,
            sky_per_pixel: false,
            naive_bump: false,
            fill_timestamps: None,
            fill,
            grids,
            feed,
            heights: textures.heights,
            detail: detail_resources,
            partials: textures.partials,
            bump_buffer: buffers.bump,
            normals: textures.normals,
            normal_pass,
            water_cull,
            lod,
            auto_planar: false,
            geomip_state: GeomipState::default(),
            planar,
            planar_pipelines: None,
            grid_pipelines: None,
            wire_pipelines: None,
            shading_pipelines: Vec::new(),
        })
    }

    /// The projected grid covers the view this frame (its pipelines are built).
    fn grid_drawn(&self) -> bool {
        self.lod.mode == LodMode::Projgrid && self.grid_pipelines.is_some()
    }

    /// The wireframe overlay's pipelines draw this frame.
    fn wire_drawn(&self) -> bool {
        self.overlays.wireframe && self.wire_pipelines.is_some() && !self.use_passthrough
    }

    /// The clipmap's draws read the vertex pre-pass's vertices this frame.
    fn placed_drawn(&self) -> bool {
        self.place_pipelines.is_some() && !self.use_passthrough && !self.wire_drawn()
    }

    /// Measurement: the vertex stage places the clipmap's vertices itself, as before the
    /// vertex pre-pass (`render::placement`); off by default, on where the device cannot hold
    /// the pre-pass's buffer (then it stays on). Rebuilds the pipelines.
    pub fn set_place_in_vertex_stage(&mut self, on: bool) {
        let on = on || self.placement.is_none();
        if on != self.pipeline_parts.vertex_stage {
            self.pipeline_parts.vertex_stage = on;
            let device = self.pipeline_parts.device.clone();
            self.rebuild_pipelines(&device);
        }
    }

    /// Vertices the last frame's pre-pass placed (0 when the vertex stage places them).
    pub fn vertices_placed(&self) -> u64 {
        match (&self.placement, self.frame_placed) {
            (Some(p), true) => p.placed_last_frame(),
            _ => 0,
        }
    }

    /// The last frame's pre-pass reused the work lists of the frame before (same ranges).
    pub fn placement_lists_reused(&self) -> bool {
        self.frame_placed
            && self
                .placement
                .as_ref()
                .is_some_and(|p| p.reused_last_frame())
    }

    /// The wireframe overlay on or off (builds its pipelines the first time).
    pub fn set_wireframe(&mut self, device: &wgpu::Device, on: bool) {
        self.overlays.wireframe = on;
        if on && self.wire_pipelines.is_none() {
            self.wire_pipelines = Some(self.pipeline_parts.build_wire(
                device,
                self.look,
                self.lod.geomip.geomorph,
            ));
        }
        self.build_grid_pipelines(device);
    }

    /// The projected grid's pipelines (and its wireframe's), when its mode is on.
    fn build_grid_pipelines(&mut self, device: &wgpu::Device) {
        if self.lod.mode != LodMode::Projgrid {
            return;
        }
        if self.grid_pipelines.is_none() {
            self.grid_pipelines = Some(self.pipeline_parts.build_grid(device, self.look));
        }
        if let Some(w) = &mut self.wire_pipelines
            && w.grid.is_none()
        {
            let parts = &self.pipeline_parts;
            w.grid = Some(GridPipelines {
                plain: parts.grid_pipeline(device, self.look, "vs_projgrid_wire", "fs_main"),
                ray_cast: parts.grid_pipeline(
                    device,
                    self.look,
                    "vs_projgrid_wire",
                    "fs_projgrid_ray",
                ),
            });
        }
    }

    /// Which LOD method draws near the ground from the next frame on.
    pub fn set_lod(&mut self, device: &wgpu::Device, lod: LodSettings) {
        self.planar.set_patch_size(device, lod.geomip.patch_size);
        if lod.geomip != self.lod.geomip {
            self.geomip_state = GeomipState::default();
        }
        if lod.geomip.geomorph != self.lod.geomip.geomorph {
            self.planar_pipelines = None;
            if self.wire_pipelines.is_some() {
                self.wire_pipelines = Some(self.pipeline_parts.build_wire(
                    device,
                    self.look,
                    lod.geomip.geomorph,
                ));
            }
        }
        if matches!(lod.mode, LodMode::Geomip | LodMode::Auto) && self.planar_pipelines.is_none() {
            self.planar_pipelines = Some(self.pipeline_parts.build_planar(
                device,
                self.look,
                lod.geomip.geomorph,
            ));
        }
        if lod.mode == LodMode::Projgrid {
            self.planar
                .set_grid_size(device, lod.projgrid.cols, lod.projgrid.rows);
        }
        self.lod = lod;
        self.build_grid_pipelines(device);
    }

    /// The LOD methods' settings.
    pub fn lod(&self) -> LodSettings {
        self.lod
    }

    /// Replaces the procedural detail (the editor's change: same relief map size, other
    /// parameters or paint) without rebuilding anything: uploads the relief map and forgets
    /// every level's window, so the next [`TerrainRenderer::prepare`] refills every level
    /// once, as on the first frame. Refused when the renderer was built without detail (its
    /// pipelines leave the detail out) or the detail does not fit the clipmap settings.
    pub fn set_detail(
        &mut self,
        queue: &wgpu::Queue,
        detail: std::sync::Arc<crate::procedural::Detail>,
    ) -> Result<(), RenderError> {
        detail.check_blend(self.settings.blend_fraction as f64)?;
        if !self.detail.replace_detail(queue, detail.clone()) {
            return Err(RenderError::Gpu(
                "the renderer was built without detail or with another relief map size".into(),
            ));
        }
        if let Some(feed) = &mut self.feed {
            feed.set_detail(Some(detail.clone()));
        }
        self.terrain = self.terrain.clone().with_detail_of(Some(detail));
        self.grids.iter_mut().for_each(|g| *g = None);
        Ok(())
    }

    /// The static ring mesh.
    pub fn mesh(&self) -> &RingMesh {
        &self.mesh
    }

    /// The streaming pipeline, for a DEM.
    pub fn feed(&self) -> Option<&DemFeed> {
        self.feed.as_ref()
    }

    /// Renders nothing but runs frames for `camera` (streaming, uploads, fills) until every
    /// tile the view needs has arrived or `timeout` passes; returns whether it settled. The
    /// headless renderer calls it before the frame it keeps (`globe render` without
    /// `--no-wait`). See [`TerrainRenderer::settle_or_explain`].
    pub fn settle(
        &mut self,
        ctx: &super::GpuContext,
        camera: &Camera,
        width_px: u32,
        height_px: u32,
        timeout: std::time::Duration,
    ) -> bool {
        self.settle_or_explain(ctx, camera, width_px, height_px, timeout)
            .is_ok()
    }

    /// [`TerrainRenderer::settle`], saying why not: [`RenderError::NotSettled`] with what the
    /// last frame was still waiting for, or at once [`RenderError::GpuTilesShort`] when a
    /// level of the view (once its camera height is final) can never fit the GPU tile cache.
    pub fn settle_or_explain(
        &mut self,
        ctx: &super::GpuContext,
        camera: &Camera,
        width_px: u32,
        height_px: u32,
        timeout: std::time::Duration,
    ) -> Result<(), RenderError> {
        let deadline = std::time::Instant::now() + timeout;
        let mut first_settled = None;
        loop {
            let mut encoder = ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("settle"),
                });
            let info = self.prepare(&ctx.queue, &mut encoder, camera, width_px, height_px);
            ctx.queue.submit([encoder.finish()]);
            if info.settled() {
                // A settled frame may still lack tiles wanted only for the culling bounds: its
                // image is whole, but with the tighter bounds the next frame culls other
                // sectors (`north-pole`, one run in six: 17 984 triangles, then 10 486). Wait a little for them, so that the frame settled is the
                // one the view keeps; a budget too small to hold them costs only the grace.
                let now = std::time::Instant::now();
                let settled_at = *first_settled.get_or_insert(now);
                // The frame's culling runs after its feed update: its misses show only here.
                let bounds_missing = info.stream.as_ref().is_some_and(|s| s.tiles_missing > 0)
                    || self.feed.as_ref().is_some_and(DemFeed::queries_missed);
                if !bounds_missing || now >= deadline.min(settled_at + SETTLE_BOUNDS_GRACE) {
                    return Ok(());
                }
                if let Some(feed) = &mut self.feed {
                    feed.wait_for_tile(std::time::Duration::from_millis(50));
                }
                continue;
            }
            // The levels wanted follow the camera's height: final once it is no stand-in.
            if let Some(short) = info.stream.as_ref().and_then(|s| s.gpu_tiles_short)
                && info.ground_source != HeightSource::CoarserTiles
            {
                return Err(RenderError::GpuTilesShort(short));
            }
            let now = std::time::Instant::now();
            if now >= deadline {
                return Err(RenderError::NotSettled {
                    timeout_s: timeout.as_secs_f64(),
                    waiting_for: info.waiting_for(),
                    file_change: info
                        .stream
                        .as_ref()
                        .and_then(|s| s.file_change.clone().map(Box::new)),
                    last_error: info.stream.and_then(|s| s.last_error),
                });
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

    /// Plans the frame (`crate::plan`, f64), records the texture updates it asks for into
    /// `encoder` and writes the frame's uniforms (`gpu_data`, the f64 → f32 step). Call before
    /// `draw`, with the same viewport.
    pub fn prepare(
        &mut self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        camera: &Camera,
        width_px: u32,
        height_px: u32,
    ) -> FrameInfo {
        // From the tiles at hand when streaming: a frame never waits for the file (a read of
        // it from in here is counted: `dem::frame_reads`).
        let _frame = crate::dem::frame_reads::frame_scope();
        if self.overlays.levels != self.pipeline_parts.level_overlay {
            self.pipeline_parts.level_overlay = self.overlays.levels;
            let device = self.pipeline_parts.device.clone();
            self.rebuild_pipelines(&device);
        }
        let (view, mut clipmap) = self.plan_levels(camera, width_px, height_px);
        let (texels_filled, stream, normal_jobs) =
            self.encode_fills(queue, encoder, &view, &clipmap);
        let normals_written = self.encode_normals(queue, encoder, &normal_jobs);
        let planar = self.plan_close_up(queue, &view, &mut clipmap);
        self.plan_draws(&view, &mut clipmap);
        let (levels, bump, look, sky_ring) = self.upload_uniforms(queue, &view, &clipmap);
        self.begin_terrain_timing(encoder);
        // The sky from its table wherever the eye is inside the atmosphere (render::look).
        let inside = look.eye_radius_m < look.shell[1];
        self.look_resources
            .prepare_sky(encoder, self.look.sky && inside && !self.sky_per_pixel);
        let shading = self.choose_shading(&view, &clipmap, &levels, &bump);
        if let Some(cull) = &mut self.water_cull {
            let entries: Vec<u32> = (clipmap.draw.levels.iter().zip(&clipmap.draw.variants))
                .map(|(&l, &v)| super::water_cull::draw_entry(l, v != Variant::Plain))
                .collect();
            let boxes =
                super::water_cull::level_boxes(&self.grids, view.phi_v_rad, view.theta_v_rad);
            cull.encode(
                queue,
                encoder,
                super::water_cull::CullFrame {
                    written: &normals_written,
                    ranges: &clipmap.draw.ranges,
                    entries,
                    boxes,
                    water_level_m: look.water_level_m,
                },
            );
        }
        self.encode_placement(queue, encoder, &clipmap.draw.pieces);

        // A frame whose camera height came from coarser tiles than its own is not settled,
        // even if those tiles have arrived meanwhile.
        let mut stream = stream;
        if let Some(st) = &mut stream {
            st.complete &= view.ground_source != HeightSource::CoarserTiles;
        }
        FrameInfo {
            selection: clipmap.selection,
            densities: clipmap.densities,
            draw: clipmap.draw,
            texels_filled,
            near_m: view.near_m,
            height_above_terrain_m: view.height_above_terrain_m,
            ground_source: view.ground_source,
            sky_linear: view.sky_linear,
            sky_ring,
            shading,
            stream,
            planar,
        }
    }

    /// The frame's view and the clipmap's levels and fills for it (plan, f64).
    fn plan_levels(
        &mut self,
        camera: &Camera,
        width_px: u32,
        height_px: u32,
    ) -> (ViewPlan, ClipmapPlan) {
        let view = ViewPlan::new(camera, width_px, height_px, self.query());
        // At rest (the same camera twice), levels take their ideal φ spans: what is drawn then
        // does not depend on where the camera came from.
        let at_rest = self.last_camera == Some(*camera);
        self.last_camera = Some(*camera);
        let mut clipmap = ClipmapPlan::new(
            &view,
            &self.settings,
            &self.grids,
            self.query().height_range_m(),
            self.draw_all_levels,
            !at_rest,
        );
        // The planar methods sample the levels around the nadir whether or not they are in
        // view, so only the clipmap alone leaves out-of-view levels unfilled.
        if self.lod.mode == LodMode::Clipmap && !self.draw_all_levels {
            clipmap.limit_to_view(&view, self.query());
        }
        (view, clipmap)
    }

    /// Encodes the plan's fills (analytic, or the DEM's from the tiles at hand) and records
    /// the grids they leave: the texels written, the stream's frame, and the rectangles the
    /// normal pass must follow.
    fn encode_fills(
        &mut self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        view: &ViewPlan,
        clipmap: &ClipmapPlan,
    ) -> (u64, Option<FeedFrame>, Vec<FillJob>) {
        // The fill's pass starts the fill timing, the normal pass ends it (query 3 is written
        // by whichever runs last: the normal pass runs whenever a fill wrote something).
        let timestamps = self
            .fill_timestamps
            .as_ref()
            .map(|q| wgpu::ComputePassTimestampWrites {
                query_set: q,
                beginning_of_pass_write_index: Some(2),
                end_of_pass_write_index: Some(3),
            });
        match (self.terrain.base(), &mut self.feed) {
            (Base::Analytic(planet), _) => {
                let fills = clipmap.fills.iter().filter(|f| !f.defer);
                let jobs: Vec<FillJob> = fills
                    .clone()
                    .flat_map(|fill| {
                        fill.rects.iter().map(|rect| FillJob {
                            grid: fill.grid,
                            rect: *rect,
                        })
                    })
                    .collect();
                for fill in fills {
                    self.grids[fill.grid.level as usize] = Some(fill.grid);
                }
                let texels =
                    self.fill
                        .encode(queue, encoder, planet, &self.detail, &jobs, timestamps);
                (texels, None, jobs)
            }
            (Base::Dem(_), Some(feed)) => {
                let nadir = (view.phi_v_rad, view.theta_v_rad);
                let (filled, texels) = feed.update(
                    queue,
                    encoder,
                    &clipmap.fills,
                    nadir,
                    &self.detail,
                    timestamps,
                );
                let mut done = Vec::new();
                for (fill, ok) in clipmap.fills.iter().zip(filled) {
                    if ok {
                        self.grids[fill.grid.level as usize] = Some(fill.grid);
                        done.extend(fill.rects.iter().map(|rect| FillJob {
                            grid: fill.grid,
                            rect: *rect,
                        }));
                    }
                }
                (texels, Some(feed.last.clone()), done)
            }
            (Base::Dem(_), None) => unreachable!("a DEM renderer always has a feed"),
        }
    }

    /// Encodes the normals of the rectangles the fills wrote; which texels they cover (the
    /// water cull reads them).
    fn encode_normals(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        normal_jobs: &[FillJob],
    ) -> Vec<SlotRect> {
        let detail = self.terrain.detail().map(|d| d.as_ref());
        let blend = self.settings.blend_fraction as f64;
        let normal_timestamps =
            self.fill_timestamps
                .as_ref()
                .map(|q| wgpu::ComputePassTimestampWrites {
                    query_set: q,
                    beginning_of_pass_write_index: None,
                    end_of_pass_write_index: Some(3),
                });
        self.normal_pass.encode(
            queue,
            encoder,
            normal_jobs,
            self.terrain.radius_m(),
            |level| detail.map_or(0, |d| d.level_octaves(level, blend).partial),
            normal_timestamps,
        )
    }

    /// A planar method near the viewer: its plan and GPU data (its heights come from the
    /// levels just filled); the clipmap's cut around it.
    fn plan_close_up(
        &mut self,
        queue: &wgpu::Queue,
        view: &ViewPlan,
        clipmap: &mut ClipmapPlan,
    ) -> Option<PlanarDraw> {
        let grid_on = self.grid_drawn();
        let planar_on = self
            .lod
            .mode
            .planar(view.height_above_terrain_m, self.auto_planar)
            && self.planar_pipelines.is_some();
        self.auto_planar = planar_on;
        if grid_on {
            let plan = crate::plan::projgrid::plan(view, &self.lod.projgrid, self.query());
            Some(
                self.planar
                    .write_grid(queue, view, &plan, self.lod.projgrid.ray_cast),
            )
        } else if planar_on {
            let mut state = std::mem::take(&mut self.geomip_state);
            let plan = state.plan(view, &self.lod.geomip, self.query());
            self.geomip_state = state;
            clipmap.covered_rad = plan.covered_rad;
            clipmap.cut_rad = plan.cut_reach_rad;
            Some(self.planar.write_geomip(queue, view, &plan))
        } else {
            self.planar.write_inactive(queue);
            None
        }
    }

    /// What the clipmap draws: the levels whose grids are held, their densities and the
    /// sectors in view (nothing where the projected grid covers the view).
    fn plan_draws(&self, view: &ViewPlan, clipmap: &mut ClipmapPlan) {
        let grid_on = self.grid_drawn();
        clipmap.limit_to_held(&self.grids);
        clipmap.density_map = self.density_map;
        clipmap.density_caps = self.terrain.detail().map(|d| {
            crate::plan::clipmap::detail_density_caps(
                d,
                &self.settings,
                self.mesh.max_density,
                &crate::plan::clipmap::screen_scale(view),
            )
        });
        clipmap.cull(
            view,
            &self.settings,
            &self.mesh,
            &self.bounds,
            self.query(),
            self.draw_all_sectors,
        );
        if grid_on {
            // The grid covers the whole view: the levels fill the textures it samples but
            // draw nothing.
            clipmap.draw = Default::default();
        }
    }

    /// The frame's uniforms (the f64 → f32 step of `gpu_data`), and the sky's ring.
    fn upload_uniforms(
        &mut self,
        queue: &wgpu::Queue,
        view: &ViewPlan,
        clipmap: &ClipmapPlan,
    ) -> (
        Vec<LevelUniforms>,
        BumpUniforms,
        LookUniforms,
        Option<SkyRing>,
    ) {
        let detail = self.terrain.detail().map(|d| d.as_ref());
        let blend = self.settings.blend_fraction as f64;
        let levels = gpu_data::level_uniforms(view, &self.grids, &clipmap.densities, detail, blend);
        queue.write_buffer(&self.levels_buffer, 0, bytemuck::cast_slice(&levels));
        let uniforms =
            FrameUniforms::from_plan(view, clipmap, &self.settings, self.overlays, detail);
        queue.write_buffer(&self.frame_buffer, 0, bytemuck::bytes_of(&uniforms));
        let mut bump = BumpUniforms::new(view, detail);
        if self.naive_bump {
            bump.lambda_px = [f32::MAX, 0.0, bump.lambda_px[2], 0.0];
        }
        queue.write_buffer(&self.bump_buffer, 0, bytemuck::bytes_of(&bump));
        self.look_resources.upload(queue, self.look.mips);
        let mut look = LookUniforms::from_plan(
            view,
            &self.atmosphere,
            self.look,
            self.terrain.water_level_m(),
            self.look_time_s,
        );
        // From outside the shell, only the directions between the cone of rays that meet a
        // sphere under all terrain and the shell's cone need the sky's integral (a CPU
        // rasteriser pays for every pixel of a full-screen pass, even where each returns at
        // once). The terrain's lowest point is lowered by a kilometre for the mesh's chords.
        let sky_ring = if self.look.sky && !self.sky_whole_frame {
            let pixel_rad = 2.0 * (0.5 * view.fov_y_rad).tan() / f64::from(view.height_px.max(1));
            SkyRing::new(
                view.radius_m + view.camera.altitude_m,
                view.radius_m + self.terrain.height_range_m().0 - SKY_RING_INNER_MARGIN_M,
                self.atmosphere.top_radius_m(),
                SKY_RING_MARGIN_PX * pixel_rad,
            )
        } else {
            None
        };
        if let Some(ring) = sky_ring {
            look.sky_ring = [
                ring.tan_inner as f32,
                ring.tan_outer as f32,
                SKY_RING_DISTANCE_M as f32,
                0.0,
            ];
        }
        queue.write_buffer(&self.look_resources.uniforms, 0, bytemuck::bytes_of(&look));
        (levels, bump, look, sky_ring)
    }

    /// Benchmark: the terrain's time runs from here (the sky table, the water cull and the
    /// vertex pre-pass are the terrain pass's work too) to the terrain pass's end; the
    /// pass-through's is its pass alone.
    fn begin_terrain_timing(&mut self, encoder: &mut wgpu::CommandEncoder) {
        self.timing_started = false;
        if let Some(q) = self
            .fill_timestamps
            .as_ref()
            .filter(|_| !self.use_passthrough)
        {
            encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("terrain timing start"),
                timestamp_writes: Some(wgpu::ComputePassTimestampWrites {
                    query_set: q,
                    beginning_of_pass_write_index: Some(0),
                    end_of_pass_write_index: None,
                }),
            });
            self.timing_started = true;
        }
    }

    /// The shading variants the frame compiles in (built on the first frame that needs them).
    fn choose_shading(
        &mut self,
        view: &ViewPlan,
        clipmap: &ClipmapPlan,
        levels: &[LevelUniforms],
        bump: &BumpUniforms,
    ) -> Shading {
        // Seen from afar, the look's texture work is constant (FrameInfo::far).
        let highest_m = self.terrain.height_range_m().1;
        let shading = Shading {
            far: (self.look.textures || self.terrain.water_level_m().is_some())
                && !self.all_shading
                && far_footprint_m(view, highest_m) >= FAR_FOOTPRINT_M,
            // Seen from high enough, every octave of two pixels is in the levels' geometry.
            // Without detail `BUMP` compiles nothing: keep the default pipelines.
            bump: self.all_shading
                || !self.pipeline_parts.detail_on
                || bump_can_show(bump, levels, &clipmap.draw.levels, view, highest_m),
        };
        if shading != Shading::ALL
            && !self.overlays.wireframe
            && !self.shading_pipelines.iter().any(|(s, _)| *s == shading)
        {
            let device = self.pipeline_parts.device.clone();
            let pipelines = self
                .pipeline_parts
                .build_shading(&device, self.look, shading);
            self.shading_pipelines.push((shading, pipelines));
        }
        shading
    }

    /// The vertex pre-pass over the draw list's pieces, where the frame's draws read it.
    fn encode_placement(
        &mut self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        pieces: &[(std::ops::Range<u32>, Variant)],
    ) {
        self.frame_placed = false;
        if let (true, Some(placement), Some(pipelines)) = (
            self.placed_drawn() && !pieces.is_empty(),
            &mut self.placement,
            &self.place_pipelines,
        ) {
            placement.encode(
                &self.pipeline_parts.device,
                queue,
                encoder,
                pieces,
                pipelines,
                &self.bind_group,
            );
            self.frame_placed = true;
        }
    }

    /// What of the look is drawn.
    pub fn look(&self) -> LookSettings {
        self.look
    }

    /// Draws with `look` from the next frame on (rebuilds the pipelines when the compiled
    /// parts change; the textures' mips change at the next `prepare`).
    pub fn set_look(&mut self, device: &wgpu::Device, look: LookSettings) {
        let compiled = |l: LookSettings| (l.textures, l.sky);
        if compiled(look) != compiled(self.look) {
            self.look = look;
            self.rebuild_pipelines(device);
        }
        self.look = look;
    }

    /// Rebuilds every pipeline built so far from the current look and overlays (they are
    /// pipeline constants).
    fn rebuild_pipelines(&mut self, device: &wgpu::Device) {
        let look = self.look;
        (self.pipelines, self.passthrough, self.place_pipelines) =
            self.pipeline_parts.build(device, look);
        if self.planar_pipelines.is_some() {
            self.planar_pipelines = Some(self.pipeline_parts.build_planar(
                device,
                look,
                self.lod.geomip.geomorph,
            ));
        }
        if self.wire_pipelines.is_some() {
            self.wire_pipelines = Some(self.pipeline_parts.build_wire(
                device,
                look,
                self.lod.geomip.geomorph,
            ));
        }
        self.grid_pipelines = None;
        self.shading_pipelines.clear();
        self.build_grid_pipelines(device);
    }

    /// Where the frame plan's terrain questions are answered: the streamed tiles for a DEM,
    /// the terrain function for the analytic planet.
    fn query(&self) -> &dyn TerrainQuery {
        match &self.feed {
            Some(feed) => feed,
            None => &self.terrain,
        }
    }

    /// Records a whole terrain pass: colour cleared to the sky, depth cleared to 0 (reversed-Z),
    /// then the draw calls of `info`. `depth_store` keeps the depth for readback or discards it;
    /// `timestamps` times the pass on the GPU (from the work `prepare` recorded after the fill
    /// when it started the timing there).
    pub fn encode_pass(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        info: &FrameInfo,
        color: &wgpu::TextureView,
        depth: &wgpu::TextureView,
        depth_store: wgpu::StoreOp,
        timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        // With the sky on, its pass shades every pixel the terrain leaves, black beyond the
        // shell: the clear colour shows only outside `sky_ring`, where the pass would be black.
        let [r, g, b] = if self.look.sky && !self.use_passthrough {
            [0.0; 3]
        } else {
            info.sky_linear
        };
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
            timestamp_writes: timestamps.map(|t| wgpu::RenderPassTimestampWrites {
                beginning_of_pass_write_index: t
                    .beginning_of_pass_write_index
                    .filter(|_| !self.timing_started),
                ..t
            }),
            occlusion_query_set: None,
            multiview_mask: None,
        });
        self.draw(&mut pass, info);
    }

    /// Records the terrain draw calls of `info` into `pass`.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, info: &FrameInfo) {
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.set_bind_group(1, self.planar.bind_group(), &[]);
        pass.set_vertex_buffer(
            0,
            match (&self.placement, self.placed_drawn()) {
                (Some(p), true) => p.vertex_buffer().slice(..),
                _ => self.vertex_buffer.slice(..),
            },
        );
        pass.set_index_buffer(self.index_buffer.slice(..), wgpu::IndexFormat::Uint32);
        let mut current = None;
        let wire = self
            .wire_pipelines
            .as_ref()
            .filter(|_| self.overlays.wireframe && !self.use_passthrough);
        // The projected grid draws alone.
        if let Some(grid) = info.planar.as_ref().and_then(|p| p.grid.as_ref()) {
            if let Some(pipelines) = &self.grid_pipelines
                && !grid.indices.is_empty()
                && !self.use_passthrough
            {
                match wire.and_then(|w| w.grid.as_ref()) {
                    Some(w) => {
                        pass.set_pipeline(if grid.ray_cast { &w.ray_cast } else { &w.plain });
                        pass.draw(grid.indices.clone(), 0..1);
                    }
                    None => {
                        pass.set_pipeline(if grid.ray_cast {
                            &pipelines.ray_cast
                        } else {
                            &pipelines.plain
                        });
                        pass.set_index_buffer(
                            self.planar.grid_index_buffer().slice(..),
                            wgpu::IndexFormat::Uint32,
                        );
                        pass.draw_indexed(grid.indices.clone(), 0, 0..1);
                    }
                }
            }
            if self.look.sky && !self.use_passthrough {
                self.look_resources.draw_sky(pass, info.sky_ring);
            }
            return;
        }
        // With a planar method the clipmap leaves its square out.
        let planar = match (&info.planar, &self.planar_pipelines) {
            (Some(draw), Some(pipelines)) if !self.use_passthrough => Some((draw, pipelines)),
            _ => None,
        };
        let shaded = (self.shading_pipelines.iter())
            .find(|(s, _)| *s == info.shading)
            .map(|(_, p)| p);
        let uncut = match (wire, shaded) {
            (Some(w), _) => &w.clipmap,
            (None, Some(p)) => p,
            (None, None) => &self.pipelines,
        };
        let cull = self
            .water_cull
            .as_ref()
            .filter(|_| !self.use_passthrough && !self.ignore_water_cull);
        let cut = match (wire, planar) {
            (Some(w), Some(_)) => &w.clipmap_cut,
            (None, Some((_, p))) => &p.clipmap_cut,
            (_, None) => uncut,
        };
        for (i, (range, &variant)) in info.draw.ranges.iter().zip(&info.draw.variants).enumerate() {
            if range.is_empty() {
                continue;
            }
            // The pipeline set by (cut, variant): a range of the cut never reuses an uncut one.
            let in_cut = i >= info.draw.first_cut;
            let clipmap = if in_cut { cut } else { uncut };
            let v = match variant {
                Variant::Plain => 0,
                Variant::Blend => 1,
                Variant::Morph => 2,
            };
            if let (Some(cull), Some(dry)) = (cull, &clipmap.dry) {
                // Twice, each draw with the instance the water cull gave it or none.
                pass.set_pipeline(&dry[v]);
                pass.draw_indexed_indirect(cull.args(), WaterCull::offset(i, false));
                pass.set_pipeline(&clipmap.wet[v]);
                pass.draw_indexed_indirect(cull.args(), WaterCull::offset(i, true));
                current = Some((in_cut, variant));
                continue;
            }
            if current != Some((in_cut, variant)) {
                pass.set_pipeline(if self.use_passthrough {
                    &self.passthrough
                } else {
                    &clipmap.wet[v]
                });
                current = Some((in_cut, variant));
            }
            if wire.is_some() {
                pass.draw(range.clone(), 0..1);
            } else {
                pass.draw_indexed(range.clone(), 0, 0..1);
            }
        }
        if let Some((draw, pipelines)) = planar {
            match wire {
                Some(w) => pass.set_pipeline(&w.geomip),
                None => pass.set_pipeline(&pipelines.geomip),
            }
            pass.set_index_buffer(
                self.planar.index_buffer().slice(..),
                wgpu::IndexFormat::Uint32,
            );
            for (range, patch) in &draw.draws {
                if wire.is_some() {
                    pass.draw(range.clone(), *patch..*patch + 1);
                } else {
                    pass.draw_indexed(range.clone(), 0, *patch..*patch + 1);
                }
            }
        }
        if self.look.sky && !self.use_passthrough {
            self.look_resources.draw_sky(pass, info.sky_ring);
        }
    }
}
