//! EHdr/BIL reader, mosaic and writer (issue 3 items 1–2): round trips, GTOPO30-shaped tiles,
//! mosaics, every bad input we know of, garbage headers, and a cross-check against GDAL's
//! `gdallocationinfo` when it is installed.

use crate::common::gdal as gdal_common;

use std::path::{Path, PathBuf};

use globe::dem::ehdr::{
    ByteOrder, EhdrHeader, EhdrMosaic, EhdrRaster, EhdrWriteOptions, Layout, SampleType, write_ehdr,
};
use globe::dem::{DemError, GeoGrid, RasterSource};

// ---------------------------------------------------------------------------------------------
// Helpers

/// A unique folder under the system temp dir, removed on drop.
struct TempDir(tempfile::TempDir);

impl TempDir {
    fn new(name: &str) -> TempDir {
        let prefix = format!("globe-ehdr-test-{name}-");
        TempDir(tempfile::Builder::new().prefix(&prefix).tempdir().unwrap())
    }

    fn path(&self) -> &Path {
        self.0.path()
    }

    fn join(&self, name: &str) -> PathBuf {
        self.0.path().join(name)
    }

    fn write(&self, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
        let p = self.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }
}

/// 30″ in degrees, as GTOPO30's headers write it.
const GTOPO_DIM: f64 = 0.00833333333333;

/// The GTOPO30 header of tile W020N40, verbatim.
const W020N40_HDR: &str = "BYTEORDER      M
LAYOUT       BIL
NROWS         6000
NCOLS         4800
NBANDS        1
NBITS         16
BANDROWBYTES         9600
TOTALROWBYTES        9600
BANDGAPBYTES         0
NODATA        -9999
ULXMAP        -19.99583333333333
ULYMAP        39.99583333333333
XDIM          0.00833333333333
YDIM          0.00833333333333
";

/// A synthetic global 30″ field, by global row/column of the GTOPO30 lattice (row 0 at
/// 89.9958°N, column 0 at 179.9958°W): every neighbour differs, and some pixels are no-data.
fn global_value(grow: i64, gcol: i64) -> f32 {
    if (grow / 97 + gcol / 89) % 7 == 0 {
        return f32::NAN;
    }
    ((grow * 31 + gcol * 17).rem_euclid(9000) - 500) as f32
}

/// Global (row, col) of a GTOPO30 tile's pixel (0, 0).
fn tile_origin(grid: &GeoGrid) -> (i64, i64) {
    (
        ((89.99583333333333 - grid.lat0_deg) / GTOPO_DIM).round() as i64,
        ((grid.lon0_deg + 179.99583333333333) / GTOPO_DIM).round() as i64,
    )
}

fn gtopo_grid(ulx: f64, uly: f64, cols: usize, rows: usize) -> GeoGrid {
    GeoGrid {
        cols,
        rows,
        lon0_deg: ulx,
        lat0_deg: uly,
        dlon_deg: GTOPO_DIM,
        dlat_deg: GTOPO_DIM,
    }
}

/// Writes a GTOPO30-style tile filled from [`global_value`].
fn write_gtopo_tile(dir: &Path, name: &str, grid: &GeoGrid) -> PathBuf {
    let (r0, c0) = tile_origin(grid);
    let cols = grid.cols;
    let mut row = vec![0.0f32; cols];
    let rows = (0..grid.rows).map(move |r| {
        for (c, v) in row.iter_mut().enumerate() {
            *v = global_value(r0 + r as i64, c0 + c as i64);
        }
        row.clone()
    });
    write_ehdr(&dir.join(name), grid, &EhdrWriteOptions::gtopo30(), rows)
        .unwrap()
        .header_path
}

fn small_grid(cols: usize, rows: usize) -> GeoGrid {
    GeoGrid {
        cols,
        rows,
        lon0_deg: 10.125,
        lat0_deg: 45.875,
        dlon_deg: 0.25,
        dlat_deg: 0.25,
    }
}

/// Rows of a small test field with a NaN here and there.
fn small_rows(grid: &GeoGrid, f: impl Fn(usize, usize) -> f32) -> Vec<Vec<f32>> {
    (0..grid.rows)
        .map(|r| (0..grid.cols).map(|c| f(r, c)).collect())
        .collect()
}

fn read_all(src: &dyn RasterSource) -> Vec<Vec<f32>> {
    let g = src.grid();
    (0..g.rows)
        .map(|r| {
            let mut row = vec![0.0; g.cols];
            src.read_row(r, &mut row).unwrap();
            row
        })
        .collect()
}

fn same(a: f32, b: f32) -> bool {
    a == b || (a.is_nan() && b.is_nan())
}

fn assert_rows_eq(got: &[Vec<f32>], want: &[Vec<f32>]) {
    assert_eq!(got.len(), want.len());
    for (r, (g, w)) in got.iter().zip(want).enumerate() {
        for (c, (&a, &b)) in g.iter().zip(w).enumerate() {
            assert!(same(a, b), "row {r}, col {c}: read {a}, wrote {b}");
        }
    }
}

fn i16_be(values: &[i16]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_be_bytes()).collect()
}

// ---------------------------------------------------------------------------------------------
// Round trips

fn round_trip(options: EhdrWriteOptions, f: impl Fn(usize, usize) -> f32) {
    let tmp = TempDir::new("roundtrip");
    let grid = small_grid(7, 5);
    let rows = small_rows(&grid, f);
    let written = write_ehdr(&tmp.join("T"), &grid, &options, &rows).unwrap();
    assert!(
        written
            .data_path
            .ends_with(format!("T.{}", options.data_extension))
    );
    for path in [&written.header_path, &written.data_path] {
        let r = EhdrRaster::open(path).unwrap();
        let h = r.header();
        assert_eq!(h.sample_type, options.sample_type);
        assert_eq!(h.byte_order, options.byte_order);
        assert_eq!(h.layout, Layout::Bil);
        assert_eq!((h.nrows, h.ncols, h.nbands), (5, 7, 1));
        assert_eq!(r.grid(), grid);
        assert_rows_eq(&read_all(&r), &rows);
        for (ri, row) in rows.iter().enumerate() {
            for (ci, &v) in row.iter().enumerate() {
                let got = r.value(ri, ci).unwrap();
                assert_eq!(got.is_none(), v.is_nan());
                if let Some(g) = got {
                    assert_eq!(g, v);
                }
            }
        }
    }
}

#[test]
fn round_trip_i16_big_endian() {
    round_trip(EhdrWriteOptions::gtopo30(), |r, c| {
        if (r + c) % 5 == 0 {
            f32::NAN
        } else {
            (r as f32 - 2.0) * 3000.0 + c as f32 * 7.0 - 12.0
        }
    });
}

#[test]
fn round_trip_i16_little_endian() {
    let options = EhdrWriteOptions {
        byte_order: ByteOrder::LittleEndian,
        data_extension: "bil".into(),
        ..EhdrWriteOptions::gtopo30()
    };
    round_trip(options, |r, c| {
        if r == 3 && c == 6 {
            f32::NAN
        } else {
            32767.0 - (r * 7 + c) as f32 * 1900.0
        }
    });
}

#[test]
fn round_trip_u8() {
    let options = EhdrWriteOptions {
        sample_type: SampleType::U8,
        byte_order: ByteOrder::BigEndian,
        nodata: Some(255.0),
        data_extension: "BIL".into(),
    };
    round_trip(options, |r, c| {
        if c == 0 {
            f32::NAN
        } else {
            (r * 50 + c) as f32
        }
    });
}

#[test]
fn round_trip_f32_both_byte_orders_and_nodata_kinds() {
    for (order, nodata) in [
        (ByteOrder::BigEndian, Some(-3.4028234663852886e38)),
        (ByteOrder::LittleEndian, Some(f64::NAN)),
        (ByteOrder::LittleEndian, Some(-9999.0)),
    ] {
        let options = EhdrWriteOptions {
            sample_type: SampleType::F32,
            byte_order: order,
            nodata,
            data_extension: "FLT".into(),
        };
        round_trip(options, |r, c| {
            if r == c {
                f32::NAN
            } else {
                -10994.25 + (r * 7 + c) as f32 * 1234.567
            }
        });
    }
}

