//! The normalisation stage on rendered turntables: trained on registered views, it takes views
//! moved, scaled and exposed differently back to the training frame; the model file keeps it;
//! an image it cannot normalise is a clear error.

use linpose::normalize::{NormalizeParams, Normalized};
use linpose::render::synth::{dataset, PoseGrid};
use linpose::render::{objects, Grid, Jitter, RenderParams};
use linpose::{model_file, Dataset, EigenspaceParams, Error, MethodSpec, PoseModel, TrainSelection};
use std::path::Path;

/// The duck every 5 degrees of azimuth at 80 x 60, registered, and the same views jittered.
fn duck(jitter: Option<Jitter>) -> Dataset {
    let mut grid = PoseGrid::new(Grid::parse("elevation", "40").unwrap(), Grid::parse("azimuth", "0:355:5").unwrap()).unwrap();
    if let Some(j) = jitter {
        grid = grid.with_jitter(j).unwrap();
    }
    let params = RenderParams::default().width(80).height(60);
    dataset(&objects::builtin("duck").unwrap(), &grid, &params, Path::new("<render>"), &|_| {}).unwrap()
}

fn unseen_mean(model: &dyn PoseModel, data: &Dataset) -> f64 {
    let r = linpose::evaluate(model, data, 0.0, 0).unwrap();
    r.unseen.unwrap().mean_deg
}

#[test]
fn jittered_views_come_back_to_the_training_frame_and_the_model_file_keeps_the_stage() {
    let full = duck(None);
    let train = full.subset(&full.manifest().training_mask(&TrainSelection::Step(10.0)).unwrap()).unwrap();
    let jittered = duck(Some(Jitter { shift: 4.0, scale: 0.1, exposure: 0.2, seed: 3 }));
    let spec: MethodSpec = EigenspaceParams::default().components(12).into();
    let plain = spec.fit(&train).unwrap();
    let model = Normalized::fit(&spec, &train, NormalizeParams { geometry: true, brightness: true }).unwrap();
    let (reg, jit, jit_plain) = (unseen_mean(&model, &full), unseen_mean(&model, &jittered), unseen_mean(&plain, &jittered));
    // Without the stage the jitter costs degrees; with it, the jittered views are estimated
    // about as well as the registered ones.
    assert!(jit_plain > 3.0, "plain model on jittered views: {jit_plain}");
    assert!(jit <= 1.5 * reg + 0.1, "normalised: registered {reg}, jittered {jit}");

    let path = std::env::temp_dir().join(format!("linpose-normalize-{}.safetensors", std::process::id()));
    model_file::save(&model, &path).unwrap();
    let back = model_file::load(&path).unwrap();
    std::fs::remove_file(&path).ok();
    assert_eq!(back.meta(), model.meta());
    assert!(back.meta().normalize.is_some());
    let (a, b) = (model.predict(jittered.features()).unwrap(), back.predict(jittered.features()).unwrap());
    assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()), "the same estimates after the round trip");
}

#[test]
fn an_image_the_stage_cannot_normalise_is_an_error_naming_it() {
    let full = duck(None);
    let train = full.subset(&full.manifest().training_mask(&TrainSelection::Step(30.0)).unwrap()).unwrap();
    let spec: MethodSpec = EigenspaceParams::default().components(4).into();
    let model = Normalized::fit(&spec, &train, NormalizeParams::geometry()).unwrap();
    let m = full.n_features();
    let mut batch = full.row(0).to_vec();
    batch.extend(vec![0.0f32; m]);
    match model.predict(&batch) {
        Err(e @ Error::Normalize { .. }) => {
            let text = e.to_string();
            assert!(text.contains("query #1 of the batch") && text.contains("no object found"), "{text}");
        }
        other => panic!("expected a normalisation error, got {other:?}"),
    }
    // The duck moved against the left edge.
    let mut cut = vec![0.0f32; m];
    let (w, h) = (80, 60);
    for y in 0..h {
        for x in 0..w - 30 {
            cut[y * w + x] = full.row(0)[y * w + x + 30];
        }
    }
    let e = model.predict(&cut).unwrap_err().to_string();
    assert!(e.contains("touches the frame edge (left)"), "{e}");
}
