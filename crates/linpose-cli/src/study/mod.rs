//! The paper's study on one object: every method at the paper's training step, under query
//! noise, across training-set sizes (the overtraining question of section 4, with the linear
//! model's closed-form leave-one-out error beside its true unseen error), and the storage and
//! cost of Table 1 measured on the fitted models.
//!
//! `linpose experiment` (`cmd/experiment.rs`) renders or loads each object, runs
//! [`run_object`] (and [`normalization::run`], each method with and without the normalisation
//! stage) and writes the report; everything a figure or table shows is in the returned
//! [`ObjectResult`]. The study uses only the library's public API.

pub(crate) mod normalization;
pub(crate) mod recognition;
pub(crate) mod scenes;
pub(crate) mod table1;
pub(crate) mod three_params;
pub(crate) mod tuning;

use linpose::dataset::Dataset;
use linpose::eval::{evaluate, ConfidenceSummary, EvalOptions};
use linpose::manifest::TrainSelection;
use linpose::model::MethodSpec;
use linpose::model::{AnyModel, PoseModel};
use linpose::pose::ErrorSummary;
use linpose::Result;
use serde::{Deserialize, Serialize};

/// What to run on each object.
#[derive(Debug, Clone)]
pub(crate) struct StudyParams {
    /// The methods compared.
    pub methods: Vec<MethodSpec>,
    /// The main training step (the paper: 9 degrees).
    pub train_step: f64,
    /// Query noise amplitudes (fractions of full brightness; the paper: 0, 0.05, 0.10).
    pub noise: Vec<f64>,
    /// Training steps of the training-set-size sweep (degrees).
    pub size_steps: Vec<f64>,
    /// Seed of the query noise.
    pub seed: u64,
}

impl Default for StudyParams {
    fn default() -> Self {
        StudyParams {
            methods: linpose::methods::METHODS.iter().map(|m| m.default_spec()).collect(),
            train_step: 9.0,
            noise: vec![0.0, 0.05, 0.10],
            size_steps: vec![6.0, 9.0, 12.0, 18.0, 27.0],
            seed: 0,
        }
    }
}

/// A regular (elevation x azimuth) grid the samples lie on, for heat maps.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct Grid {
    /// Name of the row parameter and its values.
    pub rows: (String, Vec<f64>),
    /// Name of the column parameter and its values.
    pub cols: (String, Vec<f64>),
    /// For each sample, its (row, column) cell.
    pub cell: Vec<(usize, usize)>,
}

/// One method evaluated at the main training step under one noise level.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct Run {
    /// Method name.
    pub method: String,
    /// Noise amplitude.
    pub noise: f64,
    /// Training samples.
    pub n_train: usize,
    /// Evaluated samples.
    pub n_eval: usize,
    /// Bytes of the model's numbers.
    pub model_bytes: usize,
    /// Seconds to fit.
    pub fit_s: f64,
    /// Seconds to estimate all samples.
    pub predict_s: f64,
    /// Microseconds per query.
    pub per_query_us: f64,
    /// Errors over all samples.
    pub all: ErrorSummary,
    /// Errors over unseen samples.
    pub unseen: Option<ErrorSummary>,
    /// Each sample's error (degrees), in data set order.
    pub errors: Vec<f64>,
    /// Whether each sample was a training view.
    pub seen: Vec<bool>,
    /// Mean absolute error of each parameter over unseen samples (wrapped for circular ones),
    /// to tell which parameter a method gets wrong.
    pub param_mean_abs_err_deg: Vec<f64>,
    /// Fraction of unseen samples with an error above [`GROSS_ERROR_DEG`].
    pub gross_frac: f64,
    /// Each sample's confidence ([`linpose::confidence`]), in data set order.
    pub confidences: Vec<f64>,
    /// How well the confidence told the gross errors (flagged shares, reliability table).
    pub confidence: Option<ConfidenceSummary>,
}

/// An error above this many degrees counts as a gross failure (a wrong side, a lost parameter):
/// [`linpose::confidence::GROSS_DEG`].
pub(crate) const GROSS_ERROR_DEG: f64 = linpose::confidence::GROSS_DEG;

/// One method at one training-set size.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct SweepPoint {
    /// Method name.
    pub method: String,
    /// Training step (degrees).
    pub step: f64,
    /// Training samples.
    pub n_train: usize,
    /// Mean error over unseen samples (clean queries).
    pub unseen_mean_deg: f64,
    /// Mean error over all samples.
    pub all_mean_deg: f64,
    /// The linear model's exact leave-one-out mean error on its training set.
    pub loo_mean_deg: Option<f64>,
    /// The model's storage and time per query (on every view), for the Table 1 figure.
    #[serde(flatten)]
    pub cost: table1::Cost,
}

