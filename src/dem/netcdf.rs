//! A reader of our own for netCDF-3 classic files (CDF-1, and CDF-2 "64-bit offset"), and a
//! raster adaptor for ETOPO-style global grids (DESIGN.md "Data": ETOPO5 from Debian's
//! `ferret-datasets`).
//!
//! The header is parsed per the netCDF classic format specification:
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
//! memory-mapped and values are decoded on demand.
//!
//! [`NetcdfRaster`] turns a 2-D latitude × longitude variable into a [`RasterSource`]: rows run
//! north → south whatever the file's order, coordinate axes close to a regular grid are replaced
//! by the exact regular values (reported by [`NetcdfRaster::notes`]), `scale_factor`/`add_offset`
//! and `_FillValue`/`missing_value` are applied (fill → `NaN`), and heights in feet become metres.

use std::fmt;
use std::fs::File;
use std::path::{Path, PathBuf};

use memmap2::Mmap;

use super::DemError;
use super::raster::{GeoGrid, RasterSource};

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
    fn default_fill(self) -> f64 {
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
    map: Mmap,
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
}

fn pad4(n: u64) -> u64 {
    n.div_ceil(4) * 4
}

impl NetcdfFile {
    /// Opens and memory-maps a netCDF-3 classic file and parses its header. The data extents of
    /// every variable are checked against the file's length.
    pub fn open(path: impl AsRef<Path>) -> Result<NetcdfFile, DemError> {
        let path = path.as_ref().to_path_buf();
        let io = |source| DemError::Io {
            path: path.clone(),
            source,
        };
        let file = File::open(&path).map_err(io)?;
        // SAFETY: the map is read-only; as with every memory-mapped reader, the file must not be
        // truncated by another process while it is mapped.
        let map = unsafe { Mmap::map(&file) }.map_err(io)?;
        Self::parse(path, map)
    }

