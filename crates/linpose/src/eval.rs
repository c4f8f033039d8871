//! Evaluation: estimate every sample of a data set, optionally under pixel noise, and measure the
//! error of docs/method.md over all samples and over the unseen ones; and how well the model's
//! confidence ([`crate::confidence`]) tells its gross errors: the share of views flagged, the
//! share of gross errors flagged, whether the truth was among the top hypotheses, and a
//! reliability table of confidence bins against error.

use crate::confidence::{Estimate, Hypothesis, FLAG_BELOW, GROSS_DEG};
use crate::dataset::Dataset;
use crate::model::PoseModel;
use crate::pose::ErrorSummary;
use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use std::time::Instant;

use crate::pixel_noise::add_uniform_noise;

/// One evaluated sample.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SampleResult {
    /// Image path as in the manifest.
    pub image: String,
    /// True pose (degrees).
    pub r#true: Vec<f64>,
    /// Estimated pose (degrees).
    pub estimated: Vec<f64>,
    /// Pose error (degrees; [`crate::PoseSpace::error_deg`]).
    pub error_deg: f64,
    /// Each parameter's own error (degrees, in the order of the report's `params`;
    /// [`crate::PoseSpace::param_errors_deg`]).
    #[serde(default)]
    pub param_errors_deg: Vec<f64>,
    /// Whether the pose is one of the model's training poses.
    pub seen: bool,
    /// The model's confidence in the estimate, in [0, 1] (absent when not asked for).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub confidence: Option<f64>,
    /// Whether the confidence is under the report's `flag_below`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flagged: Option<bool>,
    /// The ranked hypotheses, the estimate first (at most the report's `top`).
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub hypotheses: Vec<Hypothesis>,
    /// Whether one of `hypotheses` is within [`GROSS_DEG`] of the true pose.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub in_top: Option<bool>,
    /// For an image larger than the training views, where the object was found: the box of the
    /// training view's frame (left, top, width, height, pixels; [`crate::model::Located`]).
    #[serde(skip_serializing_if = "Option::is_none", default, rename = "box")]
    pub bbox: Option<[f64; 4]>,
    /// For an image larger than the training views, the share of the object's pixels the
    /// estimate used ([`crate::model::Located::shown`]).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub shown: Option<f64>,
}

/// A sample with no estimate: refused by the model's normalisation stage, or by the model
/// itself (an all-black image, which cannot be scaled to unit energy).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Rejected {
    /// Image path as in the manifest.
    pub image: String,
    /// Why it was refused.
    pub reason: String,
}

/// How to evaluate: the query noise and whether (and how) to ask for confidence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EvalOptions {
    /// Uniform noise of +-`noise` (a fraction of full brightness) added to every query (0: none).
    pub noise: f64,
    /// The noise's seed.
    pub seed: u64,
    /// Hypotheses kept per sample; 0 asks for no confidence at all (the estimates alone).
    pub top: usize,
    /// The confidence under which an estimate is flagged.
    pub flag_below: f64,
}

impl EvalOptions {
    /// Noise +-`noise` from `seed`, the top 3 hypotheses, flagged under [`FLAG_BELOW`].
    pub fn new(noise: f64, seed: u64) -> Self {
        EvalOptions { noise, seed, top: 3, flag_below: FLAG_BELOW }
    }
}

/// One bin of a reliability table: the views whose confidence fell in [lo, hi).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReliabilityBin {
    /// Lower end of the bin.
    pub lo: f64,
    /// Upper end (the last bin includes 1).
    pub hi: f64,
    /// Views in it.
    pub n: usize,
    /// Their mean error (degrees; NaN, written null, for an empty bin).
    pub mean_error_deg: f64,
    /// The share of them with an error over [`GROSS_DEG`] (NaN, written null, for an empty bin).
    pub gross_share: f64,
}

