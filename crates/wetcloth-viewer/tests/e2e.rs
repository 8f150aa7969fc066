//! End to end: the viewer window under Xvfb, driven by a script.
//!
//! The script waits for the cloth to settle on the table, turns the air-pressure force off with
//! its shortcut (so the keyboard path is exercised, and the lift does not hang on the air
//! model's parameters), saves a screenshot, picks the cloth near its centre, drags it up, saves a
//! second screenshot, pins the particle with a right click, lets go of the mouse, saves a third
//! and quits. The test then checks that the viewer exited with status 0 and that, in the second
//! and third screenshots, the pixels on the path of the drag above the cloth's resting
//! silhouette have turned from table to cloth, while the pixels away from the drag stayed as
//! they were.
//!
//! Needs `Xvfb` and a Vulkan driver (Mesa's lavapipe works without a GPU). On Debian:
//! `apt-get install xvfb mesa-vulkan-drivers libvulkan1`. Without them the test fails and says
//! so. It runs without the test harness (`harness = false`) because a window's event loop must
//! live on the main thread: the test re-runs its own executable as the viewer process.

use std::io::Read;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Environment variable that makes this executable act as the viewer process; its value is the
/// script path.
const CHILD: &str = "WETCLOTH_E2E_VIEWER_SCRIPT";

const PACKAGES: &str = "xvfb mesa-vulkan-drivers libvulkan1";

/// Environment variable naming the scene file the viewer process opens (the thesis demo
/// without it).
const SCENE: &str = "WETCLOTH_E2E_VIEWER_SCENE";

/// Environment variable that keeps the screenshots of a passing run (their folder is printed).
const KEEP: &str = "WETCLOTH_E2E_KEEP";

/// The tests, by name.
const TESTS: [(&str, fn()); 2] = [
    ("viewer_lifts_the_cloth", viewer_lifts_the_cloth),
    (
        "viewer_drags_a_vertex_of_a_mesh_cloth",
        viewer_drags_a_vertex_of_a_mesh_cloth,
    ),
];

fn main() {
    if let Ok(script) = std::env::var(CHILD) {
        viewer(Path::new(&script));
        return;
    }
    // `cargo test NAME` passes filters; run each test unless one is given that does not match.
    let filters: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    let list = std::env::args().any(|a| a == "--list");
    for (name, test) in TESTS {
        if !filters.is_empty() && !filters.iter().any(|f| name.contains(f.as_str())) {
            if !list {
                println!("test {name} ... filtered out");
            }
            continue;
        }
        if list {
            println!("{name}: test");
            continue;
        }
        println!("test {name} ...");
        test();
        println!("test {name} ... ok");
    }
}

/// The viewer process: the thesis demo, or the scene [`SCENE`] names, driven by the script.
fn viewer(script: &Path) {
    let mut opts = match std::env::var(SCENE) {
        Ok(path) => {
            let scene = wetcloth_scene::load(Path::new(&path)).unwrap_or_else(|e| {
                eprintln!("viewer failed: {e}");
                std::process::exit(1);
            });
            wetcloth_viewer::ViewerOptions::new(scene.config, scene.name)
        }
        Err(_) => wetcloth_viewer::ViewerOptions::thesis_demo(),
    };
    opts.script = Some(script.to_path_buf());
    opts.exit_after_script = true;
    opts.window_size = [1100.0, 700.0];
    if let Err(e) = wetcloth_viewer::run(opts) {
        eprintln!("viewer failed: {e}");
        std::process::exit(1);
    }
}

/// An Xvfb server on a free display, stopped on drop.
struct Xvfb {
    child: Child,
    display: String,
    /// The display's number.
    number: u32,
}

/// The lock file and socket an X server on display `n` keeps while it runs.
fn display_files(n: u32) -> [String; 2] {
    [format!("/tmp/.X{n}-lock"), format!("/tmp/.X11-unix/X{n}")]
}

