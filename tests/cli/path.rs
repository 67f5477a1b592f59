//! Recorded camera paths as a user replays them: `globe render --path` writes one PNG per
//! frame and renders the same frames twice (0 px apart), `globe bench --path` times one, and a
//! bad file or a missing flag is refused with what is wrong.

use std::path::Path;
use std::process::Command;

fn globe(args: &[&str]) -> (bool, String, String) {
    let run = Command::new(env!("CARGO_BIN_EXE_globe"))
        .args(args)
        .output()
        .expect("globe runs");
    (
        run.status.success(),
        String::from_utf8_lossy(&run.stdout).into_owned(),
        String::from_utf8_lossy(&run.stderr).into_owned(),
    )
}

/// A 20 s path as the viewer writes it: down and round over the analytic planet's hills.
fn write_path(file: &Path) {
    let key = |t: f64, lat: f64, lon: f64, alt: f64, heading: f64| {
        format!(
            r#"{{"t_s":{t},"lat_deg":{lat},"lon_deg":{lon},"altitude_m":{alt},"heading_deg":{heading},"pitch_deg":-25,"roll_deg":0,"fov_y_deg":60}}"#
        )
    };
    let keys = [
        key(0.0, 45.0, 10.0, 20_000.0, 0.0),
        key(7.5, 45.1, 10.1, 8_000.0, 60.0),
        key(20.0, 45.2, 10.3, 3_000.0, 300.0),
    ];
    let text = format!(
        r#"{{"format":"globe camera path","version":1,"keys":[{}]}}"#,
        keys.join(",")
    );
    std::fs::write(file, text).unwrap();
}

fn pngs(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
        .collect();
    files.sort();
    files
}

/// A 20 s path at 10 fps is 200 PNGs, and rendering it twice gives the same pixels.
#[test]
fn a_path_replayed_twice_renders_the_same_frames() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("path.json");
    write_path(&file);
    let mut runs = Vec::new();
    for name in ["first", "second"] {
        let out = dir.path().join(name);
        let (ok, _, err) = globe(&[
            "render",
            "--path",
            file.to_str().unwrap(),
            "--out-dir",
            out.to_str().unwrap(),
            "--fps",
            "10",
            "--width",
            "32",
            "--height",
            "18",
            "--dem",
            "analytic",
        ]);
        assert!(ok, "{err}");
        assert!(err.contains("wrote 200 frames"), "{err}");
        runs.push(pngs(&out));
    }
    assert_eq!(runs[0].len(), 200);
    assert_eq!(
        runs[0].iter().map(|p| p.file_name()).collect::<Vec<_>>(),
        runs[1].iter().map(|p| p.file_name()).collect::<Vec<_>>()
    );
    let mut changes = 0;
    for (k, (a, b)) in runs[0].iter().zip(&runs[1]).enumerate() {
        let (a, b) = (
            image::open(a).unwrap().to_rgba8(),
            image::open(b).unwrap().to_rgba8(),
        );
        let differing = a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count();
        assert_eq!(
            differing, 0,
            "frame {k}: {differing} px differ between the two renders"
        );
        if k > 0 && image::open(&runs[0][k - 1]).unwrap().to_rgba8() != a {
            changes += 1;
        }
    }
    // The path moves: the frames are not one image 200 times.
    assert!(
        changes > 150,
        "only {changes} of 199 frames differ from the one before"
    );
}

/// `globe bench --path` times a recorded path as it times `flight`, named "path".
#[test]
fn bench_times_a_recorded_path() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("path.json");
    write_path(&file);
    let (ok, out, err) = globe(&[
        "bench",
        "--path",
        file.to_str().unwrap(),
        "--frames",
        "6",
        "--width",
        "32",
        "--height",
        "18",
        "--dem",
        "analytic",
        "--no-error",
        "--json",
    ]);
    assert!(ok, "{err}");
    let v: serde_json::Value =
        serde_json::from_str(out.trim()).unwrap_or_else(|e| panic!("{e}: {out}"));
    assert_eq!(v["scene"], "path", "{out}");
    assert_eq!(v["frames"], 6, "{out}");
    assert_eq!(v["settled"], true, "{out}");
}

/// What cannot be replayed is refused, naming the file, the key and the field, or the flag.
#[test]
fn bad_paths_and_flags_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("bad.json");
    std::fs::write(
        &file,
        r#"{"format":"globe camera path","version":1,"keys":[{"t_s":0,"lat_deg":1,"lon_deg":2,"altitude_m":3,"heading_deg":0,"pitch_deg":-100}]}"#,
    )
    .unwrap();
    let f = file.to_str().unwrap();
    let out = dir.path().join("frames");
    let o = out.to_str().unwrap();
    for (args, says) in [
        (
            vec!["render", "--path", f, "--out-dir", o],
            "key 0: `pitch_deg` is -100",
        ),
        (vec!["render", "--path", f], "--out-dir"),
        (
            vec!["render", "--path", f, "--out-dir", o, "--fps", "0"],
            "--fps",
        ),
        (vec!["bench", "--path", f, "--dem", "analytic"], "bad.json"),
    ] {
        let (ok, _, err) = globe(&args);
        assert!(!ok && err.contains(says), "{args:?}: {err}");
        assert!(
            !err.contains("adapter:"),
            "{args:?}: refused only after starting: {err}"
        );
    }
}
