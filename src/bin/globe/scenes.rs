//! `globe scenes`, and the view a command draws (a named scene or `--camera`).

use globe::scenes::{CAMERA_VIEW_NAME, CameraSpec, SCENES};

/// The view a command draws and its name: `--camera` (named "camera") or the scene `name`.
pub fn chosen_view(name: &str, camera: Option<CameraSpec>) -> anyhow::Result<(String, CameraSpec)> {
    Ok(match camera {
        Some(view) => (CAMERA_VIEW_NAME.to_owned(), view),
        None => (name.to_owned(), globe::scenes::find(name)?.view()),
    })
}

pub fn print_scenes() {
    println!(
        "{:<13} {:>9} {:>9}  {:<22} {:>8} {:>6}  stresses",
        "scene", "lat °", "lon °", "height", "heading", "pitch"
    );
    for s in &SCENES {
        let pitch = if s.pitch_deg == -90.0 {
            "centre".to_string()
        } else {
            format!("{}", s.pitch_deg)
        };
        println!(
            "{:<13} {:>9.2} {:>9.2}  {:<22} {:>8} {:>6}  {}",
            s.name,
            s.lat_deg,
            s.lon_deg,
            s.height_label(),
            s.heading_deg,
            pitch,
            s.stresses
        );
    }
}
