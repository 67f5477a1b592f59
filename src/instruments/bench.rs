//! `globe bench`: a scene (or the `flight` path) rendered headless frame after frame, with
//! per-frame CPU time, GPU time (timestamp queries where the adapter has them), triangles,
//! levels and the streaming pipeline's counters, summarised as median/min/max.
//!
//! A named scene or a `--camera` view is benchmarked warm: streaming settles first, then
//! `warmup` frames, then the measured ones. The flight starts cold, as a user would: its frames never wait for tiles, and
//! afterwards the bench waits for streaming to settle and compares that last frame with a
//! fresh render that had everything loaded (`final_vs_loaded_px`).

use std::time::Instant;

use serde::Serialize;

use crate::clipmap::ClipmapSettings;
use crate::geo::camera::Camera;
use crate::look::LookSettings;
use crate::measure::ErrorStats;
use crate::render::dem_feed::FeedFrame;
use crate::render::formats::COLOR_FORMAT;
use crate::render::offscreen::{OffscreenFrame, RenderedFrame, SETTLE_TIMEOUT, TimedFrame};
use crate::render::timing::GpuTimer;
use crate::render::{GpuContext, RenderError, TerrainRenderer};
use crate::scenes::{self, CameraSpec, UnknownScene, flight};
use crate::stream::StreamSettings;
use crate::terrain::Terrain;

/// The `globe bench --scene` name of the jump benchmark ([`run_jump`]).
pub const JUMP: &str = "jump";
/// The scenes the jump goes from and to, looked up in the registry.
pub const JUMP_FROM: &str = "aircraft";
pub const JUMP_TO: &str = "everest";

/// Why a benchmark (or the report, which measures the same way) could not run.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error(transparent)]
    Scene(#[from] UnknownScene),
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error("`--scene {JUMP}` measures streaming: it needs a DEM (--dem), not the analytic planet")]
    JumpNeedsDem,
    #[error("cannot start the tile streamer: {0}")]
    Streamer(#[source] std::io::Error),
    #[error(transparent)]
    Measure(#[from] crate::measure::MeasureError),
}

#[derive(Clone, Debug)]
pub struct BenchOptions {
    /// A scene name, or `flight`; with [`BenchOptions::camera`] only the label of the view in
    /// the outputs ([`scenes::CAMERA_VIEW_NAME`]).
    pub scene: String,
    /// A view given as such (`--camera`), benchmarked instead of a named scene.
    pub camera: Option<CameraSpec>,
    /// A recorded path (`--path`), flown as `flight` is: its frames spread evenly over it.
    pub path: Option<crate::scenes::path::CameraPath>,
    pub frames: usize,
    pub warmup: usize,
    pub width: u32,
    pub height: u32,
    pub settings: ClipmapSettings,
    pub stream: StreamSettings,
    /// Also time the same frames with the pass-through pipeline (same triangles, no shading:
    /// the raster limit), named scenes only.
    pub passthrough: bool,
    /// Measure the error of a settled frame (ρ against the terrain function, coverage against
    /// the reference ray caster).
    pub measure_error: bool,
    /// Frames start at most this often (a viewer's frame rate: streaming gets the wall time a
    /// real flight gives it); None renders back to back.
    pub frame_interval: Option<std::time::Duration>,
    /// What of the look is drawn (timed with the frame; the error does not depend on it).
    pub look: LookSettings,
    /// The LOD methods (`--mode` and geomipmapping's settings).
    pub lod: crate::plan::LodSettings,
    /// Also time the same frames with the plain look (`LookSettings::plain`: no surface
    /// types, no atmosphere), named scenes only: the look's cost as a ratio in one run.
    pub compare_plain_look: bool,
    /// Also time the same frames with the vertex stage placing the clipmap's vertices itself
    /// instead of the vertex pre-pass (`render::placement`), named scenes only.
    pub compare_vertex_stage: bool,
}

/// One measured frame.
#[derive(Clone, Debug)]
pub struct FrameRecord {
    pub cpu_ms: f64,
    pub frame_ms: f64,
    pub gpu_ms: Option<f64>,
    /// The compute fill's GPU time, in frames that filled texels.
    pub fill_gpu_ms: Option<f64>,
    pub texels_filled: u64,
    pub triangles: u64,
    pub levels_drawn: u32,
    pub levels_waiting: u32,
    pub altitude_m: f64,
    pub stream: Option<FeedFrame>,
}

impl FrameRecord {
    fn of(f: &TimedFrame, camera: &Camera) -> Self {
        let sel = &f.info.selection;
        Self {
            cpu_ms: f.cpu_ms,
            frame_ms: f.frame_ms,
            gpu_ms: f.gpu_ms,
            fill_gpu_ms: f.fill_gpu_ms,
            texels_filled: f.info.texels_filled,
            triangles: f.info.triangles(),
            levels_drawn: if sel.any_drawn() {
                sel.finest - sel.coarsest + 1
            } else {
                0
            },
            levels_waiting: sel.waiting().len() as u32,
            altitude_m: camera.altitude_m,
            stream: f.info.stream.clone(),
        }
    }
}

/// One benchmark run's frames and findings.
pub struct BenchRun {
    pub adapter: String,
    pub options: BenchOptions,
    pub frames: Vec<FrameRecord>,
    /// Seconds from the end of the flight until streaming settled (flight only).
    pub settle_s: Option<f64>,
    pub settled: bool,
    /// Pixels of the settled last frame that differ from a render with everything loaded
    /// (flight only).
    pub final_vs_loaded_px: Option<usize>,
    /// The settled last frame (flight only), for error measurement.
    pub final_frame: Option<RenderedFrame>,
    pub final_camera: Camera,
    /// Error of the settled last frame (see [`BenchOptions::measure_error`]).
    pub error: Option<ErrorStats>,
    /// The pass-through pipeline's frames (see [`BenchOptions::passthrough`]).
    pub passthrough: Vec<FrameRecord>,
    /// The plain look's frames (see [`BenchOptions::compare_plain_look`]).
    pub plain_look: Vec<FrameRecord>,
    /// The vertex stage's frames (see [`BenchOptions::compare_vertex_stage`]).
    pub vertex_stage: Vec<FrameRecord>,
    pub wall_s: f64,
}

/// The view a run holds still, or None for the `flight` path and a recorded one.
fn fixed_view(options: &BenchOptions) -> Result<Option<CameraSpec>, UnknownScene> {
    if options.path.is_some() {
        return Ok(None);
    }
    match (&options.camera, options.scene.as_str()) {
        (Some(view), _) => Ok(Some(*view)),
        (None, flight::NAME) => Ok(None),
        (None, name) => scenes::find(name)
            .map(|s| Some(s.view()))
            .map_err(|e| e.also_known(&[flight::NAME, JUMP])),
    }
}

/// Median, minimum and maximum.
pub fn summary(values: &[f64]) -> Option<(f64, f64, f64)> {
    if values.is_empty() {
        return None;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    let median = if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    };
    Some((median, v[0], v[n - 1]))
}

/// Pixels whose colour differs in any channel.
pub fn pixels_differing(a: &RenderedFrame, b: &RenderedFrame) -> usize {
    a.rgba
        .chunks_exact(4)
        .zip(b.rgba.chunks_exact(4))
        .filter(|(p, q)| p != q)
        .count()
}

/// How a run's error measurement is watched (`--measure-timeout`, its progress line).
pub struct MeasureWatch<'a> {
    /// The reference ray cast stops past it ([`crate::measure::MeasureError::TimedOut`]).
    pub limit: Option<std::time::Duration>,
    /// `(pixels cast, pixels)`, about every [`crate::measure::PROGRESS_INTERVAL`].
    pub progress: &'a mut dyn FnMut(usize, usize),
}

