//! The air pockets in pictures, end to end on small runs: `wetcloth run` writes each frame's
//! pocket labels (checked against `pockets.csv`), and `wetcloth render --pockets` tints the
//! cloth where the pockets are, by their pressure. Rendering needs a graphics adapter (Mesa's
//! software Vulkan on a machine without a GPU, which `.ci/run` installs).

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

use wetcloth_export::{NO_POCKET, parse_pocket_labels};

mod common;

use common::{BIN, TENT, png_size_and_pixels as pixels, run_into};

/// Two seeded pockets under a wet cloth, left (x = -0.07 m) and right (x = +0.07 m) of the
/// centre: each inflates to a little above atmospheric pressure and stays.
/// Two seeded pockets either side of the centre; 10 cm^3 under a 4 cm disc is a cap a tenth as
/// high as wide, so each starts over its own disc (a larger amount widens its footprint
/// towards the seam, `air::pockets::lift_seeds`).
const TWO_POCKETS: &str = r#"
name = "two-pockets"
[simulation]
duration = 0.2
frame_rate = 10
[cloth]
size = [0.3, 0.3]
resolution = [21, 21]
position = [0.0, 0.00075, 0.0]
mass = 0.02
damping = 2.0
self_collision = false
wetness = 1.0
[air]
model = "pockets"
[[air.pocket]]
center = [-0.07, 0.0]
radius = 0.04
amount = 10e-6
[[air.pocket]]
center = [0.07, 0.0]
radius = 0.04
amount = 10e-6
[[collider]]
shape = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
friction = 0.6
"#;

fn run_scene(test: &str, scene_text: &str) -> PathBuf {
    common::run_scene("cli-pockets-pictures", test, scene_text)
}

/// `pockets.csv` rows: (frame, pocket, pressure, particles).
fn pockets_csv(run: &Path) -> Vec<(u64, u32, f64, usize)> {
    let text = fs::read_to_string(run.join("pockets.csv")).unwrap();
    text.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (
                f[0].parse().unwrap(),
                f[2].parse().unwrap(),
                f[5].parse().unwrap(),
                f[7].parse().unwrap(),
            )
        })
        .collect()
}

fn render(run: &Path, out: &str, extra: &[&str]) -> std::process::Output {
    Command::new(BIN)
        .arg("render")
        .arg(run)
        .args([
            "--size",
            "320x180",
            "--no-video",
            "--no-grabs",
            "--camera",
            "0,75",
            "--out",
        ])
        .arg(run.join(out))
        .args(extra)
        .output()
        .unwrap()
}

fn is_red(p: [u8; 3]) -> bool {
    let [r, g, b] = p.map(i32::from);
    r > g + 80 && r > b + 80
}

fn is_blue(p: [u8; 3]) -> bool {
    let [r, g, b] = p.map(i32::from);
    b > r + 40 && b > g + 20
}

#[test]
fn pocket_labels_are_written_per_frame_and_agree_with_pockets_csv() {
    let run = run_scene("labels", TWO_POCKETS);
    let rows = pockets_csv(&run);
    for frame in 0..=2u64 {
        let path = run.join(format!("frames/frame_{frame:04}.pockets"));
        let labels = parse_pocket_labels(&fs::read_to_string(&path).unwrap()).unwrap();
        assert_eq!(labels.len(), 21 * 21, "one label per particle");
        let here: Vec<_> = rows.iter().filter(|r| r.0 == frame).collect();
        assert_eq!(here.len(), 2, "two pockets in frame {frame}");
        for &&(_, id, _, particles) in &here {
            let n = labels.iter().filter(|&&l| l == id).count();
            assert_eq!(n, particles, "pocket {id} in frame {frame}");
        }
        // Every labelled particle is in a pocket of the same frame, and the two pockets lie
        // on their own sides of the cloth (column < 10 left, > 10 right).
        for (k, &l) in labels.iter().enumerate() {
            if l == NO_POCKET {
                continue;
            }
            assert!(
                here.iter().any(|r| r.1 == l),
                "label {l} not in pockets.csv"
            );
            let column = k % 21;
            let left = here[0].1 == l;
            assert!(if left { column < 10 } else { column > 10 }, "{k}: {l}");
        }
    }
    // A rerun with the thesis model in the same folder leaves no label files behind.
    let scene = run.parent().unwrap().join("thesis.toml");
    fs::write(&scene, TENT).unwrap();
    run_into(&scene, &run);
    let stale = fs::read_dir(run.join("frames"))
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .ends_with(".pockets")
        })
        .count();
    assert_eq!(stale, 0, "label files of the earlier run removed");
}

