//! `globe bench --scene soak`: a long seeded random flight under failing, slow reads, watched
//! for what a short test cannot see — memory that creeps, a frame that blocks on the file, a
//! tile lost or wrong after hundreds of evictions and retries.
//!
//! The path ([`SoakPath`]) is drawn from a seed: legs between waypoints in space, at aircraft
//! height, a few metres above the ground, at and around both poles and across the
//! antimeridian; most legs fly (great circle, height eased in log space with a climb that
//! keeps the camera above the ground it crosses), some jump and hold there, turning. Time on
//! the path is the soak's own clock, which runs only while frames are drawn.
//!
//! At the end of every leg the flight stops at a **settle point**: the renderer (with its
//! faults) waits until the view is complete, and its frame is compared with a second renderer
//! that reads the same file without faults and waits for everything: they must be equal
//! (0 px differ). Every frame records the process's memory (anonymous RSS, from
//! `/proc/self/status`), the decoded-tile cache's bytes, the GPU tiles resident, and the file
//! reads made while the frame was prepared (`dem::frame_reads`: a frame must make none).
//!
//! The findings ([`SoakFindings`]) hold the budgets: the decoded-tile cache within
//! `--cache-mb`, GPU tiles within `--gpu-tiles`, and anonymous RSS over the second half of the
//! soak within its most over the first half plus the cache's budget plus a slack: memory may
//! grow while new kinds of views still compile pipelines (a software GPU keeps their code in
//! anonymous memory), then it must stop growing. File-backed RSS is reported but not held to
//! a budget: the kernel maps the pyramid's pages in as they are read and drops them under
//! pressure.

use std::time::{Duration, Instant};

use serde::Serialize;

use crate::clipmap::ClipmapSettings;
use crate::dem::frame_reads;
use crate::geo::camera::Camera;
use crate::instruments::bench::{BenchError, pixels_differing};
use crate::look::LookSettings;
use crate::render::formats::COLOR_FORMAT;
use crate::render::offscreen::{OffscreenFrame, RenderedFrame};
use crate::render::{GpuContext, TerrainRenderer};
use crate::scenes::soak_path::{LegSeconds, Place, SoakPath};
use crate::stream::{FaultSettings, StreamSettings};
use crate::terrain::Terrain;

/// The `globe bench --scene` name of the soak.
pub const NAME: &str = "soak";
/// What the soak injects unless told otherwise: one read in twenty fails, and each read
/// waits 0–200 ms (drawn per read).
pub const DEFAULT_FAIL_RATE: f64 = 0.05;
pub const DEFAULT_LATENCY_MS: (u64, u64) = (0, 200);
/// Anonymous memory allowed beyond the first settle point's and the cache's budget.
pub const DEFAULT_RSS_SLACK_BYTES: u64 = 96 << 20;

mod trace;

/// What the soak runs with.
#[derive(Clone, Debug)]
pub struct SoakOptions {
    /// Seconds of flight on the soak's clock (settle points not counted).
    pub seconds: f64,
    pub seed: u64,
    pub legs: LegSeconds,
    pub width: u32,
    pub height: u32,
    pub settings: ClipmapSettings,
    /// Budgets and the faults injected into the flying renderer's reads.
    pub stream: StreamSettings,
    pub look: LookSettings,
    pub lod: crate::plan::LodSettings,
    /// Frames start at most this often; None: back to back.
    pub frame_interval: Option<Duration>,
    /// How long a settle point may wait for its view to complete.
    pub settle_timeout: Duration,
    pub rss_slack_bytes: u64,
    /// Where to write the three images of a settle point that differs (flying renderer,
    /// reference, fresh renderer), if anywhere.
    pub mismatch_dir: Option<std::path::PathBuf>,
}

impl SoakOptions {
    /// The soak's stream settings: `stream` with the default faults where it has none.
    pub fn default_faults(stream: StreamSettings, seed: u64) -> StreamSettings {
        StreamSettings {
            faults: FaultSettings {
                latency_ms: DEFAULT_LATENCY_MS.0,
                latency_max_ms: DEFAULT_LATENCY_MS.1,
                fail_rate: DEFAULT_FAIL_RATE,
                seed,
            },
            ..stream
        }
    }
}

