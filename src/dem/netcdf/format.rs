//! The netCDF-3 classic file format (CDF-1 and CDF-2): the header is parsed per the netCDF
//! classic format specification:
//!
//! ```text
//! header    = magic numrecs dim_list gatt_list var_list
//! magic     = 'C' 'D' 'F' (1 | 2)
//! dim_list  = ABSENT | NC_DIMENSION nelems [name dim_length ...]
//! att_list  = ABSENT | NC_ATTRIBUTE nelems [name nc_type nelems values(padded to 4) ...]
//! var_list  = ABSENT | NC_VARIABLE  nelems [name ndims dimid... vatt_list nc_type vsize begin ...]
//! begin     = 32-bit offset (CDF-1) | 64-bit offset (CDF-2)
//! ```
//!
//! All integers are big-endian. Every read is bounds-checked: a truncated or garbage file gives
//! a [`DemError`] naming the file, the header field and what was wrong, never a panic. No byte
//! offset is hard-coded; data is located through each variable's `begin`. The file is
//! memory-mapped and values are decoded on demand, raw (scale, offset and fill values are the
//! raster adaptor's concern, [`super::raster`]).

use std::fmt;
use std::path::{Path, PathBuf};

use crate::dem::DemError;
use crate::dem::mapped::MappedFile;

const NC_DIMENSION: u32 = 0x0A;
const NC_VARIABLE: u32 = 0x0B;
const NC_ATTRIBUTE: u32 = 0x0C;
const STREAMING: u32 = 0xFFFF_FFFF;

/// netCDF-3 external data types.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NcType {
    Byte,
    Char,
    Short,
    Int,
    Float,
    Double,
}

impl NcType {
    fn from_code(code: u32) -> Option<NcType> {
        Some(match code {
            1 => NcType::Byte,
            2 => NcType::Char,
            3 => NcType::Short,
            4 => NcType::Int,
            5 => NcType::Float,
            6 => NcType::Double,
            _ => return None,
        })
    }

    /// The on-disk code of the type (1 = byte … 6 = double).
    pub fn code(self) -> u32 {
        match self {
            NcType::Byte => 1,
            NcType::Char => 2,
            NcType::Short => 3,
            NcType::Int => 4,
            NcType::Float => 5,
            NcType::Double => 6,
        }
    }

    /// Bytes per element.
    pub fn size(self) -> usize {
        match self {
            NcType::Byte | NcType::Char => 1,
            NcType::Short => 2,
            NcType::Int | NcType::Float => 4,
            NcType::Double => 8,
        }
    }

    /// The netCDF default fill value of the type (used when a variable has no `_FillValue`).
    pub(super) fn default_fill(self) -> f64 {
        match self {
            NcType::Byte => -127.0,
            NcType::Char => 0.0,
            NcType::Short => -32767.0,
            NcType::Int => -2_147_483_647.0,
            NcType::Float => f64::from(9.969_21e36_f32),
            NcType::Double => 9.969_209_968_386_869e36,
        }
    }

    fn name(self) -> &'static str {
        match self {
            NcType::Byte => "byte",
            NcType::Char => "char",
            NcType::Short => "short",
            NcType::Int => "int",
            NcType::Float => "float",
            NcType::Double => "double",
        }
    }

    /// Decodes one big-endian element (`bytes.len() == self.size()`). Char decodes as its code.
    fn decode(self, bytes: &[u8]) -> f64 {
        match self {
            NcType::Byte => f64::from(bytes[0] as i8),
            NcType::Char => f64::from(bytes[0]),
            NcType::Short => f64::from(i16::from_be_bytes([bytes[0], bytes[1]])),
            NcType::Int => f64::from(i32::from_be_bytes([bytes[0], bytes[1], bytes[2], bytes[3]])),
            NcType::Float => {
                f64::from(f32::from_be_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]))
            }
            NcType::Double => f64::from_be_bytes([
                bytes[0], bytes[1], bytes[2], bytes[3], bytes[4], bytes[5], bytes[6], bytes[7],
            ]),
        }
    }
}

