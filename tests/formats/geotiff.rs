//! GeoTIFF / COG import (issue 15 items 3 and 4): files written by GDAL itself from ETOPO5
//! (`gdal_translate -of GTiff` in strips and tiles, Deflate/LZW/none, Int16/UInt16/Float32,
//! `-of COG`), read by globe and compared with `gdallocationinfo` at the corners, along every
//! edge and at seeded random points; and the bad inputs, each a clear error.
//!
//! Needs GDAL's command-line tools and ETOPO5 (Debian `gdal-bin`, `ferret-datasets`): without
//! them the GDAL tests are skipped, unless `GLOBE_REQUIRE_DATA=1` makes that a failure.

use crate::common::gdal as gdal_common;

use std::path::{Path, PathBuf};

use gdal_common::{Agreement, Rng, compare_with_gdal, etopo5, gdal, gdal_ready};
use globe::dem::pyramid::{Pyramid, PyramidBuilder};
use globe::dem::{DemError, GeoTiffRaster, RasterSource};

/// A small window of the Alps and the Po plain (all land: UInt16 holds it), resampled from
/// ETOPO5 to 97 × 61 pixels so strips and tiles end part-way.
const WINDOW: [&str; 8] = ["-projwin", "8", "47", "12", "45", "-outsize", "97", "61"];

fn translate(dir: &Path, name: &str, args: &[&str]) -> PathBuf {
    let out = dir.join(name);
    let mut all: Vec<String> = vec!["-q".into()];
    all.extend(WINDOW.iter().map(|s| s.to_string()));
    all.extend(["-r", "bilinear", "-a_srs", "EPSG:4326"].map(String::from));
    all.extend(args.iter().map(|s| s.to_string()));
    all.push(etopo5().display().to_string());
    all.push(out.display().to_string());
    gdal("gdal_translate", &all);
    out
}

/// The GDAL-written variants: (file name, gdal_translate options, what it exercises).
const VARIANTS: &[(&str, &[&str])] = &[
    (
        "int16-deflate-strips.tif",
        &[
            "-ot",
            "Int16",
            "-co",
            "COMPRESS=DEFLATE",
            "-co",
            "BLOCKYSIZE=7",
        ],
    ),
    (
        "uint16-lzw-predictor-strips.tif",
        &[
            "-ot",
            "UInt16",
            "-co",
            "COMPRESS=LZW",
            "-co",
            "PREDICTOR=2",
            "-co",
            "BLOCKYSIZE=5",
        ],
    ),
    (
        "float32-deflate-fp-predictor-tiles.tif",
        &[
            "-ot",
            "Float32",
            "-co",
            "TILED=YES",
            "-co",
            "BLOCKXSIZE=16",
            "-co",
            "BLOCKYSIZE=16",
            "-co",
            "COMPRESS=DEFLATE",
            "-co",
            "PREDICTOR=3",
        ],
    ),
    (
        "int16-lzw-tiles.tif",
        &[
            "-ot",
            "Int16",
            "-co",
            "TILED=YES",
            "-co",
            "BLOCKXSIZE=32",
            "-co",
            "BLOCKYSIZE=16",
            "-co",
            "COMPRESS=LZW",
        ],
    ),
    (
        "int16-big-endian-uncompressed.tif",
        &[
            "-ot",
            "Int16",
            "-co",
            "ENDIANNESS=BIG",
            "-co",
            "BLOCKYSIZE=9",
        ],
    ),
    (
        "float32-uncompressed-tiles.tif",
        &[
            "-ot",
            "Float32",
            "-co",
            "TILED=YES",
            "-co",
            "BLOCKXSIZE=16",
            "-co",
            "BLOCKYSIZE=32",
        ],
    ),
    (
        "uint16-pixel-is-point.tif",
        &[
            "-ot",
            "UInt16",
            "-mo",
            "AREA_OR_POINT=Point",
            "-co",
            "COMPRESS=DEFLATE",
        ],
    ),
    (
        "cog-int16-deflate.tif",
        &[
            "-of",
            "COG",
            "-ot",
            "Int16",
            "-co",
            "COMPRESS=DEFLATE",
            "-co",
            "BLOCKSIZE=32",
        ],
    ),
    (
        "cog-float32-lzw.tif",
        &[
            "-of",
            "COG",
            "-ot",
            "Float32",
            "-co",
            "COMPRESS=LZW",
            "-co",
            "PREDICTOR=YES",
            "-co",
            "BLOCKSIZE=16",
        ],
    ),
];