/// Runs the benchmark. `progress(done, total)` is called after each frame; the error
/// measurement has no time limit.
pub fn run(
    ctx: &GpuContext,
    terrain: &Terrain,
    options: &BenchOptions,
    progress: impl FnMut(usize, usize),
) -> Result<BenchRun, BenchError> {
    let watch = MeasureWatch {
        limit: None,
        progress: &mut |_, _| {},
    };
    run_with(ctx, terrain, options, progress, watch)
}

/// [`run`], its error measurement watched by `measure`.
pub fn run_with(
    ctx: &GpuContext,
    terrain: &Terrain,
    options: &BenchOptions,
    mut progress: impl FnMut(usize, usize),
    measure: MeasureWatch<'_>,
) -> Result<BenchRun, BenchError> {
    let started = Instant::now();
    let view = fixed_view(options)?;
    let mut renderer = TerrainRenderer::with_streaming(
        &ctx.device,
        options.settings.clone(),
        terrain.clone(),
        COLOR_FORMAT,
        options.stream,
    )?;
    renderer.set_look(&ctx.device, options.look);
    renderer.set_lod(&ctx.device, options.lod);
    let timer = GpuTimer::new(ctx);
    let target = OffscreenFrame::new(&ctx.device, options.width, options.height);
    let rig = Rig {
        ctx,
        target: &target,
        timer: timer.as_ref(),
    };
    let ground = |lat: f64, lon: f64| terrain.height_at_lat_lon_m(lat, lon);
    let is_flight = view.is_none();
    let fixed = view.map(|v| v.camera(ground));
    let camera_of = |i: usize| match (fixed, &options.path) {
        (Some(c), _) => c,
        (None, Some(path)) => {
            let t = i as f64 / options.frames.saturating_sub(1).max(1) as f64;
            path.camera_at(t * path.duration_s())
        }
        (None, None) => flight::frame_camera(i, options.frames, ground),
    };
    if let Some(camera) = &fixed {
        warm_up(&rig, &mut renderer, camera, options)?;
    }
    let frames = measured_frames(&rig, &mut renderer, options, camera_of, &mut progress)?;
    let compared = match &fixed {
        Some(camera) => compare_still(&rig, &mut renderer, camera, options)?,
        None => Compared::default(),
    };
    let final_camera = camera_of(options.frames.saturating_sub(1));
    let mut end = if is_flight {
        settle_after_flight(&rig, &mut renderer, terrain, options, &final_camera)?
    } else {
        FlightEnd::default()
    };
    let error = if options.measure_error {
        let (frame, stats) = measure_final(
            &rig,
            &mut renderer,
            terrain,
            &final_camera,
            end.final_frame.take(),
            measure,
        )?;
        end.final_frame = Some(frame);
        Some(stats)
    } else {
        None
    };
    Ok(BenchRun {
        adapter: ctx.adapter_description(),
        error,
        passthrough: compared.passthrough,
        plain_look: compared.plain_look,
        vertex_stage: compared.vertex_stage,
        options: options.clone(),
        frames,
        settle_s: end.settle_s,
        settled: end.settled,
        final_vs_loaded_px: end.final_vs_loaded_px,
        final_frame: end.final_frame,
        final_camera,
        wall_s: started.elapsed().as_secs_f64(),
    })
}

