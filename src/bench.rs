//! `globe bench`: a scene (or the `flight` path) rendered headless frame after frame, with
//! per-frame CPU time, GPU time (timestamp queries where the adapter has them), triangles,
//! levels and the streaming pipeline's counters, summarised as median/min/max.
//!
//! A named scene is benchmarked warm: streaming settles first, then `warmup` frames, then the
//! measured ones. The flight starts cold, as a user would: its frames never wait for tiles, and
//! afterwards the bench waits for streaming to settle and compares that last frame with a
//! fresh render that had everything loaded (`final_vs_loaded_px`).

use std::time::Instant;

use crate::clipmap::ClipmapSettings;
use crate::geo::camera::Camera;
use crate::render::dem_feed::FeedFrame;
use crate::render::offscreen::{COLOR_FORMAT, OffscreenFrame, RenderedFrame, SETTLE_TIMEOUT};
use crate::render::timing::GpuTimer;
use crate::render::{GpuContext, RenderError, TerrainRenderer};
use crate::scenes::{Scene, flight};
use crate::stream::StreamSettings;
use crate::terrain::Terrain;

#[derive(Clone, Debug)]
pub struct BenchOptions {
    /// A scene name, or `flight`.
    pub scene: String,
    pub frames: usize,
    pub warmup: usize,
    pub width: u32,
    pub height: u32,
    pub settings: ClipmapSettings,
    pub stream: StreamSettings,
    /// Frames start at most this often (a viewer's frame rate: streaming gets the wall time a
    /// real flight gives it); None renders back to back.
    pub frame_interval: Option<std::time::Duration>,
}

/// One measured frame.
#[derive(Clone, Debug)]
pub struct FrameRecord {
    pub cpu_ms: f64,
    pub frame_ms: f64,
    pub gpu_ms: Option<f64>,
    pub triangles: u64,
    pub levels_drawn: u32,
    pub levels_waiting: u32,
    pub altitude_m: f64,
    pub stream: Option<FeedFrame>,
}

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
    pub wall_s: f64,
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

