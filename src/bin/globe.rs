//! `globe`: the viewer, and its headless commands (`render`, `scenes`).

use std::cell::RefCell;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, bail};
use clap::{Args, Parser, Subcommand, ValueEnum};
use globe::clipmap::selection::LevelStatus;
use globe::clipmap::settings::DEFAULT_ERROR_BUDGET_PX;
use globe::clipmap::{ClipmapSettings, TransformForm};
use globe::look::{LookSettings, MipKind};
use globe::plan::{LodMode, LodSettings};
use globe::planar::geomip::GeomipSettings;
use globe::planar::projgrid::ProjGridSettings;
use globe::procedural::DetailSpec;
use globe::progress::Progress;
use globe::render::offscreen::{COLOR_FORMAT, OffscreenFrame};
use globe::render::{GpuContext, TerrainRenderer};
use globe::scenes::{CAMERA_VIEW_NAME, CameraSpec, SCENES};
use globe::stream::{FaultSettings, StreamSettings};
use globe::terrain::Terrain;

#[derive(Parser)]
#[command(
    name = "globe",
    version,
    about = "A planetary globe viewer: spherical geometry clipmaps from orbit to the ground",
    long_about = "A planetary globe viewer: spherical geometry clipmaps from orbit to the ground.\n\n\
                  With no command, opens the viewer window. Without a display use `globe render`."
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    #[command(flatten)]
    viewer: ViewerArgs,
}

#[derive(Subcommand)]
enum Command {
    /// Render a named scene or a --camera view headless (no window, no GPU needed: a software adapter works) to PNG.
    Render(RenderArgs),
    /// Benchmark a scene, a --camera view or the `flight` path headless: per-frame CPU and GPU time,
    /// triangles, levels, streaming counters (median/min/max; `--json` for one JSON object).
    Bench(BenchArgs),
    /// Run every method and setting over the named scenes and write report.csv, report.json,
    /// report.md and error_vs_time.png/.svg: triangles, CPU/GPU time and the per-pixel error ρ.
    Report(ReportArgs),
    /// List the named scenes (the viewer's bookmarks).
    Scenes,
}

#[derive(Args)]
struct ReportArgs {
    /// Folder to write the report's files into (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Scenes to run, comma-separated [default: space,aircraft,ground; none with --camera].
    #[arg(long, value_delimiter = ',')]
    scenes: Option<Vec<String>>,
    /// Also run this view (after --scenes; alone without --scenes), named "camera" in the
    /// outputs. Same form as `globe render --camera`.
    #[arg(long, value_name = "VIEW", allow_hyphen_values = true)]
    camera: Option<CameraSpec>,
    #[arg(long, default_value_t = 1920)]
    width: u32,
    #[arg(long, default_value_t = 1080)]
    height: u32,
    /// Timed frames per setting (medians reported).
    #[arg(long, default_value_t = 5)]
    frames: usize,
    /// Cast the reference at every Nth pixel in x and y (1: all). The error statistics then
    /// cover that sample, at the full resolution's pixel footprint (the reference over rough
    /// procedural detail costs minutes per full 1080p frame on two cores).
    #[arg(long, value_name = "N", default_value_t = 1)]
    every: u32,
    /// Run the error-bounded projected grid's Tables 1–2 instead of the settings grid: grids
    /// 1024x512, 512x256, 600x600, 300x900 and 400x1900, uniform and warped, without and with
    /// ray casting, beside the clipmap (the paper used --width 1024 --height 800); also writes
    /// projgrid_tables.md.
    #[arg(long = "projgrid-tables")]
    projgrid_tables: bool,
    #[command(flatten)]
    measure_limit: MeasureArgs,
    /// The base settings every row varies one parameter of.
    #[command(flatten)]
    mesh: MeshArgs,
    #[command(flatten)]
    dem: DemArgs,
    #[command(flatten)]
    look: LookArgs,
    #[command(flatten)]
    lod: LodArgs,
    #[command(flatten)]
    stream: StreamArgs,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Overlay {
    /// Each clipmap level in its own colour; geomipmapping patches by tessellation level
    /// (white finest, toward red coarsest).
    Levels,
    /// Every triangle's edges (barycentric, so on every adapter), for every LOD method.
    Wireframe,
    /// The per-pixel screen-space error ρ as a heat map (blue 0 px, yellow 1 px, red ≥ 4 px),
    /// computed on the CPU against the terrain function (`globe render` only).
    Error,
}

/// Clipmap settings; the defaults are explained in README.md.
#[derive(Args, Clone, Debug)]
struct MeshArgs {
    /// The one error knob: target max screen-space error ρ in pixels at the frame's
    /// resolution. The vertex spacing, the texture size and (below 1 px) the mesh resolution
    /// follow from it (README "One error knob"); the flags below override single settings.
    #[arg(long = "error-budget", value_name = "PX", default_value_t = DEFAULT_ERROR_BUDGET_PX)]
    error_budget_px: f32,
    /// n: φ̃ steps around each ring (a multiple of 2 × sectors) [default: from --error-budget, 512].
    #[arg(long = "phi-steps", value_name = "N")]
    phi_steps: Option<u32>,
    /// m: rings per level [default: from --error-budget, 32].
    #[arg(long = "rings", value_name = "M")]
    rings_per_level: Option<u32>,
    /// Most levels a frame may draw (level i spans θ̃ ∈ (2^-(i+1)π, 2^-iπ]; level 29 is 7.5 cm
    /// across, level 39 0.07 mm). A frame draws down to the pixel bound, and no level whose
    /// disk around the nadir is out of view; 40 keeps the cap under a camera 1 mm above the
    /// detail a fraction of a millimetre wide.
    #[arg(long, default_value_t = ClipmapSettings::default().levels)]
    levels: u32,
    /// Side of each level texture in texels (a power of two) [default: from --error-budget, 512].
    #[arg(long = "texture-size", value_name = "TEXELS")]
    texture_size: Option<u32>,
    /// φ̃ sectors per level, culled against the view frustum.
    #[arg(long, default_value_t = ClipmapSettings::default().sectors)]
    sectors: u32,
    /// Map transform form used by the vertex shader: direct (paper eq. 4), stable (DESIGN.md),
    /// approximate (paper eq. 11/14 on inner levels, blended into stable).
    #[arg(long, value_name = "FORM", default_value = "stable")]
    transform: TransformForm,
    /// First level using the approximation with --transform approximate.
    #[arg(long = "approx-start-level", value_name = "LEVEL", default_value_t = ClipmapSettings::default().approx_start_level)]
    approx_start_level: u32,
    /// Target on-screen spacing of the mesh's vertices in pixels: each level is drawn at the
    /// coarsest ring density (n/2^k, m/2^k; k ≤ 4 at the default n and m) that keeps its
    /// vertices this close; 0 draws every level at full density [default: from
    /// --error-budget, 5 × the budget].
    #[arg(long = "vertex-spacing", value_name = "PX")]
    target_spacing_px: Option<f32>,
}

impl MeshArgs {
    fn settings(&self) -> anyhow::Result<ClipmapSettings> {
        let budget = ClipmapSettings::for_error_budget(self.error_budget_px)
            .context("invalid --error-budget")?;
        let settings = ClipmapSettings {
            phi_steps: self.phi_steps.unwrap_or(budget.phi_steps),
            rings_per_level: self.rings_per_level.unwrap_or(budget.rings_per_level),
            levels: self.levels,
            texture_size: self.texture_size.unwrap_or(budget.texture_size),
            sectors: self.sectors,
            transform: self.transform,
            approx_start_level: self.approx_start_level,
            target_spacing_px: self.target_spacing_px.unwrap_or(budget.target_spacing_px),
            ..budget
        };
        settings.validate().context("invalid mesh settings")?;
        Ok(settings)
    }
}

/// The terrain to draw.
#[derive(Args, Clone, Debug)]
struct DemArgs {
    /// `embedded` (the real Earth inside the binary: ETOPO5 at 10′), `analytic` (the test
    /// planet), a pyramid file made by `globe-data import`, or a raster to import into the cache
    /// first (a folder of GTOPO30-style tiles, of SRTM .hgt tiles or of GeoTIFFs; one .HDR/.DEM;
    /// a netCDF-3 file such as ETOPO5; a GeoTIFF/COG; an SRTM .hgt tile).
    #[arg(long, value_name = "SOURCE", default_value = "embedded")]
    dem: String,
    /// Procedural detail below the data's resolution: `default` (on), `off`, or a detail
    /// parameter file (JSON; README "Procedural detail" lists the fields and their ranges).
    #[arg(long, value_name = "off|default|FILE", default_value = "default")]
    detail: DetailSpec,
    /// Water at sea level: the surface is max(height, 0 m), shaded as water (measured as that
    /// surface too); off: the bathymetry, tinted.
    #[arg(long, value_name = "on|off", default_value = "on")]
    water: Switch,
    /// A remote pyramid (`--dem https://…`, `s3://bucket/key`): the local disk cache of fetched
    /// tiles, MiB (0: none), so a second visit costs no request.
    #[arg(long, value_name = "MIB", default_value_t = 512)]
    disk_cache_mb: u64,
    /// Where that disk cache lives (default: the cache folder's `remote/`).
    #[arg(long, value_name = "DIR")]
    disk_cache_dir: Option<std::path::PathBuf>,
    /// A remote pyramid: requests in flight at most.
    #[arg(long, value_name = "N", default_value_t = 8)]
    remote_requests: usize,
    /// A remote pyramid: added before every request (a simulated round trip, for measuring).
    #[arg(long, value_name = "MS", default_value_t = 0)]
    remote_latency_ms: u64,
    /// A remote pyramid: the coarsest levels fitting in this many KiB are fetched at open.
    #[arg(long, value_name = "KIB", default_value_t = 4096)]
    remote_prefetch_kb: u64,
}

impl DemArgs {
    fn remote_options(&self) -> globe::stream::RemoteOptions {
        globe::stream::RemoteOptions {
            disk_cache_bytes: self.disk_cache_mb << 20,
            disk_cache_dir: self.disk_cache_dir.clone(),
            max_requests: self.remote_requests.max(1),
            latency: std::time::Duration::from_millis(self.remote_latency_ms),
            prefetch_bytes: self.remote_prefetch_kb << 10,
            ..Default::default()
        }
    }