#[test]
fn render_pockets_tints_the_cloth_red_over_each_pocket() {
    let run = run_scene("render", TWO_POCKETS);
    let rows = pockets_csv(&run);
    let pa = 101325.0;
    assert!(
        rows.iter().filter(|r| r.0 == 2).all(|r| r.2 > pa),
        "both pockets above atmospheric at frame 2: {rows:?}"
    );
    let o = render(&run, "plain", &["--frames", "2"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = render(&run, "tinted", &["--frames", "2", "--pockets"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (w, h, plain) = pixels(&run.join("plain/frame_0002.png"));
    let (_, _, tinted) = pixels(&run.join("tinted/frame_0002.png"));
    // Only the image above the legend (bottom left) counts.
    let top = (h as f32 * 0.7) as usize;
    let red_at = |px: &[[u8; 3]]| -> Vec<usize> {
        (0..top * w as usize)
            .filter(|&i| is_red(px[i]))
            .map(|i| i % w as usize)
            .collect()
    };
    assert!(red_at(&plain).is_empty(), "no red without --pockets");
    let red = red_at(&tinted);
    eprintln!("{} red pixels with --pockets", red.len());
    // Both pockets are red, one each side of the cloth's centre, and the seam between them
    // (the middle tenth of the image) is not.
    let w = w as usize;
    let left = red.iter().filter(|&&x| x < w / 2).count();
    let right = red.iter().filter(|&&x| x >= w / 2).count();
    let middle = red.iter().filter(|&&x| x.abs_diff(w / 2) < w / 20).count();
    assert!(left > 200 && right > 200, "left {left}, right {right}");
    assert!(
        (left as f64 / right as f64 - 1.0).abs() < 0.3,
        "symmetric pockets, symmetric tint: {left} vs {right}"
    );
    assert!(middle < red.len() / 50, "seam tinted: {middle}");
    // The colour bar is drawn: blue and red along the bottom (under the cloth's picture).
    let legend = &tinted;
    let below = (h as f32 * 0.75) as usize * w;
    let corner = |f: fn([u8; 3]) -> bool| legend[below..].iter().filter(|p| f(**p)).count();
    assert!(corner(is_blue) > 50 && corner(is_red) > 50, "legend");
}

#[test]
fn render_pockets_of_a_thesis_run_tints_the_whole_cloth_by_the_bubble() {
    let run = run_scene("thesis", TENT);
    let rows = pockets_csv(&run);
    let last = rows.iter().find(|r| r.0 == 3).unwrap();
    assert_eq!(last.1, 0, "the thesis bubble is pocket 0");
    assert!(last.2 < 101325.0, "the lifted bubble is below atmospheric");
    for (out, extra) in [("plain", &[][..]), ("tinted", &["--pockets"][..])] {
        let mut args = vec!["--frames", "3"];
        args.extend(extra);
        let o = render(&run, out, &args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let (w, h, plain) = pixels(&run.join("plain/frame_0003.png"));
    let (_, _, tinted) = pixels(&run.join("tinted/frame_0003.png"));
    let top = (h as f32 * 0.7) as usize * w as usize;
    let blue = |px: &[[u8; 3]]| px[..top].iter().filter(|p| is_blue(**p)).count();
    let cloth = plain[..top]
        .iter()
        .filter(|p| is_red(**p) || p[0] > p[2] + 20)
        .count();
    eprintln!(
        "blue pixels: {} plain, {} tinted; cloth pixels {cloth}",
        blue(&plain),
        blue(&tinted)
    );
    assert!(blue(&plain) < cloth / 50, "the satin is not blue");
    assert!(blue(&tinted) > cloth / 2, "the whole cloth tinted blue");
}

#[test]
fn render_pockets_is_refused_without_pockets_csv() {
    let run = run_scene("refused", TENT);
    fs::remove_file(run.join("pockets.csv")).unwrap();
    let o = render(&run, "pics", &["--pockets", "--frames", "0"]);
    assert_eq!(o.status.code(), Some(2), "bad input: exit 2");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("no pockets.csv in") && err.contains("--pockets"),
        "{err}"
    );
    assert!(
        !run.join("pics/frame_0000.png").exists(),
        "nothing rendered"
    );
    // --pressure-range needs --pockets, and must be a positive pressure.
    let o = render(&run, "pics", &["--pressure-range", "10"]);
    assert_eq!(o.status.code(), Some(2));
    let o = render(&run, "pics", &["--pockets", "--pressure-range", "0"]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("above 0"), "{e}");
}

#[test]
fn render_pockets_refuses_a_damaged_label_file_naming_file_and_line() {
    let run = run_scene("damaged", TWO_POCKETS);
    let labels = run.join("frames/frame_0001.pockets");
    fs::write(&labels, "wetcloth pocket labels 1\nparticles 441\nx 441\n").unwrap();
    let o = render(&run, "pics", &["--pockets", "--frames", "1"]);
    assert_eq!(o.status.code(), Some(1));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("frame_0001.pockets:3") && e.contains("pocket id \"x\""),
        "{e}"
    );
    // A label file for another cloth size.
    fs::write(&labels, "wetcloth pocket labels 1\nparticles 4\n- 4\n").unwrap();
    let o = render(&run, "pics", &["--pockets", "--frames", "1"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("labels 4 particles") && e.contains("441 vertices"),
        "{e}"
    );
    // A missing one.
    fs::remove_file(&labels).unwrap();
    let o = render(&run, "pics", &["--pockets", "--frames", "1"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("frame_0001.pockets") && e.contains("missing"),
        "{e}"
    );
}
