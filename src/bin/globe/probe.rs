//! `globe probe`: what lies under one pixel of a headless view (latitude, longitude, height,
//! distance), from the f64 ray caster over the terrain function: no GPU.

use std::process::ExitCode;
use std::str::FromStr;

use anyhow::{Context, bail};
use clap::Args;
use globe::measure::probe_pixel;
use globe::scenes::CameraSpec;
use serde::Serialize;

use crate::args::DemArgs;
use crate::scenes::chosen_view;

/// A pixel as `X,Y` (column, row; row 0 at the top).
#[derive(Clone, Copy, Debug)]
pub struct Pixel {
    pub x: u32,
    pub y: u32,
}

impl FromStr for Pixel {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let parse = |part: &str| part.trim().parse::<u32>();
        match s.split_once(',') {
            Some((x, y)) => match (parse(x), parse(y)) {
                (Ok(x), Ok(y)) => Ok(Self { x, y }),
                _ => Err(format!(
                    "'{s}': expected X,Y as two whole numbers ≥ 0, e.g. 640,360"
                )),
            },
            None => Err(format!("'{s}': expected X,Y (column, row), e.g. 640,360")),
        }
    }
}

#[derive(Args)]
#[group(id = "view", required = true, multiple = false, args = ["scene", "camera"])]
pub struct ProbeArgs {
    /// Named scene whose view to probe (see `globe scenes`).
    #[arg(long)]
    pub scene: Option<String>,
    /// The view to probe: LAT,LON,HEIGHT,HEADING,PITCH[,ROLL] as `globe render --camera`
    /// takes it (HEIGHT above the terrain under the camera, or HEIGHT@sphere).
    #[arg(long, value_name = "VIEW", allow_hyphen_values = true)]
    pub camera: Option<CameraSpec>,
    /// The pixel: X,Y (column, row from the top-left corner), its centre probed.
    #[arg(long, value_name = "X,Y")]
    pub pixel: Pixel,
    /// The view's width in pixels.
    #[arg(long, default_value_t = 1280)]
    pub width: u32,
    /// The view's height in pixels.
    #[arg(long, default_value_t = 720)]
    pub height: u32,
    /// One JSON object: `hit`, and with a hit `lat_deg`, `lon_deg`, `height_m`, `distance_m`.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub dem: DemArgs,
}

/// `globe probe --json`: these fields, `null` for sky.
#[derive(Serialize)]
struct ProbeJson {
    hit: bool,
    lat_deg: Option<f64>,
    lon_deg: Option<f64>,
    height_m: Option<f64>,
    distance_m: Option<f64>,
}

pub fn probe(args: &ProbeArgs) -> anyhow::Result<ExitCode> {
    let (width, height) = (args.width, args.height);
    if width == 0 || height == 0 {
        bail!("--width and --height must be at least 1 (got {width}×{height})");
    }
    let p = args.pixel;
    if p.x >= width || p.y >= height {
        bail!(
            "--pixel {},{} lies outside the {width}×{height} view (X < {width}, Y < {height})",
            p.x,
            p.y
        );
    }
    let (_, view) = chosen_view(args.scene.as_deref().unwrap_or_default(), args.camera)?;
    let terrain = args.dem.open()?;
    let camera = view.camera(|lat, lon| terrain.height_at_lat_lon_m(lat, lon));
    let hit = probe_pixel(&terrain, &camera, width, height, p.x, p.y);
    if args.json {
        let out = ProbeJson {
            hit: hit.is_some(),
            lat_deg: hit.map(|h| h.lat_deg),
            lon_deg: hit.map(|h| h.lon_deg),
            height_m: hit.map(|h| h.height_m),
            distance_m: hit.map(|h| h.distance_m),
        };
        println!(
            "{}",
            serde_json::to_string(&out).context("cannot write the JSON")?
        );
    } else {
        match hit {
            None => println!("sky"),
            Some(h) => println!(
                "lat {:.9}°  lon {:.9}°  height {:.3} m  distance {:.3} m",
                h.lat_deg, h.lon_deg, h.height_m, h.distance_m
            ),
        }
    }
    Ok(ExitCode::SUCCESS)
}
