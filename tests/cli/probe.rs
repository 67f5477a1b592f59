//! `globe probe` as a user runs it: what lies under a pixel, against what the camera's own
//! definition makes true (straight down from 2 m above the terrain, the centre pixel is the
//! nadir, 2 m away), sky above the horizon, and clear refusals of a bad pixel.

use std::process::Command;

fn probe(args: &[&str]) -> (bool, String, String) {
    let run = Command::new(env!("CARGO_BIN_EXE_globe"))
        .arg("probe")
        .args(args)
        .output()
        .expect("globe runs");
    (
        run.status.success(),
        String::from_utf8_lossy(&run.stdout).into_owned(),
        String::from_utf8_lossy(&run.stderr).into_owned(),
    )
}

fn json(stdout: &str) -> serde_json::Value {
    serde_json::from_str(stdout.trim()).unwrap_or_else(|e| panic!("not JSON ({e}): {stdout}"))
}

/// Straight down from 2 m above the drawn ground (the real Earth with its detail and water,
/// the defaults), in the Alps and on the sea: the centre pixel of an odd-sized view is the
/// nadir, 2 m away (±1 cm), at the camera's latitude and longitude (±1e-7°).
#[test]
fn straight_down_the_centre_pixel_is_two_metres_below_the_camera() {
    for (lat, lon) in [(46.2, 7.7), (-10.0, -150.0)] {
        let camera = format!("--camera={lat},{lon},2,0,-90");
        let (ok, out, err) = probe(&[
            &camera, "--pixel", "50,50", "--width", "101", "--height", "101", "--json",
        ]);
        assert!(ok, "{err}");
        let v = json(&out);
        assert_eq!(v["hit"], true, "{out}");
        let distance = v["distance_m"].as_f64().unwrap();
        assert!((distance - 2.0).abs() < 0.01, "{out}");
        assert!((v["lat_deg"].as_f64().unwrap() - lat).abs() < 1e-7, "{out}");
        assert!((v["lon_deg"].as_f64().unwrap() - lon).abs() < 1e-7, "{out}");
        if lat < 0.0 {
            // The Pacific: the water's surface, at sea level.
            assert!(v["height_m"].as_f64().unwrap().abs() < 1e-9, "{out}");
        }
    }
}

/// Looking 30° up there is only sky: `hit: false` and no coordinates.
#[test]
fn a_pixel_of_sky_is_no_hit() {
    let (ok, out, err) = probe(&[
        "--camera=46.2,7.7,2000,0,30",
        "--pixel",
        "40,10",
        "--width",
        "80",
        "--height",
        "60",
        "--json",
    ]);
    assert!(ok, "{err}");
    let v = json(&out);
    assert_eq!(v["hit"], false, "{out}");
    assert!(v["lat_deg"].is_null(), "{out}");
}

/// A pixel outside the view, or not X,Y, is refused with what was expected.
#[test]
fn a_bad_pixel_is_refused_with_what_was_expected() {
    let (ok, _, err) = probe(&[
        "--scene", "space", "--pixel", "80,10", "--width", "80", "--height", "60",
    ]);
    assert!(!ok);
    assert!(err.contains("outside the 80×60 view"), "{err}");
    let (ok, _, err) = probe(&["--scene", "space", "--pixel", "12"]);
    assert!(!ok);
    assert!(err.contains("expected X,Y"), "{err}");
}
