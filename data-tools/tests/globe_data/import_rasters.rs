//! `globe-data import` and `info` on the rasters people hold (issue 15 items 3 and 4): a folder
//! of SRTM `.hgt` tiles and a COG written by GDAL from ETOPO5 import, and `sample` then gives
//! GDAL's value at pixel centres; a corrupt GeoTIFF fails with an error naming the file and
//! leaves neither the pyramid nor its `.partial` behind.

use std::path::Path;
use std::process::Command;

const ETOPO5: &str = "/usr/share/ferret-vis/data/etopo5.cdf";

fn available() -> bool {
    let gdal = Command::new("gdal_translate")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if gdal && Path::new(ETOPO5).exists() {
        return true;
    }
    assert!(
        std::env::var("GLOBE_REQUIRE_DATA").as_deref() != Ok("1"),
        "GLOBE_REQUIRE_DATA=1 but gdal-bin or ferret-datasets is missing"
    );
    eprintln!("SKIPPED: needs gdal_translate (gdal-bin) and {ETOPO5} (ferret-datasets)");
    false
}

fn run(program: &str, args: &[&str]) -> std::process::Output {
    Command::new(program).args(args).output().unwrap()
}

fn ok(program: &str, args: &[&str]) -> String {
    let out = run(program, args);
    assert!(
        out.status.success(),
        "{program} {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

const GLOBE_DATA: &str = env!("CARGO_BIN_EXE_globe-data");

#[test]
fn hgt_folder_and_cog_import_and_sample_like_gdal() {
    if !available() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let p = |n: &str| tmp.path().join(n).display().to_string();
    // Two 3″ tiles sharing their edge column, cut from one resampled window.
    let h = 0.5 / 1200.0;
    let ullr = [10.0 - h, 47.0 + h, 12.0 + h, 46.0 - h].map(|v| v.to_string());
    let wide = p("wide.tif");
    ok(
        "gdal_translate",
        &[
            "-q",
            "-ot",
            "Int16",
            "-a_nodata",
            "none",
            "-r",
            "bilinear",
            "-outsize",
            "2401",
            "1201",
            "-projwin",
            "10",
            "47",
            "12",
            "46",
            "-a_srs",
            "EPSG:4326",
            "-a_ullr",
            &ullr[0],
            &ullr[1],
            &ullr[2],
            &ullr[3],
            ETOPO5,
            &wide,
        ],
    );
    std::fs::create_dir(p("srtm")).unwrap();
    for (k, name) in [(0, "N46E010.hgt"), (1200, "n46e011.hgt")] {
        let out = p(&format!("srtm/{name}"));
        let x = k.to_string();
        ok(
            "gdal_translate",
            &[
                "-q", "-of", "SRTMHGT", "-srcwin", &x, "0", "1201", "1201", &wide, &out,
            ],
        );
        std::fs::remove_file(format!("{out}.aux.xml")).ok();
    }
    let info = ok(GLOBE_DATA, &["info", &p("srtm")]);
    assert!(info.contains("2401 × 1201"), "{info}");
    let pyr = p("srtm.globepyr");
    ok(
        GLOBE_DATA,
        &["import", "--input", &p("srtm"), "--out", &pyr],
    );
    ok(GLOBE_DATA, &["verify", &pyr]);
    // Pixel centres: the sampled height is the stored one, as GDAL reads it from the tiles.
    for (lat, lon) in [(47.0, 10.0), (46.0, 12.0), (46.5, 11.0), (46.25, 10.75)] {
        let ours: f64 = ok(
            GLOBE_DATA,
            &["sample", &pyr, &lat.to_string(), &lon.to_string()],
        )
        .trim()
        .parse()
        .unwrap();
        let tile = if lon < 11.0 {
            "N46E010.hgt"
        } else {
            "n46e011.hgt"
        };
        let gdal: f64 = ok(
            "gdallocationinfo",
            &[
                "-valonly",
                "-geoloc",
                &p(&format!("srtm/{tile}")),
                &lon.to_string(),
                &lat.to_string(),
            ],
        )
        .trim()
        .parse()
        .unwrap();
        assert_eq!(ours, gdal, "at {lat}, {lon}");
    }

    // A COG (tiled, with overviews, which are ignored).
    let cog = p("alps.tif");
    ok(
        "gdal_translate",
        &[
            "-q",
            "-of",
            "COG",
            "-ot",
            "Int16",
            "-co",
            "COMPRESS=DEFLATE",
            "-co",
            "BLOCKSIZE=64",
            "-outsize",
            "400",
            "200",
            "-projwin",
            "8",
            "47",
            "12",
            "45",
            ETOPO5,
            &cog,
        ],
    );
    let info = ok(GLOBE_DATA, &["info", &cog]);
    assert!(
        info.contains("GeoTIFF") && info.contains("overviews ignored"),
        "{info}"
    );
    ok(
        GLOBE_DATA,
        &["import", "--input", &cog, "--out", &p("alps.globepyr")],
    );
}

#[test]
fn a_corrupt_geotiff_fails_the_import_and_leaves_nothing() {
    if !available() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let p = |n: &str| tmp.path().join(n).display().to_string();
    let good = p("good.tif");
    ok(
        "gdal_translate",
        &[
            "-q",
            "-ot",
            "Int16",
            "-co",
            "COMPRESS=DEFLATE",
            "-co",
            "BLOCKYSIZE=8",
            "-outsize",
            "200",
            "100",
            "-projwin",
            "8",
            "47",
            "12",
            "45",
            ETOPO5,
            &good,
        ],
    );
    let mut bytes = std::fs::read(&good).unwrap();
    let n = bytes.len();
    for b in &mut bytes[n - 80..n - 2] {
        *b = 0x5A; // the last strip's stream, garbled: found only when decoded
    }
    let bad = p("bad.tif");
    std::fs::write(&bad, bytes).unwrap();
    let out = p("bad.globepyr");
    let o = run(GLOBE_DATA, &["import", "--input", &bad, "--out", &out]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "the import must fail");
    assert!(err.contains("bad.tif") && err.contains("strip"), "{err}");
    assert!(!Path::new(&out).exists(), "no pyramid");
    assert!(
        !Path::new(&format!("{out}.partial")).exists(),
        "no partial file"
    );
}