/// What every frame of a run is drawn through, so the steps below take one argument for it
/// instead of three.
struct Rig<'a> {
    ctx: &'a GpuContext,
    target: &'a OffscreenFrame,
    timer: Option<&'a GpuTimer>,
}

impl Rig<'_> {
    /// One timed frame of `renderer` at `camera`.
    fn draw(
        &self,
        renderer: &mut TerrainRenderer,
        camera: &Camera,
    ) -> Result<TimedFrame, RenderError> {
        self.target
            .draw_timed(self.ctx, renderer, camera, self.timer)
    }

    /// `n` timed frames at one still camera, as records.
    fn records_at(
        &self,
        renderer: &mut TerrainRenderer,
        camera: &Camera,
        n: usize,
    ) -> Result<Vec<FrameRecord>, RenderError> {
        let mut records = Vec::new();
        for _ in 0..n {
            let f = self.draw(renderer, camera)?;
            records.push(FrameRecord::of(&f, camera));
        }
        Ok(records)
    }
}

/// A still view is measured warm: streaming settles first, then `warmup` untimed frames, so
/// the measured frames see neither missing tiles nor first-draw costs.
fn warm_up(
    rig: &Rig<'_>,
    renderer: &mut TerrainRenderer,
    camera: &Camera,
    options: &BenchOptions,
) -> Result<(), RenderError> {
    renderer.settle_or_explain(
        rig.ctx,
        camera,
        options.width,
        options.height,
        SETTLE_TIMEOUT,
    )?;
    for _ in 0..options.warmup {
        rig.draw(renderer, camera)?;
    }
    Ok(())
}

/// The measured frames, paced by [`BenchOptions::frame_interval`] when it is set so that
/// streaming gets the wall time a viewer would give it.
fn measured_frames(
    rig: &Rig<'_>,
    renderer: &mut TerrainRenderer,
    options: &BenchOptions,
    camera_of: impl Fn(usize) -> Camera,
    progress: &mut impl FnMut(usize, usize),
) -> Result<Vec<FrameRecord>, RenderError> {
    let mut frames = Vec::with_capacity(options.frames);
    let mut next_start = Instant::now();
    for i in 0..options.frames {
        if let Some(dt) = options.frame_interval {
            let now = Instant::now();
            if next_start > now {
                std::thread::sleep(next_start - now);
            }
            next_start = next_start.max(now) + dt;
        }
        let camera = camera_of(i);
        let f = rig.draw(renderer, &camera)?;
        frames.push(FrameRecord::of(&f, &camera));
        progress(i + 1, options.frames);
    }
    Ok(frames)
}

/// The frames of the comparisons a still view can make (empty where not asked for).
#[derive(Default)]
struct Compared {
    passthrough: Vec<FrameRecord>,
    plain_look: Vec<FrameRecord>,
    vertex_stage: Vec<FrameRecord>,
}

/// The same still frames again with one thing changed at a time (pass-through pipeline,
/// plain look, vertex-stage placement), each put back afterwards, so their cost is a ratio
/// within one run.
fn compare_still(
    rig: &Rig<'_>,
    renderer: &mut TerrainRenderer,
    camera: &Camera,
    options: &BenchOptions,
) -> Result<Compared, RenderError> {
    let mut compared = Compared::default();
    if options.passthrough {
        renderer.switches.use_passthrough = true;
        compared.passthrough = rig.records_at(renderer, camera, options.frames)?;
        renderer.switches.use_passthrough = false;
    }
    if options.compare_plain_look {
        renderer.set_look(&rig.ctx.device, LookSettings::plain());
        // One untimed frame: the new pipelines' first draw compiles them on some drivers.
        rig.draw(renderer, camera)?;
        compared.plain_look = rig.records_at(renderer, camera, options.frames)?;
        renderer.set_look(&rig.ctx.device, options.look);
    }
    if options.compare_vertex_stage {
        renderer.set_place_in_vertex_stage(true);
        rig.draw(renderer, camera)?;
        compared.vertex_stage = rig.records_at(renderer, camera, options.frames)?;
        renderer.set_place_in_vertex_stage(false);
    }
    Ok(compared)
}

/// What the flight found after its last frame (a still view's defaults: settled, nothing
/// compared).
struct FlightEnd {
    settle_s: Option<f64>,
    settled: bool,
    final_vs_loaded_px: Option<usize>,
    final_frame: Option<RenderedFrame>,
}

impl Default for FlightEnd {
    fn default() -> Self {
        Self {
            settle_s: None,
            settled: true,
            final_vs_loaded_px: None,
            final_frame: None,
        }
    }
}

