//! `globe bench`: a scene, a view, the `flight` path or the `jump`, timed frame by frame.

use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

use anyhow::{Context, bail};
use clap::Args;
use globe::dem::remote::{RemoteStats, RemoteStore};
use globe::instruments::bench::{BenchOptions, BenchRun};
use globe::progress::Progress;
use globe::render::GpuContext;
use globe::scenes::{CAMERA_VIEW_NAME, CameraSpec};
use globe::terrain::Terrain;

use crate::args::*;
use crate::render::*;
use crate::soak::*;

#[derive(Args)]
pub struct BenchArgs {
    /// Scene to benchmark (see `globe scenes`); `flight`: the path from space down to the
    /// ground, played over --frames frames from a cold start; `jump`: the time from a jump
    /// (aircraft → everest) to full detail, and the pipeline's tiles/s and MB/s against the
    /// raw read rate of the same file (--throughput-tiles tiles each); `soak`: a seeded
    /// random flight for --seconds under failing, slow reads (default 5 % and 0-200 ms),
    /// stopping at the end of every leg to compare the settled frame with a fault-free
    /// render, holding memory to its budgets; exits with failure when a check fails.
    #[arg(long, default_value = "aircraft", conflicts_with = "camera")]
    pub scene: String,
    /// Benchmark this view instead of a scene (named "camera" in the outputs). Same form as
    /// `globe render --camera`.
    #[arg(long, value_name = "VIEW", allow_hyphen_values = true)]
    pub camera: Option<CameraSpec>,
    /// Benchmark a recorded camera path (JSON, as the viewer's R key writes it) as `flight`
    /// is: --frames frames spread over it from a cold start (named "path" in the outputs).
    #[arg(long, value_name = "FILE.json", conflicts_with_all = ["camera", "scene"])]
    pub path: Option<std::path::PathBuf>,
    /// Measured frames.
    #[arg(long, default_value_t = 100)]
    pub frames: usize,
    /// Frames rendered before measuring (named scenes only; the flight starts cold).
    #[arg(long, default_value_t = 10)]
    pub warmup: usize,
    /// Start frames at most this often, as a viewer would (streaming gets real time); 0
    /// renders back to back. Default: 60 for `flight`, 0 for a scene.
    #[arg(long)]
    pub fps: Option<f64>,
    #[arg(long, default_value_t = 1280)]
    pub width: u32,
    #[arg(long, default_value_t = 720)]
    pub height: u32,
    /// Also time the same frames drawn by a pass-through pipeline (same triangles on the bare
    /// sphere, no texture reads, flat colour) and report terrain/pass-through GPU time.
    #[arg(long)]
    pub passthrough: bool,
    /// Also time the same frames with the plain look (no surface types, no atmosphere) and
    /// report the look's GPU time over the plain one's (named scenes).
    #[arg(long = "plain-look")]
    pub plain_look: bool,
    /// Also time the same frames with the vertex stage placing the clipmap's vertices (as
    /// before the vertex pre-pass) and report the pre-pass's GPU time over it (named scenes).
    #[arg(long = "vertex-stage")]
    pub vertex_stage: bool,
    /// Tiles read by each side of the `jump` throughput comparison.
    #[arg(long = "throughput-tiles", default_value_t = 256)]
    pub throughput_tiles: usize,
    /// Skip the error measurement of the settled frame (ρ against the terrain function and the
    /// reference ray caster's coverage: seconds per megapixel on the CPU).
    #[arg(long = "no-error")]
    pub no_error: bool,
    #[command(flatten)]
    pub measure_limit: MeasureArgs,
    /// `--scene soak`: seconds of flight on its clock (settle points not counted; default 600).
    #[arg(long, value_name = "S")]
    pub seconds: Option<f64>,
    /// `--scene soak`: the seed of its random path and of the faults it injects.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// `--scene soak`: write the memory trace (camera height, anonymous RSS, decoded-tile
    /// cache, GPU tiles against time, each with its budget) to this PNG.
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
    /// `--scene soak`: write the images of every settle point that differs from the
    /// fault-free render here (flying, reference, and a fresh renderer's).
    #[arg(long = "mismatch-dir", value_name = "DIR")]
    pub mismatch_dir: Option<PathBuf>,
    /// `--scene soak`: how long a settle point may wait for its view to complete.
    #[arg(long = "settle-timeout", value_name = "S", default_value_t = 120.0)]
    pub settle_timeout: f64,
    /// Print one JSON object per run on stdout (one line each) instead of a summary.
    #[arg(long)]
    pub json: bool,
    /// Also write every frame's figures to this CSV file (with several latencies, the
    /// latency is added to the name: FILE-50ms.csv).
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    #[command(flatten)]
    pub mesh: MeshArgs,
    #[command(flatten)]
    pub dem: DemArgs,
    #[command(flatten)]
    pub look: LookArgs,
    #[command(flatten)]
    pub lod: LodArgs,
    #[command(flatten)]
    pub stream: StreamArgs,
}

