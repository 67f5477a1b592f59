//! `globe-data`: elevation data tools for globe (see data-tools/README.md).

mod earth;
mod progress;
mod synth;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(name = "globe-data", version, about = "Elevation data tools for globe")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Write GTOPO30-style tiles (.DEM + .HDR: big-endian i16, NODATA -9999, GTOPO30's 33-tile
    /// layout and names) resampled from a real raster (ETOPO5 netCDF, or any EHdr raster or
    /// folder of tiles), for tests and demos.
    Synth(synth::SynthArgs),
    /// Make the small Earth embedded in globe (10′, bathymetry included) from ETOPO5.
    Earth(earth::EarthArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Synth(args) => synth::run(&args),
        Command::Earth(args) => earth::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("globe-data: error: {e}");
            for cause in e.chain().skip(1) {
                eprintln!("  caused by: {cause}");
            }
            ExitCode::FAILURE
        }
    }
}