#[test]
fn round_trip_other_integer_types() {
    for (st, nodata, lo) in [
        (SampleType::U16, Some(65535.0), 0.0),
        (SampleType::I32, None, -2e9),
        (SampleType::U32, Some(0.0), 1.0),
        (SampleType::I8, Some(-128.0), -127.0),
    ] {
        let options = EhdrWriteOptions {
            sample_type: st,
            byte_order: ByteOrder::LittleEndian,
            nodata,
            data_extension: "bil".into(),
        };
        round_trip(options, |r, c| {
            if nodata.is_some() && r == 1 && c == 1 {
                f32::NAN
            } else {
                lo + (r * 7 + c) as f32
            }
        });
    }
}

#[test]
fn writer_header_matches_gtopo30_keys() {
    let tmp = TempDir::new("writer-hdr");
    let grid = gtopo_grid(-19.99583333333333, 39.99583333333333, 3, 2);
    let w = write_ehdr(
        &tmp.join("W020N40"),
        &grid,
        &EhdrWriteOptions::gtopo30(),
        [[1.0f32, 2.0, 3.0], [4.0, 5.0, f32::NAN]],
    )
    .unwrap();
    assert!(w.data_path.ends_with("W020N40.DEM"));
    assert!(w.header_path.ends_with("W020N40.HDR"));
    let text = std::fs::read_to_string(&w.header_path).unwrap();
    let keys: Vec<&str> = text
        .lines()
        .map(|l| l.split_whitespace().next().unwrap())
        .collect();
    assert_eq!(
        keys,
        [
            "BYTEORDER",
            "LAYOUT",
            "NROWS",
            "NCOLS",
            "NBANDS",
            "NBITS",
            "BANDROWBYTES",
            "TOTALROWBYTES",
            "BANDGAPBYTES",
            "NODATA",
            "ULXMAP",
            "ULYMAP",
            "XDIM",
            "YDIM"
        ]
    );
    assert!(text.contains("NODATA        -9999\n"), "{text}");
    assert!(
        text.contains("ULXMAP        -19.99583333333333\n"),
        "{text}"
    );
    assert!(text.contains("XDIM          0.00833333333333\n"), "{text}");
    assert_eq!(
        std::fs::read(&w.data_path).unwrap(),
        i16_be(&[1, 2, 3, 4, 5, -9999])
    );
}

#[test]
fn writer_rejects_what_it_cannot_store() {
    let tmp = TempDir::new("writer-bad");
    let grid = small_grid(2, 2);
    let gt = EhdrWriteOptions::gtopo30();
    let no_nodata = EhdrWriteOptions {
        nodata: None,
        ..EhdrWriteOptions::gtopo30()
    };
    let cases: Vec<(&str, EhdrWriteOptions, Vec<Vec<f32>>, &str)> = vec![
        (
            "range",
            gt.clone(),
            vec![vec![1.0, 40000.0], vec![0.0, 0.0]],
            "does not fit SIGNEDINT 16",
        ),
        (
            "nan",
            no_nodata,
            vec![vec![1.0, f32::NAN], vec![0.0, 0.0]],
            "no NODATA",
        ),
        (
            "inf",
            gt.clone(),
            vec![vec![1.0, 2.0], vec![f32::INFINITY, 0.0]],
            "expected finite",
        ),
        (
            "nodata",
            gt.clone(),
            vec![vec![-9999.0, 2.0], vec![0.0, 0.0]],
            "read back as NODATA",
        ),
        (
            "short",
            gt.clone(),
            vec![vec![1.0, 2.0]],
            "1 rows were given; expected NROWS 2",
        ),
        (
            "long",
            gt.clone(),
            vec![vec![1.0, 2.0]; 3],
            "more than NROWS 2",
        ),
        (
            "width",
            gt.clone(),
            vec![vec![1.0], vec![2.0]],
            "expected NCOLS 2",
        ),
    ];
    for (name, options, rows, needle) in cases {
        let stem = tmp.join(name);
        let e = write_ehdr(&stem, &grid, &options, &rows).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains(needle), "{name}: {msg}");
        assert!(msg.contains(&format!("{name}.DEM")), "{name}: {msg}");
        assert!(
            !tmp.join(&format!("{name}.DEM")).exists(),
            "{name}: data file left behind"
        );
        assert!(
            !tmp.join(&format!("{name}.HDR")).exists(),
            "{name}: header left behind"
        );
    }
    let bad_nodata = EhdrWriteOptions {
        sample_type: SampleType::U8,
        ..EhdrWriteOptions::gtopo30()
    };
    let msg = write_ehdr(&tmp.join("u8"), &grid, &bad_nodata, [[0.0f32; 2]; 2])
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("NODATA -9999 cannot be stored as UNSIGNEDINT 8"),
        "{msg}"
    );
}

// ---------------------------------------------------------------------------------------------
// Sampling

#[test]
fn pixel_centres_exact_and_bilinear_between() {
    let tmp = TempDir::new("bilinear");
    let grid = GeoGrid {
        cols: 6,
        rows: 4,
        lon0_deg: -19.99583333333333,
        lat0_deg: 39.99583333333333,
        dlon_deg: GTOPO_DIM,
        dlat_deg: GTOPO_DIM,
    };
    let f = |r: usize, c: usize| (r * 100 + c * 7) as f32 + 0.5 * (c % 2) as f32;
    let mut rows = small_rows(&grid, f);
    rows[3][5] = f32::NAN;
    let options = EhdrWriteOptions {
        sample_type: SampleType::F32,
        nodata: Some(-9999.0),
        ..EhdrWriteOptions::gtopo30()
    };
    let w = write_ehdr(&tmp.join("B"), &grid, &options, &rows).unwrap();
    let r = EhdrRaster::open(&w.header_path).unwrap();

    // Every centre returns its stored value exactly, by nearest and by bilinear.
    for (ri, row) in rows.iter().enumerate() {
        for (ci, &v) in row.iter().enumerate() {
            let (lat, lon) = (grid.lat_of_row(ri as f64), grid.lon_of_col(ci as f64));
            assert_eq!(r.pixel_of(lat, lon), Some((ri, ci)));
            if v.is_nan() {
                assert_eq!(r.sample_nearest(lat, lon).unwrap(), None);
                assert_eq!(r.sample_bilinear(lat, lon).unwrap(), None);
            } else {
                assert_eq!(r.sample_nearest(lat, lon).unwrap(), Some(v));
                assert_eq!(r.sample_bilinear(lat, lon).unwrap(), Some(v as f64));
            }
        }
    }
    // In between: the bilinear blend of the four centres.
    let at = |row: f64, col: f64| {
        r.sample_bilinear(grid.lat_of_row(row), grid.lon_of_col(col))
            .unwrap()
    };
    let v = |r: usize, c: usize| rows[r][c] as f64;
    let mid = at(1.5, 2.5).unwrap();
    let want = (v(1, 2) + v(1, 3) + v(2, 2) + v(2, 3)) / 4.0;
    assert!((mid - want).abs() < 1e-9, "{mid} vs {want}");
    let q = at(0.25, 3.75).unwrap();
    let want = 0.75 * (0.25 * v(0, 3) + 0.75 * v(0, 4)) + 0.25 * (0.25 * v(1, 3) + 0.75 * v(1, 4));
    assert!((q - want).abs() < 1e-9, "{q} vs {want}");
    // Along an edge between two centres, only those two count.
    let e = at(0.0, 0.5).unwrap();
    assert!((e - (v(0, 0) + v(0, 1)) / 2.0).abs() < 1e-9);
    // Within half a pixel of the outer edge the edge pixels extend; beyond it, nothing.
    assert_eq!(at(-0.4, 0.0), Some(v(0, 0)));
    assert_eq!(at(1.0, -0.49), Some(v(1, 0)));
    assert_eq!(at(-0.6, 0.0), None);
    assert_eq!(at(1.0, 5.6), None);
    assert_eq!(at(4.0, 1.0), None);
    // A no-data neighbour is left out and the weights renormalised.
    let n = at(2.5, 4.5).unwrap();
    let want = (v(2, 4) + v(2, 5) + v(3, 4)) / 3.0;
    assert!((n - want).abs() < 1e-9, "{n} vs {want}");
    // Nearest: pixel edges belong to the pixel east / south of them (GDAL's floor).
    assert_eq!(
        r.pixel_of(grid.lat_of_row(1.0), grid.lon_of_col(2.49)),
        Some((1, 2))
    );
    assert_eq!(
        r.pixel_of(grid.lat_of_row(1.0), grid.lon_of_col(2.51)),
        Some((1, 3))
    );
    assert_eq!(
        r.pixel_of(grid.lat_of_row(2.51), grid.lon_of_col(0.0)),
        Some((3, 0))
    );
    assert_eq!(r.pixel_of(f64::NAN, 0.0), None);
    assert_eq!(r.sample_bilinear(0.0, f64::INFINITY).unwrap(), None);
}