    fn parse(path: PathBuf, map: Mmap) -> Result<NetcdfFile, DemError> {
        let bytes: &[u8] = &map;
        let mut c = Cursor {
            bytes,
            pos: 0,
            path: &path,
        };
        let magic = c.take(4, "magic")?;
        if &magic[..3] != b"CDF" {
            let hint = if magic == b"\x89HDF" {
                " (this is HDF5, i.e. netCDF-4, which is not supported)"
            } else {
                ""
            };
            return Err(c.err(
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
            return Err(c.err(
                "magic",
                format!("unsupported version byte {version} (expected 1 or 2){hint}"),
            ));
        }
        let numrecs_raw = c.u32("numrecs")?;
        if numrecs_raw != STREAMING && numrecs_raw > i32::MAX as u32 {
            return Err(c.err("numrecs", format!("negative count {}", numrecs_raw as i32)));
        }

        let ndims = c.list_header(NC_DIMENSION, "dim_list")?;
        let mut dims: Vec<Dimension> = Vec::new();
        let mut record_dim: Option<usize> = None;
        for i in 0..ndims {
            let name = c.name(&format!("dim_list[{i}].name"))?;
            let len = c.non_neg(&format!("dim_list[{name:?}].dim_length"))?;
            if len == 0 {
                if let Some(r) = record_dim {
                    return Err(c.err(
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

        let global_attrs = c.att_list("gatt_list")?;

        let nvars = c.list_header(NC_VARIABLE, "var_list")?;
        let mut vars = Vec::new();
        for i in 0..nvars {
            let name = c.name(&format!("var_list[{i}].name"))?;
            let f = format!("var_list[{name:?}]");
            let nd = c.non_neg(&format!("{f}.ndims"))?;
            let mut dim_ids = Vec::new();
            for k in 0..nd {
                let fk = format!("{f}.dimid[{k}]");
                let at = c.pos;
                let id = c.non_neg(&fk)?;
                if id >= dims.len() {
                    return Err(c.err(
                        &fk,
                        format!(
                            "dimension id {id} at byte {at} but the file has {} dimensions",
                            dims.len()
                        ),
                    ));
                }
                if k > 0 && Some(id) == record_dim {
                    return Err(c.err(
                        &fk,
                        "the record dimension may only be a variable's first dimension",
                    ));
                }
                dim_ids.push(id);
            }
            let attributes = c.att_list(&format!("{f}.vatt_list"))?;
            let nc_type = c.nc_type(&format!("{f}.nc_type"))?;
            let vsize = u64::from(c.u32(&format!("{f}.vsize"))?);
            let begin = if version == 1 {
                u64::from(c.u32(&format!("{f}.begin"))?)
            } else {
                c.u64(&format!("{f}.begin"))?
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

        // Record size: the sum of the record variables' padded slab sizes, except that a lone
        // record variable's records are not padded (netCDF classic format spec, "Note on vsize").
        let mut rec_slabs = Vec::new();
        for v in nc.vars.iter().filter(|v| v.is_record) {
            rec_slabs.push(nc.slab_bytes(v).ok_or_else(|| {
                nc.header_err(&format!("var_list[{:?}]", v.name), "size overflows")
            })?);
        }
        nc.record_size = match rec_slabs.as_slice() {
            [] => 0,
            [one] => *one,
            many => many.iter().map(|&s| pad4(s)).sum(),
        };
        let file_len = nc.map.len() as u64;
        nc.num_records = if numrecs_raw == STREAMING {
            // Streaming: the record count is whatever fits in the file.
            let first = nc
                .vars
                .iter()
                .filter(|v| v.is_record)
                .map(|v| v.begin)
                .min()
                .unwrap_or(file_len);
            file_len
                .saturating_sub(first)
                .checked_div(nc.record_size)
                .unwrap_or(0) as usize
        } else {
            numrecs_raw as usize
        };
        if let Some(r) = record_dim {
            nc.dims[r].len = nc.num_records;
        }

        // Every variable's data must lie after the header and inside the file.
        for v in &nc.vars {
            let f = format!("var_list[{:?}].begin", v.name);
            let total = nc
                .data_extent(v)
                .ok_or_else(|| nc.header_err(&f, "data size overflows"))?;
            if total == 0 {
                continue;
            }
            if v.begin < header_end as u64 {
                return Err(nc.header_err(
                    &f,
                    format!(
                        "data offset {} lies inside the header (which ends at byte {header_end})",
                        v.begin
                    ),
                ));
            }
            let end = v.begin.checked_add(total);
            if end.is_none_or(|e| e > file_len) {
                return Err(nc.header_err(
                    &f,
                    format!(
                        "data of {total} bytes from offset {} runs past the end of the file \
                         ({file_len} bytes): truncated file?",
                        v.begin
                    ),
                ));
            }
        }
        Ok(nc)
    }

    fn header_err(&self, field: &str, message: impl Into<String>) -> DemError {
        DemError::Header {
            path: self.path.clone(),
            field: field.to_string(),
            message: message.into(),
        }
    }

    fn data_err(&self, message: impl Into<String>) -> DemError {
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

    fn missing_var_err(&self, var: &str) -> DemError {
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
    fn read_var_with(
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

// ---------------------------------------------------------------------------------------------
// Raster adaptor
// ---------------------------------------------------------------------------------------------

/// A regular axis fitted to a stored coordinate variable.
#[derive(Clone, Copy, Debug)]
struct Axis {
    /// Value at index 0 of the axis as stored.
    first: f64,
    /// Signed step per index as stored (negative for a descending axis).
    step: f64,
    /// A longitude axis whose last value repeats the first one 360° on (n − 1 steps span the
    /// circle): the last column duplicates the first.
    repeats_first: bool,
}

/// How far (in units of the spacing) a stored coordinate may be from the regular grid and still
/// be taken as that grid.
pub const AXIS_TOLERANCE: f64 = 0.1;

/// Relative difference within which a stored spacing is taken as a round value (a whole number
/// of arc-seconds, or 1/k degree).
const SPACING_SNAP: f64 = 1e-5;

/// Fits an exact regular axis to stored coordinates (values in degrees).
///
/// - Spacing: 360/n for a longitude axis that covers the circle (360/(n−1) when the last value
///   repeats the first), 180/(n−1) for a latitude axis from pole to pole, else a whole number of
///   arc-seconds or 1/k degree when within [`SPACING_SNAP`], else as stored.
/// - First value: rounded to the nearest multiple of half the spacing when close (pixel centres
///   sit on whole or half steps from 0° in every common grid); ±90° exactly for pole to pole.
/// - Every stored value must then lie within [`AXIS_TOLERANCE`] spacing of the regular grid.
///
/// Returns the axis and, when the regular values differ from the stored ones, a note.
fn fit_axis(name: &str, values: &[f64], is_lon: bool) -> Result<(Axis, Option<String>), String> {
    let n = values.len();
    if n < 2 {
        return Err(format!(
            "coordinate {name:?} has {n} value(s); at least 2 are needed for a spacing"
        ));
    }
    if values.iter().any(|v| !v.is_finite()) {
        return Err(format!("coordinate {name:?} has non-finite values"));
    }
    let (a, b) = (values[0], values[n - 1]);
    let raw = (b - a) / (n - 1) as f64;
    if raw == 0.0 {
        return Err(format!("coordinate {name:?} is constant ({a})"));
    }
    let sign = raw.signum();
    let mag = raw.abs();
    let close = |x: f64, y: f64| (x - y).abs() <= AXIS_TOLERANCE * mag;

    let full_circle = is_lon && close(n as f64 * mag, 360.0);
    let repeats_first = is_lon && !full_circle && close((n - 1) as f64 * mag, 360.0);
    let pole_to_pole = !is_lon && close(a.abs(), 90.0) && close(b.abs(), 90.0) && a * b < 0.0;
    let (d, how) = if full_circle {
        (360.0 / n as f64, "covers the circle: spacing 360°/n")
    } else if repeats_first {
        (
            360.0 / (n - 1) as f64,
            "last value repeats the first 360° on: spacing 360°/(n−1)",
        )
    } else if pole_to_pole {
        (180.0 / (n - 1) as f64, "pole to pole: spacing 180°/(n−1)")
    } else {
        let arcsec = (mag * 3600.0).round() / 3600.0;
        let k = (1.0 / mag).round();
        if arcsec > 0.0 && (arcsec - mag).abs() <= SPACING_SNAP * mag {
            (arcsec, "spacing a whole number of arc-seconds")
        } else if k >= 1.0 && (1.0 / k - mag).abs() <= SPACING_SNAP * mag {
            (1.0 / k, "spacing 1/k degree")
        } else {
            (mag, "")
        }
    };
    let half = d / 2.0;
    let snapped = (a / half).round() * half;
    let first = if pole_to_pole {
        90.0_f64.copysign(a)
    } else if close(snapped, a) {
        snapped
    } else {
        a
    };
    let step = d * sign;
    let mut worst: f64 = 0.0;
    for (i, &v) in values.iter().enumerate() {
        worst = worst.max((v - (first + i as f64 * step)).abs());
    }
    if worst > AXIS_TOLERANCE * d {
        return Err(format!(
            "coordinate {name:?} is not a regular grid: a value is {worst:.6}° from the best \
             regular fit (first {first}, spacing {d}); the tolerance is {AXIS_TOLERANCE} spacing"
        ));
    }
    let note = (worst > 0.0 || first != a || step != raw).then(|| {
        format!(
            "coordinate {name:?} ({n} values, stored {a}…{b}, step {raw}) taken as the regular \
             grid {first} + i·{step}{}; largest stored deviation {worst:.3e}° ({:.2e} of a spacing)",
            if how.is_empty() {
                String::new()
            } else {
                format!(" ({how})")
            },
            worst / d
        )
    });
    Ok((
        Axis {
            first,
            step,
            repeats_first,
        },
        note,
    ))
}

/// Unit conversion to metres of a height variable's `units` attribute, or `None` if unknown.
fn metres_per_unit(units: &str) -> Option<f64> {
    let u = units.trim().to_ascii_lowercase();
    match u.as_str() {
        "m" | "meter" | "meters" | "metre" | "metres" => Some(1.0),
        "ft" | "feet" | "foot" | "international_foot" | "international_feet" => Some(0.3048),
        "km" | "kilometer" | "kilometers" | "kilometre" | "kilometres" => Some(1000.0),
        _ => None,
    }
}

/// Which role a dimension's coordinate plays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    Lat,
    Lon,
}

fn role_of(nc: &NetcdfFile, dim_name: &str) -> Option<Role> {
    let coord = nc.variable(dim_name);
    let text = |a: &str| {
        coord
            .and_then(|v| v.attribute(a))
            .and_then(AttrValue::as_text)
            .map(|s| s.trim().to_ascii_lowercase())
    };
    if let Some(u) = text("units") {
        if u.starts_with("degrees_north") || u == "degree_north" || u == "degrees_n" {
            return Some(Role::Lat);
        }
        if u.starts_with("degrees_east") || u == "degree_east" || u == "degrees_e" {
            return Some(Role::Lon);
        }
    }
    if let Some(s) = text("standard_name") {
        match s.as_str() {
            "latitude" => return Some(Role::Lat),
            "longitude" => return Some(Role::Lon),
            _ => {}
        }
    }
    if let Some(ax) = text("axis") {
        match ax.as_str() {
            "y" => return Some(Role::Lat),
            "x" => return Some(Role::Lon),
            _ => {}
        }
    }
    let n = dim_name.to_ascii_lowercase();
    if n.starts_with("lat") || n == "y" || n.ends_with("_y") {
        return Some(Role::Lat);
    }
    if n.starts_with("lon") || n == "x" || n.ends_with("_x") {
        return Some(Role::Lon);
    }
    None
}

/// A 2-D latitude × longitude variable of a netCDF-3 file as a [`RasterSource`] of heights in
/// metres, rows north → south.
pub struct NetcdfRaster {
    nc: NetcdfFile,
    var: usize,
    grid: GeoGrid,
    /// Flat element index of output (row 0, col 0), and strides per output row / column.
    origin: isize,
    row_stride: isize,
    col_stride: isize,
    scale: f64,
    offset: f64,
    /// Raw values that mean "no data".
    fills: Vec<f64>,
    /// Raw values outside `[valid_min, valid_max]` are no data.
    valid: (f64, f64),
    to_metres: f64,
    notes: Vec<String>,
}

impl fmt::Debug for NetcdfRaster {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("NetcdfRaster")
            .field("path", &self.nc.path)
            .field("variable", &self.nc.vars[self.var].name)
            .field("grid", &self.grid)
            .field("notes", &self.notes)
            .finish()
    }
}

impl NetcdfRaster {
    /// Opens a netCDF-3 file as a raster. `variable` names the height variable; `None` picks the
    /// only 2-D numeric variable whose dimensions both have coordinate variables (or, failing
    /// that, the only 2-D numeric variable).
    pub fn open(path: impl AsRef<Path>, variable: Option<&str>) -> Result<NetcdfRaster, DemError> {
        Self::from_file(NetcdfFile::open(path)?, variable)
    }

    /// As [`NetcdfRaster::open`], from an already opened file.
    pub fn from_file(nc: NetcdfFile, variable: Option<&str>) -> Result<NetcdfRaster, DemError> {
        let err = |field: &str, message: String| DemError::Header {
            path: nc.path.clone(),
            field: field.to_string(),
            message,
        };
        let numeric = |v: &Variable| v.nc_type != NcType::Char;
        let var = match variable {
            Some(name) => {
                let i = nc
                    .vars
                    .iter()
                    .position(|v| v.name == name)
                    .ok_or_else(|| nc.missing_var_err(name))?;
                let v = &nc.vars[i];
                if v.dim_ids.len() != 2 || !numeric(v) {
                    return Err(err(
                        &format!("var_list[{name:?}]"),
                        format!(
                            "expected a 2-D numeric variable, found {}-D {}",
                            v.dim_ids.len(),
                            v.nc_type
                        ),
                    ));
                }
                i
            }
            None => {
                let two_d: Vec<usize> = (0..nc.vars.len())
                    .filter(|&i| nc.vars[i].dim_ids.len() == 2 && numeric(&nc.vars[i]))
                    .collect();
                let with_coords: Vec<usize> = two_d
                    .iter()
                    .copied()
                    .filter(|&i| {
                        nc.vars[i].dim_ids.iter().all(|&d| {
                            nc.variable(&nc.dims[d].name)
                                .is_some_and(|c| c.dim_ids == [d])
                        })
                    })
                    .collect();
                match (with_coords.as_slice(), two_d.as_slice()) {
                    ([one], _) | ([], [one]) => *one,
                    _ => {
                        let names: Vec<&str> =
                            two_d.iter().map(|&i| nc.vars[i].name.as_str()).collect();
                        return Err(err(
                            "var_list",
                            format!(
                                "cannot pick the height variable: expected exactly one 2-D \
                                 numeric variable, found {names:?}; name one"
                            ),
                        ));
                    }
                }
            }
        };
        let v = &nc.vars[var];
        let vname = v.name.clone();
        let vf = format!("var_list[{vname:?}]");
        let mut notes = Vec::new();

        // Which dimension is latitude, which longitude.
        let dnames: Vec<String> = v.dim_ids.iter().map(|&d| nc.dims[d].name.clone()).collect();
        let roles = [role_of(&nc, &dnames[0]), role_of(&nc, &dnames[1])];
        let lat_first = match roles {
            [Some(Role::Lat), Some(Role::Lon) | None] | [None, Some(Role::Lon)] => true,
            [Some(Role::Lon), Some(Role::Lat) | None] | [None, Some(Role::Lat)] => false,
            [None, None] => {
                notes.push(format!(
                    "dimensions {dnames:?} not recognised as latitude/longitude; assumed \
                     (latitude, longitude)"
                ));
                true
            }
            _ => {
                return Err(err(
                    &format!("{vf}.dimensions"),
                    format!(
                        "expected one latitude and one longitude dimension, found {dnames:?} \
                         taken as {roles:?}"
                    ),
                ));
            }
        };
        let (lat_dim, lon_dim) = if lat_first {
            (v.dim_ids[0], v.dim_ids[1])
        } else {
            (v.dim_ids[1], v.dim_ids[0])
        };
        let (nlat, nlon_stored) = (nc.dims[lat_dim].len, nc.dims[lon_dim].len);
        if nlat < 2 || nlon_stored < 2 {
            return Err(err(
                &format!("{vf}.dimensions"),
                format!(
                    "need at least 2×2 nodes, found {nlon_stored} longitudes × {nlat} latitudes"
                ),
            ));
        }

        let mut axis = |dim: usize, is_lon: bool| -> Result<Axis, DemError> {
            let dname = &nc.dims[dim].name;
            let c = nc
                .variable(dname)
                .filter(|c| c.dim_ids == [dim] && numeric(c))
                .ok_or_else(|| {
                    err(
                        &format!("var_list[{dname:?}]"),
                        format!(
                            "no 1-D coordinate variable for dimension {dname:?}, so the \
                             {} of the nodes are unknown",
                            if is_lon { "longitudes" } else { "latitudes" }
                        ),
                    )
                })?;
            let mut vals = nc.read_f64(&c.name)?;
            let s = c.attribute("scale_factor").and_then(AttrValue::first_f64);
            let o = c.attribute("add_offset").and_then(AttrValue::first_f64);
            for x in &mut vals {
                *x = *x * s.unwrap_or(1.0) + o.unwrap_or(0.0);
            }
            let (a, note) = fit_axis(dname, &vals, is_lon)
                .map_err(|m| err(&format!("var_list[{dname:?}]"), m))?;
            notes.extend(note);
            Ok(a)
        };
        let lat = axis(lat_dim, false)?;
        let lon = axis(lon_dim, true)?;
        let dlat = lat.step.abs();
        let dlon = lon.step.abs();
        // A repeated wrap-around column is dropped (the output's last column).
        let nlon = nlon_stored - usize::from(lon.repeats_first);
        if lon.repeats_first {
            notes.push(format!(
                "the last of the {nlon_stored} longitudes repeats the first 360° on; that column \
                 is dropped, leaving {nlon} that cover the circle"
            ));
        }
        // Output rows run north → south, columns west → east.
        let lat_idx0 = if lat.step > 0.0 { nlat - 1 } else { 0 };
        let lon_idx0 = if lon.step > 0.0 { 0 } else { nlon_stored - 1 };
        let lat0 = lat.first + lat_idx0 as f64 * lat.step;
        let lon0 = lon.first + lon_idx0 as f64 * lon.step;
        if lat.step > 0.0 {
            notes.push("latitude runs south → north in the file; rows flipped".into());
        }
        if lon.step < 0.0 {
            notes.push("longitude runs east → west in the file; columns flipped".into());
        }
        if lat0 > 90.0 + 1e-9 || lat0 - (nlat - 1) as f64 * dlat < -90.0 - 1e-9 {
            return Err(err(
                &format!("var_list[{:?}]", nc.dims[lat_dim].name),
                format!(
                    "latitudes {}…{lat0} leave [−90°, 90°]",
                    lat0 - (nlat - 1) as f64 * dlat
                ),
            ));
        }
        let grid = GeoGrid {
            cols: nlon,
            rows: nlat,
            lon0_deg: lon0,
            lat0_deg: lat0,
            dlon_deg: dlon,
            dlat_deg: dlat,
        };
        // Element strides in the file for one step south / east.
        let (s_lat, s_lon) = if lat_first {
            (nlon_stored as isize, 1isize)
        } else {
            (1isize, nlat as isize)
        };
        let row_stride = if lat.step > 0.0 { -s_lat } else { s_lat };
        let col_stride = if lon.step > 0.0 { s_lon } else { -s_lon };
        let origin = lat_idx0 as isize * s_lat + lon_idx0 as isize * s_lon;

        // Packing, fill and units.
        let num = |a: &str| v.attribute(a).and_then(AttrValue::first_f64);
        let scale = num("scale_factor").unwrap_or(1.0);
        let offset = num("add_offset").unwrap_or(0.0);
        if scale != 1.0 || offset != 0.0 {
            notes.push(format!("values unpacked as raw·{scale} + {offset}"));
        }
        let mut fills = Vec::new();
        for a in ["_FillValue", "missing_value"] {
            if let Some(vals) = v.attribute(a).and_then(AttrValue::as_f64s) {
                fills.extend(vals);
            }
        }
        if v.attribute("_FillValue").is_none() && v.nc_type != NcType::Byte {
            fills.push(v.nc_type.default_fill());
        }
        // Compare in the variable's own type (a double attribute on a float variable).
        if v.nc_type == NcType::Float {
            for f in &mut fills {
                *f = f64::from(*f as f32);
            }
        }
        let mut valid = (f64::NEG_INFINITY, f64::INFINITY);
        if let Some(r) = v.attribute("valid_range").and_then(AttrValue::as_f64s)
            && r.len() == 2
        {
            valid = (r[0], r[1]);
        }
        if let Some(x) = num("valid_min") {
            valid.0 = x;
        }
        if let Some(x) = num("valid_max") {
            valid.1 = x;
        }
        let units = v.attribute("units").and_then(AttrValue::as_text);
        let to_metres = match units {
            Some(u) => match metres_per_unit(u) {
                Some(k) => {
                    if k != 1.0 {
                        notes.push(format!("heights in {u:?} converted to metres (×{k})"));
                    }
                    k
                }
                None => {
                    notes.push(format!("unknown height units {u:?}; taken as metres"));
                    1.0
                }
            },
            None => {
                notes.push("no units attribute; heights taken as metres".into());
                1.0
            }
        };

        Ok(NetcdfRaster {
            nc,
            var,
            grid,
            origin,
            row_stride,
            col_stride,
            scale,
            offset,
            fills,
            valid,
            to_metres,
            notes,
        })
    }

    /// The underlying file (header, attributes, other variables).
    pub fn file(&self) -> &NetcdfFile {
        &self.nc
    }

    /// The height variable's name.
    pub fn variable_name(&self) -> &str {
        &self.nc.vars[self.var].name
    }

    /// What the adaptor did beyond reading values: axes snapped to exact regular grids, rows
    /// flipped, units converted, values unpacked.
    pub fn notes(&self) -> &[String] {
        &self.notes
    }

    fn convert(&self, raw: f64) -> f32 {
        if raw.is_nan() || self.fills.contains(&raw) || raw < self.valid.0 || raw > self.valid.1 {
            return f32::NAN;
        }
        ((raw * self.scale + self.offset) * self.to_metres) as f32
    }

    /// Height in metres at node (row, col) (row 0 northernmost).
    pub fn value(&self, row: usize, col: usize) -> Result<f32, DemError> {
        if row >= self.grid.rows || col >= self.grid.cols {
            return Err(self.nc.data_err(format!(
                "node ({row}, {col}) outside the {}×{} grid",
                self.grid.rows, self.grid.cols
            )));
        }
        let flat = self.origin + row as isize * self.row_stride + col as isize * self.col_stride;
        let mut x = [0.0];
        self.nc
            .read_var_with(&self.nc.vars[self.var], flat as usize, 1, |_, v| x[0] = v)?;
        Ok(self.convert(x[0]))
    }
}

impl RasterSource for NetcdfRaster {
    fn grid(&self) -> GeoGrid {
        self.grid
    }

    fn read_row(&self, row: usize, out: &mut [f32]) -> Result<(), DemError> {
        let g = self.grid;
        if row >= g.rows || out.len() != g.cols {
            return Err(self.nc.data_err(format!(
                "read_row({row}) with a buffer of {} on a {}×{} grid (rows × cols)",
                out.len(),
                g.rows,
                g.cols
            )));
        }
        let v = &self.nc.vars[self.var];
        let start = self.origin + row as isize * self.row_stride;
        if self.col_stride == 1 {
            self.nc.read_var_with(v, start as usize, g.cols, |i, x| {
                out[i] = self.convert(x);
            })
        } else if self.col_stride == -1 {
            let first = start as usize + 1 - g.cols;
            self.nc.read_var_with(v, first, g.cols, |i, x| {
                out[g.cols - 1 - i] = self.convert(x);
            })
        } else {
            for (c, o) in out.iter_mut().enumerate() {
                let flat = start + c as isize * self.col_stride;
                let mut x = 0.0;
                self.nc
                    .read_var_with(v, flat as usize, 1, |_, val| x = val)?;
                *o = self.convert(x);
            }
            Ok(())
        }
    }

    fn describe(&self) -> String {
        format!(
            "netCDF-3 (CDF-{}) {} variable {:?}, {}×{} nodes at {}°",
            self.nc.version,
            self.nc.path.display(),
            self.variable_name(),
            self.grid.cols,
            self.grid.rows,
            self.grid.dlon_deg
        )
    }
}
