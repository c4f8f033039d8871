//! Recognition then pose on rendered objects: the built-in objects on a turntable, every object
//! known or some left out of training to be reported unknown (by each recogniser, with the second
//! stage in each object's own eigenspace); the model file round trip, a file written before the
//! second stage and the caller's labels included; bad sets of objects refused with clear errors;
//! and behind one normalisation stage, a query moved by whole pixels answered exactly as it was,
//! and a query the stage cannot normalise refused by its place, alone; and without poses, the
//! views alone.

use linpose::image_io::{ColorMode, ImageSpec};
use linpose::normalize::{NormalizeParams, Rejection};
use linpose::recognize::{Labels, ObjectModel, RecognizerParams, Unknown, RECOGNIZERS};
use linpose::render::synth::{dataset, PoseGrid};
use linpose::render::{objects, Grid, RenderParams};
use linpose::{model_file, AnyModel, Dataset, EigenspaceParams, LinearParams, MethodSpec, ObjectSet, Param, PoseModel, PoseSpace, TrainSelection};
use std::path::Path;
use std::sync::OnceLock;

/// Every built-in object every 5 degrees of azimuth at 64 x 48 (all views, training views).
fn builtins() -> &'static (ObjectSet, ObjectSet) {
    static DATA: OnceLock<(ObjectSet, ObjectSet)> = OnceLock::new();
    DATA.get_or_init(|| {
        let grid = PoseGrid::new(Grid::parse("elevation", "40").unwrap(), Grid::parse("azimuth", "0:355:5").unwrap()).unwrap();
        let params = RenderParams::default().width(64).height(48);
        // The five objects these bars were set on (the mug and the ring came later).
        let names: Vec<String> = objects::OBJECTS[..5].iter().map(|o| o.0.to_string()).collect();
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
    for &kind in RECOGNIZERS {
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
        let own = model.pose_model(k).expect("fitted with poses").predict(all.object(k).row(i)).unwrap();
        assert_eq!(e.pose.as_ref().map(|p| &p.pose), Some(&own), "object {k} view {i}");
        let err = all.space().error_deg(all.object(k).pose(i), &own);
        assert!(err < 3.0 || ["twin", "column"].contains(&all.names()[k].as_str()), "object {k} view {i}: pose error {err}");
    }
    let path = std::env::temp_dir().join(format!("linpose-recognize-{}.safetensors", std::process::id()));
    model.save(&path).unwrap();
    assert!(model_file::holds_objects(&path).unwrap());
    let back = ObjectModel::load(&path).unwrap();
    let e = AnyModel::load(&path).unwrap_err().to_string();
    std::fs::remove_file(&path).ok();
    assert!(e.contains("several objects"), "{e}");
    assert_eq!(back.names(), model.names());
    assert_eq!(back.settings(), model.settings());
    assert_eq!(back.model_bytes(), model.model_bytes());
    assert_eq!(back.estimate(&queries, 2).unwrap(), est);
    // The second stage's thresholds come back as calibrated (the largest held-out distance), and
    // every recognised view was measured against them.
    let own = &back.settings().own;
    assert_eq!(own.thresholds, own.held_out_max);
    assert!(own.thresholds.iter().zip(&own.held_out_median).all(|(t, m)| t.is_finite() && m <= t), "{own:?}");
    assert!(est.iter().all(|e| e.recognition.own_distance.is_some_and(|d| d <= e.recognition.own_threshold)));
}

/// The `linpose.objects` JSON of many-object model file bytes.
fn objects_header(bytes: &[u8]) -> serde_json::Value {
    let n = u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize;
    let h: serde_json::Value = serde_json::from_slice(&bytes[8..8 + n]).unwrap();
    serde_json::from_str(h["__metadata__"]["linpose.objects"].as_str().unwrap()).unwrap()
}

/// The file `bytes` with its `linpose.objects` JSON edited by `edit` (the header padded to 8
/// bytes as safetensors wants it), as another linpose or a damaged file would hold it.
fn with_objects_header(bytes: &[u8], edit: impl FnOnce(&mut serde_json::Value)) -> Vec<u8> {
    let n = u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize;
    let mut top: serde_json::Value = serde_json::from_slice(&bytes[8..8 + n]).unwrap();
    let mut objects = objects_header(bytes);
    edit(&mut objects);
    top["__metadata__"]["linpose.objects"] = serde_json::Value::String(objects.to_string());
    let mut text = top.to_string().into_bytes();
    text.resize(text.len().div_ceil(8) * 8, b' ');
    [(text.len() as u64).to_le_bytes().as_slice(), &text, &bytes[8 + n..]].concat()
}

#[test]
fn the_model_file_keeps_the_callers_labels_and_writes_none_without_them() {
    let (_, train) = builtins();
    let model = ObjectModel::fit(train, &RecognizerParams::default(), &eigenspace()).unwrap();
    let k = model.names().len();
    // Without labels the file says nothing of them, as before they existed.
    let plain = model.to_bytes().unwrap();
    assert!(objects_header(&plain).get("labels").is_none());
    assert!(ObjectModel::from_bytes(Path::new("m"), &plain).unwrap().labels().is_none());
    // Numbers stay numbers through the file.
    let labels = Labels { values: (0..k).map(|i| serde_json::json!(10 * i + 3)).collect(), unknown: serde_json::json!(-1), kind: "int64".into() };
    let e = model.clone().with_labels(Labels { values: labels.values[1..].to_vec(), ..labels.clone() }).unwrap_err().to_string();
    assert!(e.contains(&format!("one label per object ({k} objects)")), "{e}");
    let labelled = model.with_labels(labels.clone()).unwrap();
    let bytes = labelled.to_bytes().unwrap();
    assert_eq!(objects_header(&bytes)["labels"]["values"][1], serde_json::json!(13));
    let back = ObjectModel::from_bytes(Path::new("m"), &bytes).unwrap();
    assert_eq!(back.labels(), Some(&labels));
    assert_eq!(back.names(), labelled.names());
    // A file whose labels do not match its objects is refused as damaged.
    let bad = with_objects_header(&bytes, |o| {
        o["labels"]["values"].as_array_mut().unwrap().pop();
    });
    let e = ObjectModel::from_bytes(Path::new("m"), &bad).unwrap_err().to_string();
    assert!(e.contains(&format!("damaged object model: {} labels for {k} objects", k - 1)), "{e}");
}

#[test]
fn a_model_file_without_the_second_stage_is_damaged() {
    let (_, train) = builtins();
    let model = ObjectModel::fit(train, &RecognizerParams::default(), &eigenspace()).unwrap();
    // Every file of this format records the second stage: one without `own` is refused, named.
    let bytes = model.to_bytes().unwrap();
    let cut = with_objects_header(&bytes, |o| {
        assert!(o["settings"].as_object_mut().unwrap().remove("own").is_some());
    });
    let e = ObjectModel::from_bytes(Path::new("cut.safetensors"), &cut).unwrap_err().to_string();
    assert!(e.contains("cut.safetensors") && e.contains("own"), "{e}");
}

/// Each built-in object left out in turn, the others fitted by `fit`: the views of the object
/// left out reported unknown and all views, the known objects' unseen views reported unknown and
/// all, summed; `inspect` sees each left-out object's recognitions.
fn each_left_out(fit: impl Fn(&ObjectSet) -> ObjectModel, mut inspect: impl FnMut(&[linpose::recognize::Recognition])) -> (usize, usize, usize, usize) {
    let (all, train) = builtins();
    let (mut rejected, mut left, mut false_rejected, mut unseen) = (0, 0, 0, 0);
    for out in all.names() {
        let known: Vec<String> = all.names().iter().filter(|n| *n != out).cloned().collect();
        let model = fit(&train.select(&known).unwrap());
        let (_, _, _, f, u) = rates(&model, &all.select(&known).unwrap(), &known);
        (false_rejected, unseen) = (false_rejected + f, unseen + u);
        let rec = model.recognize(all.object(all.names().iter().position(|n| n == out).unwrap()).features()).unwrap();
        rejected += rec.iter().filter(|r| r.object.is_none()).count();
        left += rec.len();
        inspect(&rec);
    }
    (rejected, left, false_rejected, unseen)
}

#[test]
fn every_recogniser_with_its_second_stage_reports_each_object_left_out_unknown() {
    for &kind in RECOGNIZERS {
        let (mut by_second, mut by_nearer) = (0, 0);
        let fit = |known: &ObjectSet| ObjectModel::fit(known, &RecognizerParams::new(kind), &eigenspace()).unwrap();
        let (rejected, left, false_rejected, unseen) = each_left_out(fit, |rec| {
            by_second += rec.iter().filter(|r| r.object.is_none() && r.own_distance.is_some()).count();
            by_nearer += rec.iter().filter(|r| r.object.is_none() && r.own_nearer.is_some()).count();
            // Another object's own manifold nearer only ever rejects a query its own threshold
            // let through, and names an object other than the nearest.
            assert!(rec
                .iter()
                .filter_map(|r| r.own_nearer.map(|j| (j, r)))
                .all(|(j, r)| j != r.nearest && r.object.is_none() && r.own_distance.is_some_and(|d| d <= r.own_threshold)));
        });
        println!(
            "{}: {rejected} of {left} views of the object left out reported unknown ({by_second} by the second stage, {by_nearer} of them nearer another object's own manifold); {false_rejected} of {unseen} unseen views of the known objects",
            kind.name
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
    for &kind in RECOGNIZERS {
        let model = ObjectModel::fit(&train, &RecognizerParams::new(kind), &linear).unwrap();
        let own = &model.settings().own;
        assert_eq!(own.components[0], 0, "{kind:?}");
        assert_eq!(own.thresholds[0], f64::INFINITY, "{kind:?}");
        assert!(own.thresholds[1..].iter().all(|t| t.is_finite()), "{kind:?}: {own:?}");
        // Its training view is recognised, unmeasured by a second stage; the file keeps that.
        let r = &model.recognize(all.object(0).row(0)).unwrap()[0];
        assert_eq!((r.object, r.own_distance), (Some(0), None), "{kind:?}");
        let back = ObjectModel::from_bytes(Path::new("m"), &model.to_bytes().unwrap()).unwrap();
        assert_eq!(back.settings(), model.settings());
        assert_eq!(back.recognize(all.object(0).features()).unwrap(), model.recognize(all.object(0).features()).unwrap());
    }
}

/// The size of [`builtins`]' images.
const W: usize = 64;
const H: usize = 48;

/// `img` moved by (`dx`, `dy`) whole pixels, the dark background filling in; `None` when part of
/// the object would leave the frame or touch its edge.
fn moved(img: &[f32], dx: isize, dy: isize) -> Option<Vec<f32>> {
    let mut out = vec![0.0f32; W * H];
    for y in 0..H as isize {
        for x in 0..W as isize {
            let v = img[y as usize * W + x as usize];
            let (tx, ty) = (x + dx, y + dy);
            let inside = tx > 0 && ty > 0 && tx < W as isize - 1 && ty < H as isize - 1;
            if v != 0.0 && !inside {
                return None;
            }
            if inside {
                out[ty as usize * W + tx as usize] = v;
            }
        }
    }
    Some(out)
}

#[test]
fn behind_the_stage_a_view_moved_by_whole_pixels_gets_the_same_object_and_pose_and_the_file_keeps_it() {
    let (all, train) = builtins();
    for &kind in RECOGNIZERS {
        let params = RecognizerParams::new(kind);
        let model = ObjectModel::fit_normalized(train, &params, &eigenspace(), NormalizeParams::geometry(), &|_| {}).unwrap();
        let stage = model.stage().expect("a stage");
        assert!(stage.radius.is_some() && stage.brightness.is_none(), "{stage:?}");
        // The unseen views (azimuths 5, 15, ...) of every object, as they are and moved.
        let (mut queries, mut shifted, mut truth) = (Vec::new(), Vec::new(), Vec::new());
        for (k, d) in all.objects().iter().enumerate() {
            for i in (1..d.len()).step_by(2) {
                for (dx, dy) in [(3, -2), (-4, 1)] {
                    if let Some(s) = moved(d.row(i), dx, dy) {
                        queries.extend_from_slice(d.row(i));
                        shifted.extend(s);
                        truth.push(k);
                    }
                }
            }
        }
        assert!(truth.len() >= all.total_len() / 2, "{kind:?}: only {} moved views inside the frame", truth.len());
        let est = model.estimate(&queries, 2).unwrap();
        // The stage is exact for a move by whole pixels: the same normalised image, so the same
        // object, distances and pose, bit for bit.
        assert_eq!(model.estimate(&shifted, 2).unwrap(), est, "{kind:?}");
        let right = est.iter().zip(&truth).filter(|(e, &k)| e.recognition.object == Some(k)).count();
        assert!(right as f64 >= 0.97 * truth.len() as f64, "{kind:?}: {right} of {} recognised", truth.len());
        // The model file keeps the stage, and the answers with it.
        let path = std::env::temp_dir().join(format!("linpose-recognize-normalize-{}-{}.safetensors", std::process::id(), kind.name));
        model.save(&path).unwrap();
        let back = ObjectModel::load(&path);
        std::fs::remove_file(&path).ok();
        let back = back.unwrap();
        assert_eq!(back.stage(), model.stage());
        assert_eq!(back.estimate(&shifted, 2).unwrap(), est, "{kind:?}");
    }
}

#[test]
fn a_query_the_stage_cannot_normalise_is_refused_by_its_place_and_alone() {
    let (all, train) = builtins();
    let model = ObjectModel::fit_normalized(train, &RecognizerParams::default(), &eigenspace(), NormalizeParams::geometry(), &|_| {}).unwrap();
    let duck = all.object(0);
    // A view, a black image, the view again.
    let mut queries = duck.row(1).to_vec();
    queries.extend(vec![0.0f32; W * H]);
    queries.extend_from_slice(duck.row(3));
    let e = model.estimate(&queries, 1).unwrap_err().to_string();
    assert!(e.contains("query row 1 of the batch") && e.contains("no object found"), "{e}");
    let each = model.estimate_each(&queries, 1).unwrap();
    assert_eq!(each.len(), 3);
    assert!(matches!(each[1], Err(Rejection::Empty { .. })), "{:?}", each[1]);
    // The others are estimated as the batch without the refused one.
    let others: Vec<f32> = duck.row(1).iter().chain(duck.row(3)).copied().collect();
    let without = model.estimate(&others, 1).unwrap();
    assert_eq!((each[0].as_ref().unwrap(), each[2].as_ref().unwrap()), (&without[0], &without[1]));
    assert_eq!(without[0].recognition.object, Some(0));
    // Without a stage the model takes every query as it is.
    let plain = ObjectModel::fit(train, &RecognizerParams::default(), &eigenspace()).unwrap();
    assert!(plain.stage().is_none());
    assert!(plain.estimate_each(duck.row(1), 1).unwrap()[0].is_ok());
    // A training view the stage cannot normalise is an error naming it.
    let mut names = train.names().to_vec();
    names.push("dark".into());
    let mut sets = train.objects().to_vec();
    let dark = Dataset::from_features(train.object(0).manifest().clone(), train.spec(), vec![0.0; train.object(0).len() * W * H]).unwrap();
    sets.push(dark);
    let bad = ObjectSet::new(names, sets).unwrap();
    let e = ObjectModel::fit_normalized(&bad, &RecognizerParams::default(), &eigenspace(), NormalizeParams::geometry(), &|_| {}).unwrap_err().to_string();
    assert!(e.contains("no object found"), "{e}");
}

/// `set` with each object's views in reverse order and their poses replaced by the views'
/// places in that order (a pose that says nothing).
fn posed_by_place(set: &ObjectSet) -> ObjectSet {
    let space = PoseSpace::new(vec![Param::linear("place")]).unwrap();
    let objects = set
        .objects()
        .iter()
        .map(|d| {
            let features: Vec<f32> = (0..d.len()).rev().flat_map(|i| d.row(i).iter().copied()).collect();
            Dataset::new(d.spec(), features, space.clone(), (0..d.len()).map(|i| i as f64).collect()).unwrap()
        })
        .collect();
    ObjectSet::new(set.names().to_vec(), objects).unwrap()
}

#[test]
fn without_poses_the_training_views_recognise_alone_whatever_their_order() {
    let (all, train) = builtins();
    for &kind in RECOGNIZERS {
        let params = RecognizerParams::new(kind);
        let model = ObjectModel::fit_views(train, &params).unwrap();
        assert!(model.space().is_none() && model.method_name().is_none() && model.pose_model(0).is_none());
        assert!(model.settings().views_only);
        // The views in another order with other (meaningless) poses: the same model.
        let shuffled = ObjectModel::fit_views(&posed_by_place(train), &params).unwrap();
        for d in all.objects() {
            let (a, b) = (model.recognize(d.features()).unwrap(), shuffled.recognize(d.features()).unwrap());
            for (a, b) in a.iter().zip(&b) {
                assert_eq!((a.object, a.nearest), (b.object, b.nearest), "{kind:?}");
                assert!((a.distance - b.distance).abs() <= 1e-4 * a.distance.max(1e-3), "{kind:?}: {} against {}", a.distance, b.distance);
            }
        }
        // Identity: a training view is one of its object's points (universal) or has its one-hot
        // target as outputs (linear).
        for (k, d) in train.objects().iter().enumerate() {
            for r in model.recognize(d.features()).unwrap() {
                assert!(r.distance < 2e-3 && r.object == Some(k), "{kind:?}: training view at distance {}, as {:?}", r.distance, r.object);
            }
        }
        let (seen_ok, seen, unseen_ok, unknown, unseen) = rates(&model, all, all.names());
        println!("{}, without poses: {unseen_ok} of {unseen} unseen views recognised, {unknown} reported unknown", kind.name);
        assert_eq!(seen_ok, seen, "{kind:?}");
        assert!(unseen_ok as f64 >= 0.97 * unseen as f64, "{kind:?}: {unseen_ok} of {unseen} unseen views recognised");
        // Estimates carry the object and no pose; the model file keeps it so.
        let est = model.estimate(all.object(2).features(), 1).unwrap();
        assert!(est.iter().all(|e| e.pose.is_none()));
        let bytes = model.to_bytes().unwrap();
        let back = ObjectModel::from_bytes(Path::new("views.safetensors"), &bytes).unwrap();
        assert_eq!((back.settings(), back.spec(), back.space()), (model.settings(), model.spec(), None));
        assert_eq!(back.estimate(all.object(2).features(), 1).unwrap(), est);
    }
}

#[test]
fn without_poses_objects_left_out_are_reported_unknown() {
    for &kind in RECOGNIZERS {
        let fit = |known: &ObjectSet| ObjectModel::fit_views(known, &RecognizerParams::new(kind)).unwrap();
        let (rejected, left, false_rejected, unseen) = each_left_out(fit, |_| {});
        println!(
            "{}, without poses: {rejected} of {left} views of the object left out reported unknown; {false_rejected} of {unseen} unseen views of the known objects",
            kind.name
        );
        assert!(rejected as f64 >= 0.95 * left as f64, "{kind:?}: {rejected} of {left} views of objects left out reported unknown");
        assert!(false_rejected as f64 <= 0.02 * unseen as f64, "{kind:?}: {false_rejected} of {unseen} unseen views of known objects reported unknown");
    }
}