    fn open(&self) -> anyhow::Result<Terrain> {
        // Shown only once an import starts (an open from the cache reports nothing).
        let mut progress = None;
        let remote = self.remote_options();
        let terrain = globe::terrain::open_terrain_with(&self.dem, remote, |fraction| {
            progress
                .get_or_insert_with(|| {
                    let label = format!("importing {} into the cache", self.dem);
                    Progress::new(label, 1000, None)
                })
                .set_fraction(fraction)
        })
        .with_context(|| format!("cannot open the terrain '{}'", self.dem))?;
        if let Some(p) = progress {
            p.finish();
        }
        let params = self.detail.params()?;
        let water = self.water.on().then_some(globe::look::SEA_LEVEL_M);
        Ok(terrain.with_detail(params).with_water_level(water))
    }
}

/// On or off (a flag's value).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Switch {
    On,
    Off,
}

impl Switch {
    fn on(self) -> bool {
        self == Switch::On
    }
}

/// The proto-textures' mipmaps.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum TextureMips {
    /// Variance-reducing (infinite-landscapes paper §4.2): far terrain neither shimmers nor
    /// repeats.
    Variance,
    /// Plain box-filtered mipmaps (for comparison).
    Standard,
}

/// The look of the planet (README "The look"). None of it changes the measured error.
#[derive(Args, Clone, Debug)]
struct LookArgs {
    /// Proto-textured surface types (sand, grass, forest, rock, snow by height, slope and
    /// latitude); off: the hypsometric tint.
    #[arg(long, value_name = "on|off", default_value = "on")]
    textures: Switch,
    /// The atmosphere: the sky, the glow around the disk from space, haze toward the horizon;
    /// off: a flat sky colour and raw terrain colours.
    #[arg(long, value_name = "on|off", default_value = "on")]
    sky: Switch,
    /// Mipmaps of the proto-textures.
    #[arg(long = "texture-mips", value_name = "KIND", default_value = "variance")]
    texture_mips: TextureMips,
}

impl LookArgs {
    fn settings(&self) -> LookSettings {
        LookSettings {
            textures: self.textures.on(),
            sky: self.sky.on(),
            mips: match self.texture_mips {
                TextureMips::Variance => MipKind::VarianceReducing,
                TextureMips::Standard => MipKind::Standard,
            },
        }
    }
}