#[test]
fn global_grid_wraps_in_longitude() {
    let tmp = TempDir::new("wrap");
    let grid = GeoGrid {
        cols: 8,
        rows: 2,
        lon0_deg: -157.5,
        lat0_deg: 45.0,
        dlon_deg: 45.0,
        dlat_deg: 90.0,
    };
    let rows = small_rows(&grid, |r, c| (r * 10 + c) as f32);
    let w = write_ehdr(&tmp.join("G"), &grid, &EhdrWriteOptions::gtopo30(), &rows).unwrap();
    let r = EhdrRaster::open(&w.header_path).unwrap();
    assert!(r.grid().wraps_in_longitude());
    // Halfway between the last column (157.5°E) and the first (157.5°W) is the antimeridian.
    assert_eq!(r.sample_bilinear(45.0, 180.0).unwrap(), Some(3.5));
    assert_eq!(r.sample_bilinear(45.0, -180.0).unwrap(), Some(3.5));
    assert_eq!(r.sample_nearest(45.0, 179.0).unwrap(), Some(7.0));
    assert_eq!(r.sample_nearest(45.0, 181.0).unwrap(), Some(0.0));
    assert_eq!(r.sample_nearest(45.0, 202.5 + 360.0).unwrap(), Some(0.0));
}

// ---------------------------------------------------------------------------------------------
// GTOPO30-shaped tiles and mosaics

#[test]
fn gtopo30_w020n40_tile() {
    let tmp = TempDir::new("w020n40");
    let grid = gtopo_grid(-19.99583333333333, 39.99583333333333, 4800, 6000);
    let hdr = write_gtopo_tile(tmp.path(), "W020N40", &grid);
    // Replace our header by GTOPO30's own, verbatim: both must read the same.
    let ours = EhdrHeader::parse(&std::fs::read_to_string(&hdr).unwrap(), &hdr).unwrap();
    std::fs::write(&hdr, W020N40_HDR).unwrap();
    let r = EhdrRaster::open(&tmp.join("W020N40.DEM")).unwrap();
    assert_eq!(*r.header(), ours);
    let h = r.header();
    assert_eq!(
        h.sample_type,
        SampleType::I16,
        "negative NODATA makes 16 bits signed"
    );
    assert_eq!(h.byte_order, ByteOrder::BigEndian);
    assert_eq!(h.expected_data_len(), 57_600_000);
    assert_eq!(r.grid(), grid);

    let want = |row: usize, col: usize| global_value(6000 + row as i64, 19200 + col as i64);
    assert_eq!(tile_origin(&grid), (6000, 19200));

    // Rows: first, last and a spread in between, against the formula; timing for the report.
    let mut buf = vec![0.0f32; 4800];
    let t0 = std::time::Instant::now();
    for row in 0..6000 {
        r.read_row(row, &mut buf).unwrap();
        if row % 499 == 0 || row == 5999 {
            for (col, &v) in buf.iter().enumerate() {
                assert!(same(v, want(row, col)), "row {row} col {col}: {v}");
            }
        }
    }
    let dt = t0.elapsed().as_secs_f64();
    eprintln!(
        "read_row over W020N40 (57.6 MB): {:.3} s, {:.0} MB/s",
        dt,
        57.6 / dt
    );

    // Corners and edges: centres, and points just inside / outside the tile's outer edges.
    let eps = 1e-7;
    let corners = [
        (39.99583333333333, -19.99583333333333, 0, 0),
        (39.99583333333333, 19.99583333333333, 0, 4799),
        (-9.99583333333333, -19.99583333333333, 5999, 0),
        (-9.99583333333333, 19.99583333333333, 5999, 4799),
        (40.0 - eps, -20.0 + eps, 0, 0),
        (40.0 - eps, 20.0 - eps, 0, 4799),
        (-10.0 + eps, -20.0 + eps, 5999, 0),
        (-10.0 + eps, 20.0 - eps, 5999, 4799),
        (40.0 - eps, 0.001, 0, 2400),
        (15.0, -20.0 + eps, 3000, 0),
        (15.0 - 0.001, 20.0 - eps, 3000, 4799),
        (-10.0 + eps, -0.001, 5999, 2399),
    ];
    for (lat, lon, row, col) in corners {
        assert_eq!(r.pixel_of(lat, lon), Some((row, col)), "({lat}, {lon})");
        let got = r.sample_nearest(lat, lon).unwrap();
        let w = want(row, col);
        assert_eq!(
            got.unwrap_or(f32::NAN).to_bits(),
            w.to_bits(),
            "({lat}, {lon})"
        );
    }
    for (lat, lon) in [
        (40.0 + eps, 0.0),
        (-10.0 - eps, 0.0),
        (15.0, -20.0 - eps),
        (15.0, 20.0 + eps),
        (90.0, 0.0),
    ] {
        assert_eq!(r.pixel_of(lat, lon), None, "({lat}, {lon})");
        assert_eq!(r.sample_nearest(lat, lon).unwrap(), None);
        assert_eq!(r.sample_bilinear(lat, lon).unwrap(), None);
    }
    // Centres, by latitude/longitude, return their values exactly through bilinear too.
    for (row, col) in [(0, 0), (0, 4799), (5999, 0), (5999, 4799), (1234, 4321)] {
        let (lat, lon) = (grid.lat_of_row(row as f64), grid.lon_of_col(col as f64));
        let w = want(row, col);
        let got = r.sample_bilinear(lat, lon).unwrap();
        assert_eq!(
            got.map(|v| v as f32).unwrap_or(f32::NAN).to_bits(),
            w.to_bits()
        );
    }
}