/// The flight ran cold, so afterwards it waits for streaming to settle at the last camera
/// and compares that frame with a fresh renderer's that had everything loaded.
fn settle_after_flight(
    rig: &Rig<'_>,
    renderer: &mut TerrainRenderer,
    terrain: &Terrain,
    options: &BenchOptions,
    final_camera: &Camera,
) -> Result<FlightEnd, BenchError> {
    let ctx = rig.ctx;
    let t = Instant::now();
    let settled = match renderer.settle_or_explain(
        ctx,
        final_camera,
        options.width,
        options.height,
        SETTLE_TIMEOUT,
    ) {
        Ok(()) => true,
        // Never settling is the flight's finding; settings that cannot work are an error.
        Err(RenderError::NotSettled { .. }) => false,
        Err(e) => return Err(e.into()),
    };
    let settle_s = Some(t.elapsed().as_secs_f64());
    let last = rig.target.render_now(ctx, renderer, final_camera)?;
    // The reference: a fresh renderer with no faults that waited for everything.
    let mut fresh = TerrainRenderer::new(
        &ctx.device,
        options.settings.clone(),
        terrain.clone(),
        COLOR_FORMAT,
    )?;
    fresh.set_look(&ctx.device, options.look);
    fresh.set_lod(&ctx.device, options.lod);
    let loaded = rig.target.render(ctx, &mut fresh, final_camera)?;
    Ok(FlightEnd {
        settle_s,
        settled,
        final_vs_loaded_px: Some(pixels_differing(&last, &loaded)),
        final_frame: Some(last),
    })
}

/// The error of the final frame (the flight's settled one, or a settled render of the still
/// view), returned with the frame it was measured on.
fn measure_final(
    rig: &Rig<'_>,
    renderer: &mut TerrainRenderer,
    terrain: &Terrain,
    final_camera: &Camera,
    final_frame: Option<RenderedFrame>,
    measure: MeasureWatch<'_>,
) -> Result<(RenderedFrame, ErrorStats), BenchError> {
    let frame = match final_frame {
        Some(f) => f,
        None => rig.target.render(rig.ctx, renderer, final_camera)?,
    };
    let stats = crate::measure::evaluate_within(
        &frame,
        final_camera,
        terrain,
        measure.limit,
        measure.progress,
    )?;
    Ok((frame, stats))
}

impl BenchRun {
    fn values(&self, f: impl Fn(&FrameRecord) -> Option<f64>) -> Vec<f64> {
        self.frames.iter().filter_map(f).collect()
    }

    pub fn cpu_ms(&self) -> Option<(f64, f64, f64)> {
        summary(&self.values(|f| Some(f.cpu_ms)))
    }

    pub fn gpu_ms(&self) -> Option<(f64, f64, f64)> {
        summary(&self.values(|f| f.gpu_ms))
    }

    /// Median GPU time of the pass-through frames.
    pub fn passthrough_gpu_ms(&self) -> Option<f64> {
        median_gpu_ms(&self.passthrough)
    }

    /// Median GPU time of the frames whose vertex stage placed the vertices.
    pub fn vertex_stage_gpu_ms(&self) -> Option<f64> {
        median_gpu_ms(&self.vertex_stage)
    }

    /// Median GPU time of the plain look's frames.
    pub fn plain_look_gpu_ms(&self) -> Option<f64> {
        median_gpu_ms(&self.plain_look)
    }

    /// The largest decoded-tile cache size seen in any frame.
    pub fn cache_bytes_max(&self) -> u64 {
        self.frames
            .iter()
            .filter_map(|f| f.stream.as_ref().map(|s| s.cache_bytes))
            .max()
            .unwrap_or(0)
    }

    /// Per-frame records as CSV (hitch analysis: one row per measured frame).
    pub fn frames_csv(&self) -> String {
        let mut out = String::from(
            "frame,altitude_m,cpu_ms,frame_ms,gpu_ms,fill_gpu_ms,texels_filled,triangles,\
             levels_drawn,levels_waiting,tiles_missing,queued,in_flight,tiles_loaded,uploads,\
             cache_bytes\n",
        );
        for (i, f) in self.frames.iter().enumerate() {
            let s = f.stream.clone().unwrap_or_default();
            out.push_str(&format!(
                "{i},{:.3},{:.4},{:.4},{},{},{},{},{},{},{},{},{},{},{},{}\n",
                f.altitude_m,
                f.cpu_ms,
                f.frame_ms,
                f.gpu_ms.map_or(String::new(), |g| format!("{g:.4}")),
                f.fill_gpu_ms.map_or(String::new(), |g| format!("{g:.4}")),
                f.texels_filled,
                f.triangles,
                f.levels_drawn,
                f.levels_waiting,
                s.tiles_missing,
                s.stream.queued,
                s.stream.in_flight,
                s.stream.tiles_loaded,
                s.uploads,
                s.cache_bytes
            ));
        }
        out
    }

    pub fn last_stream(&self) -> Option<&FeedFrame> {
        self.frames.last().and_then(|f| f.stream.as_ref())
    }

