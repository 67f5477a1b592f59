//! SRTM `.hgt` import (issue 15 items 3 and 4): tiles GDAL's SRTMHGT driver writes from
//! ETOPO5 (3″ and 1″), alone and as a folder mosaic, compared with `gdallocationinfo`; the
//! pyramid a folder imports into; and the bad inputs (wrong size, a name with no corner).
//!
//! Needs GDAL's command-line tools and ETOPO5: without them the GDAL tests are skipped, unless
//! `GLOBE_REQUIRE_DATA=1` makes that a failure.

use crate::common::gdal as gdal_common;

use std::path::{Path, PathBuf};

use gdal_common::{Rng, compare_with_gdal_nodata, etopo5, gdal, gdal_ready};
use globe::dem::pyramid::{Pyramid, PyramidBuilder};
use globe::dem::{DemError, HgtRaster, RasterMosaic, RasterSource};

/// Writes SRTM tiles with GDAL: a window of `n_lon` degrees × 1 from (`lat`, `lon`) resampled
/// from ETOPO5 at `side` samples per degree + 1, cut into one-degree tiles with `-srcwin` (so
/// neighbours share their edge column exactly), each named by its south-west corner.
fn srtm_tiles(dir: &Path, lat: i32, lon: i32, n_lon: i32, side: usize) -> Vec<PathBuf> {
    let per = (side - 1) as f64;
    let h = 0.5 / per;
    let wide = dir.join(format!("window-{lat}-{lon}.tif"));
    let cols = (side - 1) * n_lon as usize + 1;
    let (west, east) = (lon as f64, (lon + n_lon) as f64);
    let (south, north) = (lat as f64, (lat + 1) as f64);
    // ETOPO5 runs 0…360° east: ask for western longitudes there.
    let wrap = |x: f64| if x < 0.0 { x + 360.0 } else { x };
    gdal(
        "gdal_translate",
        &[
            "-q".to_string(),
            "-ot".into(),
            "Int16".into(),
            "-a_nodata".into(),
            "none".into(),
            "-r".into(),
            "bilinear".into(),
            "-outsize".into(),
            cols.to_string(),
            side.to_string(),
            "-projwin".into(),
            wrap(west).to_string(),
            north.to_string(),
            wrap(east).to_string(),
            south.to_string(),
            "-a_ullr".into(),
            (west - h).to_string(),
            (north + h).to_string(),
            (east + h).to_string(),
            (south - h).to_string(),
            "-a_srs".into(),
            "EPSG:4326".into(),
            etopo5().display().to_string(),
            wide.display().to_string(),
        ],
    );
    (0..n_lon)
        .map(|k| {
            let x = lon + k;
            let name = format!(
                "{}{:02}{}{:03}.hgt",
                if lat < 0 { 'S' } else { 'N' },
                lat.abs(),
                if x < 0 { 'W' } else { 'E' },
                x.abs()
            );
            let out = dir.join(name);
            gdal(
                "gdal_translate",
                &[
                    "-q".to_string(),
                    "-of".into(),
                    "SRTMHGT".into(),
                    "-srcwin".into(),
                    ((side - 1) * k as usize).to_string(),
                    "0".into(),
                    side.to_string(),
                    side.to_string(),
                    wide.display().to_string(),
                    out.display().to_string(),
                ],
            );
            out
        })
        .collect()
}

/// Writes `count` voids (−32768) at seeded positions of a tile, always including its corners.
fn punch_voids(file: &Path, rng: &mut Rng, count: usize) {
    let mut b = std::fs::read(file).unwrap();
    let n = ((b.len() / 2) as f64).sqrt() as usize;
    let mut at = vec![0, n - 1, n * (n - 1), n * n - 1];
    at.extend((0..count).map(|_| rng.below(n * n)));
    for i in at {
        b[2 * i..2 * i + 2].copy_from_slice(&i16::MIN.to_be_bytes());
    }
    std::fs::write(file, b).unwrap();
}

#[test]
fn gdal_written_hgt_tiles_agree_with_gdallocationinfo() {
    if !gdal_ready() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let mut rng = Rng(0x5254_4d48_4754_0015);
    // 3″ in the Alps, 1″ south of the equator and west of Greenwich (S and W in the name).
    let mut tiles = srtm_tiles(tmp.path(), 46, 10, 1, 1201);
    tiles.extend(srtm_tiles(tmp.path(), -1, -72, 1, 3601));
    for file in &tiles {
        punch_voids(file, &mut rng, 50);
        let tile = HgtRaster::open(file).unwrap();
        let a = compare_with_gdal_nodata(&tile, file, &mut rng, 1000, Some(-32768.0));
        eprintln!(
            "GDAL agreement {} ({}): {} points ({} pixel centres on the edges and corners), \
             max |difference| {} m, {} voids",
            file.file_name().unwrap().to_string_lossy(),
            tile.describe(),
            a.points,
            a.edge_points,
            a.max_diff,
            a.nodata
        );
        assert_eq!(a.max_diff, 0.0, "{}: globe and GDAL differ", file.display());
        assert_eq!(a.mismatched_nodata, 0, "{}: voids disagree", file.display());
        assert!(a.nodata >= 4, "the corners are voids");
    }
}