impl fmt::Display for NcType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The values of an attribute, in their stored type.
#[derive(Clone, Debug, PartialEq)]
pub enum AttrValue {
    Bytes(Vec<i8>),
    /// Char attributes as text (invalid UTF-8 replaced; trailing NULs removed).
    Text(String),
    Shorts(Vec<i16>),
    Ints(Vec<i32>),
    Floats(Vec<f32>),
    Doubles(Vec<f64>),
}

impl AttrValue {
    pub fn nc_type(&self) -> NcType {
        match self {
            AttrValue::Bytes(_) => NcType::Byte,
            AttrValue::Text(_) => NcType::Char,
            AttrValue::Shorts(_) => NcType::Short,
            AttrValue::Ints(_) => NcType::Int,
            AttrValue::Floats(_) => NcType::Float,
            AttrValue::Doubles(_) => NcType::Double,
        }
    }

    /// The text of a char attribute.
    pub fn as_text(&self) -> Option<&str> {
        match self {
            AttrValue::Text(s) => Some(s),
            _ => None,
        }
    }

    /// Numeric values as f64 (`None` for text).
    pub fn as_f64s(&self) -> Option<Vec<f64>> {
        Some(match self {
            AttrValue::Bytes(v) => v.iter().map(|&x| f64::from(x)).collect(),
            AttrValue::Text(_) => return None,
            AttrValue::Shorts(v) => v.iter().map(|&x| f64::from(x)).collect(),
            AttrValue::Ints(v) => v.iter().map(|&x| f64::from(x)).collect(),
            AttrValue::Floats(v) => v.iter().map(|&x| f64::from(x)).collect(),
            AttrValue::Doubles(v) => v.clone(),
        })
    }

    /// The first numeric value.
    pub fn first_f64(&self) -> Option<f64> {
        self.as_f64s().and_then(|v| v.first().copied())
    }
}

