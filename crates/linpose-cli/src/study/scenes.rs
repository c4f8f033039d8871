//! Scenes: each method trained on an object's studio views, plain and behind the robust stage
//! ([`linpose::robust::Robust`]), and measured on unseen views of the object over a cluttered
//! background and partly hidden by occluders (`synth --background --occlude`): the unseen error,
//! the gross errors and the share the confidence flags, plain against robust, for each
//! background and hidden share, and what the stage costs (its training time, its bytes, the
//! time per query).
//!
//! The caller makes the scene views (the experiment renders them: [`SceneViews`]); the robust
//! stage is fitted on the same training views as the plain models, in front of each plain model
//! as it is, so the two differ by the stage alone.

use super::GROSS_ERROR_DEG;
use linpose::dataset::Dataset;
use linpose::eval::{evaluate, EvalOptions, EvalReport};
use linpose::model::{AnyModel, PoseModel};
use linpose::robust::Robust;
use linpose::Result;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// What stands behind the object in a scene of the study.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub(crate) enum Backdrop {
    /// The training views' own backdrop (black): occluders only.
    Studio,
    /// Procedural clutter (`--background texture`).
    Texture,
    /// Independent pixel noise (`--background noise`).
    Noise,
}

impl Backdrop {
    /// The name the report and `synth --background` use.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Backdrop::Studio => "studio",
            Backdrop::Texture => "texture",
            Backdrop::Noise => "noise",
        }
    }
}

/// One scene condition: a backdrop and the share of the object occluders hide.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub(crate) struct Condition {
    /// The backdrop.
    pub backdrop: Backdrop,
    /// The share of the object's pixels asked hidden.
    pub occlude: f64,
}

/// The scene views of one condition, as the caller made them.
pub(crate) struct SceneViews {
    /// The views (poses and pixels).
    pub data: Dataset,
    /// The mean share of the object the occluders hid (0 without occluders).
    pub hidden: f64,
}

/// One model on one condition's views.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct SceneEval {
    /// Mean error over the unseen views (degrees).
    pub mean_deg: f64,
    /// Median error over them (degrees).
    pub median_deg: f64,
    /// How many of them are off by more than [`GROSS_ERROR_DEG`].
    pub gross: usize,
    /// How many of the gross errors the confidence flags.
    pub gross_flagged: usize,
    /// How many of them the confidence flags in all.
    pub flagged: usize,
    /// Microseconds per query (every view estimated in one batch, confidence included).
    pub per_query_us: f64,
}

impl SceneEval {
    fn of(r: &EvalReport) -> SceneEval {
        let unseen: Vec<&linpose::eval::SampleResult> = r.samples.iter().filter(|s| !s.seen).collect();
        let u = r.unseen.unwrap_or(r.all);
        SceneEval {
            mean_deg: u.mean_deg,
            median_deg: u.median_deg,
            gross: unseen.iter().filter(|s| s.error_deg > GROSS_ERROR_DEG).count(),
            gross_flagged: unseen.iter().filter(|s| s.error_deg > GROSS_ERROR_DEG && s.flagged == Some(true)).count(),
            flagged: unseen.iter().filter(|s| s.flagged == Some(true)).count(),
            per_query_us: r.predict_s / r.n_eval.max(1) as f64 * 1e6,
        }
    }
}

/// One method on one object under one condition, plain and robust.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct ScenesRow {
    /// The object.
    pub object: String,
    /// The method.
    pub method: String,
    /// The condition.
    #[serde(flatten)]
    pub condition: Condition,
    /// The mean share of the object hidden, as drawn.
    pub hidden: f64,
    /// Unseen views measured.
    pub n_unseen: usize,
    /// The plain model.
    pub plain: SceneEval,
    /// The same model behind the robust stage.
    pub robust: SceneEval,
}