/// How well the confidence tells the gross errors, over the unseen views (all views when every
/// one is a training view).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ConfidenceSummary {
    /// "unseen" or "all": the views these figures are over.
    pub over: String,
    /// Views counted.
    pub n: usize,
    /// How many of them have an error over [`GROSS_DEG`].
    pub gross: usize,
    /// How many of them were flagged.
    pub flagged: usize,
    /// How many of the gross errors were flagged.
    pub gross_flagged: usize,
    /// The share of them with an error over [`GROSS_DEG`].
    pub gross_share: f64,
    /// The share of the gross errors that were flagged (1 when there is none).
    pub gross_flagged_share: f64,
    /// The share of all of them flagged.
    pub flagged_share: f64,
    /// The share whose true pose is within [`GROSS_DEG`] of one of the top hypotheses.
    pub in_top_share: f64,
    /// Confidence bins [0, 0.5), [0.5, 0.6), [0.6, 0.75), [0.75, 0.9), [0.9, 0.99), [0.99, 1]
    /// against error.
    pub reliability: Vec<ReliabilityBin>,
}

/// The reliability table's bin edges.
const BINS: [f64; 7] = [0.0, 0.5, 0.6, 0.75, 0.9, 0.99, 1.0];

impl ConfidenceSummary {
    /// The summary of `samples` (each with a confidence) over `over`.
    fn of(samples: &[&SampleResult], over: &str) -> Option<Self> {
        let n = samples.len();
        if n == 0 || samples.iter().any(|s| s.confidence.is_none()) {
            return None;
        }
        let share = |k: usize, of: usize| if of == 0 { 1.0 } else { k as f64 / of as f64 };
        let gross: Vec<&&SampleResult> = samples.iter().filter(|s| s.error_deg > GROSS_DEG).collect();
        let flagged = samples.iter().filter(|s| s.flagged == Some(true)).count();
        let gross_flagged = gross.iter().filter(|s| s.flagged == Some(true)).count();
        let reliability = BINS
            .windows(2)
            .enumerate()
            .map(|(b, w)| {
                let last = b == BINS.len() - 2;
                let inside: Vec<&&SampleResult> = samples
                    .iter()
                    .filter(|s| {
                        let c = s.confidence.unwrap_or(0.0);
                        c >= w[0] && (c < w[1] || last)
                    })
                    .collect();
                let k = inside.len();
                ReliabilityBin {
                    lo: w[0],
                    hi: w[1],
                    n: k,
                    mean_error_deg: if k == 0 { f64::NAN } else { inside.iter().map(|s| s.error_deg).sum::<f64>() / k as f64 },
                    gross_share: if k == 0 { f64::NAN } else { share(inside.iter().filter(|s| s.error_deg > GROSS_DEG).count(), k) },
                }
            })
            .collect();
        Some(ConfidenceSummary {
            over: over.to_string(),
            n,
            gross: gross.len(),
            flagged,
            gross_flagged,
            gross_share: share(gross.len(), n),
            gross_flagged_share: share(gross_flagged, gross.len()),
            flagged_share: share(flagged, n),
            in_top_share: share(samples.iter().filter(|s| s.in_top == Some(true)).count(), n),
            reliability,
        })
    }
}

/// The outcome of an evaluation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EvalReport {
    /// The model's method.
    pub method: String,
    /// Parameter names, in the order of each pose.
    pub params: Vec<String>,
    /// Samples evaluated (the data set's, less those refused).
    pub n_eval: usize,
    /// The samples with no estimate, with why (refused by the model's normalisation stage,
    /// [`crate::normalize`], or by the model): counted apart, in no error figure.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub rejected: Vec<Rejected>,
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
    /// Each parameter's own errors over all samples, in the order of `params`.
    #[serde(default)]
    pub param_all: Vec<ErrorSummary>,
    /// Each parameter's own errors over the unseen samples (absent when all are seen).
    #[serde(default)]
    pub param_unseen: Option<Vec<ErrorSummary>>,
    /// Hypotheses kept per sample (0: no confidence asked for).
    pub top: usize,
    /// The confidence under which a sample is flagged.
    pub flag_below: f64,
    /// The share of the views (unseen, or all when every one is seen) flagged
    /// ([`ConfidenceSummary::flagged_share`]; absent without confidence).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flagged_share: Option<f64>,
    /// The share of their gross errors flagged ([`ConfidenceSummary::gross_flagged_share`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gross_flagged_share: Option<f64>,
    /// The confidence's figures in full.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub confidence: Option<ConfidenceSummary>,
    /// Every sample.
    pub samples: Vec<SampleResult>,
}