/// The process's resident memory, bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Rss {
    /// Heap and other anonymous pages (the CPU side of a software GPU's memory included).
    pub anon: u64,
    /// Pages of mapped files (the pyramid): the kernel's to drop.
    pub file: u64,
}

impl Rss {
    /// From `/proc/self/status`; None where there is none (not Linux).
    pub fn now() -> Option<Rss> {
        let status = std::fs::read_to_string("/proc/self/status").ok()?;
        let field = |name: &str| -> Option<u64> {
            let line = status.lines().find(|l| l.starts_with(name))?;
            let kb: u64 = line[name.len()..]
                .trim()
                .trim_end_matches("kB")
                .trim()
                .parse()
                .ok()?;
            Some(kb * 1024)
        };
        Some(Rss {
            anon: field("RssAnon:")?,
            file: field("RssFile:")?,
        })
    }
}

/// One frame of the flight.
#[derive(Clone, Debug, Serialize)]
pub struct SoakFrame {
    /// Soak time (the path's clock), seconds.
    pub t_s: f64,
    /// Wall time since the soak started (settle points included), seconds.
    pub wall_s: f64,
    pub leg: usize,
    pub altitude_m: f64,
    pub cpu_ms: f64,
    pub frame_ms: f64,
    /// Pyramid reads made while this frame was prepared (must be 0).
    pub reads_in_frame: u64,
    pub rss: Option<Rss>,
    pub cache_bytes: u64,
    pub cache_budget: u64,
    /// What the frame held beyond the budget (`FeedFrame::cache_kept_bytes`).
    pub cache_kept_bytes: u64,
    pub gpu_tiles: usize,
    pub gpu_capacity: usize,
    pub tiles_loaded: u64,
    pub tiles_failed: u64,
    pub retries: u64,
    pub levels_waiting: u32,
}

/// A stop at the end of a leg: the faulty renderer settled and compared with a fault-free one.
#[derive(Clone, Debug, Serialize)]
pub struct SettlePoint {
    pub t_s: f64,
    pub wall_s: f64,
    pub leg: usize,
    pub place: Place,
    pub camera: [f64; 5],
    /// Seconds until the view was complete.
    pub settle_s: f64,
    pub settled: bool,
    /// Why not, when it did not settle (or the reference could not render).
    pub error: Option<String>,
    /// Pixels differing from the fault-free render (None when either failed).
    pub differing_px: Option<usize>,
    /// Of those, pixels differing visibly: by more than [`VISIBLE_CHANNEL_DIFF`] in a channel.
    pub visibly_differing_px: Option<usize>,
    /// Where they differ: what a third, fresh renderer (fault-free, default budgets) says.
    pub mismatch: Option<Mismatch>,
}

/// A channel difference (0–255) above this is visible; the goldens' tolerance.
pub const VISIBLE_CHANNEL_DIFF: u8 = 8;

fn pixels_differing_by_more_than(a: &RenderedFrame, b: &RenderedFrame, tolerance: u8) -> usize {
    a.rgba
        .chunks_exact(4)
        .zip(b.rgba.chunks_exact(4))
        .filter(|(p, q)| {
            p.iter()
                .zip(q.iter())
                .any(|(x, y)| x.abs_diff(*y) > tolerance)
        })
        .count()
}

/// A settle point that differs, seen by a third renderer made for it: whichever of the two
/// long-lived renderers it disagrees with carries state from its history.
#[derive(Clone, Debug, Serialize)]
pub struct Mismatch {
    pub fresh_vs_flying_px: usize,
    pub fresh_vs_reference_px: usize,
    /// Flying, reference, fresh.
    pub triangles: [u64; 3],
    pub levels: [(u32, u32); 3],
    pub height_above_terrain_m: [f64; 3],
}

