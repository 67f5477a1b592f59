//! `globe`: the viewer, and its headless commands. Arguments (`args` and each command's own)
//! become the library's settings; each command runs in its own module.

#![warn(clippy::too_many_lines)]

mod args;
mod bench;
mod render;
mod report;
mod scenes;
mod soak;
mod viewer;

use std::process::ExitCode;

use bench::BenchArgs;
use clap::{Parser, Subcommand};
use render::RenderArgs;
use report::ReportArgs;
use scenes::print_scenes;
use viewer::ViewerArgs;

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
        Some(Command::Render(args)) => render::render(&args),
        Some(Command::Bench(args)) => bench::bench(&args),
        Some(Command::Report(args)) => report::report(&args),
        None => viewer::viewer(&cli.viewer),
    }
}
