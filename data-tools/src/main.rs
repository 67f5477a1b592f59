//! `globe-data`: elevation data tools for globe (see data-tools/README.md).

#![warn(clippy::too_many_lines)]

mod earth;
mod pyramid_cmd;
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
    /// Build a pyramid file (tiled avg/min/max levels down to one tile, checksummed) from a
    /// raster (EHdr, netCDF-3, GeoTIFF/COG, SRTM .hgt) or a folder of tiles, in bounded memory,
    /// with progress.
    Import(pyramid_cmd::ImportArgs),
    /// Describe a pyramid file (source, extents, levels, tiles, height range), or a raster
    /// `import` reads (its grid and extents).
    Info(pyramid_cmd::FileArg),
    /// Check every tile of a pyramid file against its checksum.
    Verify(pyramid_cmd::FileArg),
    /// Print the height in metres at LAT LON (bilinear; a pixel centre gives its stored value).
    Sample(pyramid_cmd::SampleArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Synth(args) => synth::run(&args),
        Command::Earth(args) => earth::run(&args),
        Command::Import(args) => pyramid_cmd::import(&args),
        Command::Info(args) => pyramid_cmd::info(&args),
        Command::Verify(args) => pyramid_cmd::verify(&args),
        Command::Sample(args) => pyramid_cmd::sample(&args),
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
