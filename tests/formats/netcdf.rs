//! The netCDF-3 classic reader (`globe::dem::netcdf`): files written here by a small writer of
//! our own (CDF-1 and CDF-2, attributes of every type, record variables), malformed and truncated
//! headers, and the real ETOPO5 family from Debian's `ferret-datasets` (skipped when absent).

use std::path::Path;

use globe::dem::netcdf::{AttrValue, NcType, NetcdfFile, NetcdfRaster};
use globe::dem::{DemError, RasterSource};

// ---------------------------------------------------------------------------------------------
// A minimal netCDF-3 classic writer (independent of the reader: written from the format spec)
// ---------------------------------------------------------------------------------------------

#[derive(Clone)]
enum Val {
    Bytes(Vec<i8>),
    Text(&'static str),
    Shorts(Vec<i16>),
    Ints(Vec<i32>),
    Floats(Vec<f32>),
    Doubles(Vec<f64>),
}

impl Val {
    fn code(&self) -> u32 {
        match self {
            Val::Bytes(_) => 1,
            Val::Text(_) => 2,
            Val::Shorts(_) => 3,
            Val::Ints(_) => 4,
            Val::Floats(_) => 5,
            Val::Doubles(_) => 6,
        }
    }

    fn count(&self) -> usize {
        match self {
            Val::Bytes(v) => v.len(),
            Val::Text(s) => s.len(),
            Val::Shorts(v) => v.len(),
            Val::Ints(v) => v.len(),
            Val::Floats(v) => v.len(),
            Val::Doubles(v) => v.len(),
        }
    }

    /// Big-endian bytes, unpadded.
    fn bytes(&self) -> Vec<u8> {
        match self {
            Val::Bytes(v) => v.iter().map(|&x| x as u8).collect(),
            Val::Text(s) => s.as_bytes().to_vec(),
            Val::Shorts(v) => v.iter().flat_map(|x| x.to_be_bytes()).collect(),
            Val::Ints(v) => v.iter().flat_map(|x| x.to_be_bytes()).collect(),
            Val::Floats(v) => v.iter().flat_map(|x| x.to_be_bytes()).collect(),
            Val::Doubles(v) => v.iter().flat_map(|x| x.to_be_bytes()).collect(),
        }
    }
}

struct WVar {
    name: &'static str,
    dims: Vec<usize>,
    atts: Vec<(&'static str, Val)>,
    /// All the data, row-major (records outermost for a record variable).
    data: Val,
}

struct Writer {
    version: u8,
    /// (name, length); length 0 = the record dimension.
    dims: Vec<(&'static str, usize)>,
    gatts: Vec<(&'static str, Val)>,
    vars: Vec<WVar>,
    numrecs: u32,
}

fn put_u32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_be_bytes());
}

fn pad(out: &mut Vec<u8>) {
    while !out.len().is_multiple_of(4) {
        out.push(0);
    }
}

fn put_name(out: &mut Vec<u8>, name: &str) {
    put_u32(out, name.len() as u32);
    out.extend_from_slice(name.as_bytes());
    pad(out);
}

fn put_atts(out: &mut Vec<u8>, atts: &[(&str, Val)]) {
    if atts.is_empty() {
        put_u32(out, 0);
        put_u32(out, 0);
        return;
    }
    put_u32(out, 0x0C);
    put_u32(out, atts.len() as u32);
    for (name, v) in atts {
        put_name(out, name);
        put_u32(out, v.code());
        put_u32(out, v.count() as u32);
        out.extend_from_slice(&v.bytes());
        pad(out);
    }
}

impl Writer {
    fn is_record(&self, v: &WVar) -> bool {
        v.dims.first().is_some_and(|&d| self.dims[d].1 == 0)
    }

    /// Bytes of one record's slab (record variable) or the whole variable.
    fn slab(&self, v: &WVar) -> usize {
        let elem = v.data.bytes().len() / v.data.count().max(1);
        let elem = if v.data.count() == 0 { 4 } else { elem };
        let skip = usize::from(self.is_record(v));
        v.dims[skip..]
            .iter()
            .map(|&d| self.dims[d].1)
            .product::<usize>()
            * elem
    }

