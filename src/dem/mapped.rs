//! The one memory map of the elevation layer: every reader that maps a file (the pyramid, EHdr
//! data files, netCDF-3 files) opens it here, so the `unsafe` call and its safety argument
//! stand in one place (`dem` denies `unsafe_code` everywhere else).
//!
//! The same type also holds a file's bytes already in memory ([`MappedFile::from_bytes`]): the
//! readers' `from_bytes` constructors (tests and the fuzz harness hand them bytes, no file),
//! which run exactly the checks of `open`.
//!
//! # Safety argument
//!
//! `Mmap::map` is `unsafe` because the slice it returns is only valid while nobody changes the
//! file underneath it. What this crate relies on, and what it does about each risk:
//!
//! * **Read-only, private to its owner.** The map is never written and never handed out beyond
//!   the borrow of its owner, so no Rust aliasing rule can be broken from inside the process.
//! * **Truncation raises SIGBUS.** A mapped file that another process shrinks *in place* faults
//!   on the next access past its new end; Rust cannot turn that into an error without a
//!   process-wide signal handler, which this crate does not install. So:
//!   - the length is measured ([`OpenFile::len`]) before mapping, callers validate it against
//!     their header before a byte is read, and [`OpenFile::map`] checks that the map is as long
//!     as that measured length;
//!   - [`MappedFile::current_len`] (one `fstat`) re-checks it later; the pyramid does so before
//!     every tile read;
//!   - every access is bounds-checked against the validated length, never the header's word;
//!   - files this crate writes are never truncated in place: the builder writes
//!     `FILE.partial` and renames it, so a reader's mapping keeps the old inode alive.
//!
//!   - [`MappedFile::observe`] gives the streamer's watcher (one `fstat` and one `stat` about
//!     once a second) what happened to the mapped inode and to the path since the open, so a
//!     truncation is reported (`crate::dem::FileChange`) and the tiles past the new end are
//!     refused by the per-read check instead of being touched.
//!
//!   What remains is a truncation in place racing an access between a check and the copy.
//!   A rename cannot cause it: the map holds the old inode, whose length no rename changes.
//!   Replace such files by renaming; never truncate one that a viewer has open
//!   (docs/streaming.md#files-changing-under-the-viewer).
//! * **Contents changed in place without a size change** are not a memory-safety issue for
//!   `&[u8]` reads of plain integers; the pyramid catches them with its tile CRCs.

use std::fs::File;
use std::ops::Deref;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

use memmap2::Mmap;

use super::DemError;

/// A file opened for mapping, its length measured (one `fstat`) but nothing mapped yet, so the
/// caller can validate the length against its header first.
#[derive(Debug)]
pub(crate) struct OpenFile {
    path: PathBuf,
    file: File,
    len: u64,
    identity: FileIdentity,
}

/// Which file a descriptor or a path is, and how long and how recent: what the watcher
/// compares with the state at open (device + inode say whether the path still names the mapped
/// file; length and mtime whether that file changed in place).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct FileIdentity {
    pub dev: u64,
    pub ino: u64,
    pub len: u64,
    /// Modification time, nanoseconds since the epoch.
    pub mtime_ns: i128,
}

impl FileIdentity {
    fn of(m: &std::fs::Metadata) -> FileIdentity {
        FileIdentity {
            dev: m.dev(),
            ino: m.ino(),
            len: m.len(),
            mtime_ns: m.mtime() as i128 * 1_000_000_000 + m.mtime_nsec() as i128,
        }
    }

    /// The same file (device and inode), whatever its length and mtime.
    pub fn same_file(&self, other: &FileIdentity) -> bool {
        (self.dev, self.ino) == (other.dev, other.ino)
    }
}

/// What [`MappedFile::observe`] saw: the mapped file as opened and now (`fstat` of the open
/// descriptor), and what the path names now (`stat`; an error when it names nothing).
#[derive(Debug)]
pub(crate) struct Observed {
    pub opened: FileIdentity,
    pub mapped_now: std::io::Result<FileIdentity>,
    pub path_now: std::io::Result<FileIdentity>,
}