impl fmt::Display for AttrValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fn list<T: fmt::Display>(f: &mut fmt::Formatter<'_>, v: &[T]) -> fmt::Result {
            for (i, x) in v.iter().enumerate() {
                if i > 0 {
                    f.write_str(", ")?;
                }
                write!(f, "{x}")?;
            }
            Ok(())
        }
        match self {
            AttrValue::Bytes(v) => list(f, v),
            AttrValue::Text(s) => write!(f, "{s:?}"),
            AttrValue::Shorts(v) => list(f, v),
            AttrValue::Ints(v) => list(f, v),
            AttrValue::Floats(v) => list(f, v),
            AttrValue::Doubles(v) => list(f, v),
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Attribute {
    pub name: String,
    pub value: AttrValue,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Dimension {
    pub name: String,
    /// Length; for the record (unlimited) dimension, the file's current number of records.
    pub len: usize,
    /// True for the record (unlimited) dimension.
    pub is_record: bool,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Variable {
    pub name: String,
    /// Indices into [`NetcdfFile::dimensions`], slowest-varying first.
    pub dim_ids: Vec<usize>,
    pub attributes: Vec<Attribute>,
    pub nc_type: NcType,
    /// The `vsize` field as stored (informational; sizes are recomputed from the dimensions,
    /// as the netCDF library does).
    pub vsize: u64,
    /// File offset of the variable's data (of its first record for a record variable).
    pub begin: u64,
    /// True when the first dimension is the record dimension.
    pub is_record: bool,
}

impl Variable {
    pub fn attribute(&self, name: &str) -> Option<&AttrValue> {
        self.attributes
            .iter()
            .find(|a| a.name == name)
            .map(|a| &a.value)
    }
}

/// A netCDF-3 classic file (CDF-1 or CDF-2), header parsed, data memory-mapped.
pub struct NetcdfFile {
    path: PathBuf,
    map: MappedFile,
    version: u8,
    num_records: usize,
    /// Bytes from one record to the next (0 without record variables).
    record_size: u64,
    dims: Vec<Dimension>,
    global_attrs: Vec<Attribute>,
    vars: Vec<Variable>,
}

impl fmt::Debug for NetcdfFile {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("NetcdfFile")
            .field("path", &self.path)
            .field("version", &self.version)
            .field("num_records", &self.num_records)
            .field("dims", &self.dims)
            .field("global_attrs", &self.global_attrs)
            .field("vars", &self.vars)
            .finish()
    }
}

/// Bounds-checked big-endian cursor over the header bytes.
struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
    path: &'a Path,
}

impl<'a> Cursor<'a> {
    fn err(&self, field: &str, message: impl Into<String>) -> DemError {
        DemError::Header {
            path: self.path.to_path_buf(),
            field: field.to_string(),
            message: message.into(),
        }
    }

    fn take(&mut self, n: usize, field: &str) -> Result<&'a [u8], DemError> {
        let end = self
            .pos
            .checked_add(n)
            .filter(|&e| e <= self.bytes.len())
            .ok_or_else(|| {
                self.err(
                    field,
                    format!(
                        "file ends at byte {} but {n} bytes are needed at byte {} \
                         (truncated or not a netCDF-3 file)",
                        self.bytes.len(),
                        self.pos
                    ),
                )
            })?;
        let s = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(s)
    }

    fn u32(&mut self, field: &str) -> Result<u32, DemError> {
        let b = self.take(4, field)?;
        Ok(u32::from_be_bytes([b[0], b[1], b[2], b[3]]))
    }

    fn u64(&mut self, field: &str) -> Result<u64, DemError> {
        let b = self.take(8, field)?;
        Ok(u64::from_be_bytes([
            b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7],
        ]))
    }

    /// A NON_NEG count: a 32-bit integer that must not have its sign bit set.
    fn non_neg(&mut self, field: &str) -> Result<usize, DemError> {
        let at = self.pos;
        let v = self.u32(field)?;
        if v > i32::MAX as u32 {
            return Err(self.err(field, format!("negative count {} at byte {at}", v as i32)));
        }
        Ok(v as usize)
    }

    /// Skips padding to the next multiple of 4 of `n` bytes just read.
    fn pad(&mut self, n: usize, field: &str) -> Result<(), DemError> {
        let p = (4 - n % 4) % 4;
        self.take(p, field).map(|_| ())
    }

    fn name(&mut self, field: &str) -> Result<String, DemError> {
        let at = self.pos;
        let n = self.non_neg(field)?;
        if n == 0 {
            return Err(self.err(field, format!("empty name at byte {at}")));
        }
        let b = self.take(n, field)?;
        let s = std::str::from_utf8(b)
            .map_err(|_| self.err(field, format!("name at byte {at} is not UTF-8")))?
            .to_string();
        self.pad(n, field)?;
        Ok(s)
    }

    /// A list header: ABSENT (two zero words) or `tag nelems`.
    fn list_header(&mut self, tag: u32, field: &str) -> Result<usize, DemError> {
        let at = self.pos;
        let t = self.u32(field)?;
        let n = self.non_neg(field)?;
        if t == 0 {
            if n != 0 {
                return Err(self.err(
                    field,
                    format!("ABSENT list at byte {at} has a non-zero count {n}"),
                ));
            }
            return Ok(0);
        }
        if t != tag {
            return Err(self.err(
                field,
                format!("expected tag {tag:#x} or ABSENT at byte {at}, found {t:#x}"),
            ));
        }
        Ok(n)
    }

    fn nc_type(&mut self, field: &str) -> Result<NcType, DemError> {
        let at = self.pos;
        let c = self.u32(field)?;
        NcType::from_code(c).ok_or_else(|| {
            self.err(
                field,
                format!("unknown nc_type {c} at byte {at} (expected 1..=6)"),
            )
        })
    }

    fn att_list(&mut self, field: &str) -> Result<Vec<Attribute>, DemError> {
        let n = self.list_header(NC_ATTRIBUTE, field)?;
        let mut out = Vec::new();
        for i in 0..n {
            let f = format!("{field}[{i}]");
            let name = self.name(&format!("{f}.name"))?;
            let f = format!("{field}[{name:?}]");
            let ty = self.nc_type(&format!("{f}.nc_type"))?;
            let count = self.non_neg(&format!("{f}.nelems"))?;
            let vf = format!("{f}.values");
            let len = count
                .checked_mul(ty.size())
                .ok_or_else(|| self.err(&vf, format!("{count} values overflow")))?;
            let b = self.take(len, &vf)?;
            let value = match ty {
                NcType::Byte => AttrValue::Bytes(b.iter().map(|&x| x as i8).collect()),
                NcType::Char => {
                    let end = b.iter().rposition(|&c| c != 0).map_or(0, |p| p + 1);
                    AttrValue::Text(String::from_utf8_lossy(&b[..end]).into_owned())
                }
                NcType::Short => AttrValue::Shorts(
                    b.chunks_exact(2)
                        .map(|c| i16::from_be_bytes([c[0], c[1]]))
                        .collect(),
                ),
                NcType::Int => AttrValue::Ints(
                    b.chunks_exact(4)
                        .map(|c| i32::from_be_bytes([c[0], c[1], c[2], c[3]]))
                        .collect(),
                ),
                NcType::Float => AttrValue::Floats(
                    b.chunks_exact(4)
                        .map(|c| f32::from_be_bytes([c[0], c[1], c[2], c[3]]))
                        .collect(),
                ),
                NcType::Double => AttrValue::Doubles(
                    b.chunks_exact(8)
                        .map(|c| {
                            f64::from_be_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]])
                        })
                        .collect(),
                ),
            };
            self.pad(len, &vf)?;
            out.push(Attribute { name, value });
        }
        Ok(out)
    }
    /// `magic`: 'CDF' and a version byte of 1 or 2 (HDF5 and CDF-5 are named as such).
    fn magic(&mut self) -> Result<u8, DemError> {
        let magic = self.take(4, "magic")?;
        if &magic[..3] != b"CDF" {
            let hint = if magic == b"\x89HDF" {
                " (this is HDF5, i.e. netCDF-4, which is not supported)"
            } else {
                ""
            };
            return Err(self.err(
                "magic",
                format!("expected 'CDF\\x01' or 'CDF\\x02', found {magic:02x?}{hint}"),
            ));
        }
        let version = magic[3];
        if version != 1 && version != 2 {
            let hint = if version == 5 {
                " (CDF-5, the 64-bit data format, is not supported)"
            } else {
                ""
            };
            return Err(self.err(
                "magic",
                format!("unsupported version byte {version} (expected 1 or 2){hint}"),
            ));
        }
        Ok(version)
    }

    /// `numrecs`: a count, or [`STREAMING`] (the count is whatever fits in the file).
    fn numrecs(&mut self) -> Result<u32, DemError> {
        let raw = self.u32("numrecs")?;
        if raw != STREAMING && raw > i32::MAX as u32 {
            return Err(self.err("numrecs", format!("negative count {}", raw as i32)));
        }
        Ok(raw)
    }

    /// `dim_list`, and the index of the record (length 0) dimension if there is one.
    fn dim_list(&mut self) -> Result<(Vec<Dimension>, Option<usize>), DemError> {
        let ndims = self.list_header(NC_DIMENSION, "dim_list")?;
        let mut dims: Vec<Dimension> = Vec::new();
        let mut record_dim: Option<usize> = None;
        for i in 0..ndims {
            let name = self.name(&format!("dim_list[{i}].name"))?;
            let len = self.non_neg(&format!("dim_list[{name:?}].dim_length"))?;
            if len == 0 {
                if let Some(r) = record_dim {
                    return Err(self.err(
                        &format!("dim_list[{name:?}].dim_length"),
                        format!(
                            "second record (length 0) dimension; {:?} is already one",
                            dims[r].name
                        ),
                    ));
                }
                record_dim = Some(i);
            }
            dims.push(Dimension {
                name,
                len,
                is_record: len == 0,
            });
        }
        Ok((dims, record_dim))
    }

    /// `var_list`: every dimension id must exist, and the record dimension may only come first.
    fn var_list(
        &mut self,
        version: u8,
        dims: &[Dimension],
        record_dim: Option<usize>,
    ) -> Result<Vec<Variable>, DemError> {
        let nvars = self.list_header(NC_VARIABLE, "var_list")?;
        let mut vars = Vec::new();
        for i in 0..nvars {
            let name = self.name(&format!("var_list[{i}].name"))?;
            let f = format!("var_list[{name:?}]");
            let nd = self.non_neg(&format!("{f}.ndims"))?;
            let mut dim_ids = Vec::new();
            for k in 0..nd {
                let fk = format!("{f}.dimid[{k}]");
                let at = self.pos;
                let id = self.non_neg(&fk)?;
                if id >= dims.len() {
                    return Err(self.err(
                        &fk,
                        format!(
                            "dimension id {id} at byte {at} but the file has {} dimensions",
                            dims.len()
                        ),
                    ));
                }
                if k > 0 && Some(id) == record_dim {
                    return Err(self.err(
                        &fk,
                        "the record dimension may only be a variable's first dimension",
                    ));
                }
                dim_ids.push(id);
            }
            let attributes = self.att_list(&format!("{f}.vatt_list"))?;
            let nc_type = self.nc_type(&format!("{f}.nc_type"))?;
            let vsize = u64::from(self.u32(&format!("{f}.vsize"))?);
            let begin = if version == 1 {
                u64::from(self.u32(&format!("{f}.begin"))?)
            } else {
                self.u64(&format!("{f}.begin"))?
            };
            let is_record = dim_ids.first().is_some_and(|&d| Some(d) == record_dim);
            vars.push(Variable {
                name,
                dim_ids,
                attributes,
                nc_type,
                vsize,
                begin,
                is_record,
            });
        }
        Ok(vars)
    }
}