    /// The fields `globe bench --json` promises: figures that vary per frame are medians, with
    /// `_min`/`_max` beside the times.
    pub fn json_fields(&self) -> BenchJson {
        let med = |f: &dyn Fn(&FrameRecord) -> Option<f64>| summary(&self.values(f)).map(|s| s.0);
        let (cpu, gpu) = (self.cpu_ms(), self.gpu_ms());
        let frame = summary(&self.values(|f| Some(f.frame_ms)));
        let o = &self.options;
        let s = self.last_stream();
        let stat = |f: &dyn Fn(&FeedFrame) -> u64| s.map(f);
        BenchJson {
            adapter: self.adapter.clone(),
            scene: o.scene.clone(),
            width: o.width,
            height: o.height,
            frames: self.frames.len(),
            cpu_ms: cpu.map(|s| s.0),
            cpu_ms_min: cpu.map(|s| s.1),
            cpu_ms_max: cpu.map(|s| s.2),
            frame_ms: frame.map(|s| s.0),
            gpu_ms: gpu.map(|s| s.0),
            gpu_ms_min: gpu.map(|s| s.1),
            gpu_ms_max: gpu.map(|s| s.2),
            fill_gpu_ms: med(&|f| f.fill_gpu_ms),
            texels_filled: self.frames.iter().map(|f| f.texels_filled).sum(),
            triangles: med(&|f| Some(f.triangles as f64)),
            levels_drawn: med(&|f| Some(f64::from(f.levels_drawn))),
            frames_with_levels_waiting: (self.frames.iter())
                .filter(|f| f.levels_waiting > 0)
                .count(),
            tiles_requested: stat(&|s| s.stream.tiles_requested),
            tiles_loaded: stat(&|s| s.stream.tiles_loaded),
            tiles_cancelled: stat(&|s| s.stream.tiles_cancelled),
            tiles_failed: stat(&|s| s.stream.tiles_failed),
            retries: stat(&|s| s.stream.retries),
            bytes_read: stat(&|s| s.stream.bytes_read),
            cache_bytes: stat(&|s| s.cache_bytes),
            cache_bytes_max: self.cache_bytes_max(),
            cache_budget: o.stream.cache_bytes,
            gpu_bytes_uploaded: stat(&|s| s.gpu_bytes_uploaded),
            uploads_max_per_frame: (self.frames.iter())
                .filter_map(|f| f.stream.as_ref().map(|s| s.uploads))
                .max()
                .unwrap_or(0),
            tile_latency_ms: o.stream.faults.latency_ms,
            tile_fail_rate: o.stream.faults.fail_rate,
            settle_s: self.settle_s,
            settled: self.settled,
            final_vs_loaded_px: self.final_vs_loaded_px,
            mean_px: self.error.map(|e| e.mean_px),
            p99_px: self.error.map(|e| e.p99_px),
            max_px: self.error.map(|e| e.max_px),
            error_pixels_pct: self.error.map(|e| 100.0 * e.error_pixel_share),
            mismatch_px: (self.error)
                .and_then(|e| e.coverage)
                .map(|c| c.mismatched()),
            passthrough_gpu_ms: self.passthrough_gpu_ms(),
            terrain_vs_passthrough: (self.gpu_ms())
                .zip(self.passthrough_gpu_ms())
                .map(|(t, p)| t.0 / p),
            plain_look_gpu_ms: self.plain_look_gpu_ms(),
            look_vs_plain: (self.gpu_ms())
                .zip(self.plain_look_gpu_ms())
                .map(|(t, p)| t.0 / p),
            vertex_stage_gpu_ms: self.vertex_stage_gpu_ms(),
            wall_s: self.wall_s,
        }
    }

    /// [`BenchRun::json_fields`] as one line of JSON.
    pub fn to_json(&self) -> String {
        to_json_line(&self.json_fields())
    }
}

/// Median GPU time of `frames` (None without timestamp queries).
fn median_gpu_ms(frames: &[FrameRecord]) -> Option<f64> {
    summary(&frames.iter().filter_map(|f| f.gpu_ms).collect::<Vec<_>>()).map(|s| s.0)
}

/// One line of JSON. Every JSON that globe writes goes through `serde_json`, whose rule for
/// floats that JSON cannot hold holds here too: NaN and ±∞ are written as `null`, as a figure
/// that was not measured (None) is.
pub fn to_json_line<T: Serialize>(value: &T) -> String {
    serde_json::to_string(value).expect("plain structs of numbers and strings serialise")
}

/// `globe bench --json` of a scene or the flight: one object, these fields in this order.
/// Times in ms and seconds, sizes in bytes; `null` where the figure was not measured (no
/// timestamp queries, no error measurement, no streaming) or is NaN or infinite.
#[derive(Clone, Debug, Serialize)]
pub struct BenchJson {
    pub adapter: String,
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub frames: usize,
    pub cpu_ms: Option<f64>,
    pub cpu_ms_min: Option<f64>,
    pub cpu_ms_max: Option<f64>,
    pub frame_ms: Option<f64>,
    pub gpu_ms: Option<f64>,
    pub gpu_ms_min: Option<f64>,
    pub gpu_ms_max: Option<f64>,
    /// Median over the frames that filled texels.
    pub fill_gpu_ms: Option<f64>,
    /// Summed over the frames.
    pub texels_filled: u64,
    pub triangles: Option<f64>,
    pub levels_drawn: Option<f64>,
    pub frames_with_levels_waiting: usize,
    /// Streaming counters after the last frame.
    pub tiles_requested: Option<u64>,
    pub tiles_loaded: Option<u64>,
    pub tiles_cancelled: Option<u64>,
    pub tiles_failed: Option<u64>,
    pub retries: Option<u64>,
    pub bytes_read: Option<u64>,
    pub cache_bytes: Option<u64>,
    pub cache_bytes_max: u64,
    pub cache_budget: u64,
    pub gpu_bytes_uploaded: Option<u64>,
    pub uploads_max_per_frame: u32,
    pub tile_latency_ms: u64,
    pub tile_fail_rate: f64,
    pub settle_s: Option<f64>,
    pub settled: bool,
    pub final_vs_loaded_px: Option<usize>,
    pub mean_px: Option<f64>,
    pub p99_px: Option<f64>,
    pub max_px: Option<f64>,
    pub error_pixels_pct: Option<f64>,
    pub mismatch_px: Option<usize>,
    pub passthrough_gpu_ms: Option<f64>,
    pub terrain_vs_passthrough: Option<f64>,
    /// The frames' GPU time with the plain look, and the look's over it (`--plain-look`).
    pub plain_look_gpu_ms: Option<f64>,
    pub look_vs_plain: Option<f64>,
    /// The frames' GPU time with the vertex stage placing the vertices (`--vertex-stage`).
    pub vertex_stage_gpu_ms: Option<f64>,
    pub wall_s: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_is_median_min_max() {
        assert_eq!(summary(&[3.0, 1.0, 2.0]), Some((2.0, 1.0, 3.0)));
        assert_eq!(summary(&[4.0, 1.0, 2.0, 3.0]), Some((2.5, 1.0, 4.0)));
        assert_eq!(summary(&[]), None);
    }