/// Table 1 of the paper, measured: storage and cost terms of one fitted model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct Table1Row {
    /// Method name.
    pub method: String,
    /// The paper's formula for storage and cost.
    pub formula: String,
    /// The formula's terms with their actual values.
    pub terms: Vec<(String, usize)>,
    /// The formula evaluated (numbers stored).
    pub formula_numbers: usize,
    /// Bytes the model actually stores to serve queries.
    pub model_bytes: usize,
    /// Measured microseconds per query.
    pub per_query_us: f64,
}

/// Everything measured on one object.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(crate) struct ObjectResult {
    /// Object name.
    pub name: String,
    /// Parameter names.
    pub params: Vec<String>,
    /// Image width and height.
    pub size: (u32, u32),
    /// Number of samples.
    pub n_samples: usize,
    /// All poses, row-major.
    pub poses: Vec<f64>,
    /// The grid, when the samples form a full two-parameter grid.
    pub grid: Option<Grid>,
    /// Each method under each noise level at the main step.
    pub runs: Vec<Run>,
    /// The training-set-size sweep.
    pub sweep: Vec<SweepPoint>,
    /// Table 1 rows, one per method.
    pub table1: Vec<Table1Row>,
    /// Each method with and without the normalisation stage ([`normalization::run`]); empty
    /// when the study did not ask.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub normalization: Vec<normalization::NormalizationRow>,
    /// The models fitted at the main step (not serialised into JSON; the CLI saves them).
    #[serde(skip)]
    pub models: Vec<AnyModel>,
}

/// Finds the full grid the samples lie on, if they do (two parameters, every combination once).
fn find_grid(data: &Dataset) -> Option<Grid> {
    let space = data.space();
    if space.len() != 2 {
        return None;
    }
    let (ri, ci) = match (space.index_of("elevation"), space.index_of("azimuth")) {
        (Some(e), Some(a)) => (e, a),
        _ => (0, 1),
    };
    let uniq = |j: usize| {
        let mut v: Vec<f64> = (0..data.len()).map(|i| data.pose(i)[j]).collect();
        v.sort_by(f64::total_cmp);
        v.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
        v
    };
    let (rows, cols) = (uniq(ri), uniq(ci));
    if rows.len() * cols.len() != data.len() {
        return None;
    }
    let find = |v: &[f64], x: f64| v.iter().position(|&y| (y - x).abs() < 1e-9);
    let mut seen = vec![false; data.len()];
    let mut cell = Vec::with_capacity(data.len());
    for i in 0..data.len() {
        let (r, c) = (find(&rows, data.pose(i)[ri])?, find(&cols, data.pose(i)[ci])?);
        if std::mem::replace(&mut seen[r * cols.len() + c], true) {
            return None;
        }
        cell.push((r, c));
    }
    let name = |j: usize| space.params()[j].name.clone();
    Some(Grid { rows: (name(ri), rows), cols: (name(ci), cols), cell })
}

/// The storage / cost terms of the paper's Table 1 for a fitted model.
fn table1_row(model: &AnyModel, per_query_us: f64) -> Table1Row {
    let storage = model.storage();
    Table1Row {
        method: model.meta().method.clone(),
        formula: model.method().storage.to_string(),
        terms: storage.terms,
        formula_numbers: storage.numbers,
        model_bytes: model.model_bytes(),
        per_query_us,
    }
}

/// |a - b| on a circle of the given period (the library's own wrapped difference, which is not
/// public: `linpose::pose`).
fn wrapped_diff(a: f64, b: f64, period: f64) -> f64 {
    let d = (a - b).rem_euclid(period);
    d.min(period - d)
}

