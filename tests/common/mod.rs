//! Shared GPU access for the rendering tests: one adapter (a software one on CI: lavapipe),
//! a clear skip when none exists, and a hard failure instead when `GLOBE_REQUIRE_GPU=1` (set by
//! the test script, so CI can never pass by skipping).
#![allow(dead_code)]

use std::sync::{Mutex, MutexGuard, OnceLock};

use globe::render::GpuContext;

static CONTEXT: OnceLock<Option<GpuContext>> = OnceLock::new();
static SERIAL: Mutex<()> = Mutex::new(());

/// The shared context and a guard that serialises GPU tests (a software rasteriser on two
/// cores gains nothing from running them side by side).
pub fn gpu() -> Option<(&'static GpuContext, MutexGuard<'static, ()>)> {
    let ctx = CONTEXT.get_or_init(|| match GpuContext::headless() {
        Ok(ctx) => {
            eprintln!("GPU tests on {}", ctx.adapter_description());
            Some(ctx)
        }
        Err(e) => {
            if std::env::var("GLOBE_REQUIRE_GPU").as_deref() == Ok("1") {
                panic!("GLOBE_REQUIRE_GPU=1 but no adapter: {e}");
            }
            eprintln!("SKIPPED: no graphics adapter ({e}); run ./scripts/test.sh to install one");
            None
        }
    });
    let guard = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
    ctx.as_ref().map(|c| (c, guard))
}