#[test]
fn mosaic_of_gtopo30_tiles_with_antarctica() {
    let tmp = TempDir::new("mosaic");
    let w020n40 = gtopo_grid(-19.99583333333333, 39.99583333333333, 4800, 6000);
    let e020n40 = gtopo_grid(20.00416666666667, 39.99583333333333, 4800, 6000);
    let w060s60 = gtopo_grid(-59.99583333333333, -60.00416666666667, 7200, 3600);
    write_gtopo_tile(tmp.path(), "W020N40", &w020n40);
    write_gtopo_tile(tmp.path(), "E020N40", &e020n40);
    write_gtopo_tile(tmp.path(), "W060S60", &w060s60);
    // GTOPO30's other files are ignored.
    tmp.write("W020N40.STX", "1 -407 5825 365.7 512.1\n");
    tmp.write("W020N40.PRJ", "Projection GEOGRAPHIC\n");
    let m = EhdrMosaic::open_dir(tmp.path()).unwrap();
    assert_eq!(m.tiles().count(), 3);
    let g = m.grid();
    assert_eq!((g.cols, g.rows), (14_400, 15_600));
    assert_eq!(g.lon0_deg, -59.99583333333333);
    assert_eq!(g.lat0_deg, 39.99583333333333);
    assert_eq!(g.dlon_deg, GTOPO_DIM);
    let (gr0, gc0) = tile_origin(&g);
    assert_eq!((gr0, gc0), (6000, 14_400));
    let origins: Vec<_> = m.tile_origins().collect();
    assert_eq!(origins, [(0, 9600), (0, 4800), (12_000, 0)]); // E020N40, W020N40, W060S60 sorted
    let covered = |row: usize, col: usize| {
        (row < 6000 && (4800..14_400).contains(&col)) || (row >= 12_000 && col < 7200)
    };
    let mut buf = vec![0.0f32; g.cols];
    for row in (0..g.rows)
        .step_by(613)
        .chain([5999, 6000, 11_999, 12_000, 15_599])
    {
        m.read_row(row, &mut buf).unwrap();
        for (col, &v) in buf.iter().enumerate() {
            let want = if covered(row, col) {
                global_value(gr0 + row as i64, gc0 + col as i64)
            } else {
                f32::NAN
            };
            assert!(same(v, want), "mosaic row {row} col {col}: {v} vs {want}");
        }
    }
    // By latitude/longitude, across the tile seam at 20°E and into Antarctica.
    for (lat, lon) in [
        (10.0 + 1e-6, 20.0 - 1e-6),
        (10.0 + 1e-6, 20.0 + 1e-6),
        (-89.99583333333333, -59.99583333333333),
        (-60.0 - 1e-6, -0.001),
        (39.99583333333333, 59.99583333333333),
    ] {
        let (row, col) = m.pixel_of(lat, lon).unwrap();
        let want = global_value(gr0 + row as i64, gc0 + col as i64);
        let got = m.sample_nearest(lat, lon).unwrap();
        assert_eq!(
            got.unwrap_or(f32::NAN).to_bits(),
            want.to_bits(),
            "({lat}, {lon})"
        );
    }
    // Bilinear across the seam uses both tiles.
    let seam_lat = g.lat_of_row(100.0);
    let left = m.value(100, 9599).unwrap().unwrap() as f64;
    let right = m.value(100, 9600).unwrap().unwrap() as f64;
    let mid = m.sample_bilinear(seam_lat, 20.0).unwrap().unwrap();
    assert!(
        (mid - (left + right) / 2.0).abs() < 1e-6,
        "{mid} {left} {right}"
    );
    // Uncovered: no value.
    assert_eq!(m.sample_nearest(-30.0, 0.0).unwrap(), None);
    assert_eq!(m.value(7000, 100).unwrap(), None);
    assert!(m.describe().contains("3 tiles"));
}

/// A tiny tile on a 1° lattice: `f(global row, global col)` with row 0 at 89.5°N, col 0 at 179.5°W.
fn write_small_tile(
    dir: &Path,
    name: &str,
    ulx: f64,
    uly: f64,
    cols: usize,
    rows: usize,
    f: impl Fn(i64, i64) -> f32,
) {
    let grid = GeoGrid {
        cols,
        rows,
        lon0_deg: ulx,
        lat0_deg: uly,
        dlon_deg: 1.0,
        dlat_deg: 1.0,
    };
    let (r0, c0) = ((89.5 - uly).round() as i64, (ulx + 179.5).round() as i64);
    let data = small_rows(&grid, |r, c| f(r0 + r as i64, c0 + c as i64));
    write_ehdr(&dir.join(name), &grid, &EhdrWriteOptions::gtopo30(), &data).unwrap();
}

#[test]
fn mosaic_overlaps_must_agree() {
    let f = |r: i64, c: i64| ((r - 40) * 1000 + c) as f32;
    // Consistent overlap (and NODATA in one tile filled by the other): fine.
    let tmp = TempDir::new("overlap-ok");
    write_small_tile(tmp.path(), "A", 0.5, 49.5, 5, 4, f);
    write_small_tile(tmp.path(), "B", 3.5, 47.5, 5, 4, |r, c| {
        if r == 42 && c == 183 {
            f32::NAN
        } else {
            f(r, c)
        }
    });
    let m = EhdrMosaic::open_dir(tmp.path()).unwrap();
    let g = m.grid();
    assert_eq!((g.cols, g.rows), (8, 6));
    let rows = read_all(&m);
    for (r, row) in rows.iter().enumerate() {
        for (c, &v) in row.iter().enumerate() {
            let in_a = r < 4 && c < 5;
            let in_b = r >= 2 && c >= 3;
            let want = if in_a || in_b {
                f(40 + r as i64, 180 + c as i64)
            } else {
                f32::NAN
            };
            assert!(same(v, want), "row {r} col {c}: {v} vs {want}");
            assert_eq!(m.value(r, c).unwrap().is_some(), in_a || in_b);
        }
    }

    // Inconsistent overlap: an error naming both tiles and the position.
    let tmp = TempDir::new("overlap-bad");
    write_small_tile(tmp.path(), "A", 0.5, 49.5, 5, 4, f);
    write_small_tile(tmp.path(), "B", 3.5, 47.5, 5, 4, |r, c| {
        if r == 43 && c == 184 { 7.0 } else { f(r, c) }
    });
    let e = EhdrMosaic::open_dir(tmp.path()).unwrap_err();
    let msg = e.to_string();
    eprintln!("inconsistent overlap: {msg}");
    assert!(matches!(e, DemError::Data { .. }), "{e:?}");
    for needle in [
        "B.DEM",
        "A.DEM",
        "inconsistently",
        "lat 46.500000°, lon 4.500000°",
        "7",
    ] {
        assert!(msg.contains(needle), "missing {needle:?}: {msg}");
    }
}

#[test]
fn mosaic_tiles_must_share_one_lattice() {
    let f = |r: i64, c: i64| (r + c) as f32;
    let tmp = TempDir::new("lattice-dim");
    write_small_tile(tmp.path(), "A", 0.5, 49.5, 3, 3, f);
    let grid = GeoGrid {
        cols: 3,
        rows: 3,
        lon0_deg: 10.25,
        lat0_deg: 49.75,
        dlon_deg: 0.5,
        dlat_deg: 0.5,
    };
    write_ehdr(
        &tmp.join("B"),
        &grid,
        &EhdrWriteOptions::gtopo30(),
        small_rows(&grid, |_, _| 1.0),
    )
    .unwrap();
    let e = EhdrMosaic::open_dir(tmp.path()).unwrap_err();
    let msg = e.to_string();
    eprintln!("different XDIM: {msg}");
    assert!(
        matches!(&e, DemError::Header { field, .. } if field == "XDIM"),
        "{e:?}"
    );
    assert!(
        msg.contains("B.HDR") && msg.contains("A.HDR") && msg.contains("XDIM 0.5"),
        "{msg}"
    );

    let tmp = TempDir::new("lattice-shift");
    write_small_tile(tmp.path(), "A", 0.5, 49.5, 3, 3, f);
    write_small_tile(tmp.path(), "B", 5.0, 49.5, 3, 3, f); // half a pixel off
    let e = EhdrMosaic::open_dir(tmp.path()).unwrap_err();
    let msg = e.to_string();
    eprintln!("off the lattice: {msg}");
    assert!(
        matches!(&e, DemError::Header { field, .. } if field == "ULXMAP"),
        "{e:?}"
    );
    assert!(
        msg.contains("B.HDR") && msg.contains("A.HDR") && msg.contains("4.5 pixels"),
        "{msg}"
    );

    let tmp = TempDir::new("lattice-wide");
    write_small_tile(tmp.path(), "A", -179.5, 49.5, 3, 3, f);
    write_small_tile(tmp.path(), "B", 181.5, 49.5, 3, 3, f);
    let msg = EhdrMosaic::open_dir(tmp.path()).unwrap_err().to_string();
    eprintln!("wider than 360°: {msg}");
    assert!(
        msg.contains("A.HDR") && msg.contains("expected at most 360°"),
        "{msg}"
    );

    let tmp = TempDir::new("empty");
    tmp.write("README.TXT", "no tiles here");
    let e = EhdrMosaic::open_dir(tmp.path()).unwrap_err();
    eprintln!("empty folder: {e}");
    assert!(matches!(e, DemError::Missing { .. }) && e.to_string().contains("no .HDR files"));
}

// ---------------------------------------------------------------------------------------------
// Layouts, multiple bands, defaults