/// Which LOD method draws the ground near the viewer, and its settings.
#[derive(Args, Clone, Debug)]
struct LodArgs {
    /// LOD method near the ground: `clipmap` (the spherical clipmap alone), `geomip`
    /// (geomipmapping with geomorphing on the tangent plane around the viewer, the clipmap
    /// beyond), `projgrid` (the error-bounded projected grid over the whole view, ray casting
    /// the cells whose error exceeds γ), `auto` (geomip below 1 000 m above the terrain, the
    /// clipmap alone above 1 500 m; README "Close-up modes").
    #[arg(long, value_name = "MODE", default_value = "clipmap")]
    mode: ModeArg,
    /// Geomipmapping's level threshold τ: the largest projected error a patch may show, pixels.
    #[arg(long, value_name = "PX", default_value_t = 1.0)]
    tau: f64,
    /// Geomipmapping's patch size in vertices per side, 2^n + 1 (the paper's 17).
    #[arg(long = "patch-size", value_name = "N", default_value_t = 17)]
    patch_size: u32,
    /// Geomipmapping's patches per side of the square around the viewer (even, 2 to 64); the
    /// finest spacing is a sixteenth of the height above the terrain, so the square's side is
    /// this × (N − 1) × that.
    #[arg(long, value_name = "N", default_value_t = 32)]
    patches: u32,
    /// Geomorphing of the patches (off: levels switch whole and pop).
    #[arg(long, value_name = "on|off", default_value = "on")]
    geomorph: Switch,
    /// The projected grid's cells, COLSxROWS (e.g. 512x256).
    #[arg(long, value_name = "COLSxROWS", default_value = "256x256", value_parser = parse_grid)]
    grid: (u32, u32),
    /// The projected grid's error threshold γ: cells whose screen-space error bound exceeds it
    /// are ray cast, pixels (> 0).
    #[arg(long, value_name = "PX", default_value_t = 1.0)]
    gamma: f64,
    /// The projected grid warped by importance (more cells where the error bound is high) or
    /// uniform in the projector's (ψ, θ̃), already denser near the viewer; off by default: the
    /// uniform grid measured better (README "Close-up modes").
    #[arg(long, value_name = "on|off", default_value = "off")]
    warp: Switch,
    /// Ray casting of the projected grid's cells whose error exceeds γ.
    #[arg(long = "ray-cast", value_name = "on|off", default_value = "on")]
    ray_cast: Switch,
}

/// `--grid COLSxROWS`.
fn parse_grid(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("{s:?}: expected COLSxROWS, two whole numbers such as 512x256");
    let (c, r) = s.split_once(['x', 'X', '×']).ok_or_else(bad)?;
    Ok((
        c.trim().parse().map_err(|_| bad())?,
        r.trim().parse().map_err(|_| bad())?,
    ))
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum ModeArg {
    Clipmap,
    Geomip,
    Projgrid,
    Auto,
}

impl LodArgs {
    fn settings(&self) -> anyhow::Result<LodSettings> {
        let geomip = GeomipSettings {
            patch_size: self.patch_size,
            patches: self.patches,
            tau_px: self.tau,
            geomorph: self.geomorph.on(),
        };
        geomip.validate()?;
        let projgrid = ProjGridSettings {
            cols: self.grid.0,
            rows: self.grid.1,
            gamma_px: self.gamma,
            warp: self.warp.on(),
            ray_cast: self.ray_cast.on(),
        };
        projgrid.validate()?;
        Ok(LodSettings {
            mode: match self.mode {
                ModeArg::Clipmap => LodMode::Clipmap,
                ModeArg::Geomip => LodMode::Geomip,
                ModeArg::Projgrid => LodMode::Projgrid,
                ModeArg::Auto => LodMode::Auto,
            },
            geomip,
            projgrid,
        })
    }
}

/// How DEM tiles stream from the pyramid file, and faults to inject.
#[derive(Args, Clone, Debug)]
struct StreamArgs {
    /// Latency added to every tile read, in milliseconds (fault injection): MS, or MIN-MAX to
    /// draw each read's latency from that range. `globe bench` takes a comma-separated list
    /// and runs once per value, in one process. Default 0 (`--scene soak`: 0-200).
    #[arg(long = "tile-latency-ms", value_name = "MS", value_delimiter = ',')]
    tile_latency_ms: Vec<LatencyMs>,
    /// Fraction of tile reads that fail, 0…1 (fault injection; failed reads are retried).
    /// Default 0 (`--scene soak`: 0.05).
    #[arg(long = "tile-fail-rate", value_name = "F")]
    tile_fail_rate: Option<f64>,
    /// Budget of the decoded-tile cache in MiB. The tiles the frame in progress needs (the
    /// camera's ground, tiles on their way to the GPU) stay even beyond it: 0 keeps only those.
    #[arg(long = "cache-mb", value_name = "MIB", default_value_t = globe::stream::DEFAULT_CACHE_BYTES >> 20)]
    cache_mb: u64,
    /// Tiles the GPU tile cache holds (256² × 2 bytes each). A clipmap level is filled from
    /// its tiles all resident at once: too few for a level of the view is an error naming the
    /// smallest that works there.
    #[arg(long = "gpu-tiles", value_name = "N", default_value_t = StreamSettings::default().gpu_tiles)]
    gpu_tiles: u32,
    /// Tiles uploaded to the GPU per frame at most (at least 1).
    #[arg(long = "uploads-per-frame", value_name = "N", default_value_t = StreamSettings::default().uploads_per_frame)]
    uploads_per_frame: u32,
    /// Tile reads in flight at most (at least 1).
    #[arg(long = "max-in-flight", value_name = "N", default_value_t = StreamSettings::default().max_in_flight)]
    max_in_flight: usize,
}

/// A tile read's added latency: fixed, or drawn per read from a range.
#[derive(Clone, Copy, Debug, PartialEq)]
struct LatencyMs {
    min: u64,
    max: u64,
}

impl std::fmt::Display for LatencyMs {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.max > self.min {
            write!(f, "{}-{}", self.min, self.max)
        } else {
            write!(f, "{}", self.min)
        }
    }
}

impl std::str::FromStr for LatencyMs {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        let number = |t: &str| {
            t.trim()
                .parse::<u64>()
                .map_err(|_| format!("`{text}` is not MS or MIN-MAX in whole milliseconds"))
        };
        match text.split_once('-') {
            None => number(text).map(|ms| LatencyMs { min: ms, max: ms }),
            Some((a, b)) => {
                let (min, max) = (number(a)?, number(b)?);
                if max < min {
                    return Err(format!(
                        "`{text}`: the range's maximum is below its minimum"
                    ));
                }
                Ok(LatencyMs { min, max })
            }
        }
    }
}

/// The latency the faults inject, as `--tile-latency-ms` takes it.
fn latency_of(f: &FaultSettings) -> LatencyMs {
    LatencyMs {
        min: f.latency_ms,
        max: f.latency_max_ms.max(f.latency_ms),
    }
}

impl StreamArgs {
    /// The latencies asked for, or `default` when none were.
    fn latencies(&self, default: LatencyMs) -> Vec<LatencyMs> {
        if self.tile_latency_ms.is_empty() {
            vec![default]
        } else {
            self.tile_latency_ms.clone()
        }
    }