    fn header(&self, begins: &[u64]) -> Vec<u8> {
        let mut h = Vec::new();
        h.extend_from_slice(b"CDF");
        h.push(self.version);
        put_u32(&mut h, self.numrecs);
        if self.dims.is_empty() {
            put_u32(&mut h, 0);
            put_u32(&mut h, 0);
        } else {
            put_u32(&mut h, 0x0A);
            put_u32(&mut h, self.dims.len() as u32);
            for (name, len) in &self.dims {
                put_name(&mut h, name);
                put_u32(&mut h, *len as u32);
            }
        }
        put_atts(&mut h, &self.gatts);
        if self.vars.is_empty() {
            put_u32(&mut h, 0);
            put_u32(&mut h, 0);
        } else {
            put_u32(&mut h, 0x0B);
            put_u32(&mut h, self.vars.len() as u32);
            for (v, &begin) in self.vars.iter().zip(begins) {
                put_name(&mut h, v.name);
                put_u32(&mut h, v.dims.len() as u32);
                for &d in &v.dims {
                    put_u32(&mut h, d as u32);
                }
                put_atts(&mut h, &v.atts);
                put_u32(&mut h, v.data.code());
                put_u32(&mut h, self.slab(v).div_ceil(4) as u32 * 4);
                if self.version == 1 {
                    put_u32(&mut h, begin as u32);
                } else {
                    h.extend_from_slice(&begin.to_be_bytes());
                }
            }
        }
        h
    }

