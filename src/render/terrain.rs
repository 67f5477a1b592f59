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
use crate::plan::{
    ClipmapPlan, CloseUpPlan, HeightSource, LodMethod, LodMode, LodSettings, TerrainQuery, ViewPlan,
};
use crate::stream::StreamSettings;
use crate::terrain::{Base, Terrain};

use super::RenderError;
use super::dem_feed::DemFeed;
use super::fill_analytic::FillJob;
use super::gpu_data::{self, BumpUniforms, FrameUniforms, LookUniforms};
use super::look::LookResources;
use super::placement::Placement;
use super::planar::PlanarResources;
use super::shader::MAX_LEVELS;

pub use super::gpu_data::Overlays;

mod draw;
mod frame_info;
mod passes;
mod pipelines;
mod readback;
mod resources;
mod shading;
mod switches;

pub use frame_info::FrameInfo;
pub use readback::{LevelBoundaryNoise, LevelNormals, LevelPartials};
pub use shading::{FAR_FOOTPRINT_M, Shading, bump_can_show, far_footprint_m};

use frame_info::SETTLE_BOUNDS_GRACE;
use passes::Passes;
use pipelines::{ClipmapPipelines, GridPipelines, PipelineParts, PlanarPipelines, WirePipelines};
use resources::{FrameBuffers, LevelTextures};
pub use switches::Switches;

pub struct TerrainRenderer {
    pub settings: ClipmapSettings,
    pub terrain: Terrain,
    pub overlays: Overlays,
    /// What tests and benchmarks switch (all off: the frame as planned).
    pub switches: Switches,
    mesh: RingMesh,
    bounds: SectorBounds,
    /// The ring mesh and the frame's uniforms, the level textures, and group 0 over them.
    buffers: FrameBuffers,
    textures: LevelTextures,
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
    /// Benchmark: a timestamp query set whose queries 2–3 bracket the frame's compute fill.
    pub fill_timestamps: Option<wgpu::QuerySet>,
    /// The fills (analytic, or the DEM's feed), the normals and the water cull.
    passes: Passes,
    /// The map-space window each level texture currently holds (None: never filled).
    grids: Vec<Option<LevelGrid>>,
    /// Which LOD method draws near the ground (`set_lod`).
    lod: LodSettings,
    /// The method `lod` names: what the clipmap fills and draws, and the close-up's plan.
    method: Box<dyn LodMethod>,
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

/// [`TerrainRenderer::query`] from the two fields alone (borrowed beside the method's state).
fn query_of<'a>(feed: &'a Option<DemFeed>, terrain: &'a Terrain) -> &'a dyn TerrainQuery {
    match feed {
        Some(feed) => feed.tiles(),
        None => terrain,
    }
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
        let mesh = RingMesh::build(&settings);
        let buffers = FrameBuffers::new(device, &mesh);
        let textures = LevelTextures::new(device, &settings, terrain.imagery().is_some());
        let passes = Passes::new(device, &settings, &terrain, &textures, stream)?;
        let look_resources = LookResources::new(device, color_format);
        let layout = resources::bind_group_layout(device);
        let bind_group = resources::bind_group(
            device,
            &layout,
            &buffers,
            &textures,
            &passes.detail,
            &look_resources,
        );
        let lod = LodSettings::default();
        let planar = PlanarResources::new(device, lod.geomip.patch_size);
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
        Ok(Self {
            grids: vec![None; settings.levels as usize],
            atmosphere: Atmosphere::earth(terrain.radius_m()),
            settings,
            terrain,
            overlays: Overlays::default(),
            switches: Switches::default(),
            bounds: SectorBounds::new(&mesh),
            mesh,
            buffers,
            textures,
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
            look_time_s: 0.0,
            last_camera: None,
            fill_timestamps: None,
            passes,
            method: crate::plan::lod::method(&lod),
            lod,
            planar,
            planar_pipelines: None,
            grid_pipelines: None,
            wire_pipelines: None,
            shading_pipelines: Vec::new(),
        })
    }

    /// The wireframe overlay's pipelines draw this frame.
    fn wire_drawn(&self) -> bool {
        self.overlays.wireframe && self.wire_pipelines.is_some() && !self.switches.use_passthrough
    }