/// Whether display `n`'s files belong to no running server: its lock names a process that no
/// longer exists (a server killed without cleaning up), or there is a socket without a lock.
fn stale(n: u32) -> bool {
    let [lock, socket] = display_files(n);
    match std::fs::read_to_string(&lock) {
        Ok(pid) => match pid.trim().parse::<u32>() {
            Ok(pid) => !Path::new(&format!("/proc/{pid}")).exists(),
            Err(_) => false,
        },
        Err(_) => Path::new(&socket).exists(),
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        // Asked to stop (SIGTERM), Xvfb removes its lock and socket; killed, it leaves them
        // behind, and a machine that ran this test fifty times had no display left to use.
        let stopped = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status()
            .is_ok_and(|s| s.success());
        let t = Instant::now();
        while stopped && t.elapsed() < Duration::from_secs(5) {
            if let Ok(Some(_)) = self.child.try_wait() {
                break;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
        // Only files no running server owns (one that won a race for this display keeps its).
        if stale(self.number) {
            for f in display_files(self.number) {
                let _ = std::fs::remove_file(f);
            }
        }
    }
}

fn start_xvfb() -> Xvfb {
    for n in 90..140 {
        let [lock, socket] = display_files(n);
        if stale(n) {
            let _ = std::fs::remove_file(&lock);
            let _ = std::fs::remove_file(&socket);
        }
        if Path::new(&socket).exists() || Path::new(&lock).exists() {
            continue;
        }
        let display = format!(":{n}");
        let child = match Command::new("Xvfb")
            .args([&display, "-screen", "0", "1280x800x24", "-nolisten", "tcp"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
        {
            Ok(c) => c,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => panic!(
                "Xvfb is not installed: the viewer's end-to-end test needs a virtual display and \
                 a Vulkan driver. On Debian/Ubuntu: apt-get install {PACKAGES}"
            ),
            Err(e) => panic!("cannot start Xvfb: {e}"),
        };
        let mut x = Xvfb {
            child,
            display,
            number: n,
        };
        let t = Instant::now();
        while t.elapsed() < Duration::from_secs(10) {
            if Path::new(&socket).exists() {
                return x;
            }
            if let Ok(Some(_)) = x.child.try_wait() {
                break; // lost a race for this display; try the next
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
    panic!("could not start Xvfb on any display :90 to :139");
}

fn check_vulkan() {
    let dirs = ["/usr/share/vulkan/icd.d", "/etc/vulkan/icd.d"];
    let found = dirs.iter().any(|d| {
        std::fs::read_dir(d).is_ok_and(|mut r| {
            r.any(|e| e.is_ok_and(|e| e.path().extension().is_some_and(|x| x == "json")))
        })
    });
    assert!(
        found,
        "no Vulkan driver found (no ICD in {dirs:?}): the viewer's end-to-end test renders with \
         Mesa's software Vulkan. On Debian/Ubuntu: apt-get install {PACKAGES}"
    );
}

/// Where the 3D view lies in a screenshot, from the viewer's report on stderr.
#[derive(Clone, Copy, Debug)]
struct ViewRect {
    x: f32,
    y: f32,
    w: f32,
    h: f32,
}

impl ViewRect {
    /// Pixel at normalised view coordinates.
    fn at(&self, u: f32, v: f32) -> (u32, u32) {
        ((self.x + u * self.w) as u32, (self.y + v * self.h) as u32)
    }
}

fn parse_view(stderr: &str, png: &Path) -> ViewRect {
    let name = png.display().to_string();
    let line = stderr
        .lines()
        .find(|l| l.contains("saved screenshot") && l.contains(&name))
        .unwrap_or_else(|| panic!("the viewer did not report saving {name}:\n{stderr}"));
    let field = |key: &str| -> f32 {
        let i = line
            .find(key)
            .unwrap_or_else(|| panic!("no {key} in {line}"))
            + key.len();
        line[i..]
            .split(|c: char| !(c.is_ascii_digit() || c == '.'))
            .next()
            .and_then(|s| s.parse().ok())
            .unwrap_or_else(|| panic!("bad {key} in {line}"))
    };
    ViewRect {
        x: field(" x="),
        y: field(" y="),
        w: field(" w="),
        h: field(" h="),
    }
}

fn distance(a: &image::Rgba<u8>, b: &image::Rgba<u8>) -> i32 {
    (0..3)
        .map(|i| (i32::from(a[i]) - i32::from(b[i])).abs())
        .sum()
}

/// Runs the viewer process on display `x` with `script` (and the scene file `scene`, or the
/// thesis demo), waits for it to exit with status 0 and returns its stdout and stderr.
fn run_viewer(x: &Xvfb, dir: &Path, script: &Path, scene: Option<&Path>) -> (String, String) {
    let runtime = dir.join("xdg");
    std::fs::create_dir_all(&runtime).unwrap();
    let mut command = Command::new(std::env::current_exe().unwrap());
    command
        .env(CHILD, script)
        .env("DISPLAY", &x.display)
        .env_remove("WAYLAND_DISPLAY")
        .env("XDG_RUNTIME_DIR", &runtime)
        .env("WGPU_BACKEND", "vulkan")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    match scene {
        Some(s) => command.env(SCENE, s),
        None => command.env_remove(SCENE),
    };
    let mut child = command.spawn().unwrap();
    let read = |mut pipe: Box<dyn Read + Send>| {
        std::thread::spawn(move || {
            let mut s = String::new();
            let _ = pipe.read_to_string(&mut s);
            s
        })
    };
    let stdout = read(Box::new(child.stdout.take().unwrap()));
    let stderr = read(Box::new(child.stderr.take().unwrap()));
    let t = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if t.elapsed() > Duration::from_secs(240) {
            let _ = child.kill();
            let _ = child.wait();
            panic!(
                "the viewer did not finish its script within 240 s:\n{}",
                stderr.join().unwrap()
            );
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let (stdout, stderr) = (stdout.join().unwrap(), stderr.join().unwrap());
    assert!(
        status.success(),
        "the viewer exited with {status}:\n{stdout}\n{stderr}"
    );
    (stdout, stderr)
}

/// A fresh folder for one test's files.
fn test_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("wetcloth-e2e-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Removes a passing test's folder, unless [`KEEP`] is set.
fn done_with(dir: &Path) {
    if std::env::var_os(KEEP).is_some() {
        println!("screenshots kept in {}", dir.display());
    } else {
        let _ = std::fs::remove_dir_all(dir);
    }
}

fn viewer_lifts_the_cloth() {
    check_vulkan();
    let x = start_xvfb();
    let dir = test_dir("lift");
    let before = dir.join("before.png");
    let after = dir.join("after.png");
    let pinned = dir.join("pinned.png");
    let script = dir.join("lift.txt");
    // Pick below the view centre, where the cloth's middle lies with the default camera, and
    // pull straight up to near the top of the view.
    std::fs::write(
        &script,
        format!(
            "wait_sim 0.05\n\
             key A\n\
             wait_sim +0.05\n\
             screenshot {}\n\
             pick 0.5 {PICK_V}\n\
             drag_to 0.5 {DRAG_V} 20\n\
             wait_sim +0.3\n\
             screenshot {}\n\
             pin\n\
             release\n\
             wait_sim +0.2\n\
             screenshot {}\n\
             quit\n",
            before.display(),
            after.display(),
            pinned.display()
        ),
    )
    .unwrap();

    let (_, stderr) = run_viewer(&x, &dir, &script, None);

    let view = parse_view(&stderr, &after);
    let a = image::open(&before).unwrap().to_rgba8();
    let b = image::open(&after).unwrap().to_rgba8();
    assert_eq!(a.dimensions(), b.dimensions());
    let (w, h) = a.dimensions();
    assert!(
        view.w > 200.0
            && view.h > 200.0
            && view.x + view.w <= w as f32 + 1.0
            && view.y + view.h <= h as f32 + 1.0,
        "{view:?} in {w}x{h}"
    );

    // The resting silhouette: in the first screenshot, scan up the drag's column from the pick
    // point to where the table begins (eight rows in a row of the table's colour, sampled near
    // the end of the drag, which lies beyond the cloth).
    let (px, py) = view.at(0.5, PICK_V);
    let (_, top_limit) = view.at(0.5, DRAG_V + 0.02);
    let table = *a.get_pixel(px, top_limit);
    let is_table = |y: u32| distance(a.get_pixel(px, y), &table) < 30;
    let mut edge = py;
    while edge > top_limit && !(0..8).all(|d| is_table(edge - d)) {
        edge -= 1;
    }
    // Rows between the dragged point and a little above the edge: table before, cloth after.
    let (_, top) = view.at(0.5, DRAG_V + 0.03);
    let bottom = edge.saturating_sub(4);
    assert!(
        bottom > top + 10,
        "the pick point is too close to the top: edge {edge}, top {top}"
    );
    let changed_fraction = |b: &image::RgbaImage| {
        let mut changed = 0;
        let mut total = 0;
        for y in top..bottom {
            for x in px - 2..=px + 2 {
                total += 1;
                if distance(a.get_pixel(x, y), b.get_pixel(x, y)) > 40 {
                    changed += 1;
                }
            }
        }
        changed as f64 / total as f64
    };
    let lifted = changed_fraction(&b);
    // Pinned with a right click and let go: the cloth stays up.
    let still_up = changed_fraction(&image::open(&pinned).unwrap().to_rgba8());
    // A patch of table far from the drag (the bottom-left corner of the view, nearest the
    // camera) is unchanged. (Not the far end of the table: it fades into the background at a
    // distance that follows the scene's extent, which the lifted cloth changes.)
    let (cx, cy) = view.at(0.03, 0.92);
    let mut same = 0;
    let mut corner = 0;
    for y in cy..cy + 20 {
        for x in cx..cx + 20 {
            corner += 1;
            if distance(a.get_pixel(x, y), b.get_pixel(x, y)) <= 12 {
                same += 1;
            }
        }
    }
    eprintln!(
        "pick at ({px}, {py}); resting edge at y = {edge}; rows {top}..{bottom}: {:.0} % changed \
         while dragged, {:.0} % once pinned; corner {:.0} % unchanged",
        lifted * 100.0,
        still_up * 100.0,
        100.0 * same as f64 / corner as f64
    );
    assert!(
        lifted > 0.6,
        "the cloth does not show above its resting silhouette where it was dragged: only {:.0} % \
         of the pixels changed (screenshots in {})",
        lifted * 100.0,
        dir.display()
    );
    assert!(
        still_up > 0.6,
        "after the right click (pin) and letting go, the cloth fell back: {:.0} % changed \
         (screenshots in {})",
        still_up * 100.0,
        dir.display()
    );
    assert!(
        same as f64 / corner as f64 > 0.95,
        "the view changed away from the drag (screenshots in {})",
        dir.display()
    );
    done_with(&dir);
}

/// The particle's position in a `wetcloth: particle K at X Y Z m` line of `stdout`, the
/// `n`-th such line (from 0).
fn reported(stdout: &str, n: usize) -> [f32; 3] {
    let line = stdout
        .lines()
        .filter(|l| l.starts_with("wetcloth: particle "))
        .nth(n)
        .unwrap_or_else(|| panic!("no particle report {n} in:\n{stdout}"));
    let numbers: Vec<f32> = line
        .split_whitespace()
        .filter_map(|w| w.parse().ok())
        .collect();
    match numbers.as_slice() {
        [_, x, y, z] => [*x, *y, *z],
        _ => panic!("cannot read {line:?}"),
    }
}

/// A cloth of any shape in the viewer: the pinned towel (`scenes/towel-pinned.toml`, an
/// irregular triangle mesh hung by its top edge). The script lets it settle, reports the bottom
/// middle vertex, picks that vertex by its index, drags it across the view, reports it again and
/// lets go. The vertex must have followed the drag (moved well beyond its swing), the viewer
/// must draw the cloth (the view differs from an empty table where the towel hangs) and exit
/// with status 0 (a script step that fails, such as a vertex off screen, fails the run).
fn viewer_drags_a_vertex_of_a_mesh_cloth() {
    check_vulkan();
    let x = start_xvfb();
    let dir = test_dir("mesh");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/towel-pinned.toml");
    let (before, after) = (dir.join("towel.png"), dir.join("towel-dragged.png"));
    let script = dir.join("drag.txt");
    // Vertex 598 is the file's (0, 0, 0.35): the middle of the towel's bottom edge.
    std::fs::write(
        &script,
        format!(
            "wait_sim 0.3\n\
             report_particle 598\n\
             screenshot {}\n\
             pick_particle 598\n\
             drag_to 0.85 0.3 20\n\
             wait_sim +0.5\n\
             report_particle 598\n\
             screenshot {}\n\
             release\n\
             quit\n",
            before.display(),
            after.display()
        ),
    )
    .unwrap();
    let (stdout, stderr) = run_viewer(&x, &dir, &script, Some(&scene));
    let (p0, p1) = (reported(&stdout, 0), reported(&stdout, 1));
    let moved =
        ((p1[0] - p0[0]).powi(2) + (p1[1] - p0[1]).powi(2) + (p1[2] - p0[2]).powi(2)).sqrt();
    eprintln!("vertex 598 at {p0:?}, then at {p1:?} after the drag: moved {moved:.3} m");
    // At rest it hangs at y = 0.65 m; the drag lifts it up and across.
    assert!(
        (p0[1] - 0.65).abs() < 0.1,
        "the towel's bottom edge is not where it hangs: {p0:?}"
    );
    assert!(
        moved > 0.1,
        "the vertex did not follow the drag: {p0:?} then {p1:?} (screenshots in {})",
        dir.display()
    );
    assert!(
        p1[1] > p0[1] + 0.05,
        "the drag up did not lift it: {p0:?} then {p1:?}"
    );
    // The towel is drawn: the view is not one colour, and the drag changed it.
    let view = parse_view(&stderr, &before);
    let a = image::open(&before).unwrap().to_rgba8();
    let b = image::open(&after).unwrap().to_rgba8();
    let (cx, cy) = view.at(0.5, 0.5);
    let mut changed = 0;
    let mut total = 0;
    for y in (view.y as u32..(view.y + view.h) as u32).step_by(4) {
        for x in (view.x as u32..(view.x + view.w) as u32).step_by(4) {
            total += 1;
            if distance(a.get_pixel(x, y), b.get_pixel(x, y)) > 40 {
                changed += 1;
            }
        }
    }
    let (lx, ly) = view.at(0.05, 0.05);
    let differs = distance(a.get_pixel(cx, cy), a.get_pixel(lx, ly)) > 40;
    eprintln!(
        "{:.1} % of the view changed with the drag",
        100.0 * changed as f64 / total as f64
    );
    assert!(
        differs,
        "no cloth at the centre of the view (screenshots in {})",
        dir.display()
    );
    assert!(
        changed as f64 / total as f64 > 0.01,
        "the view did not change with the drag (screenshots in {})",
        dir.display()
    );
    done_with(&dir);
}

/// Normalised view height of the pick point and of the drag's end.
const PICK_V: f32 = 0.62;
const DRAG_V: f32 = 0.22;