/// What the soak found, against its budgets.
#[derive(Clone, Debug, Serialize)]
pub struct SoakFindings {
    pub frames: usize,
    pub flown_s: f64,
    pub wall_s: f64,
    pub legs: usize,
    pub jumps: usize,
    pub places: Vec<(Place, usize)>,
    /// Frames that read the pyramid while they were prepared.
    pub frames_reading_the_file: usize,
    pub cpu_ms_median: f64,
    pub cpu_ms_p99: f64,
    pub cpu_ms_max: f64,
    pub settle_points: usize,
    pub settle_failures: usize,
    pub settle_points_differing: usize,
    pub max_differing_px: usize,
    /// The largest share of an image's pixels that differ visibly at a settle point.
    pub max_visibly_differing_share: f64,
    pub settle_s_median: f64,
    pub settle_s_max: f64,
    pub cache_budget: u64,
    pub cache_bytes_max: u64,
    /// The most a frame held beyond the budget (the tiles it needs), and the frames whose
    /// cache went over both (must be 0).
    pub cache_kept_bytes_max: u64,
    pub frames_over_cache_budget: usize,
    pub gpu_capacity: usize,
    pub gpu_tiles_max: usize,
    /// Anonymous RSS: its most over the first half of the soak (wall time), the budget of the
    /// second half (that plus the cache's budget and the slack), and its most there.
    pub rss_anon_baseline: Option<u64>,
    pub rss_anon_budget: Option<u64>,
    pub rss_anon_max: Option<u64>,
    pub rss_file_max: Option<u64>,
    /// Least-squares slope of anonymous RSS over the second half of the flight, MiB/min: a
    /// leak shows as a steady rise.
    pub rss_anon_slope_mib_per_min: Option<f64>,
    pub tiles_loaded: u64,
    pub tiles_failed: u64,
    pub retries: u64,
}

impl SoakFindings {
    /// Every budget held, no frame read the file, every settle point settled and equal.
    pub fn passed(&self) -> bool {
        self.failures().is_empty()
    }

    /// What failed, in words.
    pub fn failures(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.frames_reading_the_file > 0 {
            out.push(format!(
                "{} frames read the pyramid while being prepared",
                self.frames_reading_the_file
            ));
        }
        if self.settle_failures > 0 {
            out.push(format!(
                "{} settle points did not settle",
                self.settle_failures
            ));
        }
        if self.settle_points_differing > 0 {
            out.push(format!(
                "{} settle points differ from the fault-free render (up to {} px)",
                self.settle_points_differing, self.max_differing_px
            ));
        }
        if self.frames_over_cache_budget > 0 {
            out.push(format!(
                "in {} frames the decoded-tile cache held more than its budget of {} B and \
                 more than the tiles the frame needed",
                self.frames_over_cache_budget, self.cache_budget
            ));
        }
        if self.gpu_tiles_max > self.gpu_capacity {
            out.push(format!(
                "{} GPU tiles resident, over the {} slots",
                self.gpu_tiles_max, self.gpu_capacity
            ));
        }
        if let (Some(max), Some(budget)) = (self.rss_anon_max, self.rss_anon_budget)
            && max > budget
        {
            out.push(format!(
                "anonymous RSS reached {:.1} MiB, over its budget of {:.1} MiB",
                mib(max),
                mib(budget)
            ));
        }
        out
    }
}

pub(super) fn mib(bytes: u64) -> f64 {
    bytes as f64 / (1u64 << 20) as f64
}

/// Where the soak stands, for a progress line.
#[derive(Clone, Copy, Debug)]
pub struct SoakProgress {
    pub t_s: f64,
    pub seconds: f64,
    pub frames: usize,
    pub settle_points: usize,
    pub settle_points_bad: usize,
    pub reads_in_frames: u64,
}

/// One soak's frames, settle points and findings.
pub struct SoakRun {
    pub adapter: String,
    pub options: SoakOptions,
    pub path: SoakPath,
    pub frames: Vec<SoakFrame>,
    pub settles: Vec<SettlePoint>,
    pub wall_s: f64,
}

