//! The binaries as a user runs them: headless render, bench and report, the soak, the editor's files.
//!
//! One test binary (each module was its own binary once; one link step instead of many).

#[path = "../common/mod.rs"]
mod common;

mod bench_report;
mod detail_editor;
mod headless_cli;
mod path;
mod probe;
mod profile;
mod soak;