#[test]
fn multiband_bil_with_row_padding_and_skip_bytes() {
    let tmp = TempDir::new("bil3");
    // 3 bands × 5 columns of little-endian i16; each band row padded to 12 bytes, each row to
    // 40 bytes, 7 bytes of file header.
    let (nrows, ncols) = (4usize, 5usize);
    let mut bytes = vec![0xABu8; 7];
    for r in 0..nrows {
        let mut row = Vec::new();
        for b in 0..3 {
            for c in 0..ncols {
                let v: i16 = if b == 0 {
                    (r * 10 + c) as i16 - 20
                } else {
                    0x7F7F
                };
                row.extend_from_slice(&v.to_le_bytes());
            }
            row.extend_from_slice(&[0xEE; 2]);
        }
        row.extend_from_slice(&[0xDD; 4]);
        assert_eq!(row.len(), 40);
        bytes.extend(row);
    }
    tmp.write("M.bil", &bytes);
    tmp.write(
        "M.hdr",
        "byteorder I\nlayout bil\nnrows 4\nncols 5\nnbands 3\nnbits 16\npixeltype signedint\n\
         bandrowbytes 12\ntotalrowbytes 40\nbandgapbytes 0\nskipbytes 7\nulxmap 0.5\nulymap 3.5\n\
         xdim 1\nydim 1\n",
    );
    let r = EhdrRaster::open(&tmp.join("M.bil")).unwrap();
    let want: Vec<Vec<f32>> = (0..nrows)
        .map(|row| (0..ncols).map(|c| (row * 10 + c) as f32 - 20.0).collect())
        .collect();
    assert_rows_eq(&read_all(&r), &want);
    assert_eq!(r.value(3, 4).unwrap(), Some(14.0));
}

#[test]
fn multiband_bip_and_bsq() {
    let tmp = TempDir::new("bipbsq");
    let (nrows, ncols, nbands) = (3usize, 4usize, 2usize);
    let band1 = |r: usize, c: usize| (r * 4 + c) as u16 * 1000;
    let want: Vec<Vec<f32>> = (0..nrows)
        .map(|r| (0..ncols).map(|c| band1(r, c) as f32).collect())
        .collect();
    let geo = "ULXMAP 0.5\nULYMAP 2.5\nXDIM 1\nYDIM 1\n";

    let mut bip = Vec::new();
    for r in 0..nrows {
        for c in 0..ncols {
            bip.extend_from_slice(&band1(r, c).to_be_bytes());
            bip.extend_from_slice(&9u16.to_be_bytes());
        }
    }
    tmp.write("P.BIL", &bip);
    tmp.write(
        "P.HDR",
        format!("LAYOUT BIP\nNROWS 3\nNCOLS 4\nNBANDS 2\nNBITS 16\n{geo}"),
    );
    let r = EhdrRaster::open(&tmp.join("P.HDR")).unwrap();
    assert_eq!(
        r.header().sample_type,
        SampleType::U16,
        "GDAL's default for 16 bits"
    );
    assert_rows_eq(&read_all(&r), &want);

    // BSQ: band 1, a 6-byte gap, band 2.
    let mut bsq: Vec<u8> = want
        .iter()
        .flatten()
        .flat_map(|&v| (v as u16).to_be_bytes())
        .collect();
    bsq.extend_from_slice(&[0; 6]);
    bsq.extend(std::iter::repeat_n(0x55u8, nrows * ncols * 2));
    assert_eq!(nbands, 2);
    tmp.write("S.BIL", &bsq);
    tmp.write(
        "S.HDR",
        format!("LAYOUT BSQ\nNROWS 3\nNCOLS 4\nNBANDS 2\nNBITS 16\nBANDGAPBYTES 6\n{geo}"),
    );
    let r = EhdrRaster::open(&tmp.join("S.HDR")).unwrap();
    assert_rows_eq(&read_all(&r), &want);

    // One band: BIP and BSQ are BIL.
    let one: Vec<u8> = want
        .iter()
        .flatten()
        .flat_map(|&v| (v as u16).to_be_bytes())
        .collect();
    for layout in ["BIP", "BSQ", "bil"] {
        tmp.write("O.BIL", &one);
        tmp.write(
            "O.HDR",
            format!("LAYOUT {layout}\nNROWS 3\nNCOLS 4\nNBITS 16\n{geo}"),
        );
        let r = EhdrRaster::open(&tmp.join("O.HDR")).unwrap();
        assert_rows_eq(&read_all(&r), &want);
    }
}

#[test]
fn keys_are_case_insensitive_and_unknown_keys_ignored() {
    let tmp = TempDir::new("keys");
    tmp.write("k.dem", i16_be(&[1, -2, -9999, 4]));
    tmp.write(
        "k.hdr",
        "ByteOrder m\n  nRows\t2\nNcols 2\n\nnbits 16\nNODATA_VALUE -9999\nSomeVendorKey 42 extra\n\
         ulxmap 100.25\nULYMAP -30.25\nxDim 0.5\nydim 0.5\nnrows 2\n",
    );
    let r = EhdrRaster::open(&tmp.join("k.hdr")).unwrap();
    let h = r.header();
    assert_eq!(h.sample_type, SampleType::I16);
    assert_eq!(h.nodata, Some(-9999.0));
    assert_eq!(
        (h.ulxmap, h.ulymap, h.xdim, h.ydim),
        (100.25, -30.25, 0.5, 0.5)
    );
    assert_rows_eq(&read_all(&r), &[vec![1.0, -2.0], vec![f32::NAN, 4.0]]);
}

#[test]
fn gdal_defaults() {
    let tmp = TempDir::new("defaults");
    // 16 bits, no PIXELTYPE, no NODATA: unsigned (GDAL).
    tmp.write("u.bil", i16_be(&[-1, 5]));
    tmp.write("u.hdr", "NROWS 1\nNCOLS 2\nNBITS 16\nXDIM 1\nYDIM 1\n");
    let r = EhdrRaster::open(&tmp.join("u.bil")).unwrap();
    assert_eq!(r.header().sample_type, SampleType::U16);
    assert_eq!(r.header().byte_order, ByteOrder::BigEndian);
    assert_eq!(r.value(0, 0).unwrap(), Some(65535.0));
    // ULXMAP/ULYMAP default to 0.5 (GDAL).
    assert_eq!((r.header().ulxmap, r.header().ulymap), (0.5, 0.5));

    // No NBITS, no PIXELTYPE: bytes per pixel from the file size.
    tmp.write("n2.bil", i16_be(&[-7, 5, 3]));
    tmp.write(
        "n2.hdr",
        "NROWS 1\nNCOLS 3\nNODATA -9999\nULXMAP 1\nULYMAP 1\n",
    );
    let r = EhdrRaster::open(&tmp.join("n2.hdr")).unwrap();
    assert_eq!(r.header().sample_type, SampleType::I16);
    assert_eq!(r.value(0, 0).unwrap(), Some(-7.0));
    let floats: Vec<u8> = [1.5f32, -2.25]
        .iter()
        .flat_map(|v| v.to_be_bytes())
        .collect();
    tmp.write("n4.bil", &floats);
    tmp.write("n4.hdr", "NROWS 1\nNCOLS 2\nULXMAP 1\nULYMAP 1\n");
    let r = EhdrRaster::open(&tmp.join("n4.hdr")).unwrap();
    assert_eq!(r.header().sample_type, SampleType::F32);
    assert_eq!(r.value(0, 1).unwrap(), Some(-2.25));
    // NBITS 32 in a .FLT: FLOAT.
    tmp.write("f.flt", &floats);
    tmp.write("f.hdr", "NROWS 1\nNCOLS 2\nNBITS 32\nULXMAP 1\nULYMAP 1\n");
    assert_eq!(
        EhdrRaster::open(&tmp.join("f.flt"))
            .unwrap()
            .header()
            .sample_type,
        SampleType::F32
    );
    // NBITS 32 otherwise: unsigned.
    tmp.write("g.bil", &floats);
    tmp.write("g.HDR", "NROWS 1\nNCOLS 2\nNBITS 32\nULXMAP 1\nULYMAP 1\n");
    assert_eq!(
        EhdrRaster::open(&tmp.join("g.bil"))
            .unwrap()
            .header()
            .sample_type,
        SampleType::U32
    );
    // 8 bits default unsigned; NODATA out of the type's range never matches.
    tmp.write("b.bil", [0u8, 200]);
    tmp.write(
        "b.hdr",
        "NROWS 1\nNCOLS 2\nNODATA 300\nULXMAP 1\nULYMAP 1\n",
    );
    let r = EhdrRaster::open(&tmp.join("b.bil")).unwrap();
    assert_eq!(r.header().sample_type, SampleType::U8);
    assert_eq!(r.value(0, 1).unwrap(), Some(200.0));
    // Corner / centre alternatives: XLLCORNER + YLLCORNER + CELLSIZE.
    tmp.write("c.bil", [0u8; 6]);
    tmp.write(
        "c.hdr",
        "NROWS 3\nNCOLS 2\nXLLCORNER -10\nYLLCORNER 20\nCELLSIZE 0.5\n",
    );
    let h = EhdrRaster::open(&tmp.join("c.bil"))
        .unwrap()
        .header()
        .clone();
    assert_eq!(
        (h.ulxmap, h.ulymap, h.xdim, h.ydim),
        (-9.75, 21.25, 0.5, 0.5)
    );
}