    /// The whole file, and the length of its header.
    fn build(&self) -> (Vec<u8>, usize) {
        let header_len = self.header(&vec![0; self.vars.len()]).len();
        let rec_vars: Vec<usize> = (0..self.vars.len())
            .filter(|&i| self.is_record(&self.vars[i]))
            .collect();
        let rec_size = if rec_vars.len() == 1 {
            self.slab(&self.vars[rec_vars[0]])
        } else {
            rec_vars
                .iter()
                .map(|&i| self.slab(&self.vars[i]).div_ceil(4) * 4)
                .sum()
        };
        let mut begins = vec![0u64; self.vars.len()];
        let mut at = header_len;
        for (i, v) in self.vars.iter().enumerate() {
            if !self.is_record(v) {
                begins[i] = at as u64;
                at += self.slab(v).div_ceil(4) * 4;
            }
        }
        for &i in &rec_vars {
            begins[i] = at as u64;
            at += self.slab(&self.vars[i]).div_ceil(4) * 4;
        }
        let mut out = self.header(&begins);
        assert_eq!(out.len(), header_len);
        for v in self.vars.iter().filter(|v| !self.is_record(v)) {
            out.extend_from_slice(&v.data.bytes());
            pad(&mut out);
        }
        for r in 0..self.numrecs as usize {
            for &i in &rec_vars {
                let v = &self.vars[i];
                let s = self.slab(v);
                out.extend_from_slice(&v.data.bytes()[r * s..(r + 1) * s]);
                if rec_vars.len() > 1 {
                    pad(&mut out);
                }
            }
        }
        let _ = rec_size;
        (out, header_len)
    }
}

/// A fresh temporary file whose name ends in `name`, removed when dropped.
fn temp_path(name: &str) -> tempfile::TempPath {
    tempfile::Builder::new()
        .prefix("globe-netcdf-")
        .suffix(name)
        .tempfile()
        .unwrap()
        .into_temp_path()
}

fn write(name: &str, bytes: &[u8]) -> tempfile::TempPath {
    let p = temp_path(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// A small global grid: latitudes −90…90 by 45° (south → north, as ETOPO5), longitudes 0…270
/// by 90°, heights z = 1000·lat_index + col (metres, float), one fill value.
fn small_global(version: u8) -> Writer {
    let lats: Vec<f64> = (0..5).map(|i| -90.0 + 45.0 * f64::from(i)).collect();
    let lons: Vec<f32> = (0..4).map(|i| 90.0 * i as f32).collect();
    let mut z: Vec<f32> = Vec::new();
    for i in 0..5 {
        for j in 0..4 {
            z.push((1000 * i + j) as f32);
        }
    }
    z[2 * 4 + 3] = -9999.9; // lat 0, lon 270: no data (the fill, given as a double below)
    Writer {
        version,
        dims: vec![("lon", 4), ("lat", 5)],
        gatts: vec![
            ("title", Val::Text("tiny test globe")),
            ("b", Val::Bytes(vec![-128, 0, 127])),
            ("s", Val::Shorts(vec![-32768, 1, 32767])),
            ("i", Val::Ints(vec![i32::MIN, 7])),
            ("f", Val::Floats(vec![1.5, -0.25, f32::MAX])),
            ("d", Val::Doubles(vec![std::f64::consts::PI])),
            ("empty", Val::Text("")),
        ],
        vars: vec![
            WVar {
                name: "lon",
                dims: vec![0],
                atts: vec![("units", Val::Text("degrees_east"))],
                data: Val::Floats(lons),
            },
            WVar {
                name: "lat",
                dims: vec![1],
                atts: vec![("units", Val::Text("degrees_north"))],
                data: Val::Doubles(lats),
            },
            WVar {
                name: "z",
                dims: vec![1, 0],
                atts: vec![
                    ("units", Val::Text("m")),
                    ("_FillValue", Val::Doubles(vec![-9999.9])),
                    ("long_name", Val::Text("height")),
                ],
                data: Val::Floats(z),
            },
        ],
        numrecs: 0,
    }
}

// ---------------------------------------------------------------------------------------------
// Reading back what we wrote
// ---------------------------------------------------------------------------------------------

#[test]
fn cdf1_and_cdf2_header_and_attributes_read_back() {
    for version in [1u8, 2] {
        let (bytes, _) = small_global(version).build();
        let p = write(&format!("small{version}.nc"), &bytes);
        let nc = NetcdfFile::open(&p).unwrap();
        assert_eq!(nc.version(), version);
        let dims: Vec<(&str, usize)> = nc
            .dimensions()
            .iter()
            .map(|d| (d.name.as_str(), d.len))
            .collect();
        assert_eq!(dims, [("lon", 4), ("lat", 5)]);
        let g = |n: &str| nc.global_attribute(n).unwrap().clone();
        assert_eq!(g("title"), AttrValue::Text("tiny test globe".into()));
        assert_eq!(g("b"), AttrValue::Bytes(vec![-128, 0, 127]));
        assert_eq!(g("s"), AttrValue::Shorts(vec![-32768, 1, 32767]));
        assert_eq!(g("i"), AttrValue::Ints(vec![i32::MIN, 7]));
        assert_eq!(g("f"), AttrValue::Floats(vec![1.5, -0.25, f32::MAX]));
        assert_eq!(g("d"), AttrValue::Doubles(vec![std::f64::consts::PI]));
        assert_eq!(g("empty"), AttrValue::Text(String::new()));
        assert_eq!(g("s").nc_type(), NcType::Short);

        let names: Vec<&str> = nc.variables().iter().map(|v| v.name.as_str()).collect();
        assert_eq!(names, ["lon", "lat", "z"]);
        assert_eq!(nc.shape("z").unwrap(), [5, 4]);
        assert_eq!(nc.variable("lon").unwrap().nc_type, NcType::Float);
        assert_eq!(
            nc.attribute("z", "units").and_then(AttrValue::as_text),
            Some("m")
        );
        assert_eq!(
            nc.attribute("z", "_FillValue")
                .and_then(AttrValue::first_f64),
            Some(-9999.9)
        );
        assert!(nc.attribute("z", "nope").is_none());
        assert!(nc.attribute("nope", "units").is_none());
        assert_eq!(nc.read_f64("lon").unwrap(), [0.0, 90.0, 180.0, 270.0]);
        assert_eq!(nc.read_f64("lat").unwrap(), [-90.0, -45.0, 0.0, 45.0, 90.0]);
        let z = nc.read_f64("z").unwrap();
        assert_eq!(z.len(), 20);
        assert_eq!(z[4 * 4 + 1], 4001.0);
        let mut part = [0.0; 3];
        nc.read_f64_into("z", 5, &mut part).unwrap();
        assert_eq!(part, [1001.0, 1002.0, 1003.0]);
        assert!(nc.read_f64_into("z", 18, &mut part).is_err());
        assert!(nc.read_f64("nope").is_err());
    }
}

#[test]
fn raster_flips_south_to_north_and_applies_fill() {
    let (bytes, _) = small_global(1).build();
    let p = write("raster.nc", &bytes);
    let r = NetcdfRaster::open(&p, None).unwrap();
    assert_eq!(r.variable_name(), "z");
    let g = r.grid();
    assert_eq!((g.cols, g.rows), (4, 5));
    assert_eq!((g.lat0_deg, g.dlat_deg), (90.0, 45.0));
    assert_eq!((g.lon0_deg, g.dlon_deg), (0.0, 90.0));
    assert!(g.wraps_in_longitude());
    let mut row = vec![0.0f32; 4];
    r.read_row(0, &mut row).unwrap(); // north pole = last stored latitude
    assert_eq!(row, [4000.0, 4001.0, 4002.0, 4003.0]);
    r.read_row(4, &mut row).unwrap(); // south pole
    assert_eq!(row, [0.0, 1.0, 2.0, 3.0]);
    r.read_row(2, &mut row).unwrap(); // equator, last column is fill
    assert_eq!(&row[..3], [2000.0, 2001.0, 2002.0]);
    assert!(row[3].is_nan());
    assert_eq!(r.value(1, 2).unwrap(), 3002.0);
    assert!(r.read_row(5, &mut row).is_err());
    assert!(r.read_row(0, &mut [0.0; 3]).is_err());
    assert!(
        r.notes().iter().any(|n| n.contains("rows flipped")),
        "{:?}",
        r.notes()
    );
    println!("{}\n  notes: {:#?}", r.describe(), r.notes());
    // Named explicitly: the same.
    let r2 = NetcdfRaster::open(&p, Some("z")).unwrap();
    assert_eq!(r2.grid(), g);
    // A 1-D variable cannot be a raster; a missing one is an error naming it.
    let e = NetcdfRaster::open(&p, Some("lat")).unwrap_err().to_string();
    assert!(e.contains("2-D"), "{e}");
    let e = NetcdfRaster::open(&p, Some("ROSE"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("ROSE") && e.contains("raster.nc"), "{e}");
}

/// CDF-2 (64-bit offsets), short data packed with scale/offset, in feet, missing_value, latitude
/// north → south, longitude east → west, dimensions (lon, lat), a coordinate axis slightly off a
/// regular grid that covers the circle.
#[test]
fn cdf2_packed_feet_transposed_descending_axes() {
    let nlat = 3; // 60, 0, -60 (north → south)
    let nlon = 6; // 300, 240, …, 0 (east → west), slightly off
    let lats: Vec<f32> = vec![60.0, 0.0, -60.0];
    let lons: Vec<f64> = (0..nlon)
        .map(|i| 300.0 - 60.0 * i as f64 + 0.004 * i as f64)
        .collect();
    // Stored as [lon][lat]: raw = 10·lon_index + lat_index, raw 99 = missing.
    let mut raw = Vec::new();
    for i in 0..nlon {
        for j in 0..nlat {
            raw.push((10 * i + j) as i16);
        }
    }
    raw[0] = 99;
    let w = Writer {
        version: 2,
        dims: vec![("latitude", nlat), ("longitude", nlon)],
        gatts: vec![],
        vars: vec![
            WVar {
                name: "longitude",
                dims: vec![1],
                atts: vec![],
                data: Val::Doubles(lons),
            },
            WVar {
                name: "latitude",
                dims: vec![0],
                atts: vec![],
                data: Val::Floats(lats),
            },
            WVar {
                name: "elev",
                dims: vec![1, 0],
                atts: vec![
                    ("scale_factor", Val::Doubles(vec![2.0])),
                    ("add_offset", Val::Floats(vec![100.0])),
                    ("missing_value", Val::Shorts(vec![99])),
                    ("units", Val::Text("feet")),
                ],
                data: Val::Shorts(raw),
            },
            // A second, 1-D data variable, so auto-detection has something to ignore.
            WVar {
                name: "flags",
                dims: vec![0],
                atts: vec![],
                data: Val::Bytes(vec![1, 2, 3]),
            },
        ],
        numrecs: 0,
    };
    let (bytes, _) = w.build();
    let p = write("cdf2.nc", &bytes);
    let nc = NetcdfFile::open(&p).unwrap();
    assert_eq!(nc.version(), 2);
    assert!(nc.variable("elev").unwrap().begin > 0);
    assert_eq!(nc.read_f64("flags").unwrap(), [1.0, 2.0, 3.0]);
    let r = NetcdfRaster::open(&p, None).unwrap();
    let g = r.grid();
    println!("{g:?}\n  notes: {:#?}", r.notes());
    assert_eq!((g.cols, g.rows), (6, 3));
    assert_eq!((g.lat0_deg, g.dlat_deg), (60.0, 60.0));
    assert_eq!((g.lon0_deg, g.dlon_deg), (0.0, 60.0));
    assert!(g.wraps_in_longitude());
    assert!(r.notes().iter().any(|n| n.contains("columns flipped")));
    assert!(
        r.notes()
            .iter()
            .any(|n| n.contains("longitude") && n.contains("regular"))
    );
    assert!(r.notes().iter().any(|n| n.contains("metres")));
    let ft = 0.3048f32;
    let expect =
        |lon_idx: usize, lat_idx: usize| ((10 * lon_idx + lat_idx) as f32 * 2.0 + 100.0) * ft;
    let mut row = vec![0.0f32; 6];
    for out_row in 0..3 {
        r.read_row(out_row, &mut row).unwrap();
        for (c, &v) in row.iter().enumerate() {
            let lon_idx = nlon - 1 - c; // column 0 = lon 0 = stored last
            if lon_idx == 0 && out_row == 0 {
                assert!(v.is_nan());
            } else {
                assert!((v - expect(lon_idx, out_row)).abs() < 1e-3, "{v}");
            }
        }
    }
}

#[test]
fn record_variables_and_repeated_wrap_column() {
    // Two record variables (time-major), plus a grid whose last longitude repeats the first.
    let w = Writer {
        version: 1,
        dims: vec![("time", 0), ("x", 3), ("lat", 2), ("lon", 5)],
        gatts: vec![],
        vars: vec![
            WVar {
                name: "a",
                dims: vec![0, 1],
                atts: vec![],
                data: Val::Shorts((0..9).collect()), // 3 records of 3 shorts (padded)
            },
            WVar {
                name: "b",
                dims: vec![0],
                atts: vec![],
                data: Val::Doubles(vec![10.0, 20.0, 30.0]),
            },
            WVar {
                name: "lat",
                dims: vec![2],
                atts: vec![("units", Val::Text("degrees_north"))],
                data: Val::Floats(vec![45.0, -45.0]),
            },
            WVar {
                name: "lon",
                dims: vec![3],
                atts: vec![("units", Val::Text("degrees_east"))],
                data: Val::Floats(vec![-180.0, -90.0, 0.0, 90.0, 180.0]),
            },
            WVar {
                name: "h",
                dims: vec![2, 3],
                atts: vec![("units", Val::Text("ft"))],
                data: Val::Ints(vec![1, 2, 3, 4, 1, 5, 6, 7, 8, 5]),
            },
        ],
        numrecs: 3,
    };
    let (bytes, _) = w.build();
    let p = write("records.nc", &bytes);
    let nc = NetcdfFile::open(&p).unwrap();
    assert_eq!(nc.num_records(), 3);
    assert!(nc.dimensions()[0].is_record);
    assert_eq!(nc.dimensions()[0].len, 3);
    assert_eq!(nc.shape("a").unwrap(), [3, 3]);
    assert_eq!(
        nc.read_f64("a").unwrap(),
        (0..9).map(f64::from).collect::<Vec<_>>()
    );
    assert_eq!(nc.read_f64("b").unwrap(), [10.0, 20.0, 30.0]);
    let mut two = [0.0; 2];
    nc.read_f64_into("a", 2, &mut two).unwrap(); // across a record boundary
    assert_eq!(two, [2.0, 3.0]);

    let r = NetcdfRaster::open(&p, None).unwrap();
    let g = r.grid();
    println!("{g:?}\n  notes: {:#?}", r.notes());
    assert_eq!((g.cols, g.rows), (4, 2));
    assert_eq!((g.lon0_deg, g.dlon_deg, g.lat0_deg), (-180.0, 90.0, 45.0));
    assert!(g.wraps_in_longitude());
    assert!(r.notes().iter().any(|n| n.contains("repeats the first")));
    let mut row = [0.0f32; 4];
    r.read_row(1, &mut row).unwrap();
    let ft = 0.3048f32;
    assert_eq!(row, [5.0 * ft, 6.0 * ft, 7.0 * ft, 8.0 * ft]);
}

#[test]
fn streaming_numrecs_counts_records_from_the_file_length() {
    let w = Writer {
        version: 1,
        dims: vec![("t", 0)],
        gatts: vec![],
        vars: vec![WVar {
            name: "v",
            dims: vec![0],
            atts: vec![],
            data: Val::Ints(vec![5, 6, 7, 8]),
        }],
        numrecs: 4,
    };
    let (mut bytes, _) = w.build();
    bytes[4..8].copy_from_slice(&[0xFF; 4]);
    let p = write("streaming.nc", &bytes);
    let nc = NetcdfFile::open(&p).unwrap();
    assert_eq!(nc.num_records(), 4);
    assert_eq!(nc.read_f64("v").unwrap(), [5.0, 6.0, 7.0, 8.0]);
}

#[test]
fn ambiguous_and_irregular_grids_are_errors() {
    let mut w = small_global(1);
    let mut second = w.vars.pop().unwrap();
    let z = Val::Floats(vec![0.0; 20]);
    w.vars.push(WVar {
        name: "z2",
        dims: vec![1, 0],
        atts: vec![],
        data: z,
    });
    second.name = "z";
    w.vars.push(second);
    let p = write("two.nc", &w.build().0);
    let e = NetcdfRaster::open(&p, None).unwrap_err().to_string();
    assert!(e.contains("z2") && e.contains("name one"), "{e}");
    assert!(NetcdfRaster::open(&p, Some("z2")).is_ok());

    let mut w = small_global(1);
    w.vars[0].data = Val::Floats(vec![0.0, 90.0, 200.0, 270.0]);
    let p = write("irregular.nc", &w.build().0);
    let e = NetcdfRaster::open(&p, None).unwrap_err().to_string();
    assert!(
        e.contains("not a regular grid") && e.contains("irregular.nc"),
        "{e}"
    );
}

// ---------------------------------------------------------------------------------------------
// Malformed input: errors, never panics
// ---------------------------------------------------------------------------------------------

fn assert_header_error(p: &Path, e: &DemError) {
    let s = e.to_string();
    assert!(
        s.contains(&p.display().to_string()),
        "error does not name the file: {s}"
    );
}

#[test]
fn every_truncation_is_an_error() {
    for version in [1u8, 2] {
        let (bytes, header_len) = small_global(version).build();
        let p = temp_path(&format!("trunc{version}.nc"));
        let mut messages = std::collections::BTreeSet::new();
        // Every length up to the end of the header, and on through the data (the data extents
        // are checked against the file length when opening).
        for len in 0..bytes.len() {
            std::fs::write(&p, &bytes[..len]).unwrap();
            match NetcdfFile::open(&p) {
                Ok(_) => panic!("CDF-{version} truncated to {len} bytes opened"),
                Err(e) => {
                    assert_header_error(&p, &e);
                    if len <= header_len {
                        let s = e.to_string();
                        messages.insert(s[s.find(": field").unwrap_or(0)..].to_string());
                    }
                }
            }
            assert!(NetcdfRaster::open(&p, None).is_err());
        }
        std::fs::write(&p, &bytes).unwrap();
        assert!(NetcdfFile::open(&p).is_ok());
        println!(
            "CDF-{version}: {} truncations (header {header_len} bytes) all errors; e.g.",
            bytes.len()
        );
        for m in messages.iter().take(6) {
            println!("   {m}");
        }
    }
}

#[test]
fn garbage_headers_never_panic() {
    let (bytes, header_len) = small_global(1).build();
    let p = temp_path("garbage.nc");
    let mut errors = 0;
    // Every header byte set to a few hostile values.
    for pos in 0..header_len {
        for val in [0x00u8, 0x01, 0x7F, 0x80, 0xFF] {
            let mut b = bytes.clone();
            b[pos] = val;
            std::fs::write(&p, &b).unwrap();
            match NetcdfFile::open(&p) {
                Ok(nc) => {
                    // Whatever parsed must be readable without panicking.
                    for v in nc.variables() {
                        let _ = nc.read_f64(&v.name);
                    }
                    if let Ok(r) = NetcdfRaster::open(&p, None) {
                        let g = r.grid();
                        let mut row = vec![0.0; g.cols];
                        for i in 0..g.rows {
                            let _ = r.read_row(i, &mut row);
                        }
                    }
                }
                Err(e) => {
                    assert_header_error(&p, &e);
                    errors += 1;
                }
            }
        }
    }
    println!("{errors} of {} corrupted headers rejected", header_len * 5);

    // Specific malformations and their messages.
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("empty", vec![]),
        ("HDF5 / netCDF-4", b"\x89HDF\r\n\x1a\n".to_vec()),
        ("CDF-5", {
            let mut b = bytes.clone();
            b[3] = 5;
            b
        }),
        ("text", b"hello world, this is not netCDF".to_vec()),
        ("huge dimension count", {
            let mut b = bytes[..16].to_vec();
            b[12..16].copy_from_slice(&0x7FFF_FFFFu32.to_be_bytes());
            b
        }),
        ("negative count", {
            let mut b = bytes.clone();
            b[12..16].copy_from_slice(&0xFFFF_FFF0u32.to_be_bytes());
            b
        }),
        ("bad dimension tag", {
            let mut b = bytes.clone();
            b[11] = 0x0B;
            b
        }),
    ];
    for (what, b) in cases {
        std::fs::write(&p, &b).unwrap();
        let e = NetcdfFile::open(&p).expect_err(what);
        assert_header_error(&p, &e);
        println!("{what:>22}: {e}");
    }
    let dir = tempfile::tempdir().unwrap();
    let e = NetcdfFile::open(dir.path().join("does-not-exist.nc")).unwrap_err();
    assert!(matches!(e, DemError::Io { .. }), "{e}");
}

// ---------------------------------------------------------------------------------------------
// The real ETOPO5 family (Debian ferret-datasets)
// ---------------------------------------------------------------------------------------------

const FERRET: &str = "/usr/share/ferret-vis/data";

fn etopo(name: &str) -> Option<NetcdfRaster> {
    let p = Path::new(FERRET).join(name);
    if !p.exists() {
        assert!(
            std::env::var("GLOBE_REQUIRE_DATA").as_deref() != Ok("1"),
            "GLOBE_REQUIRE_DATA=1 but {} is missing (apt-get install ferret-datasets)",
            p.display()
        );
        println!(
            "SKIPPED: {} absent (apt-get install ferret-datasets)",
            p.display()
        );
        return None;
    }
    Some(NetcdfRaster::open(&p, None).unwrap())
}

/// (min, its lat, lon), (max, its lat, lon) over the nodes within a lat/lon box.
#[allow(clippy::type_complexity)]
fn box_extremes(
    r: &NetcdfRaster,
    lat: (f64, f64),
    lon: (f64, f64),
) -> ((f32, f64, f64), (f32, f64, f64)) {
    let g = r.grid();
    let (r0, c0) = g.row_col_of(lat.1, lon.0);
    let (r1, c1) = g.row_col_of(lat.0, lon.1);
    let mut row = vec![0.0f32; g.cols];
    let mut lo = (f32::INFINITY, 0.0, 0.0);
    let mut hi = (f32::NEG_INFINITY, 0.0, 0.0);
    for ri in r0.ceil().max(0.0) as usize..=(r1.floor() as usize).min(g.rows - 1) {
        r.read_row(ri, &mut row).unwrap();
        for ci in c0.ceil() as i64..=c1.floor() as i64 {
            let c = ci.rem_euclid(g.cols as i64) as usize;
            let v = row[c];
            let at = (g.lat_of_row(ri as f64), g.lon_of_col(c as f64));
            if v < lo.0 {
                lo = (v, at.0, at.1);
            }
            if v > hi.0 {
                hi = (v, at.0, at.1);
            }
        }
    }
    (lo, hi)
}

/// Height at the node nearest (lat, lon).
fn nearest(r: &NetcdfRaster, lat: f64, lon: f64) -> f32 {
    let g = r.grid();
    let (row, col) = g.row_col_of(lat, lon);
    let row = (row.round().max(0.0) as usize).min(g.rows - 1);
    let col = (col.round() as i64).rem_euclid(g.cols as i64) as usize;
    r.value(row, col).unwrap()
}

#[test]
fn etopo5_header_grid_and_known_places() {
    let Some(r) = etopo("etopo5.cdf") else { return };
    let nc = r.file();
    println!("{}", r.describe());
    println!("  dims: {:?}", nc.dimensions());
    for a in nc.global_attributes() {
        println!("  :{} = {}", a.name, a.value);
    }
    for v in nc.variables() {
        let dims: Vec<&str> = v
            .dim_ids
            .iter()
            .map(|&d| nc.dimensions()[d].name.as_str())
            .collect();
        println!("  {} {}{dims:?} begin {}", v.nc_type, v.name, v.begin);
        for a in &v.attributes {
            println!("      :{} = {}", a.name, a.value);
        }
    }
    println!("  notes: {:#?}", r.notes());

    assert_eq!(r.variable_name(), "ROSE");
    let g = r.grid();
    assert_eq!((g.cols, g.rows), (4320, 2161));
    assert_eq!(g.dlon_deg, 360.0 / 4320.0);
    assert_eq!(g.dlat_deg, 180.0 / 2160.0);
    assert_eq!((g.lat0_deg, g.lon0_deg), (90.0, 0.0));
    assert_eq!(g.lat_of_row(2160.0), -90.0);
    assert!(g.wraps_in_longitude());
    assert!(r.notes().iter().any(|n| n.contains("ETOPO05_X")));

    // Poles: every column of the first and last rows is the same point.
    let mut row = vec![0.0f32; g.cols];
    for (i, name) in [(0, "north pole"), (2160, "south pole")] {
        r.read_row(i, &mut row).unwrap();
        let (lo, hi) = row
            .iter()
            .fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
        println!("{name}: {lo}…{hi} m");
        assert!(row.iter().all(|v| v.is_finite()));
    }
    let (mut nan, mut lo, mut hi) = (0usize, f32::MAX, f32::MIN);
    for i in 0..g.rows {
        r.read_row(i, &mut row).unwrap();
        for &v in &row {
            if v.is_nan() {
                nan += 1;
            } else {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
    }
    println!("whole grid: {lo}…{hi} m, {nan} no-data nodes");
    assert_eq!(nan, 0);

    // Everest: docs/design.md#data says ETOPO5's Asian heights are 1000-ft contour values and Everest
    // reads 6096 m (20 000 ft) at its nearest node.
    let everest_node = nearest(&r, 27.99, 86.93);
    let (_, everest) = box_extremes(&r, (27.49, 28.49), (86.43, 87.43));
    println!(
        "Everest (27.99N 86.93E): nearest node {everest_node} m; max within ±0.5°: {everest:?}"
    );
    assert_eq!(everest_node, 6096.0);
    assert!(everest.0 > 6000.0, "{everest:?}");

    let dead_sea_node = nearest(&r, 31.5, 35.5);
    let (dead_sea, _) = box_extremes(&r, (31.2, 31.8), (35.3, 35.7));
    println!(
        "Dead Sea (31.5N 35.5E): nearest node {dead_sea_node} m; min over 31.2–31.8N \
         35.3–35.7E: {dead_sea:?}"
    );
    assert!(dead_sea.0 < -300.0, "{dead_sea:?}");

    // Lake Garda is a few km wide, a 5′ node (9 km) rarely falls on it: look at the lowest
    // node within ±0.15°.
    let garda_node = nearest(&r, 45.65, 10.65);
    let (garda, _) = box_extremes(&r, (45.5, 45.8), (10.5, 10.8));
    let (_, alps) = box_extremes(&r, (46.0, 47.0), (10.0, 11.0));
    println!(
        "Lake Garda (45.65N 10.65E): nearest node {garda_node} m; min within ±0.15°: \
         {garda:?}; Alps max (46–47N 10–11E): {alps:?}"
    );
    assert!(garda.0 < 200.0, "{garda:?}");
    assert!(alps.0 > 2000.0, "{alps:?}");

    let (mariana, _) = box_extremes(&r, (10.85, 11.85), (141.7, 142.7));
    println!("Mariana trench (11.35N 142.2E): min within ±0.5°: {mariana:?}");
    assert!(mariana.0 < -8000.0, "{mariana:?}");
}

#[test]
fn etopo_siblings_agree_with_etopo5() {
    let Some(fine) = etopo("etopo5.cdf") else {
        return;
    };
    let fg = fine.grid();
    for name in ["etopo20.cdf", "etopo40.cdf", "etopo60.cdf", "etopo120.cdf"] {
        let Some(coarse) = etopo(name) else { return };
        let g = coarse.grid();
        println!(
            "{}\n  {g:?}\n  notes: {:#?}",
            coarse.describe(),
            coarse.notes()
        );
        assert!(g.wraps_in_longitude(), "{name}");
        assert!(g.lat0_deg <= 90.0 && g.lat_of_row((g.rows - 1) as f64) >= -90.0);
        // Compare every coarse node with the mean of the etopo5 nodes in its cell (resampling
        // to a coarser grid averages or subsamples), and with etopo5's nearest node.
        let half = g.dlat_deg / 2.0;
        let mut row = vec![0.0f32; g.cols];
        let (mut n, mut sum_abs_mean, mut sum_abs_near) = (0usize, 0.0f64, 0.0f64);
        let mut diffs = Vec::new();
        let (mut sxy, mut sxx, mut syy, mut sx, mut sy) = (0.0, 0.0, 0.0, 0.0, 0.0);
        let step_r = (g.rows / 45).max(1);
        let step_c = (g.cols / 90).max(1);
        for ri in (0..g.rows).step_by(step_r) {
            coarse.read_row(ri, &mut row).unwrap();
            let lat = g.lat_of_row(ri as f64);
            for ci in (0..g.cols).step_by(step_c) {
                let lon = g.lon_of_col(ci as f64);
                let c = f64::from(row[ci]);
                let (r0, c0) = fg.row_col_of(lat + half, lon - half);
                let (r1, c1) = fg.row_col_of(lat - half, lon + half);
                let (mut s, mut k) = (0.0, 0usize);
                for fr in r0.ceil().max(0.0) as usize..=(r1.floor() as usize).min(fg.rows - 1) {
                    for fc in c0.ceil() as i64..=c1.floor() as i64 {
                        let fc = fc.rem_euclid(fg.cols as i64) as usize;
                        s += f64::from(fine.value(fr, fc).unwrap());
                        k += 1;
                    }
                }
                let mean = s / k as f64;
                let near = f64::from(nearest(&fine, lat, lon));
                sum_abs_mean += (c - mean).abs();
                sum_abs_near += (c - near).abs();
                diffs.push((c - mean).abs());
                sx += c;
                sy += mean;
                sxx += c * c;
                syy += mean * mean;
                sxy += c * mean;
                n += 1;
            }
        }
        diffs.sort_by(f64::total_cmp);
        let nf = n as f64;
        let corr =
            (sxy - sx * sy / nf) / ((sxx - sx * sx / nf).sqrt() * (syy - sy * sy / nf).sqrt());
        let p50 = diffs[n / 2];
        let p95 = diffs[n * 95 / 100];
        println!(
            "  {n} nodes vs etopo5: mean |coarse − cell mean| {:.0} m (median {p50:.0}, 95% \
             {p95:.0}), mean |coarse − nearest| {:.0} m, correlation with cell mean {corr:.4}",
            sum_abs_mean / nf,
            sum_abs_near / nf
        );
        // Measured: correlation ≥ 0.9997, median ≤ 11 m, 95th percentile ≤ 133 m (the coarse
        // files are cell averages of etopo5).
        assert!(corr > 0.998, "{name}: correlation {corr}");
        assert!(p50 < 40.0, "{name}: median difference {p50} m");
        assert!(p95 < 300.0, "{name}: 95th percentile difference {p95} m");
    }
}