/// `n` rounded up to a multiple of 4; `None` past `u64::MAX`.
fn pad4(n: u64) -> Option<u64> {
    n.div_ceil(4).checked_mul(4)
}

impl NetcdfFile {
    /// Opens and memory-maps a netCDF-3 classic file and parses its header. The data extents of
    /// every variable are checked against the file's length.
    pub fn open(path: impl AsRef<Path>) -> Result<NetcdfFile, DemError> {
        let path = path.as_ref().to_path_buf();
        let map = MappedFile::open(&path)?;
        Self::parse(path, map)
    }

    /// A netCDF-3 file's bytes already in memory, parsed and checked exactly as
    /// [`NetcdfFile::open`] does a file (`name` names them in errors). For tests and the fuzz
    /// harness, which hand the reader bytes without a file.
    pub fn from_bytes(bytes: Vec<u8>, name: impl AsRef<Path>) -> Result<NetcdfFile, DemError> {
        let path = name.as_ref().to_path_buf();
        let map = MappedFile::from_bytes(&path, bytes);
        Self::parse(path, map)
    }

    fn parse(path: PathBuf, map: MappedFile) -> Result<NetcdfFile, DemError> {
        let mut c = Cursor {
            bytes: &map,
            pos: 0,
            path: &path,
        };
        let version = c.magic()?;
        let numrecs_raw = c.numrecs()?;
        let (dims, record_dim) = c.dim_list()?;
        let global_attrs = c.att_list("gatt_list")?;
        let vars = c.var_list(version, &dims, record_dim)?;
        let header_end = c.pos;

        let mut nc = NetcdfFile {
            path,
            map,
            version,
            num_records: 0,
            record_size: 0,
            dims,
            global_attrs,
            vars,
        };
        nc.count_records(numrecs_raw, record_dim)?;
        nc.check_data_extents(header_end)?;
        Ok(nc)
    }