/// Per-parameter mean absolute errors and the gross-error fraction over unseen samples.
fn param_errors(data: &Dataset, samples: &[linpose::eval::SampleResult]) -> (Vec<f64>, f64) {
    let params = data.space().params();
    let unseen: Vec<&linpose::eval::SampleResult> = samples.iter().filter(|s| !s.seen).collect();
    let n = unseen.len().max(1) as f64;
    let per = params
        .iter()
        .enumerate()
        .map(|(j, p)| {
            unseen
                .iter()
                .map(|s| match p.period {
                    Some(t) => wrapped_diff(s.r#true[j], s.estimated[j], t),
                    None => (s.r#true[j] - s.estimated[j]).abs(),
                })
                .sum::<f64>()
                / n
        })
        .collect();
    let gross = unseen.iter().filter(|s| s.error_deg > GROSS_ERROR_DEG).count() as f64 / n;
    (per, gross)
}

/// The method's exact leave-one-out mean error on `train`, where it has one in closed form.
fn loo_mean(method: &MethodSpec, train: &Dataset) -> Result<Option<f64>> {
    Ok(match method.leave_one_out(train).transpose()? {
        Some(loo) => {
            let k = train.space().len();
            let e: f64 = (0..train.len()).map(|i| train.space().error_deg(train.pose(i), &loo[i * k..(i + 1) * k])).sum();
            Some(e / train.len() as f64)
        }
        None => None,
    })
}

/// Runs the study on one object's full data set. `progress(stage)` is called as each stage
/// starts.
pub(crate) fn run_object(name: &str, data: &Dataset, p: &StudyParams, progress: &dyn Fn(&str)) -> Result<ObjectResult> {
    let mask = data.manifest().training_mask(&TrainSelection::Step(p.train_step))?;
    let train = data.subset(&mask)?;
    let mut runs = Vec::new();
    let mut table1 = Vec::new();
    let mut models = Vec::new();
    // Each method's clean evaluation at the main step, for the sweep's point at that step (the
    // same model on the same views: its errors are those of the clean run).
    let mut clean = Vec::new();
    for method in &p.methods {
        progress(&format!("{name}: {} fit", method.name()));
        let t0 = std::time::Instant::now();
        let model = method.fit(&train)?;
        let fit_s = t0.elapsed().as_secs_f64();
        for &noise in &p.noise {
            progress(&format!("{name}: {} eval, noise {noise}", method.name()));
            let r = evaluate(&model, data, &EvalOptions::new(noise, p.seed))?;
            let per_query_us = r.predict_s / r.n_eval as f64 * 1e6;
            if noise == 0.0 {
                table1.push(table1_row(&model, per_query_us));
                let cost = table1::Cost::of(&model, r.predict_s, r.n_eval);
                clean.push((models.len(), r.n_train, r.all.mean_deg, r.unseen.map_or(f64::NAN, |u| u.mean_deg), cost));
            }
            let (param_err, gross) = param_errors(data, &r.samples);
            runs.push(Run {
                method: r.method,
                noise,
                n_train: r.n_train,
                n_eval: r.n_eval,
                model_bytes: r.model_bytes,
                fit_s,
                predict_s: r.predict_s,
                per_query_us,
                all: r.all,
                unseen: r.unseen,
                errors: r.samples.iter().map(|s| s.error_deg).collect(),
                seen: r.samples.iter().map(|s| s.seen).collect(),
                param_mean_abs_err_deg: param_err,
                gross_frac: gross,
                confidences: r.samples.iter().map(|s| s.confidence.unwrap_or(f64::NAN)).collect(),
                confidence: r.confidence,
            });
        }
        models.push(model);
    }
    let mut sweep = Vec::new();
    for &step in &p.size_steps {
        let mask = data.manifest().training_mask(&TrainSelection::Step(step))?;
        let train = data.subset(&mask)?;
        for (i, method) in p.methods.iter().enumerate() {
            progress(&format!("{name}: {} with a {step}-degree training step", method.name()));
            // The main step: the model and its clean errors are the main run's.
            let shared = clean.iter().find(|c| c.0 == i).filter(|_| step == p.train_step);
            if let Some((_, n_train, all_mean_deg, unseen_mean_deg, cost)) = shared.cloned() {
                sweep.push(SweepPoint {
                    method: models[i].meta().method.clone(),
                    step,
                    n_train,
                    unseen_mean_deg,
                    all_mean_deg,
                    loo_mean_deg: loo_mean(method, &train)?,
                    cost,
                });
                continue;
            }
            let model = match method.fit(&train) {
                Ok(m) => m,
                // Too few samples for a method (e.g. an eigenspace wider than the set): skip the point.
                Err(linpose::Error::InvalidParameter { .. }) | Err(linpose::Error::Dataset { .. }) => continue,
                Err(e) => return Err(e),
            };
            let r = evaluate(&model, data, &EvalOptions { top: 0, ..EvalOptions::new(0.0, p.seed) })?;
            let loo_mean_deg = loo_mean(method, &train)?;
            let cost = table1::Cost::of(&model, r.predict_s, r.n_eval);
            sweep.push(SweepPoint {
                method: r.method,
                step,
                n_train: r.n_train,
                unseen_mean_deg: r.unseen.map_or(f64::NAN, |u| u.mean_deg),
                all_mean_deg: r.all.mean_deg,
                loo_mean_deg,
                cost,
            });
        }
    }
    Ok(ObjectResult {
        name: name.to_string(),
        params: data.space().params().iter().map(|q| q.name.clone()).collect(),
        size: (data.spec().width, data.spec().height),
        n_samples: data.len(),
        poses: data.poses().to_vec(),
        grid: find_grid(data),
        runs,
        sweep,
        table1,
        normalization: Vec::new(),
        models,
    })
}