    /// The settings with one latency of the list and the fail rate (`default_fail_rate` when
    /// none was given).
    fn settings_with(
        &self,
        latency: LatencyMs,
        default_fail_rate: f64,
    ) -> anyhow::Result<StreamSettings> {
        let fail_rate = self.tile_fail_rate.unwrap_or(default_fail_rate);
        if !(0.0..=1.0).contains(&fail_rate) {
            bail!("--tile-fail-rate must be between 0 and 1 (got {fail_rate})");
        }
        if fail_rate >= 1.0 {
            bail!("--tile-fail-rate 1 would fail every read: no tile could ever load");
        }
        // The smallest --gpu-tiles that works depends on the view: the renderer names it on
        // the view's first frames (`GpuTilesShort`). --cache-mb has none: the LRU keeps what
        // the frame in progress needs even beyond its budget.
        if self.max_in_flight == 0 {
            bail!("--max-in-flight 0 would never read a tile: the smallest that works is 1");
        }
        if self.uploads_per_frame == 0 {
            bail!(
                "--uploads-per-frame 0 would never upload a tile to the GPU: the smallest that \
                 works is 1"
            );
        }
        Ok(StreamSettings {
            cache_bytes: self.cache_mb.saturating_mul(1 << 20),
            gpu_tiles: self.gpu_tiles,
            uploads_per_frame: self.uploads_per_frame,
            max_in_flight: self.max_in_flight,
            faults: FaultSettings {
                latency_ms: latency.min,
                latency_max_ms: latency.max,
                fail_rate,
                seed: 0x5EED,
            },
            ..StreamSettings::default()
        })
    }

    /// The settings, for commands that take one latency.
    fn settings(&self) -> anyhow::Result<StreamSettings> {
        match self.latencies(LatencyMs { min: 0, max: 0 }).as_slice() {
            [one] => self.settings_with(*one, 0.0),
            _ => bail!("--tile-latency-ms takes one value here (a list only with `globe bench`)"),
        }
    }
}

/// How long measuring the error may take.
#[derive(Args, Clone, Debug)]
struct MeasureArgs {
    /// Stop measuring the error after this many seconds, with a message saying how far the
    /// reference ray cast got (0: no limit). At 1920×1080 on two CPU cores a named scene over
    /// ETOPO5 takes seconds to a few minutes, `ground` (rays grazing the procedural detail)
    /// far longer (README "Measuring time"); a progress line shows the time left.
    #[arg(long = "measure-timeout", value_name = "SECONDS", default_value_t = DEFAULT_MEASURE_TIMEOUT_S)]
    measure_timeout_s: f64,
}

/// `--measure-timeout`'s default: an hour, over ten times the slowest named scene but
/// `ground` (README "Measuring time"); a crawl stops instead of hanging a report for hours.
const DEFAULT_MEASURE_TIMEOUT_S: f64 = 3600.0;

impl MeasureArgs {
    fn limit(&self) -> anyhow::Result<Option<std::time::Duration>> {
        let s = self.measure_timeout_s;
        if !(s >= 0.0 && s.is_finite()) {
            bail!("--measure-timeout must be 0 (no limit) or a number of seconds (got {s})");
        }
        Ok((s > 0.0).then(|| std::time::Duration::from_secs_f64(s)))
    }

    /// Names the flag when the reference ray cast stopped at its limit.
    fn explain(&self, e: anyhow::Error) -> anyhow::Error {
        let timed_out = e.chain().any(|c| {
            matches!(
                c.downcast_ref::<globe::measure::MeasureError>(),
                Some(globe::measure::MeasureError::TimedOut { .. })
            ) || matches!(
                c.downcast_ref::<globe::bench::BenchError>(),
                Some(globe::bench::BenchError::Measure(
                    globe::measure::MeasureError::TimedOut { .. }
                ))
            )
        });
        if timed_out {
            e.context(format!(
                "measuring the error stopped at --measure-timeout {} s: raise it (0: no \
                 limit), or measure fewer pixels (--width/--height; `globe report --every N`)",
                self.measure_timeout_s
            ))
        } else {
            e
        }
    }
}

/// The progress line of a reference ray cast, shown from its first report on.
#[derive(Default)]
struct MeasureProgress(Option<Progress>);

impl MeasureProgress {
    fn update(&mut self, done: usize, total: usize) {
        self.0
            .get_or_insert_with(|| {
                Progress::new(
                    "measuring the error (reference ray cast)",
                    total as u64,
                    Some("px"),
                )
            })
            .set(done as u64);
    }

    fn finish(self) {
        if let Some(p) = self.0 {
            p.finish();
        }
    }
}

#[derive(Args)]
struct BenchArgs {
    /// Scene to benchmark (see `globe scenes`); `flight`: the path from space down to the
    /// ground, played over --frames frames from a cold start; `jump`: the time from a jump
    /// (aircraft → everest) to full detail, and the pipeline's tiles/s and MB/s against the
    /// raw read rate of the same file (--throughput-tiles tiles each); `soak`: a seeded
    /// random flight for --seconds under failing, slow reads (default 5 % and 0-200 ms),
    /// stopping at the end of every leg to compare the settled frame with a fault-free
    /// render, holding memory to its budgets; exits with failure when a check fails.
    #[arg(long, default_value = "aircraft", conflicts_with = "camera")]
    scene: String,
    /// Benchmark this view instead of a scene (named "camera" in the outputs). Same form as
    /// `globe render --camera`.
    #[arg(long, value_name = "VIEW", allow_hyphen_values = true)]
    camera: Option<CameraSpec>,
    /// Measured frames.
    #[arg(long, default_value_t = 100)]
    frames: usize,
    /// Frames rendered before measuring (named scenes only; the flight starts cold).
    #[arg(long, default_value_t = 10)]
    warmup: usize,
    /// Start frames at most this often, as a viewer would (streaming gets real time); 0
    /// renders back to back. Default: 60 for `flight`, 0 for a scene.
    #[arg(long)]
    fps: Option<f64>,
    #[arg(long, default_value_t = 1280)]
    width: u32,
    #[arg(long, default_value_t = 720)]
    height: u32,
    /// Also time the same frames drawn by a pass-through pipeline (same triangles on the bare
    /// sphere, no texture reads, flat colour) and report terrain/pass-through GPU time.
    #[arg(long)]
    passthrough: bool,
    /// Also time the same frames with the plain look (no surface types, no atmosphere) and
    /// report the look's GPU time over the plain one's (named scenes).
    #[arg(long = "plain-look")]
    plain_look: bool,
    /// Also time the same frames with the vertex stage placing the clipmap's vertices (as
    /// before the vertex pre-pass) and report the pre-pass's GPU time over it (named scenes).
    #[arg(long = "vertex-stage")]
    vertex_stage: bool,
    /// Tiles read by each side of the `jump` throughput comparison.
    #[arg(long = "throughput-tiles", default_value_t = 256)]
    throughput_tiles: usize,
    /// Skip the error measurement of the settled frame (ρ against the terrain function and the
    /// reference ray caster's coverage: seconds per megapixel on the CPU).
    #[arg(long = "no-error")]
    no_error: bool,
    #[command(flatten)]
    measure_limit: MeasureArgs,
    /// `--scene soak`: seconds of flight on its clock (settle points not counted; default 600).
    #[arg(long, value_name = "S")]
    seconds: Option<f64>,
    /// `--scene soak`: the seed of its random path and of the faults it injects.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// `--scene soak`: write the memory trace (camera height, anonymous RSS, decoded-tile
    /// cache, GPU tiles against time, each with its budget) to this PNG.
    #[arg(long, value_name = "FILE")]
    plot: Option<PathBuf>,
    /// `--scene soak`: write the images of every settle point that differs from the
    /// fault-free render here (flying, reference, and a fresh renderer's).
    #[arg(long = "mismatch-dir", value_name = "DIR")]
    mismatch_dir: Option<PathBuf>,
    /// `--scene soak`: how long a settle point may wait for its view to complete.
    #[arg(long = "settle-timeout", value_name = "S", default_value_t = 120.0)]
    settle_timeout: f64,
    /// Print one JSON object per run on stdout (one line each) instead of a summary.
    #[arg(long)]
    json: bool,
    /// Also write every frame's figures to this CSV file (with several latencies, the
    /// latency is added to the name: FILE-50ms.csv).
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,
    #[command(flatten)]
    mesh: MeshArgs,
    #[command(flatten)]
    dem: DemArgs,
    #[command(flatten)]
    look: LookArgs,
    #[command(flatten)]
    lod: LodArgs,
    #[command(flatten)]
    stream: StreamArgs,
}

