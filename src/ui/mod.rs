//! The interactive viewer: a winit window with the terrain pass and an egui side panel.
//!
//! | file | concern |
//! | --- | --- |
//! | `mod.rs` | [`run`], [`ViewerOptions`], [`UiError`]: the entry point and what can go wrong |
//! | `app.rs` | the winit `ApplicationHandler`, the frame loop's steps, panel actions, input routing |
//! | `gpu.rs` | the wgpu surface, depth buffer and egui renderer; one frame's encoding and present |
//! | `input.rs` | mouse and keyboard state between events |
//! | `controls.rs` | pure f64 camera controls (look, pan, zoom, fly), unit-tested |
//! | `fly_to.rs` | flights between views (up, over, down) and the view looking at a picked point, unit-tested |
//! | `measure_tool.rs` | the measure tool: distances, area and the profile through clicked points, unit-tested |
//! | `pick.rs` | what lies under the cursor: the f64 ray caster on a thread of its own |
//! | `panel.rs` | the egui side panel: statistics, level table, settings, "go to"; no wgpu code |
//! | `editor.rs` | the detail editor window: sliders, presets, load/save/reset, basis images, relief brush; no wgpu code |
//!
//! Controls (also listed in the panel):
//!
//! | input | effect |
//! | --- | --- |
//! | left drag | look around (heading, pitch); the view follows the pointer |
//! | right drag, Shift + left drag | move over the ground; speed ∝ height above terrain |
//! | wheel | zoom: height above terrain × 0.85 per notch, never below terrain + 1 mm |
//! | W/S, A/D, Q/E | fly forward/back, strafe left/right, down/up; speed ∝ height above terrain |
//! | arrow keys | turn (left/right) and pitch (up/down) |
//! | Shift (with W/S/A/D/Q/E) | 5 × faster |
//! | double-click | fly to the point under the cursor (a third of the way from it back to the eye, looking at it) |
//! | click (measure on) / Escape | add a point to the measure tool / clear its points |
//! | R | record the camera: press again to save `globe-path-<unix seconds>.json` (replay: `globe --path FILE`) |
//! | F12, P | screenshot: `globe-screenshot-<unix seconds>.png` in the current directory |
//!
//! Hidden options for automated checks: `GLOBE_VIEWER_SMOKE_FRAMES=N` takes a screenshot after N
//! frames and closes the window; `GLOBE_VIEWER_SMOKE_PRESET=NAME` loads a detail preset through
//! the editor half way through; `GLOBE_VIEWER_EDITOR=1` opens the detail editor at start.

mod app;
pub mod controls;
pub mod editor;
pub mod fly_to;
mod gpu;
mod input;
pub mod measure_tool;
pub mod panel;
pub mod pick;

use crate::clipmap::ClipmapSettings;
use crate::render::RenderError;
use crate::scenes::{CameraSpec, ViewError};

/// What the viewer starts with.
#[derive(Clone, Debug)]
pub struct ViewerOptions {
    /// The view to start at: a scene bookmark's ([`crate::scenes::Scene::view`]) or any other.
    pub start: CameraSpec,
    /// Clipmap settings of the terrain renderer (editable later in the panel).
    pub settings: ClipmapSettings,
    /// Start with the per-level colour overlay on.
    pub overlay_levels: bool,
    /// Start with the wireframe overlay on.
    pub overlay_wireframe: bool,
    /// The terrain to show (the embedded Earth, a DEM pyramid, or the analytic test planet).
    pub terrain: crate::terrain::Terrain,
    /// How DEM tiles stream (cache sizes, upload budget, injected faults).
    pub stream: crate::stream::StreamSettings,
    /// What of the look is drawn (docs/look.md#the-look).
    pub look: crate::look::LookSettings,
    /// Which LOD method draws the ground near the viewer (`--mode`).
    pub lod: crate::plan::LodSettings,
    /// A recorded path to replay from the start (`--path`).
    pub replay: Option<crate::scenes::path::CameraPath>,
}