/// A folder of two neighbouring tiles: one raster sharing their edge column, equal to each
/// tile (as GDAL reads it) everywhere; imported into a pyramid whose level 0 is the mosaic.
#[test]
fn a_folder_of_hgt_tiles_is_one_mosaic_and_imports() {
    if !gdal_ready() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("srtm");
    std::fs::create_dir(&dir).unwrap();
    let tiles = srtm_tiles(&dir, 46, 10, 2, 1201);
    for f in std::fs::read_dir(&dir).unwrap() {
        let p = f.unwrap().path();
        if p.extension().is_none_or(|e| e != "hgt") {
            std::fs::remove_file(p).unwrap(); // the window and GDAL's .aux.xml
        }
    }
    let source = globe::dem::open_raster(&dir, None).unwrap();
    let g = source.grid();
    assert_eq!((g.cols, g.rows), (2401, 1201), "{}", source.describe());
    assert_eq!((g.lon0_deg, g.lat0_deg), (10.0, 47.0));
    let mut rng = Rng(11);
    let mut total = 0;
    for (k, file) in tiles.iter().enumerate() {
        // The mosaic against GDAL's reading of each tile, over that tile's extent.
        let tile = HgtRaster::open(file).unwrap();
        let a = compare_with_gdal_nodata(&TileOf(&*source, k * 1200), file, &mut rng, 300, None);
        assert_eq!(
            (a.max_diff, a.mismatched_nodata),
            (0.0, 0),
            "{}",
            file.display()
        );
        total += a.points;
        drop(tile);
    }
    eprintln!("GDAL agreement, 2-tile .hgt mosaic: {total} points, max |difference| 0 m");

    let out = tmp.path().join("srtm.globepyr");
    let mut seen = 0;
    PyramidBuilder::new()
        .tile_size(256)
        .on_progress(|p| seen = p.rows_done)
        .build(source.as_ref(), &out)
        .unwrap();
    assert_eq!(seen, g.rows, "progress reaches every row");
    let p = Pyramid::open(&out).unwrap();
    let mut row = vec![0f32; g.cols];
    for r in (0..g.rows).step_by(97) {
        source.read_row(r, &mut row).unwrap();
        for c in (0..g.cols).step_by(89) {
            let h = p
                .sample(g.lat_of_row(r as f64), g.lon_of_col(c as f64), 0)
                .unwrap();
            assert_eq!(h, row[c] as f64, "row {r}, column {c}");
        }
    }
}

/// The 1201 × 1201 window of a mosaic starting at column `.1`, as a raster of its own.
struct TileOf<'a>(&'a dyn RasterSource, usize);

impl RasterSource for TileOf<'_> {
    fn grid(&self) -> globe::dem::GeoGrid {
        let g = self.0.grid();
        globe::dem::GeoGrid {
            cols: 1201,
            lon0_deg: g.lon_of_col(self.1 as f64),
            ..g
        }
    }
    fn read_row(&self, row: usize, out: &mut [f32]) -> Result<(), DemError> {
        let mut full = vec![0f32; self.0.grid().cols];
        self.0.read_row(row, &mut full)?;
        out.copy_from_slice(&full[self.1..self.1 + 1201]);
        Ok(())
    }
    fn describe(&self) -> String {
        "window".into()
    }
}

#[test]
fn names_give_the_south_west_corner_case_insensitively() {
    let bytes = vec![0u8; 1201 * 1201 * 2];
    for (name, lat, lon) in [
        ("N46E010.hgt", 46.0, 10.0),
        ("s01w072.HGT", -1.0, -72.0),
        ("N00W180.SRTMGL3.hgt", 0.0, -180.0),
    ] {
        let t = HgtRaster::from_bytes(bytes.clone(), name).unwrap();
        let g = t.grid();
        assert_eq!((g.lat0_deg, g.lon0_deg), (lat + 1.0, lon), "{name}");
        assert_eq!(
            g.lat_of_row(1200.0),
            lat,
            "{name}: the last row is on the corner"
        );
        assert_eq!(g.dlon_deg, 1.0 / 1200.0);
    }
}

