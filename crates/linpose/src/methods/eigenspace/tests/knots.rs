//! Three and four pose parameters: the manifold kept as its knots (the training views) and
//! searched continuously, not resampled on a lattice.

use super::*;

/// Elevation 30 to 60 every 10; azimuth every `az` degrees; roll -30 to 30 every 15.
pub(crate) fn train3(az: usize) -> Dataset {
    grid_of(&[vec![30.0, 40.0, 50.0, 60.0], (0..360).step_by(az).map(|a| a as f64).collect(), vec![-30.0, -15.0, 0.0, 15.0, 30.0]])
}

/// Views between the training views of [`train3`] (20 degrees of azimuth): halfway along every
/// axis, inside the training range.
pub(crate) fn between3() -> Dataset {
    grid_of(&[vec![35.0, 55.0], (0..6).map(|k| 10.0 + 60.0 * k as f64).collect(), vec![-22.5, -7.5, 7.5, 22.5]])
}

/// Each view's error (degrees: the angle of the rotation between the poses).
fn errors_of(est: &[f64], d: &Dataset) -> Vec<f64> {
    let p = d.space().len();
    (0..d.len()).map(|i| d.space().error_deg(d.pose(i), &est[i * p..(i + 1) * p])).collect()
}

#[test]
fn three_parameters_keep_the_knots_reproduce_training_poses_and_interpolate() {
    let train = train3(20);
    let model = EigenspaceParams::default().fit(&train).unwrap();
    let s = model.settings();
    assert!(s.continuous);
    assert_eq!((s.manifold_shape.clone(), model.manifold_len()), (vec![4, 18, 5], train.len()));
    assert_eq!(s.search, SearchKind::KdTree);
    for (i, e) in errors_of(&model.predict(train.features()).unwrap(), &train).into_iter().enumerate() {
        assert_eq!(e, 0.0, "training view {} off by {e}", train.manifest().images()[i]);
    }
    let test = between3();
    let est = model.predict(test.features()).unwrap();
    let e = errors_of(&est, &test);
    let (mean, max) = (e.iter().sum::<f64>() / e.len() as f64, e.iter().copied().fold(0.0, f64::max));
    // One 0.5-degree lattice step in two of the angles is a rotation of 0.71 degrees.
    assert!(mean < 0.75 && max <= 1.0, "unseen mean {mean}, max {max}: {e:?}");
    // What error there is, is the surface's: the estimate lies nearer the query than the true pose.
    let Search::Knots(k) = &model.search else { panic!("a lattice") };
    let l = model.components();
    let mut y = vec![0f32; test.len() * l];
    model.project_into(test.features(), &mut y).unwrap();
    let mut f = vec![0.0; l];
    let mut dist = |t: &[f64], y: &[f32]| {
        let mut t = t.to_vec();
        k.surface.clamp(&mut t);
        k.surface.eval(&t, &mut f, None);
        f.iter().zip(y).map(|(a, &b)| (a - b as f64).powi(2)).sum::<f64>()
    };
    for i in 0..test.len() {
        let yi = &y[i * l..(i + 1) * l];
        assert!(dist(&est[i * 3..i * 3 + 3], yi) <= dist(test.pose(i), yi), "view {i}");
    }
    // Brute force over the knots gives the tree's poses.
    let brute = EigenspaceParams::default().search(SearchKind::Brute).fit(&train).unwrap();
    assert_eq!(brute.settings().search, SearchKind::Brute);
    assert_eq!(brute.predict(test.features()).unwrap(), model.predict(test.features()).unwrap());
}

