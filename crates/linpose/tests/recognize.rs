//! Recognition then pose on rendered objects: the built-in objects on a turntable, every object
//! known or some left out of training to be reported unknown (by each recogniser, with the second
//! stage in each object's own eigenspace); the model file round trip, a file written before the
//! second stage included; bad sets of objects refused with clear errors.

use linpose::image_io::{ColorMode, ImageSpec};
use linpose::recognize::{ObjectModel, RecognizerKind, RecognizerParams, Unknown};
use linpose::render::synth::{dataset, PoseGrid};
use linpose::render::{objects, Grid, RenderParams};
use linpose::{model_file, Dataset, EigenspaceParams, LinearParams, MethodSpec, ObjectSet, Param, PoseModel, PoseSpace, TrainSelection};
use std::path::Path;
use std::sync::OnceLock;

/// Every built-in object every 5 degrees of azimuth at 64 x 48 (all views, training views).
fn builtins() -> &'static (ObjectSet, ObjectSet) {
    static DATA: OnceLock<(ObjectSet, ObjectSet)> = OnceLock::new();
    DATA.get_or_init(|| {
        let grid = PoseGrid::new(Grid::parse("elevation", "40").unwrap(), Grid::parse("azimuth", "0:355:5").unwrap()).unwrap();
        let params = RenderParams::default().width(64).height(48);
        let names: Vec<String> = objects::OBJECTS.iter().map(|o| o.0.to_string()).collect();
        let data: Vec<Dataset> = names.iter().map(|n| dataset(&objects::builtin(n).unwrap(), &grid, &params, Path::new(n), &|_| {}).unwrap()).collect();
        let all = ObjectSet::new(names, data).unwrap();
        let masks: Vec<Vec<bool>> = all.objects().iter().map(|d| d.manifest().training_mask(&TrainSelection::Step(10.0)).unwrap()).collect();
        let train = all.subset(&masks).unwrap();
        (all, train)
    })
}

/// Each object's rows of `set` recognised as (seen views right, unseen views right, unseen
/// views reported unknown, unseen views), every object's counts summed.
fn rates(model: &ObjectModel, set: &ObjectSet, known: &[String]) -> (usize, usize, usize, usize, usize) {
    let (mut seen_ok, mut seen, mut unseen_ok, mut unknown, mut unseen) = (0, 0, 0, 0, 0);
    for (name, d) in set.names().iter().zip(set.objects()) {
        let rec = model.recognize(d.features()).unwrap();
        let truth = known.iter().position(|n| n == name);
        for (i, r) in rec.iter().enumerate() {
            let is_seen = d.pose(i)[1] % 10.0 == 0.0;
            let right = truth.is_some() && r.object == truth;
            if is_seen {
                (seen, seen_ok) = (seen + 1, seen_ok + right as usize);
            } else {
                (unseen, unseen_ok, unknown) = (unseen + 1, unseen_ok + right as usize, unknown + r.object.is_none() as usize);
            }
        }
    }
    (seen_ok, seen, unseen_ok, unknown, unseen)
}

fn eigenspace() -> MethodSpec {
    EigenspaceParams::default().components(12).into()
}

