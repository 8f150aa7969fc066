//! Fuzzing what `render` and `plot` read: sound run folders (of the grid, or of a cloth of any
//! shape with polygon faces) damaged at random (files cut short,
//! numbers replaced by NaN, infinities or junk, lines deleted or doubled, bytes inserted,
//! frames removed or doubled, `run.json` values replaced by any JSON), and `metrics.csv` files
//! with extreme and non-finite values. Properties: no panic, no hang; a folder that
//! [`check_run`] accepts really is one cloth of finite vertices in every frame; a metrics file
//! that is accepted has finite times and draws.
//!
//! A short campaign runs with the test suite; the long one is
//! `cargo test --release -p wetcloth-render --test fuzz -- --ignored`. `WETCLOTH_FUZZ_CASES`
//! and `WETCLOTH_FUZZ_SEED` set the cases and the seed (docs/reliability.md). Keep what a
//! failure finds as a regression test named after it (`tests/damaged.rs`, `plot.rs`'s tests).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::{Config, RngAlgorithm, TestCaseError, TestRng, TestRunner};
use wetcloth_render::plot::{COLUMNS, draw_metrics, parse_metrics};
use wetcloth_render::{check_run, tented_grid};

const HANG: Duration = Duration::from_secs(60);
static CURRENT: Mutex<Option<(Instant, String)>> = Mutex::new(None);

fn watchdog() {
    static STARTED: std::sync::Once = std::sync::Once::new();
    STARTED.call_once(|| {
        std::thread::spawn(|| {
            loop {
                std::thread::sleep(Duration::from_millis(200));
                let guard = CURRENT.lock().unwrap_or_else(|e| e.into_inner());
                if let Some((t, input)) = guard.as_ref()
                    && t.elapsed() > HANG
                {
                    eprintln!("fuzz: a case hung for {HANG:?}; its input:\n{input}");
                    std::process::abort();
                }
            }
        });
    });
}

fn guarded<T>(input: impl FnOnce() -> String, f: impl FnOnce() -> T) -> T {
    *CURRENT.lock().unwrap_or_else(|e| e.into_inner()) = Some((Instant::now(), input()));
    let out = f();
    *CURRENT.lock().unwrap_or_else(|e| e.into_inner()) = None;
    out
}

fn cases(default: u32) -> u32 {
    std::env::var("WETCLOTH_FUZZ_CASES")
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(default)
}

fn runner(cases: u32) -> TestRunner {
    watchdog();
    let seed: u64 = std::env::var("WETCLOTH_FUZZ_SEED")
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(0x7265_6e64_6572);
    let mut bytes = [0u8; 32];
    bytes[..8].copy_from_slice(&seed.to_le_bytes());
    let config = Config {
        cases,
        max_shrink_iters: 1024,
        failure_persistence: None,
        ..Config::default()
    };
    eprintln!("fuzz: {cases} cases, seed {seed}");
    TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, &bytes))
}

/// Numbers and words a damaged file may hold.
const JUNK: &[&str] = &[
    "nan",
    "NaN",
    "inf",
    "-inf",
    "infinity",
    "1e39",
    "-1e39",
    "1e308",
    "-0",
    "0",
    "-1",
    "",
    "x",
    "99999999999",
    "1/1/1",
    "0/0/0",
    "f",
    "v",
    "vt",
    "#",
    "1e-320",
    "3.4028236e38",
    "2",
    "7",
    "-7",
    "1.5",
    "o",
    "//",
    "1//1",
    "-2147483648",
];

