//! `linpose train`, `eval` and `predict` on data sets of many objects: which object, then its
//! pose, and "none of these". The objects are rendered on the spot by `linpose synth` (36 views
//! of 48x36, azimuth every 10 degrees at elevation 40), each into `set/objects/<name>` (a folder
//! of object folders); `set/poses.csv` lists the same images with an `object` column.

mod util;

use serde_json::Value;
use std::collections::BTreeMap;
use util::Dir;

/// The objects of the known-object tests: the twin is left out of them, as its front and back
/// look the same but for a small mark (see `leaving_an_object_out_reports_its_views_unknown`).
const FOUR: &[&str] = &["cap", "column", "duck", "pot"];
/// The objects whose pose the eigenspace method finds from training views 20 degrees apart
/// (the column's stripes repeat around it, so its pose is ambiguous at this size).
const POSED: &[&str] = &["cap", "duck", "pot"];
const SIZE: &str = "48x36";
const FEATURES: u64 = 48 * 36;
/// Views per object, and training views per object under `--train-step 20`.
const VIEWS: usize = 36;
const TRAIN_VIEWS: usize = 18;

/// Renders `object` into `out` (relative to the test folder).
fn synth(d: &Dir, object: &str, out: &str, azimuth: &str, elevation: &str, size: &str) {
    d.ok(&["synth", "--object", object, "--azimuth", azimuth, "--elevation", elevation, "--size", size, "--out", out]);
}

/// Renders `objects` into `set/objects/<name>`, the usual grid and size.
fn render(d: &Dir, objects: &[&str]) {
    for o in objects {
        synth(d, o, &format!("set/objects/{o}"), "0:355:10", "40", SIZE);
    }
}

/// Writes `set/poses.csv` with an object column (and `set/dataset.toml`) listing the images of
/// every object folder under `set/objects`, objects in name order.
fn write_table(d: &Dir) {
    let mut names: Vec<String> = std::fs::read_dir(d.path("set/objects")).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
    names.sort();
    let mut csv = String::from("image,object,elevation,azimuth\n");
    for o in &names {
        let own = std::fs::read_to_string(d.path(&format!("set/objects/{o}/poses.csv"))).unwrap();
        let mut lines = own.lines();
        assert_eq!(lines.next(), Some("image,elevation,azimuth"));
        for l in lines.filter(|l| !l.is_empty()) {
            let (img, pose) = l.split_once(',').unwrap();
            csv.push_str(&format!("objects/{o}/{img},{o},{pose}\n"));
        }
    }
    std::fs::write(d.path("set/poses.csv"), csv).unwrap();
    std::fs::copy(d.path(&format!("set/objects/{}/dataset.toml", names[0])), d.path("set/dataset.toml")).unwrap();
}

fn json(d: &Dir, rel: &str) -> Value {
    serde_json::from_str(&std::fs::read_to_string(d.path(rel)).unwrap()).unwrap()
}

/// Trains `linpose train --data DATA --train-step 20 --method eigenspace EXTRA...` into `model`
/// and returns the training summary.
fn train(d: &Dir, data: &str, model: &str, extra: &[&str]) -> Value {
    let summary = format!("{model}.train.json");
    let mut args = vec!["train", "--data", data, "--train-step", "20", "--method", "eigenspace", "--out", model, "--json", &summary];
    args.extend(extra);
    d.ok(&args);
    json(d, &summary)
}

