//! `globe-data earth`: the embedded Earth, decimated from ETOPO5 (5′) to 10′.
//!
//! 10′ pixel centres fall exactly on every other 5′ node, so each pixel is the 3 × 3 tent
//! filter (weights ¼, ½, ¼ per axis) of the nodes around it: the standard 2× decimation,
//! which keeps the Nyquist band and does not alias.

use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::Args;
use globe::dem::embedded::{EmbeddedEarth, grid};
use globe::dem::open_raster;
use globe::dem::raster::BilinearSampler;

use globe::progress::Progress;

#[derive(Args)]
pub struct EarthArgs {
    /// Source: ETOPO5 (/usr/share/ferret-vis/data/etopo5.cdf) or any global raster at 5′.
    #[arg(long)]
    input: PathBuf,
    /// Output PNG (the repository keeps it at assets/earth-10min.png).
    #[arg(long)]
    out: PathBuf,
}

pub fn run(args: &EarthArgs) -> anyhow::Result<()> {
    let source = open_raster(&args.input, None)
        .with_context(|| format!("cannot read {}", args.input.display()))?;
    let sg = source.grid();
    if (sg.dlon_deg - 1.0 / 12.0).abs() > 1e-9 || (sg.dlat_deg - 1.0 / 12.0).abs() > 1e-9 {
        bail!(
            "{}: expected a 5′ grid (ETOPO5), found {}° × {}°",
            args.input.display(),
            sg.dlon_deg,
            sg.dlat_deg
        );
    }
    let g = grid();
    let node = 1.0 / 12.0;
    let mut sampler = BilinearSampler::new(source.as_ref());
    let mut heights = Vec::with_capacity(g.cols * g.rows);
    let mut progress = Progress::new("earth", g.rows as u64, Some("rows"));
    for r in 0..g.rows {
        let lat = g.lat_of_row(r as f64);
        for c in 0..g.cols {
            let lon = g.lon_of_col(c as f64);
            let mut sum = 0.0;
            for (i, wi) in [(-1.0, 0.25), (0.0, 0.5), (1.0, 0.25)] {
                for (j, wj) in [(-1.0, 0.25), (0.0, 0.5), (1.0, 0.25)] {
                    let la = (lat + i * node).clamp(-90.0, 90.0);
                    sum += wi * wj * sampler.sample(la, lon + j * node)?;
                }
            }
            heights.push(sum.round().clamp(i16::MIN as f64, i16::MAX as f64) as i16);
        }
        progress.add(1);
    }
    progress.finish();
    let png = EmbeddedEarth::encode_png(&heights)?;
    std::fs::write(&args.out, &png)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    let (lo, hi) = heights
        .iter()
        .fold((i16::MAX, i16::MIN), |(a, b), &h| (a.min(h), b.max(h)));
    eprintln!(
        "wrote {} ({:.2} MB, {}×{} at 10′, heights {lo}…{hi} m)",
        args.out.display(),
        png.len() as f64 / 1e6,
        g.cols,
        g.rows
    );
    Ok(())
}