#[derive(Args)]
struct ViewerArgs {
    /// Bookmark to open the viewer at (see `globe scenes`).
    #[arg(long, default_value = "space", conflicts_with = "camera")]
    scene: String,
    /// Open the viewer at this view instead of a bookmark. Same form as `globe render
    /// --camera`; the panel's "go to" field takes it too.
    #[arg(long, value_name = "VIEW", allow_hyphen_values = true)]
    camera: Option<CameraSpec>,
    /// Debug overlay to start with.
    #[arg(long)]
    overlay: Option<Overlay>,
    #[command(flatten)]
    mesh: MeshArgs,
    #[command(flatten)]
    dem: DemArgs,
    #[command(flatten)]
    look: LookArgs,
    #[command(flatten)]
    lod: LodArgs,
    #[command(flatten)]
    stream: StreamArgs,
}

#[derive(Args)]
#[group(id = "view", required = true, multiple = false, args = ["scene", "camera"])]
struct RenderArgs {
    /// Named scene to render (see `globe scenes`).
    #[arg(long)]
    scene: Option<String>,
    /// Render this view instead of a scene: LAT,LON,HEIGHT,HEADING,PITCH[,ROLL] in degrees
    /// and metres (60° vertical field of view). HEIGHT is above the terrain under the camera;
    /// HEIGHT@sphere is above the sphere of radius R = 6 371 000 m. Latitude and pitch in
    /// [-90, 90], longitude in [-360, 360], heading and roll any; e.g. `--camera
    /// 45.65,10.65,500,90,-10` or `--camera=-33.4,-70.2,3000@sphere,0,-20,5`.
    #[arg(long, value_name = "VIEW", allow_hyphen_values = true)]
    camera: Option<CameraSpec>,
    /// Image width in pixels.
    #[arg(long, default_value_t = 1280)]
    width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 720)]
    height: u32,
    /// Output PNG file.
    #[arg(long)]
    out: PathBuf,
    /// Debug overlay to draw.
    #[arg(long)]
    overlay: Option<Overlay>,
    /// Render with whatever tiles have arrived instead of waiting for streaming to settle.
    #[arg(long = "no-wait")]
    no_wait: bool,
    /// Wait at most this many seconds for streaming to settle; past it, stop with what the
    /// view was still waiting for.
    #[arg(long = "settle-timeout", value_name = "SECONDS", default_value_t = globe::render::offscreen::SETTLE_TIMEOUT.as_secs_f64())]
    settle_timeout_s: f64,
    /// Print the frame's error: ρ statistics against the terrain function and coverage
    /// mismatches against the reference ray caster (slow: seconds per megapixel).
    #[arg(long)]
    measure: bool,
    #[command(flatten)]
    measure_limit: MeasureArgs,
    #[command(flatten)]
    mesh: MeshArgs,
    #[command(flatten)]
    dem: DemArgs,
    #[command(flatten)]
    look: LookArgs,
    #[command(flatten)]
    lod: LodArgs,
    #[command(flatten)]
    stream: StreamArgs,
}

fn main() -> ExitCode {
    match run() {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e}");
            for cause in e.chain().skip(1) {
                eprintln!("  caused by: {cause}");
            }
            ExitCode::FAILURE
        }
    }
}

fn run() -> anyhow::Result<ExitCode> {
    let cli = Cli::parse();
    if cli.command.is_some() {
        // SAFETY: nothing has started a thread yet (argument parsing only).
        unsafe { globe::render::context::leave_the_display_alone() };
    }
    match cli.command {
        Some(Command::Scenes) => {
            print_scenes();
            Ok(ExitCode::SUCCESS)
        }
        Some(Command::Render(args)) => render(&args),
        Some(Command::Bench(args)) => bench(&args),
        Some(Command::Report(args)) => report(&args),
        None => viewer(&cli.viewer),
    }
}

/// The view a command draws and its name: `--camera` (named "camera") or the scene `name`.
fn chosen_view(name: &str, camera: Option<CameraSpec>) -> anyhow::Result<(String, CameraSpec)> {
    Ok(match camera {
        Some(view) => (CAMERA_VIEW_NAME.to_owned(), view),
        None => (name.to_owned(), globe::scenes::find(name)?.view()),
    })
}

fn print_scenes() {
    println!(
        "{:<13} {:>9} {:>9}  {:<22} {:>8} {:>6}  stresses",
        "scene", "lat °", "lon °", "height", "heading", "pitch"
    );
    for s in &SCENES {
        let pitch = if s.pitch_deg == -90.0 {
            "centre".to_string()
        } else {
            format!("{}", s.pitch_deg)
        };
        println!(
            "{:<13} {:>9.2} {:>9.2}  {:<22} {:>8} {:>6}  {}",
            s.name,
            s.lat_deg,
            s.lon_deg,
            s.height_label(),
            s.heading_deg,
            pitch,
            s.stresses
        );
    }
}