#[test]
fn float_non_finite_is_an_error_unless_declared_nodata() {
    let tmp = TempDir::new("nonfinite");
    let mut values = [1.0f32; 12];
    values[2 * 4 + 3] = f32::NAN;
    values[2 * 4 + 1] = f32::INFINITY;
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    tmp.write("F.bil", &bytes);
    let hdr = "BYTEORDER I\nNROWS 3\nNCOLS 4\nNBITS 32\nPIXELTYPE FLOAT\nULXMAP 0\nULYMAP 0\nXDIM 1\nYDIM 1\n";
    tmp.write("F.hdr", hdr);
    let r = EhdrRaster::open(&tmp.join("F.bil")).unwrap();
    let mut row = vec![0.0f32; 4];
    r.read_row(1, &mut row).unwrap();
    let e = r.read_row(2, &mut row).unwrap_err();
    let msg = e.to_string();
    eprintln!("non-finite float: {msg}");
    assert!(matches!(e, DemError::Data { .. }));
    assert!(
        msg.contains("F.bil") && msg.contains("row 2, column 1") && msg.contains("inf"),
        "{msg}"
    );
    let msg = r.value(2, 3).unwrap_err().to_string();
    assert!(
        msg.contains("row 2, column 3") && msg.contains("NaN"),
        "{msg}"
    );
    assert!(r.sample_nearest(-2.0, 3.0).is_err());
    assert_eq!(r.value(2, 2).unwrap(), Some(1.0));

    // NODATA nan: NaN is no-data; inf is still an error.
    tmp.write("F.hdr", format!("{hdr}NODATA nan\n"));
    let r = EhdrRaster::open(&tmp.join("F.bil")).unwrap();
    assert_eq!(r.value(2, 3).unwrap(), None);
    assert!(r.value(2, 1).is_err());
}

// ---------------------------------------------------------------------------------------------
// Bad input: the error variant and its message

/// GTOPO30-like header of a 3×2 i16 raster (12 bytes of data), with `edit` applied to the lines.
fn header_with(edit: &[(&str, Option<&str>)]) -> String {
    let mut lines: Vec<(String, String)> = [
        ("BYTEORDER", "M"),
        ("LAYOUT", "BIL"),
        ("NROWS", "2"),
        ("NCOLS", "3"),
        ("NBANDS", "1"),
        ("NBITS", "16"),
        ("BANDROWBYTES", "6"),
        ("TOTALROWBYTES", "6"),
        ("BANDGAPBYTES", "0"),
        ("NODATA", "-9999"),
        ("ULXMAP", "10.5"),
        ("ULYMAP", "45.5"),
        ("XDIM", "1"),
        ("YDIM", "1"),
    ]
    .iter()
    .map(|(k, v)| (k.to_string(), v.to_string()))
    .collect();
    for (key, value) in edit {
        lines.retain(|(k, _)| k != key);
        if let Some(v) = value {
            lines.push((key.to_string(), v.to_string()));
        }
    }
    lines.iter().map(|(k, v)| format!("{k} {v}\n")).collect()
}

