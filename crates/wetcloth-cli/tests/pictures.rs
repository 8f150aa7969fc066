//! `wetcloth render` and `wetcloth plot` end to end on a tiny run: the files exist and show
//! what they should (pixels and panels), not just "a file was written". Rendering needs a
//! graphics adapter: on a machine without a GPU, Mesa's software Vulkan (`mesa-vulkan-drivers`),
//! which `.ci/run` installs.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_wetcloth");

/// A 12 x 12 cloth with 400 cm^3-per-0.09 m^2 of air, its centre lifted 4 cm: a clear tent.
const TENT: &str = r#"
name = "tent"
[simulation]
duration = 0.3
frame_rate = 10
[cloth]
resolution = [12, 12]
position = [0.0, 0.0052, 0.0]
damping = 2.0
self_collision = false
[air]
trapped_air = 400e-6
[[grab]]
particle = [6, 6]
keys = [{ time = 0.0, offset = [0, 0, 0] }, { time = 0.25, offset = [0, 0.04, 0] }]
"#;

fn tent_run(test: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("cli-pictures")
        .join(test);
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("tent.toml");
    fs::write(&scene, TENT).unwrap();
    let run = dir.join("run");
    let o = Command::new(BIN)
        .arg("run")
        .arg(&scene)
        .arg("--out")
        .arg(&run)
        .arg("--quiet")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    run
}

fn png_size_and_pixels(path: &Path) -> (u32, u32, Vec<[u8; 3]>) {
    let decoder = png::Decoder::new(std::io::BufReader::new(fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    let channels = info.color_type.samples();
    let px = buf[..info.buffer_size()]
        .chunks(channels)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    (info.width, info.height, px)
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
