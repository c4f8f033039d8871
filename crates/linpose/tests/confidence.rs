//! Ranked hypotheses and confidence on rendered turntables: the nearly symmetric `twin` (front
//! and back alike but for a small mark) against the asymmetric `duck`, for every method.
//!
//! Each object is rendered at 80 x 60 on one elevation, every 5 degrees of azimuth; the models
//! are trained on every 10 degrees and queried on the 36 views between.

use linpose::confidence::{FLAG_BELOW, GROSS_DEG};
use linpose::render::synth::{dataset, PoseGrid};
use linpose::render::{objects, Grid, RenderParams};
use linpose::{model_file, AnyModel, Dataset, Estimate, PoseModel, TrainSelection, METHODS};
use std::path::Path;

fn turntable(object: &str) -> (Dataset, Dataset) {
    let mesh = objects::builtin(object).unwrap();
    let grid = PoseGrid::new(Grid::parse("elevation", "40").unwrap(), Grid::parse("azimuth", "0:355:5").unwrap()).unwrap();
    let params = RenderParams::default().width(80).height(60);
    let full = dataset(&mesh, &grid, &params, Path::new("<render>"), &|_| {}).unwrap();
    let mask = full.manifest().training_mask(&TrainSelection::Step(10.0)).unwrap();
    let train = full.subset(&mask).unwrap();
    let unseen = full.subset(&mask.iter().map(|&t| !t).collect::<Vec<_>>()).unwrap();
    (train, unseen)
}

fn estimates(model: &AnyModel, data: &Dataset, top: usize) -> Vec<Estimate> {
    let est = model.estimate(data.features(), top).unwrap();
    // The estimate is the pose predict gives, and the first hypothesis.
    let poses = model.predict(data.features()).unwrap();
    for (e, p) in est.iter().zip(poses.chunks_exact(data.space().len())) {
        assert_eq!(e.pose, p, "estimate() and predict() disagree");
        assert_eq!(e.hypotheses[0].pose, e.pose);
        assert!(e.hypotheses.len() <= top && (0.0..=1.0).contains(&e.confidence));
        assert_eq!(e.confidence, e.hypotheses[0].score);
        let total: f64 = e.hypotheses.iter().map(|h| h.score).sum();
        assert!(total <= 1.0 + 1e-9, "{e:?}");
    }
    est
}

fn azimuth_gap(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(360.0);
    d.min(360.0 - d)
}

#[test]
fn the_manifold_methods_see_front_and_back_of_a_symmetric_object_and_trust_an_asymmetric_one() {
    let (twin_train, twin) = turntable("twin");
    let (duck_train, duck) = turntable("duck");
    for name in ["eigenspace", "refined"] {
        let method = linpose::methods::find(name).unwrap();
        let spec = method.default_spec();
        // The twin: most views have a second hypothesis about half a turn away, and the model
        // is not sure (front or back).
        let model = spec.fit(&twin_train).unwrap();
        let est = estimates(&model, &twin, 3);
        let torn: Vec<&Estimate> =
            est.iter().filter(|e| e.hypotheses.len() >= 2 && azimuth_gap(e.hypotheses[0].pose[1], e.hypotheses[1].pose[1]) > 150.0).collect();
        assert!(torn.len() * 2 > est.len(), "{name}: {} of {} twin views with a second hypothesis half a turn away", torn.len(), est.len());
        let low = torn.iter().filter(|e| e.confidence < FLAG_BELOW).count();
        assert!(low * 2 > torn.len(), "{name}: only {low} of {} such views not trusted", torn.len());
        // Every gross error is among the flagged views, or its truth is the second hypothesis.
        for (e, i) in est.iter().zip(0..) {
            let truth = twin.pose(i);
            if twin.space().error_deg(truth, &e.pose) > GROSS_DEG {
                assert!(e.hypotheses.iter().any(|h| twin.space().error_deg(truth, &h.pose) <= GROSS_DEG), "{name}: twin view {i}: {e:?}, truth {truth:?}");
            }
        }
        // The duck: every view trusted, and right.
        let model = spec.fit(&duck_train).unwrap();
        let est = estimates(&model, &duck, 3);
        for (e, i) in est.iter().zip(0..) {
            assert!(e.confidence > 0.99, "{name}: duck view {i}: {e:?}");
            assert!(duck.space().error_deg(duck.pose(i), &e.pose) < 2.0, "{name}: duck view {i}: {e:?}");
        }
    }
}

#[test]
fn the_linear_model_trusts_the_duck_more_than_the_twin() {
    let spec = linpose::methods::find("linear").unwrap().default_spec();
    let mean_confidence = |object: &str| {
        let (train, unseen) = turntable(object);
        let est = estimates(&spec.fit(&train).unwrap(), &unseen, 3);
        assert!(est.iter().all(|e| e.hypotheses.len() == 1));
        est.iter().map(|e| e.confidence).sum::<f64>() / est.len() as f64
    };
    let (duck, twin) = (mean_confidence("duck"), mean_confidence("twin"));
    assert!(duck > 0.9 && twin < duck, "duck {duck}, twin {twin}");
}

#[test]
fn a_model_read_back_from_its_file_gives_the_same_hypotheses() {
    let (train, unseen) = turntable("twin");
    let dir = tempfile::tempdir().unwrap();
    for method in METHODS {
        let model = method.default_spec().fit(&train).unwrap();
        let path = dir.path().join(format!("{}.safetensors", method.name));
        model_file::save(&model, &path).unwrap();
        let back = model_file::load(&path).unwrap();
        let (a, b) = (model.estimate(unseen.features(), 4).unwrap(), back.estimate(unseen.features(), 4).unwrap());
        for (i, (x, y)) in a.iter().zip(&b).enumerate() {
            assert_eq!(x, y, "{}: view {i}", method.name);
        }
    }
}

#[test]
fn bad_queries_are_clear_errors() {
    let (train, unseen) = turntable("duck");
    let m = unseen.n_features();
    for method in METHODS {
        let model = method.default_spec().fit(&train).unwrap();
        let mut batch = unseen.features()[..3 * m].to_vec();
        batch[m..2 * m].fill(0.0);
        if method.name != "linear" {
            let err = model.estimate(&batch, 2).unwrap_err().to_string();
            assert!(err.contains("#1 of the batch") && err.contains("all black"), "{}: {err}", method.name);
        }
        let err = model.estimate(&batch[..m + 1], 2).unwrap_err().to_string();
        assert!(err.contains(&m.to_string()), "{}: {err}", method.name);
    }
}
