//! `globe-data sample` on imported GTOPO30-shaped tiles agrees with GDAL's `gdallocationinfo`
//! (an independent EHdr reader) at pixel centres along every edge, at the corners and at random
//! pixels. GTOPO30's NODATA (−9999, GDAL's answer over the ocean) is sea level in the pyramid.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

const ETOPO5: &str = "/usr/share/ferret-vis/data/etopo5.cdf";

fn available() -> bool {
    let gdal = Command::new("gdallocationinfo")
        .arg("--version")
        .output()
        .is_ok();
    let data = Path::new(ETOPO5).exists();
    if gdal && data {
        return true;
    }
    assert!(
        std::env::var("GLOBE_REQUIRE_DATA").as_deref() != Ok("1"),
        "GLOBE_REQUIRE_DATA=1 but gdal-bin or ferret-datasets is missing"
    );
    eprintln!("SKIPPED: needs gdallocationinfo (gdal-bin) and {ETOPO5} (ferret-datasets)");
    false
}

fn globe_data(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_globe-data"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "globe-data {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// GDAL's values at (lon, lat) points, one process for all of them.
fn gdal_values(dem: &Path, points: &[(f64, f64)]) -> Vec<f64> {
    let mut child = Command::new("gdallocationinfo")
        .args(["-valonly", "-geoloc"])
        .arg(dem)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    {
        let stdin = child.stdin.as_mut().unwrap();
        for (lat, lon) in points {
            writeln!(stdin, "{lon} {lat}").unwrap();
        }
    }
    let out = child.wait_with_output().unwrap();
    String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| l.trim().parse().unwrap())
        .collect()
}

#[test]
fn sample_matches_gdallocationinfo_on_gtopo30_tiles() {
    if !available() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let dir: PathBuf = tmp.path().join("tiles");
    let d = dir.to_str().unwrap();
    globe_data(&[
        "synth",
        "--input",
        ETOPO5,
        "--out",
        d,
        "--tiles",
        "W020N40,W060S60",
    ]);
    // (tile, north-west corner, cols, rows) at 30″.
    for (name, west, north, cols, rows) in [
        ("W020N40", -20.0, 40.0, 4800usize, 6000usize),
        ("W060S60", -60.0, -60.0, 7200, 3600),
    ] {
        let hdr = dir.join(format!("{name}.HDR"));
        let pyr = dir.join(format!("{name}.globepyr"));
        globe_data(&[
            "import",
            "--input",
            hdr.to_str().unwrap(),
            "--out",
            pyr.to_str().unwrap(),
        ]);
        let dxy = 30.0 / 3600.0;
        let centre = |r: usize, c: usize| {
            (
                north - (r as f64 + 0.5) * dxy,
                west + (c as f64 + 0.5) * dxy,
            )
        };
        let mut pixels = vec![(0, 0), (0, cols - 1), (rows - 1, 0), (rows - 1, cols - 1)];
        for i in 0..=24 {
            let (r, c) = (i * (rows - 1) / 24, i * (cols - 1) / 24);
            pixels.extend([(0, c), (rows - 1, c), (r, 0), (r, cols - 1)]);
        }
        let mut seed = 12345u64;
        for _ in 0..60 {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            pixels.push(((seed >> 33) as usize % rows, (seed >> 13) as usize % cols));
        }
        let points: Vec<(f64, f64)> = pixels.iter().map(|&(r, c)| centre(r, c)).collect();
        let gdal = gdal_values(&dir.join(format!("{name}.DEM")), &points);
        assert_eq!(gdal.len(), points.len());
        let (mut land, mut sea) = (0, 0);
        for ((lat, lon), g) in points.iter().zip(&gdal) {
            let ours: f64 = globe_data(&[
                "sample",
                pyr.to_str().unwrap(),
                &lat.to_string(),
                &lon.to_string(),
            ])
            .trim()
            .parse()
            .unwrap();
            let want = if *g == -9999.0 { 0.0 } else { *g };
            if *g == -9999.0 {
                sea += 1
            } else {
                land += 1
            }
            assert_eq!(
                ours, want,
                "{name} at {lat}, {lon}: globe-data {ours}, gdallocationinfo {g}"
            );
        }
        eprintln!(
            "{name}: {} points agree ({land} with data, {sea} NODATA = sea level)",
            points.len()
        );
    }
}
