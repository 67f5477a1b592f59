//! `globe render` as a user runs it on a machine with no display: it renders, and it never
//! touches the windowing system (no `XDG_RUNTIME_DIR` complaint from a display probe).

use std::process::Command;

#[test]
fn render_without_a_display_prints_no_windowing_errors() {
    let out = tempfile::tempdir().expect("temp dir");
    let png = out.path().join("space.png");
    let run = Command::new(env!("CARGO_BIN_EXE_globe"))
        .args([
            "render", "--scene", "space", "--width", "48", "--height", "27",
        ])
        .arg("--out")
        .arg(&png)
        .env_remove("XDG_RUNTIME_DIR")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("DISPLAY")
        .env_remove("NODEVICE_SELECT")
        .output()
        .expect("globe runs");
    let stderr = String::from_utf8_lossy(&run.stderr);
    let stdout = String::from_utf8_lossy(&run.stdout);
    if !run.status.success() && stderr.contains("no graphics adapter") {
        assert!(
            std::env::var("GLOBE_REQUIRE_GPU").as_deref() != Ok("1"),
            "GLOBE_REQUIRE_GPU=1 but no adapter: {stderr}"
        );
        eprintln!("SKIPPED: no graphics adapter");
        return;
    }
    assert!(run.status.success(), "stdout:\n{stdout}\nstderr:\n{stderr}");
    assert!(png.exists());
    for noise in ["XDG_RUNTIME_DIR", "wayland", "Wayland", "xcb", "DISPLAY"] {
        assert!(
            !stderr.contains(noise) && !stdout.contains(noise),
            "windowing noise ({noise}):\n{stderr}"
        );
    }
}

