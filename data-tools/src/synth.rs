//! `globe-data synth`: GTOPO30-style tiles resampled from a real raster.
//!
//! GTOPO30's layout: 27 tiles of 40° × 50° from 90° N to 60° S (W180 … E140 × N90, N40, S10)
//! and 6 Antarctic tiles of 60° × 30° (W180 … E120 × S60), named by their north-west corner;
//! 4800 × 6000 and 7200 × 3600 pixels at 30″. Pixel centres (ULXMAP/ULYMAP) are half a pixel in
//! from the corner.

use std::cell::RefCell;
use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use globe::dem::ehdr::{EhdrWriteOptions, write_ehdr};
use globe::dem::open_raster;
use globe::dem::raster::BilinearSampler;
use globe::dem::{DemError, GeoGrid};

use globe::progress::Progress;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Ocean {
    /// Heights below sea level become NODATA (-9999), as over GTOPO30's oceans. Inland
    /// depressions (the Dead Sea) go too: the source cannot tell them from the sea.
    Nodata,
    /// Keep every height, bathymetry included.
    Keep,
}

#[derive(Args)]
pub struct SynthArgs {
    /// Source raster: a netCDF-3 file (ETOPO5: /usr/share/ferret-vis/data/etopo5.cdf), an
    /// EHdr .HDR/.DEM file, or a folder of EHdr tiles.
    #[arg(long)]
    input: PathBuf,
    /// Output folder (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Pixel spacing in arc-seconds (GTOPO30: 30). Must divide 30° evenly.
    #[arg(long = "spacing-arcsec", default_value_t = 30)]
    spacing_arcsec: u32,
    /// Heights below sea level: nodata (GTOPO30's convention) or keep.
    #[arg(long, value_enum, default_value = "nodata")]
    ocean: Ocean,
    /// Only these tiles (GTOPO30 names, comma-separated, e.g. W020N40,W060S60); default all 33.
    #[arg(long, value_delimiter = ',')]
    tiles: Vec<String>,
    /// netCDF variable to read (default: the only 2-D variable).
    #[arg(long)]
    variable: Option<String>,
}

/// One GTOPO30 tile: its name and north-west corner and size in degrees.
#[derive(Clone, Debug, PartialEq)]
pub struct TileSpec {
    pub name: String,
    pub west_deg: i32,
    pub north_deg: i32,
    pub width_deg: u32,
    pub height_deg: u32,
}

/// GTOPO30's 33 tiles.
pub fn gtopo30_tiles() -> Vec<TileSpec> {
    let name = |west: i32, north: i32| {
        let ew = if west < 0 {
            format!("W{:03}", -west)
        } else if west == 0 {
            "W000".into()
        } else {
            format!("E{west:03}")
        };
        let ns = if north >= 0 {
            format!("N{north:02}")
        } else {
            format!("S{:02}", -north)
        };
        format!("{ew}{ns}")
    };
    let mut tiles = Vec::new();
    for north in [90, 40, -10] {
        for west in (-180..180).step_by(40) {
            tiles.push(TileSpec {
                name: name(west, north),
                west_deg: west,
                north_deg: north,
                width_deg: 40,
                height_deg: 50,
            });
        }
    }
    for west in (-180..180).step_by(60) {
        tiles.push(TileSpec {
            name: name(west, -60),
            west_deg: west,
            north_deg: -60,
            width_deg: 60,
            height_deg: 30,
        });
    }
    tiles
}

