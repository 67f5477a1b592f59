//! `globe-data synth` end to end: tiles from ETOPO5 in GTOPO30's shapes, read back by our
//! reader and by GDAL, equal to the source resampled at the pixel centres.

use std::path::Path;
use std::process::Command;

use globe::dem::EhdrRaster;
use globe::dem::open_raster;
use globe::dem::raster::BilinearSampler;

const ETOPO5: &str = "/usr/share/ferret-vis/data/etopo5.cdf";

fn require(path: &str) -> bool {
    if Path::new(path).exists() {
        return true;
    }
    assert!(
        std::env::var("GLOBE_REQUIRE_DATA").as_deref() != Ok("1"),
        "GLOBE_REQUIRE_DATA=1 but {path} is missing"
    );
    eprintln!("SKIPPED: {path} absent (apt-get install ferret-datasets)");
    false
}

#[test]
fn synth_writes_gtopo30_tiles_that_match_the_source() {
    if !require(ETOPO5) {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("tiles");
    let status = Command::new(env!("CARGO_BIN_EXE_globe-data"))
        .args([
            "synth",
            "--input",
            ETOPO5,
            "--spacing-arcsec",
            "600",
            "--tiles",
            "W020N40,W060S60",
            "--ocean",
            "keep",
            "--out",
        ])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let source = open_raster(Path::new(ETOPO5), None).unwrap();
    let mut sampler = BilinearSampler::new(source.as_ref());
    for (name, cols, rows) in [("W020N40", 240, 300), ("W060S60", 360, 180)] {
        let tile = EhdrRaster::open(&out.join(format!("{name}.HDR"))).unwrap();
        let g = tile.grid();
        assert_eq!((g.cols, g.rows), (cols, rows), "{name} shape");
        let gdal = Command::new("gdallocationinfo")
            .arg("-version")
            .output()
            .is_ok();
        for (r, c) in [
            (0, 0),
            (0, cols - 1),
            (rows - 1, 0),
            (rows - 1, cols - 1),
            (rows / 2, cols / 3),
            (7, 101),
        ] {
            let (lat, lon) = (g.lat_of_row(r as f64), g.lon_of_col(c as f64));
            let want = sampler.sample(lat, lon).unwrap().round();
            let got = tile.value(r, c).unwrap().unwrap() as f64;
            assert_eq!(got, want, "{name} ({r},{c}) at {lat},{lon}");
            if gdal {
                let o = Command::new("gdallocationinfo")
                    .args(["-valonly", "-geoloc"])
                    .arg(out.join(format!("{name}.DEM")))
                    .args([lon.to_string(), lat.to_string()])
                    .output()
                    .unwrap();
                let g: f64 = String::from_utf8_lossy(&o.stdout).trim().parse().unwrap();
                assert_eq!(g, got, "GDAL disagrees at {name} ({r},{c})");
            }
        }
    }
}