    /// The clipmap's draws read the vertex pre-pass's vertices this frame.
    fn placed_drawn(&self) -> bool {
        self.place_pipelines.is_some() && !self.switches.use_passthrough && !self.wire_drawn()
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
        if lod != self.lod {
            self.method = crate::plan::lod::method(&lod);
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
        if !self.passes.detail.replace_detail(queue, detail.clone()) {
            return Err(RenderError::Gpu(
                "the renderer was built without detail or with another relief map size".into(),
            ));
        }
        if let Some(feed) = &mut self.passes.feed {
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
        self.passes.feed.as_ref()
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
        // Once settled: the fewest tiles the culling bounds lacked so far, since when, and the
        // failed reads by then.
        let mut grace: Option<(usize, std::time::Instant, u64)> = None;
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
                // image is whole, but with the tighter bounds the next frame plans otherwise
                // (`north-pole`: 532 sectors culled, then 308, the same draws). Wait for them
                // while they can come: until the deadline while the LRU has room for them and
                // no read has failed; else (they would leave as others arrive, or a read
                // fails) for the grace from the last time fewer were missing than before.
                let now = std::time::Instant::now();
                // The frame's culling runs after its feed update: its misses show only here.
                let missing = info.stream.as_ref().map_or(0, |s| s.tiles_missing as usize)
                    + self
                        .passes
                        .feed
                        .as_ref()
                        .map_or(0, |f| f.tiles().queries_missing());
                let failed = info.stream.as_ref().map_or(0, |s| s.stream.tiles_failed);
                let (fewest, since, failed_then) = grace.get_or_insert((missing, now, failed));
                if missing < *fewest {
                    (*fewest, *since) = (missing, now);
                }
                let room = info.stream.as_ref().is_some_and(|s| {
                    let per_tile = s.cache_bytes / (s.cache_tiles.max(1) as u64);
                    s.cache_bytes + missing as u64 * per_tile <= s.cache_budget
                });
                let waiting = if room && failed == *failed_then {
                    deadline
                } else {
                    deadline.min(*since + SETTLE_BOUNDS_GRACE)
                };
                if missing == 0 || now >= waiting {
                    return Ok(());
                }
                if let Some(feed) = &mut self.passes.feed {
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
            if let Some(feed) = &mut self.passes.feed
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
        // What to fill (f64), then the fills: which levels the tiles at hand could fill
        // decides what the levels hold.
        let (view, mut clipmap) = self.plan_levels(camera, width_px, height_px);
        let (texels_filled, stream, normal_jobs) =
            self.encode_fills(queue, encoder, &view, &clipmap);
        // What to draw once the fills are known (f64): a close-up's heights come from the
        // levels just filled, and the clipmap draws the levels it holds.
        let query = query_of(&self.passes.feed, &self.terrain);
        let close_up = self.method.plan_close_up(&view, query, &mut clipmap);
        self.plan_draws(&view, &mut clipmap);
        // Then the rest of the frame's GPU work, in the order the GPU runs it.
        let normals_written = self.encode_normals(queue, encoder, &normal_jobs);
        let planar = self.encode_close_up(queue, &view, close_up.as_ref());
        let (levels, bump, look, sky_ring) = self.upload_uniforms(queue, &view, &clipmap);
        self.begin_terrain_timing(encoder);
        // The sky from its table wherever the eye is inside the atmosphere (render::look).
        let inside = look.eye_radius_m < look.shell[1];
        self.look_resources.prepare_sky(
            encoder,
            self.look.sky && inside && !self.switches.sky_per_pixel,
        );
        if self.look.sky {
            self.look_resources.aerial.encode(encoder, &look);
        }
        let shading = self.choose_shading(&view, &clipmap, &levels, &bump);
        self.encode_water_cull(queue, encoder, (&view, &clipmap), &normals_written, &look);
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
        let view = ViewPlan::new(camera, width_px, height_px, self.query()).with_sun(self.look.sun);
        // At rest (the same camera twice), levels take their ideal φ spans: what is drawn then
        // does not depend on where the camera came from.
        let at_rest = self.last_camera == Some(*camera);
        self.last_camera = Some(*camera);
        let mut clipmap = ClipmapPlan::new(
            &view,
            &self.settings,
            &self.grids,
            self.query().height_range_m(),
            self.switches.draw_all_levels,
            !at_rest,
        );
        // The planar methods sample the levels around the nadir whether or not they are in
        // view, so only the clipmap alone leaves out-of-view levels unfilled.
        if self.method.fills_only_levels_in_view() && !self.switches.draw_all_levels {
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
        match (self.terrain.base(), &mut self.passes.feed) {
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
                let texels = self.passes.fill.encode(
                    queue,
                    encoder,
                    planet,
                    &self.passes.detail,
                    &jobs,
                    timestamps,
                );
                (texels, None, jobs)
            }
            (Base::Dem(_), Some(feed)) => {
                let nadir = (view.phi_v_rad, view.theta_v_rad);
                let (filled, texels) = feed.update(
                    queue,
                    encoder,
                    &clipmap.fills,
                    nadir,
                    &self.passes.detail,
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
        self.passes.normals.encode(
            queue,
            encoder,
            normal_jobs,
            self.terrain.radius_m(),
            |level| detail.map_or(0, |d| d.level_octaves(level, blend).partial),
            normal_timestamps,
        )
    }

    /// The close-up method's GPU data for its plan (the f64 → f32 step), or none drawn.
    fn encode_close_up(
        &self,
        queue: &wgpu::Queue,
        view: &ViewPlan,
        plan: Option<&CloseUpPlan>,
    ) -> Option<PlanarDraw> {
        match plan {
            Some(CloseUpPlan::Grid { plan, ray_cast }) => {
                Some(self.planar.write_grid(queue, view, plan, *ray_cast))
            }
            Some(CloseUpPlan::Geomip(plan)) => Some(self.planar.write_geomip(queue, view, plan)),
            None => {
                self.planar.write_inactive(queue);
                None
            }
        }
    }

    /// What the clipmap draws: the levels whose grids are held, their densities and the
    /// sectors in view (nothing where the projected grid covers the view).
    fn plan_draws(&self, view: &ViewPlan, clipmap: &mut ClipmapPlan) {
        clipmap.limit_to_held(&self.grids);
        clipmap.density_map = self.switches.density_map;
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
            self.switches.draw_all_sectors,
        );
        if !self.method.clipmap_draws() {
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
        queue.write_buffer(&self.buffers.levels, 0, bytemuck::cast_slice(&levels));
        let uniforms =
            FrameUniforms::from_plan(view, clipmap, &self.settings, self.overlays, detail);
        queue.write_buffer(&self.buffers.frame, 0, bytemuck::bytes_of(&uniforms));
        let mut bump = BumpUniforms::new(view, detail);
        if self.switches.naive_bump {
            bump.lambda_px = [f32::MAX, 0.0, bump.lambda_px[2], 0.0];
        }
        queue.write_buffer(&self.buffers.bump, 0, bytemuck::bytes_of(&bump));
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
        let sky_ring = if self.look.sky && !self.switches.sky_whole_frame {
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
        if self.look.sky {
            look.aerial = super::aerial::slices(
                view.radius_m + view.camera.altitude_m,
                view.radius_m,
                self.terrain.height_range_m(),
                self.atmosphere.top_radius_m(),
            );
        }
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
            .filter(|_| !self.switches.use_passthrough)
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
                && !self.switches.all_shading
                && far_footprint_m(view, highest_m) >= FAR_FOOTPRINT_M,
            // Seen from high enough, every octave of two pixels is in the levels' geometry.
            // Without detail `BUMP` compiles nothing: keep the default pipelines.
            bump: self.switches.all_shading
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

    /// With water: the cull over the frame's draws (which may leave the water's shading out),
    /// from the normals just written.
    fn encode_water_cull(
        &mut self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        (view, clipmap): (&ViewPlan, &ClipmapPlan),
        normals_written: &[SlotRect],
        look: &LookUniforms,
    ) {
        let Some(cull) = &mut self.passes.water_cull else {
            return;
        };
        let entries: Vec<u32> = (clipmap.draw.levels.iter().zip(&clipmap.draw.variants))
            .map(|(&l, &v)| super::water_cull::draw_entry(l, v != Variant::Plain))
            .collect();
        let boxes = super::water_cull::level_boxes(&self.grids, view.phi_v_rad, view.theta_v_rad);
        cull.encode(
            queue,
            encoder,
            super::water_cull::CullFrame {
                written: normals_written,
                ranges: &clipmap.draw.ranges,
                entries,
                boxes,
                water_level_m: look.water_level_m,
            },
        );
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
        query_of(&self.passes.feed, &self.terrain)
    }
}
