//! The command line as clap parses it: the commands and, with none, the viewer's arguments.
//! Each command's own arguments live beside its runner; the groups they share in `args`.

use clap::{Parser, Subcommand};

use crate::bench::BenchArgs;
use crate::probe::ProbeArgs;
use crate::profile::ProfileArgs;
use crate::render::RenderArgs;
use crate::report::ReportArgs;
use crate::viewer::ViewerArgs;

#[derive(Parser)]
#[command(
    name = "globe",
    version,
    about = "A planetary globe viewer: spherical geometry clipmaps from orbit to the ground",
    long_about = "A planetary globe viewer: spherical geometry clipmaps from orbit to the ground.\n\n\
                  With no command, opens the viewer window. Without a display use `globe render`."
)]
/// `globe [COMMAND]`: the arguments as parsed, before any is validated.
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
    #[command(flatten)]
    pub viewer: ViewerArgs,
}

#[derive(Subcommand)]
pub enum Command {
    /// Render a named scene or a --camera view headless (no window, no GPU needed: a software adapter works) to PNG.
    Render(RenderArgs),
    /// Benchmark a scene, a --camera view or the `flight` path headless: per-frame CPU and GPU time,
    /// triangles, levels, streaming counters (median/min/max; `--json` for one JSON object).
    Bench(BenchArgs),
    /// Run every method and setting over the named scenes and write report.csv, report.json,
    /// report.md and error_vs_time.png/.svg: triangles, CPU/GPU time and the per-pixel error ρ.
    Report(ReportArgs),
    /// What lies under one pixel of a --scene or --camera view: latitude, longitude, height
    /// and distance from the eye, from the f64 ray caster over the terrain function (detail
    /// and water included: the surface that is drawn and measured). No GPU needed.
    Probe(ProbeArgs),
    /// The terrain's profile along the great circle between two places: heights at N equally
    /// spaced points (the terrain function at full resolution, detail and water included) to a
    /// CSV, optionally drawn as a PNG or SVG; prints the great-circle distance, the distance
    /// along the terrain and the heights. No GPU needed.
    Profile(ProfileArgs),
    /// List the named scenes (the viewer's bookmarks).
    Scenes,
}
