//! Three and four pose parameters: the manifold kept as its knots, every search started from the
//! training views (the clean search, the noisy match, the search in another basin).

use super::*;
use crate::methods::eigenspace::tests::grid_of;
use crate::methods::eigenspace::tests::knots::{between3, train3};

/// Each view's error (degrees: the angle of the rotation between the poses).
fn errors_of(est: &[f64], d: &Dataset) -> Vec<f64> {
    let p = d.space().len();
    (0..d.len()).map(|i| d.space().error_deg(d.pose(i), &est[i * p..(i + 1) * p])).collect()
}

fn mean(e: &[f64]) -> f64 {
    e.iter().sum::<f64>() / e.len() as f64
}

#[test]
fn three_parameters_start_from_the_training_views_and_interpolate() {
    let train = train3(20);
    // Every setting chosen on held-out training views, as by default.
    let model = RefinedParams::default().fit(&train).unwrap();
    assert!(model.continuous() && model.tree.is_none() && model.lattice.is_none() && model.noisy_tree.is_none());
    assert_eq!(model.settings().knot_shape, vec![4, 18, 5]);
    // Its `roll` moves a band rather than turning the image: no views turned between its rolls.
    let turn = model.settings().roll_turn_error.unwrap();
    assert!(model.settings().roll_split.is_none() && turn > crate::methods::refined::tuning::ROLL_TURN_MAX, "{turn}");
    // The coarse points: the surface at two points per knot interval along each axis (the knots
    // among them), 2^3 a training view but for the ends of the linear axes.
    assert_eq!((model.start_len(), model.knots_len()), (7 * 36 * 9, train.len()));
    let e = errors_of(&model.predict(train.features()).unwrap(), &train);
    assert!(e.iter().all(|&v| v == 0.0), "{e:?}");
    let test = between3();
    let e = errors_of(&model.predict(test.features()).unwrap(), &test);
    // One 0.5-degree lattice step in two of the angles is a rotation of 0.71 degrees.
    assert!(mean(&e) <= 0.75 && e.iter().all(|&v| v <= 1.0), "{e:?} with {:?}", model.settings());
    // Ranked hypotheses: predict's pose first, confident on every clean view.
    let est = model.estimate(test.features(), 3).unwrap();
    let poses = model.predict(test.features()).unwrap();
    for (i, x) in est.iter().enumerate() {
        assert_eq!(x.pose, &poses[i * 3..i * 3 + 3]);
        assert!(x.confidence > crate::confidence::FLAG_BELOW, "view {i}: {x:?}");
    }
}

#[test]
fn noisy_queries_of_three_parameters_take_the_affine_match_from_the_training_views() {
    let train = train3(20);
    let model = RefinedParams::default().components(12).fit(&train).unwrap();
    let thr = model.settings().noise_threshold;
    assert!(thr > 0.0 && model.noise_scan.w0.len() == model.settings().noise_components);
    let test = between3();
    let m = test.n_features();
    let q: Vec<f32> = test.features().chunks_exact(m).enumerate().flat_map(|(i, x)| with_noise(x, 0.1, 40 + i as u64)).collect();
    for x in q.chunks_exact(m) {
        assert!(crate::pixel_noise::pixel_noise(x, W, H, 1) > thr);
    }
    let e = errors_of(&model.predict(&q).unwrap(), &test);
    assert!(mean(&e) < 3.0 && e.iter().all(|&v| v < 10.0), "{e:?}");
    // The search in another basin (the second look's) lands on the same poses from a start a
    // knot away.
    let est = model.predict(&q).unwrap();
    for i in 0..6 {
        let x = &q[i * m..(i + 1) * m];
        let start = [est[3 * i] + 5.0, est[3 * i + 1] - 10.0, est[3 * i + 2] + 5.0];
        let mut out = [0.0; 3];
        model.refine_in_basin(x, &start, &mut out);
        assert!(test.space().error_deg(&out, &est[3 * i..3 * i + 3]) <= 2.0, "view {i}: {out:?} against {:?}", &est[3 * i..3 * i + 3]);
    }
}

#[test]
fn the_refined_knots_model_grows_with_the_training_views() {
    let per_view: Vec<f64> = [30, 20, 10]
        .iter()
        .map(|&az| {
            let train = train3(az);
            let model = RefinedParams::default().components(12).bin(1).interpolant(Interpolant::Spline).fit(&train).unwrap();
            let fixed = (model.proj.rows().len() + model.mean_proj.len() + model.look.as_ref().map_or(0, crate::second_look::SecondLook::len)) * 4;
            // Per training view and component (held-out views choose how many).
            (model.model_bytes() - fixed) as f64 / (train.len() * model.settings().components) as f64
        })
        .collect();
    for w in per_view.windows(2) {
        assert!((w[1] / w[0] - 1.0).abs() < 0.1, "{per_view:?}");
    }
}

#[test]
fn four_parameters_train_and_predict() {
    let axes = [vec![30.0, 40.0, 50.0, 60.0], (0..9).map(|k| 40.0 * k as f64).collect(), vec![-30.0, -10.0, 10.0, 30.0], vec![0.0, 30.0, 60.0]];
    let train = grid_of(&axes);
    let model = RefinedParams::default().components(12).bin(1).interpolant(Interpolant::Spline).fit(&train).unwrap();
    assert!(model.continuous());
    let e = errors_of(&model.predict(train.features()).unwrap(), &train);
    assert!(e.iter().all(|&v| v == 0.0), "{e:?}");
    let test = grid_of(&[vec![35.0, 55.0], vec![20.0, 220.0], vec![0.0, 20.0], vec![15.0, 45.0]]);
    let e = errors_of(&model.predict(test.features()).unwrap(), &test);
    assert!(e.iter().all(|&v| v < 5.0), "{e:?}");
    // Through a model file.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.safetensors");
    model.save(&path).unwrap();
    let back = crate::AnyModel::load(&path).unwrap();
    assert_eq!(back.predict(test.features()).unwrap(), model.predict(test.features()).unwrap());
}

