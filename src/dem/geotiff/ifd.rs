//! The first image file directory (IFD) of a TIFF or BigTIFF, read by us before the `tiff`
//! crate sees the file: every entry's value is checked to lie inside the file, so nothing the
//! crate then allocates for a tag can exceed the file's own size, and every field globe needs
//! is read here, so errors name the field. Later IFDs (overviews, masks) are not read.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::Path;

use crate::dem::DemError;

/// One entry: its TIFF type and count, and where its value's bytes are in the file.
#[derive(Clone, Debug)]
struct Entry {
    typ: u16,
    count: u64,
    bytes: Range<usize>,
}

/// The first IFD of a file, entries by tag.
#[derive(Debug)]
pub(crate) struct Ifd {
    little_endian: bool,
    pub bigtiff: bool,
    /// Offset of the next IFD (0: none).
    pub next: u64,
    entries: BTreeMap<u16, Entry>,
}

/// Bytes per value of a TIFF field type; `None` for a type TIFF does not define.
fn type_size(typ: u16) -> Option<u64> {
    Some(match typ {
        1 | 2 | 6 | 7 => 1,
        3 | 8 => 2,
        4 | 9 | 11 | 13 => 4,
        5 | 10 | 12 | 16 | 17 | 18 => 8,
        _ => return None,
    })
}

/// A tag's name, for messages.
pub(crate) fn tag_name(tag: u16) -> String {
    let name = match tag {
        256 => "ImageWidth",
        257 => "ImageLength",
        258 => "BitsPerSample",
        259 => "Compression",
        273 => "StripOffsets",
        277 => "SamplesPerPixel",
        278 => "RowsPerStrip",
        279 => "StripByteCounts",
        284 => "PlanarConfiguration",
        317 => "Predictor",
        322 => "TileWidth",
        323 => "TileLength",
        324 => "TileOffsets",
        325 => "TileByteCounts",
        339 => "SampleFormat",
        33550 => "ModelPixelScale",
        33922 => "ModelTiepoint",
        34264 => "ModelTransformation",
        34735 => "GeoKeyDirectory",
        34736 => "GeoDoubleParams",
        34737 => "GeoAsciiParams",
        42113 => "GDAL_NODATA",
        _ => return format!("tag {tag}"),
    };
    name.to_string()
}

fn header_err(path: &Path, field: &str, message: String) -> DemError {
    DemError::Header {
        path: path.to_path_buf(),
        field: field.to_string(),
        message,
    }
}

fn truncated(path: &Path, actual: usize, expected: u64, what: String) -> DemError {
    DemError::Truncated {
        path: path.to_path_buf(),
        actual: actual as u64,
        expected,
        what,
    }
}

/// The byte order from the first two bytes: `true` for little-endian (`II`).
fn byte_order(b: &[u8], path: &Path) -> Result<bool, DemError> {
    match &b[0..2] {
        b"II" => Ok(true),
        b"MM" => Ok(false),
        other => Err(header_err(
            path,
            "byte order",
            format!("{other:?} is not a TIFF byte-order mark; expected \"II\" or \"MM\""),
        )),
    }
}

/// What a TIFF or BigTIFF header says of the first IFD: its offset, and the bytes of one
/// entry, of the entry count and of an offset (the value field).
struct Shape {
    first: u64,
    entry_len: usize,
    count_len: usize,
    offset_len: usize,
}