#[test]
fn every_recogniser_tells_the_builtin_objects_apart_and_reproduces_its_training_views() {
    let (all, train) = builtins();
    for kind in RecognizerKind::ALL {
        let model = ObjectModel::fit(train, &RecognizerParams::new(kind).unknown(Unknown::Off), &eigenspace()).unwrap();
        // Identity: a training view is a knot of its object's manifold (universal) or has its
        // one-hot target as outputs (linear): distance 0 up to f32 serving.
        for d in train.objects() {
            for r in model.recognize(d.features()).unwrap() {
                assert!(r.distance < 2e-3, "{kind:?}: training view at distance {}", r.distance);
            }
        }
        // The recognition (for the universal eigenspace, a search pruned by bounding spheres) is
        // that of the distances to every object.
        for d in all.objects() {
            let k = all.len();
            let full = model.distances(d.features()).unwrap();
            for (r, dist) in model.recognize(d.features()).unwrap().iter().zip(full.chunks_exact(k)) {
                let mut sorted = dist.to_vec();
                sorted.sort_by(f64::total_cmp);
                assert_eq!((r.distance, r.second), (sorted[0], sorted[1]), "{kind:?}");
                assert_eq!(dist[r.nearest], sorted[0]);
            }
        }
        let (seen_ok, seen, unseen_ok, unknown, unseen) = rates(&model, all, all.names());
        assert_eq!((seen_ok, unknown), (seen, 0), "{kind:?}");
        assert!(unseen_ok as f64 >= 0.97 * unseen as f64, "{kind:?}: {unseen_ok} of {unseen} unseen views recognised");
    }
}

#[test]
fn recognised_views_get_their_objects_pose_and_the_model_file_keeps_everything() {
    let (all, train) = builtins();
    let model = ObjectModel::fit(train, &RecognizerParams::default(), &eigenspace()).unwrap();
    let queries: Vec<f32> = all.objects().iter().flat_map(|d| d.features()[..8 * d.n_features()].iter().copied()).collect();
    let est = model.estimate(&queries, 2).unwrap();
    for (q, e) in est.iter().enumerate() {
        let (k, i) = (q / 8, q % 8);
        assert_eq!(e.recognition.object, Some(k), "object {k} view {i}");
        // The pose is the object's own model's estimate (the twin's front and back may swap, and
        // the column's stripes repeat: their poses are not checked here).
        let own = model.pose_model(k).predict(all.object(k).row(i)).unwrap();
        assert_eq!(e.pose.as_ref().map(|p| &p.pose), Some(&own), "object {k} view {i}");
        let err = all.space().error_deg(all.object(k).pose(i), &own);
        assert!(err < 3.0 || ["twin", "column"].contains(&all.names()[k].as_str()), "object {k} view {i}: pose error {err}");
    }
    let path = std::env::temp_dir().join(format!("linpose-recognize-{}.safetensors", std::process::id()));
    model_file::save_objects(&model, &path).unwrap();
    assert!(model_file::holds_objects(&path).unwrap());
    let back = model_file::load_objects(&path).unwrap();
    let e = model_file::load(&path).unwrap_err().to_string();
    std::fs::remove_file(&path).ok();
    assert!(e.contains("several objects"), "{e}");
    assert_eq!(back.names(), model.names());
    assert_eq!(back.settings(), model.settings());
    assert_eq!(back.model_bytes(), model.model_bytes());
    assert_eq!(back.estimate(&queries, 2).unwrap(), est);
    // The second stage's thresholds come back as calibrated (the largest held-out distance), and
    // every recognised view was measured against them.
    let own = back.settings().own.as_ref().expect("a second stage");
    assert_eq!(own.thresholds, own.held_out_max);
    assert!(own.thresholds.iter().zip(&own.held_out_median).all(|(t, m)| t.is_finite() && m <= t), "{own:?}");
    assert!(est.iter().all(|e| e.recognition.own_distance.is_some_and(|d| d <= e.recognition.own_threshold)));
}