#[test]
fn wrong_size_or_name_is_a_clear_error() {
    let tmp = tempfile::tempdir().unwrap();
    let short = tmp.path().join("N46E010.hgt");
    std::fs::write(&short, vec![0u8; 1201 * 1201 * 2 - 2]).unwrap();
    let e = HgtRaster::open(&short).unwrap_err();
    let text = e.to_string();
    assert!(
        text.contains("N46E010.hgt") && text.contains("size") && text.contains("2884802"),
        "{text}"
    );
    for name in [
        "dem.hgt",
        "X46E010.hgt",
        "N4xE010.hgt",
        "N95E010.hgt",
        "N46Q010.hgt",
    ] {
        let path = tmp.path().join(name);
        std::fs::write(&path, vec![0u8; 1201 * 1201 * 2]).unwrap();
        let e = HgtRaster::open(&path).unwrap_err();
        let text = e.to_string();
        assert!(
            matches!(&e, DemError::Header { field, .. } if field == "file name")
                && text.contains(name)
                && text.contains("south-west corner"),
            "{name}: {text}"
        );
    }
    // In a folder, the bad tile is named.
    let dir = tmp.path().join("mixed");
    std::fs::create_dir(&dir).unwrap();
    std::fs::write(dir.join("N46E010.hgt"), vec![0u8; 1201 * 1201 * 2]).unwrap();
    std::fs::write(dir.join("N46E011.hgt"), vec![0u8; 1000]).unwrap();
    let e = RasterMosaic::open_dir(&dir).unwrap_err().to_string();
    assert!(e.contains("N46E011.hgt") && e.contains("size"), "{e}");
    // Mixed resolutions are refused, naming both.
    std::fs::write(dir.join("N46E011.hgt"), vec![0u8; 3601 * 3601 * 2]).unwrap();
    let e = RasterMosaic::open_dir(&dir).unwrap_err().to_string();
    assert!(
        e.contains("N46E011.hgt") && e.contains("N46E010.hgt"),
        "{e}"
    );
}

#[test]
fn voids_read_as_no_data() {
    let mut bytes = vec![0u8; 1201 * 1201 * 2];
    bytes[0..2].copy_from_slice(&i16::MIN.to_be_bytes());
    bytes[2..4].copy_from_slice(&(-12i16).to_be_bytes());
    bytes[4..6].copy_from_slice(&8848i16.to_be_bytes());
    let t = HgtRaster::from_bytes(bytes, "N27E086.hgt").unwrap();
    let mut row = vec![0f32; 1201];
    t.read_row(0, &mut row).unwrap();
    assert!(row[0].is_nan());
    assert_eq!((row[1], row[2]), (-12.0, 8848.0));
}

/// `globe render --dem FOLDER` takes a folder of `.hgt` tiles as a user would: imported into
/// the cache (here a temporary one) and rendered. Needs an adapter (a software one will do).
#[test]
fn globe_dem_takes_a_folder_of_hgt_tiles() {
    if !gdal_ready() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("srtm");
    std::fs::create_dir(&dir).unwrap();
    srtm_tiles(&dir, 46, 10, 1, 1201);
    for f in std::fs::read_dir(&dir).unwrap() {
        let p = f.unwrap().path();
        if p.extension().is_none_or(|e| e != "hgt") {
            std::fs::remove_file(p).unwrap();
        }
    }
    let cache = tmp.path().join("cache");
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_globe"))
        .args([
            "render", "--scene", "space", "--width", "48", "--height", "27",
        ])
        .arg("--dem")
        .arg(&dir)
        .arg("--out")
        .arg(tmp.path().join("x.png"))
        .env("XDG_CACHE_HOME", &cache)
        .output()
        .expect("globe runs");
    let stderr = String::from_utf8_lossy(&run.stderr);
    if !run.status.success() && stderr.contains("no graphics adapter") {
        assert!(
            std::env::var("GLOBE_REQUIRE_GPU").as_deref() != Ok("1"),
            "GLOBE_REQUIRE_GPU=1 but no adapter: {stderr}"
        );
        eprintln!("SKIPPED: no graphics adapter");
        return;
    }
    assert!(run.status.success(), "{stderr}");
    let imported: Vec<_> = std::fs::read_dir(cache.join("globe"))
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.path().extension().is_some_and(|x| x == "globepyr"))
        .collect();
    assert_eq!(imported.len(), 1, "one pyramid imported into the cache");
    let p = Pyramid::open(imported[0].path()).unwrap();
    assert_eq!(
        p.sample(46.5, 10.5, 0),
        HgtRaster::open(dir.join("N46E010.hgt"))
            .map(|t| {
                let mut row = vec![0f32; 1201];
                t.read_row(600, &mut row).unwrap();
                row[600] as f64
            })
            .ok()
    );
}
