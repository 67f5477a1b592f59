//! `globe`: the viewer, and its headless commands. Arguments (`args` and each command's own)
//! become the library's settings; each command runs in its own module.

#![warn(clippy::too_many_lines)]

mod args;
mod bench;
mod cli;
mod probe;
mod profile;
mod render;
mod report;
mod scenes;
mod soak;
mod viewer;

use std::process::ExitCode;

use clap::Parser;
use cli::{Cli, Command};
use scenes::print_scenes;

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
        Some(Command::Probe(args)) => probe::probe(&args),
        Some(Command::Profile(args)) => profile::profile(&args),
        None => viewer::viewer(&cli.viewer),
    }
}
