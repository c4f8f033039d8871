//! Recognition, then pose, on all the study's objects at once ([`linpose::recognize`]): each
//! recogniser fitted on every object's training views, then every view of every object
//! recognised and given its pose by the recognised object's model (each method's); and each
//! object left out of training in turn, to measure how its views are reported unknown while the
//! others' unseen views are not.

use linpose::catalog::ObjectSet;
use linpose::dataset::Dataset;
use linpose::manifest::TrainSelection;
use linpose::model::{AnyModel, PoseModel};
use linpose::recognize::{ObjectModel, RecognizerParams, RECOGNIZERS};
use linpose::{Error, Result};
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// One recogniser over the study's objects.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct RecognitionRow {
    /// The recogniser's name.
    pub recognizer: String,
    /// Views of every object recognised as their object, over all views and over the unseen
    /// ones (fractions).
    pub recognized_all: f64,
    /// See [`RecognitionRow::recognized_all`].
    pub recognized_unseen: f64,
    /// Unseen views reported unknown though their object is known (fraction).
    pub false_rejections: f64,
    /// With each object left out of training in turn: the share of its views reported unknown,
    /// pooled over the objects (`None` with fewer than three objects).
    pub left_out_rejected: Option<f64>,
    /// With each object left out in turn: the share of the other objects' unseen views reported
    /// unknown, pooled.
    pub left_out_false: Option<f64>,
    /// Per pose method: the unseen mean error (degrees) of the views recognised as their object,
    /// from the recognised object's model.
    pub pose_unseen: Vec<(String, f64)>,
    /// Seconds to fit the recogniser (all objects).
    pub fit_s: f64,
    /// Microseconds per query of the recognition alone (all views, batched).
    pub per_query_us: f64,
    /// The recogniser's storage formula with its terms' values, and its bytes.
    pub storage: String,
    /// See [`RecognitionRow::storage`].
    pub bytes: usize,
}

/// What [`run`] measured.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct RecognitionStudy {
    /// The objects, in order.
    pub objects: Vec<String>,
    /// One row per recogniser.
    pub rows: Vec<RecognitionRow>,
}

/// What the recognition study is given of the pose methods: each method's model of every object,
/// fitted on the objects' training views, and each model's clean pose error on every view of its
/// object (the study's clean run, in the order of `views`), which the recognised views' pose
/// error is taken from (the same model on the same views).
pub(crate) struct PoseRuns {
    /// `models[m][k]`: method m's model of object k (at least one method).
    pub models: Vec<Vec<AnyModel>>,
    /// `errors[m][k][i]`: that model's error on view i of object k (degrees).
    pub errors: Vec<Vec<Vec<f64>>>,
}

