//! `globe-data import | info | verify | sample`: the tiled pyramid file (`globe::dem::pyramid`).

use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::Args;
use globe::dem::open_raster;
use globe::dem::pyramid::{DEFAULT_TILE_SIZE, NanPolicy, Pyramid, PyramidBuilder};

use globe::progress::Progress;

#[derive(Args)]
pub struct ImportArgs {
    /// A folder of EHdr tiles (GTOPO30's 33 or any subset, one mosaic) or of SRTM .hgt tiles
    /// or GeoTIFFs (one mosaic), one EHdr raster (.HDR or its data file), a netCDF-3 file
    /// (ETOPO5), a GeoTIFF or COG (.tif; first image only, overviews ignored), or an SRTM .hgt
    /// tile.
    #[arg(long)]
    input: PathBuf,
    /// The pyramid file to write (written as FILE.partial and renamed when complete).
    #[arg(long)]
    out: PathBuf,
    /// Samples per tile side.
    #[arg(long = "tile-size", default_value_t = DEFAULT_TILE_SIZE)]
    tile_size: usize,
    /// netCDF variable to read (default: the only 2-D variable).
    #[arg(long)]
    variable: Option<String>,
    /// Fail on pixels without data instead of taking them as sea level (0 m).
    #[arg(long = "reject-nodata")]
    reject_nodata: bool,
}

pub fn import(args: &ImportArgs) -> anyhow::Result<()> {
    let source = open_raster(&args.input, args.variable.as_deref())
        .with_context(|| format!("cannot read {}", args.input.display()))?;
    let g = source.grid();
    eprintln!(
        "source: {} ({} × {} pixels)",
        source.describe(),
        g.cols,
        g.rows
    );
    let mut progress = Progress::new("import", g.rows as u64, Some("rows"));
    let policy = if args.reject_nodata {
        NanPolicy::Reject
    } else {
        NanPolicy::SeaLevel
    };
    let report = PyramidBuilder::new()
        .tile_size(args.tile_size)
        .nan_policy(policy)
        .on_progress(|p| progress.set(p.rows_done as u64))
        .build(source.as_ref(), &args.out)
        .with_context(|| format!("cannot build {}", args.out.display()))?;
    progress.finish();
    let seconds = report.elapsed.as_secs_f64().max(1e-9);
    let input_mb = (g.cols * g.rows * 4) as f64 / 1e6;
    println!(
        "wrote {}: {} levels, {} tiles, {:.1} MB; heights {} … {} m; {} pixels without data taken as sea level",
        report.path.display(),
        report.levels,
        report.tiles,
        report.file_bytes as f64 / 1e6,
        report.min_m,
        report.max_m,
        report.nan_count
    );
    println!(
        "{:.1} s, {:.0} rows/s, {:.1} MB/s of source samples (as f32), peak buffers {:.1} MB",
        seconds,
        report.rows_per_s,
        input_mb / seconds,
        report.buffer_bytes as f64 / 1e6
    );
    Ok(())
}

#[derive(Args)]
pub struct FileArg {
    /// A pyramid file made by `globe-data import` (`info` also describes any raster `import`
    /// reads).
    file: PathBuf,
}

/// A pyramid's header, or what `import` would read from a raster: its grid and extents.
pub fn info(args: &FileArg) -> anyhow::Result<()> {
    if !args.file.is_dir() && starts_with_pyramid_magic(&args.file) {
        let p = Pyramid::open(&args.file)?;
        print!("{}", p.info());
        return Ok(());
    }
    let source = open_raster(&args.file, None)
        .with_context(|| format!("cannot read {}", args.file.display()))?;
    let g = source.grid();
    println!("source: {}", source.describe());
    println!("pixels: {} × {}", g.cols, g.rows);
    println!(
        "pixel size: {}° × {}° ({:.1}″ × {:.1}″)",
        g.dlon_deg,
        g.dlat_deg,
        g.dlon_deg * 3600.0,
        g.dlat_deg * 3600.0
    );
    println!(
        "extents (pixel edges): west {}°, east {}°, north {}°, south {}°",
        g.lon0_deg - 0.5 * g.dlon_deg,
        g.lon0_deg + (g.cols as f64 - 0.5) * g.dlon_deg,
        g.lat0_deg + 0.5 * g.dlat_deg,
        g.lat0_deg - (g.rows as f64 - 0.5) * g.dlat_deg
    );
    Ok(())
}

fn starts_with_pyramid_magic(path: &std::path::Path) -> bool {
    use std::io::Read;
    let mut magic = [0u8; 8];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut magic))
        .is_ok()
        && magic == globe::dem::pyramid::MAGIC
}

pub fn verify(args: &FileArg) -> anyhow::Result<()> {
    let p = Pyramid::open(&args.file)?;
    let report = p
        .verify()
        .with_context(|| format!("{} failed verification", args.file.display()))?;
    println!(
        "{}: OK, {} tiles ({:.1} MB) match their checksums",
        args.file.display(),
        report.tiles,
        report.bytes as f64 / 1e6
    );
    Ok(())
}

#[derive(Args)]
pub struct SampleArgs {
    /// A pyramid file made by `globe-data import`.
    file: PathBuf,
    /// Latitude, degrees north.
    #[arg(allow_negative_numbers = true)]
    lat: f64,
    /// Longitude, degrees east.
    #[arg(allow_negative_numbers = true)]
    lon: f64,
    /// Pyramid level (0 = the finest).
    #[arg(long, default_value_t = 0)]
    level: usize,
}

/// Prints the height in metres, bilinear between pixel centres (a pixel centre gives its stored
/// value exactly).
pub fn sample(args: &SampleArgs) -> anyhow::Result<()> {
    if !(-90.0..=90.0).contains(&args.lat) || !args.lon.is_finite() {
        bail!(
            "latitude {} must be within [-90, 90] and longitude finite",
            args.lat
        );
    }
    let p = Pyramid::open(&args.file)?;
    if args.level >= p.level_count() {
        bail!(
            "{} has levels 0 to {}; --level {} does not exist",
            args.file.display(),
            p.level_count() - 1,
            args.level
        );
    }
    match p.sample(args.lat, args.lon, args.level) {
        Some(h) => println!("{h}"),
        None => bail!(
            "no data at {}, {}: outside the extents of {} ({:?})",
            args.lat,
            args.lon,
            args.file.display(),
            p.extents()
        ),
    }
    Ok(())
}