/// Evaluates `model` on `data` (with `extra` options); returns the text report and the JSON.
fn eval(d: &Dir, model: &str, data: &str, extra: &[&str]) -> (String, Value) {
    let report = format!("{model}.{}.eval.json", extra.join("_"));
    let mut args = vec!["eval", "--model", model, "--data", data, "--json", &report];
    args.extend(extra);
    let text = d.ok(&args);
    (text, json(d, &report))
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

fn samples(e: &Value) -> &Vec<Value> {
    e["samples"].as_array().unwrap()
}

/// Every sample has the documented fields.
fn check_sample_fields(e: &Value) {
    for s in samples(e) {
        for key in ["object", "image", "known", "seen", "recognized", "nearest", "distance", "confidence", "pose", "error_deg"] {
            assert!(s.get(key).is_some(), "sample lacks '{key}': {s}");
        }
        assert!(s["object"].is_string() && s["image"].is_string() && s["nearest"].is_string(), "{s}");
        assert!(f(&s["distance"]) >= 0.0, "{s}");
        assert!((0.0..=1.0).contains(&f(&s["confidence"])), "{s}");
        // An unknown verdict has no pose; a recognised one has the pose and its error.
        assert_eq!(s["recognized"].is_null(), s["pose"].is_null(), "{s}");
        assert_eq!(s["recognized"].is_null(), s["error_deg"].is_null(), "{s}");
    }
}

/// The views of known objects: every training view is recognised as its own object, with its
/// exact pose; unseen views of the objects in `POSED` are recognised within `max_err` degrees.
fn check_known_views(e: &Value, names: &[&str], max_err: f64) {
    let known: Vec<&Value> = samples(e).iter().filter(|s| s["known"] == true).collect();
    assert_eq!(known.len(), names.len() * VIEWS);
    for name in names {
        let own: Vec<&Value> = known.iter().copied().filter(|s| s["object"] == *name).collect();
        assert_eq!(own.len(), VIEWS, "{name}");
        let seen: Vec<&Value> = own.iter().copied().filter(|s| s["seen"] == true).collect();
        assert_eq!(seen.len(), TRAIN_VIEWS, "{name}");
        for s in seen {
            assert_eq!(s["recognized"], *name, "{s}");
            assert_eq!(s["nearest"], *name, "{s}");
            assert!(f(&s["error_deg"]) < 1e-6, "{s}");
            assert_eq!(f(&s["pose"][0]), 40.0, "{s}");
        }
        if POSED.contains(name) {
            for s in own.iter().filter(|s| s["seen"] == false && s["recognized"] == *name) {
                assert!(f(&s["error_deg"]) < max_err, "{s}");
            }
        }
    }
}

#[test]
fn universal_recogniser_tells_four_objects_and_their_poses() {
    let d = Dir::new();
    render(&d, FOUR);
    let t = train(&d, "set/objects", "u.safetensors", &[]);
    assert_eq!(t["recognizer"], "universal");
    assert_eq!(t["method"], "eigenspace");
    assert_eq!(t["objects"], serde_json::json!(FOUR));
    assert_eq!(t["n_train"], 4 * TRAIN_VIEWS);
    assert_eq!(t["n_features"], FEATURES);
    assert_eq!(t["settings"]["components"], 20);
    let thresholds = t["settings"]["thresholds"].as_array().unwrap();
    assert_eq!(thresholds.len(), 4);
    assert!(thresholds.iter().all(|v| f(v) > 0.0), "{thresholds:?}");

    let (text, e) = eval(&d, "u.safetensors", "set/objects", &[]);
    // Observed: every one of the 144 views recognised, none reported unknown.
    assert!(text.contains("recognised: 100.00% of the known objects' 144 views") && text.contains("of their 72 unseen views"), "{text}");
    assert!(text.contains("confusions: none"), "{text}");
    assert_eq!(e["recognizer"], "universal");
    assert_eq!(e["objects"], serde_json::json!(FOUR));
    assert_eq!(e["n_eval"], 4 * VIEWS);
    let r = &e["recognition"];
    assert_eq!((r["n_all"].as_u64(), r["n_unseen"].as_u64()), (Some(144), Some(72)));
    assert_eq!(f(&r["all"]), 1.0);
    assert!(f(&r["unseen"]) >= 0.9, "{r}");
    let u = &e["unknown"];
    assert_eq!((u["unknown_views"].as_u64(), u["known_unseen_views"].as_u64()), (Some(0), Some(72)));
    assert!(u["true_rejections"].is_null(), "{u}");
    assert!(f(&u["false_rejections"]) <= 0.05, "{u}");
    for name in FOUR {
        assert_eq!(e["confusion"][name], serde_json::json!({ *name: 36 }), "{}", e["confusion"]);
    }
    assert_eq!(e["confusion"].as_object().unwrap().len(), 4);
    assert_eq!(e["pose"]["all"]["n"], 144);
    assert_eq!(e["pose"]["unseen"]["n"], 72);
    check_sample_fields(&e);
    assert!(samples(&e).iter().all(|s| s["known"] == true));
    // Observed: unseen views of cap, duck and pot within 1.6 degrees (eigenspace manifold
    // interpolated between training views 20 degrees apart).
    check_known_views(&e, FOUR, 2.5);
}

#[test]
fn linear_recogniser_tells_four_objects() {
    let d = Dir::new();
    render(&d, FOUR);
    let t = train(&d, "set/objects", "l.safetensors", &["--recognizer", "linear"]);
    assert_eq!(t["recognizer"], "linear");
    // The recogniser is K weight rows of M features (f32), then the second stage: each object's
    // own eigenspace of L_k = 17 dimensions (18 training views less one) of the images binned by
    // 4 (12 x 9 values) with its mean, and its manifold every 0.5 degrees (720 points of 17
    // coordinates).
    let binned = FEATURES / 16;
    assert_eq!(t["recognizer_bytes"], 4 * (4 * FEATURES + 4 * (17 * binned + binned + 720 * 17)));
    let (text, e) = eval(&d, "l.safetensors", "set/objects", &[]);
    assert_eq!(e["recognizer"], "linear");
    assert_eq!(e["n_eval"], 4 * VIEWS);
    check_sample_fields(&e);
    check_known_views(&e, FOUR, 2.5);
    // Observed: 142 of 144 views recognised (70 of 72 unseen); the two others, pot at azimuth
    // 170 and 190, are reported unknown, and no view is taken for another object.
    let r = &e["recognition"];
    assert!(f(&r["all"]) >= 0.95 && f(&r["unseen"]) >= 0.9, "{r}\n{text}");
    assert!(f(&e["unknown"]["false_rejections"]) <= 0.1, "{}", e["unknown"]);
    for (truth, row) in e["confusion"].as_object().unwrap() {
        for (got, n) in row.as_object().unwrap() {
            assert!(got == truth || got == "unknown", "{truth} taken for {got} {n} times");
        }
        assert_eq!(row.as_object().unwrap().values().map(|n| n.as_u64().unwrap()).sum::<u64>(), 36, "{truth}");
    }
}

#[test]
fn object_column_layout_reads_the_same_objects() {
    let d = Dir::new();
    render(&d, FOUR);
    write_table(&d);
    let folders = train(&d, "set/objects", "folders.safetensors", &[]);
    let table = train(&d, "set", "table.safetensors", &[]);
    for key in ["objects", "n_train", "n_features", "model_bytes", "recognizer_bytes"] {
        assert_eq!(folders[key], table[key], "{key}");
    }
    assert_eq!(table["n_train"], 4 * TRAIN_VIEWS);
    let (_, by_folders) = eval(&d, "folders.safetensors", "set/objects", &[]);
    let (_, by_table) = eval(&d, "table.safetensors", "set", &[]);
    // The model trained on the folders reads the table's images too: the same names.
    let (_, crossed) = eval(&d, "folders.safetensors", "set", &[]);
    for e in [&by_table, &crossed] {
        for key in ["objects", "n_eval", "recognition", "unknown", "confusion"] {
            assert_eq!(e[key], by_folders[key], "{key}");
        }
        assert_eq!(samples(e).len(), samples(&by_folders).len());
        for (a, b) in samples(e).iter().zip(samples(&by_folders)) {
            // The table names images from its own folder.
            assert_eq!(a["image"].as_str().unwrap(), format!("objects/{}/{}", b["object"].as_str().unwrap(), b["image"].as_str().unwrap()));
            for key in ["object", "known", "seen", "recognized", "nearest"] {
                assert_eq!(a[key], b[key], "{key}: {a} vs {b}");
            }
            assert!((f(&a["distance"]) - f(&b["distance"])).abs() < 1e-6, "{a} vs {b}");
            assert!((f(&a["error_deg"]) - f(&b["error_deg"])).abs() < 1e-6, "{a} vs {b}");
        }
    }
    assert_eq!(f(&by_table["recognition"]["all"]), 1.0);
    // A training list names images as poses.csv does in the table layout, with the object
    // folder in a folder of object folders.
    let list: String = FOUR.iter().flat_map(|o| (0..360).step_by(40).map(move |a| format!("{o}/e040.0_a{a:03}.0.png\n"))).collect();
    std::fs::write(d.path("folders.txt"), &list).unwrap();
    let table_list: String = list.lines().map(|l| format!("objects/{l}\n")).collect();
    std::fs::write(d.path("table.txt"), table_list).unwrap();
    for (data, list) in [("set/objects", "folders.txt"), ("set", "table.txt")] {
        d.ok(&["train", "--data", data, "--train-list", list, "--method", "eigenspace", "--out", "listed.safetensors", "--json", "listed.json"]);
        assert_eq!(json(&d, "listed.json")["n_train"], 4 * 9, "{data}");
    }
}

#[test]
fn leaving_an_object_out_reports_its_views_unknown() {
    let d = Dir::new();
    render(&d, &["cap", "column", "duck", "pot", "twin"]);
    let t = train(&d, "set/objects", "m.safetensors", &["--leave-out", "twin"]);
    assert_eq!(t["objects"], serde_json::json!(FOUR));
    assert_eq!(t["n_train"], 4 * TRAIN_VIEWS);

    let (text, e) = eval(&d, "m.safetensors", "set/objects", &[]);
    assert_eq!(e["n_eval"], 5 * VIEWS);
    check_sample_fields(&e);
    // Observed: all 36 twin views reported unknown, no unseen view of a known object rejected,
    // every known view recognised.
    let u = &e["unknown"];
    assert_eq!((u["unknown_views"].as_u64(), u["known_unseen_views"].as_u64()), (Some(36), Some(72)));
    assert!(f(&u["true_rejections"]) >= 0.9, "{u}");
    assert!(f(&u["false_rejections"]) <= 0.05, "{u}");
    assert!(text.contains("of 36 views of objects the model does not know"), "{text}");
    let r = &e["recognition"];
    assert_eq!((r["n_all"].as_u64(), r["n_unseen"].as_u64()), (Some(144), Some(72)));
    assert!(f(&r["all"]) >= 0.95, "{r}");
    let twin = e["confusion"]["twin"].as_object().unwrap();
    assert!(twin["unknown"].as_u64().unwrap() >= 33, "{twin:?}");
    for s in samples(&e).iter().filter(|s| s["object"] == "twin") {
        assert_eq!((&s["known"], &s["seen"]), (&Value::Bool(false), &Value::Bool(false)), "{s}");
        assert!(FOUR.contains(&s["nearest"].as_str().unwrap()), "{s}");
    }
    check_known_views(&e, FOUR, 2.5);

    // Without the unknown rule every twin view is taken for some known object.
    let (text, off) = eval(&d, "m.safetensors", "set/objects", &["--unknown", "off"]);
    assert_eq!(f(&off["unknown"]["true_rejections"]), 0.0);
    assert_eq!(f(&off["unknown"]["false_rejections"]), 0.0);
    assert!(text.contains("reported unknown: 0.00% of 36 views"), "{text}");
    assert!(samples(&off).iter().all(|s| !s["recognized"].is_null()));
    let twin = off["confusion"]["twin"].as_object().unwrap();
    assert!(!twin.contains_key("unknown"), "{twin:?}");
    assert_eq!(twin.values().map(|n| n.as_u64().unwrap()).sum::<u64>(), 36);
    assert_eq!(f(&off["recognition"]["all"]), 1.0);
    // Nor does a threshold no view reaches reject any; one under every distance rejects all.
    let (_, high) = eval(&d, "m.safetensors", "set/objects", &["--unknown", "1e9"]);
    assert_eq!(high["confusion"], off["confusion"]);
    let (_, low) = eval(&d, "m.safetensors", "set/objects", &["--unknown", "1e-300"]);
    assert_eq!(f(&low["unknown"]["true_rejections"]), 1.0);
    assert_eq!(f(&low["unknown"]["false_rejections"]), 1.0);
}

/// Splits a `predict` text line into its image and its `key=value` fields.
fn fields(line: &str) -> (&str, BTreeMap<&str, &str>) {
    let mut parts = line.split('\t');
    let image = parts.next().unwrap();
    (image, parts.map(|p| p.split_once('=').unwrap_or_else(|| panic!("field without '=': {line}"))).collect())
}

#[test]
fn predict_names_the_object_and_its_pose_or_unknown() {
    let d = Dir::new();
    render(&d, &["cap", "column", "duck", "pot", "twin"]);
    write_table(&d);
    // Trained on the object-column layout, leaving the twin out.
    train(&d, "set", "m.safetensors", &["--leave-out", "twin"]);
    let known = [("duck", 10.0), ("duck", 130.0), ("duck", 200.0), ("pot", 250.0), ("cap", 330.0)];
    let paths: Vec<String> = known.iter().map(|(o, a)| format!("set/objects/{o}/e040.0_a{a:03}.0.png")).collect();
    let twin = "set/objects/twin/e040.0_a070.0.png";
    let mut args: Vec<&str> = vec!["predict", "--model", "m.safetensors"];
    args.extend(paths.iter().map(String::as_str));
    args.push(twin);
    let out = d.ok(&args);
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), known.len() + 1, "{out}");
    for ((line, path), (object, azimuth)) in lines.iter().zip(&paths).zip(known) {
        let (image, v) = fields(line);
        assert_eq!(image, path);
        assert_eq!(v["object"], object, "{line}");
        let confidence: f64 = v["confidence"].parse().unwrap();
        assert!(confidence > 0.5 && confidence <= 1.0, "{line}");
        let el: f64 = v["elevation"].parse().unwrap();
        let az: f64 = v["azimuth"].parse().unwrap();
        assert!((el - 40.0).abs() < 1e-3, "{line}");
        // Observed within 1.6 degrees (four of these views are unseen).
        assert!((az - azimuth).abs() < 2.5, "{line}");
    }
    let (image, v) = fields(lines[known.len()]);
    assert_eq!(image, twin);
    assert_eq!(v["object"], "unknown", "{out}");
    assert!(FOUR.contains(&v["nearest"]), "{out}");
    let (distance, threshold): (f64, f64) = (v["distance"].parse().unwrap(), v["threshold"].parse().unwrap());
    assert!(distance > threshold && threshold > 0.0, "{out}");
    assert!(!v.contains_key("azimuth") && !v.contains_key("confidence"), "{out}");

    args.insert(1, "--json");
    let out = d.ok(&args);
    let rows: Vec<Value> = out.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(rows.len(), known.len() + 1);
    for ((row, path), (object, azimuth)) in rows.iter().zip(&paths).zip(known) {
        assert_eq!(row["image"], path.as_str());
        assert_eq!(row["object"], object, "{row}");
        assert_eq!(row["nearest"], object, "{row}");
        assert!(f(&row["confidence"]) > 0.5 && f(&row["confidence"]) <= 1.0, "{row}");
        assert!((f(&row["pose"]["elevation"]) - 40.0).abs() < 1e-3, "{row}");
        assert!((f(&row["pose"]["azimuth"]) - azimuth).abs() < 2.5, "{row}");
        assert!(f(&row["distance"]) >= 0.0, "{row}");
    }
    let row = &rows[known.len()];
    assert!(row["object"].is_null() && row["pose"].is_null(), "{row}");
    assert!(FOUR.contains(&row["nearest"].as_str().unwrap()), "{row}");
    assert!((f(&row["distance"]) - distance).abs() < 1e-3, "{row}");
    assert!(row.get("confidence").is_some(), "{row}");
}

