//! `Scene::set` / `Scene::get` by key path, and `parse_value`: the code behind
//! `wetcloth run --set KEY=VALUE` and the Python package's `scene.set`.

use toml::Value;
use wetcloth_scene::{Scene, SceneError, parse_value};

#[test]
fn a_set_key_changes_the_configuration_and_reads_back() {
    let mut scene = Scene::thesis_demo();
    scene.set("cloth.mass", parse_value("0.05")).unwrap();
    scene.set("air.trapped_air", parse_value("1e-4")).unwrap();
    scene.set("cloth.size", parse_value("[0.2,0.2]")).unwrap();
    scene.set("air.model", parse_value("pockets")).unwrap();
    assert_eq!(scene.config.cloth.mass, 0.05);
    assert_eq!(scene.config.air.trapped_air, 1e-4);
    assert_eq!(scene.config.cloth.size, [0.2, 0.2]);
    assert_eq!(
        scene.get("air.model").unwrap(),
        Some(Value::String("pockets".into()))
    );
    assert_eq!(scene.get("cloth.mass").unwrap(), Some(Value::Float(0.05)));
    // The rest is untouched.
    let demo = Scene::thesis_demo();
    assert_eq!(scene.config.cloth.resolution, demo.config.cloth.resolution);
    assert_eq!(scene.config.grabs, demo.config.grabs);
    // And it is the scene the file would give.
    let again = wetcloth_scene::parse(&scene.to_toml(), "x.toml".as_ref()).unwrap();
    assert_eq!(again.config, scene.config);
}

#[test]
fn both_index_spellings_reach_the_same_item() {
    let mut scene = Scene::thesis_demo();
    scene
        .set("collider.0.friction", Value::Float(0.25))
        .unwrap();
    assert_eq!(scene.config.colliders[0].friction, 0.25);
    scene
        .set("collider[0].friction", Value::Float(0.5))
        .unwrap();
    assert_eq!(
        scene.get("collider.0.friction").unwrap(),
        Some(Value::Float(0.5))
    );
    scene.set("cloth.size.1", Value::Float(0.25)).unwrap();
    assert_eq!(scene.config.cloth.size, [0.3, 0.25]);
    // A second grab, appended one past the end; a grab needs its particles first.
    let keys =
        "[{ time = 0.0, offset = [0.0, 0.0, 0.0] }, { time = 0.1, offset = [0.0, 0.01, 0.0] }]";
    let err = scene.set("grab.1.keys", parse_value(keys)).unwrap_err();
    assert!(
        err.to_string()
            .starts_with("set grab[1].keys: grab[1] = [[grab]]: a grab takes exactly one of"),
        "{err}"
    );
    scene
        .set(
            "grab.1",
            parse_value(&format!("{{ particle = [3, 4], keys = {keys} }}")),
        )
        .unwrap();
    assert_eq!(scene.config.grabs.len(), 2);
    assert_eq!(scene.config.grabs[1].particle, [3, 4]);
    scene
        .set("grab.1.keys.1.offset", parse_value("[0.0, 0.02, 0.0]"))
        .unwrap();
    assert_eq!(scene.config.grabs[1].keys[1].offset.y, 0.02);
    assert_eq!(scene.get("grab.5.particle").unwrap(), None);
}

#[test]
fn an_unknown_key_is_refused_with_the_closest_one() {
    let mut scene = Scene::thesis_demo();
    let err = scene.set("cloth.masss", Value::Float(1.0)).unwrap_err();
    assert!(matches!(err, SceneError::UnknownKey { .. }));
    assert_eq!(err.key(), Some("cloth.masss"));
    let text = err.to_string();
    assert!(
        text.starts_with("set cloth.masss: unknown key `cloth.masss`; did you mean `mass`?"),
        "{text}"
    );
    assert!(text.contains("valid keys here: size, resolution"), "{text}");
    let err = scene.get("collider.0.frction").unwrap_err();
    assert_eq!(err.key(), Some("collider[0].frction"));
    assert!(err.to_string().contains("did you mean `friction`?"));
    let err = scene.set("cloth.mass.x", Value::Float(1.0)).unwrap_err();
    assert!(
        err.to_string().contains("`cloth.mass` holds a value"),
        "{err}"
    );
    assert_eq!(scene.config, Scene::thesis_demo().config);
}

#[test]
fn a_bad_value_gets_the_file_message_and_leaves_the_scene_alone() {
    let mut scene = Scene::thesis_demo();
    let err = scene.set("cloth.mass", parse_value("-1")).unwrap_err();
    assert_eq!(
        err.to_string(),
        "set cloth.mass: cloth.mass = -1 is out of range: allowed (0, 1e3]"
            .replace("(0, 1e3]", &range_of(&err))
    );
    assert_eq!((err.key(), err.value()), (Some("cloth.mass"), Some("-1")));
    let err = scene.set("cloth.mass", parse_value("heavy")).unwrap_err();
    assert!(matches!(err, SceneError::WrongType { .. }), "{err}");
    assert!(
        err.to_string()
            .starts_with("set cloth.mass: cloth.mass = \"heavy\" has the wrong type"),
        "{err}"
    );
    let err = scene
        .set("grab.3.particle", parse_value("[1, 1]"))
        .unwrap_err();
    assert!(
        err.to_string()
            .contains("past the end: the array has 1 item(s)"),
        "{err}"
    );
    assert_eq!(scene.config, Scene::thesis_demo().config);
}

/// The allowed range the message names (the core owns the figures).
fn range_of(err: &SceneError) -> String {
    match err {
        SceneError::OutOfRange { range, .. } => range.clone(),
        e => panic!("not out of range: {e}"),
    }
}

#[test]
fn values_are_read_as_toml_and_bare_words_as_strings() {
    assert_eq!(parse_value("0.05"), Value::Float(0.05));
    assert_eq!(parse_value("3"), Value::Integer(3));
    assert_eq!(parse_value("true"), Value::Boolean(true));
    assert_eq!(parse_value("pockets"), Value::String("pockets".into()));
    assert_eq!(parse_value("\"a b\""), Value::String("a b".into()));
    assert_eq!(
        parse_value("[0.2,0.2]"),
        Value::Array(vec![Value::Float(0.2), Value::Float(0.2)])
    );
}
