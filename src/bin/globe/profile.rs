//! `globe profile`: the terrain's heights along the great circle between two places, written
//! as CSV (and, with `--plot`, drawn as a PNG or SVG), from the terrain function at full
//! resolution: no GPU.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::str::FromStr;

use anyhow::{Context, bail};
use clap::Args;
use globe::instruments::plot::{profile_png, profile_svg};
use globe::measure::{Profile, great_circle_profile};

use crate::args::DemArgs;

/// A place as `LAT,LON` in degrees.
#[derive(Clone, Copy, Debug)]
pub struct Place {
    pub lat_deg: f64,
    pub lon_deg: f64,
}

impl FromStr for Place {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let expected = "expected LAT,LON in degrees, e.g. 46.55,7.98";
        let Some((lat, lon)) = s.split_once(',') else {
            return Err(format!("'{s}': {expected}"));
        };
        let parse = |v: &str| v.trim().parse::<f64>().ok().filter(|v| v.is_finite());
        match (parse(lat), parse(lon)) {
            (Some(lat_deg), Some(lon_deg)) if (-90.0..=90.0).contains(&lat_deg) => {
                Ok(Self { lat_deg, lon_deg })
            }
            (Some(lat_deg), Some(_)) => Err(format!(
                "'{s}': latitude {lat_deg} is outside −90…90 ({expected})"
            )),
            _ => Err(format!("'{s}': {expected}")),
        }
    }
}

#[derive(Args)]
pub struct ProfileArgs {
    /// The start: LAT,LON in degrees.
    #[arg(long, value_name = "LAT,LON", allow_hyphen_values = true)]
    pub from: Place,
    /// The end: LAT,LON in degrees (the shorter great-circle arc is taken).
    #[arg(long, value_name = "LAT,LON", allow_hyphen_values = true)]
    pub to: Place,
    /// Points along the arc, both ends included, equally spaced.
    #[arg(long, value_name = "N", default_value_t = 1000)]
    pub samples: usize,
    /// The CSV to write: `distance_m,lat_deg,lon_deg,height_m`, one row per point.
    #[arg(long, value_name = "FILE.csv")]
    pub out: PathBuf,
    /// Also draw the profile: a `.png` or `.svg` file, by its extension.
    #[arg(long, value_name = "FILE.png|svg")]
    pub plot: Option<PathBuf>,
    /// The plot's size in pixels, WIDTHxHEIGHT.
    #[arg(long, value_name = "WxH", default_value = "1200x500")]
    pub plot_size: String,
    #[command(flatten)]
    pub dem: DemArgs,
}

enum PlotKind {
    Png,
    Svg,
}

fn plot_kind(path: &Path) -> anyhow::Result<PlotKind> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
    {
        Some(e) if e == "png" => Ok(PlotKind::Png),
        Some(e) if e == "svg" => Ok(PlotKind::Svg),
        _ => bail!(
            "--plot {}: the plot is written as PNG or SVG, chosen by the extension (.png or .svg)",
            path.display()
        ),
    }
}

fn plot_size(s: &str) -> anyhow::Result<(u32, u32)> {
    let parsed = s
        .split_once(['x', 'X', '×'])
        .and_then(|(w, h)| Some((w.trim().parse::<u32>().ok()?, h.trim().parse::<u32>().ok()?)));
    match parsed {
        Some((w, h)) if (200..=8192).contains(&w) && (150..=8192).contains(&h) => Ok((w, h)),
        _ => bail!(
            "--plot-size {s}: expected WIDTHxHEIGHT in pixels, 200…8192 wide and 150…8192 high, e.g. 1200x500"
        ),
    }
}

fn write_csv(path: &Path, profile: &Profile) -> anyhow::Result<()> {
    let file = std::fs::File::create(path)
        .with_context(|| format!("cannot create --out {}", path.display()))?;
    let mut w = std::io::BufWriter::new(file);
    let write = |w: &mut std::io::BufWriter<std::fs::File>| -> std::io::Result<()> {
        writeln!(w, "distance_m,lat_deg,lon_deg,height_m")?;
        for p in &profile.points {
            // Enough digits for a millimetre along the arc and 1e-9° (0.1 mm) in place.
            writeln!(
                w,
                "{:.4},{:.10},{:.10},{:.4}",
                p.distance_m, p.lat_deg, p.lon_deg, p.height_m
            )?;
        }
        w.flush()
    };
    write(&mut w).with_context(|| format!("cannot write --out {}", path.display()))
}

pub fn profile(args: &ProfileArgs) -> anyhow::Result<ExitCode> {
    // Everything the arguments can get wrong is refused before the terrain is opened.
    let plot = match &args.plot {
        Some(path) => Some((path, plot_kind(path)?, plot_size(&args.plot_size)?)),
        None => None,
    };
    let terrain = args.dem.open()?;
    let (from, to) = (args.from, args.to);
    let profile = great_circle_profile(
        &terrain,
        (from.lat_deg, from.lon_deg),
        (to.lat_deg, to.lon_deg),
        args.samples,
    )
    .with_context(|| {
        format!(
            "--from {},{} --to {},{}",
            from.lat_deg, from.lon_deg, to.lat_deg, to.lon_deg
        )
    })?;
    write_csv(&args.out, &profile)?;
    if let Some((path, kind, (w, h))) = plot {
        match kind {
            PlotKind::Png => profile_png(&profile, w, h)?
                .save_with_format(path, image::ImageFormat::Png)
                .with_context(|| format!("cannot write --plot {}", path.display()))?,
            PlotKind::Svg => std::fs::write(path, profile_svg(&profile, w, h)?)
                .with_context(|| format!("cannot write --plot {}", path.display()))?,
        }
    }
    let (lo, hi) = profile.height_range_m();
    println!(
        "{} points: {:.3} m along the great circle, {:.3} m along the terrain; heights {lo:.3} … {hi:.3} m, end minus start {:+.3} m ({})",
        profile.points.len(),
        profile.great_circle_m,
        profile.along_terrain_m,
        profile.height_difference_m(),
        terrain.describe()
    );
    Ok(ExitCode::SUCCESS)
}