/// A sound run folder: `frames` frames of an `n` x `n` cloth and run.json; with `mesh`, a
/// mesh run of the same vertices (a cloth of any shape: run.json's `mesh`, no resolution) whose
/// faces are the cells as quads, every third cell as two triangles.
fn write_run(dir: &Path, n: usize, frames: usize, mesh: bool) {
    let _ = std::fs::remove_dir_all(dir);
    std::fs::create_dir_all(dir.join("frames")).unwrap();
    let mut faces: Vec<Vec<u32>> = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = (j * n + i) as u32 + 1;
            let (b, c, d) = (a + 1, a + 1 + n as u32, a + n as u32);
            if mesh && (i + j) % 3 != 0 {
                faces.push(vec![a, d, c, b]);
            } else {
                faces.extend([vec![a, c, b], vec![a, d, c]]);
            }
        }
    }
    for f in 0..frames {
        let (p, _) = tented_grid(n, 0.3, 0.002, 0.02 * f as f32);
        let mut s = if mesh {
            format!(
                "# wetcloth cloth mesh: {} particles, {} faces\no cloth\n",
                p.len(),
                faces.len()
            )
        } else {
            format!("# wetcloth cloth mesh: {n} x {n} particles\no cloth\n")
        };
        for v in &p {
            writeln!(s, "v {:?} {:?} {:?}", v[0], v[1], v[2]).unwrap();
        }
        for _ in &p {
            s += "vt 0.5 0.5\nvn 0.0 1.0 0.0\n";
        }
        for face in &faces {
            s += "f";
            for k in face {
                write!(s, " {k}/{k}/{k}").unwrap();
            }
            s += "\n";
        }
        std::fs::write(dir.join(format!("frames/frame_{f:04}.obj")), s).unwrap();
    }
    let json = serde_json::json!({
        "name": "fuzz", "resolution": [n, n], "size": [0.3, 0.3], "particle_radius": 0.001,
        "time_step": 1e-4, "frame_rate": 30.0, "duration": 1.0, "frames": frames,
        "complete": true, "status": "complete", "time": 1.0,
        "colliders": [
            {"shape": "plane", "point": [0.0, 0.0, 0.0], "normal": [0.0, 1.0, 0.0], "friction": 0.6},
            {"shape": "sphere", "center": [0.3, 0.05, 0.0], "radius": 0.05, "friction": 0.5},
            {"shape": "box", "center": [0.0, 0.05, 0.3], "half_extents": [0.05, 0.05, 0.05], "friction": 0.5}
        ],
        "grabs": [[0, 0]]
    });
    let mut json = json;
    if mesh {
        let o = json.as_object_mut().unwrap();
        o.remove("resolution");
        o.remove("size");
        o.insert(
            "mesh".into(),
            serde_json::json!({"file": "fuzz.obj", "vertices": n * n, "faces": faces.len()}),
        );
    }
    std::fs::write(
        dir.join("run.json"),
        serde_json::to_string_pretty(&json).unwrap(),
    )
    .unwrap();
}