    /// Sets the record size, the number of records and the record dimension's length.
    fn count_records(
        &mut self,
        numrecs_raw: u32,
        record_dim: Option<usize>,
    ) -> Result<(), DemError> {
        // Record size: the sum of the record variables' padded slab sizes, except that a lone
        // record variable's records are not padded (netCDF classic format spec, "Note on vsize").
        let mut rec_slabs = Vec::new();
        for v in self.vars.iter().filter(|v| v.is_record) {
            rec_slabs.push(self.slab_bytes(v).ok_or_else(|| {
                self.header_err(&format!("var_list[{:?}]", v.name), "size overflows")
            })?);
        }
        self.record_size = match rec_slabs.as_slice() {
            [] => 0,
            [one] => *one,
            many => {
                let mut sum = 0u64;
                let record_vars = self.vars.iter().filter(|v| v.is_record);
                for (&slab, v) in many.iter().zip(record_vars) {
                    sum = pad4(slab).and_then(|s| sum.checked_add(s)).ok_or_else(|| {
                        self.header_err(
                            &format!("var_list[{:?}]", v.name),
                            format!(
                                "record size overflows: this record variable's {slab}-byte \
                                 slab brings a record past 2^64 bytes; expected records that \
                                 fit a file"
                            ),
                        )
                    })?;
                }
                sum
            }
        };
        let file_len = self.map.len() as u64;
        self.num_records = if numrecs_raw == STREAMING {
            // Streaming: the record count is whatever fits in the file.
            let first = self
                .vars
                .iter()
                .filter(|v| v.is_record)
                .map(|v| v.begin)
                .min()
                .unwrap_or(file_len);
            file_len
                .saturating_sub(first)
                .checked_div(self.record_size)
                .unwrap_or(0) as usize
        } else {
            numrecs_raw as usize
        };
        if let Some(r) = record_dim {
            self.dims[r].len = self.num_records;
        }
        Ok(())
    }