/// Estimates every sample of `data` with `model` as `opt` says (`EvalOptions::new(noise, seed)`:
/// uniform noise of +-`noise` added to the queries, 0 for none, from `seed`).
pub fn evaluate(model: &dyn PoseModel, data: &Dataset, opt: &EvalOptions) -> Result<EvalReport> {
    let (noise, seed) = (opt.noise, opt.seed);
    if !(opt.flag_below.is_finite() && (0.0..=1.0).contains(&opt.flag_below)) {
        return Err(Error::invalid("flag threshold", opt.flag_below, "must be a confidence in [0, 1]"));
    }
    let meta = model.meta();
    let got = data.spec();
    let larger = got.width >= meta.spec.width && got.height >= meta.spec.height && (got.width, got.height) != (meta.spec.width, meta.spec.height);
    let search = if larger { model.scene_search() } else { None };
    if (got.width, got.height) != (meta.spec.width, meta.spec.height) && search.is_none() {
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
    let mut queries;
    let q: &[f32] = if noise > 0.0 {
        queries = data.features().to_vec();
        add_uniform_noise(&mut queries, got.features(), noise, seed)?;
        &queries
    } else {
        add_uniform_noise(&mut [], got.features(), noise, seed)?;
        data.features()
    };
    if let Some(search) = search {
        return evaluate_scenes(model, search, data, q, opt);
    }
    let m = meta.spec.features();
    let model_bytes = model.model_bytes();
    // Images the model's normalisation stage refuses are counted apart, not estimated; the
    // others are normalised once and given to the method's own model.
    let normalised;
    let mut stage_s = 0.0;
    let (model, q, refused): (&dyn PoseModel, &[f32], Vec<Option<String>>) = match model.behind_stage() {
        Some((stage, inner)) => {
            let t0 = Instant::now();
            let (rows, verdicts) = stage.apply_batch(q);
            stage_s = t0.elapsed().as_secs_f64();
            normalised = rows;
            (inner, &normalised, verdicts.into_iter().map(|v| v.map(|r| r.to_string())).collect())
        }
        None => (model, q, vec![None; data.len()]),
    };
    let kept: Vec<usize> = (0..data.len()).filter(|&i| refused[i].is_none()).collect();
    let mut rejected: Vec<(usize, Rejected)> =
        (0..data.len()).filter_map(|i| refused[i].clone().map(|reason| (i, Rejected { image: data.manifest().images()[i].clone(), reason }))).collect();
    if kept.is_empty() {
        return Err(Error::Dataset {
            path: data.manifest().image_path(0),
            message: format!("the model's normalisation refuses every image of the data set, the first: {}", rejected[0].1.reason),
        });
    }
    let t0 = Instant::now();
    // Some query the model refuses (an all-black image cannot be scaled): counted apart with why.
    let Answered { ok, refused, est } =
        answer_each(kept.len(), |rows| if rows.len() == kept.len() { model.predict(q) } else { model.predict(&crate::dataset::rows_at(q, m, rows)) })?;
    let usable;
    let q = if refused.is_empty() {
        q
    } else {
        usable = crate::dataset::rows_at(q, m, &ok);
        &usable[..]
    };
    rejected.extend(refused.into_iter().map(|(i, reason)| (kept[i], Rejected { image: data.manifest().images()[kept[i]].clone(), reason })));
    let kept: Vec<usize> = ok.iter().map(|&i| kept[i]).collect();
    rejected.sort_by_key(|r| r.0);
    let rejected: Vec<Rejected> = rejected.into_iter().map(|r| r.1).collect();
    // The normalisation is part of each query's cost.
    let predict_s = t0.elapsed().as_secs_f64() + stage_s;
    let estimates: Option<Vec<Estimate>> = if opt.top > 0 { Some(model.estimate(q, opt.top)?) } else { None };
    Ok(report(Outcome { model, data, opt, kept, est, estimates, located: None, rejected, model_bytes, predict_s }))
}

/// What [`report`] makes the report of.
struct Outcome<'a> {
    model: &'a dyn PoseModel,
    data: &'a Dataset,
    opt: &'a EvalOptions,
    /// The samples estimated, in the data set's order.
    kept: Vec<usize>,
    /// Their poses, row by row, and their estimates (when confidence was asked for).
    est: Vec<f64>,
    estimates: Option<Vec<Estimate>>,
    /// Where each was found in its scene (images larger than the training views).
    located: Option<Vec<crate::model::Located>>,
    rejected: Vec<Rejected>,
    model_bytes: usize,
    predict_s: f64,
}