/// Runs the study. `train` holds every object's training views; `views(k)` gives every view of
/// object k (called once per object and model: the views need not all be in memory at once);
/// `poses` the pose methods' models and errors. With `left_out_step`, the left-out measure runs
/// on the views of that coarser grid only (the views on its lattice, as a training step of that
/// many degrees would pick them), else on every view.
pub(crate) fn run(
    train: &ObjectSet,
    views: &dyn Fn(usize) -> Result<Dataset>,
    poses: &PoseRuns,
    left_out_step: Option<f64>,
    progress: &dyn Fn(&str),
) -> Result<RecognitionStudy> {
    let (errors, poses) = (&poses.errors, &poses.models);
    let k = train.len();
    if k < 2 {
        return Err(Error::invalid("objects", k, "recognition needs at least two objects"));
    }
    // The coarser grid's views, made once for every left-out model of every recogniser (small:
    // the views of the full grid are made again each time, not kept).
    let coarse: Option<Vec<Dataset>> = match left_out_step.filter(|_| k >= 3) {
        Some(s) => Some(
            (0..k)
                .map(|o| {
                    let data = views(o)?;
                    data.subset(&data.manifest().training_mask(&TrainSelection::Step(s))?)
                })
                .collect::<Result<_>>()?,
        ),
        None => None,
    };
    let left_out_views = |o: usize| -> Result<Dataset> {
        match &coarse {
            Some(c) => Ok(c[o].clone()),
            None => views(o),
        }
    };
    let mut rows = Vec::new();
    for &kind in RECOGNIZERS {
        let params = RecognizerParams::new(kind);
        progress(&format!("recognition: {}", kind.name));
        let t = Instant::now();
        let first = poses.first().ok_or_else(|| Error::invalid("methods", 0, "the recognition study needs a pose method"))?;
        let model = ObjectModel::from_pose_models(train, &params, first.clone())?;
        let fit_s = t.elapsed().as_secs_f64();
        let (mut ok_all, mut n_all, mut ok_unseen, mut n_unseen, mut rejected) = (0, 0, 0, 0, 0);
        let mut sums: Vec<(f64, usize)> = vec![(0.0, 0); poses.len()];
        let mut rec_s = 0.0;
        for o in 0..k {
            let data = views(o)?;
            let t = Instant::now();
            let rec = model.recognize(data.features())?;
            rec_s += t.elapsed().as_secs_f64();
            let seen: Vec<bool> = (0..data.len()).map(|i| first[o].meta().is_seen(data.pose(i))).collect();
            let right: Vec<usize> = (0..data.len()).filter(|&i| rec[i].object == Some(o)).collect();
            for (i, r) in rec.iter().enumerate() {
                n_all += 1;
                ok_all += (r.object == Some(o)) as usize;
                if !seen[i] {
                    n_unseen += 1;
                    ok_unseen += (r.object == Some(o)) as usize;
                    rejected += r.object.is_none() as usize;
                }
            }
            // Pose of the unseen views recognised as their object, by each method's model of it.
            let unseen_right: Vec<usize> = right.into_iter().filter(|&i| !seen[i]).collect();
            if !unseen_right.is_empty() {
                for (e, per_object) in sums.iter_mut().zip(errors) {
                    for &i in &unseen_right {
                        e.0 += per_object[o][i];
                    }
                    e.1 += unseen_right.len();
                }
            }
        }
        let (left_out_rejected, left_out_false) = if k >= 3 { left_out(train, &left_out_views, first, &params, progress)? } else { (None, None) };
        let s = model.recognizer_storage();
        let terms: Vec<String> = s.terms.iter().map(|(n, v)| format!("{n} = {v}")).collect();
        rows.push(RecognitionRow {
            recognizer: kind.name.into(),
            recognized_all: ok_all as f64 / n_all.max(1) as f64,
            recognized_unseen: ok_unseen as f64 / n_unseen.max(1) as f64,
            false_rejections: rejected as f64 / n_unseen.max(1) as f64,
            left_out_rejected,
            left_out_false,
            pose_unseen: poses.iter().zip(&sums).map(|(p, e)| (p[0].meta().method.clone(), e.0 / e.1.max(1) as f64)).collect(),
            fit_s,
            per_query_us: rec_s / n_all.max(1) as f64 * 1e6,
            storage: format!("{} = {} ({})", kind.storage, s.numbers, terms.join(", ")),
            bytes: model.recognizer_bytes(),
        });
    }
    Ok(RecognitionStudy { objects: train.names().to_vec(), rows })
}

/// Each object left out of the recogniser's training in turn: the shares of its views reported
/// unknown, and of the other objects' unseen views, pooled over the objects.
fn left_out(
    train: &ObjectSet,
    views: &dyn Fn(usize) -> Result<Dataset>,
    first: &[AnyModel],
    params: &RecognizerParams,
    progress: &dyn Fn(&str),
) -> Result<(Option<f64>, Option<f64>)> {
    let (mut rej, mut n, mut false_rej, mut n_known) = (0, 0, 0, 0);
    for out in 0..train.len() {
        progress(&format!("recognition: {} without {}", params.kind.name, train.names()[out]));
        let keep: Vec<String> = train.names().iter().enumerate().filter(|&(o, _)| o != out).map(|(_, s)| s.clone()).collect();
        let sub = train.select(&keep)?;
        // The kept objects' pose models are those already fitted (the recogniser alone decides
        // what is unknown).
        let kept: Vec<AnyModel> = first.iter().enumerate().filter(|&(o, _)| o != out).map(|(_, m)| m.clone()).collect();
        let model = ObjectModel::from_pose_models(&sub, params, kept)?;
        for (o, own) in first.iter().enumerate() {
            let data = views(o)?;
            if o == out {
                let rec = model.recognize(data.features())?;
                n += rec.len();
                rej += rec.iter().filter(|r| r.object.is_none()).count();
            } else {
                // Only the known objects' unseen views count, so only they are recognised.
                let unseen: Vec<bool> = (0..data.len()).map(|i| !own.meta().is_seen(data.pose(i))).collect();
                if !unseen.iter().any(|&u| u) {
                    continue;
                }
                let rec = model.recognize(data.subset(&unseen)?.features())?;
                n_known += rec.len();
                false_rej += rec.iter().filter(|r| r.object.is_none()).count();
            }
        }
    }
    Ok((Some(rej as f64 / n.max(1) as f64), Some(false_rej as f64 / n_known.max(1) as f64)))
}