enum Kind {
    Header(&'static str),
    Data,
    Missing,
}

fn check_error(case: &str, result: Result<EhdrRaster, DemError>, kind: Kind, needles: &[&str]) {
    let e = match result {
        Ok(r) => panic!("{case}: opened, expected an error ({:?})", r.header()),
        Err(e) => e,
    };
    let msg = e.to_string();
    eprintln!("| {case} | `{msg}` |");
    match (&kind, &e) {
        (Kind::Header(f), DemError::Header { field, .. }) => {
            assert_eq!(field, f, "{case}: {msg}");
            assert!(msg.contains(&format!("field {f}")), "{case}: {msg}");
        }
        (Kind::Data, DemError::Data { .. }) | (Kind::Missing, DemError::Missing { .. }) => {}
        _ => panic!("{case}: unexpected variant {e:?}"),
    }
    for n in needles {
        assert!(msg.contains(n), "{case}: message lacks {n:?}: {msg}");
    }
}

#[test]
fn bad_headers_give_clear_errors() {
    let tmp = TempDir::new("bad");
    let data = i16_be(&[1, 2, 3, 4, 5, 6]);
    type Case = (
        &'static str,
        Vec<(&'static str, Option<&'static str>)>,
        Kind,
        Vec<&'static str>,
    );
    let cases: Vec<Case> = vec![
        (
            "LAYOUT XYZ",
            vec![("LAYOUT", Some("XYZ"))],
            Kind::Header("LAYOUT"),
            vec!["\"XYZ\"", "expected BIL, BIP or BSQ"],
        ),
        (
            "NBITS 12",
            vec![("NBITS", Some("12"))],
            Kind::Header("NBITS"),
            vec!["12", "expected 8, 16 or 32"],
        ),
        (
            "NBITS 4",
            vec![("NBITS", Some("4"))],
            Kind::Header("NBITS"),
            vec!["expected 8, 16 or 32"],
        ),
        (
            "NBITS 64",
            vec![("NBITS", Some("64"))],
            Kind::Header("NBITS"),
            vec!["64"],
        ),
        (
            "NBITS sixteen",
            vec![("NBITS", Some("sixteen"))],
            Kind::Header("NBITS"),
            vec!["expected an integer", "\"sixteen\""],
        ),
        (
            "PIXELTYPE COMPLEX",
            vec![("PIXELTYPE", Some("COMPLEX"))],
            Kind::Header("PIXELTYPE"),
            vec!["\"COMPLEX\"", "SIGNEDINT, UNSIGNEDINT or FLOAT"],
        ),
        (
            "FLOAT with NBITS 16",
            vec![("PIXELTYPE", Some("FLOAT"))],
            Kind::Header("NBITS"),
            vec!["FLOAT needs NBITS 32", "16"],
        ),
        (
            "BYTEORDER X",
            vec![("BYTEORDER", Some("X"))],
            Kind::Header("BYTEORDER"),
            vec!["\"X\"", "expected M (big-endian) or I (little-endian)"],
        ),
        (
            "NROWS 0",
            vec![("NROWS", Some("0"))],
            Kind::Header("NROWS"),
            vec!["expected a positive integer", "found 0"],
        ),
        (
            "NROWS -5",
            vec![("NROWS", Some("-5"))],
            Kind::Header("NROWS"),
            vec!["found -5"],
        ),
        (
            "NROWS 2.5",
            vec![("NROWS", Some("2.5"))],
            Kind::Header("NROWS"),
            vec!["expected an integer", "\"2.5\""],
        ),
        (
            "NCOLS 0",
            vec![("NCOLS", Some("0"))],
            Kind::Header("NCOLS"),
            vec!["expected a positive integer"],
        ),
        (
            "NCOLS huge",
            vec![("NCOLS", Some("99999999999"))],
            Kind::Header("NCOLS"),
            vec!["no larger than 2147483647"],
        ),
        (
            "NROWS missing",
            vec![("NROWS", None)],
            Kind::Header("NROWS"),
            vec!["missing required field"],
        ),
        (
            "NCOLS missing",
            vec![("NCOLS", None)],
            Kind::Header("NCOLS"),
            vec!["missing required field"],
        ),
        (
            "NROWS without value",
            vec![("NROWS", Some(""))],
            Kind::Header("NROWS"),
            vec!["has no value"],
        ),
        (
            "NROWS twice",
            vec![("NROWS", Some("2\nNROWS 3"))],
            Kind::Header("NROWS"),
            vec!["given twice", "\"2\"", "\"3\""],
        ),
        (
            "XDIM 0",
            vec![("XDIM", Some("0"))],
            Kind::Header("XDIM"),
            vec!["expected a pixel size in degrees > 0", "found 0"],
        ),
        (
            "XDIM -0.5",
            vec![("XDIM", Some("-0.5"))],
            Kind::Header("XDIM"),
            vec!["found -0.5"],
        ),
        (
            "XDIM nan",
            vec![("XDIM", Some("nan"))],
            Kind::Header("XDIM"),
            vec!["found NaN"],
        ),
        (
            "YDIM 0",
            vec![("YDIM", Some("0"))],
            Kind::Header("YDIM"),
            vec!["> 0"],
        ),
        (
            "ULXMAP abc",
            vec![("ULXMAP", Some("abc"))],
            Kind::Header("ULXMAP"),
            vec!["expected a number"],
        ),
        (
            "ULYMAP inf",
            vec![("ULYMAP", Some("inf"))],
            Kind::Header("ULYMAP"),
            vec!["expected a finite number"],
        ),
        (
            "no georeferencing",
            vec![
                ("ULXMAP", None),
                ("ULYMAP", None),
                ("XDIM", None),
                ("YDIM", None),
            ],
            Kind::Header("ULXMAP"),
            vec!["no georeferencing"],
        ),
        (
            "projected (UTM metres)",
            vec![
                ("ULYMAP", Some("4500000")),
                ("ULXMAP", Some("500000")),
                ("XDIM", Some("30")),
                ("YDIM", Some("30")),
            ],
            Kind::Header("ULYMAP"),
            vec!["expected them within [-90°, 90°]", "geographic"],
        ),
        (
            "wider than 360°",
            vec![("XDIM", Some("150"))],
            Kind::Header("XDIM"),
            vec!["450° wide", "at most 360°"],
        ),
        (
            "BANDROWBYTES too small",
            vec![("BANDROWBYTES", Some("4"))],
            Kind::Header("BANDROWBYTES"),
            vec!["less than NCOLS 3 × 2 bytes = 6"],
        ),
        (
            "TOTALROWBYTES too small",
            vec![("TOTALROWBYTES", Some("5"))],
            Kind::Header("TOTALROWBYTES"),
            vec!["expected at least 6"],
        ),
        (
            "BANDGAPBYTES in BIL",
            vec![("BANDGAPBYTES", Some("8"))],
            Kind::Header("BANDGAPBYTES"),
            vec!["applies to LAYOUT BSQ only"],
        ),
        (
            "SKIPBYTES -1",
            vec![("SKIPBYTES", Some("-1"))],
            Kind::Header("SKIPBYTES"),
            vec!["expected a non-negative integer"],
        ),
        (
            "XLLCORNER and ULXMAP",
            vec![("XLLCORNER", Some("10"))],
            Kind::Header("ULXMAP"),
            vec!["ULXMAP and XLLCORNER both given"],
        ),
        (
            "CELLSIZE vs XDIM",
            vec![("CELLSIZE", Some("2"))],
            Kind::Header("XDIM"),
            vec!["disagrees with CELLSIZE 2"],
        ),
    ];
    for (case, edit, kind, needles) in cases {
        tmp.write("T.DEM", &data);
        let hdr = tmp.write("T.HDR", header_with(&edit));
        let mut needles = needles;
        needles.push("T.HDR");
        check_error(case, EhdrRaster::open(&hdr), kind, &needles);
    }

    // Data file size.
    tmp.write("T.HDR", header_with(&[]));
    tmp.write("T.DEM", &data[..10]);
    check_error(
        "data file 2 bytes short",
        EhdrRaster::open(&tmp.join("T.HDR")),
        Kind::Data,
        &[
            "T.DEM",
            "is 10 bytes",
            "T.HDR implies exactly 12 bytes",
            "NROWS 2 × TOTALROWBYTES 6",
            "shorter",
        ],
    );
    tmp.write("T.DEM", [data.as_slice(), &[0, 0]].concat());
    check_error(
        "data file 2 bytes long",
        EhdrRaster::open(&tmp.join("T.HDR")),
        Kind::Data,
        &[
            "T.DEM",
            "is 14 bytes",
            "exactly 12 bytes",
            "2 bytes longer",
            "GDAL tolerates",
        ],
    );
    tmp.write("T.HDR", header_with(&[("SKIPBYTES", Some("4"))]));
    tmp.write("T.DEM", &data);
    check_error(
        "SKIPBYTES not in the file",
        EhdrRaster::open(&tmp.join("T.DEM")),
        Kind::Data,
        &[
            "SKIPBYTES 4 + NROWS 2 × TOTALROWBYTES 6",
            "exactly 16 bytes",
        ],
    );
    tmp.write(
        "T.HDR",
        header_with(&[("NBANDS", Some("2")), ("TOTALROWBYTES", Some("12"))]),
    );
    check_error(
        "NBANDS 2 but one band of data",
        EhdrRaster::open(&tmp.join("T.DEM")),
        Kind::Data,
        &["NROWS 2 × TOTALROWBYTES 12", "exactly 24 bytes", "shorter"],
    );

    // Missing files.
    let lonely = TempDir::new("missing");
    lonely.write("W020N40.DEM", &data);
    check_error(
        "missing .HDR",
        EhdrRaster::open(&lonely.join("W020N40.DEM")),
        Kind::Missing,
        &[
            "W020N40.HDR",
            "header file missing",
            "next to data file W020N40.DEM",
        ],
    );
    lonely.write("E020N40.HDR", header_with(&[]));
    check_error(
        "missing .DEM",
        EhdrRaster::open(&lonely.join("E020N40.HDR")),
        Kind::Missing,
        &["E020N40.HDR", "data file missing", "expected E020N40.DEM"],
    );
    check_error(
        "no such file",
        EhdrRaster::open(&lonely.join("NOPE.HDR")),
        Kind::Missing,
        &["NOPE.HDR", "not found"],
    );
    lonely.write("E020N40.DEM", &data);
    lonely.write("E020N40.BIL", &data);
    check_error(
        "two data files",
        EhdrRaster::open(&lonely.join("E020N40.HDR")),
        Kind::Data,
        &["E020N40.HDR", "ambiguous", "E020N40.BIL", "E020N40.DEM"],
    );
    lonely.write("BIG.HDR", vec![b'x'; 100_000]);
    lonely.write("BIG.DEM", &data);
    check_error(
        "100 kB binary header",
        EhdrRaster::open(&lonely.join("BIG.DEM")),
        Kind::Header("(file)"),
        &["BIG.HDR", "100000 bytes"],
    );
}

/// A small deterministic generator (xorshift64*), so failures reproduce.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }

    fn pick<'a>(&mut self, items: &[&'a str]) -> &'a str {
        items[self.below(items.len())]
    }
}

