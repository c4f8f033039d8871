//! Table 1 against the number of training views: each method's storage (the bytes it serves
//! queries from, and its Table 1 formula's terms) and time per query, measured on models fitted
//! on nested training sets of one, two and three pose parameters, for the report's log-log
//! figure beside the paper's formulas (M K for the linear model, N L + M L for the eigenspace).
//!
//! The points of two parameters are the size sweep's ([`super::run_object`]: its models are
//! fitted anyway); those of one parameter are fitted here on a ring of the first object's views
//! ([`ring`]: one elevation, azimuth alone), those of three on sub-lattices of the
//! three-parameter study's training lattice ([`super::three_params`]). Storage is exact; the
//! time per query is the wall time of estimating the evaluated views, batched, divided by their
//! number, as everywhere in the study.

use super::tuning::{TIMING_BUDGET_S, TIMING_REPEATS};
use linpose::dataset::Dataset;
use linpose::manifest::Manifest;
use linpose::model::{AnyModel, MethodSpec, Origin, PoseModel};
use linpose::pose::PoseSpace;
use linpose::Result;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// What a fitted model costs: its storage and its time per query.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct Cost {
    /// Bytes the model stores to serve queries ([`PoseModel::model_bytes`]).
    pub model_bytes: usize,
    /// The terms of the method's Table 1 formula with their values ([`PoseModel::storage`]).
    pub terms: Vec<(String, usize)>,
    /// The method's own formula evaluated (numbers stored).
    pub formula_numbers: usize,
    /// Measured microseconds per query.
    pub per_query_us: f64,
}

impl Cost {
    /// The cost of `model`, whose estimation of `n_eval` views took `predict_s` seconds.
    pub(crate) fn of(model: &AnyModel, predict_s: f64, n_eval: usize) -> Cost {
        let storage = model.storage();
        Cost { model_bytes: model.model_bytes(), terms: storage.terms, formula_numbers: storage.numbers, per_query_us: predict_s / n_eval.max(1) as f64 * 1e6 }
    }

    /// The value of the formula's term `name`.
    fn term(&self, name: &str) -> Option<usize> {
        self.terms.iter().find(|(k, _)| k == name).map(|t| t.1)
    }
}

/// One method fitted on one training set, for the figure.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct SizePoint {
    /// The object.
    pub object: String,
    /// Pose parameters of the data set (1, 2 or 3).
    pub params: usize,
    /// Method name.
    pub method: String,
    /// Training views.
    pub n_train: usize,
    /// Storage and time per query.
    #[serde(flatten)]
    pub cost: Cost,
}

impl SizePoint {
    /// The paper's Table 1 storage of the point's model, numbers: M K for the paper's method,
    /// N L + M L for its baseline (N the manifold's points, L its dimensions, M the pixels),
    /// with the model's own terms; none for a method beyond the paper.
    pub(crate) fn paper_numbers(&self) -> Option<usize> {
        let t = |n: &str| self.cost.term(n);
        match linpose::Method::from_name(&self.method).ok()?.origin {
            Origin::Paper => Some(t("M")? * t("K")?),
            Origin::Baseline => Some((t("N")? + t("M")?) * t("L")?),
            Origin::Beyond => None,
        }
    }
}

/// The one-parameter ring of a two-parameter data set: the views at the smallest value of the
/// parameter other than the circular one (the lowest elevation), with that parameter dropped.
/// None when the data set has not two parameters, one of them circular.
pub(crate) fn ring(data: &Dataset) -> Result<Option<Dataset>> {
    let params = data.space().params();
    let Some(keep) = params.iter().position(|p| p.period.is_some()).filter(|_| params.len() == 2) else { return Ok(None) };
    let fixed = 1 - keep;
    let lowest = (0..data.len()).map(|i| data.pose(i)[fixed]).fold(f64::INFINITY, f64::min);
    let mask: Vec<bool> = (0..data.len()).map(|i| data.pose(i)[fixed] == lowest).collect();
    let sub = data.subset(&mask)?;
    let poses: Vec<f64> = (0..sub.len()).map(|i| sub.pose(i)[keep]).collect();
    let space = PoseSpace::new(vec![params[keep].clone()])?;
    let manifest = Manifest::new(sub.manifest().root(), space, sub.manifest().images().to_vec(), poses)?;
    Dataset::from_features(manifest, sub.spec(), sub.features().to_vec()).map(Some)
}

/// The least wall time of estimating every view of `data` with `model`, batched, over up to
/// [`TIMING_REPEATS`] runs within [`TIMING_BUDGET_S`] (seconds).
pub(crate) fn predict_s(model: &AnyModel, data: &Dataset) -> Result<f64> {
    let (mut best, start) = (f64::INFINITY, Instant::now());
    for _ in 0..TIMING_REPEATS {
        let t = Instant::now();
        model.predict(data.features())?;
        best = best.min(t.elapsed().as_secs_f64());
        if start.elapsed().as_secs_f64() > TIMING_BUDGET_S {
            break;
        }
    }
    Ok(best)
}

/// What [`sizes`] fits and where it measures.
pub(crate) struct Sizes<'a> {
    /// The object's name.
    pub object: &'a str,
    /// The data set the training sets are drawn from.
    pub data: &'a Dataset,
    /// The training sets, as masks over `data`.
    pub trainings: &'a [Vec<bool>],
    /// The methods.
    pub methods: &'a [MethodSpec],
    /// The views whose estimation is timed.
    pub timed: &'a Dataset,
}

/// Every method fitted on every training set of `s`: its storage, and its time per query on the
/// timed views. A training set too small for a method (an eigenspace wider than the set) gives
/// no point, as in the size sweep. The time is the least of a few runs ([`predict_s`]): a fit's
/// estimations are few and short, and a single run's time is mostly noise.
pub(crate) fn sizes(s: &Sizes<'_>, progress: &dyn Fn(&str)) -> Result<Vec<SizePoint>> {
    let mut points = Vec::new();
    for mask in s.trainings {
        let train = s.data.subset(mask)?;
        for method in s.methods {
            progress(&format!("{}: {} on {} views", s.object, method.name(), train.len()));
            let model = match method.fit(&train) {
                Ok(m) => m,
                Err(linpose::Error::InvalidParameter { .. }) | Err(linpose::Error::Dataset { .. }) => continue,
                Err(e) => return Err(e),
            };
            let meta = model.meta();
            points.push(SizePoint {
                object: s.object.to_string(),
                params: s.data.space().len(),
                method: meta.method.clone(),
                n_train: meta.n_train(),
                cost: Cost::of(&model, predict_s(&model, s.timed)?, s.timed.len()),
            });
        }
    }
    Ok(points)
}

/// The size sweep's points of an object ([`super::run_object`]), as the figure's.
pub(crate) fn from_sweep(o: &super::ObjectResult) -> Vec<SizePoint> {
    o.sweep
        .iter()
        .map(|p| SizePoint { object: o.name.clone(), params: o.params.len(), method: p.method.clone(), n_train: p.n_train, cost: p.cost.clone() })
        .collect()
}