/// `--detail FILE` with a value out of range stops before any rendering, naming the file, the
/// field and its allowed range; `--detail off` and `--detail default` are accepted.
#[test]
fn a_bad_detail_file_is_refused_with_the_field_and_range() {
    let out = tempfile::tempdir().expect("temp dir");
    let file = out.path().join("rough.json");
    std::fs::write(&file, r#"{ "hurst": 3.0 }"#).unwrap();
    let run = Command::new(env!("CARGO_BIN_EXE_globe"))
        .args([
            "render", "--scene", "space", "--width", "8", "--height", "8",
        ])
        .arg("--detail")
        .arg(&file)
        .arg("--out")
        .arg(out.path().join("x.png"))
        .output()
        .expect("globe runs");
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(
        stderr.contains("rough.json") && stderr.contains("hurst") && stderr.contains("[0.05, 1]"),
        "{stderr}"
    );
    let help = Command::new(env!("CARGO_BIN_EXE_globe"))
        .args(["render", "--help"])
        .output()
        .expect("globe runs");
    let help = String::from_utf8_lossy(&help.stdout);
    assert!(help.contains("--detail <off|default|FILE>"), "{help}");
}

/// Bad close-up settings stop before any rendering, naming the flag and what it must be.
#[test]
fn bad_close_up_settings_name_their_flag() {
    let out = tempfile::tempdir().expect("temp dir");
    for (flag, value, says) in [
        ("--tau", "0", "must be > 0"),
        ("--tau", "-1", "must be > 0"),
        ("--patch-size", "16", "2^n + 1"),
        ("--patch-size", "65", "2^n + 1"),
        ("--patches", "0", "even"),
        ("--patches", "7", "even"),
        ("--grid", "0x256", "at least 1 column"),
        ("--grid", "4096x4096", "at most"),
        ("--grid", "abc", "COLSxROWS"),
        ("--gamma", "0", "must be > 0"),
        ("--time", "2026-06-21 19:00", "YYYY-MM-DDTHH:MMZ"),
        ("--time", "2026-02-30T19:00Z", "day 30"),
        ("--time", "2026-06-21T25:00Z", "hour 25"),
    ] {
        let run = Command::new(env!("CARGO_BIN_EXE_globe"))
            .args([
                "render", "--scene", "ground", "--mode", "geomip", "--width", "8", "--height", "8",
            ])
            .arg(format!("{flag}={value}"))
            .arg("--out")
            .arg(out.path().join("x.png"))
            .output()
            .expect("globe runs");
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{flag} {value} accepted");
        assert!(
            stderr.contains(flag) && stderr.contains(says),
            "{flag} {value}: {stderr}"
        );
        assert!(
            !stderr.contains("adapter:"),
            "{flag} {value}: checked only after starting: {stderr}"
        );
        assert!(!out.path().join("x.png").exists());
    }
}

/// `globe render` with `args` (a small `aircraft` over the embedded Earth unless overridden),
/// writing into `dir`: (success, stderr). None when there is no adapter and none is required.
fn render_with(dir: &std::path::Path, args: &[&str]) -> Option<(bool, String)> {
    let run = Command::new(env!("CARGO_BIN_EXE_globe"))
        .args([
            "render", "--scene", "aircraft", "--width", "64", "--height", "36",
        ])
        .args(args)
        .arg("--out")
        .arg(dir.join("x.png"))
        .output()
        .expect("globe runs");
    let stderr = String::from_utf8_lossy(&run.stderr).into_owned();
    if !run.status.success() && stderr.contains("no graphics adapter") {
        assert!(
            std::env::var("GLOBE_REQUIRE_GPU").as_deref() != Ok("1"),
            "GLOBE_REQUIRE_GPU=1 but no adapter: {stderr}"
        );
        eprintln!("SKIPPED: no graphics adapter");
        return None;
    }
    Some((run.status.success(), stderr))
}

/// The first number after `prefix` in `text`.
fn number_after(text: &str, prefix: &str) -> Option<f64> {
    let rest = &text[text.find(prefix)? + prefix.len()..];
    let end = rest
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(rest.len());
    rest[..end].parse().ok()
}

/// Budgets that can never work stop at the start, naming the flag and the smallest value that
/// does, before any adapter starts.
#[test]
fn zero_read_and_upload_budgets_are_refused_with_the_smallest_that_works() {
    let out = tempfile::tempdir().expect("temp dir");
    for flag in ["--max-in-flight", "--uploads-per-frame"] {
        let Some((ok, stderr)) = render_with(out.path(), &[flag, "0"]) else {
            return;
        };
        assert!(!ok, "{flag} 0 accepted");
        assert!(
            stderr.contains(&format!("{flag} 0")) && stderr.contains("smallest that works is 1"),
            "{flag} 0: {stderr}"
        );
        assert!(
            !stderr.contains("adapter:"),
            "{flag}: checked late: {stderr}"
        );
    }
}

/// A GPU tile cache smaller than one level of the view stops on the view's first frames (not
/// after the settle timeout) with the smallest `--gpu-tiles` that works for that view, computed
/// from the view; with exactly that many the view completes.
#[test]
fn too_few_gpu_tiles_name_the_smallest_that_works_for_the_view() {
    let out = tempfile::tempdir().expect("temp dir");
    for asked in ["0", "1"] {
        let started = std::time::Instant::now();
        let Some((ok, stderr)) = render_with(out.path(), &["--gpu-tiles", asked]) else {
            return;
        };
        let took = started.elapsed().as_secs_f64();
        assert!(!ok, "--gpu-tiles {asked} accepted: {stderr}");
        let prefix = "the smallest that works for this view is --gpu-tiles ";
        let needed = number_after(&stderr, prefix)
            .unwrap_or_else(|| panic!("--gpu-tiles {asked}: {stderr}"));
        assert!(
            stderr.contains(&format!("--gpu-tiles {asked} cannot hold")),
            "{stderr}"
        );
        eprintln!("--gpu-tiles {asked}: refused after {took:.1} s, needs {needed}");
        assert!(took < 60.0, "--gpu-tiles {asked} waited {took:.1} s");
        if asked == "1" {
            let enough = format!("{needed}");
            let (ok, stderr) = render_with(out.path(), &["--gpu-tiles", &enough]).unwrap();
            assert!(
                ok,
                "--gpu-tiles {enough} (the smallest named) failed: {stderr}"
            );
            let fewer = format!("{}", needed - 1.0);
            let (ok, stderr) = render_with(out.path(), &["--gpu-tiles", &fewer]).unwrap();
            assert!(
                !ok,
                "--gpu-tiles {fewer} worked: not the smallest: {stderr}"
            );
        }
    }
}

/// A decoded-tile cache of 0 MiB still completes the view, and the frame it keeps stands on
/// the camera's own tile, not a coarser stand-in: the height above the terrain it prints is
/// the default budget's.
#[test]
fn a_zero_tile_cache_still_completes_the_view() {
    let out = tempfile::tempdir().expect("temp dir");
    let Some((ok, plain)) = render_with(out.path(), &[]) else {
        return;
    };
    assert!(ok, "{plain}");
    let (ok, zero) = render_with(out.path(), &["--cache-mb", "0"]).unwrap();
    assert!(ok, "--cache-mb 0: {zero}");
    let above = |s: &str| number_after(s, "m (").unwrap_or_else(|| panic!("{s}"));
    assert_eq!(above(&plain), above(&zero), "{plain}\n{zero}");
}

/// A settle that times out says what it was still waiting for; a measurement past its time
/// limit says how far it got and names its flag.
#[test]
fn timeouts_say_what_they_were_waiting_for() {
    let out = tempfile::tempdir().expect("temp dir");
    let Some((ok, stderr)) = render_with(
        out.path(),
        &["--tile-latency-ms", "60000", "--settle-timeout", "0.5"],
    ) else {
        return;
    };
    assert!(!ok);
    assert!(
        stderr.contains("did not settle within 0.5 s: still waiting for")
            && stderr.contains("tiles")
            && stderr.contains("reading"),
        "{stderr}"
    );
    let (ok, stderr) =
        render_with(out.path(), &["--measure", "--measure-timeout", "0.000001"]).unwrap();
    assert!(!ok);
    assert!(
        stderr.contains("--measure-timeout 0.000001 s") && stderr.contains("pixels cast"),
        "{stderr}"
    );
}
