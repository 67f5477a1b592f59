//! The argument groups every command shares (mesh, terrain, look, LOD method, streaming,
//! measurement limits), each turned into the library's settings type it stands for.

use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use globe::clipmap::settings::DEFAULT_ERROR_BUDGET_PX;
use globe::clipmap::{ClipmapSettings, TransformForm};
use globe::look::{LookSettings, MipKind, Sun, Utc};
use globe::plan::{LodMode, LodSettings};
use globe::planar::geomip::GeomipSettings;
use globe::planar::projgrid::ProjGridSettings;
use globe::procedural::DetailSpec;
use globe::progress::Progress;
pub use globe::stream::LatencyMs;
use globe::stream::{FaultSettings, StreamSettings};
use globe::terrain::Terrain;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Overlay {
    /// Each clipmap level in its own colour; geomipmapping patches by tessellation level
    /// (white finest, toward red coarsest).
    Levels,
    /// Every triangle's edges (barycentric, so on every adapter), for every LOD method.
    Wireframe,
    /// The per-pixel screen-space error ρ as a heat map (blue 0 px, yellow 1 px, red ≥ 4 px),
    /// computed on the CPU against the terrain function (`globe render` only).
    Error,
}

/// Clipmap settings; the defaults are explained in docs/design.md.
#[derive(Args, Clone, Debug)]
pub struct MeshArgs {
    /// The one error knob: target max screen-space error ρ in pixels at the frame's
    /// resolution. The vertex spacing, the texture size and (below 1 px) the mesh resolution
    /// follow from it (docs/design.md#the-error-knob); the flags below override single settings.
    #[arg(long = "error-budget", value_name = "PX", default_value_t = DEFAULT_ERROR_BUDGET_PX)]
    pub error_budget_px: f32,
    /// n: φ̃ steps around each ring (a multiple of 2 × sectors) [default: from --error-budget, 512].
    #[arg(long = "phi-steps", value_name = "N")]
    pub phi_steps: Option<u32>,
    /// m: rings per level [default: from --error-budget, 32].
    #[arg(long = "rings", value_name = "M")]
    pub rings_per_level: Option<u32>,
    /// Most levels a frame may draw (level i spans θ̃ ∈ (2^-(i+1)π, 2^-iπ]; level 29 is 7.5 cm
    /// across, level 39 0.07 mm). A frame draws down to the pixel bound, and no level whose
    /// disk around the nadir is out of view; 40 keeps the cap under a camera 1 mm above the
    /// detail a fraction of a millimetre wide.
    #[arg(long, default_value_t = ClipmapSettings::default().levels)]
    pub levels: u32,
    /// Side of each level texture in texels (a power of two) [default: from --error-budget, 512].
    #[arg(long = "texture-size", value_name = "TEXELS")]
    pub texture_size: Option<u32>,
    /// φ̃ sectors per level, culled against the view frustum.
    #[arg(long, default_value_t = ClipmapSettings::default().sectors)]
    pub sectors: u32,
    /// Map transform form used by the vertex shader: direct (paper eq. 4), stable (docs/design.md#numerics),
    /// approximate (paper eq. 11/14 on inner levels, blended into stable).
    #[arg(long, value_name = "FORM", default_value = "stable")]
    pub transform: TransformForm,
    /// First level using the approximation with --transform approximate.
    #[arg(long = "approx-start-level", value_name = "LEVEL", default_value_t = ClipmapSettings::default().approx_start_level)]
    pub approx_start_level: u32,
    /// Target on-screen spacing of the mesh's vertices in pixels: each level is drawn at the
    /// coarsest ring density (n/2^k, m/2^k; k ≤ 4 at the default n and m) that keeps its
    /// vertices this close; 0 draws every level at full density [default: from
    /// --error-budget, 5 × the budget].
    #[arg(long = "vertex-spacing", value_name = "PX")]
    pub target_spacing_px: Option<f32>,
}