/// Runs `linpose ARGS`, which must be refused (exit code 1, no panic) with a message holding
/// every one of `words`; returns the message.
fn refused(d: &Dir, args: &[&str], words: &[&str]) -> String {
    let out = d.run(args);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "linpose {args:?}: {err}");
    assert!(!err.contains("panicked"), "linpose {args:?} panicked: {err}");
    for w in words {
        assert!(err.contains(w), "linpose {args:?}: the message lacks '{w}': {err}");
    }
    err
}

#[test]
fn an_object_without_training_views_is_named() {
    let d = Dir::new();
    render(&d, &["duck", "pot"]);
    // The step counts from each object's own smallest value of each parameter: the cap's views
    // (elevation 40, azimuth 10) and (elevation 50, azimuth 0) are off every 20-degree grid.
    synth(&d, "cap", "set/objects/cap", "0:10:10", "40:50:10", SIZE);
    std::fs::write(d.path("set/objects/cap/poses.csv"), "image,elevation,azimuth\ne040.0_a010.0.png,40,10\ne050.0_a000.0.png,50,0\n").unwrap();
    refused(
        &d,
        &["train", "--data", "set/objects", "--train-step", "20", "--method", "eigenspace", "--out", "m.safetensors"],
        &["set/objects/cap", "object 'cap' has no training views under every 20 degrees"],
    );
    // A training list naming the duck's and the pot's images only.
    std::fs::write(d.path("list.txt"), "duck/e040.0_a000.0.png\nduck/e040.0_a180.0.png\npot/e040.0_a000.0.png\npot/e040.0_a180.0.png\n").unwrap();
    refused(
        &d,
        &["train", "--data", "set/objects", "--train-list", "list.txt", "--method", "eigenspace", "--out", "m.safetensors"],
        &["object 'cap' has no training views under a list of 4 images"],
    );
    // The list names images relative to the data folder.
    std::fs::write(d.path("bare.txt"), "e040.0_a000.0.png\n").unwrap();
    refused(
        &d,
        &["train", "--data", "set/objects", "--train-list", "bare.txt", "--out", "m.safetensors"],
        &["'e040.0_a000.0.png'", "in no object of the data set", "such as 'cap/e040.0_a010.0.png'"],
    );
    // An object of one view at an odd angle has a training view under any step (its own
    // smallest azimuth), but no eigenspace of its own.
    std::fs::remove_dir_all(d.path("set/objects/cap")).unwrap();
    synth(&d, "cap", "set/objects/cap", "5", "40", SIZE);
    refused(
        &d,
        &["train", "--data", "set/objects", "--train-step", "20", "--method", "eigenspace", "--out", "m.safetensors"],
        &["set/objects/cap", "object 'cap'", "the eigenspace needs at least 2 training images, got 1"],
    );
    assert!(!d.path("m.safetensors").exists());
}