pub fn run(args: &SynthArgs) -> anyhow::Result<()> {
    if args.spacing_arcsec == 0 || 30 * 3600 % args.spacing_arcsec != 0 {
        bail!(
            "--spacing-arcsec {} must divide 30° = 108000″ evenly (e.g. 30, 60, 300, 600)",
            args.spacing_arcsec
        );
    }
    let all = gtopo30_tiles();
    let tiles: Vec<TileSpec> = if args.tiles.is_empty() {
        all
    } else {
        let mut chosen = Vec::new();
        for wanted in &args.tiles {
            let t = all
                .iter()
                .find(|t| t.name.eq_ignore_ascii_case(wanted))
                .with_context(|| {
                    format!(
                        "unknown tile '{wanted}'; GTOPO30's tiles are {}",
                        all.iter()
                            .map(|t| t.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    )
                })?;
            chosen.push(t.clone());
        }
        chosen
    };
    let source = open_raster(&args.input, args.variable.as_deref())
        .with_context(|| format!("cannot read the source raster {}", args.input.display()))?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let spacing_deg = args.spacing_arcsec as f64 / 3600.0;
    let per_deg = 3600 / args.spacing_arcsec as usize;
    let total_rows: u64 = tiles
        .iter()
        .map(|t| (t.height_deg as usize * 3600 / args.spacing_arcsec as usize) as u64)
        .sum();
    eprintln!("source: {}", source.describe());
    let mut progress = Progress::new(
        format!("synth {} tiles", tiles.len()),
        total_rows,
        Some("rows"),
    );
    let mut bytes = 0u64;
    for tile in &tiles {
        let grid = GeoGrid {
            cols: tile.width_deg as usize * 3600 / args.spacing_arcsec as usize,
            rows: tile.height_deg as usize * 3600 / args.spacing_arcsec as usize,
            lon0_deg: tile.west_deg as f64 + 0.5 * spacing_deg,
            lat0_deg: tile.north_deg as f64 - 0.5 * spacing_deg,
            dlon_deg: spacing_deg,
            dlat_deg: spacing_deg,
        };
        debug_assert_eq!(grid.cols, tile.width_deg as usize * per_deg);
        let sampler = RefCell::new(BilinearSampler::new(source.as_ref()));
        let failure: RefCell<Option<DemError>> = RefCell::new(None);
        let progress_cell = RefCell::new(&mut progress);
        let rows = (0..grid.rows).map(|r| {
            let lat = grid.lat_of_row(r as f64);
            let mut row = vec![f32::NAN; grid.cols];
            if failure.borrow().is_none() {
                let mut s = sampler.borrow_mut();
                for (c, v) in row.iter_mut().enumerate() {
                    match s.sample(lat, grid.lon_of_col(c as f64)) {
                        Ok(h) if args.ocean == Ocean::Nodata && h < 0.0 => *v = f32::NAN,
                        Ok(h) => *v = h as f32,
                        Err(e) => {
                            *failure.borrow_mut() = Some(e);
                            break;
                        }
                    }
                }
            }
            progress_cell.borrow_mut().add(1);
            row
        });
        let stem = args.out.join(&tile.name);
        let written = write_ehdr(&stem, &grid, &EhdrWriteOptions::gtopo30(), rows)
            .with_context(|| format!("cannot write tile {}", tile.name))?;
        if let Some(e) = failure.into_inner() {
            let _ = std::fs::remove_file(&written.data_path);
            let _ = std::fs::remove_file(&written.header_path);
            return Err(e).with_context(|| format!("reading the source for tile {}", tile.name));
        }
        bytes += std::fs::metadata(&written.data_path)
            .map(|m| m.len())
            .unwrap_or(0);
    }
    let seconds = progress.finish();
    eprintln!(
        "wrote {} tiles ({:.1} MB of .DEM) to {} in {:.1} s",
        tiles.len(),
        bytes as f64 / 1e6,
        args.out.display(),
        seconds
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_33_gtopo30_tiles() {
        let t = gtopo30_tiles();
        assert_eq!(t.len(), 33);
        assert!(t.iter().any(|t| t.name == "W020N40"));
        assert!(
            t.iter()
                .any(|t| t.name == "W000S60" && t.width_deg == 60 && t.height_deg == 30)
        );
        assert!(t.iter().any(|t| t.name == "E140S10"));
        let area: u32 = t.iter().map(|t| t.width_deg * t.height_deg).sum();
        assert_eq!(area, 360 * 180);
    }
}
