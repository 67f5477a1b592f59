//! Reads of a pyramid's bytes made on a thread while it prepares a frame: the count behind
//! "no frame waits on I/O". The render thread is meant to read decoded tiles only
//! (`render::dem_feed`), the file itself on the streamer's workers; a read from inside a frame
//! would block that frame on a page fault, a slow disk or a remote store. `globe bench --scene
//! soak` reports the count, and it must stay 0.
//!
//! The flag is per thread, so reads on the streamer's workers never count, and cheap to test
//! (one thread-local load), so the hot sample loops can afford it.

use std::cell::Cell;
use std::sync::atomic::{AtomicU64, Ordering};

thread_local! {
    static IN_FRAME: Cell<bool> = const { Cell::new(false) };
    static HERE: Cell<u64> = const { Cell::new(0) };
}

static READS_IN_FRAMES: AtomicU64 = AtomicU64::new(0);

/// Marks the current thread as preparing a frame until dropped (nested scopes are fine).
#[must_use = "the scope ends when the guard is dropped"]
pub struct FrameScope {
    was: bool,
}

impl Drop for FrameScope {
    fn drop(&mut self) {
        IN_FRAME.with(|f| f.set(self.was));
    }
}

/// Starts a frame scope on this thread.
pub fn frame_scope() -> FrameScope {
    FrameScope {
        was: IN_FRAME.with(|f| f.replace(true)),
    }
}

/// Called by every accessor of a pyramid's bytes.
#[inline]
pub(crate) fn note_read() {
    if IN_FRAME.with(Cell::get) {
        READS_IN_FRAMES.fetch_add(1, Ordering::Relaxed);
        HERE.with(|h| h.set(h.get() + 1));
    }
}

/// Pyramid reads made inside frame scopes since the process started (all threads).
pub fn reads_in_frames() -> u64 {
    READS_IN_FRAMES.load(Ordering::Relaxed)
}

/// Of those, the reads made on this thread.
pub fn reads_in_frames_on_this_thread() -> u64 {
    HERE.with(Cell::get)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_only_inside_a_scope_on_its_own_thread() {
        let here = reads_in_frames_on_this_thread;
        let (before, before_all) = (here(), reads_in_frames());
        note_read();
        assert_eq!(here(), before, "outside a scope");
        let scope = frame_scope();
        // Another thread's reads (the streamer's workers) do not count.
        std::thread::spawn(note_read).join().unwrap();
        assert_eq!(here(), before, "another thread");
        {
            let _nested = frame_scope();
        }
        // Still inside the outer scope after the nested one ended.
        note_read();
        assert_eq!(here(), before + 1);
        drop(scope);
        note_read();
        assert_eq!(here(), before + 1, "after the scope");
        assert!(reads_in_frames() > before_all, "the process-wide count");
    }
}