/// Flies the soak. Errors are those that stop it (no adapter, settings the renderer refuses);
/// what goes wrong during the flight is a finding.
pub fn run(
    ctx: &GpuContext,
    terrain: &Terrain,
    options: &SoakOptions,
    mut progress: impl FnMut(&SoakProgress),
) -> Result<SoakRun, BenchError> {
    let started = Instant::now();
    let path = SoakPath::new(
        options.seed,
        options.seconds,
        &options.legs,
        terrain.radius_m(),
        |lat, lon| terrain.height_at_lat_lon_m(lat, lon),
    );
    let mut renderer = soak_renderer(ctx, terrain, options, options.stream)?;
    // The reference reads without faults and holds only what its frame needs (cache 0), so
    // its memory stays out of the flying renderer's budget.
    let reference = soak_renderer(
        ctx,
        terrain,
        options,
        StreamSettings {
            faults: FaultSettings::default(),
            cache_bytes: 0,
            ..options.stream
        },
    )?;
    let target = OffscreenFrame::new(&ctx.device, options.width, options.height);
    let mut frames: Vec<SoakFrame> = Vec::new();
    let mut settles: Vec<SettlePoint> = Vec::new();
    let mut flown = 0.0f64;
    let mut reads_total = 0u64;
    let mut stops = Settler {
        ctx,
        terrain,
        options,
        target: &target,
        reference,
        started,
        path: &path,
    };
    let mut next_start = Instant::now();
    loop {
        // Every leg that ended gets its settle point, at its end's view.
        let done = settles.len();
        if done < path.legs().len() && path.legs()[done].end_s() <= flown.min(options.seconds) {
            let leg = &path.legs()[done];
            let camera = leg.camera_at(1.0);
            settles.push(stops.settle(done, leg.end_s(), &camera, &mut renderer));
            continue;
        }
        if flown >= options.seconds {
            break;
        }
        if let Some(dt) = options.frame_interval {
            let now = Instant::now();
            if next_start > now {
                std::thread::sleep(next_start - now);
            }
            next_start = next_start.max(now) + dt;
        }
        let clock = Instant::now();
        let frame = fly_frame(ctx, &target, &mut renderer, &path, flown, started)?;
        reads_total += frame.reads_in_frame;
        frames.push(frame);
        flown += clock.elapsed().as_secs_f64();
        progress(&SoakProgress {
            t_s: flown.min(options.seconds),
            seconds: options.seconds,
            frames: frames.len(),
            settle_points: settles.len(),
            settle_points_bad: settles.iter().filter(|p| p.differing_px != Some(0)).count(),
            reads_in_frames: reads_total,
        });
    }
    // The view where the flight stopped, mid-leg: one more settle point.
    if settles.len() < path.legs().len() {
        let (leg, camera) = path.camera(options.seconds);
        settles.push(stops.settle(leg, options.seconds, &camera, &mut renderer));
    }
    Ok(SoakRun {
        adapter: ctx.adapter_description(),
        options: options.clone(),
        path,
        frames,
        settles,
        wall_s: started.elapsed().as_secs_f64(),
    })
}

/// A renderer as the soak configures all three of its kinds (flying, reference, fresh):
/// the same terrain, clipmap, look and LOD, reading through `stream`.
fn soak_renderer(
    ctx: &GpuContext,
    terrain: &Terrain,
    options: &SoakOptions,
    stream: StreamSettings,
) -> Result<TerrainRenderer, BenchError> {
    let mut r = TerrainRenderer::with_streaming(
        &ctx.device,
        options.settings.clone(),
        terrain.clone(),
        COLOR_FORMAT,
        stream,
    )?;
    r.set_look(&ctx.device, options.look);
    r.set_lod(&ctx.device, options.lod);
    Ok(r)
}

/// One frame of the flight at soak time `flown`, with what it read and what it held: a frame
/// that reads the file or a budget that creeps shows here first.
fn fly_frame(
    ctx: &GpuContext,
    target: &OffscreenFrame,
    renderer: &mut TerrainRenderer,
    path: &SoakPath,
    flown: f64,
    started: Instant,
) -> Result<SoakFrame, BenchError> {
    let (leg, camera) = path.camera(flown);
    let reads_before = frame_reads::reads_in_frames_on_this_thread();
    let f = target.draw_timed(ctx, renderer, &camera, None)?;
    let reads_in_frame = frame_reads::reads_in_frames_on_this_thread() - reads_before;
    let s = f.info.stream.clone().unwrap_or_default();
    Ok(SoakFrame {
        t_s: flown,
        wall_s: started.elapsed().as_secs_f64(),
        leg,
        altitude_m: camera.altitude_m,
        cpu_ms: f.cpu_ms,
        frame_ms: f.frame_ms,
        reads_in_frame,
        rss: Rss::now(),
        cache_bytes: s.cache_bytes,
        cache_budget: s.cache_budget,
        cache_kept_bytes: s.cache_kept_bytes,
        gpu_tiles: s.gpu_tiles,
        gpu_capacity: s.gpu_capacity,
        tiles_loaded: s.stream.tiles_loaded,
        tiles_failed: s.stream.tiles_failed,
        retries: s.stream.retries,
        levels_waiting: f.info.selection.waiting().len() as u32,
    })
}