/// Runs the benchmark. `progress(done, total)` is called after each frame.
pub fn run(
    ctx: &GpuContext,
    terrain: &Terrain,
    options: &BenchOptions,
    mut progress: impl FnMut(usize, usize),
) -> Result<BenchRun, RenderError> {
    let started = Instant::now();
    let mut renderer = TerrainRenderer::with_streaming(
        &ctx.device,
        options.settings.clone(),
        terrain.clone(),
        COLOR_FORMAT,
        options.stream,
    )?;
    let timer = GpuTimer::new(ctx);
    let target = OffscreenFrame::new(&ctx.device, options.width, options.height);
    let ground = |lat: f64, lon: f64| terrain.height_at_lat_lon_m(lat, lon);
    let is_flight = options.scene == flight::NAME;
    let fixed = if is_flight {
        None
    } else {
        let scene = Scene::by_name(&options.scene).ok_or_else(|| {
            RenderError::Stream(format!(
                "unknown scene '{}' (known: {}, {})",
                options.scene,
                crate::scenes::scene_names(),
                flight::NAME
            ))
        })?;
        Some(scene.camera(ground))
    };
    let camera_of = |i: usize| match fixed {
        Some(c) => c,
        None => flight::frame_camera(i, options.frames, ground),
    };
    if let Some(camera) = &fixed {
        renderer.settle(ctx, camera, options.width, options.height, SETTLE_TIMEOUT);
        for _ in 0..options.warmup {
            target.draw_timed(ctx, &mut renderer, camera, timer.as_ref())?;
        }
    }
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
        let f = target.draw_timed(ctx, &mut renderer, &camera, timer.as_ref())?;
        frames.push(FrameRecord {
            cpu_ms: f.cpu_ms,
            frame_ms: f.frame_ms,
            gpu_ms: f.gpu_ms,
            triangles: f.info.draw.triangles,
            levels_drawn: if f.info.selection.any_drawn() {
                f.info.selection.finest - f.info.selection.coarsest + 1
            } else {
                0
            },
            levels_waiting: f.info.selection.waiting().len() as u32,
            altitude_m: camera.altitude_m,
            stream: f.info.stream.clone(),
        });
        progress(i + 1, options.frames);
    }
    let final_camera = camera_of(options.frames.saturating_sub(1));
    let (mut settle_s, mut settled, mut final_vs_loaded_px, mut final_frame) =
        (None, true, None, None);
    if is_flight {
        let t = Instant::now();
        settled = renderer.settle(
            ctx,
            &final_camera,
            options.width,
            options.height,
            SETTLE_TIMEOUT,
        );
        settle_s = Some(t.elapsed().as_secs_f64());
        let last = target.render_now(ctx, &mut renderer, &final_camera)?;
        // The reference: a fresh renderer with no faults that waited for everything.
        let mut fresh = TerrainRenderer::new(
            &ctx.device,
            options.settings.clone(),
            terrain.clone(),
            COLOR_FORMAT,
        )?;
        let loaded = target.render(ctx, &mut fresh, &final_camera)?;
        final_vs_loaded_px = Some(pixels_differing(&last, &loaded));
        final_frame = Some(last);
    }
    Ok(BenchRun {
        adapter: ctx.adapter_description(),
        options: options.clone(),
        frames,
        settle_s,
        settled,
        final_vs_loaded_px,
        final_frame,
        final_camera,
        wall_s: started.elapsed().as_secs_f64(),
    })
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
            "frame,altitude_m,cpu_ms,frame_ms,gpu_ms,triangles,levels_drawn,levels_waiting,\
             tiles_missing,queued,in_flight,tiles_loaded,uploads,cache_bytes\n",
        );
        for (i, f) in self.frames.iter().enumerate() {
            let s = f.stream.clone().unwrap_or_default();
            out.push_str(&format!(
                "{i},{:.3},{:.4},{:.4},{},{},{},{},{},{},{},{},{},{}\n",
                f.altitude_m,
                f.cpu_ms,
                f.frame_ms,
                f.gpu_ms.map_or(String::new(), |g| format!("{g:.4}")),
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

    /// One JSON object (the fields `globe bench --json` promises; figures that vary per frame
    /// are medians, with `_min`/`_max` beside the times).
    pub fn to_json(&self, extra: &[(&str, String)]) -> String {
        let num = |v: Option<f64>| v.map_or("null".to_string(), |x| format!("{x:.4}"));
        let med =
            |f: &dyn Fn(&FrameRecord) -> Option<f64>| num(summary(&self.values(f)).map(|s| s.0));
        let cpu = self.cpu_ms();
        let gpu = self.gpu_ms();
        let frame = summary(&self.values(|f| Some(f.frame_ms)));
        let o = &self.options;
        let mut fields: Vec<(String, String)> = vec![
            ("adapter".into(), json_string(&self.adapter)),
            ("scene".into(), json_string(&o.scene)),
            ("width".into(), o.width.to_string()),
            ("height".into(), o.height.to_string()),
            ("frames".into(), self.frames.len().to_string()),
            ("cpu_ms".into(), num(cpu.map(|s| s.0))),
            ("cpu_ms_min".into(), num(cpu.map(|s| s.1))),
            ("cpu_ms_max".into(), num(cpu.map(|s| s.2))),
            ("frame_ms".into(), num(frame.map(|s| s.0))),
            ("gpu_ms".into(), num(gpu.map(|s| s.0))),
            ("gpu_ms_min".into(), num(gpu.map(|s| s.1))),
            ("gpu_ms_max".into(), num(gpu.map(|s| s.2))),
            ("triangles".into(), med(&|f| Some(f.triangles as f64))),
            ("levels_drawn".into(), med(&|f| Some(f.levels_drawn as f64))),
            (
                "frames_with_levels_waiting".into(),
                self.frames
                    .iter()
                    .filter(|f| f.levels_waiting > 0)
                    .count()
                    .to_string(),
            ),
        ];
        let s = self.last_stream();
        let stat =
            |f: &dyn Fn(&FeedFrame) -> u64| s.map_or("null".to_string(), |s| f(s).to_string());
        fields.extend([
            (
                "tiles_requested".into(),
                stat(&|s| s.stream.tiles_requested),
            ),
            ("tiles_loaded".into(), stat(&|s| s.stream.tiles_loaded)),
            (
                "tiles_cancelled".into(),
                stat(&|s| s.stream.tiles_cancelled),
            ),
            ("tiles_failed".into(), stat(&|s| s.stream.tiles_failed)),
            ("retries".into(), stat(&|s| s.stream.retries)),
            ("bytes_read".into(), stat(&|s| s.stream.bytes_read)),
            ("cache_bytes".into(), stat(&|s| s.cache_bytes)),
            ("cache_bytes_max".into(), self.cache_bytes_max().to_string()),
            ("cache_budget".into(), o.stream.cache_bytes.to_string()),
            ("gpu_bytes_uploaded".into(), stat(&|s| s.gpu_bytes_uploaded)),
            (
                "uploads_max_per_frame".into(),
                self.frames
                    .iter()
                    .filter_map(|f| f.stream.as_ref().map(|s| s.uploads))
                    .max()
                    .unwrap_or(0)
                    .to_string(),
            ),
            (
                "tile_latency_ms".into(),
                o.stream.faults.latency_ms.to_string(),
            ),
            (
                "tile_fail_rate".into(),
                format!("{}", o.stream.faults.fail_rate),
            ),
            ("settle_s".into(), num(self.settle_s)),
            ("settled".into(), self.settled.to_string()),
            (
                "final_vs_loaded_px".into(),
                self.final_vs_loaded_px
                    .map_or("null".to_string(), |n| n.to_string()),
            ),
            ("wall_s".into(), format!("{:.3}", self.wall_s)),
        ]);
        for (k, v) in extra {
            fields.push((k.to_string(), v.clone()));
        }
        let body: Vec<String> = fields
            .iter()
            .map(|(k, v)| format!("{}: {v}", json_string(k)))
            .collect();
        format!("{{{}}}", body.join(", "))
    }
}

/// A JSON string literal.
pub fn json_string(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if (c as u32) < 0x20 => out.push_str(&format!("\\u{:04x}", c as u32)),
            c => out.push(c),
        }
    }
    out.push('"');
    out
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

    #[test]
    fn json_strings_are_escaped() {
        assert_eq!(json_string("a\"b\\c\n"), "\"a\\\"b\\\\c\\u000a\"");
    }
}
