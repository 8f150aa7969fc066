//! Messages found misleading from outside, each with what it says now: the key, the line and
//! what is wrong, in words a scene author can act on.

use wetcloth::{Shape, Vec3};
use wetcloth_scene::{SceneError, load, parse};

fn err(text: &str) -> (SceneError, String) {
    let e = parse(text, "s.toml".as_ref()).unwrap_err();
    let msg = e.to_string();
    (e, msg)
}

fn assert_has(msg: &str, parts: &[&str]) {
    for p in parts {
        assert!(msg.contains(p), "missing {p:?} in:\n{msg}");
    }
}

/// `[[simulation]]` was reported as "expected a number, found map".
#[test]
fn an_array_of_tables_where_a_table_belongs_is_named_as_such() {
    let (e, msg) = err("[[simulation]]\nduration = 0.1\n");
    assert_has(
        &msg,
        &[
            "s.toml:1:1",
            "simulation",
            "expected a table, written [simulation], found an array of tables [[simulation]]",
        ],
    );
    assert_eq!(e.key(), Some("simulation"));
    let (_, msg) = err("[[cloth]]\nmass = 0.02\n");
    assert_has(&msg, &["expected a table, written [cloth]"]);
    let (e, msg) = err("[collider]\nshape = \"plane\"\n");
    assert_has(
        &msg,
        &[
            "s.toml:1:1",
            "expected an array of tables, written [[collider]], found a table [collider]",
        ],
    );
    assert_eq!(e.key(), Some("collider"));
    let (_, msg) = err("grab = { particle = [0, 0], keys = [] }\n");
    assert_has(
        &msg,
        &["expected an array of tables, written [[grab]], found an inline table"],
    );
    let (_, msg) = err("simulation = 3\n");
    assert_has(
        &msg,
        &["expected a table, written [simulation], found an integer 3"],
    );
}

/// A date value was reported as "expected a number, found map".
#[test]
fn a_date_value_is_named_a_date_time() {
    let (_, msg) = err("[simulation]\nduration = 1979-05-27\n");
    assert_has(
        &msg,
        &[
            "s.toml:2:12",
            "simulation.duration",
            "expected a number, found a date-time 1979-05-27",
        ],
    );
    let (_, msg) = err("[cloth]\nself_collision = 07:32:00\n");
    assert_has(
        &msg,
        &["expected true or false, found a date-time 07:32:00"],
    );
    let (_, msg) = err("name = 1979-05-27T07:32:00Z\n");
    assert_has(
        &msg,
        &["expected a string, found a date-time 1979-05-27T07:32:00Z"],
    );
    let (_, msg) = err("[[grab]]\nparticle = 1979-05-27\nkeys = []\n");
    assert_has(&msg, &["grab[0].particle", "found a date-time"]);
}

/// "must be a non-zero vector" was said of normals that are not zero, only very small or very
/// large: any finite non-zero vector is a direction, and is normalised.
#[test]
fn tiny_and_huge_normals_are_directions_and_only_zero_is_refused() {
    for n in [
        "[1e-200, 1e-200, 0]",
        "[1e300, 1e300, 0]",
        "[0, 5e-324, 0]",
        "[1.7e308, 1.7e308, 1.7e308]",
    ] {
        let text = format!(
            "[air]\nenabled = false\n[[collider]]\nshape = \"plane\"\npoint = [0, -1, 0]\nnormal = {n}\n"
        );
        let scene = parse(&text, "s.toml".as_ref()).unwrap_or_else(|e| panic!("{n}: {e}"));
        let Shape::Plane(wetcloth::collide::Plane { normal, .. }) = scene.config.colliders[0].shape
        else {
            panic!("a plane")
        };
        assert!((normal.length() - 1.0).abs() < 1e-12, "{n}: {normal:?}");
        assert!(normal.is_finite());
    }
    let text =
        "[[collider]]\nshape = \"plane\"\npoint = [-1, -1, 0]\nnormal = [1e-200, 1e-200, 0]\n";
    let s = parse(text, "s.toml".as_ref()).unwrap();
    let Shape::Plane(wetcloth::collide::Plane { normal, .. }) = s.config.colliders[0].shape else {
        panic!()
    };
    assert!((normal - Vec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-15);

    let (e, msg) = err("[[collider]]\nshape = \"plane\"\nnormal = [0, 0, 0]\n");
    assert_has(
        &msg,
        &[
            "s.toml:3:10",
            "collider[0].normal = [0, 0, 0]",
            "the zero vector has no direction",
        ],
    );
    assert_eq!(e.key(), Some("collider[0].normal"));
    let (_, msg) = err("[[collider]]\nshape = \"plane\"\nnormal = [nan, 0, 1]\n");
    assert_has(&msg, &["s.toml:3:10", "must be finite"]);
}

fn scratch(name: &str) -> std::path::PathBuf {
    let d = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("scene-messages");
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// Invalid UTF-8 was reported without a line ("stream did not contain valid UTF-8").
#[test]
fn invalid_utf8_is_located() {
    let path = scratch("latin1.toml");
    std::fs::write(&path, b"name = \"x\"\n[cloth]\nmass = 0.02 # caf\xe9\n").unwrap();
    let msg = load(&path).unwrap_err().to_string();
    assert_has(&msg, &["latin1.toml:3:18", "not UTF-8 text: byte 0xe9"]);
}

/// A TOML "recursion limit" (deeply dotted keys) was reported without a line.
#[test]
fn a_recursion_limit_is_located() {
    let text = format!("name = \"deep\"\n\n{}y = 1\n", "x.".repeat(300));
    let (e, msg) = err(&text);
    let at = e.location().unwrap();
    assert_eq!((at.line, at.column), (3, 1), "{msg}");
    assert_has(&msg, &["recursion", "nested too deeply"]);
    let text = format!("[cloth]\nmass = 1\n[{}b]\n", "a.".repeat(300));
    let (e, msg) = err(&text);
    assert_eq!(e.location().unwrap().line, 3, "{msg}");
    // Deep arrays and inline tables come with a position from the parser itself.
    let text = format!("a = {}{}\n", "[".repeat(2000), "]".repeat(2000));
    let (e, _) = err(&text);
    assert_eq!(e.location().unwrap().line, 1);
}

/// A scene file was read without a size limit: `wetcloth run /dev/zero` never ended.
#[cfg(unix)]
#[test]
fn an_endless_file_is_refused_after_the_size_limit() {
    let t = std::time::Instant::now();
    let msg = load("/dev/zero").unwrap_err().to_string();
    assert_has(
        &msg,
        &["/dev/zero", "larger than the 16 MiB a scene file may have"],
    );
    assert!(t.elapsed().as_secs() < 30);
    let big = scratch("big.toml");
    let mut text = String::from("# padding\n");
    while text.len() <= 16 << 20 {
        text.push_str(&"#".repeat(1023));
        text.push('\n');
    }
    std::fs::write(&big, &text).unwrap();
    assert_has(
        &load(&big).unwrap_err().to_string(),
        &["larger than the 16 MiB"],
    );
}
