//! Whether to normalise: each method fitted on the registered training views as they are and
//! behind the normalisation stage ([`linpose::normalize`], position, scale and brightness), both
//! measured on the registered unseen views and, where the study has them, on the same views as a
//! camera would take them (moved, nearer or farther, brighter or darker: `synth --jitter`). The
//! report recommends the stage for a method when it costs at most [`REGISTERED_COST`] of the
//! accuracy on registered views, and says what it buys on the jittered ones.

use linpose::dataset::Dataset;
use linpose::eval::{evaluate, EvalOptions};
use linpose::manifest::TrainSelection;
use linpose::model::Normalized;
use linpose::model::{AnyModel, PoseModel};
use linpose::normalize::{NormalizeParams, Normalizer};
use linpose::{Error, Result};
use serde::{Deserialize, Serialize};

use super::tuning::REGISTERED_COST;
use super::StudyParams;

/// One method with and without the stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct NormalizationRow {
    /// The method.
    pub method: String,
    /// Unseen mean error on the registered views, without and with the stage (degrees).
    pub registered: [f64; 2],
    /// Unseen mean error on the jittered views, without and with the stage (degrees), when the
    /// study has them.
    pub jittered: Option<[f64; 2]>,
    /// Jittered unseen views the stage refused (counted apart, not in `jittered`).
    pub refused: usize,
    /// Jittered unseen views in all.
    pub n_jittered: usize,
    /// Whether the report recommends the stage: it costs at most [`REGISTERED_COST`] on
    /// registered views.
    pub recommended: bool,
    /// Why the stage could not be fitted (a training view it refuses), when it could not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unavailable: Option<String>,
}

/// The unseen mean error of `model` on `data` (no confidence asked), and how many views were
/// refused.
fn unseen_mean(model: &AnyModel, data: &Dataset, seed: u64) -> Result<(f64, usize)> {
    let r = evaluate(model, data, &EvalOptions { top: 0, ..EvalOptions::new(0.0, seed) })?;
    Ok((r.unseen.map_or(r.all.mean_deg, |u| u.mean_deg), r.rejected.len()))
}

/// Views normalised by a stage once for every method behind it: the views it accepts, as a data
/// set (none when it refuses them all), and how many it refused.
struct NormalisedViews {
    kept: Option<Dataset>,
    refused: usize,
}

impl NormalisedViews {
    /// What evaluating a model behind `stage` on `d` normalises: the same rows, in order.
    fn of(stage: &Normalizer, d: &Dataset) -> Result<Self> {
        let (rows, verdicts) = stage.apply_batch(d.features());
        let keep: Vec<bool> = verdicts.iter().map(Option::is_none).collect();
        let refused = keep.iter().filter(|&&k| !k).count();
        let kept = match refused {
            0 => Some(Dataset::from_features(d.manifest().clone(), d.spec(), rows)?),
            r if r == d.len() => None,
            _ => Some(Dataset::from_features(d.subset(&keep)?.manifest().clone(), d.spec(), rows)?),
        };
        Ok(NormalisedViews { kept, refused })
    }

    /// The unseen mean error of `inner` (fitted behind `stage`) on the views, and how many the
    /// stage refused: what [`unseen_mean`] of the model behind the stage on the views gives.
    fn unseen_mean(&self, stage: &Normalizer, inner: &AnyModel, d: &Dataset, seed: u64) -> Result<(f64, usize)> {
        match &self.kept {
            Some(k) => Ok((unseen_mean(inner, k, seed)?.0, self.refused)),
            // Every view refused: the evaluation's own error.
            None => unseen_mean(&AnyModel::new(Normalized::new(stage.clone(), inner.clone())), d, seed),
        }
    }
}