impl MeshArgs {
    pub fn settings(&self) -> anyhow::Result<ClipmapSettings> {
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
pub struct DemArgs {
    /// `embedded` (the real Earth inside the binary: ETOPO5 at 10′), `analytic` (the test
    /// planet), a pyramid file made by `globe-data import`, or a raster to import into the cache
    /// first (a folder of GTOPO30-style tiles, of SRTM .hgt tiles or of GeoTIFFs; one .HDR/.DEM;
    /// a netCDF-3 file such as ETOPO5; a GeoTIFF/COG; an SRTM .hgt tile).
    #[arg(long, value_name = "SOURCE", default_value = "embedded")]
    pub dem: String,
    /// Procedural detail below the data's resolution: `default` (on), `off`, or a detail
    /// parameter file (JSON; docs/detail.md#the-parameter-file lists the fields and their ranges).
    #[arg(long, value_name = "off|default|FILE", default_value = "default")]
    pub detail: DetailSpec,
    /// Water at sea level: the surface is max(height, 0 m), shaded as water (measured as that
    /// surface too); off: the bathymetry, tinted.
    #[arg(long, value_name = "on|off", default_value = "on")]
    pub water: Switch,
    /// True-colour imagery draped on the terrain: `embedded` (NASA's Blue Marble at 4′,
    /// inside the binary), `off` (the surface types' colours by height, slope and latitude),
    /// a GeoTIFF in latitude/longitude (RGB or RGBA, 8 bits), or a JPEG/PNG plate carrée as
    /// `FILE@W,S,E,N` (degrees; without the extent a 2:1 image is taken as the whole Earth)
    /// [default: embedded; off with --dem analytic, which is not the Earth].
    #[arg(long, value_name = "SOURCE")]
    pub imagery: Option<String>,
    /// A remote pyramid (`--dem https://…`, `s3://bucket/key`): the local disk cache of fetched
    /// tiles, MiB (0: none), so a second visit costs no request.
    #[arg(long, value_name = "MIB", default_value_t = 512)]
    pub disk_cache_mb: u64,
    /// Where that disk cache lives (default: the cache folder's `remote/`).
    #[arg(long, value_name = "DIR")]
    pub disk_cache_dir: Option<std::path::PathBuf>,
    /// A remote pyramid: requests in flight at most.
    #[arg(long, value_name = "N", default_value_t = 8)]
    pub remote_requests: usize,
    /// A remote pyramid: added before every request (a simulated round trip, for measuring).
    #[arg(long, value_name = "MS", default_value_t = 0)]
    pub remote_latency_ms: u64,
    /// A remote pyramid: the coarsest levels fitting in this many KiB are fetched at open.
    #[arg(long, value_name = "KIB", default_value_t = 4096)]
    pub remote_prefetch_kb: u64,
}

impl DemArgs {
    pub fn remote_options(&self) -> globe::stream::RemoteOptions {
        globe::stream::RemoteOptions {
            disk_cache_bytes: self.disk_cache_mb << 20,
            disk_cache_dir: self.disk_cache_dir.clone(),
            max_requests: self.remote_requests.max(1),
            latency: std::time::Duration::from_millis(self.remote_latency_ms),
            prefetch_bytes: self.remote_prefetch_kb << 10,
            ..Default::default()
        }
    }

    pub fn open(&self) -> anyhow::Result<Terrain> {
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
        let imagery = self.imagery_source()?;
        let imagery = imagery
            .open()
            .with_context(|| format!("cannot open the imagery '{}'", self.imagery_spec()))?
            .map(std::sync::Arc::new);
        Ok(terrain
            .with_detail(params)
            .with_water_level(water)
            .with_imagery(imagery))
    }

    /// `--imagery` as given, or its default for `--dem`.
    pub fn imagery_spec(&self) -> &str {
        match &self.imagery {
            Some(s) => s,
            None if self.dem == "analytic" => "off",
            None => "embedded",
        }
    }

    pub fn imagery_source(&self) -> anyhow::Result<globe::imagery::ImagerySource> {
        globe::imagery::ImagerySource::parse(self.imagery_spec()).context("invalid --imagery")
    }
}

/// On or off (a flag's value).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Switch {
    On,
    Off,
}

impl Switch {
    pub fn on(self) -> bool {
        self == Switch::On
    }
}

/// The proto-textures' mipmaps.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum TextureMips {
    /// Variance-reducing (infinite-landscapes paper §4.2): far terrain neither shimmers nor
    /// repeats.
    Variance,
    /// Plain box-filtered mipmaps (for comparison).
    Standard,
}

/// The look of the planet (docs/look.md#the-look). None of it changes the measured error.
#[derive(Args, Clone, Debug)]
pub struct LookArgs {
    /// Proto-textured surface types (sand, grass, forest, rock, snow by height, slope and
    /// latitude); off: the hypsometric tint.
    #[arg(long, value_name = "on|off", default_value = "on")]
    pub textures: Switch,
    /// The atmosphere: the sky, the glow around the disk from space, haze toward the horizon;
    /// off: a flat sky colour and raw terrain colours.
    #[arg(long, value_name = "on|off", default_value = "on")]
    pub sky: Switch,
    /// Mipmaps of the proto-textures.
    #[arg(long = "texture-mips", value_name = "KIND", default_value = "variance")]
    pub texture_mips: TextureMips,
    /// The sun where it stands at this UTC time, YYYY-MM-DDTHH:MMZ (or with :SS), e.g.
    /// 2026-06-21T19:30Z (Meeus's solar position, about 0.01°); without it the sun stands 35°
    /// above the south-east horizon of every view.
    #[arg(long, value_name = "UTC", value_parser = parse_time)]
    pub time: Option<Utc>,
}