    /// The NaN/∞ rule: a non-finite figure is null, and the line stays valid JSON.
    #[test]
    fn json_writes_nan_and_infinity_as_null() {
        #[derive(Serialize)]
        struct T {
            nan: f64,
            inf: f64,
            none: Option<f64>,
            x: f64,
            name: &'static str,
        }
        let line = to_json_line(&T {
            nan: f64::NAN,
            inf: f64::NEG_INFINITY,
            none: None,
            x: 1.5,
            name: "a\"b\n",
        });
        assert_eq!(
            line,
            r#"{"nan":null,"inf":null,"none":null,"x":1.5,"name":"a\"b\n"}"#
        );
        let v: serde_json::Value = serde_json::from_str(&line).unwrap();
        assert!(v["nan"].is_null() && v["inf"].is_null());
        assert_eq!(v["name"], "a\"b\n");
    }
}

/// Throughput of the streaming pipeline against the raw read rate of the same file.
#[derive(Clone, Debug)]
pub struct Throughput {
    pub tiles: usize,
    pub tile_bytes: u64,
    /// Seconds for the pipeline (queue, tokio blocking pool, CRC, decode, channel) to deliver
    /// `tiles` tiles: first pass (pages as the caller left them: cold after a cache drop) and
    /// second pass (the same tiles again, from the page cache).
    pub pipeline_s: [f64; 2],
    /// Seconds to read as many tiles of another block of the same level one after another on
    /// one thread (mmap, CRC, decode: the raw rate), first and second pass.
    pub raw_s: [f64; 2],
}

impl Throughput {
    pub fn tiles_per_s(&self, seconds: f64) -> f64 {
        self.tiles as f64 / seconds
    }
    pub fn mb_per_s(&self, seconds: f64) -> f64 {
        (self.tiles as u64 * self.tile_bytes) as f64 / (1 << 20) as f64 / seconds
    }
}

/// `count` tiles of level 0 in a growing square around (lat, lon).
fn tiles_around(
    pyramid: &crate::dem::pyramid::Pyramid,
    count: usize,
    lat_deg: f64,
    lon_deg: f64,
) -> Vec<crate::stream::TileKey> {
    let level = pyramid.levels()[0];
    let (row, col) = level.grid.row_col_of(lat_deg, lon_deg);
    let t = pyramid.tile_size() as f64;
    let (cx, cy) = ((col / t) as i64, (row / t) as i64);
    let mut keys = Vec::new();
    let mut seen = std::collections::HashSet::new();
    let limit = count.min(level.tile_count());
    for r in 0i64.. {
        for dy in -r..=r {
            for dx in -r..=r {
                let tx = (cx + dx).rem_euclid(level.tiles_x as i64);
                let ty = (cy + dy).clamp(0, level.tiles_y as i64 - 1);
                if keys.len() < limit && seen.insert((tx, ty)) {
                    keys.push(crate::stream::TileKey {
                        level: 0,
                        tx: tx as u32,
                        ty: ty as u32,
                    });
                }
            }
        }
        if keys.len() >= limit {
            break;
        }
    }
    keys
}

/// Measures [`Throughput`] on `count` tiles of the finest level around (lat, lon) through the
/// pipeline, against `count` tiles around (lat, lon + 90°) read raw (separate blocks, so
/// neither side finds the other's pages cached or read ahead). For cold-cache first passes
/// drop the page cache before (Linux, root: `sync; echo 1 > /proc/sys/vm/drop_caches`).
pub fn throughput(
    dem: &crate::terrain::DemTerrain,
    stream: &StreamSettings,
    count: usize,
    lat_deg: f64,
    lon_deg: f64,
) -> std::io::Result<Throughput> {
    use crate::stream::open_source;
    use crate::stream::{Completion, TileStreamer};
    let pyramid = dem.pyramid();
    let pipe_keys = tiles_around(pyramid, count, lat_deg, lon_deg);
    let raw_keys = tiles_around(pyramid, count, lat_deg, lon_deg + 90.0);
    let n = raw_keys.len().min(pipe_keys.len());
    let source = open_source(dem.pyramid_arc(), stream.faults);
    let mut raw_s = [0.0; 2];
    let mut pipeline_s = [0.0; 2];
    for pass in 0..2 {
        raw_s[pass] = crate::stream::raw_read_rate(source.as_ref(), &raw_keys[..n]).2;
        let streamer = TileStreamer::new(source.clone(), stream)?;
        let started = Instant::now();
        let wanted = pipe_keys[..n]
            .iter()
            .enumerate()
            .map(|(i, k)| (*k, i as u64))
            .collect();
        streamer.want(&wanted);
        let mut done = 0;
        let deadline = started + SETTLE_TIMEOUT;
        while done < n && Instant::now() < deadline {
            if let Some(Completion::Loaded(_)) =
                streamer.wait(std::time::Duration::from_millis(100))
            {
                done += 1;
            }
        }
        pipeline_s[pass] = started.elapsed().as_secs_f64();
    }
    Ok(Throughput {
        tiles: n,
        tile_bytes: 3 * 2 * (pyramid.tile_size() * pyramid.tile_size()) as u64,
        pipeline_s,
        raw_s,
    })
}

