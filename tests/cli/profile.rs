//! `globe profile` as a user runs it: the heights along a meridian of a GeoTIFF against GDAL's
//! own reading of the same pixels, the points of a long arc against the haversine formula,
//! the plot files, and clear refusals of impossible profiles.

use std::path::{Path, PathBuf};
use std::process::Command;

use globe::geo::EARTH_RADIUS_M;

fn profile(dir: &Path, args: &[&str]) -> (bool, String, String) {
    let run = Command::new(env!("CARGO_BIN_EXE_globe"))
        .arg("profile")
        .args(args)
        // Imports of --dem files go to a cache of this test's own.
        .env("XDG_CACHE_HOME", dir.join("cache"))
        .output()
        .expect("globe runs");
    (
        run.status.success(),
        String::from_utf8_lossy(&run.stdout).into_owned(),
        String::from_utf8_lossy(&run.stderr).into_owned(),
    )
}

/// The CSV's rows: (distance_m, lat_deg, lon_deg, height_m), after checking its header.
fn rows(csv: &Path) -> Vec<[f64; 4]> {
    let text = std::fs::read_to_string(csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("distance_m,lat_deg,lon_deg,height_m"));
    lines
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|f| f.parse().unwrap()).collect();
            [v[0], v[1], v[2], v[3]]
        })
        .collect()
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("globe-profile-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn gdal_out(program: &str, args: &[&str]) -> String {
    let out = Command::new(program)
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("{program}: {e}"));
    assert!(
        out.status.success(),
        "{program} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn gdal_ready() -> bool {
    let etopo5 = Path::new("/usr/share/ferret-vis/data/etopo5.cdf");
    let tools = ["gdal_translate", "gdallocationinfo", "gdalinfo"]
        .iter()
        .all(|p| {
            Command::new(p)
                .arg("--version")
                .output()
                .is_ok_and(|o| o.status.success())
        });
    if tools && etopo5.exists() {
        return true;
    }
    assert!(
        std::env::var("GLOBE_REQUIRE_DATA").as_deref() != Ok("1"),
        "GLOBE_REQUIRE_DATA=1 but GDAL's tools or ETOPO5 are missing (apt-get install gdal-bin ferret-datasets)"
    );
    eprintln!("SKIPPED: GDAL's tools or ETOPO5 missing (apt-get install gdal-bin ferret-datasets)");
    false
}