fn parse_time(text: &str) -> Result<Utc, String> {
    Utc::parse(text).map_err(|e| e.to_string())
}

impl LookArgs {
    pub fn settings(&self) -> LookSettings {
        LookSettings {
            textures: self.textures.on(),
            sky: self.sky.on(),
            mips: match self.texture_mips {
                TextureMips::Variance => MipKind::VarianceReducing,
                TextureMips::Standard => MipKind::Standard,
            },
            sun: self.time.map_or(Sun::Fixed, Sun::At),
        }
    }
}

/// Which LOD method draws the ground near the viewer, and its settings.
#[derive(Args, Clone, Debug)]
pub struct LodArgs {
    /// LOD method near the ground: `clipmap` (the spherical clipmap alone), `geomip`
    /// (geomipmapping with geomorphing on the tangent plane around the viewer, the clipmap
    /// beyond), `projgrid` (the error-bounded projected grid over the whole view, ray casting
    /// the cells whose error exceeds γ), `auto` (geomip below 1 000 m above the terrain, the
    /// clipmap alone above 1 500 m; docs/close-up.md#close-up-modes).
    #[arg(long, value_name = "MODE", default_value = "clipmap")]
    pub mode: ModeArg,
    /// Geomipmapping's level threshold τ: the largest projected error a patch may show, pixels.
    #[arg(long, value_name = "PX", default_value_t = 1.0)]
    pub tau: f64,
    /// Geomipmapping's patch size in vertices per side, 2^n + 1 (the paper's 17).
    #[arg(long = "patch-size", value_name = "N", default_value_t = 17)]
    pub patch_size: u32,
    /// Geomipmapping's patches per side of the square around the viewer (even, 2 to 64); the
    /// finest spacing is a sixteenth of the height above the terrain, so the square's side is
    /// this × (N − 1) × that.
    #[arg(long, value_name = "N", default_value_t = 32)]
    pub patches: u32,
    /// Geomorphing of the patches (off: levels switch whole and pop).
    #[arg(long, value_name = "on|off", default_value = "on")]
    pub geomorph: Switch,
    /// The projected grid's cells, COLSxROWS (e.g. 512x256).
    #[arg(long, value_name = "COLSxROWS", default_value = "256x256", value_parser = ProjGridSettings::parse_grid)]
    pub grid: (u32, u32),
    /// The projected grid's error threshold γ: cells whose screen-space error bound exceeds it
    /// are ray cast, pixels (> 0).
    #[arg(long, value_name = "PX", default_value_t = 1.0)]
    pub gamma: f64,
    /// The projected grid warped by importance (more cells where the error bound is high) or
    /// uniform in the projector's (ψ, θ̃), already denser near the viewer; off by default: the
    /// uniform grid measured better (docs/close-up.md#uniform-and-non-uniform-grids).
    #[arg(long, value_name = "on|off", default_value = "off")]
    pub warp: Switch,
    /// Ray casting of the projected grid's cells whose error exceeds γ.
    #[arg(long = "ray-cast", value_name = "on|off", default_value = "on")]
    pub ray_cast: Switch,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ModeArg {
    Clipmap,
    Geomip,
    Projgrid,
    Auto,
}

impl LodArgs {
    pub fn settings(&self) -> anyhow::Result<LodSettings> {
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
pub struct StreamArgs {
    /// Latency added to every tile read, in milliseconds (fault injection): MS, or MIN-MAX to
    /// draw each read's latency from that range. `globe bench` takes a comma-separated list
    /// and runs once per value, in one process. Default 0 (`--scene soak`: 0-200).
    #[arg(long = "tile-latency-ms", value_name = "MS", value_delimiter = ',')]
    pub tile_latency_ms: Vec<LatencyMs>,
    /// Fraction of tile reads that fail, 0…1 (fault injection; failed reads are retried).
    /// Default 0 (`--scene soak`: 0.05).
    #[arg(long = "tile-fail-rate", value_name = "F")]
    pub tile_fail_rate: Option<f64>,
    /// Budget of the decoded-tile cache in MiB. The tiles the frame in progress needs (the
    /// camera's ground, tiles on their way to the GPU) stay even beyond it: 0 keeps only those.
    #[arg(long = "cache-mb", value_name = "MIB", default_value_t = globe::stream::DEFAULT_CACHE_BYTES >> 20)]
    pub cache_mb: u64,
    /// Tiles the GPU tile cache holds (256² × 2 bytes each). A clipmap level is filled from
    /// its tiles all resident at once: too few for a level of the view is an error naming the
    /// smallest that works there.
    #[arg(long = "gpu-tiles", value_name = "N", default_value_t = StreamSettings::default().gpu_tiles)]
    pub gpu_tiles: u32,
    /// Tiles uploaded to the GPU per frame at most (at least 1).
    #[arg(long = "uploads-per-frame", value_name = "N", default_value_t = StreamSettings::default().uploads_per_frame)]
    pub uploads_per_frame: u32,
    /// Tile reads in flight at most (at least 1).
    #[arg(long = "max-in-flight", value_name = "N", default_value_t = StreamSettings::default().max_in_flight)]
    pub max_in_flight: usize,
}

impl StreamArgs {
    /// The latencies asked for, or `default` when none were.
    pub fn latencies(&self, default: LatencyMs) -> Vec<LatencyMs> {
        if self.tile_latency_ms.is_empty() {
            vec![default]
        } else {
            self.tile_latency_ms.clone()
        }
    }

    /// The settings with one latency of the list and the fail rate (`default_fail_rate` when
    /// none was given).
    pub fn settings_with(
        &self,
        latency: LatencyMs,
        default_fail_rate: f64,
    ) -> anyhow::Result<StreamSettings> {
        let settings = StreamSettings {
            cache_bytes: self.cache_mb.saturating_mul(1 << 20),
            gpu_tiles: self.gpu_tiles,
            uploads_per_frame: self.uploads_per_frame,
            max_in_flight: self.max_in_flight,
            faults: FaultSettings {
                latency_ms: latency.min,
                latency_max_ms: latency.max,
                fail_rate: self.tile_fail_rate.unwrap_or(default_fail_rate),
                seed: 0x5EED,
            },
            ..StreamSettings::default()
        };
        settings.validate()?;
        Ok(settings)
    }

    /// The settings, for commands that take one latency.
    pub fn settings(&self) -> anyhow::Result<StreamSettings> {
        match self.latencies(LatencyMs { min: 0, max: 0 }).as_slice() {
            [one] => self.settings_with(*one, 0.0),
            _ => bail!("--tile-latency-ms takes one value here (a list only with `globe bench`)"),
        }
    }
}

/// How long measuring the error may take.
#[derive(Args, Clone, Debug)]
pub struct MeasureArgs {
    /// Stop measuring the error after this many seconds, with a message saying how far the
    /// reference ray cast got (0: no limit). At 1920×1080 on two CPU cores a named scene over
    /// ETOPO5 takes seconds to a few minutes, `ground` (rays grazing the procedural detail)
    /// far longer (docs/measurements.md#measuring-time); a progress line shows the time left.
    #[arg(long = "measure-timeout", value_name = "SECONDS", default_value_t = DEFAULT_MEASURE_TIMEOUT_S)]
    pub measure_timeout_s: f64,
}

/// `--measure-timeout`'s default: an hour, over ten times the slowest named scene but
/// `ground` (docs/measurements.md#measuring-time); a crawl stops instead of hanging a report for hours.
pub const DEFAULT_MEASURE_TIMEOUT_S: f64 = 3600.0;

impl MeasureArgs {
    pub fn limit(&self) -> anyhow::Result<Option<std::time::Duration>> {
        Ok(globe::measure::time_limit(self.measure_timeout_s)?)
    }

    /// Names the flag when the reference ray cast stopped at its limit.
    pub fn explain(&self, e: anyhow::Error) -> anyhow::Error {
        let timed_out = e.chain().any(|c| {
            matches!(
                c.downcast_ref::<globe::measure::MeasureError>(),
                Some(globe::measure::MeasureError::TimedOut { .. })
            ) || matches!(
                c.downcast_ref::<globe::instruments::bench::BenchError>(),
                Some(globe::instruments::bench::BenchError::Measure(
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
pub struct MeasureProgress(pub Option<Progress>);

impl MeasureProgress {
    pub fn update(&mut self, done: usize, total: usize) {
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

    pub fn finish(self) {
        if let Some(p) = self.0 {
            p.finish();
        }
    }
}