fn render(args: &RenderArgs) -> anyhow::Result<ExitCode> {
    let (name, view) = chosen_view(args.scene.as_deref().unwrap_or_default(), args.camera)?;
    if args.width == 0 || args.height == 0 || args.width > 16384 || args.height > 16384 {
        bail!(
            "--width and --height must be between 1 and 16384 (got {}×{})",
            args.width,
            args.height
        );
    }
    let settings = args.mesh.settings()?;
    let lod = args.lod.settings()?;
    let stream = args.stream.settings()?;
    let measure_limit = args.measure_limit.limit()?;
    let settle_timeout = match args.settle_timeout_s {
        s if s >= 0.0 && s.is_finite() => std::time::Duration::from_secs_f64(s),
        s => bail!("--settle-timeout must be a number of seconds (got {s})"),
    };
    let started = Instant::now();
    let ctx = GpuContext::headless().context("cannot render without a graphics adapter")?;
    eprintln!("adapter: {}", ctx.adapter_description());
    let terrain = args.dem.open()?;
    eprintln!("terrain: {}", terrain.describe());
    let mut renderer =
        TerrainRenderer::with_streaming(&ctx.device, settings, terrain, COLOR_FORMAT, stream)?;
    renderer.overlays.levels = args.overlay == Some(Overlay::Levels);
    renderer.set_wireframe(&ctx.device, args.overlay == Some(Overlay::Wireframe));
    renderer.set_look(&ctx.device, args.look.settings());
    renderer.set_lod(&ctx.device, lod);
    let camera = view.camera(|lat, lon| renderer.terrain_height_m(lat, lon));
    let target = OffscreenFrame::new(&ctx.device, args.width, args.height);
    let mut frame = if args.no_wait {
        target.render_now(&ctx, &mut renderer, &camera)?
    } else {
        target.render_settled_within(&ctx, &mut renderer, &camera, settle_timeout)?
    };
    print_file_changes("globe render", frame.info.stream.as_ref());
    if args.measure {
        let mut progress = MeasureProgress::default();
        let measured = globe::measure::evaluate_within(
            &frame,
            &camera,
            &renderer.terrain,
            measure_limit,
            |done, total| progress.update(done, total),
        )
        .map_err(|e| args.measure_limit.explain(e.into()))?;
        progress.finish();
        let e = measured;
        let coverage = e.coverage.unwrap_or_default();
        eprintln!(
            "error: mean ρ {:.3} px, p99 {:.3} px, max {:.3} px over {} terrain px; {:.3} % above {} px; coverage mismatches {} px (reference: {:.1} march steps per pixel)",
            e.mean_px,
            e.p99_px,
            e.max_px,
            e.pixels_measured,
            100.0 * e.error_pixel_share,
            e.threshold_px,
            coverage.mismatched(),
            coverage.reference_steps as f64 / coverage.compared.max(1) as f64
        );
    }
    if args.overlay == Some(Overlay::Error) {
        let rho = globe::measure::rho_image(&frame, &camera, &renderer.terrain);
        globe::measure::overlay_heat(&mut frame.rgba, &rho, globe::measure::ERROR_OVERLAY_OPACITY);
    }
    frame
        .save_png(&args.out)
        .with_context(|| format!("cannot write {}", args.out.display()))?;

    let sel = &frame.info.selection;
    let count = |s: LevelStatus| sel.status.iter().filter(|x| **x == s).count();
    eprintln!(
        "{} {name}: {:.2}°, {:.2}°, {:.1} m ({:.2} m above terrain), heading {}°, pitch {}°, roll {}°",
        if args.camera.is_some() {
            "view"
        } else {
            "scene"
        },
        camera.lat_deg,
        camera.lon_deg,
        camera.altitude_m,
        frame.info.height_above_terrain_m,
        camera.heading_deg,
        camera.pitch_deg,
        camera.roll_deg
    );
    eprintln!(
        "levels drawn {}..={} (θ̃max {:.4}°, θ̃min {:.3e}°): {} beyond the horizon, {} sub-pixel, \
         {} out of view",
        sel.coarsest,
        sel.finest,
        sel.theta_max_rad.to_degrees(),
        sel.theta_min_rad.to_degrees(),
        count(LevelStatus::BeyondHorizon),
        count(LevelStatus::SubPixel),
        count(LevelStatus::OutOfView)
    );
    eprintln!(
        "ring density k per drawn level, coarse to fine (n/2^k steps, m/2^k rings): {}",
        sel.drawn_levels()
            .map(|l| frame.info.densities.levels[l as usize].body.k.to_string())
            .collect::<Vec<_>>()
            .join(" ")
    );
    eprintln!(
        "triangles {} in {} draw calls; sectors drawn {}, culled {}; texels filled {}",
        frame.info.triangles(),
        frame.info.draw.ranges.len(),
        frame.info.draw.sectors_drawn,
        frame.info.draw.sectors_culled,
        frame.info.texels_filled
    );
    match frame.info.planar.as_ref().map(|p| (p, &p.grid)) {
        Some((p, Some(g))) => eprintln!(
            "projected grid: {} triangles; {} cells with ρ > γ ({}); error buffer mean {:.3} px, max {:.3} px",
            p.triangles,
            g.cells_above_gamma,
            if g.ray_cast {
                "ray cast"
            } else {
                "not ray cast"
            },
            g.mean_rho_px,
            g.max_rho_px
        ),
        Some((p, None)) => eprintln!(
            "geomipmapping: {} patches in view ({} triangles), finest spacing {} m",
            p.patches, p.triangles, p.spacing_m
        ),
        None => {}
    }
    eprintln!(
        "wrote {} ({}×{}) in {:.2} s",
        args.out.display(),
        args.width,
        args.height,
        started.elapsed().as_secs_f64()
    );
    Ok(ExitCode::SUCCESS)
}

/// Each change to the pyramid file the watcher reported during the run, once, on stderr.
fn print_file_changes(command: &str, stream: Option<&globe::render::dem_feed::FeedFrame>) {
    for change in stream.map_or(&[][..], |s| s.file_changes_after(0)) {
        eprintln!("{command}: {change}");
    }
}

fn viewer(args: &ViewerArgs) -> anyhow::Result<ExitCode> {
    let (_, start) = chosen_view(&args.scene, args.camera)?;
    if args.overlay == Some(Overlay::Error) {
        bail!(
            "--overlay error is for `globe render`; in the viewer press the panel's \
             \"error overlay (ρ)\" button (it measures the view on the CPU, on demand)"
        );
    }
    let options = globe::ui::ViewerOptions {
        start,
        settings: args.mesh.settings()?,
        overlay_levels: args.overlay == Some(Overlay::Levels),
        overlay_wireframe: args.overlay == Some(Overlay::Wireframe),
        terrain: args.dem.open()?,
        look: args.look.settings(),
        lod: args.lod.settings()?,
        stream: args.stream.settings()?,
    };
    match globe::ui::run(options) {
        Ok(()) => Ok(ExitCode::SUCCESS),
        Err(globe::ui::UiError::NoDisplay(why)) => {
            eprintln!("globe: {why}");
            Ok(ExitCode::from(2))
        }
        Err(e) => Err(e.into()),
    }
}

