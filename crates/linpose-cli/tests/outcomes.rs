//! Every image answered: `predict` and `eval` estimate every usable image, name each unusable
//! one with its reason (an all-black image, a truncated file, an image of the wrong size), and
//! exit with status 3; `--strict` stops at the first with status 1.

mod util;

use serde_json::Value;
use util::Dir;

/// The duck every 30 degrees at 48 x 36, an eigenspace on all of it, and three bad images.
fn setup(d: &Dir) {
    d.ok(&["synth", "--object", "duck", "--azimuth", "0:330:30", "--elevation", "40", "--size", "48x36", "--out", "duck"]);
    d.ok(&["train", "--data", "duck", "--method", "eigenspace", "--no-normalize", "--out", "m.st"]);
    image::GrayImage::new(48, 36).save(d.path("black.png")).unwrap();
    image::GrayImage::from_pixel(50, 36, image::Luma([90])).save(d.path("wide.png")).unwrap();
    let whole = std::fs::read(d.path("duck/e040.0_a030.0.png")).unwrap();
    std::fs::write(d.path("cut.png"), &whole[..whole.len() / 2]).unwrap();
}

fn lines(out: &[u8]) -> Vec<Value> {
    String::from_utf8_lossy(out).lines().map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}"))).collect()
}

#[test]
fn predict_estimates_every_good_image_and_names_each_bad_one() {
    let d = Dir::new();
    setup(&d);
    let good = ["duck/e040.0_a000.0.png", "duck/e040.0_a030.0.png", "duck/e040.0_a060.0.png"];
    let alone = lines(&d.run(&["predict", "--model", "m.st", "--json", good[0], good[1], good[2]]).stdout);
    let args = ["predict", "--model", "m.st", "--json", good[0], "black.png", good[1], "cut.png", "wide.png", good[2]];
    let out = d.run(&args);
    assert_eq!(out.status.code(), Some(3), "{}", String::from_utf8_lossy(&out.stderr));
    let all = lines(&out.stdout);
    // Every image answered, in the order given; the good ones with the numbers they have alone.
    let names: Vec<&str> = all.iter().map(|v| v["image"].as_str().unwrap()).collect();
    assert_eq!(names, ["duck/e040.0_a000.0.png", "black.png", "duck/e040.0_a030.0.png", "cut.png", "wide.png", "duck/e040.0_a060.0.png"]);
    let estimated: Vec<&Value> = all.iter().filter(|v| v.get("refused").is_none()).collect();
    assert_eq!(estimated, alone.iter().collect::<Vec<_>>());
    let why = |name: &str| all.iter().find(|v| v["image"] == name).unwrap()["refused"].as_str().unwrap().to_string();
    assert!(why("black.png").contains("all black"), "{}", why("black.png"));
    assert!(why("cut.png").contains("decode"), "{}", why("cut.png"));
    assert!(why("wide.png").contains("50x36") && why("wide.png").contains("48x36"), "{}", why("wide.png"));
    // On the terminal: each refused image on its own line on stderr, named, never a batch index.
    let stderr = String::from_utf8_lossy(&out.stderr);
    for bad in ["black.png", "cut.png", "wide.png"] {
        assert!(stderr.lines().any(|l| l.starts_with(&format!("linpose: {bad}: refused: "))), "{stderr}");
    }
    assert!(stderr.contains("3 of 6 images have no estimate") && !stderr.contains("batch"), "{stderr}");
    // --strict: the first bad image ends the run, named, with status 1.
    let out = d.run(&["predict", "--model", "m.st", "--strict", good[0], "black.png", good[1]]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("black.png: the image is all black"), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn eval_counts_bad_views_apart_and_reports_the_rest() {
    let d = Dir::new();
    setup(&d);
    let clean = d.ok(&["eval", "--model", "m.st", "--data", "duck", "--json", "clean.json"]);
    assert!(clean.contains("12 samples evaluated"), "{clean}");
    // Views of the data set replaced by a black frame, a truncated file and one of another size.
    let bad = ["e040.0_a090.0.png", "e040.0_a180.0.png", "e040.0_a270.0.png"];
    std::fs::copy(d.path("black.png"), d.path(&format!("duck/{}", bad[0]))).unwrap();
    std::fs::copy(d.path("cut.png"), d.path(&format!("duck/{}", bad[1]))).unwrap();
    std::fs::copy(d.path("wide.png"), d.path(&format!("duck/{}", bad[2]))).unwrap();
    let out = d.run(&["eval", "--model", "m.st", "--data", "duck", "--json", "e.json"]);
    assert_eq!(out.status.code(), Some(3), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("9 samples evaluated") && text.contains("e040.0_a090.0.png: the image is all black"), "{text}");
    let e: Value = serde_json::from_str(&std::fs::read_to_string(d.path("e.json")).unwrap()).unwrap();
    let mut named: Vec<&str> = e["rejected"].as_array().unwrap().iter().map(|r| r["image"].as_str().unwrap()).collect();
    named.sort();
    assert_eq!(named, bad);
    let c: Value = serde_json::from_str(&std::fs::read_to_string(d.path("clean.json")).unwrap()).unwrap();
    // The other views' estimates are the ones they have without the bad ones.
    let others: Vec<&Value> = c["samples"].as_array().unwrap().iter().filter(|s| !bad.contains(&s["image"].as_str().unwrap())).collect();
    assert_eq!(e["samples"].as_array().unwrap().iter().collect::<Vec<_>>(), others);
}

/// `predict --top K` with a many-object model: the K best (object, pose) hypotheses, best first,
/// each with its object, pose and score; the view's own object and pose come first.
#[test]
fn top_ranks_object_and_pose_hypotheses_of_a_many_object_model() {
    let d = Dir::new();
    for o in ["duck", "cap"] {
        d.ok(&["synth", "--object", o, "--azimuth", "0:350:10", "--elevation", "40", "--size", "32x24", "--out", &format!("objs/{o}")]);
    }
    d.ok(&["train", "--data", "objs", "--method", "eigenspace", "--train-step", "20", "--no-normalize", "--out", "m.st"]);
    for (o, view, azimuth) in [("duck", "objs/duck/e040.0_a010.0.png", 10.0), ("cap", "objs/cap/e040.0_a130.0.png", 130.0)] {
        let out = d.ok(&["predict", "--model", "m.st", "--top", "3", "--json", view]);
        let v: Value = serde_json::from_str(out.trim()).unwrap();
        let h = v["hypotheses"].as_array().unwrap();
        assert!(!h.is_empty() && h.len() <= 3, "{out}");
        assert_eq!(h[0]["object"], o, "{out}");
        assert!((h[0]["pose"]["azimuth"].as_f64().unwrap() - azimuth).abs() <= 3.0, "{out}");
        let scores: Vec<f64> = h.iter().map(|x| x["score"].as_f64().unwrap()).collect();
        assert!(scores.windows(2).all(|w| w[0] >= w[1]) && scores.iter().all(|s| (0.0..=1.0).contains(s)), "{out}");
    }
    // Text: every hypothesis after the estimate, numbered.
    let text = d.ok(&["predict", "--model", "m.st", "--top", "2", "objs/duck/e040.0_a010.0.png"]);
    assert!(text.contains("\t#1: object=duck ") && text.contains("\t#2: object="), "{text}");
}

/// `eval` of a many-object model: a black view and a truncated file among the objects' views are
/// counted apart with why; every other view is evaluated; exit status 3.
#[test]
fn eval_of_many_objects_counts_bad_views_apart() {
    let d = Dir::new();
    for o in ["duck", "cap"] {
        d.ok(&["synth", "--object", o, "--azimuth", "0:330:30", "--elevation", "40", "--size", "32x24", "--out", &format!("objs/{o}")]);
    }
    d.ok(&["train", "--data", "objs", "--method", "eigenspace", "--no-normalize", "--out", "m.st"]);
    image::GrayImage::new(32, 24).save(d.path("objs/duck/e040.0_a090.0.png")).unwrap();
    let whole = std::fs::read(d.path("objs/cap/e040.0_a030.0.png")).unwrap();
    std::fs::write(d.path("objs/cap/e040.0_a060.0.png"), &whole[..whole.len() / 2]).unwrap();
    let out = d.run(&["eval", "--model", "m.st", "--data", "objs", "--json", "e.json"]);
    assert_eq!(out.status.code(), Some(3), "{}", String::from_utf8_lossy(&out.stderr));
    let e: Value = serde_json::from_str(&std::fs::read_to_string(d.path("e.json")).unwrap()).unwrap();
    let mut named: Vec<String> =
        e["rejected"].as_array().unwrap().iter().map(|r| format!("{}/{}", r["object"].as_str().unwrap(), r["image"].as_str().unwrap())).collect();
    named.sort();
    assert_eq!(named, ["cap/e040.0_a060.0.png", "duck/e040.0_a090.0.png"]);
    assert_eq!(e["samples"].as_array().unwrap().len(), 22);
}
