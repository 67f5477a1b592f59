//! What happened to a mapped file since it was opened, as the streamer's watcher sees it (one
//! `fstat` of the mapped descriptor and one `stat` of the path, about once a second).
//!
//! The viewer keeps drawing from the mapping it has in every case; the kinds differ in what
//! can still be read from it. A replaced file is not reopened: the new one may have other
//! levels, tiles and extents, and every cache (decoded tiles, GPU tiles, level textures, the
//! CPU's terrain) holds the old one's data under the same tile keys, so mixing them would draw
//! neither file. Reopening is the user's step.

use std::path::PathBuf;

use super::mapped::Observed;

/// A change to the file behind a mapping. Each names the file and says what globe does now.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FileChange {
    /// The path names another file now (the supported replacement: a rename over it).
    #[error(
        "{path} was replaced; globe keeps drawing the file it opened (still mapped, unchanged); \
         reopen to see the new one"
    )]
    Replaced { path: PathBuf },
    /// The path names nothing now; the mapped inode lives on until globe closes it.
    #[error(
        "{path} was deleted; globe keeps drawing the file it opened (still mapped and readable \
         until globe exits)"
    )]
    Deleted { path: PathBuf },
    /// The path cannot be looked at (permissions, a vanished directory): the mapping itself is
    /// unaffected.
    #[error(
        "{path} cannot be looked at any more ({message}); globe keeps drawing the file it opened"
    )]
    Unreachable { path: PathBuf, message: String },
    /// The mapped file itself shrank: tiles past its new end are refused before they are read
    /// (touching their pages would raise SIGBUS).
    #[error(
        "{path} was truncated in place from {from} to {to} bytes: {unavailable} of {tiles} tiles \
         (levels {levels:?}) can no longer be read; globe keeps drawing what it has cached"
    )]
    Truncated {
        path: PathBuf,
        from: u64,
        to: u64,
        unavailable: usize,
        tiles: usize,
        /// The levels with at least one tile past the new end.
        levels: Vec<u32>,
    },
    /// The mapped file grew: the bytes within its first `from` are where they were, and each
    /// tile's CRC still says whether they hold what they held.
    #[error(
        "{path} was appended to ({from} → {to} bytes); globe keeps reading the tiles within the \
         first {from} bytes, CRC-checked, and ignores the rest"
    )]
    Appended { path: PathBuf, from: u64, to: u64 },
    /// Same inode, same length, a new mtime: written in place (or touched).
    #[error(
        "{path} was modified in place (same length); globe keeps drawing, and a tile whose \
         bytes changed fails its CRC when it is read"
    )]
    Modified { path: PathBuf },
}

impl FileChange {
    /// The file the change is about.
    pub fn path(&self) -> &std::path::Path {
        match self {
            Self::Replaced { path }
            | Self::Deleted { path }
            | Self::Unreachable { path, .. }
            | Self::Truncated { path, .. }
            | Self::Appended { path, .. }
            | Self::Modified { path } => path,
        }
    }
}

/// Classifies what `seen` says about the file at `path`, or None when it is as opened.
/// `past_end(len)` counts the tiles a file of `len` bytes no longer holds: (unavailable, all,
/// levels with any). The mapped inode's own state comes first (a truncation decides what can be
/// read, wherever the path points); then the path's.
pub(crate) fn classify(
    path: &std::path::Path,
    seen: Observed,
    past_end: impl Fn(u64) -> (usize, usize, Vec<u32>),
) -> Option<FileChange> {
    let path = path.to_path_buf();
    let opened = seen.opened;
    let mapped = match seen.mapped_now {
        Ok(m) => m,
        Err(e) => {
            return Some(FileChange::Unreachable {
                path,
                message: e.to_string(),
            });
        }
    };
    if mapped.len < opened.len {
        let (unavailable, tiles, levels) = past_end(mapped.len);
        return Some(FileChange::Truncated {
            path,
            from: opened.len,
            to: mapped.len,
            unavailable,
            tiles,
            levels,
        });
    }
    match seen.path_now {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Some(FileChange::Deleted { path }),
        Err(e) => Some(FileChange::Unreachable {
            path,
            message: e.to_string(),
        }),
        Ok(now) if !now.same_file(&opened) => Some(FileChange::Replaced { path }),
        Ok(_) if mapped.len > opened.len => Some(FileChange::Appended {
            path,
            from: opened.len,
            to: mapped.len,
        }),
        Ok(_) if mapped.mtime_ns != opened.mtime_ns => Some(FileChange::Modified { path }),
        Ok(_) => None,
    }
}
