//! Tests of the tiled elevation pyramid (`globe::dem::pyramid`): built from synthetic in-memory
//! rasters with closed-form heights, global and regional, sizes that are not multiples of the
//! tile size.
//!
//! `cargo test --test formats -- pyramid:: --nocapture` prints the measurements (build timing, peak
//! memory). `GLOBE_PYRAMID_BIG=43200x21600 cargo test --release --test formats pyramid::memory_bound --
//! --nocapture` runs the memory test at another size (default 8640 × 4320, a 2.5′ global grid).

use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::time::Instant;

use globe::dem::pyramid::{
    BuildProgress, BuildReport, NanPolicy, Plane, Pyramid, PyramidBuilder, Region,
};
use globe::dem::{DemError, GeoGrid, RasterSource};

// ---------------------------------------------------------------------------------------------
// Synthetic sources

/// A few sines and a sharp peak near Everest, metres.
fn terrain(lat: f64, lon: f64) -> f64 {
    let (p, l) = (lat.to_radians(), lon.to_radians());
    let waves = 1200.0 * (2.0 * p).sin() * (3.0 * l).cos()
        + 300.0 * (7.0 * p + 1.0).sin() * (5.0 * l).sin()
        + 40.0 * (29.0 * p).sin() * (31.0 * l).cos();
    waves + peak(lat, lon)
}

fn peak(lat: f64, lon: f64) -> f64 {
    let (p0, l0) = (27.95f64.to_radians(), 86.9f64.to_radians());
    let dp = lat.to_radians() - p0;
    let dl = (lon.to_radians() - l0 + PI).rem_euclid(2.0 * PI) - PI;
    let d2 = dp * dp + (p0.cos() * dl).powi(2);
    3000.0 * (-d2 / (0.01f64 * 0.01)).exp()
}

type HeightFn = Box<dyn Fn(usize, usize, f64, f64) -> f32 + Send + Sync>;

/// A raster whose pixel (row, col) is `f(row, col, lat, lon)`.
struct Synth {
    grid: GeoGrid,
    f: HeightFn,
}

impl Synth {
    fn new(
        grid: GeoGrid,
        f: impl Fn(usize, usize, f64, f64) -> f32 + Send + Sync + 'static,
    ) -> Self {
        Self {
            grid,
            f: Box::new(f),
        }
    }
    fn value(&self, row: usize, col: usize) -> f32 {
        let g = &self.grid;
        (self.f)(row, col, g.lat_of_row(row as f64), g.lon_of_col(col as f64))
    }
}

impl RasterSource for Synth {
    fn grid(&self) -> GeoGrid {
        self.grid
    }
    fn read_row(&self, row: usize, out: &mut [f32]) -> Result<(), DemError> {
        for (c, v) in out.iter_mut().enumerate() {
            *v = self.value(row, c);
        }
        Ok(())
    }
    fn describe(&self) -> String {
        format!("synthetic {} × {}", self.grid.cols, self.grid.rows)
    }
}

/// 333 × 217 pixels of 30″ north of Lake Garda (regional, odd sizes).
fn regional_grid() -> GeoGrid {
    let d = 1.0 / 120.0;
    GeoGrid {
        cols: 333,
        rows: 217,
        lon0_deg: 9.0 + 0.5 * d,
        lat0_deg: 47.0 - 0.5 * d,
        dlon_deg: d,
        dlat_deg: d,
    }
}

fn tmp_path(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("pyramid-tests");
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir.join(name)
}

fn build(src: &dyn RasterSource, name: &str, tile: usize) -> (PathBuf, BuildReport) {
    let path = tmp_path(name);
    let report = PyramidBuilder::new()
        .tile_size(tile)
        .build(src, &path)
        .unwrap_or_else(|e| panic!("build {name}: {e}"));
    (path, report)
}

/// Deterministic xorshift64* in [0, 1).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.next()
    }
}

fn expected_level_count(cols: usize, rows: usize, t: usize) -> usize {
    let (mut c, mut r, mut n) = (cols, rows, 1);
    while c.div_ceil(t) > 1 || r.div_ceil(t) > 1 {
        c = c.div_ceil(2);
        r = r.div_ceil(2);
        n += 1;
    }
    n
}