#[test]
fn garbage_headers_never_panic() {
    let tmp = TempDir::new("fuzz");
    let keys = [
        "BYTEORDER",
        "LAYOUT",
        "NROWS",
        "NCOLS",
        "NBANDS",
        "NBITS",
        "PIXELTYPE",
        "BANDROWBYTES",
        "TOTALROWBYTES",
        "BANDGAPBYTES",
        "SKIPBYTES",
        "NODATA",
        "NODATA_VALUE",
        "ULXMAP",
        "ULYMAP",
        "XDIM",
        "YDIM",
        "XLLCORNER",
        "YLLCORNER",
        "XLLCENTER",
        "YLLCENTER",
        "CELLSIZE",
        "nrows",
        "Junk",
        "",
    ];
    let values = [
        "0",
        "1",
        "2",
        "3",
        "-1",
        "7",
        "8",
        "16",
        "32",
        "64",
        "255",
        "65535",
        "4294967296",
        "9223372036854775807",
        "-9223372036854775808",
        "99999999999999999999",
        "1e308",
        "-1e308",
        "nan",
        "inf",
        "-inf",
        "0.5",
        "-0.5",
        "1e-300",
        "0.00833333333333",
        "-9999",
        "M",
        "I",
        "L",
        "X",
        "BIL",
        "BIP",
        "BSQ",
        "SIGNEDINT",
        "UNSIGNEDINT",
        "FLOAT",
        "",
        "\u{0}",
        "é",
        "2147483647",
        "2147483648",
        "90",
        "-90",
        "180",
        "360",
        "-360",
        "1.5",
    ];
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut opened = 0;
    let mut errors = 0;
    for i in 0..3000 {
        let text: String = if i % 10 == 9 {
            // Raw bytes.
            let n = rng.below(300);
            let bytes: Vec<u8> = (0..n).map(|_| rng.next() as u8).collect();
            String::from_utf8_lossy(&bytes).into_owned()
        } else {
            // A valid small header, mutated.
            let mut lines: Vec<String> = header_with(&[]).lines().map(String::from).collect();
            for _ in 0..1 + rng.below(4) {
                let line = format!("{} {}", rng.pick(&keys), rng.pick(&values));
                match rng.below(3) {
                    0 if !lines.is_empty() => {
                        let k = rng.below(lines.len());
                        lines[k] = line;
                    }
                    1 if !lines.is_empty() => {
                        let k = rng.below(lines.len());
                        lines.remove(k);
                    }
                    _ => lines.push(line),
                }
            }
            lines.join(if rng.below(4) == 0 { "\r\n" } else { "\n" })
        };
        let len = match rng.below(4) {
            0 => rng.below(64),
            _ => 12,
        };
        let data: Vec<u8> = (0..len).map(|_| rng.next() as u8).collect();
        tmp.write("Z.HDR", &text);
        tmp.write("Z.BIL", &data);
        let _ = EhdrHeader::parse(&text, &tmp.join("Z.HDR"));
        match EhdrRaster::open(&tmp.join("Z.BIL")) {
            Err(e) => {
                assert!(!e.to_string().is_empty());
                errors += 1;
            }
            Ok(r) => {
                opened += 1;
                let g = r.grid();
                let mut row = vec![0.0; g.cols];
                for rr in 0..g.rows {
                    let _ = r.read_row(rr, &mut row);
                }
                assert!(r.read_row(g.rows, &mut row).is_err());
                assert!(r.value(0, g.cols).is_err());
                for (lat, lon) in [(0.0, 0.0), (45.5, 10.5), (-90.0, 540.0), (1e300, -1e300)] {
                    let _ = r.sample_nearest(lat, lon);
                    let _ = r.sample_bilinear(lat, lon);
                }
                let _ = r.describe();
            }
        }
    }
    eprintln!("garbage headers: {opened} opened, {errors} rejected, no panic");
    assert!(
        opened > 50 && errors > 1000,
        "{opened} opened, {errors} rejected"
    );
}

#[test]
fn sources_are_send_and_sync() {
    fn is_source<T: RasterSource + Send + Sync>() {}
    is_source::<EhdrRaster>();
    is_source::<EhdrMosaic>();
}

// ---------------------------------------------------------------------------------------------
// Cross-check against GDAL

fn gdallocationinfo_available() -> bool {
    std::process::Command::new("gdallocationinfo")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// Points covering a tile, in (row, col) pixel coordinates: corner and edge pixel centres,
/// points a quarter pixel inside and outside the outer edges (all along them), points exactly on
/// the outer edges and on inner pixel edges, and pseudo-random interior points.
fn probe_points(grid: &GeoGrid, rng: &mut Rng, random: usize) -> Vec<(f64, f64)> {
    let (rows, cols) = (grid.rows as f64, grid.cols as f64);
    let mut rc: Vec<(f64, f64)> = Vec::new();
    for (r, c) in [
        (0.0, 0.0),
        (0.0, cols - 1.0),
        (rows - 1.0, 0.0),
        (rows - 1.0, cols - 1.0),
    ] {
        rc.push((r, c));
        for (dr, dc) in [(-0.5, -0.5), (-0.5, 0.5), (0.5, -0.5), (0.5, 0.5)] {
            rc.push((r + dr, c + dc)); // the corner's four pixel corners
            rc.push((r + 0.5 * dr, c + 0.5 * dc)); // inside / outside by a quarter pixel
            rc.push((r + 1.5 * dr, c + 1.5 * dc));
        }
    }
    for k in 0..=40 {
        let t = k as f64 / 40.0;
        let (r, c) = (t * (rows - 1.0), t * (cols - 1.0));
        for d in [-0.75, -0.5, -0.25] {
            rc.extend([(d, c), (rows - 1.0 - d, c), (r, d), (r, cols - 1.0 - d)]);
        }
        rc.extend([
            (0.0, c.round()),
            (rows - 1.0, c.round()),
            (r.round(), 0.0),
            (r.round(), cols - 1.0),
        ]);
    }
    for _ in 0..random {
        let r = (rng.next() % 1_000_000) as f64 / 1e6 * rows - 0.5;
        let c = (rng.next() % 1_000_000) as f64 / 1e6 * cols - 0.5;
        rc.push((r, c));
        // Exactly on an inner pixel edge (as exactly as f64 allows).
        let (ri, ci) = (
            rng.below(grid.rows - 1) as f64,
            rng.below(grid.cols - 1) as f64,
        );
        rc.push((ri + 0.5, ci + 0.5));
        rc.push((ri, ci + 0.5));
    }
    rc
}

#[test]
fn gdal_cross_check_gtopo30_shapes() {
    if !gdallocationinfo_available() {
        assert!(
            std::env::var("GLOBE_REQUIRE_DATA").as_deref() != Ok("1"),
            "GLOBE_REQUIRE_DATA=1 but gdallocationinfo is missing (apt-get install gdal-bin)"
        );
        eprintln!("SKIPPED: gdallocationinfo not found (apt-get install gdal-bin)");
        return;
    }
    let tmp = TempDir::new("gdal");
    let mut rng = Rng(0xD1B5_4A32_D192_ED03);
    let tiles = [
        (
            "W020N40",
            gtopo_grid(-19.99583333333333, 39.99583333333333, 4800, 6000),
        ),
        (
            "W060S60",
            gtopo_grid(-59.99583333333333, -60.00416666666667, 7200, 3600),
        ),
    ];
    for (name, grid) in tiles {
        let hdr = write_gtopo_tile(tmp.path(), name, &grid);
        if name == "W020N40" {
            std::fs::write(&hdr, W020N40_HDR).unwrap(); // GTOPO30's own header text
        }
        let data = tmp.join(&format!("{name}.DEM"));
        let r = EhdrRaster::open(&data).unwrap();
        let (r0, c0) = tile_origin(&grid);
        let rc = probe_points(&grid, &mut rng, 2000);
        let points: Vec<(f64, f64)> = rc
            .iter()
            .map(|&(row, col)| (grid.lat_of_row(row), grid.lon_of_col(col)))
            .collect();
        let gdal = gdal_common::gdal_values(&data, &points);
        assert_eq!(
            gdal.len(),
            points.len(),
            "{name}: one line per point from GDAL"
        );
        let (mut inside, mut outside, mut nodata) = (0, 0, 0);
        for ((&(lat, lon), &(row, col)), g) in points.iter().zip(&rc).zip(&gdal) {
            // GDAL prints the stored value (NODATA included) or an empty line off the file.
            let ours = match (r.pixel_of(lat, lon), r.sample_nearest(lat, lon).unwrap()) {
                (None, _) => {
                    outside += 1;
                    String::new()
                }
                (Some(_), Some(v)) => {
                    inside += 1;
                    format!("{v}")
                }
                (Some((pr, pc)), None) => {
                    assert!(global_value(r0 + pr as i64, c0 + pc as i64).is_nan());
                    nodata += 1;
                    "-9999".to_string()
                }
            };
            assert_eq!(
                &ours, g,
                "{name}: pixel coordinate ({row}, {col}) = lat {lat}, lon {lon}: ours {ours:?}, \
                 GDAL {g:?}"
            );
        }
        eprintln!(
            "GDAL cross-check {name}: all {} points agree ({inside} values, {nodata} NODATA, \
             {outside} off the tile)",
            points.len()
        );
        assert!(inside > 3000 && outside > 100 && nodata > 100);
    }
}
