//! Evaluation: estimate every sample of a data set, optionally under pixel noise, and measure the
//! error of docs/method.md over all samples and over the unseen ones.

use crate::dataset::Dataset;
use crate::model::PoseModel;
use crate::pose::ErrorSummary;
use crate::{Error, Result};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Adds uniform noise of +-`amplitude` (a fraction of full brightness) to every feature of every
/// row and clips to [0, 1]. Row i draws from its own ChaCha8 stream of `seed`, so the result does
/// not depend on the thread count.
pub fn add_uniform_noise(features: &mut [f32], m: usize, amplitude: f64, seed: u64) -> Result<()> {
    if !(amplitude.is_finite() && (0.0..=1.0).contains(&amplitude)) {
        return Err(Error::invalid("noise", amplitude, "must be a fraction of full brightness in [0, 1] (0.05 = +-5%)"));
    }
    if amplitude == 0.0 {
        return Ok(());
    }
    let a = amplitude as f32;
    features.par_chunks_mut(m).enumerate().for_each(|(i, row)| {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(i as u64);
        for v in row.iter_mut() {
            *v = (*v + rng.random_range(-a..a)).clamp(0.0, 1.0);
        }
    });
    Ok(())
}

/// One evaluated sample.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SampleResult {
    /// Image path as in the manifest.
    pub image: String,
    /// True pose (degrees).
    pub r#true: Vec<f64>,
    /// Estimated pose (degrees).
    pub estimated: Vec<f64>,
    /// Pose error (degrees).
    pub error_deg: f64,
    /// Whether the pose is one of the model's training poses.
    pub seen: bool,
}

/// The outcome of an evaluation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EvalReport {
    /// The model's method.
    pub method: String,
    /// Parameter names, in the order of each pose.
    pub params: Vec<String>,
    /// Samples evaluated.
    pub n_eval: usize,
    /// Training samples of the model.
    pub n_train: usize,
    /// Noise amplitude (fraction of full brightness).
    pub noise: f64,
    /// Noise seed.
    pub seed: u64,
    /// Bytes of the model's numbers.
    pub model_bytes: usize,
    /// Wall time of the estimation of all samples (seconds).
    pub predict_s: f64,
    /// Errors over all samples.
    pub all: ErrorSummary,
    /// Errors over the samples whose pose is not a training pose (absent when all are seen).
    pub unseen: Option<ErrorSummary>,
    /// Every sample.
    pub samples: Vec<SampleResult>,
}

/// Estimates every sample of `data` with `model`, with uniform noise of +-`noise` added to the
/// queries (0 for none) from `seed`.
pub fn evaluate(model: &dyn PoseModel, data: &Dataset, noise: f64, seed: u64) -> Result<EvalReport> {
    let meta = model.meta();
    let got = data.spec();
    if (got.width, got.height) != (meta.spec.width, meta.spec.height) {
        return Err(Error::ImageSizeMismatch {
            path: data.manifest().image_path(0),
            expected_w: meta.spec.width,
            expected_h: meta.spec.height,
            got_w: got.width,
            got_h: got.height,
            context: "the size of the model's training images".into(),
        });
    }
    if got.color != meta.spec.color {
        return Err(Error::invalid("colour mode", format!("{:?}", got.color), format!("the model was trained with {:?}", meta.spec.color)));
    }
    if data.space().params().iter().map(|p| &p.name).ne(meta.space.params().iter().map(|p| &p.name)) {
        return Err(Error::Dataset {
            path: data.manifest().root().to_path_buf(),
            message: format!("the data set's parameters ({}) differ from the model's ({})", names(data.space()).join(", "), names(&meta.space).join(", ")),
        });
    }
    let m = meta.spec.features();
    let mut queries;
    let q: &[f32] = if noise > 0.0 {
        queries = data.features().to_vec();
        add_uniform_noise(&mut queries, m, noise, seed)?;
        &queries
    } else {
        add_uniform_noise(&mut [], m, noise, seed)?;
        data.features()
    };
    let t0 = Instant::now();
    let est = model.predict(q)?;
    let predict_s = t0.elapsed().as_secs_f64();
    let p = meta.space.len();
    let samples: Vec<SampleResult> = (0..data.len())
        .map(|i| {
            let truth = data.pose(i);
            let e = &est[i * p..(i + 1) * p];
            SampleResult {
                image: data.manifest().images()[i].clone(),
                r#true: truth.to_vec(),
                estimated: e.to_vec(),
                error_deg: meta.space.error_deg(truth, e),
                seen: meta.is_seen(truth),
            }
        })
        .collect();
    let all_e: Vec<f64> = samples.iter().map(|s| s.error_deg).collect();
    let unseen_e: Vec<f64> = samples.iter().filter(|s| !s.seen).map(|s| s.error_deg).collect();
    Ok(EvalReport {
        method: meta.method.clone(),
        params: names(&meta.space),
        n_eval: data.len(),
        n_train: meta.n_train(),
        noise,
        seed,
        model_bytes: model.model_bytes(),
        predict_s,
        all: ErrorSummary::of(&all_e).expect("a data set has samples"),
        unseen: ErrorSummary::of(&unseen_e),
        samples,
    })
}

fn names(space: &crate::pose::PoseSpace) -> Vec<String> {
    space.params().iter().map(|p| p.name.clone()).collect()
}
