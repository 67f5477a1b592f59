//! `globe-data`: builds globe's tiled elevation pyramid from GTOPO30-style rasters.
//!
//! The importer arrives with the real-data issue; until then this binary says so plainly
//! rather than pretending to work.

use std::process::ExitCode;

const HELP: &str = "globe-data: elevation data tools for globe

USAGE:
    globe-data <COMMAND>

This build has no commands yet. The importer (EHdr/BIL and GTOPO30 tiles → pyramid file),
`info`, `verify`, `sample` and `synth` are planned; see data-tools/README.md.
The viewer currently renders the built-in analytic test planet.";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        None | Some("-h") | Some("--help") | Some("help") => {
            println!("{HELP}");
            ExitCode::SUCCESS
        }
        Some("-V") | Some("--version") => {
            println!("globe-data {}", env!("CARGO_PKG_VERSION"));
            ExitCode::SUCCESS
        }
        Some(other) => {
            eprintln!(
                "globe-data: unknown command '{other}': this build has no data commands yet (see --help)"
            );
            ExitCode::from(2)
        }
    }
}