impl Ifd {
    /// Parses the header and the first IFD of `b`, checking every value's extent against the
    /// file's length.
    pub fn parse(b: &[u8], path: &Path) -> Result<Ifd, DemError> {
        if b.len() < 8 {
            return Err(truncated(
                path,
                b.len(),
                8,
                "the TIFF header (8 bytes)".into(),
            ));
        }
        let mut ifd = Ifd {
            little_endian: byte_order(b, path)?,
            bigtiff: false,
            next: 0,
            entries: BTreeMap::new(),
        };
        let shape = ifd.read_header(b, path)?;
        let (first, count_len) = (shape.first, shape.count_len);
        let len = b.len() as u64;
        if first < 8 || first.saturating_add(count_len as u64) > len {
            return Err(truncated(
                path,
                b.len(),
                first.saturating_add(count_len as u64),
                format!("the first IFD at offset {first}"),
            ));
        }
        let at = first as usize;
        let n = if count_len == 2 {
            ifd.u16_at(b, at) as u64
        } else {
            ifd.u64_at(b, at)
        };
        let table_end = n
            .checked_mul(shape.entry_len as u64)
            .and_then(|t| t.checked_add(first + count_len as u64))
            .unwrap_or(u64::MAX);
        if table_end > len {
            return Err(truncated(
                path,
                b.len(),
                table_end,
                format!("the first IFD's {n} entries at offset {first}"),
            ));
        }
        // The pointer to the next IFD follows the table; a file may end without it.
        if table_end + shape.offset_len as u64 <= len {
            let next_at = table_end as usize;
            ifd.next = if ifd.bigtiff {
                ifd.u64_at(b, next_at)
            } else {
                ifd.u32_at(b, next_at) as u64
            };
        }
        for k in 0..n as usize {
            let e = at + count_len + k * shape.entry_len;
            if let Some((tag, entry)) = ifd.entry_at(b, e, shape.offset_len, path)? {
                ifd.entries.insert(tag, entry);
            }
        }
        Ok(ifd)
    }

    /// Reads the magic number (42: TIFF, 43: BigTIFF, setting `bigtiff`) and what follows it:
    /// where the first IFD is and the sizes of its fields.
    fn read_header(&mut self, b: &[u8], path: &Path) -> Result<Shape, DemError> {
        match self.u16_at(b, 2) {
            42 => Ok(Shape {
                first: self.u32_at(b, 4) as u64,
                entry_len: 12,
                count_len: 2,
                offset_len: 4,
            }),
            43 => {
                if b.len() < 16 {
                    return Err(truncated(
                        path,
                        b.len(),
                        16,
                        "the BigTIFF header (16 bytes)".into(),
                    ));
                }
                if self.u16_at(b, 4) != 8 || self.u16_at(b, 6) != 0 {
                    return Err(header_err(
                        path,
                        "BigTIFF header",
                        "offset size is not 8; expected 8 and 0 after the magic 43".into(),
                    ));
                }
                self.bigtiff = true;
                Ok(Shape {
                    first: self.u64_at(b, 8),
                    entry_len: 20,
                    count_len: 8,
                    offset_len: 8,
                })
            }
            other => Err(header_err(
                path,
                "magic",
                format!("{other} is not a TIFF magic number; expected 42 (TIFF) or 43 (BigTIFF)"),
            )),
        }
    }

    /// The entry at byte `e` of the table as (tag, entry), its value's extent checked against
    /// the file (values of at most `offset_len` bytes are stored in the entry itself); `None`
    /// for a type TIFF does not define, which readers skip.
    fn entry_at(
        &self,
        b: &[u8],
        e: usize,
        offset_len: usize,
        path: &Path,
    ) -> Result<Option<(u16, Entry)>, DemError> {
        let tag = self.u16_at(b, e);
        let typ = self.u16_at(b, e + 2);
        let (count, value_at) = if self.bigtiff {
            (self.u64_at(b, e + 4), e + 12)
        } else {
            (self.u32_at(b, e + 4) as u64, e + 8)
        };
        let Some(size) = type_size(typ) else {
            return Ok(None);
        };
        let total = count.saturating_mul(size);
        let bytes = if total <= offset_len as u64 {
            value_at..value_at + total as usize
        } else {
            let offset = if self.bigtiff {
                self.u64_at(b, value_at)
            } else {
                self.u32_at(b, value_at) as u64
            };
            let end = offset.saturating_add(total);
            if end > b.len() as u64 {
                return Err(truncated(
                    path,
                    b.len(),
                    end,
                    format!("the {count} values of {} at offset {offset}", tag_name(tag)),
                ));
            }
            offset as usize..end as usize
        };
        Ok(Some((tag, Entry { typ, count, bytes })))
    }