pub fn bench(args: &BenchArgs) -> anyhow::Result<ExitCode> {
    let path = match &args.path {
        Some(file) => Some(globe::scenes::path::CameraPath::load(file)?),
        None => None,
    };
    let is_flight =
        path.is_some() || (args.camera.is_none() && args.scene == globe::scenes::flight::NAME);
    if args.camera.is_none() && args.scene == globe::instruments::bench::JUMP {
        return bench_jump(args);
    }
    if args.camera.is_none() && args.scene == globe::instruments::soak::NAME {
        return bench_soak(args);
    }
    if args.seconds.is_some() || args.plot.is_some() {
        bail!(
            "--seconds and --plot are for `--scene {}`",
            globe::instruments::soak::NAME
        );
    }
    let name = match path {
        Some(_) => PATH_VIEW_NAME,
        None => view_name(args, is_flight)?,
    };
    if args.frames == 0 {
        bail!("--frames must be at least 1");
    }
    let settings = args.mesh.settings()?;
    let measure_limit = args.measure_limit.limit()?;
    let ctx = GpuContext::headless().context("cannot benchmark without a graphics adapter")?;
    let adapter = ctx.adapter_description();
    eprintln!("adapter: {adapter}");
    let terrain = args.dem.open()?;
    eprintln!("terrain: {}", terrain.describe());
    let remote = terrain.dem().and_then(|d| d.pyramid().remote().cloned());
    let mut runs = Vec::new();
    let latencies = args.stream.latencies(LatencyMs { min: 0, max: 0 });
    for &latency in &latencies {
        let remote_before = remote.as_ref().map(|r| r.stats());
        let options = globe::instruments::bench::BenchOptions {
            scene: name.to_owned(),
            camera: args.camera,
            path: path.clone(),
            frames: args.frames,
            warmup: args.warmup,
            width: args.width,
            height: args.height,
            settings: settings.clone(),
            stream: args.stream.settings_with(latency, 0.0)?,
            measure_error: !args.no_error,
            passthrough: args.passthrough,
            look: args.look.settings(),
            lod: args.lod.settings()?,
            compare_plain_look: args.plain_look,
            compare_vertex_stage: args.vertex_stage,
            frame_interval: frame_interval(args.fps, is_flight)?,
        };
        let label = format!("{name} (latency {latency} ms)");
        let run = run_with_progress(args, &ctx, &terrain, &options, label, measure_limit)?;
        print_file_changes("globe bench", run.last_stream());
        if let Some(path) = &args.csv {
            write_frames_csv(&run, path, latency, latencies.len() > 1)?;
        }
        if args.json {
            println!("{}", run.to_json());
        } else {
            print_bench(&run);
        }
        if let (Some(r), Some(b)) = (&remote, remote_before) {
            print_remote_use(r, &b);
        }
        runs.push(run);
    }
    if runs.len() > 1 {
        print_latency_ratios(&runs);
    }
    Ok(ExitCode::SUCCESS)
}

/// What the outputs call a recorded path's run.
const PATH_VIEW_NAME: &str = "path";

/// The name the outputs give the view: names are checked before the adapter starts, so a
/// misspelt scene fails at once; the library looks them up the same way.
fn view_name(args: &BenchArgs, is_flight: bool) -> anyhow::Result<&'static str> {
    Ok(match args.camera {
        Some(_) => CAMERA_VIEW_NAME,
        None if is_flight => globe::scenes::flight::NAME,
        None => {
            globe::scenes::find(&args.scene)
                .map_err(|e| {
                    e.also_known(&[
                        globe::scenes::flight::NAME,
                        globe::instruments::bench::JUMP,
                        globe::instruments::soak::NAME,
                    ])
                })?
                .name
        }
    })
}

/// `--fps` as the time between frame starts (None: back to back); the flight defaults to a
/// viewer's 60 so that streaming gets the wall time a real flight gives it.
fn frame_interval(fps: Option<f64>, is_flight: bool) -> anyhow::Result<Option<Duration>> {
    let default = if is_flight { 60.0 } else { 0.0 };
    let fps = fps.unwrap_or(default);
    if !(fps >= 0.0 && fps.is_finite()) {
        bail!("--fps must be 0 or more (got {fps})");
    }
    Ok((fps > 0.0).then(|| Duration::from_secs_f64(1.0 / fps)))
}

