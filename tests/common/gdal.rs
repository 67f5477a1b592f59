//! What the GDAL cross-checks of the GeoTIFF and SRTM readers share (`tests/formats/geotiff.rs`,
//! `tests/formats/hgt.rs`): the gate on GDAL's tools and ETOPO5, running GDAL, and the comparison of a
//! raster with `gdallocationinfo` at its corners, along its edges and at seeded random points.

#![allow(dead_code)]

use std::path::{Path, PathBuf};

use globe::dem::RasterSource;

/// ETOPO5 (5′ global relief, netCDF), from Debian's `ferret-datasets`.
pub fn etopo5() -> PathBuf {
    PathBuf::from("/usr/share/ferret-vis/data/etopo5.cdf")
}

fn tool_runs(program: &str) -> bool {
    std::process::Command::new(program)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// Whether GDAL's tools and ETOPO5 are here; without them the test is skipped, unless
/// `GLOBE_REQUIRE_DATA=1`, which makes their absence a failure.
pub fn gdal_ready() -> bool {
    let missing: Vec<String> = ["gdal_translate", "gdallocationinfo", "gdalwarp"]
        .into_iter()
        .filter(|p| !tool_runs(p))
        .map(String::from)
        .chain((!etopo5().exists()).then(|| etopo5().display().to_string()))
        .collect();
    if missing.is_empty() {
        return true;
    }
    assert!(
        std::env::var("GLOBE_REQUIRE_DATA").as_deref() != Ok("1"),
        "GLOBE_REQUIRE_DATA=1 but {} missing (apt-get install gdal-bin ferret-datasets)",
        missing.join(", ")
    );
    eprintln!(
        "SKIPPED: {} missing (apt-get install gdal-bin ferret-datasets)",
        missing.join(", ")
    );
    false
}

/// Runs a GDAL tool, failing the test with its message if it fails.
pub fn gdal(program: &str, args: &[impl AsRef<std::ffi::OsStr>]) {
    let out = std::process::Command::new(program)
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("{program}: {e}"));
    assert!(
        out.status.success(),
        "{program} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A seeded generator (splitmix64), so every run probes the same points.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }

    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// How globe's values compared with GDAL's.
#[derive(Clone, Debug, Default)]
pub struct Agreement {
    pub points: usize,
    /// Of which pixel centres on the corners and edges.
    pub edge_points: usize,
    /// Largest |globe − GDAL| where both have a value, metres, in f32 (GDAL's text rounded to
    /// the nearest f32; integers compare exactly).
    pub max_diff: f64,
    /// Points where both say no data.
    pub nodata: usize,
    /// Points where one says no data and the other does not, or GDAL is off the raster.
    pub mismatched_nodata: usize,
}

impl Agreement {
    pub fn add(&mut self, o: &Agreement) {
        self.points += o.points;
        self.edge_points += o.edge_points;
        self.max_diff = self.max_diff.max(o.max_diff);
        self.nodata += o.nodata;
        self.mismatched_nodata += o.mismatched_nodata;
    }
}

/// Values `gdallocationinfo -valonly -geoloc` reports at (lat, lon) points, in one run.
pub fn gdal_values(file: &Path, points: &[(f64, f64)]) -> Vec<String> {
    use std::io::Write;
    let mut child = std::process::Command::new("gdallocationinfo")
        .args(["-valonly", "-geoloc"])
        .arg(file)
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let input: String = points
        .iter()
        .map(|(lat, lon)| format!("{lon} {lat}\n"))
        .collect();
    let mut stdin = child.stdin.take().unwrap();
    let writer = std::thread::spawn(move || stdin.write_all(input.as_bytes()));
    let out = child.wait_with_output().unwrap();
    writer.join().unwrap().unwrap();
    assert!(
        out.status.success(),
        "gdallocationinfo failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| l.trim().to_string())
        .collect()
}

/// Compares `source` (read in full: test rasters are small) with GDAL's reading of `file` at
/// every corner and edge pixel centre, `random` random pixel centres and `random` random points
/// inside pixels (never within 0.1 pixel of an edge, where rounding may legitimately differ).
/// `gdal_nodata` is the value GDAL prints where globe has no data.
pub fn compare_with_gdal_nodata(
    source: &dyn RasterSource,
    file: &Path,
    rng: &mut Rng,
    random: usize,
    gdal_nodata: Option<f64>,
) -> Agreement {
    let g = source.grid();
    let mut values = vec![0f32; g.cols * g.rows];
    for (r, row) in values.chunks_exact_mut(g.cols).enumerate() {
        source.read_row(r, row).unwrap();
    }
    // (row, col) in pixel units, centres at integers.
    let mut rc: Vec<(f64, f64)> = Vec::new();
    let (last_r, last_c) = ((g.rows - 1) as f64, (g.cols - 1) as f64);
    for c in 0..g.cols {
        rc.push((0.0, c as f64));
        rc.push((last_r, c as f64));
    }
    for r in 1..g.rows - 1 {
        rc.push((r as f64, 0.0));
        rc.push((r as f64, last_c));
    }
    let edge_points = rc.len();
    for _ in 0..random {
        rc.push((rng.below(g.rows) as f64, rng.below(g.cols) as f64));
        rc.push((
            rng.below(g.rows) as f64 + rng.uniform(-0.4, 0.4),
            rng.below(g.cols) as f64 + rng.uniform(-0.4, 0.4),
        ));
    }
    let points: Vec<(f64, f64)> = rc
        .iter()
        .map(|&(r, c)| (g.lat_of_row(r), g.lon_of_col(c)))
        .collect();
    let gdal = gdal_values(file, &points);
    assert_eq!(
        gdal.len(),
        points.len(),
        "{}: one line per point",
        file.display()
    );
    let mut a = Agreement {
        points: points.len(),
        edge_points,
        ..Agreement::default()
    };
    for ((&(r, c), &(lat, lon)), text) in rc.iter().zip(&points).zip(&gdal) {
        let (row, col) = (r.round() as usize, c.round() as usize);
        let ours = values[row * g.cols + col];
        let Ok(theirs) = text.parse::<f64>() else {
            eprintln!(
                "{}: GDAL gives {text:?} at lat {lat}, lon {lon} (pixel {row}, {col})",
                file.display()
            );
            a.mismatched_nodata += 1;
            continue;
        };
        let gdal_says_nodata =
            gdal_nodata.is_some_and(|nd| theirs == nd || (nd.is_nan() && theirs.is_nan()));
        match (ours.is_nan(), gdal_says_nodata) {
            (true, true) => a.nodata += 1,
            (false, false) => {
                // GDAL prints 15 significant digits: a Float32 value's text read back to f32
                // is that value exactly (the difference of integers is exact anyway).
                let d = (ours - theirs as f32).abs() as f64;
                if d > a.max_diff {
                    eprintln!(
                        "{}: at lat {lat}, lon {lon} (pixel {row}, {col}) globe {ours}, GDAL {theirs}",
                        file.display()
                    );
                }
                a.max_diff = a.max_diff.max(d);
            }
            _ => {
                eprintln!(
                    "{}: at lat {lat}, lon {lon} (pixel {row}, {col}) globe {ours}, GDAL {theirs}",
                    file.display()
                );
                a.mismatched_nodata += 1;
            }
        }
    }
    a
}

/// [`compare_with_gdal_nodata`] for a GeoTIFF, whose no-data value GDAL prints.
pub fn compare_with_gdal(
    raster: &globe::dem::GeoTiffRaster,
    file: &Path,
    rng: &mut Rng,
    random: usize,
) -> Agreement {
    compare_with_gdal_nodata(raster, file, rng, random, raster.nodata())
}
