//! Whether to normalise: each method fitted on the registered training views as they are and
//! behind the normalisation stage ([`linpose::normalize`], position, scale and brightness), both
//! measured on the registered unseen views and, where the study has them, on the same views as a
//! camera would take them (moved, nearer or farther, brighter or darker: `synth --jitter`). The
//! report recommends the stage for a method when it costs at most [`REGISTERED_COST`] of the
//! accuracy on registered views, and says what it buys on the jittered ones.

use linpose::dataset::Dataset;
use linpose::eval::{evaluate_with, EvalOptions};
use linpose::manifest::TrainSelection;
use linpose::model::{AnyModel, PoseModel};
use linpose::normalize::{NormalizeParams, Normalized};
use linpose::{Error, Result};
use serde::{Deserialize, Serialize};

use super::StudyParams;

/// The largest share of accuracy on registered views the stage may cost and still be
/// recommended (0.10: the normalised unseen mean at most 1.1 times the plain one). Not tuned: the
/// bar issue 33 set, a cost a user who needs unregistered queries would accept.
pub const REGISTERED_COST: f64 = 0.10;

/// One method with and without the stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NormalizationRow {
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
    let r = evaluate_with(model, data, &EvalOptions { top: 0, ..EvalOptions::new(0.0, seed) })?;
    Ok((r.unseen.map_or(r.all.mean_deg, |u| u.mean_deg), r.rejected.len()))
}

/// Fits every method of `p` behind the stage on `data`'s training views and compares it with
/// `plain` (the same methods fitted without it, in the same order) on `data` and on `jittered`.
pub fn run(data: &Dataset, jittered: Option<&Dataset>, plain: &[AnyModel], p: &StudyParams, progress: &dyn Fn(&str)) -> Result<Vec<NormalizationRow>> {
    let mask = data.manifest().training_mask(&TrainSelection::Step(p.train_step))?;
    let train = data.subset(&mask)?;
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
    let mut rows = Vec::new();
    for (method, plain) in p.methods.iter().zip(plain) {
        progress(&format!("{} normalised", method.name()));
        let normalised = match Normalized::fit(method, &train, NormalizeParams { geometry: true, brightness: true }) {
            Ok(m) => m,
            // A training view the stage refuses: the study says so for this data set and goes on.
            Err(e @ Error::Normalize { .. }) => {
                rows.push(NormalizationRow {
                    method: plain.meta().method.clone(),
                    registered: [unseen_mean(plain, data, p.seed)?.0, f64::NAN],
                    jittered: None,
                    refused: 0,
                    n_jittered: 0,
                    recommended: false,
                    unavailable: Some(e.to_string()),
                });
                continue;
            }
            Err(e) => return Err(e),
        };
        let registered = [unseen_mean(plain, data, p.seed)?.0, unseen_mean(&normalised, data, p.seed)?.0];
        let (jittered_err, refused) = match jittered {
            Some(j) => {
                let (a, _) = unseen_mean(plain, j, p.seed)?;
                let (b, refused) = unseen_mean(&normalised, j, p.seed)?;
                (Some([a, b]), refused)
            }
            None => (None, 0),
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