#[test]
fn a_model_file_written_before_the_second_stage_recognises_with_the_first_alone() {
    let (all, train) = builtins();
    let model = ObjectModel::fit(train, &RecognizerParams::default(), &eigenspace()).unwrap();
    // The file as an older linpose wrote it: no `own` in the settings (its arrays, unread, may
    // stay).
    let bytes = model_file::objects_to_bytes(&model).unwrap();
    let n = u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize;
    let mut header: serde_json::Value = serde_json::from_slice(&bytes[8..8 + n]).unwrap();
    let meta = header["__metadata__"]["linpose.objects"].as_str().unwrap();
    let mut objects: serde_json::Value = serde_json::from_str(meta).unwrap();
    assert!(objects["settings"].as_object_mut().unwrap().remove("own").is_some());
    header["__metadata__"]["linpose.objects"] = serde_json::Value::String(objects.to_string());
    let mut text = header.to_string().into_bytes();
    text.resize(text.len().div_ceil(8) * 8, b' ');
    let old = [(text.len() as u64).to_le_bytes().as_slice(), &text, &bytes[8 + n..]].concat();
    let back = model_file::objects_from_bytes(Path::new("old.safetensors"), &old).unwrap();
    assert!(back.settings().own.is_none());
    assert!(back.model_bytes() < model.model_bytes());
    let first_only = model.clone().with_unknown(Unknown::Threshold(f64::MAX)).unwrap();
    for d in all.objects() {
        let (a, b) = (back.recognize(d.features()).unwrap(), model.recognize(d.features()).unwrap());
        let f = first_only.recognize(d.features()).unwrap();
        for ((a, b), f) in a.iter().zip(&b).zip(&f) {
            // The same first stage, no second.
            assert_eq!((a.nearest, a.distance, a.threshold), (b.nearest, b.distance, b.threshold));
            assert_eq!(a.own_distance, None);
            assert_eq!(a.object, if a.distance <= a.threshold { Some(a.nearest) } else { None });
            assert_eq!(f.own_distance, None);
        }
    }
}

#[test]
fn every_recogniser_with_its_second_stage_reports_each_object_left_out_unknown() {
    let (all, train) = builtins();
    for kind in RecognizerKind::ALL {
        let (mut rejected, mut left, mut false_rejected, mut unseen, mut by_second, mut by_nearer) = (0, 0, 0, 0, 0, 0);
        for out in all.names() {
            let known: Vec<String> = all.names().iter().filter(|n| *n != out).cloned().collect();
            let model = ObjectModel::fit(&train.select(&known).unwrap(), &RecognizerParams::new(kind), &eigenspace()).unwrap();
            let (_, _, _, f, u) = rates(&model, &all.select(&known).unwrap(), &known);
            (false_rejected, unseen) = (false_rejected + f, unseen + u);
            let rec = model.recognize(all.object(all.names().iter().position(|n| n == out).unwrap()).features()).unwrap();
            rejected += rec.iter().filter(|r| r.object.is_none()).count();
            by_second += rec.iter().filter(|r| r.object.is_none() && r.own_distance.is_some()).count();
            by_nearer += rec.iter().filter(|r| r.object.is_none() && r.own_nearer.is_some()).count();
            // Another object's own manifold nearer only ever rejects a query its own threshold
            // let through, and names an object other than the nearest.
            assert!(rec
                .iter()
                .filter_map(|r| r.own_nearer.map(|j| (j, r)))
                .all(|(j, r)| j != r.nearest && r.object.is_none() && r.own_distance.is_some_and(|d| d <= r.own_threshold)));
            left += rec.len();
        }
        println!(
            "{}: {rejected} of {left} views of the object left out reported unknown ({by_second} by the second stage, {by_nearer} of them nearer another object's own manifold); {false_rejected} of {unseen} unseen views of the known objects",
            kind.name()
        );
        assert!(rejected as f64 >= 0.95 * left as f64, "{kind:?}: {rejected} of {left} views of objects left out reported unknown");
        assert!(false_rejected as f64 <= 0.02 * unseen as f64, "{kind:?}: {false_rejected} of {unseen} unseen views of known objects reported unknown");
    }
}