impl Default for ViewerOptions {
    fn default() -> Self {
        Self {
            start: crate::scenes::SCENES[1].view(),
            settings: ClipmapSettings::default(),
            overlay_levels: false,
            overlay_wireframe: false,
            terrain: crate::terrain::Terrain::analytic_earth(),
            stream: crate::stream::StreamSettings::default(),
            look: crate::look::LookSettings::default(),
            lod: crate::plan::LodSettings::default(),
            replay: None,
        }
    }
}

/// Why the viewer could not run.
#[derive(Debug, thiserror::Error)]
pub enum UiError {
    /// No X server to open a window on. The text is complete (see [`UiError::no_display`]):
    /// what is missing, why (winit's error or the unset variable), and the headless alternative.
    #[error("{0}")]
    NoDisplay(String),
    #[error("start view: {0}")]
    View(#[from] ViewError),
    #[error(transparent)]
    Render(#[from] RenderError),
    /// The window surface could not be created, configured or recreated.
    #[error("window surface: {0}")]
    Surface(String),
    /// The event loop or the window failed after the display was opened.
    #[error("window system: {0}")]
    Window(String),
    /// A screenshot could not be rendered or saved.
    #[error("screenshot: {0}")]
    Screenshot(String),
}

impl UiError {
    /// [`UiError::NoDisplay`] with the standard advice and `detail` (what exactly failed).
    pub fn no_display(detail: impl std::fmt::Display) -> Self {
        Self::NoDisplay(format!(
            "no display available (DISPLAY/WAYLAND_DISPLAY unset or unreachable); use `globe render --scene NAME --out FILE.png` for headless rendering ({detail})"
        ))
    }
}

/// Opens the viewer window and runs until it is closed.
///
/// Returns [`UiError::NoDisplay`] (never panics) when there is no X server: `DISPLAY` unset or
/// empty, or the server unreachable. This build talks X11 only; under Wayland it needs XWayland.
pub fn run(options: ViewerOptions) -> Result<(), UiError> {
    options.start.validate(options.terrain.radius_m())?;
    options.settings.validate().map_err(RenderError::from)?;
    check_display(|name| std::env::var(name).ok())?;
    app::run(options, None)
}

/// Fails early, before winit is touched, when no X display is configured. `var` reads an
/// environment variable (injected so tests need not change the process environment).
fn check_display(var: impl Fn(&str) -> Option<String>) -> Result<(), UiError> {
    let set = |name: &str| var(name).is_some_and(|v| !v.trim().is_empty());
    if set("DISPLAY") {
        return Ok(());
    }
    let detail = if set("WAYLAND_DISPLAY") || set("WAYLAND_SOCKET") {
        "DISPLAY is not set; this build talks X11 only, so under Wayland it needs XWayland"
    } else {
        "neither DISPLAY nor WAYLAND_DISPLAY is set"
    };
    Err(UiError::no_display(detail))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env<'a>(pairs: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
        move |name| {
            pairs
                .iter()
                .find(|(k, _)| *k == name)
                .map(|(_, v)| v.to_string())
        }
    }

    #[test]
    fn display_check_reports_missing_display() {
        for pairs in [
            &[][..],
            &[("DISPLAY", "")][..],
            &[("DISPLAY", "  "), ("WAYLAND_DISPLAY", "")][..],
            &[("WAYLAND_DISPLAY", "wayland-0")][..],
        ] {
            match check_display(env(pairs)) {
                Err(e @ UiError::NoDisplay(_)) => {
                    let UiError::NoDisplay(payload) = &e else {
                        unreachable!()
                    };
                    assert_eq!(&e.to_string(), payload);
                    assert!(payload.starts_with("no display available (DISPLAY/WAYLAND_DISPLAY unset or unreachable); use `globe render --scene NAME --out FILE.png` for headless rendering ("), "{payload}");
                }
                other => panic!("{pairs:?}: expected NoDisplay, got {other:?}"),
            }
        }
        assert!(check_display(env(&[("DISPLAY", ":0")])).is_ok());
    }

    /// `run` itself must return `NoDisplay`, not panic, on a machine without a display. Only
    /// meaningful where no display is configured; elsewhere it would open a window, so it skips.
    #[test]
    fn run_without_display_returns_no_display() {
        if check_display(|name| std::env::var(name).ok()).is_ok() {
            eprintln!("skipped: a display is configured");
            return;
        }
        let result = run(ViewerOptions::default());
        assert!(
            matches!(result, Err(UiError::NoDisplay(_))),
            "got {result:?}"
        );
    }

    /// Opens the real window for a few frames, takes a screenshot and closes: needs a display
    /// (e.g. `xvfb-run cargo test --lib ui::tests::viewer_smoke -- --ignored --nocapture`) and
    /// skips without one. `GLOBE_VIEWER_SMOKE_SCENE` picks the scene, `GLOBE_VIEWER_SMOKE_FRAMES`
    /// the frame count, `GLOBE_VIEWER_SMOKE_OVERLAY` turns the level overlay on,
    /// `GLOBE_VIEWER_SMOKE_PRESET` turns the detail on and loads that preset half way; the screenshot
    /// is deleted afterwards unless `GLOBE_VIEWER_SMOKE_KEEP` is set.
    #[test]
    #[ignore = "opens a window"]
    fn viewer_smoke() {
        if check_display(|name| std::env::var(name).ok()).is_err() {
            eprintln!("skipped: no display");
            return;
        }
        let screenshots = || -> std::collections::BTreeSet<std::path::PathBuf> {
            std::fs::read_dir(".")
                .into_iter()
                .flatten()
                .flatten()
                .map(|e| e.path())
                .filter(|p| {
                    p.file_name()
                        .and_then(|n| n.to_str())
                        .is_some_and(|n| n.starts_with("globe-screenshot-") && n.ends_with(".png"))
                })
                .collect()
        };
        let before = screenshots();
        let scene = std::env::var("GLOBE_VIEWER_SMOKE_SCENE").unwrap_or_else(|_| "aircraft".into());
        let frames = std::env::var(app::SMOKE_FRAMES_ENV)
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(30);
        let overlay_levels = std::env::var("GLOBE_VIEWER_SMOKE_OVERLAY").is_ok();
        let start = crate::scenes::find(&scene).expect("a scene name").view();
        // A preset needs the detail on (the default options have none).
        let terrain = match std::env::var(app::SMOKE_PRESET_ENV) {
            Ok(_) => {
                crate::terrain::Terrain::analytic_earth().with_detail(Some(Default::default()))
            }
            Err(_) => crate::terrain::Terrain::analytic_earth(),
        };
        let options = ViewerOptions {
            start,
            overlay_levels,
            terrain,
            ..Default::default()
        };
        app::run(options, Some(frames)).expect("the viewer runs");
        let new: Vec<_> = screenshots().difference(&before).cloned().collect();
        assert!(!new.is_empty(), "the smoke run saved no screenshot");
        if std::env::var("GLOBE_VIEWER_SMOKE_KEEP").is_err() {
            for path in new {
                let _ = std::fs::remove_file(path);
            }
        }
    }

    #[test]
    fn run_rejects_bad_start_view_and_bad_settings() {
        let options = ViewerOptions {
            start: CameraSpec {
                lat_deg: 91.0,
                ..ViewerOptions::default().start
            },
            ..Default::default()
        };
        assert!(matches!(
            run(options),
            Err(UiError::View(ViewError::Latitude(91.0)))
        ));
        let settings = ClipmapSettings {
            phi_steps: 100,
            ..Default::default()
        };
        let options = ViewerOptions {
            settings,
            ..Default::default()
        };
        assert!(matches!(run(options), Err(UiError::Render(_))));
    }
}