fn bench(args: &BenchArgs) -> anyhow::Result<ExitCode> {
    let is_flight = args.camera.is_none() && args.scene == globe::scenes::flight::NAME;
    if args.camera.is_none() && args.scene == globe::bench::JUMP {
        return bench_jump(args);
    }
    if args.camera.is_none() && args.scene == globe::soak::NAME {
        return bench_soak(args);
    }
    if args.seconds.is_some() || args.plot.is_some() {
        bail!(
            "--seconds and --plot are for `--scene {}`",
            globe::soak::NAME
        );
    }
    // Names are checked before the adapter starts; the library looks them up the same way.
    let name = match args.camera {
        Some(_) => CAMERA_VIEW_NAME,
        None if is_flight => globe::scenes::flight::NAME,
        None => {
            globe::scenes::find(&args.scene)
                .map_err(|e| {
                    e.also_known(&[
                        globe::scenes::flight::NAME,
                        globe::bench::JUMP,
                        globe::soak::NAME,
                    ])
                })?
                .name
        }
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
        let options = globe::bench::BenchOptions {
            scene: name.to_owned(),
            camera: args.camera,
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
            frame_interval: {
                let default = if is_flight { 60.0 } else { 0.0 };
                let fps = args.fps.unwrap_or(default);
                if !(fps >= 0.0 && fps.is_finite()) {
                    bail!("--fps must be 0 or more (got {fps})");
                }
                (fps > 0.0).then(|| std::time::Duration::from_secs_f64(1.0 / fps))
            },
        };
        let label = format!("{name} (latency {latency} ms)");
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
        let watch = globe::bench::MeasureWatch {
            limit: measure_limit,
            progress: &mut on_measure,
        };
        let on_frame = |done: usize, _| {
            if let Some(p) = progress.borrow_mut().as_mut() {
                p.set(done as u64)
            }
        };
        let run = globe::bench::run_with(&ctx, &terrain, &options, on_frame, watch)
            .map_err(|e| args.measure_limit.explain(e.into()))?;
        if let Some(p) = progress.take() {
            p.finish();
        }
        measuring.finish();
        print_file_changes("globe bench", run.last_stream());
        if let Some(path) = &args.csv {
            let path = if latencies.len() > 1 {
                let stem = path.file_stem().unwrap_or_default().to_string_lossy();
                path.with_file_name(format!("{stem}-{latency}ms.csv"))
            } else {
                path.clone()
            };
            std::fs::write(&path, run.frames_csv())
                .with_context(|| format!("cannot write {}", path.display()))?;
        }
        if args.json {
            println!("{}", run.to_json());
        } else {
            print_bench(&run);
        }
        if let (Some(r), Some(b)) = (&remote, remote_before) {
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
        runs.push(run);
    }
    if runs.len() > 1 {
        let base = runs[0].cpu_ms().map(|s| s.0).unwrap_or(f64::NAN);
        eprintln!("median CPU ms per frame against the first latency (same process):");
        for r in &runs {
            let cpu = r.cpu_ms().map(|s| s.0).unwrap_or(f64::NAN);
            eprintln!(
                "  latency {:>7} ms: {cpu:8.3} ms  ratio {:.3}",
                latency_of(&r.options.stream.faults).to_string(),
                cpu / base
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn print_bench(run: &globe::bench::BenchRun) {
    let o = &run.options;
    println!(
        "{} {}×{}, {} frames, latency {} ms, fail rate {}",
        o.scene,
        o.width,
        o.height,
        run.frames.len(),
        latency_of(&o.stream.faults),
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
    if let Some((m, lo, hi)) = globe::bench::summary(&fills) {
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

fn bench_soak(args: &BenchArgs) -> anyhow::Result<ExitCode> {
    use globe::soak;
    let seconds = args.seconds.unwrap_or(600.0);
    if !(seconds > 0.0 && seconds.is_finite()) {
        bail!("--seconds must be above 0 (got {seconds})");
    }
    if !(args.settle_timeout > 0.0 && args.settle_timeout.is_finite()) {
        bail!(
            "--settle-timeout must be above 0 (got {})",
            args.settle_timeout
        );
    }
    let (lo, hi) = soak::DEFAULT_LATENCY_MS;
    let [latency] = args.stream.latencies(LatencyMs { min: lo, max: hi })[..] else {
        bail!("--scene soak takes one --tile-latency-ms (MS or MIN-MAX)");
    };
    let mut stream = args
        .stream
        .settings_with(latency, soak::DEFAULT_FAIL_RATE)?;
    stream.faults.seed = args.seed;
    let fps = args.fps.unwrap_or(0.0);
    if !(fps >= 0.0 && fps.is_finite()) {
        bail!("--fps must be 0 or more (got {fps})");
    }
    if let Some(dir) = &args.mismatch_dir {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create --mismatch-dir {}", dir.display()))?;
    }
    let ctx = GpuContext::headless().context("cannot benchmark without a graphics adapter")?;
    eprintln!("adapter: {}", ctx.adapter_description());
    let terrain = args.dem.open()?;
    eprintln!("terrain: {}", terrain.describe());
    let options = soak::SoakOptions {
        seconds,
        seed: args.seed,
        legs: soak::LegSeconds::default(),
        width: args.width,
        height: args.height,
        settings: args.mesh.settings()?,
        stream,
        look: args.look.settings(),
        lod: args.lod.settings()?,
        frame_interval: (fps > 0.0).then(|| std::time::Duration::from_secs_f64(1.0 / fps)),
        settle_timeout: std::time::Duration::from_secs_f64(args.settle_timeout),
        rss_slack_bytes: soak::DEFAULT_RSS_SLACK_BYTES,
        mismatch_dir: args.mismatch_dir.clone(),
    };
    eprintln!(
        "soak: seed {}, {seconds} s, {}×{}, fail rate {}, latency {latency} ms, cache {} MiB, \
         {} GPU tiles",
        args.seed,
        args.width,
        args.height,
        stream.faults.fail_rate,
        stream.cache_bytes >> 20,
        stream.gpu_tiles
    );
    let mut progress = Progress::new("soak", seconds.ceil() as u64, Some("s"));
    let run = soak::run(&ctx, &terrain, &options, |p| {
        progress.note(format!(
            "{} frames, {} settle points ({} not equal), {} reads in frames",
            p.frames, p.settle_points, p.settle_points_bad, p.reads_in_frames
        ));
        progress.set(p.t_s as u64);
    })?;
    progress.finish();
    if let Some(path) = &args.csv {
        std::fs::write(path, run.frames_csv())
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    if let Some(path) = &args.plot {
        run.write_plot(path)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    let f = run.findings();
    if args.json {
        println!("{}", run.to_json());
    } else {
        print_soak(&run, &f);
    }
    let failures = f.failures();
    if failures.is_empty() {
        Ok(ExitCode::SUCCESS)
    } else {
        for line in &failures {
            eprintln!("globe bench: soak failed: {line}");
        }
        Ok(ExitCode::FAILURE)
    }
}

fn print_soak(run: &globe::soak::SoakRun, f: &globe::soak::SoakFindings) {
    let mib = |b: u64| b as f64 / 1048576.0;
    let opt_mib = |b: Option<u64>| b.map_or("n/a".to_owned(), |b| format!("{:.1}", mib(b)));
    println!(
        "soak, seed {}: {:.0} s flown in {:.0} s, {} frames, {} legs ({} jumps; {})",
        run.options.seed,
        f.flown_s,
        f.wall_s,
        f.frames,
        f.legs,
        f.jumps,
        f.places
            .iter()
            .map(|(p, n)| format!("{} {n}", p.name()))
            .collect::<Vec<_>>()
            .join(", ")
    );
    println!(
        "  frames that read the file: {}; CPU ms per frame median {:.2}, p99 {:.2}, max {:.2}",
        f.frames_reading_the_file, f.cpu_ms_median, f.cpu_ms_p99, f.cpu_ms_max
    );
    println!(
        "  settle points: {}, not settled {}, differing from the fault-free render {} (max {} px, \
         visibly at most {:.3} % of the image); settle s median {:.2}, max {:.2}",
        f.settle_points,
        f.settle_failures,
        f.settle_points_differing,
        f.max_differing_px,
        100.0 * f.max_visibly_differing_share,
        f.settle_s_median,
        f.settle_s_max
    );
    for p in run.settles.iter().filter(|p| p.differing_px != Some(0)) {
        println!(
            "    leg {} ({}) at {:.1} s: {}",
            p.leg,
            p.place.name(),
            p.t_s,
            p.error.clone().unwrap_or_else(|| format!(
                "{} px differ, {} of them visibly (a channel by more than {})",
                p.differing_px.unwrap_or(0),
                p.visibly_differing_px.unwrap_or(0),
                globe::soak::VISIBLE_CHANNEL_DIFF
            ))
        );
        if let Some(m) = &p.mismatch {
            println!(
                "      a fresh renderer differs from the flying one by {} px, from the reference \
                 by {} px; triangles {:?}, levels {:?}, height above terrain {:?} m \
                 (flying, reference, fresh)",
                m.fresh_vs_flying_px,
                m.fresh_vs_reference_px,
                m.triangles,
                m.levels,
                m.height_above_terrain_m
            );
        }
    }
    println!(
        "  tiles loaded {}, failed reads {}, retries {}",
        f.tiles_loaded, f.tiles_failed, f.retries
    );
    println!(
        "  memory, MiB: cache max {:.1} of {:.1} (the frame's own tiles, kept beyond it: at most \
         {:.1}; frames over both: {}); GPU tiles max {} of {}; anonymous RSS max {} \
         of budget {} (first half's max {}, slope over the second half {} MiB/min); file-backed RSS max {}",
        mib(f.cache_bytes_max),
        mib(f.cache_budget),
        mib(f.cache_kept_bytes_max),
        f.frames_over_cache_budget,
        f.gpu_tiles_max,
        f.gpu_capacity,
        opt_mib(f.rss_anon_max),
        opt_mib(f.rss_anon_budget),
        opt_mib(f.rss_anon_baseline),
        f.rss_anon_slope_mib_per_min
            .map_or("n/a".to_owned(), |s| format!("{s:+.2}")),
        opt_mib(f.rss_file_max)
    );
    println!("  {}", if f.passed() { "PASSED" } else { "FAILED" });
}

fn bench_jump(args: &BenchArgs) -> anyhow::Result<ExitCode> {
    let ctx = GpuContext::headless().context("cannot benchmark without a graphics adapter")?;
    eprintln!("adapter: {}", ctx.adapter_description());
    let terrain = args.dem.open()?;
    eprintln!("terrain: {}", terrain.describe());
    let options = globe::bench::JumpOptions {
        width: args.width,
        height: args.height,
        settings: args.mesh.settings()?,
        stream: args.stream.settings()?,
        throughput_tiles: args.throughput_tiles,
    };
    let run = globe::bench::run_jump(&ctx, &terrain, &options, |line| eprintln!("{line}"))?;
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

fn report(args: &ReportArgs) -> anyhow::Result<ExitCode> {
    let scenes = match (&args.scenes, args.camera) {
        (Some(scenes), _) => scenes.clone(),
        (None, Some(_)) => Vec::new(),
        (None, None) => ["space", "aircraft", "ground"].map(String::from).to_vec(),
    };
    for name in &scenes {
        globe::scenes::find(name)?;
    }
    if args.frames == 0 || args.width == 0 || args.height == 0 {
        bail!("--frames, --width and --height must be at least 1");
    }
    let measure_limit = args.measure_limit.limit()?;
    let ctx = GpuContext::headless().context("cannot run the report without a graphics adapter")?;
    let adapter = ctx.adapter_description();
    eprintln!("adapter: {adapter}");
    let terrain = args.dem.open()?;
    eprintln!("terrain: {}", terrain.describe());
    let options = globe::report::ReportOptions {
        scenes,
        camera: args.camera,
        width: args.width,
        height: args.height,
        frames: args.frames,
        base: args.mesh.settings()?,
        stream: args.stream.settings()?,
        look: args.look.settings(),
        lod: args.lod.settings()?,
        every: args.every,
        projgrid_tables: args.projgrid_tables,
    };
    let started = Instant::now();
    let mut progress = None;
    let describe = terrain.describe();
    let mut partial_error = None;
    let rows = globe::report::run_within(
        &ctx,
        &terrain,
        &options,
        measure_limit,
        |step| {
            let p = progress
                .get_or_insert_with(|| Progress::new("report", step.total as u64, Some("steps")));
            match step.pixels {
                Some((done, all)) => p.note(format!(
                    "{} ({:.0} % of {all} px)",
                    step.message,
                    100.0 * done as f64 / all.max(1) as f64
                )),
                None => p.step(step.index as u64, step.message.as_str()),
            }
        },
        // The text files follow every row, so an interrupted run keeps what it measured.
        |rows| {
            if partial_error.is_none() {
                partial_error =
                    globe::report::write_text(&args.out, rows, &adapter, &describe, &options).err();
            }
        },
    )
    .map_err(|e| args.measure_limit.explain(e.into()))?;
    if let Some(e) = partial_error {
        return Err(anyhow::Error::new(e).context(format!(
            "cannot write the report into {}",
            args.out.display()
        )));
    }
    if let Some(p) = progress {
        p.finish();
    }
    globe::report::write(&args.out, &rows, &adapter, &describe, &options)
        .with_context(|| format!("cannot write the report into {}", args.out.display()))?;
    eprintln!(
        "wrote {}/report.csv, report.json, report.md, error_vs_time.png and .svg ({} rows) in {:.1} s",
        args.out.display(),
        rows.len(),
        started.elapsed().as_secs_f64()
    );
    Ok(ExitCode::SUCCESS)
}