#[test]
fn objects_must_share_image_size_and_pose_parameters() {
    let d = Dir::new();
    render(&d, &["cap", "duck"]);
    synth(&d, "pot", "set/objects/pot", "0:355:10", "40", "40x30");
    refused(
        &d,
        &["train", "--data", "set/objects", "--train-step", "20", "--out", "m.safetensors"],
        &["set/objects/pot/e040.0_a000.0.png", "object 'pot' has images of 40x30 but object 'cap' has 48x36", "one size"],
    );
    // The pot again at the size of the others, without its elevation column.
    std::fs::remove_dir_all(d.path("set/objects/pot")).unwrap();
    render(&d, &["pot"]);
    let own = std::fs::read_to_string(d.path("set/objects/pot/poses.csv")).unwrap();
    let no_elevation: String = own
        .lines()
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            format!("{},{}\n", c[0], c[2])
        })
        .collect();
    assert!(no_elevation.starts_with("image,azimuth\n"));
    std::fs::write(d.path("set/objects/pot/poses.csv"), &no_elevation).unwrap();
    // Its dataset.toml still describes an elevation: that file is named first.
    refused(
        &d,
        &["train", "--data", "set/objects", "--out", "m.safetensors"],
        &["set/objects/pot/dataset.toml", "'elevation' is not a parameter of poses.csv", "azimuth"],
    );
    std::fs::write(d.path("set/objects/pot/dataset.toml"), "azimuth = { period = 360 }\n").unwrap();
    refused(
        &d,
        &["train", "--data", "set/objects", "--out", "m.safetensors"],
        &[
            "set/objects/pot",
            "object 'pot' has pose parameters (azimuth (period 360)) but object 'cap' has (elevation (linear), azimuth (period 360))",
            "the same pose parameters",
        ],
    );
    // A model of other images: eval names both sizes.
    let e = Dir::new();
    for o in ["cap", "duck"] {
        synth(&e, o, &format!("big/{o}"), "0:355:20", "40", SIZE);
        synth(&e, o, &format!("small/{o}"), "0:355:20", "40", "40x30");
    }
    e.ok(&["train", "--data", "big", "--method", "eigenspace", "--out", "m.safetensors"]);
    refused(
        &e,
        &["eval", "--model", "m.safetensors", "--data", "small"],
        &["small: images of 40x30 with parameters elevation, azimuth, but the model was trained on 48x36 with elevation, azimuth"],
    );
    refused(&e, &["predict", "--model", "m.safetensors", "small/cap/e040.0_a000.0.png"], &["e040.0_a000.0.png", "40x30", "48x36"]);
}

