//! `wetcloth bench`: its table and JSON have the promised content (never its speed: timings
//! are the benchmark's business, not a test's).

use std::path::Path;
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_wetcloth");

#[test]
fn bench_writes_a_table_and_json_with_one_entry_per_size_and_thread_count() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("cli-bench");
    std::fs::create_dir_all(&dir).unwrap();
    let json = dir.join("bench.json");
    let o = Command::new(BIN)
        .args([
            "bench",
            "--sizes",
            "4,10",
            "--threads",
            "1,2",
            "--seconds",
            "0.05",
            "--json",
        ])
        .arg(&json)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let table = String::from_utf8_lossy(&o.stdout);
    assert!(table.contains("particle-steps/s"), "{table}");
    // 10 x 10 = 100 particles is in the thesis' table 4.2 (1720 frames per second).
    assert!(
        table
            .lines()
            .any(|l| l.trim_start().starts_with("100 ") && l.contains("1720")),
        "{table}"
    );

    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let list = v.as_array().unwrap();
    assert_eq!(list.len(), 4);
    let mut seen = Vec::new();
    for m in list {
        let get = |k: &str| m[k].as_f64().unwrap_or_else(|| panic!("key {k} in {m}"));
        let (n, t, sps) = (get("particles"), get("threads"), get("steps_per_second"));
        seen.push((n as usize, t as usize));
        assert!(sps > 0.0);
        assert!((get("particle_steps_per_second") - sps * n).abs() <= 1e-9 * sps * n);
        assert!((get("real_time_factor") - sps / 12000.0).abs() <= 1e-3 * sps / 12000.0);
    }
    assert_eq!(seen, [(16, 1), (16, 2), (100, 1), (100, 2)]);
}

#[test]
fn bench_rejects_bad_options_with_a_clear_message() {
    let o = Command::new(BIN)
        .args(["bench", "--seconds=-1"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("--seconds"), "{err}");
    let o = Command::new(BIN)
        .args(["bench", "--sizes", "1"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
}