#[test]
fn the_knots_model_grows_with_the_training_views_not_with_a_lattice() {
    let sizes: Vec<(usize, usize, usize)> = [30, 20, 10]
        .iter()
        .map(|&az| {
            let train = train3(az);
            let model = EigenspaceParams::default().components(12).fit(&train).unwrap();
            let fixed = (model.basis().len() + model.mean().len() + model.look.as_ref().map_or(0, SecondLook::len)) * 4;
            (train.len(), model.model_bytes(), model.model_bytes() - fixed)
        })
        .collect();
    // The manifold's part: the knots, their positions, the surface, the coarse points (about 2^3
    // a view) with their poses and tree: about the same per view whatever N (the tree's leaves
    // and the linear axes' ends vary a little), under 30 L numbers.
    let per_view: Vec<f64> = sizes.iter().map(|&(n, _, part)| part as f64 / n as f64).collect();
    for w in per_view.windows(2) {
        assert!((w[1] / w[0] - 1.0).abs() < 0.2, "{sizes:?}");
    }
    assert!(per_view.iter().all(|&b| b <= 30.0 * 12.0 * 4.0), "{per_view:?}");
    // The lattice of 0.5 degrees over the same ranges would hold 61 x 720 x 121 points of 12.
    assert!(sizes.iter().all(|s| s.1 < 61 * 720 * 121 * 12 * 4 / 100), "{sizes:?}");
}

#[test]
fn four_parameters_train_and_predict() {
    let axes = [vec![30.0, 40.0, 50.0, 60.0], (0..9).map(|k| 40.0 * k as f64).collect(), vec![-30.0, -10.0, 10.0, 30.0], vec![0.0, 30.0, 60.0]];
    let train = grid_of(&axes);
    let model = EigenspaceParams::default().fit(&train).unwrap();
    assert!(model.settings().continuous);
    assert_eq!(model.settings().manifold_shape, vec![4, 9, 4, 3]);
    let e = errors_of(&model.predict(train.features()).unwrap(), &train);
    assert!(e.iter().all(|&v| v == 0.0), "{e:?}");
    // Views between the training views along every axis land near their poses.
    let test = grid_of(&[vec![35.0, 55.0], vec![20.0, 220.0], vec![0.0, 20.0], vec![15.0, 45.0]]);
    let e = errors_of(&model.predict(test.features()).unwrap(), &test);
    // Knots 10 to 40 degrees apart along four axes: a few degrees, the surface's own error.
    assert!(e.iter().all(|&v| v < 5.0), "{e:?}");
}

#[test]
fn a_model_file_of_three_parameters_reads_back_with_the_same_poses() {
    let train = train3(30);
    let model = EigenspaceParams::default().components(10).fit(&train).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.safetensors");
    model.save(&path).unwrap();
    let back = crate::AnyModel::load(&path).unwrap();
    let test = between3();
    assert_eq!(back.predict(test.features()).unwrap(), model.predict(test.features()).unwrap());
    assert_eq!(back.model_bytes(), model.model_bytes());
    let names: Vec<String> = model.tensors().iter().map(|t| t.name.clone()).collect();
    assert!(names.contains(&"knots".to_string()) && !names.contains(&"manifold".to_string()), "{names:?}");
    // Settings that say a lattice where the space needs the knots are refused, naming them.
    let mut meta = model.meta().clone();
    meta.settings["continuous"] = serde_json::json!(false);
    let set = crate::model::TensorSet { path, tensors: model.tensors() };
    let e = EigenspaceModel::from_parts(meta, &set).unwrap_err().to_string();
    assert!(e.contains("3 pose parameters"), "{e}");
}

#[test]
fn three_parameters_give_confident_hypotheses_and_8_bit_poses() {
    let train = train3(20);
    let model = EigenspaceParams::default().fit(&train).unwrap();
    let test = between3();
    let est = model.estimate(test.features(), 3).unwrap();
    let poses = model.predict(test.features()).unwrap();
    let p = test.space().len();
    for (i, e) in est.iter().enumerate() {
        assert_eq!(e.pose, &poses[i * p..(i + 1) * p], "estimate and predict agree");
        assert!(e.confidence > FLAG, "view {i}: {e:?}");
        for h in &e.hypotheses[1..] {
            assert!(test.space().error_deg(&h.pose, &e.pose) >= crate::confidence::GROSS_DEG, "{e:?}");
        }
    }
    let q8: Vec<u8> = test.features().iter().map(|&v| (v * 255.0).round().clamp(0.0, 255.0) as u8).collect();
    let mut p8 = vec![0.0; poses.len()];
    model.predict_u8_into(&q8, &mut p8).unwrap();
    let e8 = errors_of(&p8, &test);
    assert!(e8.iter().all(|&v| v < 2.0), "{e8:?}");
}

/// The flagging threshold.
const FLAG: f64 = crate::confidence::FLAG_BELOW;

