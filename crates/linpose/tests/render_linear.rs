//! End to end on rendered data: the paper's experiment (its Fig. 3) on the built-in duck.
//!
//! The duck is rendered in memory on the paper's grid (1760 poses of 160 x 120), the linear model
//! is trained on the 222 poses 9 degrees apart and evaluated on all of them; on the 1538 unseen
//! poses its mean error must stay under 5 degrees, as the paper's own duck did.

use linpose::render::synth::{dataset, PoseGrid};
use linpose::render::{objects, RenderParams};
use linpose::{evaluate, Estimator, LinearParams, TrainSelection};
use std::path::Path;

#[test]
fn linear_model_estimates_the_rendered_duck_within_5_degrees() {
    let duck = objects::builtin("duck").unwrap();
    let full = dataset(&duck, &PoseGrid::paper(), &RenderParams::default(), Path::new("<duck>"), &|_| {}).unwrap();
    assert_eq!(full.len(), 1760);
    let mask = full.manifest().training_mask(&TrainSelection::Step(9.0)).unwrap();
    let train = full.subset(&mask).unwrap();
    assert_eq!(train.len(), 222);
    let model = LinearParams::default().fit(&train).unwrap();
    let report = evaluate(&model, &full, 0.0, 0).unwrap();
    let unseen = report.unseen.expect("1538 poses are not training poses");
    eprintln!("duck, linear model: all {:?}\nunseen {:?}", report.all, unseen);
    assert_eq!(unseen.n, 1538);
    assert!(unseen.mean_deg < 5.0, "mean error on unseen poses {:.2} degrees", unseen.mean_deg);
}