/// What a settle point needs besides the flying renderer: the fault-free reference it is
/// compared with, and what to make a fresh renderer from when they differ.
struct Settler<'a> {
    ctx: &'a GpuContext,
    terrain: &'a Terrain,
    options: &'a SoakOptions,
    target: &'a OffscreenFrame,
    reference: TerrainRenderer,
    started: Instant,
    path: &'a SoakPath,
}

impl Settler<'_> {
    /// The flying renderer waits at `camera` until its view is complete, and its frame is
    /// compared with the reference's; a failure is recorded, not returned.
    fn settle(
        &mut self,
        leg: usize,
        t_s: f64,
        camera: &Camera,
        renderer: &mut TerrainRenderer,
    ) -> SettlePoint {
        let options = self.options;
        let t = Instant::now();
        let waited = renderer.settle_or_explain(
            self.ctx,
            camera,
            options.width,
            options.height,
            options.settle_timeout,
        );
        let settle_s = t.elapsed().as_secs_f64();
        let compared = waited
            .map_err(|e| e.to_string())
            .and_then(|()| self.compare(leg, camera, renderer));
        SettlePoint {
            t_s,
            wall_s: self.started.elapsed().as_secs_f64(),
            leg,
            place: self.path.legs()[leg].to.place,
            camera: [
                camera.lat_deg,
                camera.lon_deg,
                camera.altitude_m,
                camera.heading_deg,
                camera.pitch_deg,
            ],
            settle_s,
            settled: compared.is_ok(),
            differing_px: compared.as_ref().ok().map(|c| c.0),
            visibly_differing_px: compared.as_ref().ok().map(|c| c.1),
            mismatch: compared.as_ref().ok().and_then(|c| c.2.clone()),
            error: compared.err(),
        }
    }

    /// The settled flying frame against the reference's: pixels differing, pixels differing
    /// visibly, and where they differ at all, what a third renderer says.
    fn compare(
        &mut self,
        leg: usize,
        camera: &Camera,
        renderer: &mut TerrainRenderer,
    ) -> Result<(usize, usize, Option<Mismatch>), String> {
        let (ctx, target, timeout) = (self.ctx, self.target, self.options.settle_timeout);
        let got = target
            .render_now(ctx, renderer, camera)
            .map_err(|e| e.to_string())?;
        let want = target
            .render_settled_within(ctx, &mut self.reference, camera, timeout)
            .map_err(|e| format!("the fault-free reference: {e}"))?;
        let differing = pixels_differing(&got, &want);
        let visibly = pixels_differing_by_more_than(&got, &want, VISIBLE_CHANNEL_DIFF);
        let mut mismatch = None;
        if differing > 0 {
            mismatch = Some(self.third_opinion(leg, camera, &got, &want)?);
        }
        Ok((differing, visibly, mismatch))
    }

    /// A fresh renderer (fault-free, default budgets) renders the view too: whichever of the
    /// two long-lived renderers it disagrees with carries state from its history. The three
    /// images are written to [`SoakOptions::mismatch_dir`] when it is set.
    fn third_opinion(
        &self,
        leg: usize,
        camera: &Camera,
        got: &RenderedFrame,
        want: &RenderedFrame,
    ) -> Result<Mismatch, String> {
        let options = self.options;
        let mut fresh = soak_renderer(
            self.ctx,
            self.terrain,
            options,
            StreamSettings {
                faults: FaultSettings::default(),
                ..StreamSettings::default()
            },
        )
        .map_err(|e| e.to_string())?;
        let third = self
            .target
            .render_settled_within(self.ctx, &mut fresh, camera, options.settle_timeout)
            .map_err(|e| format!("a fresh renderer: {e}"))?;
        let frames = [got, want, &third];
        let mismatch = Mismatch {
            fresh_vs_flying_px: pixels_differing(&third, got),
            fresh_vs_reference_px: pixels_differing(&third, want),
            triangles: frames.map(|f| f.info.triangles()),
            levels: frames.map(|f| (f.info.selection.coarsest, f.info.selection.finest)),
            height_above_terrain_m: frames.map(|f| f.info.height_above_terrain_m),
        };
        if let Some(dir) = &options.mismatch_dir {
            for (frame, who) in frames.iter().zip(["flying", "reference", "fresh"]) {
                let png = dir.join(format!("settle-{leg:03}-{who}.png"));
                frame
                    .save_png(&png)
                    .map_err(|e| format!("cannot write {}: {e}", png.display()))?;
            }
        }
        Ok(mismatch)
    }
}

fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

impl SoakRun {
    pub fn findings(&self) -> SoakFindings {
        let mut cpu: Vec<f64> = self.frames.iter().map(|f| f.cpu_ms).collect();
        cpu.sort_by(f64::total_cmp);
        let mut settle_s: Vec<f64> = self.settles.iter().map(|p| p.settle_s).collect();
        settle_s.sort_by(f64::total_cmp);
        let legs = &self.path.legs()[..self.settles.len().min(self.path.legs().len())];
        let places = Place::ALL
            .iter()
            .map(|&p| (p, legs.iter().filter(|l| l.to.place == p).count()))
            .collect();
        // Each renderer compiles a pipeline the first time a kind of view needs it (a software
        // GPU keeps the code in anonymous memory), so memory grows while new kinds of views
        // come; the first half is the warm-up, the second must stay within it plus what the
        // cache may still take.
        let half_s = self.frames.last().map_or(0.0, |f| f.wall_s) / 2.0;
        let anon_max = |first: bool| {
            self.frames
                .iter()
                .filter(|f| (f.wall_s <= half_s) == first)
                .filter_map(|f| f.rss.map(|r| r.anon))
                .max()
        };
        let (rss_anon_baseline, rss_anon_max) = (anon_max(true), anon_max(false));
        let last = self.frames.last();
        let cache_budget = self.options.stream.cache_bytes;
        SoakFindings {
            frames: self.frames.len(),
            flown_s: last.map_or(0.0, |f| f.t_s),
            wall_s: self.wall_s,
            legs: legs.len(),
            jumps: legs.iter().filter(|l| l.jump).count(),
            places,
            frames_reading_the_file: self.frames.iter().filter(|f| f.reads_in_frame > 0).count(),
            cpu_ms_median: quantile(&cpu, 0.5),
            cpu_ms_p99: quantile(&cpu, 0.99),
            cpu_ms_max: cpu.last().copied().unwrap_or(f64::NAN),
            settle_points: self.settles.len(),
            settle_failures: self.settles.iter().filter(|p| !p.settled).count(),
            settle_points_differing: self
                .settles
                .iter()
                .filter(|p| p.differing_px.is_some_and(|d| d > 0))
                .count(),
            max_differing_px: self
                .settles
                .iter()
                .filter_map(|p| p.differing_px)
                .max()
                .unwrap_or(0),
            max_visibly_differing_share: self
                .settles
                .iter()
                .filter_map(|p| p.visibly_differing_px)
                .max()
                .unwrap_or(0) as f64
                / (self.options.width as f64 * self.options.height as f64),
            settle_s_median: quantile(&settle_s, 0.5),
            settle_s_max: settle_s.last().copied().unwrap_or(f64::NAN),
            cache_budget,
            cache_bytes_max: self.frames.iter().map(|f| f.cache_bytes).max().unwrap_or(0),
            cache_kept_bytes_max: self
                .frames
                .iter()
                .map(|f| f.cache_kept_bytes)
                .max()
                .unwrap_or(0),
            frames_over_cache_budget: self
                .frames
                .iter()
                .filter(|f| f.cache_bytes > f.cache_budget.max(f.cache_kept_bytes))
                .count(),
            gpu_capacity: self.frames.first().map_or(0, |f| f.gpu_capacity),
            gpu_tiles_max: self.frames.iter().map(|f| f.gpu_tiles).max().unwrap_or(0),
            rss_anon_baseline,
            rss_anon_budget: rss_anon_baseline
                .map(|b| b + cache_budget + self.options.rss_slack_bytes),
            rss_anon_max,
            rss_file_max: self
                .frames
                .iter()
                .filter_map(|f| f.rss.map(|r| r.file))
                .max(),
            rss_anon_slope_mib_per_min: self.rss_slope_mib_per_min(),
            tiles_loaded: last.map_or(0, |f| f.tiles_loaded),
            tiles_failed: last.map_or(0, |f| f.tiles_failed),
            retries: last.map_or(0, |f| f.retries),
        }
    }

