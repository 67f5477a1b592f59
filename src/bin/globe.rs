//! `globe`: the viewer, and its headless commands (`render`, `scenes`).

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, bail};
use clap::{Args, Parser, Subcommand, ValueEnum};
use globe::clipmap::selection::LevelStatus;
use globe::clipmap::{ClipmapSettings, TransformForm};
use globe::render::offscreen::{COLOR_FORMAT, OffscreenFrame};
use globe::render::{GpuContext, TerrainRenderer};
use globe::scenes::{SCENES, Scene, scene_names};
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
    /// Render a named scene headless (no window, no GPU needed: a software adapter works) to PNG.
    Render(RenderArgs),
    /// List the named scenes (the viewer's bookmarks).
    Scenes,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Overlay {
    /// Each clipmap level in its own colour.
    Levels,
}

/// Clipmap settings; the defaults are explained in README.md.
#[derive(Args, Clone, Debug)]
struct MeshArgs {
    /// n: φ̃ steps around each ring (a multiple of 2 × sectors).
    #[arg(long = "phi-steps", value_name = "N", default_value_t = ClipmapSettings::default().phi_steps)]
    phi_steps: u32,
    /// m: rings per level.
    #[arg(long = "rings", value_name = "M", default_value_t = ClipmapSettings::default().rings_per_level)]
    rings_per_level: u32,
    /// Number of levels in the mesh (level i spans θ̃ ∈ (2^-(i+1)π, 2^-iπ]).
    #[arg(long, default_value_t = ClipmapSettings::default().levels)]
    levels: u32,
    /// Side of each level texture in texels (a power of two).
    #[arg(long = "texture-size", value_name = "TEXELS", default_value_t = ClipmapSettings::default().texture_size)]
    texture_size: u32,
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
}

impl MeshArgs {
    fn settings(&self) -> anyhow::Result<ClipmapSettings> {
        let settings = ClipmapSettings {
            phi_steps: self.phi_steps,
            rings_per_level: self.rings_per_level,
            levels: self.levels,
            texture_size: self.texture_size,
            sectors: self.sectors,
            transform: self.transform,
            approx_start_level: self.approx_start_level,
            ..ClipmapSettings::default()
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
    /// first (a folder of GTOPO30-style tiles, one .HDR/.DEM, or a netCDF-3 file such as ETOPO5).
    #[arg(long, value_name = "SOURCE", default_value = "embedded")]
    dem: String,
}

impl DemArgs {
    fn open(&self) -> anyhow::Result<Terrain> {
        let mut last_pct = -1i64;
        let terrain = globe::terrain::open_terrain(&self.dem, |fraction| {
            let pct = (fraction * 100.0).floor() as i64;
            if pct != last_pct {
                last_pct = pct;
                eprint!("\rimporting {} into the cache: {pct:3} %", self.dem);
            }
        })
        .with_context(|| format!("cannot open the terrain '{}'", self.dem))?;
        if last_pct >= 0 {
            eprintln!();
        }
        Ok(terrain)
    }
}

#[derive(Args)]
struct ViewerArgs {
    /// Bookmark to open the viewer at (see `globe scenes`).
    #[arg(long, default_value = "space")]
    scene: String,
    /// Debug overlay to start with.
    #[arg(long)]
    overlay: Option<Overlay>,
    #[command(flatten)]
    mesh: MeshArgs,
    #[command(flatten)]
    dem: DemArgs,
}

#[derive(Args)]
struct RenderArgs {
    /// Named scene to render (see `globe scenes`).
    #[arg(long)]
    scene: String,
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
    #[command(flatten)]
    mesh: MeshArgs,
    #[command(flatten)]
    dem: DemArgs,
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
    match cli.command {
        Some(Command::Scenes) => {
            print_scenes();
            Ok(ExitCode::SUCCESS)
        }
        Some(Command::Render(args)) => render(&args),
        None => viewer(&cli.viewer),
    }
}

fn find_scene(name: &str) -> anyhow::Result<&'static Scene> {
    Scene::by_name(name)
        .with_context(|| format!("unknown scene '{name}' (known scenes: {})", scene_names()))
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
    let scene = find_scene(&args.scene)?;
    if args.width == 0 || args.height == 0 || args.width > 16384 || args.height > 16384 {
        bail!(
            "--width and --height must be between 1 and 16384 (got {}×{})",
            args.width,
            args.height
        );
    }
    let settings = args.mesh.settings()?;
    let started = Instant::now();
    let ctx = GpuContext::headless().context("cannot render without a graphics adapter")?;
    eprintln!("adapter: {}", ctx.adapter_description());
    let terrain = args.dem.open()?;
    eprintln!("terrain: {}", terrain.describe());
    let mut renderer = TerrainRenderer::new(&ctx.device, settings, terrain, COLOR_FORMAT)?;
    renderer.overlays.levels = args.overlay == Some(Overlay::Levels);
    let camera = scene.camera(|lat, lon| renderer.terrain_height_m(lat, lon));
    let target = OffscreenFrame::new(&ctx.device, args.width, args.height);
    let frame = target.render(&ctx, &mut renderer, &camera)?;
    frame
        .save_png(&args.out)
        .with_context(|| format!("cannot write {}", args.out.display()))?;

    let sel = &frame.info.selection;
    let count = |s: LevelStatus| sel.status.iter().filter(|x| **x == s).count();
    eprintln!(
        "scene {}: {:.2}°, {:.2}°, {:.1} m ({:.2} m above terrain), heading {}°, pitch {}°",
        scene.name,
        camera.lat_deg,
        camera.lon_deg,
        camera.altitude_m,
        frame.info.height_above_terrain_m,
        camera.heading_deg,
        camera.pitch_deg
    );
    eprintln!(
        "levels drawn {}..={} (θ̃max {:.4}°, θ̃min {:.3e}°): {} beyond the horizon, {} sub-pixel",
        sel.coarsest,
        sel.finest,
        sel.theta_max_rad.to_degrees(),
        sel.theta_min_rad.to_degrees(),
        count(LevelStatus::BeyondHorizon),
        count(LevelStatus::SubPixel)
    );
    eprintln!(
        "triangles {} in {} draw calls; sectors drawn {}, culled {}; texels filled {}",
        frame.info.draw.triangles,
        frame.info.draw.ranges.len(),
        frame.info.draw.sectors_drawn,
        frame.info.draw.sectors_culled,
        frame.info.texels_filled
    );
    eprintln!(
        "wrote {} ({}×{}) in {:.2} s",
        args.out.display(),
        args.width,
        args.height,
        started.elapsed().as_secs_f64()
    );
    Ok(ExitCode::SUCCESS)
}

fn viewer(args: &ViewerArgs) -> anyhow::Result<ExitCode> {
    find_scene(&args.scene)?;
    let options = globe::ui::ViewerOptions {
        scene: args.scene.clone(),
        settings: args.mesh.settings()?,
        overlay_levels: args.overlay == Some(Overlay::Levels),
        terrain: args.dem.open()?,
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