/// Fits every method of `p` behind the stage on `data`'s training views and compares it with
/// `plain` (the same methods fitted without it, in the same order) on `data` and on `jittered`
/// (its unseen views: `jittered` may be the views of a coarser grid). `plain_registered[i]`, when
/// given, is `plain[i]`'s unseen mean error on `data` already measured (the study's clean run:
/// the same model on the same views), else it is measured here.
pub(crate) fn run(
    data: &Dataset,
    jittered: Option<&Dataset>,
    plain: &[AnyModel],
    plain_registered: Option<&[f64]>,
    p: &StudyParams,
    progress: &dyn Fn(&str),
) -> Result<Vec<NormalizationRow>> {
    let mask = data.manifest().training_mask(&TrainSelection::Step(p.train_step))?;
    let train = data.subset(&mask)?;
    // The stage depends on the training views alone: fitted, and the training views normalised,
    // once for all the methods (what `Normalized::fit` does for each). A training view the stage
    // refuses: the study says so for this data set and goes on.
    let stage = match Normalizer::fit(&train, NormalizeParams { geometry: true, brightness: true }).and_then(|s| Ok((s.apply_dataset(&train)?, s))) {
        Ok(s) => Ok(s),
        Err(e @ Error::Normalize { .. }) => Err(e.to_string()),
        Err(e) => return Err(e),
    };
    // Only the unseen views are measured, so only they are estimated.
    let unseen_of = |d: &Dataset| -> Result<Dataset> {
        let m = d.manifest().training_mask(&TrainSelection::Step(p.train_step))?;
        match m.iter().all(|&t| t) {
            true => Ok(d.clone()),
            false => d.subset(&m.iter().map(|&t| !t).collect::<Vec<_>>()),
        }
    };
    let data = &unseen_of(data)?;
    let jittered = jittered.map(unseen_of).transpose()?;
    let jittered = jittered.as_ref();
    // The views normalised once for all the methods (each method's evaluation behind the stage
    // normalises the same rows the same way).
    let views = match &stage {
        Ok((_, s)) => Some((NormalisedViews::of(s, data)?, jittered.map(|j| NormalisedViews::of(s, j)).transpose()?)),
        Err(_) => None,
    };
    let mut rows = Vec::new();
    for (i, (method, plain)) in p.methods.iter().zip(plain).enumerate() {
        progress(&format!("{} normalised", method.name()));
        let plain_mean = |d: &Dataset| -> Result<f64> {
            match plain_registered {
                Some(v) => Ok(v[i]),
                None => Ok(unseen_mean(plain, d, p.seed)?.0),
            }
        };
        let fitted = match (&stage, &views) {
            (Ok((normalised, s)), Some(v)) => match method.fit(normalised) {
                Ok(inner) => Ok((s, inner, v)),
                Err(e @ Error::Normalize { .. }) => Err(e.to_string()),
                Err(e) => return Err(e),
            },
            (Err(why), _) => Err(why.clone()),
            (Ok(_), None) => unreachable!("views are normalised whenever the stage is fitted"),
        };
        let (stage, inner, (registered_views, jittered_views)) = match fitted {
            Ok(m) => m,
            Err(why) => {
                rows.push(NormalizationRow {
                    method: plain.meta().method.clone(),
                    registered: [plain_mean(data)?, f64::NAN],
                    jittered: None,
                    refused: 0,
                    n_jittered: 0,
                    recommended: false,
                    unavailable: Some(why),
                });
                continue;
            }
        };
        let registered = [plain_mean(data)?, registered_views.unseen_mean(stage, &inner, data, p.seed)?.0];
        let (jittered_err, refused) = match (jittered, jittered_views) {
            (Some(j), Some(jv)) => {
                let (a, _) = unseen_mean(plain, j, p.seed)?;
                let (b, refused) = jv.unseen_mean(stage, &inner, j, p.seed)?;
                (Some([a, b]), refused)
            }
            _ => (None, 0),
        };
        rows.push(NormalizationRow {
            method: plain.meta().method.clone(),
            registered,
            jittered: jittered_err,
            refused,
            n_jittered: jittered.map_or(0, Dataset::len),
            recommended: registered[1] <= (1.0 + REGISTERED_COST) * registered[0],
            unavailable: None,
        });
    }
    Ok(rows)
}