#[test]
fn gdal_written_geotiffs_agree_with_gdallocationinfo() {
    if !gdal_ready() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let mut rng = Rng(0x6765_6f74_6966_6615);
    let mut total = Agreement::default();
    let mut area_grid = None;
    for (name, args) in VARIANTS {
        let file = translate(tmp.path(), name, args);
        let raster = GeoTiffRaster::open(&file).unwrap_or_else(|e| panic!("{name}: {e}"));
        let g = raster.grid();
        assert_eq!((g.cols, g.rows), (97, 61), "{name}");
        if name.starts_with("cog") {
            assert!(raster.tiled(), "{name}: a COG is tiled");
        }
        if name.contains("point") {
            // GDAL moves the tiepoint to the pixel centre; read back, it is the same grid.
            assert!(raster.pixel_is_point(), "{name}: GDAL wrote PixelIsPoint");
            let a: globe::dem::GeoGrid = area_grid.expect("an area file first");
            assert!(
                (g.lon0_deg - a.lon0_deg).abs() < 1e-9 * a.dlon_deg
                    && (g.lat0_deg - a.lat0_deg).abs() < 1e-9 * a.dlat_deg,
                "{name}: {g:?} against PixelIsArea {a:?}"
            );
        } else {
            assert!(!raster.pixel_is_point(), "{name}");
            area_grid.get_or_insert(g);
        }
        let a = compare_with_gdal(&raster, &file, &mut rng, 400);
        eprintln!(
            "GDAL agreement {name} ({}): {} points ({} pixel centres on the edges and \
             corners), max |difference| {} m, {} no data",
            raster.describe(),
            a.points,
            a.edge_points,
            a.max_diff,
            a.nodata
        );
        assert_eq!(a.max_diff, 0.0, "{name}: globe and GDAL differ");
        assert_eq!(a.mismatched_nodata, 0, "{name}: no-data disagrees");
        total.add(&a);
    }
    eprintln!(
        "GDAL agreement, all GeoTIFF/COG variants: {} points, max |difference| {} m",
        total.points, total.max_diff
    );
}

/// GDAL_NODATA: the value of a pixel made the no-data value reads as NaN wherever it occurs,
/// as GDAL reports its no-data value there.
#[test]
fn gdal_nodata_reads_as_no_data() {
    if !gdal_ready() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let plain = translate(tmp.path(), "plain.tif", &["-ot", "Int16"]);
    let first = {
        let r = GeoTiffRaster::open(&plain).unwrap();
        let mut row = vec![0f32; r.grid().cols];
        r.read_row(0, &mut row).unwrap();
        row[0]
    };
    let nodata = format!("{first}");
    let file = translate(
        tmp.path(),
        "nodata.tif",
        &[
            "-ot",
            "Int16",
            "-a_nodata",
            &nodata,
            "-co",
            "COMPRESS=DEFLATE",
        ],
    );
    let raster = GeoTiffRaster::open(&file).unwrap();
    assert_eq!(raster.nodata(), Some(first as f64));
    let a = compare_with_gdal(&raster, &file, &mut Rng(7), 200);
    assert!(a.nodata >= 1, "pixel (0, 0) is no data");
    assert_eq!((a.max_diff, a.mismatched_nodata), (0.0, 0));
}