/// One run, with a progress bar over its frames that gives way to the error measurement's
/// once that starts (the frames are done by then).
fn run_with_progress(
    args: &BenchArgs,
    ctx: &GpuContext,
    terrain: &Terrain,
    options: &BenchOptions,
    label: String,
    measure_limit: Option<Duration>,
) -> anyhow::Result<BenchRun> {
    let progress = RefCell::new(Some(Progress::new(
        label,
        args.frames as u64,
        Some("frames"),
    )));
    let mut measuring = MeasureProgress::default();
    let mut on_measure = |done, total| {
        // The frames are done once the measurement starts.
        if let Some(p) = progress.borrow_mut().take() {
            p.finish();
        }
        measuring.update(done, total)
    };
    let watch = globe::instruments::bench::MeasureWatch {
        limit: measure_limit,
        progress: &mut on_measure,
    };
    let on_frame = |done: usize, _| {
        if let Some(p) = progress.borrow_mut().as_mut() {
            p.set(done as u64)
        }
    };
    let run = globe::instruments::bench::run_with(ctx, terrain, options, on_frame, watch)
        .map_err(|e| args.measure_limit.explain(e.into()))?;
    if let Some(p) = progress.take() {
        p.finish();
    }
    measuring.finish();
    Ok(run)
}

/// `--csv`: the run's frames, one file per latency when there are several (FILE-50ms.csv).
fn write_frames_csv(
    run: &BenchRun,
    path: &Path,
    latency: LatencyMs,
    several: bool,
) -> anyhow::Result<()> {
    let path = if several {
        let stem = path.file_stem().unwrap_or_default().to_string_lossy();
        path.with_file_name(format!("{stem}-{latency}ms.csv"))
    } else {
        path.to_path_buf()
    };
    std::fs::write(&path, run.frames_csv())
        .with_context(|| format!("cannot write {}", path.display()))
}

/// What a remote pyramid cost during one run (`before` its figures at the start): requests,
/// bytes asked for against bytes used, and where the tiles came from.
fn print_remote_use(r: &RemoteStore, b: &RemoteStats) {
    let s = r.stats();
    let used = s.tile_bytes_used - b.tile_bytes_used;
    let asked = s.bytes_requested - b.bytes_requested;
    eprintln!(
        "  remote {}: {} requests ({} failed), {:.2} MiB requested for {:.2} MiB of {} tiles \
         (requested/used {:.3}); {} tiles from the disk cache, {} from memory, {} refused (CRC)",
        r.url(),
        s.requests - b.requests,
        s.request_errors - b.request_errors,
        asked as f64 / 1048576.0,
        used as f64 / 1048576.0,
        s.tiles_fetched - b.tiles_fetched,
        if used > 0 {
            asked as f64 / used as f64
        } else {
            0.0
        },
        s.disk_hits - b.disk_hits,
        s.resident_hits - b.resident_hits,
        s.rejected_tiles - b.rejected_tiles,
    );
}

/// With several latencies, each run's median CPU time against the first's: runs in one
/// process compare where runs in two would not.
fn print_latency_ratios(runs: &[BenchRun]) {
    let base = runs[0].cpu_ms().map(|s| s.0).unwrap_or(f64::NAN);
    eprintln!("median CPU ms per frame against the first latency (same process):");
    for r in runs {
        let cpu = r.cpu_ms().map(|s| s.0).unwrap_or(f64::NAN);
        eprintln!(
            "  latency {:>7} ms: {cpu:8.3} ms  ratio {:.3}",
            LatencyMs::of(&r.options.stream.faults).to_string(),
            cpu / base
        );
    }
}