    /// Every variable's data must lie after the header and inside the file.
    fn check_data_extents(&self, header_end: usize) -> Result<(), DemError> {
        let file_len = self.map.len() as u64;
        for v in &self.vars {
            let f = format!("var_list[{:?}].begin", v.name);
            let total = self
                .data_extent(v)
                .ok_or_else(|| self.header_err(&f, "data size overflows"))?;
            if total == 0 {
                continue;
            }
            if v.begin < header_end as u64 {
                return Err(self.header_err(
                    &f,
                    format!(
                        "data offset {} lies inside the header (which ends at byte {header_end})",
                        v.begin
                    ),
                ));
            }
            let end = v.begin.checked_add(total);
            if end.is_none_or(|e| e > file_len) {
                return Err(self.header_err(
                    &f,
                    format!(
                        "data of {total} bytes from offset {} runs past the end of the file \
                         ({file_len} bytes): truncated file?",
                        v.begin
                    ),
                ));
            }
        }
        Ok(())
    }

    pub(super) fn header_err(&self, field: &str, message: impl Into<String>) -> DemError {
        DemError::Header {
            path: self.path.clone(),
            field: field.to_string(),
            message: message.into(),
        }
    }

    pub(super) fn data_err(&self, message: impl Into<String>) -> DemError {
        DemError::Data {
            path: self.path.clone(),
            message: message.into(),
        }
    }

    /// Bytes of one record's slab (record variable) or of the whole variable.
    fn slab_bytes(&self, v: &Variable) -> Option<u64> {
        let skip = usize::from(v.is_record);
        v.dim_ids[skip..]
            .iter()
            .try_fold(v.nc_type.size() as u64, |acc, &d| {
                acc.checked_mul(self.dims[d].len as u64)
            })
    }