#[test]
fn leave_out_must_name_an_object_and_keep_one() {
    let d = Dir::new();
    render(&d, &["cap", "duck", "pot"]);
    refused(
        &d,
        &["train", "--data", "set/objects", "--leave-out", "duck,teapot", "--out", "m.safetensors"],
        &["--leave-out teapot: no such object in set/objects (it has cap, duck, pot)"],
    );
    refused(&d, &["train", "--data", "set/objects", "--leave-out", "cap,duck,pot", "--out", "m.safetensors"], &["--leave-out leaves no object to train on"]);
    // Settings of the recogniser are checked as flags.
    refused(&d, &["train", "--data", "set/objects", "--unknown=-1", "--out", "m.safetensors"], &["--unknown -1", "calibrated, off, or a positive distance"]);
    let out = d.run(&["train", "--data", "set/objects", "--recognizer", "nearest", "--out", "m.safetensors"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("universal"));
    assert!(!d.path("m.safetensors").exists());
    // The model's own objects are still evaluated with an unknown rule of the command line.
    train(&d, "set/objects", "m.safetensors", &["--leave-out", "pot"]);
    refused(&d, &["eval", "--model", "m.safetensors", "--data", "set/objects", "--unknown", "often"], &["--unknown often", "calibrated, off"]);
}

#[test]
fn many_object_options_and_models_need_many_objects() {
    let d = Dir::new();
    render(&d, &["cap", "duck", "pot"]);
    synth(&d, "duck", "duck", "0:355:10", "40", SIZE);
    // The recogniser's options with one object's data set: refused, not ignored.
    for flag in [&["--recognizer", "linear"][..], &["--recognizer-components", "5"], &["--unknown", "off"], &["--leave-out", "duck"]] {
        let mut args = vec!["train", "--data", "duck", "--out", "one.safetensors"];
        args.extend(flag);
        refused(&d, &args, &[flag[0], "are for data sets of many objects; duck holds one"]);
    }
    assert!(!d.path("one.safetensors").exists());
    // Not yet for many objects: streaming.
    refused(
        &d,
        &["train", "--data", "set/objects", "--stream", "--out", "m.safetensors"],
        &["set/objects: a data set of many objects is fitted in memory", "--stream"],
    );
    // A many-object model on one object's data set.
    train(&d, "set/objects", "m.safetensors", &[]);
    refused(
        &d,
        &["eval", "--model", "m.safetensors", "--data", "duck"],
        &["duck: the model knows 3 objects (cap, duck, pot), but this data set holds one", "a folder of object folders"],
    );
    refused(&d, &["eval", "--model", "m.safetensors", "--data", "set/objects", "--noise", "0.1"], &["--noise", "many-object model"]);
    // And a one-object model with the option of many.
    d.ok(&["train", "--data", "duck", "--out", "one.safetensors"]);
    refused(
        &d,
        &["eval", "--model", "one.safetensors", "--data", "duck", "--unknown", "off"],
        &["--unknown: one.safetensors holds one object's pose model", "many-object model"],
    );
}

#[test]
fn behind_normalisation_many_objects_take_moved_views_and_the_images_refused_are_named() {
    let d = Dir::new();
    for o in POSED {
        synth(&d, o, &format!("reg/{o}"), "0:355:10", "40", SIZE);
        d.ok(&[
            "synth",
            "--object",
            o,
            "--azimuth",
            "0:355:10",
            "--elevation",
            "40",
            "--size",
            SIZE,
            "--jitter",
            "3,0.05,0",
            "--jitter-seed",
            "4",
            "--out",
            &format!("jit/{o}"),
        ]);
    }
    let out =
        d.run(&["train", "--data", "reg", "--train-step", "20", "--method", "eigenspace", "--normalize", "geometry", "--out", "n.st", "--json", "t.json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stderr).contains("normalised: object centred and scaled"));
    assert!(json(&d, "t.json")["normalize"].as_str().unwrap().starts_with("normalised: object centred"));
    train(&d, "reg", "plain.st", &[]);
    // Moved views: behind the stage every view the stage takes is recognised (those it refuses,
    // cut by the frame edge, are listed apart); without it most are reported unknown.
    let out = d.run(&["eval", "--model", "n.st", "--data", "jit", "--json", "n.eval.json"]);
    let (text, e) = (String::from_utf8_lossy(&out.stdout).to_string(), json(&d, "n.eval.json"));
    let refused_n = e.get("rejected").map_or(0, |r| r.as_array().unwrap().len());
    // Exit status 3 when some images have no estimate.
    assert_eq!(out.status.code(), Some(if refused_n > 0 { 3 } else { 0 }), "{text}");
    assert!(refused_n <= 6, "{text}");
    assert_eq!(samples(&e).len() + refused_n, POSED.len() * VIEWS, "{text}");
    assert_eq!(f(&e["recognition"]["all"]), 1.0, "{text}");
    let (text, plain) = eval(&d, "plain.st", "jit", &[]);
    assert!(f(&plain["recognition"]["all"]) < 0.8, "{text}");
    // A black image and a view: the first refused with the reason, the second named; the exit
    // code says one failed.
    image::GrayImage::new(48, 36).save(d.path("black.png")).unwrap();
    std::fs::copy(d.path("reg/duck/e040.0_a010.0.png"), d.path("view.png")).unwrap();
    let out = d.run(&["predict", "--model", "n.st", "black.png", "view.png"]);
    assert_eq!(out.status.code(), Some(3));
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(stderr.contains("black.png: refused: cannot normalise: no object found") && stderr.contains("1 of 2 images"), "{stderr}");
    let (image, v) = fields(stdout.trim_end());
    assert_eq!((image, v["object"]), ("view.png", "duck"), "{stdout}");
}

#[test]
fn robust_many_object_models_recognise_views_in_scenes() {
    let d = Dir::new();
    render(&d, POSED);
    for o in POSED {
        d.ok(&["scene", "--data", &format!("set/objects/{o}"), "--out", &format!("scenes/{o}"), "--background", "texture", "--occlude", "0.2", "--seed", "1"]);
    }
    train(&d, "set/objects", "plain.st", &["--no-normalize"]);
    train(&d, "set/objects", "robust.st", &["--no-normalize", "--robust"]);
    let rate = |model: &str| f(&eval(&d, model, "scenes", &["--unknown", "off"]).1["recognition"]["all"]);
    let (plain, robust) = (rate("plain.st"), rate("robust.st"));
    assert!(robust >= 0.9 && robust > plain + 0.2, "recognised in scenes: plain {plain:.3}, robust {robust:.3}");
    // The studio views: the same objects named (at 48 x 36 trained every 20 degrees a few of
    // the pot's views between fail the check and are repaired, their poses moved).
    let studio = |model: &str| samples(&eval(&d, model, "set/objects", &["--unknown", "off"]).1).iter().map(|s| s["recognized"].clone()).collect::<Vec<_>>();
    assert_eq!(studio("robust.st"), studio("plain.st"));
}