/// A jump across the globe: settled at `from`, the camera moves to `to` in one frame.
#[derive(Clone, Debug)]
pub struct Jump {
    pub from: String,
    pub to: String,
    /// Seconds from the jump until every level had its data (full detail).
    pub to_full_detail_s: f64,
    /// Frames rendered meanwhile (the view showed the coarser levels).
    pub frames: usize,
    pub tiles_loaded: u64,
    pub tiles_cancelled: u64,
    pub bytes_read: u64,
}

/// Measures a jump from scene `from` to scene `to` with frames rendered back to back (no
/// waiting), until streaming has settled.
pub fn jump(
    ctx: &GpuContext,
    terrain: &Terrain,
    options: &JumpOptions,
    from: &str,
    to: &str,
) -> Result<Jump, BenchError> {
    let scene = |name: &str| {
        scenes::find(name).map(|s| s.camera(|lat, lon| terrain.height_at_lat_lon_m(lat, lon)))
    };
    let (a, b) = (scene(from)?, scene(to)?);
    let mut renderer = TerrainRenderer::with_streaming(
        &ctx.device,
        options.settings.clone(),
        terrain.clone(),
        COLOR_FORMAT,
        options.stream,
    )?;
    let target = OffscreenFrame::new(&ctx.device, options.width, options.height);
    renderer.settle_or_explain(ctx, &a, options.width, options.height, SETTLE_TIMEOUT)?;
    let before = target.draw_timed(ctx, &mut renderer, &a, None)?;
    let s0 = before.info.stream.unwrap_or_default().stream;
    let started = Instant::now();
    let mut frames = 0;
    let mut last = None;
    while started.elapsed() < SETTLE_TIMEOUT {
        let f = target.draw_timed(ctx, &mut renderer, &b, None)?;
        frames += 1;
        let settled = f.info.settled();
        last = f.info.stream;
        if settled {
            break;
        }
    }
    let s1 = last.unwrap_or_default().stream;
    Ok(Jump {
        from: from.into(),
        to: to.into(),
        to_full_detail_s: started.elapsed().as_secs_f64(),
        frames,
        tiles_loaded: s1.tiles_loaded - s0.tiles_loaded,
        tiles_cancelled: s1.tiles_cancelled - s0.tiles_cancelled,
        bytes_read: s1.bytes_read - s0.bytes_read,
    })
}

/// What `globe bench --scene jump` measures with.
#[derive(Clone, Debug)]
pub struct JumpOptions {
    pub width: u32,
    pub height: u32,
    pub settings: ClipmapSettings,
    pub stream: StreamSettings,
    /// Tiles read by each side of the throughput comparison.
    pub throughput_tiles: usize,
}

/// `globe bench --scene jump`: the jump [`JUMP_FROM`] → [`JUMP_TO`] and the pipeline's
/// throughput around [`JUMP_TO`] against the raw read rate.
#[derive(Clone, Debug)]
pub struct JumpRun {
    pub adapter: String,
    pub options: JumpOptions,
    /// Size of the pyramid file read.
    pub file_bytes: u64,
    pub jump: Jump,
    pub throughput: Throughput,
}

/// Runs the jump benchmark on a DEM terrain: first the throughput comparison around the jump's
/// destination, then the jump. `progress` gets a line before each part.
pub fn run_jump(
    ctx: &GpuContext,
    terrain: &Terrain,
    options: &JumpOptions,
    mut progress: impl FnMut(&str),
) -> Result<JumpRun, BenchError> {
    let Some(dem) = terrain.dem() else {
        return Err(BenchError::JumpNeedsDem);
    };
    let to = scenes::find(JUMP_TO)?;
    progress(&format!(
        "throughput: {} tiles raw, {} through the pipeline…",
        options.throughput_tiles, options.throughput_tiles
    ));
    let throughput = throughput(
        dem,
        &options.stream,
        options.throughput_tiles,
        to.lat_deg,
        to.lon_deg,
    )
    .map_err(BenchError::Streamer)?;
    progress(&format!("jump {JUMP_FROM} → {JUMP_TO}…"));
    let jump = jump(ctx, terrain, options, JUMP_FROM, JUMP_TO)?;
    Ok(JumpRun {
        adapter: ctx.adapter_description(),
        options: options.clone(),
        file_bytes: dem.pyramid().info().file_bytes,
        jump,
        throughput,
    })
}

impl JumpRun {
    /// One JSON object: the jump, then the throughput of each pass (`_cached`: the second,
    /// from the page cache); NaN or infinite rates (from a zero time) as `null`.
    pub fn to_json(&self) -> String {
        to_json_line(&JumpJson::new(self))
    }
}