/// The report of an evaluation's estimates.
fn report(o: Outcome<'_>) -> EvalReport {
    let Outcome { model, data, opt, kept, est, estimates, located, rejected, model_bytes, predict_s } = o;
    let (noise, seed) = (opt.noise, opt.seed);
    let meta = model.meta();
    let p = meta.space.len();
    let samples: Vec<SampleResult> = kept
        .iter()
        .enumerate()
        .map(|(i, &k)| {
            let truth = data.pose(k);
            let e = &est[i * p..(i + 1) * p];
            let h = estimates.as_ref().map(|v| &v[i]);
            SampleResult {
                image: data.manifest().images()[k].clone(),
                r#true: truth.to_vec(),
                estimated: e.to_vec(),
                error_deg: meta.space.error_deg(truth, e),
                param_errors_deg: meta.space.param_errors_deg(truth, e),
                seen: meta.is_seen(truth),
                confidence: h.map(|h| h.confidence),
                flagged: h.map(|h| h.flagged(opt.flag_below)),
                hypotheses: h.map(|h| h.hypotheses.clone()).unwrap_or_default(),
                in_top: h.map(|h| h.hypotheses.iter().any(|k| meta.space.error_deg(truth, &k.pose) <= GROSS_DEG)),
                bbox: located.as_ref().map(|l| l[i].bbox),
                shown: located.as_ref().map(|l| l[i].shown),
            }
        })
        .collect();
    let unseen: Vec<&SampleResult> = samples.iter().filter(|s| !s.seen).collect();
    let confidence = match unseen.is_empty() {
        false => ConfidenceSummary::of(&unseen, "unseen"),
        true => ConfidenceSummary::of(&samples.iter().collect::<Vec<_>>(), "all"),
    };
    let all_e: Vec<f64> = samples.iter().map(|s| s.error_deg).collect();
    let unseen_e: Vec<f64> = samples.iter().filter(|s| !s.seen).map(|s| s.error_deg).collect();
    EvalReport {
        method: meta.method.clone(),
        params: names(&meta.space),
        n_eval: samples.len(),
        rejected,
        n_train: meta.n_train(),
        noise,
        seed,
        model_bytes,
        predict_s,
        all: ErrorSummary::of(&all_e).expect("a data set has samples"),
        unseen: ErrorSummary::of(&unseen_e),
        param_all: per_param(samples.iter(), p).expect("a data set has samples"),
        param_unseen: per_param(samples.iter().filter(|s| !s.seen), p),
        top: opt.top,
        flag_below: opt.flag_below,
        flagged_share: confidence.as_ref().map(|c| c.flagged_share),
        gross_flagged_share: confidence.as_ref().map(|c| c.gross_flagged_share),
        confidence,
        samples,
    }
}