/// `globe-data import` path: a GDAL COG into a pyramid, level 0 equal to the raster.
#[test]
fn cog_imports_into_a_pyramid_equal_at_level_0() {
    if !gdal_ready() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let file = translate(
        tmp.path(),
        "cog.tif",
        &[
            "-of",
            "COG",
            "-ot",
            "Int16",
            "-co",
            "COMPRESS=DEFLATE",
            "-co",
            "BLOCKSIZE=32",
        ],
    );
    let source = globe::dem::open_raster(&file, None).unwrap();
    let out = tmp.path().join("cog.globepyr");
    PyramidBuilder::new()
        .tile_size(32)
        .build(source.as_ref(), &out)
        .unwrap();
    let p = Pyramid::open(&out).unwrap();
    let g = source.grid();
    let mut row = vec![0f32; g.cols];
    for r in (0..g.rows).step_by(7) {
        source.read_row(r, &mut row).unwrap();
        for c in (0..g.cols).step_by(5) {
            let h = p
                .sample(g.lat_of_row(r as f64), g.lon_of_col(c as f64), 0)
                .unwrap();
            assert_eq!(h, row[c] as f64, "row {r}, column {c}");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Bad input: each a clear error naming the file and the field
// ---------------------------------------------------------------------------------------------

fn open_err(file: &Path) -> String {
    let e = GeoTiffRaster::open(file).expect_err("must be refused");
    let text = e.to_string();
    assert!(
        text.contains(&file.display().to_string()),
        "the error names the file: {text}"
    );
    text
}

#[test]
fn projected_crs_is_refused_naming_it() {
    if !gdal_ready() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let geo = translate(tmp.path(), "geo.tif", &["-ot", "Int16"]);
    let utm = tmp.path().join("utm.tif");
    gdal(
        "gdalwarp",
        &[
            "-q",
            "-t_srs",
            "EPSG:32632",
            "-ts",
            "40",
            "30",
            geo.to_str().unwrap(),
            utm.to_str().unwrap(),
        ],
    );
    let text = open_err(&utm);
    assert!(text.contains("EPSG:32632"), "names the CRS: {text}");
    assert!(
        text.contains("ProjectedCSTypeGeoKey"),
        "names the field: {text}"
    );
    assert!(text.contains("geographic"), "says what globe needs: {text}");
}

#[test]
fn compressions_the_build_lacks_are_refused_naming_them() {
    if !gdal_ready() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    for (name, args, expect) in [
        (
            "zstd.tif",
            vec!["-ot", "Int16", "-co", "COMPRESS=ZSTD"],
            "ZSTD (50000)",
        ),
        (
            "jpeg.tif",
            vec!["-ot", "Byte", "-co", "COMPRESS=JPEG"],
            "JPEG (7)",
        ),
    ] {
        let file = translate(tmp.path(), name, &args);
        let text = open_err(&file);
        assert!(
            text.contains("Compression") && text.contains(expect),
            "{text}"
        );
    }
}

#[test]
fn unsupported_sample_types_are_refused() {
    if !gdal_ready() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    for ty in ["Byte", "Int32", "Float64"] {
        let file = translate(tmp.path(), &format!("{ty}.tif"), &["-ot", ty]);
        let text = open_err(&file);
        assert!(
            text.contains("SampleFormat") && text.contains("expected Int16, UInt16 or Float32"),
            "{ty}: {text}"
        );
    }
}

#[test]
fn a_truncated_strip_is_refused_at_open() {
    if !gdal_ready() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    for args in [
        vec![
            "-ot",
            "Int16",
            "-co",
            "COMPRESS=DEFLATE",
            "-co",
            "BLOCKYSIZE=7",
        ],
        vec!["-ot", "Int16", "-co", "BLOCKYSIZE=7"],
    ] {
        let file = translate(tmp.path(), "whole.tif", &args);
        let bytes = std::fs::read(&file).unwrap();
        // GDAL writes the IFD first and the strips after it: cut into the last strip.
        let cut = tmp.path().join("cut.tif");
        std::fs::write(&cut, &bytes[..bytes.len() - 40]).unwrap();
        let err = GeoTiffRaster::open(&cut).expect_err("truncated");
        assert!(
            matches!(err, DemError::Truncated { .. }),
            "a Truncated error: {err}"
        );
        let text = err.to_string();
        assert!(
            text.contains("strip") && text.contains("StripByteCounts"),
            "names the strip and the field: {text}"
        );
        // What `--dem` and `globe-data import` open: the same error, before any import.
        assert!(globe::dem::open_raster(&cut, None).is_err());
    }
}

/// A strip whose bytes are all there but whose compressed stream is corrupt fails while the
/// pyramid is being built: the error names the strip, and no file is left behind.
#[test]
fn a_corrupt_strip_fails_the_import_and_leaves_nothing() {
    if !gdal_ready() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let file = translate(
        tmp.path(),
        "deflate.tif",
        &[
            "-ot",
            "Int16",
            "-co",
            "COMPRESS=DEFLATE",
            "-co",
            "BLOCKYSIZE=7",
        ],
    );
    let mut bytes = std::fs::read(&file).unwrap();
    let n = bytes.len();
    // The last strip's stream: garbage in place of its end.
    for b in &mut bytes[n - 60..n - 2] {
        *b = 0xA5;
    }
    let bad = tmp.path().join("bad.tif");
    std::fs::write(&bad, &bytes).unwrap();
    let source = GeoTiffRaster::open(&bad).expect("the layout is intact");
    let out = tmp.path().join("bad.globepyr");
    let err = PyramidBuilder::new()
        .tile_size(32)
        .build(&source, &out)
        .expect_err("a corrupt strip");
    let text = err.to_string();
    assert!(
        text.contains("strip 8") && text.contains("bad.tif"),
        "{text}"
    );
    assert!(!out.exists(), "no pyramid left behind");
    let partial = tmp.path().join("bad.globepyr.partial");
    assert!(!partial.exists(), "no partial file left behind");
}

#[test]
fn not_a_tiff_and_no_georeferencing_are_refused_but_no_crs_is_taken_as_lat_lon() {
    let tmp = tempfile::tempdir().unwrap();
    let junk = tmp.path().join("junk.tif");
    std::fs::write(&junk, b"not a tiff at all").unwrap();
    let text = open_err(&junk);
    assert!(text.contains("byte order"), "{text}");
    if !gdal_ready() {
        return;
    }
    // A plain TIFF, no GeoTIFF tags.
    let plain = translate(
        tmp.path(),
        "plain.tif",
        &["-ot", "Int16", "-co", "PROFILE=BASELINE"],
    );
    let text = open_err(&plain);
    // A georeferenced file without a CRS (ETOPO5's netCDF has none, so GDAL writes none).
    let no_crs = tmp.path().join("no-crs.tif");
    gdal(
        "gdal_translate",
        &[
            "-q",
            "-ot",
            "Int16",
            "-srcwin",
            "100",
            "500",
            "40",
            "30",
            etopo5().to_str().unwrap(),
            no_crs.to_str().unwrap(),
        ],
    );
    let r = GeoTiffRaster::open(&no_crs).unwrap();
    assert!(r.crs().contains("no CRS"), "{}", r.crs());
    assert!(
        text.contains("ModelPixelScale") && text.contains("not georeferenced"),
        "{text}"
    );
}

/// A header claiming 2³¹ × 2³¹ pixels in one strip of a few bytes is refused at open, before
/// anything the size of the claim is allocated.
#[test]
fn a_huge_claim_is_refused_before_allocating() {
    let mut t = Vec::new();
    t.extend_from_slice(b"II*\0");
    t.extend_from_slice(&8u32.to_le_bytes());
    let entries: &[(u16, u16, u32, u32)] = &[
        (256, 4, 1, 1 << 31),
        (257, 4, 1, 1 << 31),
        (258, 3, 1, 16),
        (259, 3, 1, 8),
        (273, 4, 1, 200),
        (277, 3, 1, 1),
        (278, 4, 1, 1 << 31),
        (279, 4, 1, 10),
        (339, 3, 1, 2),
    ];
    t.extend_from_slice(&(entries.len() as u16).to_le_bytes());
    for &(tag, typ, count, value) in entries {
        t.extend_from_slice(&tag.to_le_bytes());
        t.extend_from_slice(&typ.to_le_bytes());
        t.extend_from_slice(&count.to_le_bytes());
        t.extend_from_slice(&value.to_le_bytes());
    }
    t.extend_from_slice(&0u32.to_le_bytes());
    t.resize(256, 0);
    let e = GeoTiffRaster::from_bytes(t, "huge.tif").expect_err("refused");
    let text = e.to_string();
    assert!(text.contains("huge.tif"), "{text}");
}

/// A little-endian, uncompressed Int16 GeoTIFF of 3 × 2 pixels with the given extra entries
/// (tag, type, values as little-endian bytes), for the georeferencing forms GDAL writes rarely.
fn tiny_tiff(extra: &[(u16, u16, Vec<u8>)]) -> Vec<u8> {
    let pixels: [i16; 6] = [1, 2, 3, 4, 5, 6];
    let mut entries: Vec<(u16, u16, Vec<u8>)> = vec![
        (256, 3, 3u16.to_le_bytes().to_vec()),
        (257, 3, 2u16.to_le_bytes().to_vec()),
        (258, 3, 16u16.to_le_bytes().to_vec()),
        (259, 3, 1u16.to_le_bytes().to_vec()),
        (273, 4, vec![]), // patched below: the data's offset
        (277, 3, 1u16.to_le_bytes().to_vec()),
        (278, 3, 2u16.to_le_bytes().to_vec()),
        (279, 4, 12u32.to_le_bytes().to_vec()),
        (339, 3, 2u16.to_le_bytes().to_vec()),
    ];
    entries.extend(extra.iter().cloned());
    entries.sort_by_key(|e| e.0);
    let size = |typ: u16| match typ {
        3 => 2,
        4 => 4,
        12 => 8,
        _ => 1,
    };
    let ifd_len = 2 + 12 * entries.len() + 4;
    let mut blobs: Vec<u8> = Vec::new();
    let blob_base = 8 + ifd_len;
    let data_at = blob_base + entries.iter().map(|e| e.2.len() + 8).sum::<usize>();
    let mut t = Vec::new();
    t.extend_from_slice(b"II*\0");
    t.extend_from_slice(&8u32.to_le_bytes());
    t.extend_from_slice(&(entries.len() as u16).to_le_bytes());
    for (tag, typ, value) in &entries {
        let value = if *tag == 273 {
            (data_at as u32).to_le_bytes().to_vec()
        } else {
            value.clone()
        };
        t.extend_from_slice(&tag.to_le_bytes());
        t.extend_from_slice(&typ.to_le_bytes());
        t.extend_from_slice(&((value.len() / size(*typ)) as u32).to_le_bytes());
        if value.len() <= 4 {
            let mut v = value.clone();
            v.resize(4, 0);
            t.extend_from_slice(&v);
        } else {
            t.extend_from_slice(&((blob_base + blobs.len()) as u32).to_le_bytes());
            blobs.extend_from_slice(&value);
        }
    }
    t.extend_from_slice(&0u32.to_le_bytes());
    t.extend_from_slice(&blobs);
    t.resize(data_at, 0);
    for p in pixels {
        t.extend_from_slice(&p.to_le_bytes());
    }
    t
}

fn doubles(v: &[f64]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

fn shorts(v: &[u16]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// GeoKeys: geographic model, the raster type (1 area, 2 point), EPSG:4326.
fn geokeys(raster_type: u16) -> (u16, u16, Vec<u8>) {
    (
        34735,
        3,
        shorts(&[
            1,
            1,
            0,
            3,
            1024,
            0,
            1,
            2,
            1025,
            0,
            1,
            raster_type,
            2048,
            0,
            1,
            4326,
        ]),
    )
}

#[test]
fn model_transformation_and_pixel_is_point_give_gdals_grid() {
    // Corner (10°, 47°), 0.5° × 0.25° pixels, no rotation.
    let m = [
        0.5, 0.0, 0.0, 10.0, 0.0, -0.25, 0.0, 47.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0,
    ];
    for (raster_type, lon0, lat0) in [(1, 10.25, 46.875), (2, 10.0, 47.0)] {
        let t = tiny_tiff(&[(34264, 12, doubles(&m)), geokeys(raster_type)]);
        let r = GeoTiffRaster::from_bytes(t, "transform.tif").unwrap();
        let g = r.grid();
        assert_eq!(
            (g.lon0_deg, g.lat0_deg, g.dlon_deg, g.dlat_deg),
            (lon0, lat0, 0.5, 0.25)
        );
        let mut row = [0f32; 3];
        r.read_row(1, &mut row).unwrap();
        assert_eq!(row, [4.0, 5.0, 6.0]);
    }
    // The same through ModelPixelScale + a tiepoint at raster (1, 1).
    let t = tiny_tiff(&[
        (33550, 12, doubles(&[0.5, 0.25, 0.0])),
        (33922, 12, doubles(&[1.0, 1.0, 0.0, 10.5, 46.75, 0.0])),
        geokeys(1),
    ]);
    let g = GeoTiffRaster::from_bytes(t, "tie.tif").unwrap().grid();
    assert_eq!((g.lon0_deg, g.lat0_deg), (10.25, 46.875));
    // Rotation is refused, naming the field.
    let mut rotated = m;
    rotated[1] = 0.01;
    let t = tiny_tiff(&[(34264, 12, doubles(&rotated)), geokeys(1)]);
    let e = GeoTiffRaster::from_bytes(t, "rotated.tif")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("ModelTransformation") && e.contains("rotat"),
        "{e}"
    );
}

/// A folder of GeoTIFFs (two halves GDAL cut from one file, one with Deflate, one with LZW
/// tiles) is one raster equal to the whole, pixel for pixel.
#[test]
fn a_folder_of_geotiffs_is_one_mosaic_equal_to_the_whole() {
    if !gdal_ready() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let whole = translate(tmp.path(), "whole.tif", &["-ot", "Int16"]);
    let dir = tmp.path().join("halves");
    std::fs::create_dir(&dir).unwrap();
    for (name, x, w, co) in [
        ("west.tif", "0", "48", "COMPRESS=DEFLATE"),
        ("east.TIF", "48", "49", "COMPRESS=LZW"),
    ] {
        let out = dir.join(name);
        gdal(
            "gdal_translate",
            &[
                "-q",
                "-co",
                co,
                "-co",
                "TILED=YES",
                "-co",
                "BLOCKXSIZE=16",
                "-co",
                "BLOCKYSIZE=16",
                "-srcwin",
                x,
                "0",
                w,
                "61",
                whole.to_str().unwrap(),
                out.to_str().unwrap(),
            ],
        );
    }
    let whole = GeoTiffRaster::open(&whole).unwrap();
    let mosaic = globe::dem::open_raster(&dir, None).unwrap();
    let (a, b) = (whole.grid(), mosaic.grid());
    assert_eq!((a.cols, a.rows), (b.cols, b.rows), "{}", mosaic.describe());
    assert!((a.lon0_deg - b.lon0_deg).abs() < 1e-9 && (a.lat0_deg - b.lat0_deg).abs() < 1e-9);
    let (mut ra, mut rb) = (vec![0f32; a.cols], vec![0f32; a.cols]);
    for r in 0..a.rows {
        whole.read_row(r, &mut ra).unwrap();
        mosaic.read_row(r, &mut rb).unwrap();
        assert_eq!(ra, rb, "row {r}");
    }
}
