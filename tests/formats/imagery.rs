//! Imagery GeoTIFFs (issue 36) against GDAL: files GDAL writes (RGB and RGBA, strips and
//! tiles, uncompressed, Deflate and LZW, one across the antimeridian), read by globe and
//! sampled at pixel centres, against `gdallocationinfo` at the same points: exact.

use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};

use crate::common::gdal::{Rng, gdal, gdal_ready};

use globe::imagery::{ImagerySource, encode};

/// `gdallocationinfo -valonly -geoloc` of every (lon, lat) in one run: the bands' values.
fn gdal_values(file: &Path, points: &[(f64, f64)], bands: usize) -> Vec<Vec<u8>> {
    let mut child = Command::new("gdallocationinfo")
        .args(["-valonly", "-geoloc"])
        .arg(file)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .expect("gdallocationinfo");
    let mut input = String::new();
    for (lon, lat) in points {
        input.push_str(&format!("{lon:.12} {lat:.12}\n"));
    }
    child
        .stdin
        .take()
        .unwrap()
        .write_all(input.as_bytes())
        .unwrap();
    let out = child.wait_with_output().unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    let values: Vec<u8> = text.lines().map(|l| l.trim().parse().unwrap()).collect();
    assert_eq!(
        values.len(),
        points.len() * bands,
        "gdallocationinfo: {text}"
    );
    values.chunks(bands).map(<[u8]>::to_vec).collect()
}

#[test]
fn imagery_geotiffs_agree_with_gdal_at_pixel_centres() {
    if !gdal_ready() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    // GDAL's own copy of a 300 × 150 window of the embedded Blue Marble (GDAL decodes it).
    let jpeg = dir.path().join("bmng.jpg");
    std::fs::write(&jpeg, globe::imagery::embedded::BMNG_JPEG).unwrap();
    let cases: [(&str, &[&str], &str); 5] = [
        ("rgb-strips.tif", &[], "-20 40 20 20"),
        (
            "rgb-tiles-deflate.tif",
            &["-co", "TILED=YES", "-co", "COMPRESS=DEFLATE"],
            "-20 40 20 20",
        ),
        ("rgb-lzw.tif", &["-co", "COMPRESS=LZW"], "100 -10 140 -30"),
        // Alpha from the red band: coverage that varies.
        (
            "rgba-tiles.tif",
            &[
                "-co",
                "TILED=YES",
                "-b",
                "1",
                "-b",
                "2",
                "-b",
                "3",
                "-b",
                "1",
                "-colorinterp",
                "red,green,blue,alpha",
            ],
            "0 60 40 40",
        ),
        // Across the antimeridian: 170° E to 190° E (170° W).
        ("rgb-antimeridian.tif", &[], "170 10 190 -10"),
    ];
    let mut rng = Rng(36);
    for (name, options, ullr) in cases {
        let out = dir.path().join(name);
        let mut args: Vec<String> = [
            "-q",
            "-of",
            "GTiff",
            "-a_srs",
            "EPSG:4326",
            "-srcwin",
            "2600",
            "700",
            "300",
            "150",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        args.extend(options.iter().map(|s| s.to_string()));
        args.push("-a_ullr".into());
        args.extend(ullr.split(' ').map(String::from));
        args.push(jpeg.display().to_string());
        args.push(out.display().to_string());
        gdal("gdal_translate", &args);
        let img = ImagerySource::parse(out.to_str().unwrap())
            .unwrap()
            .open()
            .unwrap()
            .unwrap();
        assert_eq!((img.width, img.height), (300, 150), "{name}");
        let bands = if name.starts_with("rgba") { 4 } else { 3 };
        let (dx, dy) = img.pixel_deg();
        let mut points = Vec::new();
        let mut pixels = Vec::new();
        for k in 0..400 {
            // Corners first, then random pixels.
            let (col, row) = match k {
                0 => (0, 0),
                1 => (299, 149),
                2 => (299, 0),
                3 => (0, 149),
                _ => (rng.below(300) as u32, rng.below(150) as u32),
            };
            let lon = img.extent.west + (col as f64 + 0.5) * dx;
            let lat = img.extent.north - (row as f64 + 0.5) * dy;
            points.push((lon, lat));
            pixels.push((col, row));
        }
        let want = gdal_values(&out, &points, bands);
        for (((lon, lat), (col, row)), w) in points.iter().zip(&pixels).zip(&want) {
            // globe asked at the longitude in [−180, 180) (the antimeridian file's east half
            // as 170° W and on).
            let lon_q = (lon + 180.0).rem_euclid(360.0) - 180.0;
            let got = encode(img.sample(*lat, lon_q).expect("inside"));
            assert_eq!(
                &got[..bands],
                &w[..],
                "{name}: pixel ({col}, {row}) at {lat}, {lon}"
            );
        }
    }
}

/// A projected GeoTIFF and a single-band one are refused, naming the file and what was
/// expected.
#[test]
fn projected_and_single_band_geotiffs_are_clear_errors() {
    if !gdal_ready() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let jpeg = dir.path().join("bmng.jpg");
    std::fs::write(&jpeg, globe::imagery::embedded::BMNG_JPEG).unwrap();
    let projected = dir.path().join("utm.tif");
    gdal(
        "gdal_translate",
        &[
            "-q",
            "-of",
            "GTiff",
            "-a_srs",
            "EPSG:32633",
            "-a_ullr",
            "500000",
            "5000000",
            "600000",
            "4900000",
            "-srcwin",
            "0",
            "0",
            "64",
            "64",
            jpeg.to_str().unwrap(),
            projected.to_str().unwrap(),
        ],
    );
    let e = ImagerySource::parse(projected.to_str().unwrap())
        .unwrap()
        .open()
        .unwrap_err();
    let text = format!("{e:#}");
    assert!(text.contains("utm.tif"), "{text}");
    let single = dir.path().join("grey.tif");
    gdal(
        "gdal_translate",
        &[
            "-q",
            "-of",
            "GTiff",
            "-b",
            "1",
            "-a_srs",
            "EPSG:4326",
            "-a_ullr",
            "0",
            "10",
            "10",
            "0",
            "-srcwin",
            "0",
            "0",
            "64",
            "64",
            jpeg.to_str().unwrap(),
            single.to_str().unwrap(),
        ],
    );
    let e = ImagerySource::parse(single.to_str().unwrap())
        .unwrap()
        .open()
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("grey.tif") && e.contains("expected RGB or RGBA"),
        "{e}"
    );
}