/// `globe bench --scene jump --json`: the jump and the throughput, one object, these fields in
/// this order (NaN or infinite rates, from a zero time, as `null`).
#[derive(Clone, Debug, Serialize)]
pub struct JumpJson {
    pub adapter: String,
    pub scene: &'static str,
    pub file_bytes: u64,
    pub width: u32,
    pub height: u32,
    pub jump_from: String,
    pub jump_to: String,
    pub jump_to_full_detail_s: f64,
    pub jump_frames: usize,
    pub jump_tiles_loaded: u64,
    pub jump_tiles_cancelled: u64,
    pub jump_bytes_read: u64,
    pub throughput_tiles: usize,
    /// First pass (pages as the caller left them).
    pub pipeline_tiles_per_s: f64,
    pub pipeline_mb_per_s: f64,
    pub raw_tiles_per_s: f64,
    pub raw_mb_per_s: f64,
    pub pipeline_vs_raw: f64,
    /// Second pass (from the page cache).
    pub pipeline_mb_per_s_cached: f64,
    pub raw_mb_per_s_cached: f64,
    pub pipeline_vs_raw_cached: f64,
    pub tile_latency_ms: u64,
    pub max_in_flight: usize,
}

impl JumpJson {
    pub fn new(run: &JumpRun) -> Self {
        let (jump, tp, options) = (&run.jump, &run.throughput, &run.options);
        JumpJson {
            adapter: run.adapter.clone(),
            scene: JUMP,
            file_bytes: run.file_bytes,
            width: options.width,
            height: options.height,
            jump_from: jump.from.clone(),
            jump_to: jump.to.clone(),
            jump_to_full_detail_s: jump.to_full_detail_s,
            jump_frames: jump.frames,
            jump_tiles_loaded: jump.tiles_loaded,
            jump_tiles_cancelled: jump.tiles_cancelled,
            jump_bytes_read: jump.bytes_read,
            throughput_tiles: tp.tiles,
            pipeline_tiles_per_s: tp.tiles_per_s(tp.pipeline_s[0]),
            pipeline_mb_per_s: tp.mb_per_s(tp.pipeline_s[0]),
            raw_tiles_per_s: tp.tiles_per_s(tp.raw_s[0]),
            raw_mb_per_s: tp.mb_per_s(tp.raw_s[0]),
            pipeline_vs_raw: tp.raw_s[0] / tp.pipeline_s[0],
            pipeline_mb_per_s_cached: tp.mb_per_s(tp.pipeline_s[1]),
            raw_mb_per_s_cached: tp.mb_per_s(tp.raw_s[1]),
            pipeline_vs_raw_cached: tp.raw_s[1] / tp.pipeline_s[1],
            tile_latency_ms: options.stream.faults.latency_ms,
            max_in_flight: options.stream.max_in_flight,
        }
    }
}

/// How `bench` and `report` resolve what they render (CPU only: no frame is drawn).
#[cfg(test)]
mod view_tests {
    use super::*;
    use crate::instruments::report::{ReportOptions, views};

    fn options(scene: &str, camera: Option<CameraSpec>) -> BenchOptions {
        BenchOptions {
            scene: scene.into(),
            camera,
            path: None,
            frames: 1,
            warmup: 0,
            width: 1,
            height: 1,
            settings: ClipmapSettings::default(),
            stream: StreamSettings::default(),
            passthrough: false,
            measure_error: false,
            frame_interval: None,
            look: crate::look::LookSettings::default(),
            lod: Default::default(),
            compare_plain_look: false,
            compare_vertex_stage: false,
        }
    }

    #[test]
    fn bench_holds_a_scene_or_camera_view_and_flies_the_flight() {
        let garda: CameraSpec = "45.65,10.65,500,90,-10".parse().unwrap();
        assert_eq!(
            fixed_view(&options("everest", None)).unwrap(),
            Some(scenes::find("everest").unwrap().view())
        );
        assert_eq!(
            fixed_view(&options(scenes::CAMERA_VIEW_NAME, Some(garda))).unwrap(),
            Some(garda)
        );
        assert_eq!(fixed_view(&options(flight::NAME, None)).unwrap(), None);
        let e = fixed_view(&options("nowhere", None)).unwrap_err();
        assert!(e.to_string().ends_with("everest, flight, jump)"), "{e}");
    }

    #[test]
    fn report_runs_the_scenes_then_the_camera_view() {
        let garda: CameraSpec = "45.65,10.65,500,90,-10".parse().unwrap();
        let mut o = ReportOptions {
            scenes: vec!["space".into(), "ground".into()],
            camera: Some(garda),
            width: 1,
            height: 1,
            frames: 1,
            base: ClipmapSettings::default(),
            stream: StreamSettings::default(),
            every: 1,
            look: crate::look::LookSettings::default(),
            lod: Default::default(),
            projgrid_tables: false,
        };
        let names: Vec<String> = views(&o).unwrap().into_iter().map(|v| v.0).collect();
        assert_eq!(names, ["space", "ground", scenes::CAMERA_VIEW_NAME]);
        assert_eq!(views(&o).unwrap()[2].1, garda);
        o.scenes.push("nope".into());
        assert_eq!(views(&o).unwrap_err().name, "nope");
    }
}