/// Every pixel of every level: min ≤ avg ≤ max, and the padding of edge tiles repeats the edge.
fn check_planes(pyr: &Pyramid) {
    for (level, l) in pyr.levels().iter().enumerate() {
        for ty in 0..l.tiles_y {
            for tx in 0..l.tiles_x {
                let tile = pyr.tile_verified(level, tx, ty).expect("tile");
                let t = tile.tile_size;
                for y in 0..t {
                    for x in 0..t {
                        let i = y * t + x;
                        assert!(
                            tile.min[i] <= tile.avg[i] && tile.avg[i] <= tile.max[i],
                            "level {level} tile ({tx}, {ty}) sample ({x}, {y}): min {} avg {} max {}",
                            tile.min[i],
                            tile.avg[i],
                            tile.max[i]
                        );
                        let (vx, vy) = (x.min(tile.valid_cols - 1), y.min(tile.valid_rows - 1));
                        let j = vy * t + vx;
                        assert_eq!(
                            (tile.avg[i], tile.min[i], tile.max[i]),
                            (tile.avg[j], tile.min[j], tile.max[j]),
                            "padding repeats the edge"
                        );
                    }
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Structure and exact round trip

#[test]
fn pyramid_can_be_shared_across_threads() {
    fn send_sync<T: Send + Sync>() {}
    send_sync::<Pyramid>();
}

#[test]
fn global_odd_sizes_levels_and_exact_pixel_centres() {
    let grid = GeoGrid::global(1000, 499);
    let src = Synth::new(grid, |_, _, lat, lon| terrain(lat, lon) as f32);
    let t = 64;
    let (path, report) = build(&src, "global.gpyr", t);
    let pyr = Pyramid::open(&path).expect("open");
    println!("{}", pyr.info());
    assert_eq!(pyr.level_count(), expected_level_count(1000, 499, t));
    assert_eq!(pyr.level_count(), 5);
    assert_eq!(report.levels, 5);
    let last = pyr.levels().last().expect("levels");
    assert_eq!((last.tiles_x, last.tiles_y), (1, 1));
    assert!(pyr.levels()[pyr.level_count() - 2].tiles_x > 1);
    assert!(pyr.wraps());
    for (k, l) in pyr.levels().iter().enumerate() {
        // Every level covers the circle exactly.
        assert!(
            (l.cols as f64 * l.grid.dlon_deg - 360.0).abs() < 1e-9,
            "level {k}"
        );
        if k > 0 {
            let f = &pyr.levels()[k - 1];
            assert_eq!((l.cols, l.rows), (f.cols.div_ceil(2), f.rows.div_ceil(2)));
        }
    }
    // Level 0: every pixel centre returns the source value rounded to the metre, exactly.
    let mut row = vec![0.0f32; grid.cols];
    for r in 0..grid.rows {
        src.read_row(r, &mut row).expect("row");
        for (c, &v) in row.iter().enumerate() {
            let (lat, lon) = (grid.lat_of_row(r as f64), grid.lon_of_col(c as f64));
            let got = pyr.sample(lat, lon, 0).expect("covered");
            assert_eq!(got, (v as f64).round(), "centre ({r}, {c})");
            // The same centre one turn of longitude away.
            if c % 97 == 0 {
                assert_eq!(pyr.sample(lat, lon + 360.0, 0), Some(got));
                assert_eq!(pyr.sample(lat, lon - 720.0, 0), Some(got));
            }
        }
    }
    // Every level: centres return the stored avg exactly.
    for level in 1..pyr.level_count() {
        let g = pyr.grid(level);
        for r in (0..g.rows).step_by(3) {
            for c in (0..g.cols).step_by(5) {
                let stored = pyr.pixel_m(level, Plane::Avg, r, c).expect("pixel");
                let got = pyr.sample(g.lat_of_row(r as f64), g.lon_of_col(c as f64), level);
                assert_eq!(got, Some(stored), "level {level} ({r}, {c})");
            }
        }
    }
    // Wrap: halfway between the last and the first column is their mean.
    let g = pyr.grid(0);
    let lat = g.lat_of_row(100.0);
    let west = pyr.pixel_m(0, Plane::Avg, 100, 0).expect("pixel");
    let east = pyr.pixel_m(0, Plane::Avg, 100, g.cols - 1).expect("pixel");
    let mid = pyr.sample(lat, 180.0, 0).expect("covered");
    assert!(
        (mid - 0.5 * (west + east)).abs() < 1e-9,
        "{mid} vs {west}, {east}"
    );
    // Poles clamp to the first/last row.
    let pole = pyr.sample(90.0, 10.0, 0).expect("covered");
    let row0 = pyr.sample(g.lat_of_row(0.0), 10.0, 0).expect("covered");
    assert_eq!(pole, row0);
    assert_eq!(pyr.sample(90.5, 10.0, 0), None, "not a latitude");
    check_planes(&pyr);
    pyr.verify().expect("verify");
    std::fs::remove_file(&path).ok();
}

#[test]
fn regional_odd_sizes_integer_source_round_trips_and_says_where_it_has_no_data() {
    let grid = regional_grid();
    // Integer metres, like GTOPO30: level 0 must hold them exactly.
    let src = Synth::new(grid, |_, _, lat, lon| {
        (terrain(lat * 40.0, lon * 40.0) + 1500.0).round() as f32
    });
    let t = 32;
    let (path, _) = build(&src, "regional.gpyr", t);
    let pyr = Pyramid::open(&path).expect("open");
    println!("{}", pyr.info());
    assert!(!pyr.wraps());
    assert_eq!(pyr.level_count(), expected_level_count(333, 217, t));
    assert_eq!(pyr.level_count(), 5);
    let mut row = vec![0.0f32; grid.cols];
    for r in 0..grid.rows {
        src.read_row(r, &mut row).expect("row");
        for (c, &v) in row.iter().enumerate() {
            let got = pyr.sample(grid.lat_of_row(r as f64), grid.lon_of_col(c as f64), 0);
            assert_eq!(got, Some(v as f64), "centre ({r}, {c})");
        }
    }
    // Extents: 9° … 9.25° (+ 333/120), 47° − 217/120 … 47°.
    let e = pyr.extents();
    assert!((e.west_deg - 9.0).abs() < 1e-12 && (e.north_deg - 47.0).abs() < 1e-12);
    for level in 0..pyr.level_count() {
        assert_eq!(pyr.sample(46.0, 8.99, level), None, "west of the data");
        assert_eq!(pyr.sample(47.01, 10.0, level), None, "north of the data");
        assert_eq!(pyr.sample(45.0, 10.0, level), None, "south of the data");
        assert_eq!(pyr.sample(46.0, 11.8, level), None, "east of the data");
        assert_eq!(pyr.sample(46.0, 190.0, level), None, "far away");
        // Inside, up to the very edge (clamped to the edge pixels).
        assert!(pyr.sample(46.0, 9.0, level).is_some());
        assert!(pyr.sample(47.0, 9.5, level).is_some());
        assert!(
            pyr.sample(46.0, 369.5, level).is_some(),
            "longitude taken modulo 360"
        );
    }
    assert!(!pyr.covers(46.0, 8.9));
    assert!(pyr.covers(46.0, 9.1));
    // Bounds of a box that sticks out of the data: marked incomplete; inside: complete.
    let partial = Region::Box {
        south_deg: 46.0,
        north_deg: 46.5,
        west_deg: 8.5,
        east_deg: 9.5,
    };
    let b = pyr.min_max_in(partial, 1).expect("overlaps the data");
    assert!(!b.complete && b.min_m <= b.max_m);
    let inside = Region::Box {
        south_deg: 46.0,
        north_deg: 46.5,
        west_deg: 9.5,
        east_deg: 10.5,
    };
    assert!(pyr.min_max_in(inside, 1).expect("inside").complete);
    let away = Region::Box {
        south_deg: 10.0,
        north_deg: 20.0,
        west_deg: 9.5,
        east_deg: 10.5,
    };
    assert_eq!(pyr.min_max_in(away, 0), None);
    check_planes(&pyr);
    pyr.verify().expect("verify");
    std::fs::remove_file(&path).ok();
}

// ---------------------------------------------------------------------------------------------
// Bounds

/// The pixel of a level whose footprint contains (lat, lon).
fn containing_pixel(pyr: &Pyramid, level: usize, lat: f64, lon: f64) -> (usize, usize) {
    let g = pyr.grid(level);
    let (r, c) = g.row_col_of(lat, lon);
    let r = r.round().clamp(0.0, (g.rows - 1) as f64) as usize;
    let c = if pyr.wraps() {
        (c.round() as i64).rem_euclid(g.cols as i64) as usize
    } else {
        c.round().clamp(0.0, (g.cols - 1) as f64) as usize
    };
    (r, c)
}

/// A random point at angular distance ≤ `radius` from (lat, lon).
fn point_in_cap(rng: &mut Rng, lat: f64, lon: f64, radius: f64) -> (f64, f64) {
    let d = radius * rng.next().sqrt();
    let bearing = rng.range(0.0, 2.0 * PI);
    let (p1, l1) = (lat.to_radians(), lon.to_radians());
    let p2 = (p1.sin() * d.cos() + p1.cos() * d.sin() * bearing.cos()).asin();
    let l2 = l1 + (bearing.sin() * d.sin() * p1.cos()).atan2(d.cos() - p1.sin() * p2.sin());
    (p2.to_degrees(), l2.to_degrees())
}

fn check_bounds_property(pyr: &Pyramid, seed: u64, points: usize) {
    let e = pyr.extents();
    let mut rng = Rng(seed);
    let eps = 1e-9;
    for _ in 0..points {
        let lat = rng.range(e.south_deg.max(-90.0), e.north_deg.min(90.0));
        let lon = rng.range(e.west_deg, e.east_deg);
        let h0 = pyr.sample(lat, lon, 0).expect("covered");
        for m in 0..pyr.level_count() {
            // The level-0 surface lies within the bounds of the pixel containing the point.
            let (r, c) = containing_pixel(pyr, m, lat, lon);
            let lo = pyr.pixel_m(m, Plane::Min, r, c).expect("pixel");
            let hi = pyr.pixel_m(m, Plane::Max, r, c).expect("pixel");
            assert!(
                lo - eps <= h0 && h0 <= hi + eps,
                "level {m} pixel ({r}, {c}) [{lo}, {hi}] misses the level-0 height {h0} at ({lat}, {lon})"
            );
            // min_max_in over a small box bounds every level ≤ m at the point.
            let boxed = Region::Box {
                south_deg: lat - 0.01,
                north_deg: lat + 0.01,
                west_deg: lon - 0.01,
                east_deg: lon + 0.01,
            };
            let b = pyr.min_max_in(boxed, m).expect("covered");
            for k in 0..=m {
                let hk = pyr.sample(lat, lon, k).expect("covered");
                assert!(
                    b.min_m - eps <= hk && hk <= b.max_m + eps,
                    "min_max_in(level {m}) = [{}, {}] misses level {k}'s {hk} at ({lat}, {lon})",
                    b.min_m,
                    b.max_m
                );
            }
        }
        // A cap: bounds at a level hold for the level-0 surface at points inside it.
        let radius = rng.range(1e-4, 0.05);
        let m = (rng.next() * pyr.level_count() as f64) as usize;
        if let Some(b) = pyr.min_max_in(
            Region::Cap {
                lat_deg: lat,
                lon_deg: lon,
                radius_rad: radius,
            },
            m,
        ) {
            for _ in 0..8 {
                let (qlat, qlon) = point_in_cap(&mut rng, lat, lon, radius);
                if let Some(h) = pyr.sample(qlat, qlon, 0) {
                    assert!(
                        b.min_m - eps <= h && h <= b.max_m + eps,
                        "cap at ({lat}, {lon}) r {radius} level {m}: [{}, {}] misses {h} at ({qlat}, {qlon})",
                        b.min_m,
                        b.max_m
                    );
                }
            }
        }
    }
}

/// Coarse min/max bound the fine min/max of every fine pixel under the coarse footprint.
fn check_footprints(pyr: &Pyramid, seed: u64) {
    let mut rng = Rng(seed);
    for m in 1..pyr.level_count() {
        let (f, c) = (pyr.levels()[m - 1], pyr.levels()[m]);
        let n = 4000.min(c.cols * c.rows);
        for i in 0..n {
            let (cr, cc) = if n == c.cols * c.rows {
                (i / c.cols, i % c.cols)
            } else {
                (
                    (rng.next() * c.rows as f64) as usize,
                    (rng.next() * c.cols as f64) as usize,
                )
            };
            let lo = pyr.pixel_m(m, Plane::Min, cr, cc).expect("pixel");
            let hi = pyr.pixel_m(m, Plane::Max, cr, cc).expect("pixel");
            let rows = cr * f.rows / c.rows..((cr + 1) * f.rows).div_ceil(c.rows);
            let cols = cc * f.cols / c.cols..((cc + 1) * f.cols).div_ceil(c.cols);
            for fr in rows {
                for fc in cols.clone() {
                    let flo = pyr.pixel_m(m - 1, Plane::Min, fr, fc).expect("pixel");
                    let fhi = pyr.pixel_m(m - 1, Plane::Max, fr, fc).expect("pixel");
                    let favg = pyr.pixel_m(m - 1, Plane::Avg, fr, fc).expect("pixel");
                    assert!(
                        lo <= flo && fhi <= hi && lo <= favg && favg <= hi,
                        "level {m} ({cr}, {cc}) [{lo}, {hi}] vs level {} ({fr}, {fc}) [{flo}, {fhi}]",
                        m - 1
                    );
                }
            }
        }
    }
}

#[test]
fn coarse_min_max_bound_finer_samples() {
    let grid = GeoGrid::global(700, 351);
    let src = Synth::new(grid, |_, _, lat, lon| terrain(lat, lon) as f32);
    let (path, _) = build(&src, "bounds-global.gpyr", 32);
    let pyr = Pyramid::open(&path).expect("open");
    check_footprints(&pyr, 7);
    check_bounds_property(&pyr, 0x9e37_79b9_7f4a_7c15, 1500);
    // The whole planet at the coarsest level bounds everything, and says it is complete.
    let all = pyr
        .min_max_in(
            Region::Box {
                south_deg: -90.0,
                north_deg: 90.0,
                west_deg: -180.0,
                east_deg: 180.0,
            },
            pyr.level_count() - 1,
        )
        .expect("global");
    assert!(all.complete);
    let info = pyr.info();
    assert_eq!((all.min_m, all.max_m), (info.min_m, info.max_m));
    // A cap over the north pole and one across the antimeridian.
    for (lat, lon) in [(89.9, 0.0), (0.0, 180.0), (-89.5, 45.0)] {
        let b = pyr
            .min_max_in(
                Region::Cap {
                    lat_deg: lat,
                    lon_deg: lon,
                    radius_rad: 0.02,
                },
                1,
            )
            .expect("cap");
        let mut rng = Rng(3);
        for _ in 0..200 {
            let (qlat, qlon) = point_in_cap(&mut rng, lat, lon, 0.02);
            let h = pyr.sample(qlat, qlon, 0).expect("global");
            assert!(
                b.min_m <= h && h <= b.max_m,
                "cap ({lat}, {lon}) misses {h}"
            );
        }
    }
    std::fs::remove_file(&path).ok();

    let grid = regional_grid();
    let src = Synth::new(grid, |_, _, lat, lon| {
        terrain(lat * 40.0, lon * 40.0) as f32
    });
    let (path, _) = build(&src, "bounds-regional.gpyr", 16);
    let pyr = Pyramid::open(&path).expect("open");
    check_footprints(&pyr, 11);
    check_bounds_property(&pyr, 12345, 1500);
    std::fs::remove_file(&path).ok();
}

// ---------------------------------------------------------------------------------------------
// Filtering on the sphere

/// Latitude edges of row `r` of a level, clamped to the sphere.
fn row_edges(g: &GeoGrid, r: usize) -> (f64, f64) {
    let top = g.lat0_deg + 0.5 * g.dlat_deg - r as f64 * g.dlat_deg;
    (
        top.clamp(-90.0, 90.0),
        (top - g.dlat_deg).clamp(-90.0, 90.0),
    )
}

fn sin_deg(x: f64) -> f64 {
    x.to_radians().sin()
}

#[test]
fn area_weighted_average_of_latitude_bands() {
    // 0.5° global grid with rows centred on both poles (like ETOPO5): 720 × 361. The height
    // depends on the row only, so every level's avg must be the area-weighted mean of the
    // finer rows under it — weights Δ sin(latitude), not equal weights.
    let grid = GeoGrid {
        cols: 720,
        rows: 361,
        lon0_deg: 0.0,
        lat0_deg: 90.0,
        dlon_deg: 0.5,
        dlat_deg: 0.5,
    };
    let band = |r: usize| {
        (500.0 * (0.05 * r as f64).sin() + 300.0 * (r as f64 * 0.5).to_radians().sin()) as f32
    };
    let src = Synth::new(grid, move |r, _, _, _| band(r));
    let q = 1.0 / 32.0;
    let path = tmp_path("bands.gpyr");
    PyramidBuilder::new()
        .tile_size(32)
        .encoding(q, 0.0)
        .build(&src, &path)
        .expect("build");
    let pyr = Pyramid::open(&path).expect("open");
    assert_eq!(pyr.encoding().quantum_m, q);
    let mut expected: Vec<f64> = (0..grid.rows).map(|r| band(r) as f64).collect();
    let mut worst = 0.0f64;
    let mut naive_gap = 0.0f64;
    let area = |g: &GeoGrid, r: usize| {
        let (t, b) = row_edges(g, r);
        sin_deg(t) - sin_deg(b)
    };
    let mean0: f64 = (0..grid.rows)
        .map(|r| area(&grid, r) * expected[r])
        .sum::<f64>()
        / 2.0;
    for level in 1..pyr.level_count() {
        let (f, c) = (pyr.grid(level - 1), pyr.grid(level));
        let mut next = Vec::with_capacity(c.rows);
        for cr in 0..c.rows {
            let (ct, cb) = row_edges(&c, cr);
            let (mut num, mut den, mut naive, mut count) = (0.0, 0.0, 0.0, 0.0);
            for (fr, &v) in expected.iter().enumerate() {
                let (ft, fb) = row_edges(&f, fr);
                let (t, b) = (ct.min(ft), cb.max(fb));
                if t > b {
                    let w = sin_deg(t) - sin_deg(b);
                    num += w * v;
                    den += w;
                    naive += v;
                    count += 1.0;
                }
            }
            let want = num / den;
            naive_gap = naive_gap.max((naive / count - want).abs());
            for cc in (0..c.cols).step_by(7) {
                let got = pyr.pixel_m(level, Plane::Avg, cr, cc).expect("pixel");
                let err = (got - want).abs();
                worst = worst.max(err);
                assert!(
                    err <= 0.5 * q + 1e-3,
                    "level {level} row {cr}: {got} vs {want}"
                );
            }
            next.push(want);
        }
        // The area-weighted global mean is conserved from level to level.
        let mean: f64 = (0..c.rows)
            .map(|r| area(&c, r) * pyr.pixel_m(level, Plane::Avg, r, 0).expect("pixel"))
            .sum::<f64>()
            / 2.0;
        assert!(
            (mean - mean0).abs() < q,
            "level {level}: global mean {mean} vs {mean0}"
        );
        expected = next;
    }
    println!(
        "latitude bands: worst |avg − area-weighted mean| {worst:.4} m (quantum {q} m); an unweighted mean would be off by up to {naive_gap:.1} m"
    );
    assert!(
        naive_gap > 10.0,
        "the test must tell weighted from unweighted means"
    );
    std::fs::remove_file(&path).ok();
}

#[test]
fn longitude_kernel_widens_towards_the_poles() {
    // A pure longitude wave of 9° wavelength at every latitude. On the sphere its ground
    // wavelength shrinks as cos(lat), so near the poles it is far above the band limit of the
    // coarse level and must be filtered away; near the equator a 2×2 box keeps most of it.
    let grid = GeoGrid::global(720, 360);
    let src = Synth::new(grid, |_, _, _, lon| {
        (1000.0 * (40.0 * lon.to_radians()).cos()) as f32
    });
    let path = tmp_path("polar.gpyr");
    let report = PyramidBuilder::new()
        .tile_size(64)
        .build(&src, &path)
        .expect("build");
    let pyr = Pyramid::open(&path).expect("open");
    let g = pyr.grid(1);
    let amplitude = |r: usize| {
        (0..g.cols)
            .map(|c| pyr.pixel_m(1, Plane::Avg, r, c).expect("pixel").abs())
            .fold(0.0f64, f64::max)
    };
    // Expected, from an independent implementation of the kernel: level 0 as constant cells,
    // a box of width W = max(Δλ, Δφ / c̄) (isotropic on the ground) centred on each coarse
    // centre, wrapping; the wave does not depend on latitude, so the latitude part drops out.
    let fine = pyr.grid(0);
    let cell = |j: i64| {
        let j = j.rem_euclid(fine.cols as i64) as f64;
        (1000.0 * (40.0 * fine.lon_of_col(j).to_radians()).cos()) as f32 as f64
    };
    let west = fine.lon0_deg - 0.5 * fine.dlon_deg;
    let mut table = Vec::new();
    let mut worst = 0.0f64;
    for r in 0..g.rows {
        let (top, bottom) = row_edges(&g, r);
        let cbar = (sin_deg(top) - sin_deg(bottom)) / (top - bottom).to_radians();
        let width = (g.dlat_deg / cbar).clamp(g.dlon_deg, 360.0);
        for c in 0..g.cols {
            let centre = g.lon_of_col(c as f64);
            let (a, b) = (centre - 0.5 * width, centre + 0.5 * width);
            let (ja, jb) = (
                ((a - west) / fine.dlon_deg).floor() as i64,
                ((b - west) / fine.dlon_deg).ceil() as i64,
            );
            let mut sum = 0.0;
            for j in ja..jb {
                let (ca, cb) = (
                    west + j as f64 * fine.dlon_deg,
                    west + (j + 1) as f64 * fine.dlon_deg,
                );
                let overlap = cb.min(b) - ca.max(a);
                if overlap > 0.0 {
                    sum += overlap * cell(j);
                }
            }
            let want = sum / (b - a);
            let got = pyr.pixel_m(1, Plane::Avg, r, c).expect("pixel");
            worst = worst.max((got - want).abs());
            assert!(
                (got - want).abs() <= 0.5 + 1e-3,
                "level 1 ({r}, {c}) at {}°: {got} m, expected {want:.3} m for a {width:.2}° window",
                g.lat_of_row(r as f64)
            );
        }
        table.push((g.lat_of_row(r as f64), width, amplitude(r)));
    }
    let equator = amplitude(g.rows / 2);
    assert!(equator > 900.0, "the equator keeps the wave: {equator}");
    // The rows next to the poles average ~115° of longitude: the wave (9°) is gone.
    let polar = amplitude(0).max(amplitude(g.rows - 1));
    assert!(polar <= 0.05 * equator, "polar rows: {polar}");
    let at_80 = table
        .iter()
        .find(|t| (t.0 - 80.5).abs() < 0.01)
        .expect("row at 80.5°")
        .2;
    assert!(at_80 < 0.5 * equator, "80.5°: {at_80} vs equator {equator}");
    println!(
        "longitude wave (9° wavelength) at level 1, worst deviation from the reference kernel {worst:.3} m; latitude, window, amplitude:"
    );
    for (lat, width, amp) in table.iter().filter(|t| t.0 > 0.0).step_by(6) {
        println!("  {lat:6.1}°  {width:7.2}°  {amp:6.1} m");
    }
    println!(
        "widened passes {}, full-circle passes {}",
        report.widened_passes, report.full_circle_passes
    );
    assert!(report.widened_passes > 0);
    std::fs::remove_file(&path).ok();
}

// ---------------------------------------------------------------------------------------------
// Corruption, truncation, bad headers

fn small_pyramid(name: &str) -> PathBuf {
    let src = Synth::new(GeoGrid::global(300, 150), |_, _, lat, lon| {
        terrain(lat, lon) as f32
    });
    build(&src, name, 32).0
}

fn flip_byte(path: &Path, at: u64) {
    let mut bytes = std::fs::read(path).expect("read");
    bytes[at as usize] ^= 0x5a;
    std::fs::write(path, bytes).expect("write");
}

#[test]
fn verify_names_a_corrupt_tile() {
    let path = small_pyramid("corrupt.gpyr");
    let pyr = Pyramid::open(&path).expect("open");
    let report = pyr.verify().expect("a fresh file verifies");
    assert_eq!(report.tiles, pyr.info().tiles);
    let entry = pyr.tile_entry(1, 2, 1).expect("tile");
    drop(pyr);
    flip_byte(&path, entry.offset + 1234);
    let pyr = Pyramid::open(&path).expect("the header is intact");
    let err = pyr.verify().expect_err("corrupt tile");
    println!("verify: {err}");
    match &err {
        DemError::TileChecksum { level, tx, ty, .. } => assert_eq!((*level, *tx, *ty), (1, 2, 1)),
        other => panic!("expected a checksum error, got {other}"),
    }
    let msg = err.to_string();
    assert!(
        msg.contains("level 1 tile (2, 1)") && msg.contains("corrupt.gpyr"),
        "{msg}"
    );
    assert!(pyr.tile_verified(1, 2, 1).is_err());
    assert!(pyr.tile_verified(1, 1, 1).is_ok());
    assert!(pyr.tile(9, 0, 0).is_err() && pyr.tile(0, 99, 0).is_err());
    drop(pyr);
    // A flipped byte in the tile index is caught by the header CRC.
    flip_byte(&path, 1000);
    let err = Pyramid::open(&path).expect_err("corrupt header");
    println!("open: {err}");
    assert!(err.to_string().contains("header CRC"), "{err}");
    std::fs::remove_file(&path).ok();
}

#[test]
fn truncated_files_are_errors_not_crashes() {
    let path = small_pyramid("truncate-src.gpyr");
    let full = std::fs::read(&path).expect("read");
    let pyr = Pyramid::open(&path).expect("open");
    let first_tile = pyr.tile_entry(0, 0, 0).expect("tile").offset as usize;
    let last_tile = pyr
        .tile_entry(pyr.level_count() - 1, 0, 0)
        .expect("tile")
        .offset as usize;
    drop(pyr);
    let cut_path = tmp_path("truncated.gpyr");
    let header_len = u32::from_le_bytes(full[12..16].try_into().expect("4")) as usize;
    for len in [
        0,
        3,
        8,
        11,
        100,
        135,
        136,
        header_len / 2,
        header_len - 1,
        header_len,
        first_tile,
        first_tile + 1000,
        (first_tile + full.len()) / 2,
        last_tile,
        full.len() - 1,
    ] {
        std::fs::write(&cut_path, &full[..len]).expect("write");
        let err = Pyramid::open(&cut_path).expect_err("truncated");
        let msg = err.to_string();
        println!("{len:>8} bytes: {msg}");
        assert!(msg.contains("truncated.gpyr"), "names the file: {msg}");
        assert!(
            matches!(err, DemError::Truncated { .. }) && msg.contains("missing"),
            "says what is missing: {msg}"
        );
    }
    // One byte too many is an error too.
    let mut longer = full.clone();
    longer.push(0);
    std::fs::write(&cut_path, &longer).expect("write");
    let err = Pyramid::open(&cut_path).expect_err("longer");
    println!("+1 byte: {err}");
    assert!(err.to_string().contains("unexpected bytes"));
    // Truncated after open: check_length and verify see it (no access past the end).
    std::fs::write(&cut_path, &full).expect("write");
    let pyr = Pyramid::open(&cut_path).expect("open");
    let f = std::fs::OpenOptions::new()
        .write(true)
        .open(&cut_path)
        .expect("open rw");
    f.set_len(full.len() as u64 - 10).expect("truncate");
    let err = pyr.verify().expect_err("changed size");
    println!("truncated while open: {err}");
    assert!(matches!(err, DemError::Truncated { .. }));
    assert!(pyr.check_length().is_err());
    drop(pyr);
    std::fs::remove_file(&cut_path).ok();
    std::fs::remove_file(&path).ok();
}

#[test]
fn bad_magic_version_and_garbage_are_clear_errors() {
    let path = small_pyramid("header-src.gpyr");
    let full = std::fs::read(&path).expect("read");
    let bad = tmp_path("bad-header.gpyr");

    let mut b = full.clone();
    b[..8].copy_from_slice(b"GLOBEPYX");
    std::fs::write(&bad, &b).expect("write");
    let err = Pyramid::open(&bad).expect_err("magic");
    println!("magic: {err}");
    assert!(
        err.to_string().contains("not a globe pyramid file"),
        "{err}"
    );

    let mut b = full.clone();
    b[8..12].copy_from_slice(&2u32.to_le_bytes());
    std::fs::write(&bad, &b).expect("write");
    let err = Pyramid::open(&bad).expect_err("version");
    println!("version: {err}");
    assert!(err.to_string().contains("format version 2"), "{err}");

    // A version-1 header with a forged (but CRC-consistent) tile size.
    let mut b = full.clone();
    b[16..20].copy_from_slice(&64u32.to_le_bytes());
    let header_len = u32::from_le_bytes(b[12..16].try_into().expect("4")) as usize;
    let crc = crc32fast::hash(&b[..header_len - 4]);
    b[header_len - 4..header_len].copy_from_slice(&crc.to_le_bytes());
    std::fs::write(&bad, &b).expect("write");
    let err = Pyramid::open(&bad).expect_err("inconsistent level table");
    println!("forged tile size: {err}");
    assert!(err.to_string().contains("level"), "{err}");

    let garbage: Vec<u8> = (0..100_000u32)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
        .collect();
    std::fs::write(&bad, &garbage).expect("write");
    let err = Pyramid::open(&bad).expect_err("garbage");
    println!("garbage: {err}");
    assert!(err.to_string().contains("not a globe pyramid file"));

    let err = Pyramid::open(tmp_path("does-not-exist.gpyr")).expect_err("missing");
    assert!(err.to_string().contains("does-not-exist.gpyr"));
    std::fs::remove_file(&bad).ok();
    std::fs::remove_file(&path).ok();
}

// ---------------------------------------------------------------------------------------------
// NaN policy, bad values, progress

#[test]
fn nan_becomes_sea_level_and_is_counted() {
    let grid = GeoGrid::global(250, 130);
    let is_nan = |r: usize, c: usize| r == 5 || (r * 7 + c * 3).is_multiple_of(101);
    let src = Synth::new(grid, move |r, c, lat, lon| {
        if is_nan(r, c) {
            f32::NAN
        } else {
            terrain(lat, lon) as f32
        }
    });
    let expected = (0..grid.rows)
        .flat_map(|r| (0..grid.cols).map(move |c| (r, c)))
        .filter(|&(r, c)| is_nan(r, c))
        .count() as u64;
    let (path, report) = build(&src, "nan.gpyr", 32);
    assert_eq!(report.nan_count, expected);
    let pyr = Pyramid::open(&path).expect("open");
    assert_eq!(pyr.nan_count(), expected);
    for (r, c) in [(5, 0), (5, 100), (0, 0)] {
        assert!(is_nan(r, c));
        let h = pyr.sample(grid.lat_of_row(r as f64), grid.lon_of_col(c as f64), 0);
        assert_eq!(h, Some(0.0), "NaN at ({r}, {c}) is sea level");
    }
    assert!(
        pyr.info()
            .to_string()
            .contains(&format!("{expected} no-data pixels"))
    );
    check_planes(&pyr);
    std::fs::remove_file(&path).ok();

    let path = tmp_path("nan-reject.gpyr");
    let err = PyramidBuilder::new()
        .tile_size(32)
        .nan_policy(NanPolicy::Reject)
        .build(&src, &path)
        .expect_err("reject");
    println!("reject: {err}");
    assert!(err.to_string().contains("row 0, column 0") && err.to_string().contains("NaN"));
    assert!(!path.exists(), "no output after an error");
    let mut partial = path.clone().into_os_string();
    partial.push(".partial");
    assert!(!Path::new(&partial).exists(), "no partial file left behind");

    let inf = Synth::new(
        grid,
        |r, c, _, _| if (r, c) == (7, 8) { f32::INFINITY } else { 1.0 },
    );
    let err = PyramidBuilder::new()
        .tile_size(32)
        .build(&inf, &path)
        .expect_err("inf");
    println!("inf: {err}");
    assert!(err.to_string().contains("row 7, column 8") && err.to_string().contains("inf"));

    let high = Synth::new(
        grid,
        |r, c, _, _| if (r, c) == (9, 1) { 40_000.0 } else { 1.0 },
    );
    let err = PyramidBuilder::new()
        .tile_size(32)
        .build(&high, &path)
        .expect_err("out of range");
    println!("range: {err}");
    assert!(err.to_string().contains("row 9, column 1") && err.to_string().contains("quantum"));
    // …and a coarser quantum holds it.
    PyramidBuilder::new()
        .tile_size(32)
        .encoding(2.0, 0.0)
        .build(&high, &path)
        .expect("2 m quantum");
    let pyr = Pyramid::open(&path).expect("open");
    assert_eq!(
        pyr.sample(grid.lat_of_row(9.0), grid.lon_of_col(1.0), 0),
        Some(40_000.0)
    );
    drop(pyr);
    std::fs::remove_file(&path).ok();

    let bad_grid = GeoGrid {
        lat0_deg: 95.0,
        ..grid
    };
    let err = PyramidBuilder::new()
        .build(&Synth::new(bad_grid, |_, _, _, _| 0.0), &path)
        .expect_err("grid off the sphere");
    println!("grid: {err}");
    assert!(err.to_string().contains("latitude"));
}

#[test]
fn progress_reaches_one() {
    let src = Synth::new(GeoGrid::global(400, 200), |_, _, lat, lon| {
        terrain(lat, lon) as f32
    });
    let path = tmp_path("progress.gpyr");
    let mut seen: Vec<BuildProgress> = Vec::new();
    PyramidBuilder::new()
        .tile_size(64)
        .on_progress(|p| seen.push(*p))
        .build(&src, &path)
        .expect("build");
    let last = seen.last().expect("at least the final report");
    assert_eq!(
        (last.fraction, last.rows_done, last.rows_total),
        (1.0, 200, 200)
    );
    assert!(last.rows_per_s > 0.0);
    assert!(seen.windows(2).all(|w| w[0].fraction <= w[1].fraction));
    std::fs::remove_file(&path).ok();
}

// ---------------------------------------------------------------------------------------------
// Memory bound (in a child process, so no other test's allocations count)

/// The terrain function with per-column tables, fast enough for tens of millions of pixels.
struct BigSynth {
    grid: GeoGrid,
    c3: Vec<f32>,
    s5: Vec<f32>,
    c31: Vec<f32>,
}

impl BigSynth {
    fn new(grid: GeoGrid) -> Self {
        let lon = |c: usize| grid.lon_of_col(c as f64).to_radians();
        Self {
            grid,
            c3: (0..grid.cols)
                .map(|c| (3.0 * lon(c)).cos() as f32)
                .collect(),
            s5: (0..grid.cols)
                .map(|c| (5.0 * lon(c)).sin() as f32)
                .collect(),
            c31: (0..grid.cols)
                .map(|c| (31.0 * lon(c)).cos() as f32)
                .collect(),
        }
    }
}

impl RasterSource for BigSynth {
    fn grid(&self) -> GeoGrid {
        self.grid
    }
    fn read_row(&self, row: usize, out: &mut [f32]) -> Result<(), DemError> {
        let lat = self.grid.lat_of_row(row as f64);
        let p = lat.to_radians();
        let a = (1200.0 * (2.0 * p).sin()) as f32;
        let b = (300.0 * (7.0 * p + 1.0).sin()) as f32;
        let c = (40.0 * (29.0 * p).sin()) as f32;
        for (j, v) in out.iter_mut().enumerate() {
            *v = a * self.c3[j] + b * self.s5[j] + c * self.c31[j];
        }
        if (lat - 27.95).abs() < 3.0 {
            for (j, v) in out.iter_mut().enumerate() {
                let lon = self.grid.lon_of_col(j as f64);
                if (lon - 86.9).abs() < 4.0 {
                    *v += peak(lat, lon) as f32;
                }
            }
        }
        Ok(())
    }
    fn describe(&self) -> String {
        format!("synthetic global {} × {}", self.grid.cols, self.grid.rows)
    }
}

fn vm_hwm_kb() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .unwrap_or(0)
}

fn big_size() -> (usize, usize) {
    std::env::var("GLOBE_PYRAMID_BIG")
        .ok()
        .and_then(|s| {
            let (c, r) = s.split_once('x')?;
            Some((c.parse().ok()?, r.parse().ok()?))
        })
        .unwrap_or((8640, 4320))
}

#[test]
fn memory_bound() {
    if !Path::new("/proc/self/status").exists() {
        eprintln!("SKIPPED: no /proc/self/status on this system");
        return;
    }
    let exe = std::env::current_exe().expect("test binary");
    // The child's full test name in this binary (`pyramid::memory_bound_child`): the crate's
    // name is not part of it.
    let module = module_path!().split_once("::").map_or("", |(_, m)| m);
    let child = format!("{module}::memory_bound_child");
    let out = std::process::Command::new(exe)
        .args([
            child.as_str(),
            "--exact",
            "--ignored",
            "--nocapture",
            "--test-threads=1",
        ])
        .env("GLOBE_PYRAMID_CHILD", "1")
        .output()
        .expect("run the child");
    let stdout = String::from_utf8_lossy(&out.stdout);
    println!("{stdout}");
    assert!(
        out.status.success(),
        "child failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let field = |key: &str| -> u64 {
        stdout
            .lines()
            .find_map(|l| l.split_once(key).map(|(_, v)| v))
            .and_then(|v| v.trim().parse().ok())
            .unwrap_or_else(|| panic!("child printed no {key}"))
    };
    let before = field("VMHWM_BEFORE_KB=");
    let after = field("VMHWM_AFTER_KB=");
    let raster = field("RASTER_F32_BYTES=");
    let buffers = field("BUFFER_BYTES=");
    let grown = (after - before) * 1024;
    println!(
        "peak RSS grew {:.1} MB during the build; the raster is {:.1} MB as f32; the builder's buffers {:.1} MB",
        grown as f64 / 1e6,
        raster as f64 / 1e6,
        buffers as f64 / 1e6
    );
    assert!(
        grown < raster / 4,
        "peak grew by {grown} bytes, raster {raster}"
    );
    assert!(
        grown < buffers + (16 << 20),
        "peak {grown} vs computed buffers {buffers}"
    );
}

#[test]
#[ignore = "run by memory_bound in a child process"]
fn memory_bound_child() {
    if std::env::var("GLOBE_PYRAMID_CHILD").is_err() {
        return;
    }
    let (cols, rows) = big_size();
    let grid = GeoGrid::global(cols, rows);
    let src = BigSynth::new(grid);
    let path = tmp_path(&format!("big-{cols}x{rows}.gpyr"));
    let before = vm_hwm_kb();
    let mut reports = 0;
    let report = PyramidBuilder::new()
        .on_progress(|_| reports += 1)
        .build(&src, &path)
        .expect("build");
    let after = vm_hwm_kb();
    let secs = report.elapsed.as_secs_f64();
    println!("VMHWM_BEFORE_KB={before}");
    println!("VMHWM_AFTER_KB={after}");
    println!("RASTER_F32_BYTES={}", 4 * cols * rows);
    println!("BUFFER_BYTES={}", report.buffer_bytes);
    println!(
        "built {cols} × {rows} ({} levels, {} tiles, {:.1} MB) in {secs:.2} s: {:.0} rows/s, {:.1} M samples/s, {:.0} MB/s of f32 source; {} progress reports; widened longitude passes {}, full circle {}",
        report.levels,
        report.tiles,
        report.file_bytes as f64 / 1e6,
        report.rows_per_s,
        (cols * rows) as f64 / secs / 1e6,
        (4 * cols * rows) as f64 / secs / 1e6,
        reports,
        report.widened_passes,
        report.full_circle_passes
    );
    let t = Instant::now();
    let pyr = Pyramid::open(&path).expect("open");
    let v = pyr.verify().expect("verify");
    println!(
        "open + verify: {} tiles, {:.1} MB in {:.2} s",
        v.tiles,
        v.bytes as f64 / 1e6,
        t.elapsed().as_secs_f64()
    );
    let h = pyr.sample(27.95, 86.9, 0).expect("global");
    println!(
        "peak at level 0: {h} m; levels: {:?}",
        pyr.levels()
            .iter()
            .map(|l| (l.cols, l.rows))
            .collect::<Vec<_>>()
    );
    assert!(h > 2500.0);
    drop(pyr);
    if std::env::var("GLOBE_PYRAMID_KEEP").is_err() {
        std::fs::remove_file(&path).ok();
    }
}