    fn u16_at(&self, b: &[u8], at: usize) -> u16 {
        let v = [b[at], b[at + 1]];
        if self.little_endian {
            u16::from_le_bytes(v)
        } else {
            u16::from_be_bytes(v)
        }
    }

    fn u32_at(&self, b: &[u8], at: usize) -> u32 {
        let v: [u8; 4] = b[at..at + 4].try_into().expect("4 bytes");
        if self.little_endian {
            u32::from_le_bytes(v)
        } else {
            u32::from_be_bytes(v)
        }
    }

    fn u64_at(&self, b: &[u8], at: usize) -> u64 {
        let v: [u8; 8] = b[at..at + 8].try_into().expect("8 bytes");
        if self.little_endian {
            u64::from_le_bytes(v)
        } else {
            u64::from_be_bytes(v)
        }
    }

    pub fn has(&self, tag: u16) -> bool {
        self.entries.contains_key(&tag)
    }

    /// The values of an integer field (BYTE, SHORT, LONG, LONG8, IFD), or `None` when absent.
    pub fn unsigned(&self, b: &[u8], tag: u16, path: &Path) -> Result<Option<Vec<u64>>, DemError> {
        let Some(e) = self.entries.get(&tag) else {
            return Ok(None);
        };
        let size = type_size(e.typ).expect("checked at parse") as usize;
        let read = |i: usize| -> u64 {
            let at = e.bytes.start + i * size;
            match e.typ {
                1 => b[at] as u64,
                3 => self.u16_at(b, at) as u64,
                4 | 13 => self.u32_at(b, at) as u64,
                _ => self.u64_at(b, at),
            }
        };
        match e.typ {
            1 | 3 | 4 | 13 | 16 | 18 => Ok(Some((0..e.count as usize).map(read).collect())),
            other => Err(header_err(
                path,
                &tag_name(tag),
                format!("stored as TIFF type {other}; expected an unsigned integer type"),
            )),
        }
    }

    /// The one value of an integer field, `default` when absent.
    pub fn scalar(
        &self,
        b: &[u8],
        tag: u16,
        default: Option<u64>,
        path: &Path,
    ) -> Result<u64, DemError> {
        match self.unsigned(b, tag, path)? {
            Some(v) if v.len() == 1 => Ok(v[0]),
            Some(v) if !v.is_empty() && v.iter().all(|x| *x == v[0]) => Ok(v[0]), // one per sample
            Some(v) => Err(header_err(
                path,
                &tag_name(tag),
                format!(
                    "{} values {:?}; expected one",
                    v.len(),
                    &v[..v.len().min(8)]
                ),
            )),
            None => default.ok_or_else(|| {
                header_err(path, &tag_name(tag), "absent; the TIFF requires it".into())
            }),
        }
    }

    /// The values of a floating-point field (FLOAT or DOUBLE; integers are accepted too).
    pub fn doubles(&self, b: &[u8], tag: u16, path: &Path) -> Result<Option<Vec<f64>>, DemError> {
        let Some(e) = self.entries.get(&tag) else {
            return Ok(None);
        };
        let n = e.count as usize;
        let at = |i: usize, size: usize| e.bytes.start + i * size;
        let v = match e.typ {
            11 => (0..n)
                .map(|i| f32::from_bits(self.u32_at(b, at(i, 4))) as f64)
                .collect(),
            12 => (0..n)
                .map(|i| f64::from_bits(self.u64_at(b, at(i, 8))))
                .collect(),
            _ => match self.unsigned(b, tag, path) {
                Ok(Some(v)) => v.into_iter().map(|x| x as f64).collect(),
                _ => {
                    return Err(header_err(
                        path,
                        &tag_name(tag),
                        format!("stored as TIFF type {}; expected DOUBLE", e.typ),
                    ));
                }
            },
        };
        Ok(Some(v))
    }

    /// An ASCII field without its terminating NULs.
    pub fn ascii(&self, b: &[u8], tag: u16) -> Option<String> {
        let e = self.entries.get(&tag)?;
        if e.typ != 2 {
            return None;
        }
        let s = String::from_utf8_lossy(&b[e.bytes.clone()]);
        Some(s.trim_end_matches('\0').to_string())
    }
}