/// One kind of damage.
#[derive(Clone, Debug)]
enum Damage {
    Truncate(Index, Index),
    ReplaceWord(Index, Index, &'static str),
    DeleteLine(Index, Index),
    DuplicateLine(Index, Index),
    InsertBytes(Index, Index, Vec<u8>),
    RemoveFile(Index),
    CopyFrame(Index, u64),
    JsonSet(&'static str, serde_json::Value),
    JsonRemove(&'static str),
}

fn json_value() -> impl Strategy<Value = serde_json::Value> {
    use serde_json::json;
    let leaf = prop_oneof![
        Just(json!(null)),
        any::<bool>().prop_map(|b| json!(b)),
        any::<f64>()
            .prop_filter("JSON numbers are finite", |v| v.is_finite())
            .prop_map(|v| json!(v)),
        any::<i64>().prop_map(|v| json!(v)),
        (0u64..10).prop_map(|v| json!(v)),
        "[a-z]{0,6}".prop_map(|s| json!(s)),
        prop::sample::select(vec![
            "running",
            "complete",
            "interrupted",
            "failed",
            "plane",
            "box"
        ])
        .prop_map(|s| json!(s)),
    ];
    leaf.prop_recursive(2, 12, 4, |inner| {
        prop_oneof![
            prop::collection::vec(inner.clone(), 0..4).prop_map(serde_json::Value::Array),
            prop::collection::vec(inner, 2..=3).prop_map(serde_json::Value::Array),
        ]
    })
}

const JSON_KEYS: &[&str] = &[
    "name",
    "resolution",
    "particle_radius",
    "frame_rate",
    "frames",
    "status",
    "colliders",
    "grabs",
    "complete",
    "time",
    "mesh",
    "mesh.vertices",
    "mesh.faces",
];

fn damage() -> impl Strategy<Value = Damage> {
    let junk = prop::sample::select(JUNK);
    prop_oneof![
        1 => (any::<Index>(), any::<Index>()).prop_map(|(f, i)| Damage::Truncate(f, i)),
        4 => (any::<Index>(), any::<Index>(), junk).prop_map(|(f, i, w)| Damage::ReplaceWord(f, i, w)),
        1 => (any::<Index>(), any::<Index>()).prop_map(|(f, i)| Damage::DeleteLine(f, i)),
        1 => (any::<Index>(), any::<Index>()).prop_map(|(f, i)| Damage::DuplicateLine(f, i)),
        1 => (any::<Index>(), any::<Index>(), prop::collection::vec(any::<u8>(), 1..6))
            .prop_map(|(f, i, b)| Damage::InsertBytes(f, i, b)),
        1 => any::<Index>().prop_map(Damage::RemoveFile),
        1 => (any::<Index>(), 0u64..8).prop_map(|(f, n)| Damage::CopyFrame(f, n)),
        3 => (prop::sample::select(JSON_KEYS), json_value()).prop_map(|(k, v)| Damage::JsonSet(k, v)),
        1 => (prop::sample::select(JSON_KEYS)).prop_map(Damage::JsonRemove),
    ]
}

/// The files of a run folder, in a fixed order.
fn files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir.join("frames"))
        .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    v.sort();
    if dir.join("run.json").exists() {
        v.push(dir.join("run.json"));
    }
    v
}

fn apply(dir: &Path, d: &Damage) {
    let fs = files(dir);
    let pick = |i: &Index| (!fs.is_empty()).then(|| fs[i.index(fs.len())].clone());
    let edit = |i: &Index, f: &dyn Fn(Vec<u8>) -> Vec<u8>| {
        if let Some(p) = pick(i)
            && let Ok(b) = std::fs::read(&p)
        {
            std::fs::write(&p, f(b)).unwrap();
        }
    };
    let lines =
        |b: &[u8]| -> Vec<Vec<u8>> { b.split(|&c| c == b'\n').map(<[u8]>::to_vec).collect() };
    match d {
        Damage::Truncate(f, i) => edit(f, &|mut b| {
            let n = i.index(b.len().max(1));
            b.truncate(n);
            b
        }),
        Damage::ReplaceWord(f, i, w) => edit(f, &|b| {
            let text = String::from_utf8_lossy(&b).into_owned();
            let words: Vec<&str> = text.split(' ').collect();
            let k = i.index(words.len());
            let mut words: Vec<String> = words.iter().map(|s| s.to_string()).collect();
            // Keep a line end the word carried.
            let tail = if words[k].ends_with('\n') { "\n" } else { "" };
            words[k] = format!("{w}{tail}");
            words.join(" ").into_bytes()
        }),
        Damage::DeleteLine(f, i) => edit(f, &|b| {
            let mut l = lines(&b);
            let k = i.index(l.len());
            l.remove(k);
            l.join(&b'\n')
        }),
        Damage::DuplicateLine(f, i) => edit(f, &|b| {
            let mut l = lines(&b);
            let k = i.index(l.len());
            l.insert(k, l[k].clone());
            l.join(&b'\n')
        }),
        Damage::InsertBytes(f, i, bytes) => edit(f, &|mut b| {
            let at = i.index(b.len() + 1);
            b.splice(at..at, bytes.iter().copied());
            b
        }),
        Damage::RemoveFile(f) => {
            if let Some(p) = pick(f) {
                let _ = std::fs::remove_file(p);
            }
        }
        Damage::CopyFrame(f, n) => {
            if let Some(p) = pick(f) {
                let _ = std::fs::copy(p, dir.join(format!("frames/frame_{n:04}.obj")));
            }
        }
        Damage::JsonSet(k, _) | Damage::JsonRemove(k) if dir.join("run.json").exists() => {
            let path = dir.join("run.json");
            let Ok(mut json) =
                serde_json::from_slice::<serde_json::Value>(&std::fs::read(&path).unwrap())
            else {
                return;
            };
            // `a.b` is key `b` of the object at key `a`.
            let (outer, key) = match k.split_once('.') {
                Some((a, b)) => (json.get_mut(a), b),
                None => (Some(&mut json), *k),
            };
            if let Some(o) = outer.and_then(|o| o.as_object_mut()) {
                match d {
                    Damage::JsonSet(_, v) => {
                        o.insert(key.to_string(), v.clone());
                    }
                    _ => {
                        o.remove(key);
                    }
                }
            }
            std::fs::write(&path, serde_json::to_string(&json).unwrap()).unwrap();
        }
        Damage::JsonSet(..) | Damage::JsonRemove(_) => {}
    }
}

/// An independent reading of the frames: vertex lines and whether all are finite 32-bit
/// numbers.
fn vertex_lines(path: &Path) -> (usize, bool) {
    let text = String::from_utf8_lossy(&std::fs::read(path).unwrap()).into_owned();
    let mut count = 0;
    let mut finite = true;
    for line in text.lines() {
        let mut w = line.split_ascii_whitespace();
        if w.next() == Some("v") {
            count += 1;
            finite &= w
                .take(3)
                .all(|x| x.parse::<f32>().is_ok_and(f32::is_finite));
        }
    }
    (count, finite)
}

fn check_folder(dir: &Path) -> Result<(), TestCaseError> {
    let describe = || {
        files(dir)
            .iter()
            .map(|p| {
                format!(
                    "== {}\n{}",
                    p.display(),
                    String::from_utf8_lossy(&std::fs::read(p).unwrap_or_default())
                )
            })
            .collect::<String>()
    };
    let result = guarded(describe, || check_run(dir));
    if let Ok(found) = result {
        let frames: Vec<PathBuf> = files(dir)
            .into_iter()
            .filter(|p| p.extension().is_some_and(|e| e == "obj"))
            .collect();
        prop_assert_eq!(found.frames, frames.len());
        for p in &frames {
            let (count, finite) = vertex_lines(p);
            prop_assert!(finite, "accepted a non-finite vertex in {}", p.display());
            prop_assert_eq!(count, found.vertices, "{}", p.display());
        }
        if let Some(info) = &found.info
            && let Some((v, t)) = info.mesh_size()
        {
            prop_assert_eq!((found.vertices, found.triangles), (v, t));
        }
        if let Some(m) = found.info.as_ref().and_then(|i| i.mesh.as_ref()) {
            prop_assert_eq!((found.vertices, found.faces), (m.vertices, m.faces));
        }
    } else if let Err(e) = result {
        let msg = e.to_string();
        prop_assert!(!msg.is_empty());
    }
    Ok(())
}

fn folder_campaign(n: u32) {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fuzz-render-run");
    runner(n)
        .run(
            &(
                2usize..7,
                1usize..4,
                any::<bool>(),
                prop::collection::vec(damage(), 0..4),
            ),
            |(side, frames, mesh, damage)| {
                write_run(&dir, side, frames, mesh);
                for d in &damage {
                    apply(&dir, d);
                }
                check_folder(&dir)
            },
        )
        .unwrap();
}

fn metric_value() -> impl Strategy<Value = String> {
    prop_oneof![
        300 => (-10.0f64..10.0).prop_map(|v| format!("{v:?}")),
        100 => any::<f64>().prop_map(|v| format!("{v:?}")),
        50 => prop::sample::select(vec![
            "inf", "-inf", "nan", "NaN", "1e308", "-1e308", "1.7976931348623157e308", "5e-324",
            "-0.0", "0", "1e-320",
        ])
        .prop_map(String::from),
        // Not a number now and then: the row is refused.
        1 => prop::sample::select(vec!["x", "", "1e", "--1"]).prop_map(String::from),
    ]
}

/// A metrics.csv: the plot's columns (shuffled, sometimes one missing or one extra), and rows
/// of numbers, times mostly increasing.
fn metrics_text() -> impl Strategy<Value = String> {
    (
        Just(COLUMNS.to_vec()).prop_shuffle(),
        prop_oneof![8 => Just(None), 1 => any::<Index>().prop_map(Some)],
        any::<bool>(),
        prop::collection::vec(
            (
                prop_oneof![6 => Just(None), 1 => metric_value().prop_map(Some)],
                prop::collection::vec(metric_value(), 9),
            ),
            0..60,
        ),
        0.0f64..1e3,
    )
        .prop_map(|(mut cols, drop, extra, rows, step)| {
            if let Some(i) = drop {
                cols.remove(i.index(cols.len()));
            }
            if extra {
                cols.push("trapped_air");
            }
            let mut s = cols.join(",") + "\n";
            for (k, (time, values)) in rows.iter().enumerate() {
                let fields: Vec<String> = cols
                    .iter()
                    .enumerate()
                    .map(|(c, name)| match *name {
                        "time" => time
                            .clone()
                            .unwrap_or_else(|| format!("{:?}", k as f64 * step)),
                        "frame" => k.to_string(),
                        _ => values[c % values.len()].clone(),
                    })
                    .collect();
                s += &fields.join(",");
                s.push('\n');
            }
            s
        })
}

fn metrics_campaign(n: u32, draw_every: u32) {
    let count = std::sync::atomic::AtomicU32::new(0);
    runner(n)
        .run(&metrics_text(), |text| {
            let count = count.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            let parsed = guarded(
                || text.clone(),
                || parse_metrics(&text, Path::new("metrics.csv")),
            );
            if let Ok(m) = parsed {
                prop_assert!(m.time.iter().all(|t| t.is_finite()));
                prop_assert!(!m.is_empty());
                if count.is_multiple_of(draw_every) {
                    let img = guarded(|| text.clone(), || draw_metrics(&m, "fuzz"));
                    prop_assert!(img.is_ok(), "{:?}", img.err());
                }
            }
            Ok(())
        })
        .unwrap();
}

#[test]
fn damaged_run_folders_never_panic_and_nothing_damaged_is_accepted() {
    folder_campaign(cases(300));
}

#[test]
fn metrics_files_never_panic_or_hang_the_plot() {
    metrics_campaign(cases(600), 20);
}

/// The long campaign: 100 000 damaged folders and 100 000 metrics files (10 000 drawn), unless
/// `WETCLOTH_FUZZ_CASES` says otherwise.
#[test]
#[ignore = "long fuzz campaign: run with --ignored"]
fn long_campaign_damaged_folders_and_metrics() {
    folder_campaign(cases(100_000));
    metrics_campaign(cases(100_000), 10);
}
