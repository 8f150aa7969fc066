//! `wetcloth view` without a display: it must say so plainly and point to `wetcloth run`. (The
//! window itself is tested end to end under Xvfb by the `wetcloth-viewer` crate's `e2e` test.)

use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_wetcloth");

#[test]
fn without_a_display_view_points_to_run_and_xvfb() {
    let out = Command::new(BIN)
        .arg("view")
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("no display"), "{err}");
    assert!(err.contains("wetcloth run"), "{err}");
    assert!(err.contains("xvfb-run"), "{err}");
}

#[test]
fn a_bad_scene_file_is_reported_before_any_window_opens() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("cli-view");
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("bad.toml");
    std::fs::write(&scene, "[cloth]\nmass = -1\n").unwrap();
    let out = Command::new(BIN)
        .arg("view")
        .arg(&scene)
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("mass"), "{err}");
}