impl OpenFile {
    pub(crate) fn open(path: &Path) -> Result<OpenFile, DemError> {
        let io = |source| DemError::Io {
            path: path.to_path_buf(),
            source,
        };
        let file = File::open(path).map_err(io)?;
        let identity = FileIdentity::of(&file.metadata().map_err(io)?);
        Ok(OpenFile {
            path: path.to_path_buf(),
            file,
            len: identity.len,
            identity,
        })
    }

    /// The length measured at open, bytes.
    pub(crate) fn len(&self) -> u64 {
        self.len
    }

    /// Maps the file read-only. Fails if the map is not exactly as long as the length measured
    /// at open (the file changed size in between).
    pub(crate) fn map(self) -> Result<MappedFile, DemError> {
        // SAFETY: read-only and private to the returned value; the remaining risk, a truncation
        // in place by another process, is the one documented in this module's docs.
        #[allow(unsafe_code)]
        let map = unsafe { Mmap::map(&self.file) }.map_err(|source| DemError::Io {
            path: self.path.clone(),
            source,
        })?;
        if map.len() as u64 != self.len {
            return Err(DemError::Data {
                path: self.path,
                message: format!(
                    "changed size while being opened ({} bytes mapped, {} expected)",
                    map.len(),
                    self.len
                ),
            });
        }
        Ok(MappedFile {
            path: self.path,
            bytes: Storage::Map {
                file: self.file,
                map,
                opened: self.identity,
            },
        })
    }
}

/// A read-only memory map of a whole file, as validated at open, or the bytes of one held in
/// memory; dereferences to its bytes. A mapped file stays open so that its length can be
/// re-checked ([`MappedFile::current_len`]).
pub(crate) struct MappedFile {
    path: PathBuf,
    bytes: Storage,
}

/// Where the bytes are.
enum Storage {
    Map {
        file: File,
        map: Mmap,
        /// The file as measured at open.
        opened: FileIdentity,
    },
    Owned(Vec<u8>),
}

impl MappedFile {
    /// Opens and maps `path` in one step, for readers with nothing to check before mapping.
    pub(crate) fn open(path: &Path) -> Result<MappedFile, DemError> {
        OpenFile::open(path)?.map()
    }

    /// Bytes already in memory, as if read from `path` (which only names them in errors).
    pub(crate) fn from_bytes(path: &Path, bytes: Vec<u8>) -> MappedFile {
        MappedFile {
            path: path.to_path_buf(),
            bytes: Storage::Owned(bytes),
        }
    }

    /// The path the bytes came from (or are named by).
    pub(crate) fn path(&self) -> &Path {
        &self.path
    }

    /// The mapped file as opened and now, and what its path names now (one `fstat`, one
    /// `stat`); None for bytes in memory, which cannot change.
    pub(crate) fn observe(&self) -> Option<Observed> {
        match &self.bytes {
            Storage::Map { file, opened, .. } => Some(Observed {
                opened: *opened,
                mapped_now: file.metadata().map(|m| FileIdentity::of(&m)),
                path_now: std::fs::metadata(&self.path).map(|m| FileIdentity::of(&m)),
            }),
            Storage::Owned(_) => None,
        }
    }

    /// The file's length now (one `fstat`): differs from the mapped length when another
    /// process truncated or extended the file in place since it was mapped. Bytes in memory
    /// cannot change.
    pub(crate) fn current_len(&self) -> Result<u64, DemError> {
        match &self.bytes {
            Storage::Map { file, .. } => Ok(file
                .metadata()
                .map_err(|source| DemError::Io {
                    path: self.path.clone(),
                    source,
                })?
                .len()),
            Storage::Owned(v) => Ok(v.len() as u64),
        }
    }
}

impl Deref for MappedFile {
    type Target = [u8];

    fn deref(&self) -> &[u8] {
        match &self.bytes {
            Storage::Map { map, .. } => map,
            Storage::Owned(v) => v,
        }
    }
}