/// [`evaluate`] of images larger than the training views, `q` (the data set's, with its noise):
/// the object found in each by `search`, the located queries estimated by the method's own
/// model. A scene the search refuses is counted apart with why.
fn evaluate_scenes(model: &dyn PoseModel, search: &dyn crate::model::SceneSearch, data: &Dataset, q: &[f32], opt: &EvalOptions) -> Result<EvalReport> {
    let spec = data.spec();
    let m = spec.features();
    let t0 = Instant::now();
    let (mut kept, mut found, mut rejected) = (Vec::new(), Vec::new(), Vec::new());
    match search.locate(q, spec) {
        Ok(f) => {
            kept = (0..data.len()).collect();
            found = f;
        }
        Err(first) => {
            for i in 0..data.len() {
                match search.locate(&q[i * m..(i + 1) * m], spec) {
                    Ok(mut f) => {
                        kept.push(i);
                        found.append(&mut f);
                    }
                    Err(e) => rejected.push((i, e.to_string())),
                }
            }
            if kept.is_empty() {
                return Err(first);
            }
        }
    }
    // A located view the method refuses (a box of a black scene cannot be scaled): counted
    // apart with why.
    let Answered { ok, refused, est } = answer_each(found.len(), |rows| {
        if rows.len() == found.len() {
            search.predict_located(&found)
        } else {
            search.predict_located(&rows.iter().map(|&i| found[i].clone()).collect::<Vec<_>>())
        }
    })?;
    if !refused.is_empty() {
        rejected.extend(refused.into_iter().map(|(i, reason)| (kept[i], reason)));
        let mut answered = vec![false; found.len()];
        ok.iter().for_each(|&i| answered[i] = true);
        found = found.into_iter().zip(answered).filter_map(|(f, a)| a.then_some(f)).collect();
        kept = ok.iter().map(|&i| kept[i]).collect();
    }
    rejected.sort_by_key(|r| r.0);
    let rejected = rejected.into_iter().map(|(i, reason)| Rejected { image: data.manifest().images()[i].clone(), reason }).collect();
    let predict_s = t0.elapsed().as_secs_f64();
    let estimates = if opt.top > 0 { Some(search.estimate_located(&found, opt.top)?) } else { None };
    let model_bytes = model.model_bytes();
    Ok(report(Outcome { model, data, opt, kept, est, estimates, located: Some(found), rejected, model_bytes, predict_s }))
}

/// What [`answer_each`] gives: the places answered, those refused with why, and the estimates
/// (rows of P) of those answered.
struct Answered {
    ok: Vec<usize>,
    refused: Vec<(usize, String)>,
    est: Vec<f64>,
}

/// The estimates (rows of P) of the items `0..n` of a batch by `predict`, which answers the
/// items at the places it is given together: when the whole batch fails, each item alone, those
/// refused set apart with why, and the others answered together as they would be without them
/// (an item's estimate does not depend on its batch); the batch's error when every item is
/// refused.
fn answer_each(n: usize, predict: impl Fn(&[usize]) -> Result<Vec<f64>>) -> Result<Answered> {
    let all: Vec<usize> = (0..n).collect();
    let first = match predict(&all) {
        Ok(est) => return Ok(Answered { ok: all, refused: Vec::new(), est }),
        Err(e) => e,
    };
    let (mut ok, mut refused) = (Vec::new(), Vec::new());
    for i in 0..n {
        match predict(&[i]) {
            Ok(_) => ok.push(i),
            // Alone, the item is the batch's only row: why, without the row.
            Err(Error::InvalidParameter { name: "query", reason, .. }) => refused.push((i, reason)),
            Err(Error::Normalize { reason, .. }) => refused.push((i, format!("cannot normalise: {reason}"))),
            Err(e) => refused.push((i, e.to_string())),
        }
    }
    if ok.is_empty() {
        return Err(first);
    }
    let est = predict(&ok)?;
    Ok(Answered { ok, refused, est })
}

/// Each parameter's error summary over `samples` (`None` when there are none).
fn per_param<'a>(samples: impl Iterator<Item = &'a SampleResult> + Clone, p: usize) -> Option<Vec<ErrorSummary>> {
    (0..p).map(|j| ErrorSummary::of(&samples.clone().map(|s| s.param_errors_deg[j]).collect::<Vec<_>>())).collect()
}

fn names(space: &crate::pose::PoseSpace) -> Vec<String> {
    space.params().iter().map(|p| p.name.clone()).collect()
}