/// The robust stage of one object: what it costs to train and store (one stage for every
/// method: it depends on the training views alone).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct StageCost {
    /// The object.
    pub object: String,
    /// Training views.
    pub n_train: usize,
    /// Image width and height.
    pub size: (u32, u32),
    /// Seconds to fit the stage (the method's model already fitted).
    pub fit_s: f64,
    /// The stage's bytes (a robust model's less its plain model's).
    pub stage_bytes: usize,
}

/// The scenes study over the objects.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct ScenesStudy {
    /// The views measured, in words (the same poses in every condition).
    pub views: String,
    /// The seed of the scenes' draws (the same backgrounds and occluders in every condition of
    /// one share).
    pub seed: u64,
    /// The conditions, in order.
    pub conditions: Vec<Condition>,
    /// One row per object, method and condition.
    pub rows: Vec<ScenesRow>,
    /// One per object.
    pub stages: Vec<StageCost>,
    /// Seconds the section took, rendering included.
    pub total_s: f64,
}

/// What [`run`] is given of one object.
pub(crate) struct ObjectScenes<'a> {
    /// The object.
    pub object: &'a str,
    /// Its training views (the studio views the plain models were fitted on).
    pub train: &'a Dataset,
    /// The plain models, one per method.
    pub plain: &'a [AnyModel],
    /// The conditions.
    pub conditions: &'a [Condition],
    /// Makes a condition's views.
    pub views: &'a dyn Fn(Condition) -> Result<SceneViews>,
}

/// Runs the study on one object: the robust stage fitted on the training views (once: it
/// depends on them alone) and put in front of every plain model, then every condition's views
/// made and estimated by each model plain and robust. Returns the rows and the stage's cost;
/// `progress(stage)` is called as each stage starts.
pub(crate) fn run(o: &ObjectScenes<'_>, seed: u64, progress: &dyn Fn(&str)) -> Result<(Vec<ScenesRow>, StageCost)> {
    let Some(first) = o.plain.first() else {
        return Err(linpose::Error::invalid("methods", 0, "the scenes study needs a pose method"));
    };
    progress(&format!("{}, scenes: robust stage fit", o.object));
    let t = Instant::now();
    let stage = Robust::fit(o.train, first.clone())?;
    let fit_s = t.elapsed().as_secs_f64();
    let spec = o.train.spec();
    let cost = StageCost {
        object: o.object.to_string(),
        n_train: o.train.len(),
        size: (spec.width, spec.height),
        fit_s,
        stage_bytes: stage.model_bytes().saturating_sub(first.model_bytes()),
    };
    let robust: Vec<AnyModel> = {
        let r = stage.downcast_ref::<Robust>().expect("Robust::fit gives a robust model");
        std::iter::once(Ok(stage.clone())).chain(o.plain[1..].iter().map(|p| r.with_inner(p.clone()))).collect::<Result<_>>()?
    };
    let opt = EvalOptions::new(0.0, seed);
    let mut rows = Vec::new();
    for &c in o.conditions {
        progress(&format!("{}, scenes: {} {:.0}% hidden", o.object, c.backdrop.name(), 100.0 * c.occlude));
        let v = (o.views)(c)?;
        for (plain, robust) in o.plain.iter().zip(&robust) {
            let p = evaluate(plain, &v.data, &opt)?;
            let r = evaluate(robust, &v.data, &opt)?;
            rows.push(ScenesRow {
                object: o.object.to_string(),
                method: p.method.clone(),
                condition: c,
                hidden: v.hidden,
                n_unseen: p.samples.iter().filter(|s| !s.seen).count(),
                plain: SceneEval::of(&p),
                robust: SceneEval::of(&r),
            });
        }
    }
    Ok((rows, cost))
}

/// The conditions of a study: `texture` at every share of `shares`; the studio backdrop and
/// `noise` at every share of `side` (both orders kept, studio first).
pub(crate) fn conditions(shares: &[f64], side: &[f64]) -> Vec<Condition> {
    let mut c = Vec::new();
    for (backdrop, s) in [(Backdrop::Studio, side), (Backdrop::Texture, shares), (Backdrop::Noise, side)] {
        c.extend(s.iter().map(|&occlude| Condition { backdrop, occlude }));
    }
    c
}
