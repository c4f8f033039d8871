//! Recognition then pose behind one normalisation stage fitted on every object's training views:
//! a query moved by whole pixels gets exactly the answer of the query as it was, the model file
//! keeps the stage, and a query the stage cannot normalise is refused by name, alone.

use linpose::normalize::{NormalizeParams, Rejection};
use linpose::recognize::{ObjectModel, RecognizerKind, RecognizerParams};
use linpose::render::synth::{dataset, PoseGrid};
use linpose::render::{objects, Grid, RenderParams};
use linpose::{model_file, Dataset, EigenspaceParams, MethodSpec, ObjectSet, TrainSelection};
use std::path::Path;

const W: usize = 64;
const H: usize = 48;

/// Every built-in object every 5 degrees of azimuth at 64 x 48 (all views, training views: every
/// 10 degrees).
fn builtins() -> (ObjectSet, ObjectSet) {
    let grid = PoseGrid::new(Grid::parse("elevation", "40").unwrap(), Grid::parse("azimuth", "0:355:5").unwrap()).unwrap();
    let params = RenderParams::default().width(W as u32).height(H as u32);
    let names: Vec<String> = objects::OBJECTS.iter().map(|o| o.0.to_string()).collect();
    let data: Vec<Dataset> = names.iter().map(|n| dataset(&objects::builtin(n).unwrap(), &grid, &params, Path::new(n), &|_| {}).unwrap()).collect();
    let all = ObjectSet::new(names, data).unwrap();
    let masks: Vec<Vec<bool>> = all.objects().iter().map(|d| d.manifest().training_mask(&TrainSelection::Step(10.0)).unwrap()).collect();
    let train = all.subset(&masks).unwrap();
    (all, train)
}

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

fn eigenspace() -> MethodSpec {
    EigenspaceParams::default().components(12).into()
}

#[test]
fn behind_the_stage_a_view_moved_by_whole_pixels_gets_the_same_object_and_pose_and_the_file_keeps_it() {
    let (all, train) = builtins();
    for kind in RecognizerKind::ALL {
        let params = RecognizerParams::new(kind);
        let model = ObjectModel::fit_normalized(&train, &params, &eigenspace(), NormalizeParams::geometry(), &|_| {}).unwrap();
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
        let path = std::env::temp_dir().join(format!("linpose-recognize-normalize-{}-{}.safetensors", std::process::id(), kind.name()));
        model_file::save_objects(&model, &path).unwrap();
        let back = model_file::load_objects(&path);
        std::fs::remove_file(&path).ok();
        let back = back.unwrap();
        assert_eq!(back.stage(), model.stage());
        assert_eq!(back.estimate(&shifted, 2).unwrap(), est, "{kind:?}");
    }
}

#[test]
fn a_query_the_stage_cannot_normalise_is_refused_by_its_place_and_alone() {
    let (all, train) = builtins();
    let model = ObjectModel::fit_normalized(&train, &RecognizerParams::default(), &eigenspace(), NormalizeParams::geometry(), &|_| {}).unwrap();
    let duck = all.object(0);
    // A view, a black image, the view again.
    let mut queries = duck.row(1).to_vec();
    queries.extend(vec![0.0f32; W * H]);
    queries.extend_from_slice(duck.row(3));
    let e = model.estimate(&queries, 1).unwrap_err().to_string();
    assert!(e.contains("query #1") && e.contains("no object found"), "{e}");
    let each = model.estimate_each(&queries, 1).unwrap();
    assert_eq!(each.len(), 3);
    assert!(matches!(each[1], Err(Rejection::Empty { .. })), "{:?}", each[1]);
    // The others are estimated as the batch without the refused one.
    let others: Vec<f32> = duck.row(1).iter().chain(duck.row(3)).copied().collect();
    let without = model.estimate(&others, 1).unwrap();
    assert_eq!((each[0].as_ref().unwrap(), each[2].as_ref().unwrap()), (&without[0], &without[1]));
    assert_eq!(without[0].recognition.object, Some(0));
    // Without a stage the model takes every query as it is.
    let plain = ObjectModel::fit(&train, &RecognizerParams::default(), &eigenspace()).unwrap();
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
