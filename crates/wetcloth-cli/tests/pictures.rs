//! `wetcloth render` and `wetcloth plot` end to end on a tiny run: the files exist and show
//! what they should (pixels and panels), not just "a file was written". Rendering needs a
//! graphics adapter: on a machine without a GPU, Mesa's software Vulkan (`mesa-vulkan-drivers`),
//! which `.ci/run` installs.

use std::path::PathBuf;
use std::process::Command;

mod common;

use common::{BIN, TENT, png_size_and_pixels, run_scene};

fn tent_run(test: &str) -> PathBuf {
    run_scene("cli-pictures", test, TENT)
}

#[test]
fn render_draws_the_cloth_in_the_middle_and_the_table_around_it() {
    let run = tent_run("render");
    let out = run.join("pictures");
    let o = Command::new(BIN)
        .args(["render"])
        .arg(&run)
        .args([
            "--size",
            "160x90",
            "--frames",
            "3",
            "--no-video",
            "--camera",
            "0,60",
            "--out",
        ])
        .arg(&out)
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "render failed (is Mesa's software Vulkan installed?): {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let (w, h, px) = png_size_and_pixels(&out.join("frame_0003.png"));
    assert_eq!((w, h), (160, 90));
    // Seen from above at 60 degrees, the cloth fills the middle of the frame; the corners show
    // the table. The satin is reddish, the table grey: compare red against blue.
    let at = |x: u32, y: u32| px[(y * w + x) as usize];
    let warm = |p: [u8; 3]| i32::from(p[0]) - i32::from(p[2]);
    let centre = at(w / 2, h / 2);
    let corner = at(4, h - 4);
    assert!(warm(centre) > 15, "cloth at the centre: {centre:?}");
    assert!(warm(corner).abs() < 15, "table in the corner: {corner:?}");
}

#[test]
fn plot_writes_a_chart_with_every_panel_drawn() {
    let run = tent_run("plot");
    let o = Command::new(BIN).arg("plot").arg(&run).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (w, h, px) = png_size_and_pixels(&run.join("metrics.png"));
    assert!(w >= 600 && h >= 600, "{w}x{h}");
    // Every horizontal band of the chart (one per panel) has coloured (series) pixels, not just
    // grey axes and black text.
    let bands = 7;
    for b in 0..bands {
        let y0 = h * b / bands + h / (4 * bands);
        let y1 = h * (b + 1) / bands;
        let coloured = (y0..y1)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .filter(|&(x, y)| {
                let [r, g, bl] = px[(y * w + x) as usize];
                let (mx, mn) = (r.max(g).max(bl), r.min(g).min(bl));
                mx - mn > 60
            })
            .count();
        assert!(coloured > 50, "panel {b} has {coloured} coloured pixels");
    }
    // A missing run directory is a clear error, exit code 1.
    let o = Command::new(BIN)
        .args(["plot", "/nonexistent/run"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("metrics.csv"));
}
