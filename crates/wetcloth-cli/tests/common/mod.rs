//! Helpers shared by the picture tests (`pictures.rs`, `pockets_pictures.rs`): a small scene
//! run into a fresh folder, and a PNG's pixels.

#![allow(dead_code)] // each test file uses its own share

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

pub const BIN: &str = env!("CARGO_BIN_EXE_wetcloth");

/// The thesis model: a 12 x 12 cloth with 400 cm^3-per-0.09 m^2 of air under it, its centre
/// lifted 4 cm: a clear tent, its bubble below atmospheric pressure.
pub const TENT: &str = r#"
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

/// `wetcloth run SCENE --out OUT --quiet`, which must succeed.
pub fn run_into(scene: &Path, out: &Path) {
    let o = Command::new(BIN)
        .arg("run")
        .arg(scene)
        .arg("--out")
        .arg(out)
        .arg("--quiet")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// `scene_text` written into a fresh folder `group/test` of the test scratch space and run;
/// returns the run folder.
pub fn run_scene(group: &str, test: &str, scene_text: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(group)
        .join(test);
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("scene.toml");
    fs::write(&scene, scene_text).unwrap();
    let run = dir.join("run");
    run_into(&scene, &run);
    run
}

/// A PNG's width, height and RGB pixels.
pub fn png_size_and_pixels(path: &Path) -> (u32, u32, Vec<[u8; 3]>) {
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