pub fn print_bench(run: &globe::instruments::bench::BenchRun) {
    let o = &run.options;
    println!(
        "{} {}×{}, {} frames, latency {} ms, fail rate {}",
        o.scene,
        o.width,
        o.height,
        run.frames.len(),
        LatencyMs::of(&o.stream.faults),
        o.stream.faults.fail_rate
    );
    if let Some((m, lo, hi)) = run.cpu_ms() {
        println!("  CPU ms/frame   median {m:.3}  min {lo:.3}  max {hi:.3}");
    }
    match run.gpu_ms() {
        Some((m, lo, hi)) => {
            println!(
                "  GPU ms (terrain: its compute passes and the pass) median {m:.3}  min {lo:.3}  max {hi:.3}"
            )
        }
        None => println!("  GPU ms: the adapter has no timestamp queries"),
    }
    let fills: Vec<f64> = run.frames.iter().filter_map(|f| f.fill_gpu_ms).collect();
    if let Some((m, lo, hi)) = globe::instruments::bench::summary(&fills) {
        println!(
            "  GPU ms (compute fill, {} frames that filled) median {m:.3}  min {lo:.3}  max {hi:.3}",
            fills.len()
        );
    }
    if let Some(s) = run.last_stream() {
        println!(
            "  tiles requested {} loaded {} cancelled {} failed {} (retries {})",
            s.stream.tiles_requested,
            s.stream.tiles_loaded,
            s.stream.tiles_cancelled,
            s.stream.tiles_failed,
            s.stream.retries
        );
        println!(
            "  cache max {:.1} MiB of {:.0} MiB; GPU uploads {:.1} MiB",
            run.cache_bytes_max() as f64 / 1048576.0,
            o.stream.cache_bytes as f64 / 1048576.0,
            s.gpu_bytes_uploaded as f64 / 1048576.0
        );
    }
    if let (Some(p), Some(t)) = (run.passthrough_gpu_ms(), run.gpu_ms()) {
        println!(
            "  pass-through GPU ms median {p:.3}: terrain / pass-through {:.2}",
            t.0 / p
        );
    }
    if let (Some(p), Some(t)) = (run.plain_look_gpu_ms(), run.gpu_ms()) {
        println!(
            "  plain look GPU ms median {p:.3}: look / plain {:.2}",
            t.0 / p
        );
    }
    if let (Some(v), Some(t)) = (run.vertex_stage_gpu_ms(), run.gpu_ms()) {
        println!(
            "  vertex stage placing GPU ms median {v:.3}: pre-pass / vertex stage {:.2}",
            t.0 / v
        );
    }
    if let Some(e) = &run.error {
        println!(
            "  error (settled frame): mean ρ {:.3} px, p99 {:.3} px, max {:.3} px, {:.3} % above {} px, {} px coverage mismatches",
            e.mean_px,
            e.p99_px,
            e.max_px,
            100.0 * e.error_pixel_share,
            e.threshold_px,
            e.coverage.map_or(0, |c| c.mismatched())
        );
    }
    if let (Some(t), Some(px)) = (run.settle_s, run.final_vs_loaded_px) {
        println!(
            "  settled {} s after the last frame ({}); last frame vs. everything loaded: {px} px differ",
            format_args!("{t:.2}"),
            if run.settled { "complete" } else { "TIMED OUT" }
        );
    }
}

pub fn bench_jump(args: &BenchArgs) -> anyhow::Result<ExitCode> {
    let ctx = GpuContext::headless().context("cannot benchmark without a graphics adapter")?;
    eprintln!("adapter: {}", ctx.adapter_description());
    let terrain = args.dem.open()?;
    eprintln!("terrain: {}", terrain.describe());
    let options = globe::instruments::bench::JumpOptions {
        width: args.width,
        height: args.height,
        settings: args.mesh.settings()?,
        stream: args.stream.settings()?,
        throughput_tiles: args.throughput_tiles,
    };
    let run =
        globe::instruments::bench::run_jump(&ctx, &terrain, &options, |line| eprintln!("{line}"))?;
    if args.json {
        println!("{}", run.to_json());
        return Ok(ExitCode::SUCCESS);
    }
    let (jump, tp) = (&run.jump, &run.throughput);
    println!(
        "jump {} → {}: full detail after {:.3} s ({} frames, {} tiles loaded, {} cancelled, {:.1} MiB)",
        jump.from,
        jump.to,
        jump.to_full_detail_s,
        jump.frames,
        jump.tiles_loaded,
        jump.tiles_cancelled,
        jump.bytes_read as f64 / 1048576.0
    );
    for (pass, what) in ["first pass", "second pass (page cache)"]
        .iter()
        .enumerate()
    {
        println!(
            "throughput, {what}, {} tiles each: pipeline {:.1} tiles/s ({:.1} MB/s), raw {:.1} tiles/s ({:.1} MB/s): pipeline/raw {:.3}",
            tp.tiles,
            tp.tiles_per_s(tp.pipeline_s[pass]),
            tp.mb_per_s(tp.pipeline_s[pass]),
            tp.tiles_per_s(tp.raw_s[pass]),
            tp.mb_per_s(tp.raw_s[pass]),
            tp.raw_s[pass] / tp.pipeline_s[pass]
        );
    }
    Ok(ExitCode::SUCCESS)
}
