//! `globe render`: one view headless to PNG, optionally measured.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use clap::Args;
use globe::clipmap::ClipmapSettings;
use globe::clipmap::selection::LevelStatus;
use globe::geo::camera::Camera;
use globe::plan::LodSettings;
use globe::render::formats::COLOR_FORMAT;
use globe::render::offscreen::{OffscreenFrame, RenderedFrame};
use globe::render::{GpuContext, TerrainRenderer};
use globe::scenes::CameraSpec;
use globe::stream::StreamSettings;
use globe::terrain::Terrain;

use crate::args::*;
use crate::scenes::*;

#[derive(Args)]
#[group(id = "view", required = true, multiple = false, args = ["scene", "camera", "path"])]
pub struct RenderArgs {
    /// Named scene to render (see `globe scenes`).
    #[arg(long)]
    pub scene: Option<String>,
    /// Render this view instead of a scene: LAT,LON,HEIGHT,HEADING,PITCH[,ROLL] in degrees
    /// and metres (60° vertical field of view). HEIGHT is above the terrain under the camera;
    /// HEIGHT@sphere is above the sphere of radius R = 6 371 000 m. Latitude and pitch in
    /// [-90, 90], longitude in [-360, 360], heading and roll any; e.g. `--camera
    /// 45.65,10.65,500,90,-10` or `--camera=-33.4,-70.2,3000@sphere,0,-20,5`.
    #[arg(long, value_name = "VIEW", allow_hyphen_values = true)]
    pub camera: Option<CameraSpec>,
    /// Image width in pixels.
    #[arg(long, default_value_t = 1280)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 720)]
    pub height: u32,
    /// A recorded camera path (JSON, as the viewer's R key writes it) to render frame by frame
    /// into --out-dir.
    #[arg(long, value_name = "FILE.json")]
    pub path: Option<PathBuf>,
    /// Output PNG file (one view: --scene or --camera).
    #[arg(long, required_unless_present = "path")]
    pub out: Option<PathBuf>,
    /// With --path: the folder the frames are written to, `frame_00000.png` on (made if
    /// missing).
    #[arg(long, value_name = "DIR", requires = "path")]
    pub out_dir: Option<PathBuf>,
    /// With --path: frames per second of path time.
    #[arg(long, value_name = "N", default_value_t = 30.0, requires = "path")]
    pub fps: f64,
    /// Debug overlay to draw.
    #[arg(long)]
    pub overlay: Option<Overlay>,
    /// Render with whatever tiles have arrived instead of waiting for streaming to settle.
    #[arg(long = "no-wait")]
    pub no_wait: bool,
    /// Wait at most this many seconds for streaming to settle; past it, stop with what the
    /// view was still waiting for.
    #[arg(long = "settle-timeout", value_name = "SECONDS", default_value_t = globe::render::offscreen::SETTLE_TIMEOUT.as_secs_f64())]
    pub settle_timeout_s: f64,
    /// Print the frame's error: ρ statistics against the terrain function and coverage
    /// mismatches against the reference ray caster (slow: seconds per megapixel).
    #[arg(long)]
    pub measure: bool,
    #[command(flatten)]
    pub measure_limit: MeasureArgs,
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

pub fn render(args: &RenderArgs) -> anyhow::Result<ExitCode> {
    if let Some(path) = &args.path {
        return render_path(args, path);
    }
    let Some(out) = &args.out else {
        bail!("--out FILE.png is needed to render one view");
    };
    let (name, view) = chosen_view(args.scene.as_deref().unwrap_or_default(), args.camera)?;
    let checked = RenderSettings::of(args)?;
    let started = Instant::now();
    let ctx = GpuContext::headless().context("cannot render without a graphics adapter")?;
    eprintln!("adapter: {}", ctx.adapter_description());
    let terrain = args.dem.open()?;
    eprintln!("terrain: {}", terrain.describe());
    let mut renderer = TerrainRenderer::with_streaming(
        &ctx.device,
        checked.settings,
        terrain,
        COLOR_FORMAT,
        checked.stream,
    )?;
    renderer.overlays.levels = args.overlay == Some(Overlay::Levels);
    renderer.set_wireframe(&ctx.device, args.overlay == Some(Overlay::Wireframe));
    renderer.set_look(&ctx.device, args.look.settings());
    renderer.set_lod(&ctx.device, checked.lod);
    let camera = view.camera(|lat, lon| renderer.terrain_height_m(lat, lon));
    let target = OffscreenFrame::new(&ctx.device, args.width, args.height);
    let mut frame = if args.no_wait {
        target.render_now(&ctx, &mut renderer, &camera)?
    } else {
        target.render_settled_within(&ctx, &mut renderer, &camera, checked.settle_timeout)?
    };
    print_file_changes("globe render", frame.info.stream.as_ref());
    if args.measure {
        print_error(
            args,
            &frame,
            &camera,
            &renderer.terrain,
            checked.measure_limit,
        )?;
    }
    if args.overlay == Some(Overlay::Error) {
        let rho = globe::measure::rho_image(&frame, &camera, &renderer.terrain);
        globe::measure::overlay_heat(&mut frame.rgba, &rho, globe::measure::ERROR_OVERLAY_OPACITY);
    }
    frame
        .save_png(out)
        .with_context(|| format!("cannot write {}", out.display()))?;

    print_frame_summary(args, &name, &camera, &frame);
    eprintln!(
        "wrote {} ({}×{}) in {:.2} s",
        out.display(),
        args.width,
        args.height,
        started.elapsed().as_secs_f64()
    );
    Ok(ExitCode::SUCCESS)
}

/// `--path`: one PNG per frame of the recorded path at `--fps`, each with streaming settled
/// (or `--no-wait`: what a live viewer would show then), with progress on stderr.
fn render_path(args: &RenderArgs, path_file: &std::path::Path) -> anyhow::Result<ExitCode> {
    let Some(dir) = &args.out_dir else {
        bail!("--path needs --out-dir DIR for its frames");
    };
    if args.out.is_some() {
        bail!("--path writes frames into --out-dir; --out is for one view");
    }
    if args.measure || args.overlay == Some(Overlay::Error) {
        bail!("--measure and --overlay error measure one view; render it with --camera");
    }
    if !(args.fps.is_finite() && args.fps > 0.0 && args.fps <= 1000.0) {
        bail!("--fps must be above 0 and at most 1000 (got {})", args.fps);
    }
    let checked = RenderSettings::of(args)?;
    let path = globe::scenes::path::CameraPath::load(path_file)?;
    let times = path.frame_times_s(args.fps);
    std::fs::create_dir_all(dir)
        .with_context(|| format!("cannot create --out-dir {}", dir.display()))?;
    let started = Instant::now();
    let ctx = GpuContext::headless().context("cannot render without a graphics adapter")?;
    eprintln!("adapter: {}", ctx.adapter_description());
    let terrain = args.dem.open()?;
    eprintln!("terrain: {}", terrain.describe());
    let mut renderer = TerrainRenderer::with_streaming(
        &ctx.device,
        checked.settings,
        terrain,
        COLOR_FORMAT,
        checked.stream,
    )?;
    renderer.overlays.levels = args.overlay == Some(Overlay::Levels);
    renderer.set_wireframe(&ctx.device, args.overlay == Some(Overlay::Wireframe));
    renderer.set_look(&ctx.device, args.look.settings());
    renderer.set_lod(&ctx.device, checked.lod);
    let target = OffscreenFrame::new(&ctx.device, args.width, args.height);
    let mut progress =
        globe::progress::Progress::new("rendering the path", times.len() as u64, Some("frames"));
    for (k, &t) in times.iter().enumerate() {
        let camera = path.camera_at(t);
        let frame = if args.no_wait {
            target.render_now(&ctx, &mut renderer, &camera)?
        } else {
            target.render_settled_within(&ctx, &mut renderer, &camera, checked.settle_timeout)?
        };
        let file = dir.join(format!("frame_{k:05}.png"));
        frame
            .save_png(&file)
            .with_context(|| format!("cannot write {}", file.display()))?;
        progress.set(k as u64 + 1);
    }
    progress.finish();
    eprintln!(
        "wrote {} frames ({}×{}, {} fps of a {:.2} s path) to {} in {:.2} s",
        times.len(),
        args.width,
        args.height,
        args.fps,
        path.duration_s(),
        dir.display(),
        started.elapsed().as_secs_f64()
    );
    Ok(ExitCode::SUCCESS)
}

/// The arguments checked into what the renderer takes, all before the adapter starts, so a
/// bad flag fails at once.
struct RenderSettings {
    settings: ClipmapSettings,
    lod: LodSettings,
    stream: StreamSettings,
    measure_limit: Option<Duration>,
    settle_timeout: Duration,
}

impl RenderSettings {
    fn of(args: &RenderArgs) -> anyhow::Result<Self> {
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
            s if s >= 0.0 && s.is_finite() => Duration::from_secs_f64(s),
            s => bail!("--settle-timeout must be a number of seconds (got {s})"),
        };
        Ok(Self {
            settings,
            lod,
            stream,
            measure_limit,
            settle_timeout,
        })
    }
}

/// `--measure`: the frame's error against the terrain function and the reference ray
/// caster, on stderr.
fn print_error(
    args: &RenderArgs,
    frame: &RenderedFrame,
    camera: &Camera,
    terrain: &Terrain,
    measure_limit: Option<Duration>,
) -> anyhow::Result<()> {
    let mut progress = MeasureProgress::default();
    let measured =
        globe::measure::evaluate_within(frame, camera, terrain, measure_limit, |done, total| {
            progress.update(done, total)
        })
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
    Ok(())
}

/// What was drawn, on stderr: the view, the levels and why the others were not, the ring
/// densities, the triangles and draw calls, and the planar method's figures.
fn print_frame_summary(args: &RenderArgs, name: &str, camera: &Camera, frame: &RenderedFrame) {
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
}

/// Each change to the pyramid file the watcher reported during the run, once, on stderr.
pub fn print_file_changes(command: &str, stream: Option<&globe::render::dem_feed::FeedFrame>) {
    for change in stream.map_or(&[][..], |s| s.file_changes_after(0)) {
        eprintln!("{command}: {change}");
    }
}