    /// Bytes spanned by the variable's data from `begin` (all records included).
    fn data_extent(&self, v: &Variable) -> Option<u64> {
        let slab = self.slab_bytes(v)?;
        if !v.is_record {
            return Some(slab);
        }
        if self.num_records == 0 || slab == 0 {
            return Some(0);
        }
        (self.num_records as u64 - 1)
            .checked_mul(self.record_size)?
            .checked_add(slab)
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// 1 for CDF-1 (classic), 2 for CDF-2 (64-bit offset).
    pub fn version(&self) -> u8 {
        self.version
    }

    pub fn num_records(&self) -> usize {
        self.num_records
    }

    pub fn dimensions(&self) -> &[Dimension] {
        &self.dims
    }

    pub fn global_attributes(&self) -> &[Attribute] {
        &self.global_attrs
    }

    pub fn global_attribute(&self, name: &str) -> Option<&AttrValue> {
        self.global_attrs
            .iter()
            .find(|a| a.name == name)
            .map(|a| &a.value)
    }

    pub fn variables(&self) -> &[Variable] {
        &self.vars
    }

    pub fn variable(&self, name: &str) -> Option<&Variable> {
        self.vars.iter().find(|v| v.name == name)
    }

    /// An attribute of variable `var`.
    pub fn attribute(&self, var: &str, name: &str) -> Option<&AttrValue> {
        self.variable(var)?.attribute(name)
    }

    /// Dimension lengths of a variable (the record dimension's is the number of records).
    pub fn shape(&self, var: &str) -> Option<Vec<usize>> {
        let v = self.variable(var)?;
        Some(v.dim_ids.iter().map(|&d| self.dims[d].len).collect())
    }

    pub(super) fn missing_var_err(&self, var: &str) -> DemError {
        let names: Vec<&str> = self.vars.iter().map(|v| v.name.as_str()).collect();
        self.data_err(format!("no variable {var:?} (variables: {names:?})"))
    }

    fn variable_or_err(&self, var: &str) -> Result<&Variable, DemError> {
        self.variable(var).ok_or_else(|| self.missing_var_err(var))
    }

    /// Number of elements of a variable.
    pub fn len(&self, var: &str) -> Result<usize, DemError> {
        let v = self.variable_or_err(var)?;
        Ok(self.element_count(v))
    }

    fn element_count(&self, v: &Variable) -> usize {
        // Cannot overflow: data_extent was checked against the file length in `open`, except
        // for zero-size variables, whose product is then 0 anyway (saturating keeps it so).
        v.dim_ids
            .iter()
            .fold(1usize, |acc, &d| acc.saturating_mul(self.dims[d].len))
    }

    /// Decodes `count` elements starting at flat (row-major) element index `start` of a
    /// variable into `out`, raw values (no scale, offset or fill handling), as f64.
    pub fn read_f64_into(&self, var: &str, start: usize, out: &mut [f64]) -> Result<(), DemError> {
        let v = self.variable_or_err(var)?;
        self.read_var_with(v, start, out.len(), |i, x| out[i] = x)
    }

    /// All elements of a variable, raw (no scale, offset or fill handling), as f64.
    pub fn read_f64(&self, var: &str) -> Result<Vec<f64>, DemError> {
        let v = self.variable_or_err(var)?;
        let n = self.element_count(v);
        let mut out = vec![0.0; n];
        self.read_var_with(v, 0, n, |i, x| out[i] = x)?;
        Ok(out)
    }

    /// Calls `sink(i, value)` for elements `start..start + count` (flat, row-major).
    pub(super) fn read_var_with(
        &self,
        v: &Variable,
        start: usize,
        count: usize,
        mut sink: impl FnMut(usize, f64),
    ) -> Result<(), DemError> {
        let total = self.element_count(v);
        if start.checked_add(count).is_none_or(|e| e > total) {
            return Err(self.data_err(format!(
                "variable {:?}: elements {start}..{} requested but it has {total}",
                v.name,
                start.saturating_add(count)
            )));
        }
        let es = v.nc_type.size();
        let bytes: &[u8] = &self.map;
        // Elements per record (record variables) or all of them.
        let per_rec = if v.is_record {
            // Fits: at most `total`, which is in range.
            (self.slab_bytes(v).unwrap_or(0) / es as u64) as usize
        } else {
            total
        };
        let mut i = 0;
        while i < count {
            let flat = start + i;
            let (rec, within) = (flat / per_rec.max(1), flat % per_rec.max(1));
            let run = (per_rec - within).min(count - i);
            let off = v.begin + rec as u64 * self.record_size + (within * es) as u64;
            // In bounds: checked against the file length in `open`.
            let off = off as usize;
            let chunk = bytes.get(off..off + run * es).ok_or_else(|| {
                self.data_err(format!(
                    "variable {:?}: bytes {off}..{} lie outside the file",
                    v.name,
                    off + run * es
                ))
            })?;
            for (k, e) in chunk.chunks_exact(es).enumerate() {
                sink(i + k, v.nc_type.decode(e));
            }
            i += run;
        }
        Ok(())
    }
}