/// Down a meridian of the Alps through pixel centres of a GeoTIFF cut from ETOPO5 by GDAL,
/// with the detail and water off: every height is the pixel's value as `gdallocationinfo`
/// reads it (pixel centres are exact), to a millimetre.
#[test]
fn heights_down_a_meridian_are_gdals_pixels() {
    if !gdal_ready() {
        return;
    }
    let dir = temp_dir("gdal");
    let tif = dir.join("alps.tif");
    let tif_s = tif.to_str().unwrap();
    gdal_out(
        "gdal_translate",
        &[
            "-q",
            "-projwin",
            "6",
            "48",
            "12",
            "44",
            "-a_srs",
            "EPSG:4326",
            "-ot",
            "Int16",
            "/usr/share/ferret-vis/data/etopo5.cdf",
            tif_s,
        ],
    );
    let info: serde_json::Value =
        serde_json::from_str(&gdal_out("gdalinfo", &["-json", tif_s])).unwrap();
    let gt: Vec<f64> = (info["geoTransform"].as_array().unwrap().iter())
        .map(|v| v.as_f64().unwrap())
        .collect();
    let size: Vec<u64> = (info["size"].as_array().unwrap().iter())
        .map(|v| v.as_u64().unwrap())
        .collect();
    let (col, r0, r1) = (size[0] / 2, 3u64, size[1] - 4);
    let lon = gt[0] + (col as f64 + 0.5) * gt[1];
    let lat = |r: u64| gt[3] + (r as f64 + 0.5) * gt[5];
    let n = (r1 - r0 + 1) as usize;
    let csv = dir.join("meridian.csv");
    let (from, to) = (format!("{},{lon}", lat(r0)), format!("{},{lon}", lat(r1)));
    let (ok, out, err) = profile(
        &dir,
        &[
            "--dem",
            tif_s,
            "--detail",
            "off",
            "--water",
            "off",
            "--imagery",
            "off",
            "--from",
            &from,
            "--to",
            &to,
            "--samples",
            &n.to_string(),
            "--out",
            csv.to_str().unwrap(),
        ],
    );
    assert!(ok, "{err}");
    assert!(out.contains(&format!("{n} points")), "{out}");
    let rows = rows(&csv);
    assert_eq!(rows.len(), n);
    let mut relief = (f64::INFINITY, f64::NEG_INFINITY);
    for (k, row) in rows.iter().enumerate() {
        let r = r0 + k as u64;
        let gdal: f64 = gdal_out(
            "gdallocationinfo",
            &["-valonly", tif_s, &col.to_string(), &r.to_string()],
        )
        .trim()
        .parse()
        .unwrap();
        assert!((row[1] - lat(r)).abs() < 1e-9, "row {k}: {row:?}");
        assert!((row[2] - lon).abs() < 1e-9, "row {k}: {row:?}");
        assert!(
            (row[3] - gdal).abs() < 1e-3,
            "row {k} (pixel {col},{r}): globe {} m, gdallocationinfo {gdal} m",
            row[3]
        );
        relief = (relief.0.min(gdal), relief.1.max(gdal));
    }
    // The meridian crosses real relief, so agreement is not one flat value.
    assert!(relief.1 - relief.0 > 1000.0, "{relief:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The great-circle distance in metres on the sphere of radius R by Vincenty's formula for
/// the sphere (a form of its own, apart from the library's vector form).
fn vincenty_m((lat1, lon1): (f64, f64), (lat2, lon2): (f64, f64)) -> f64 {
    let (p1, p2) = (lat1.to_radians(), lat2.to_radians());
    let dl = (lon2 - lon1).to_radians();
    let y = (p2.cos() * dl.sin()).hypot(p1.cos() * p2.sin() - p1.sin() * p2.cos() * dl.cos());
    let x = p1.sin() * p2.sin() + p1.cos() * p2.cos() * dl.cos();
    EARTH_RADIUS_M * y.atan2(x)
}

/// London to New York: the length is Vincenty's great-circle distance (±1 mm per km), every
/// point lies on the great circle (its distances to the two ends add up to the whole, and the first is the CSV's distance), the
/// points are equally spaced, and the distance along the terrain printed is the polyline
/// through the CSV's points at their heights.
#[test]
fn a_long_arc_lies_on_the_great_circle() {
    let dir = temp_dir("arc");
    let csv = dir.join("arc.csv");
    let (a, b) = ((51.4779, -0.0015), (40.6892, -74.0445));
    let (ok, out, err) = profile(
        &dir,
        &[
            "--from",
            "51.4779,-0.0015",
            "--to",
            "40.6892,-74.0445",
            "--samples",
            "501",
            "--out",
            csv.to_str().unwrap(),
        ],
    );
    assert!(ok, "{err}");
    let rows = rows(&csv);
    assert_eq!(rows.len(), 501);
    let total = vincenty_m(a, b);
    assert!(
        (rows[500][0] - total).abs() < 1e-3,
        "{} vs {total}",
        rows[500][0]
    );
    let mut polyline = 0.0;
    let mut previous: Option<glam::DVec3> = None;
    for (k, row) in rows.iter().enumerate() {
        let p = (row[1], row[2]);
        let (d_from, d_to) = (vincenty_m(a, p), vincenty_m(p, b));
        assert!(
            (d_from + d_to - total).abs() < 2e-3,
            "row {k}: off the arc by {} m",
            d_from + d_to - total
        );
        assert!(
            (d_from - row[0]).abs() < 2e-3,
            "row {k}: {} vs {}",
            d_from,
            row[0]
        );
        assert!((row[0] - total * k as f64 / 500.0).abs() < 1e-3, "row {k}");
        let (la, lo) = (row[1].to_radians(), row[2].to_radians());
        let u = glam::DVec3::new(la.cos() * lo.cos(), la.cos() * lo.sin(), la.sin());
        let q = (EARTH_RADIUS_M + row[3]) * u;
        if let Some(prev) = previous {
            polyline += (q - prev).length();
        }
        previous = Some(q);
    }
    let printed: f64 = out
        .split(" m along the terrain")
        .next()
        .and_then(|s| s.rsplit(' ').next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no distance along the terrain in {out}"));
    // The CSV's 4 decimals of height and 10 of degrees: a few mm over 501 points.
    assert!((printed - polyline).abs() < 0.05, "{printed} vs {polyline}");
    assert!(printed > total, "{printed} vs {total}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--plot` writes a PNG of the size asked for or an SVG with the line in it; an extension
/// it cannot write is refused before anything is computed.
#[test]
fn the_plot_files() {
    let dir = temp_dir("plot");
    let csv = dir.join("p.csv");
    let (png, svg) = (dir.join("p.png"), dir.join("p.svg"));
    for (plot, size) in [(&png, "800x300"), (&svg, "640x240")] {
        let (ok, _, err) = profile(
            &dir,
            &[
                "--from",
                "46.0,7.0",
                "--to",
                "46.5,8.5",
                "--samples",
                "200",
                "--out",
                csv.to_str().unwrap(),
                "--plot",
                plot.to_str().unwrap(),
                "--plot-size",
                size,
            ],
        );
        assert!(ok, "{err}");
    }
    let img = image::open(&png).unwrap();
    assert_eq!((img.width(), img.height()), (800, 300));
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(
        text.contains("<svg") && text.contains("<polyline"),
        "{text}"
    );
    let gif = dir.join("p.gif");
    let (ok, _, err) = profile(
        &dir,
        &[
            "--from",
            "46.0,7.0",
            "--to",
            "46.5,8.5",
            "--out",
            csv.to_str().unwrap(),
            "--plot",
            gif.to_str().unwrap(),
        ],
    );
    assert!(!ok && err.contains(".png or .svg"), "{err}");
    assert!(!gif.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// What cannot be a profile is refused with what is wrong: antipodal ends, one place twice,
/// a latitude past a pole, one sample.
#[test]
fn impossible_profiles_are_refused() {
    let dir = temp_dir("bad");
    let csv = dir.join("bad.csv");
    let out = csv.to_str().unwrap();
    for (args, says) in [
        (vec!["--from", "10,20", "--to", "-10,-160"], "antipodal"),
        (vec!["--from", "10,20", "--to", "10,20"], "same place"),
        (vec!["--from", "95,20", "--to", "10,20"], "outside −90…90"),
        (vec!["--from", "10;20", "--to", "10,20"], "expected LAT,LON"),
        (
            vec!["--from", "10,20", "--to", "11,20", "--samples", "1"],
            "at least 2 samples",
        ),
    ] {
        let mut all = args.clone();
        all.extend(["--out", out]);
        let (ok, _, err) = profile(&dir, &all);
        assert!(!ok && err.contains(says), "{args:?}: {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The profile's two ends have the heights `globe probe` finds there: straight down from 2 m
/// above the ground, the centre pixel (the default terrain: the Earth with detail and water).
#[test]
fn the_ends_are_where_probe_finds_the_ground() {
    let dir = temp_dir("ends");
    let csv = dir.join("ends.csv");
    let (ok, _, err) = profile(
        &dir,
        &[
            "--from",
            "46.2,7.7",
            "--to",
            "46.6,8.1",
            "--samples",
            "11",
            "--out",
            csv.to_str().unwrap(),
        ],
    );
    assert!(ok, "{err}");
    let rows = rows(&csv);
    for row in [rows[0], rows[10]] {
        let run = Command::new(env!("CARGO_BIN_EXE_globe"))
            .args(["probe", &format!("--camera={},{},2,0,-90", row[1], row[2])])
            .args([
                "--pixel", "50,50", "--width", "101", "--height", "101", "--json",
            ])
            .output()
            .unwrap();
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
        let probed = v["height_m"].as_f64().unwrap();
        // The CSV keeps 4 decimals; the probe's hit lies within 1e-7° of the nadir.
        assert!(
            (probed - row[3]).abs() < 0.01,
            "{row:?}: probe says {probed} m"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