    /// Anonymous RSS against wall time over the second half of the frames, least squares.
    fn rss_slope_mib_per_min(&self) -> Option<f64> {
        let pts: Vec<(f64, f64)> = self.frames[self.frames.len() / 2..]
            .iter()
            .filter_map(|f| f.rss.map(|r| (f.wall_s / 60.0, mib(r.anon))))
            .collect();
        if pts.len() < 3 {
            return None;
        }
        let n = pts.len() as f64;
        let (mx, my) = (
            pts.iter().map(|p| p.0).sum::<f64>() / n,
            pts.iter().map(|p| p.1).sum::<f64>() / n,
        );
        let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
        let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
        (sxx > 0.0).then(|| sxy / sxx)
    }

    /// Every frame, one CSV row each.
    pub fn frames_csv(&self) -> String {
        let mut out = String::from(
            "t_s,wall_s,leg,altitude_m,cpu_ms,frame_ms,reads_in_frame,rss_anon_bytes,\
             rss_file_bytes,cache_bytes,cache_budget,cache_kept_bytes,gpu_tiles,gpu_capacity,\
             tiles_loaded,\
             tiles_failed,retries,levels_waiting\n",
        );
        for f in &self.frames {
            let (anon, file) = f.rss.map_or((String::new(), String::new()), |r| {
                (r.anon.to_string(), r.file.to_string())
            });
            out += &format!(
                "{:.3},{:.3},{},{:.3},{:.3},{:.3},{},{anon},{file},{},{},{},{},{},{},{},{},{}\n",
                f.t_s,
                f.wall_s,
                f.leg,
                f.altitude_m,
                f.cpu_ms,
                f.frame_ms,
                f.reads_in_frame,
                f.cache_bytes,
                f.cache_budget,
                f.cache_kept_bytes,
                f.gpu_tiles,
                f.gpu_capacity,
                f.tiles_loaded,
                f.tiles_failed,
                f.retries,
                f.levels_waiting
            );
        }
        out
    }

    /// The findings, the settle points and the legs, one JSON object.
    pub fn to_json(&self) -> String {
        #[derive(Serialize)]
        struct Json<'a> {
            adapter: &'a str,
            seed: u64,
            seconds: f64,
            width: u32,
            height: u32,
            fail_rate: f64,
            latency_ms: (u64, u64),
            passed: bool,
            failures: Vec<String>,
            findings: SoakFindings,
            settle_points: &'a [SettlePoint],
        }
        let f = &self.options.stream.faults;
        let findings = self.findings();
        crate::instruments::bench::to_json_line(&Json {
            adapter: &self.adapter,
            seed: self.options.seed,
            seconds: self.options.seconds,
            width: self.options.width,
            height: self.options.height,
            fail_rate: f.fail_rate,
            latency_ms: (f.latency_ms, f.latency_max_ms.max(f.latency_ms)),
            passed: findings.passed(),
            failures: findings.failures(),
            findings,
            settle_points: &self.settles,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rss_reads_this_process() {
        if cfg!(target_os = "linux") {
            let before = Rss::now().expect("/proc/self/status");
            let block = vec![1u8; 64 << 20];
            let after = Rss::now().unwrap();
            assert!(block.iter().all(|&b| b == 1));
            // Pages touched by the 64 MiB block show in anonymous RSS (other tests' threads
            // allocate and free meanwhile: half is plenty of margin).
            assert!(
                after.anon >= before.anon + (32 << 20),
                "{before:?} then {after:?}"
            );
        }
    }
}