#[test]
fn objects_left_out_of_training_are_reported_unknown() {
    let (all, train) = builtins();
    let known: Vec<String> = ["duck", "pot", "cap"].map(String::from).to_vec();
    let model = ObjectModel::fit(&train.select(&known).unwrap(), &RecognizerParams::default(), &eigenspace()).unwrap();
    let (_, _, _, false_rejected, unseen) = rates(&model, &all.select(&known).unwrap(), &known);
    let left_out: Vec<String> = ["twin", "column"].map(String::from).to_vec();
    let rec: Vec<_> = all.select(&left_out).unwrap().objects().iter().flat_map(|d| model.recognize(d.features()).unwrap()).collect();
    let rejected = rec.iter().filter(|r| r.object.is_none()).count();
    assert!(rejected as f64 >= 0.95 * rec.len() as f64, "{rejected} of {} views of objects left out reported unknown", rec.len());
    assert!(false_rejected as f64 <= 0.02 * unseen as f64, "{false_rejected} of {unseen} unseen views of known objects reported unknown");
    // Switched off, nothing is unknown.
    let off = model.clone().with_unknown(Unknown::Off).unwrap();
    assert!(all.objects().iter().all(|d| off.recognize(d.features()).unwrap().iter().all(|r| r.object.is_some())));
}

#[test]
fn sets_of_objects_that_cannot_share_a_model_are_refused_by_name() {
    let space = PoseSpace::new(vec![Param::circular("azimuth", 360.0)]).unwrap();
    let poses: Vec<f64> = (0..4).map(|k| 90.0 * k as f64).collect();
    let data = |w: u32, space: &PoseSpace| {
        let spec = ImageSpec { width: w, height: 2, color: ColorMode::Gray };
        Dataset::new(spec, (0..4 * 2 * w as usize).map(|i| (i % 7) as f32 / 7.0).collect(), space.clone(), poses.clone()).unwrap()
    };
    let e = ObjectSet::new(vec!["a".into(), "b".into()], vec![data(4, &space), data(3, &space)]).unwrap_err().to_string();
    assert!(e.contains("'b'") && e.contains("size"), "{e}");
    let other = PoseSpace::new(vec![Param::linear("azimuth")]).unwrap();
    let e = ObjectSet::new(vec!["a".into(), "b".into()], vec![data(4, &space), data(4, &other)]).unwrap_err().to_string();
    assert!(e.contains("'b'"), "{e}");
    let e = ObjectSet::new(vec!["a".into(), "a".into()], vec![data(4, &space), data(4, &space)]).unwrap_err().to_string();
    assert!(e.contains("'a'"), "{e}");
}

#[test]
fn an_object_of_a_single_training_view_is_recognised_without_a_second_stage() {
    // The duck trained on one view, the pot and the cap every 10 degrees (a linear pose model:
    // the twin's identical front and back would make its system singular).
    let all = builtins().0.select(&["duck", "pot", "cap"].map(String::from)).unwrap();
    let masks: Vec<Vec<bool>> =
        all.objects().iter().enumerate().map(|(k, d)| (0..d.len()).map(|i| if k == 0 { i == 0 } else { d.pose(i)[1] % 10.0 == 0.0 }).collect()).collect();
    let train = all.subset(&masks).unwrap();
    let linear: MethodSpec = LinearParams::default().into();
    for kind in RecognizerKind::ALL {
        let model = ObjectModel::fit(&train, &RecognizerParams::new(kind), &linear).unwrap();
        let own = model.settings().own.as_ref().unwrap();
        assert_eq!(own.components[0], 0, "{kind:?}");
        assert_eq!(own.thresholds[0], f64::INFINITY, "{kind:?}");
        assert!(own.thresholds[1..].iter().all(|t| t.is_finite()), "{kind:?}: {own:?}");
        // Its training view is recognised, unmeasured by a second stage; the file keeps that.
        let r = &model.recognize(all.object(0).row(0)).unwrap()[0];
        assert_eq!((r.object, r.own_distance), (Some(0), None), "{kind:?}");
        let back = model_file::objects_from_bytes(Path::new("m"), &model_file::objects_to_bytes(&model).unwrap()).unwrap();
        assert_eq!(back.settings(), model.settings());
        assert_eq!(back.recognize(all.object(0).features()).unwrap(), model.recognize(all.object(0).features()).unwrap());
    }
}
