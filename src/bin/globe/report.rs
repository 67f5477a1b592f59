//! `globe report`: every method and setting over the named scenes, written as tables and plots.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, bail};
use clap::Args;
use globe::progress::Progress;
use globe::render::GpuContext;
use globe::scenes::CameraSpec;

use crate::args::*;

#[derive(Args)]
pub struct ReportArgs {
    /// Folder to write the report's files into (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// Scenes to run, comma-separated [default: space,aircraft,ground; none with --camera].
    #[arg(long, value_delimiter = ',')]
    pub scenes: Option<Vec<String>>,
    /// Also run this view (after --scenes; alone without --scenes), named "camera" in the
    /// outputs. Same form as `globe render --camera`.
    #[arg(long, value_name = "VIEW", allow_hyphen_values = true)]
    pub camera: Option<CameraSpec>,
    #[arg(long, default_value_t = 1920)]
    pub width: u32,
    #[arg(long, default_value_t = 1080)]
    pub height: u32,
    /// Timed frames per setting (medians reported).
    #[arg(long, default_value_t = 5)]
    pub frames: usize,
    /// Cast the reference at every Nth pixel in x and y (1: all). The error statistics then
    /// cover that sample, at the full resolution's pixel footprint (the reference over rough
    /// procedural detail costs minutes per full 1080p frame on two cores).
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub every: u32,
    /// Run the error-bounded projected grid's Tables 1–2 instead of the settings grid: grids
    /// 1024x512, 512x256, 600x600, 300x900 and 400x1900, uniform and warped, without and with
    /// ray casting, beside the clipmap (the paper used --width 1024 --height 800); also writes
    /// projgrid_tables.md.
    #[arg(long = "projgrid-tables")]
    pub projgrid_tables: bool,
    #[command(flatten)]
    pub measure_limit: MeasureArgs,
    /// The base settings every row varies one parameter of.
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

pub fn report(args: &ReportArgs) -> anyhow::Result<ExitCode> {
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
    let options = globe::instruments::report::ReportOptions {
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
    let rows = globe::instruments::report::run_within(
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
                partial_error = globe::instruments::report::write_text(
                    &args.out, rows, &adapter, &describe, &options,
                )
                .err();
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
    globe::instruments::report::write(&args.out, &rows, &adapter, &describe, &options)
        .with_context(|| format!("cannot write the report into {}", args.out.display()))?;
    eprintln!(
        "wrote {}/report.csv, report.json, report.md, error_vs_time.png and .svg ({} rows) in {:.1} s",
        args.out.display(),
        rows.len(),
        started.elapsed().as_secs_f64()
    );
    Ok(ExitCode::SUCCESS)
}
