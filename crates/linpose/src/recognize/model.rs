//! [`ObjectModel`]: a recogniser, each object's unknown-object thresholds (in the recogniser's
//! space, then in the object's own eigenspace: `own.rs`), and each object's pose model, with the
//! objects' names; optionally behind one normalisation stage ([`crate::normalize`]) fitted on
//! every object's training views, as Murase & Nayar segment and normalise before recognising.

use super::own::OwnSpaces;
use super::robust::{Patched, RobustObjects};
use super::{checked_distances, Recognition, Recognize, Recognizer, RecognizerParams, Unknown};
use crate::catalog::ObjectSet;
use crate::confidence::{Estimate, Hypothesis};
use crate::dataset::Dataset;
use crate::image_io::ImageSpec;
use crate::model::{check_queries, AnyModel, MethodSpec, PoseModel, Storage, Tensor, TensorSet};
use crate::normalize::{median64, NormalizeParams, Normalizer, Rejection};
use crate::pose::PoseSpace;
use crate::{Error, Result};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::sync::Arc;

/// What an [`ObjectModel`] records about its recogniser: the parameters as given, what they
/// resolved to, and what calibrated the thresholds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObjectSettings {
    /// The parameters as given.
    pub params: RecognizerParams,
    /// Universal eigenspace dimensions kept (0 for the linear recogniser).
    pub components: usize,
    /// The fraction of the training energy (about the mean) they hold (1 for the linear
    /// recogniser).
    pub energy_kept: f64,
    /// Per object, the largest distance of one of its held-out training views; for an object too
    /// sparse to hold views out, the largest of the other objects' (infinite, `null` in JSON,
    /// when no object can).
    #[serde(with = "infinite_as_null")]
    pub held_out_max: Vec<f64>,
    /// Per object, the median of those distances.
    #[serde(with = "infinite_as_null")]
    pub held_out_median: Vec<f64>,
    /// Per object, the distance beyond which a query nearest to it is unknown (infinite: never).
    #[serde(with = "infinite_as_null")]
    pub thresholds: Vec<f64>,
    /// The second stage, each object's own eigenspace: its calibration and thresholds.
    pub own: OwnSettings,
    /// Fitted without poses ([`ObjectModel::fit_views`]): each object's manifold is its training
    /// views' points, each view was held out together with its nearest other view, and there
    /// are no pose models.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub views_only: bool,
    /// How the normalisation was decided, when training decided it ([`ObjectModel::fit_staged`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stage_choice: Option<crate::normalize::StageChoice>,
}

/// What an [`ObjectModel`] records about its second stage, each object's own eigenspace
/// ([`super::Unknown::Calibrated`]): per object, as [`ObjectSettings`] records the first stage's.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OwnSettings {
    /// Per object, the dimensions of its own eigenspace, L_k = min(L, N_k - 1) (0: none, for an
    /// object of a single training view).
    pub components: Vec<usize>,
    /// Per object, the largest distance of one of its held-out training views to its manifold
    /// in its own eigenspace fitted without them (the largest of the other objects' for an object
    /// too sparse to hold views out; infinite for one without an eigenspace of its own).
    #[serde(with = "infinite_as_null")]
    pub held_out_max: Vec<f64>,
    /// Per object, the median of those distances.
    #[serde(with = "infinite_as_null")]
    pub held_out_median: Vec<f64>,
    /// Per object, the distance in its own eigenspace beyond which a query recognised as it is
    /// unknown (infinite: the second stage is off).
    #[serde(with = "infinite_as_null")]
    pub thresholds: Vec<f64>,
    /// The binning factor of the images the own eigenspaces are of.
    pub bin: usize,
}

/// A query's object and, when it is one of the known objects, its pose.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectEstimate {
    /// Which object.
    pub recognition: Recognition,
    /// Its pose from the object's own model; `None` for an unknown object.
    pub pose: Option<Estimate>,
}

/// One (object, pose) hypothesis of a query ([`ObjectModel::hypotheses`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObjectHypothesis {
    /// The object's index ([`ObjectModel::names`]).
    pub object: usize,
    /// The query's distance to the object, in the recogniser's measure.
    pub distance: f64,
    /// The pose with its score, as the object's pose model judges them.
    pub pose: Hypothesis,
}

/// Recognition then pose over several objects ([`crate::recognize`]).
#[derive(Debug, Clone)]
pub struct ObjectModel {
    names: Vec<String>,
    spec: ImageSpec,
    /// The pose parameters (`None`: fitted without poses, [`ObjectModel::fit_views`]).
    space: Option<PoseSpace>,
    recognizer: Arc<dyn Recognize>,
    /// The second stage (`None` for a model file written before it).
    own: OwnSpaces,
    settings: ObjectSettings,
    /// One per object; none for a model fitted without poses.
    poses: Vec<AnyModel>,
    /// The normalisation every query goes through first (the recogniser and the pose models were
    /// fitted on normalised images); `None`: queries are used as they are.
    stage: Option<Normalizer>,
    /// The caller's labels for the objects, where the names do not say them ([`Labels`]).
    labels: Option<Labels>,
    /// Each object's robust stage ([`ObjectModel::with_robust`], `robust.rs`); `None`: queries
    /// go to the recogniser as they are (after the normalisation stage, if any).
    pub(super) robust: Option<RobustObjects>,
}

/// How a caller labels the objects where their names, as text, do not say it: each object's
/// label as a JSON value (numbers stay numbers), in the order of the names, the label the caller
/// gives an image of none of them, and the labels' type in the caller's words (the Python package
/// writes numpy's dtype). The library keeps them with the model and in its file, and reads
/// nothing from them: the command line names objects by their names. Without them, a caller's
/// labels are the names (the Python package's default for text labels).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Labels {
    /// Each object's label, in the order of [`ObjectModel::names`].
    pub values: Vec<serde_json::Value>,
    /// The label of an image of none of the objects.
    pub unknown: serde_json::Value,
    /// The labels' type, as the caller names it (e.g. `int64`).
    pub kind: String,
}

impl ObjectModel {
    /// Fits the recogniser on every object's training views and `method` on each object's.
    pub fn fit(objects: &ObjectSet, params: &RecognizerParams, method: &MethodSpec) -> Result<Self> {
        Self::fit_with(objects, params, method, &|_| {})
    }

    /// As [`ObjectModel::fit`], calling `progress` with 1 after the recogniser and after each
    /// object's pose model.
    pub fn fit_with(objects: &ObjectSet, params: &RecognizerParams, method: &MethodSpec, progress: &(dyn Fn(u64) + Sync)) -> Result<Self> {
        params.validate()?;
        // The objects' pose models in parallel (a small fit leaves cores idle); the first failing
        // object in order is the error, so it is the same on every run.
        let fit = || -> Result<Vec<AnyModel>> {
            let poses: Vec<Result<AnyModel>> = objects
                .objects()
                .par_iter()
                .zip(objects.names())
                .map(|(d, name)| {
                    let m = method.fit(d).map_err(|e| match e {
                        Error::Dataset { path, message } => Error::Dataset { path, message: format!("object '{name}': {message}") },
                        e => Error::Dataset { path: d.manifest().root().to_path_buf(), message: format!("object '{name}': {e}") },
                    });
                    progress(1);
                    m
                })
                .collect();
            poses.into_iter().collect()
        };
        let recognise = || {
            let r = Self::fit_recognizer(objects, params, false);
            progress(1);
            r
        };
        let (recognizer, poses) = rayon::join(recognise, fit);
        Ok(Self::fitted(objects, recognizer?, poses?))
    }

    /// A recogniser without poses: which object each query shows, and "none of these", from
    /// each object's training views alone, whatever order they come in. Each object's manifold
    /// (in the universal eigenspace, and in its own for the second stage) is its training views'
    /// points, not a curve through them, and the unknown-object thresholds are calibrated with
    /// each view held out together with its nearest other view of its object (a near-duplicate
    /// of it, as a symmetric object's other side, would otherwise calibrate nothing). The
    /// objects' poses are not read, and the model has no pose models: its estimates have no
    /// pose ([`ObjectEstimate::pose`] is `None`). Views between the training views are nearer
    /// a curve than any point, so, fitted with poses ([`ObjectModel::fit`]), a model recognises
    /// them at least as well; this is for views whose poses are unknown.
    pub fn fit_views(objects: &ObjectSet, params: &RecognizerParams) -> Result<Self> {
        params.validate()?;
        let mut model = Self::fitted(objects, Self::fit_recognizer(objects, params, true)?, Vec::new());
        model.space = None;
        Ok(model)
    }

    /// As [`ObjectModel::fit_views`], behind a normalisation stage fitted on every object's
    /// training views ([`ObjectModel::fit_normalized`]).
    pub fn fit_views_normalized(objects: &ObjectSet, params: &RecognizerParams, normalize: NormalizeParams) -> Result<Self> {
        params.validate()?;
        let (stage, normalised) = Self::normalise(objects, normalize)?;
        let mut model = Self::fit_views(&normalised, params)?;
        model.stage = Some(stage);
        Ok(model)
    }

    /// The stage fitted on every object's training views, and the objects normalised by it.
    fn normalise(objects: &ObjectSet, normalize: NormalizeParams) -> Result<(Normalizer, ObjectSet)> {
        let stage = Normalizer::fit_sets(objects.objects(), normalize)?;
        let normalised = objects.objects().iter().map(|d| stage.apply_dataset(d)).collect::<Result<Vec<Dataset>>>()?;
        Ok((stage, ObjectSet::new(objects.names().to_vec(), normalised)?))
    }

    /// The model of `objects` with its recogniser, second stage and settings, and `poses`; no
    /// normalisation stage.
    fn fitted(objects: &ObjectSet, (recognizer, own, settings): (Arc<dyn Recognize>, OwnSpaces, ObjectSettings), poses: Vec<AnyModel>) -> Self {
        ObjectModel {
            names: objects.names().to_vec(),
            spec: objects.spec(),
            space: Some(objects.space().clone()),
            recognizer,
            own,
            settings,
            poses,
            stage: None,
            labels: None,
            robust: None,
        }
    }

    /// As [`ObjectModel::fit_with`], behind a normalisation stage ([`crate::normalize`]): the
    /// stage is fitted on every object's training views together (one background, threshold
    /// and target size for all, so that the objects' normalised views compare as the
    /// recogniser needs), each object's views are normalised by it, and the recogniser and the
    /// pose models are fitted on the result. Queries then go through the same stage. A training
    /// view the stage cannot normalise is an error naming it.
    pub fn fit_normalized(
        objects: &ObjectSet,
        params: &RecognizerParams,
        method: &MethodSpec,
        normalize: NormalizeParams,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<Self> {
        params.validate()?;
        let (stage, normalised) = Self::normalise(objects, normalize)?;
        let mut model = Self::fit_with(&normalised, params, method, progress)?;
        model.stage = Some(stage);
        Ok(model)
    }

    /// As [`ObjectModel::fit_with`], behind the normalisation `rule` decides: fixed, or chosen
    /// on the objects' held-out training views ([`crate::MethodSpec::fit_with_stage`]: every object's pose
    /// model fitted without its held-out views, their errors pooled over the objects, for each of
    /// off, brightness, geometry and all behind one stage fitted on every object's views). The
    /// settings record the decision ([`ObjectSettings::stage_choice`]).
    pub fn fit_staged(
        objects: &ObjectSet,
        params: &RecognizerParams,
        method: &MethodSpec,
        rule: crate::normalize::StageRule,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<Self> {
        params.validate()?;
        let choice = match rule {
            crate::normalize::StageRule::Fixed(p) => crate::normalize::StageChoice::fixed(p),
            crate::normalize::StageRule::Auto => crate::stage_choice::choose_objects(objects, method)?,
        };
        let mut model = match choice.params() {
            p if p.is_on() => Self::fit_normalized(objects, params, method, p, progress)?,
            _ => Self::fit_with(objects, params, method, progress)?,
        };
        model.settings.stage_choice = Some(choice);
        Ok(model)
    }

    /// As [`ObjectModel::fit_views`], behind the normalisation `rule` asks for. Without poses
    /// there is no pose error to choose on, so `auto` means none (the settings say so).
    pub fn fit_views_staged(objects: &ObjectSet, params: &RecognizerParams, rule: crate::normalize::StageRule) -> Result<Self> {
        let (choice, mut model) = match rule {
            crate::normalize::StageRule::Fixed(p) if p.is_on() => (crate::normalize::StageChoice::fixed(p), Self::fit_views_normalized(objects, params, p)?),
            crate::normalize::StageRule::Fixed(p) => (crate::normalize::StageChoice::fixed(p), Self::fit_views(objects, params)?),
            crate::normalize::StageRule::Auto => (
                crate::normalize::StageChoice::off("fitted without poses: no pose error to choose the stage on, so the images are used as they are"),
                Self::fit_views(objects, params)?,
            ),
        };
        model.settings.stage_choice = Some(choice);
        Ok(model)
    }

    /// The same model with `choice` recorded as how its normalisation was decided.
    pub fn with_stage_choice(mut self, choice: crate::normalize::StageChoice) -> Self {
        self.settings.stage_choice = Some(choice);
        self
    }

    /// The normalisation stage queries go through first, if the model has one.
    pub fn stage(&self) -> Option<&Normalizer> {
        self.stage.as_ref()
    }

    /// The queries as the recogniser and the pose models take them: normalised by the stage
    /// when there is one; a query the stage refuses is an error naming its place in the batch
    /// ([`ObjectModel::estimate_each`] answers the others).
    fn prepared<'a>(&self, queries: &'a [f32]) -> Result<Cow<'a, [f32]>> {
        check_queries(self.spec.features(), queries.len(), "query batch")?;
        match &self.stage {
            None => Ok(Cow::Borrowed(queries)),
            Some(stage) => stage.apply_queries(queries).map(Cow::Owned),
        }
    }

    /// Fits the recogniser on every object's training views and puts the objects' pose models,
    /// already fitted (one per object, in order, of the objects' image size and parameters),
    /// behind it.
    pub fn from_pose_models(objects: &ObjectSet, params: &RecognizerParams, poses: Vec<AnyModel>) -> Result<Self> {
        params.validate()?;
        if poses.len() != objects.len() {
            return Err(Error::invalid("pose models", poses.len(), format!("one per object: {} objects", objects.len())));
        }
        if let Some((k, p)) = poses.iter().enumerate().find(|(_, p)| p.meta().spec != objects.spec() || p.meta().space != *objects.space()) {
            return Err(Error::invalid("pose model", &objects.names()[k], format!("fitted on other images or parameters ({})", p.meta().method)));
        }
        Ok(Self::fitted(objects, Self::fit_recognizer(objects, params, false)?, poses))
    }

    /// The recogniser, the objects' own eigenspaces (the second stage) and their calibration.
    /// With `views_only`, each object's manifolds are its views' points ([`ObjectModel::fit_views`]).
    fn fit_recognizer(objects: &ObjectSet, params: &RecognizerParams, views_only: bool) -> Result<(Arc<dyn Recognize>, OwnSpaces, ObjectSettings)> {
        let all = concatenate(objects)?;
        let fitted = (params.kind.fit)(objects, &all, params, views_only)?;
        let (recognizer, components, energy_kept, held_out) = (fitted.model, fitted.components, fitted.energy_kept, fitted.held_out);
        drop(all);
        let own = OwnSpaces::fit(objects, params, views_only)?;
        let (held_out_max, held_out_median) = calibration(held_out);
        let (mut own_max, own_median) = calibration(own.held_out);
        // An object without an eigenspace of its own (a single training view): no second stage.
        for (k, v) in own_max.iter_mut().enumerate() {
            if !own.model.has(k) {
                *v = f64::INFINITY;
            }
        }
        let own_settings =
            OwnSettings { components: own.components, held_out_max: own_max, held_out_median: own_median, thresholds: Vec::new(), bin: own.model.bin() };
        let mut settings = ObjectSettings {
            params: *params,
            components,
            energy_kept,
            held_out_max,
            held_out_median,
            thresholds: Vec::new(),
            own: own_settings,
            views_only,
            stage_choice: None,
        };
        set_thresholds(&mut settings, params.unknown);
        Ok((recognizer, own.model, settings))
    }

    /// The objects' names, in the order of their indices.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// The caller's labels for the objects, if given ([`ObjectModel::with_labels`]).
    pub fn labels(&self) -> Option<&Labels> {
        self.labels.as_ref()
    }

    /// The model with the caller's labels for its objects (kept with it and in its file), one
    /// per object in the order of [`ObjectModel::names`]; a different number is an error.
    pub fn with_labels(mut self, labels: Labels) -> Result<Self> {
        if labels.values.len() != self.names.len() {
            return Err(Error::invalid("labels", labels.values.len(), format!("one label per object ({} objects)", self.names.len())));
        }
        self.labels = Some(labels);
        Ok(self)
    }

    /// The image size and preprocessing every query must have.
    pub fn spec(&self) -> ImageSpec {
        self.spec
    }

    /// The pose parameters; `None` for a model fitted without poses ([`ObjectModel::fit_views`]).
    pub fn space(&self) -> Option<&PoseSpace> {
        self.space.as_ref()
    }

    /// The recogniser.
    pub fn kind(&self) -> &'static Recognizer {
        self.settings.params.kind
    }

    /// The recogniser's settings and calibration.
    pub fn settings(&self) -> &ObjectSettings {
        &self.settings
    }

    /// Object `k`'s pose model (`None` for a model fitted without poses); panics when `k` is
    /// not an object's index.
    pub fn pose_model(&self, k: usize) -> Option<&AnyModel> {
        assert!(k < self.names.len(), "object {k} of {}", self.names.len());
        self.poses.get(k)
    }

    /// The pose method's name (`None` for a model fitted without poses).
    pub fn method_name(&self) -> Option<&str> {
        self.poses.first().map(|p| p.meta().method.as_str())
    }

    /// The same model with the unknown-object rule `unknown` (thresholds recomputed from the
    /// stored calibration).
    pub fn with_unknown(mut self, unknown: Unknown) -> Result<Self> {
        let mut p = self.settings.params;
        p.unknown = unknown;
        p.validate()?;
        self.settings.params = p;
        set_thresholds(&mut self.settings, unknown);
        Ok(self)
    }

    /// Each query's distance to each object (rows of K values): the recogniser's measure.
    pub fn distances(&self, queries: &[f32]) -> Result<Vec<f64>> {
        Ok(self.distances_of(self.prepared(queries)?)?.1)
    }

    /// [`ObjectModel::distances`] of queries already prepared, through the robust stage as
    /// [`ObjectModel::recognize`] (the nearest object's stage checks each query): the queries
    /// as answered, repaired where they needed it, and their distances.
    fn distances_of<'q>(&self, queries: Cow<'q, [f32]>) -> Result<(Patched<'q>, Vec<f64>)> {
        let k = self.names.len();
        let mut d = self.distances_plain(&queries)?;
        let named: Vec<usize> = d.chunks_exact(k).map(|row| (0..k).min_by(|&a, &b| row[a].total_cmp(&row[b])).expect("at least one object")).collect();
        let (queries, fixes) = self.repaired(queries, &named);
        if !fixes.is_empty() {
            for (&(i, _), row) in fixes.iter().zip(self.distances_plain(queries.repaired_rows())?.chunks_exact(k)) {
                d[i * k..(i + 1) * k].copy_from_slice(row);
            }
        }
        Ok((queries, d))
    }

    /// The recogniser's distances of queries as they are.
    fn distances_plain(&self, queries: &[f32]) -> Result<Vec<f64>> {
        checked_distances(&*self.recognizer, queries, queries.len() / self.spec.features(), self.names.len())
    }

    /// Which object each query shows.
    pub fn recognize(&self, queries: &[f32]) -> Result<Vec<Recognition>> {
        Ok(self.recognize_of(self.prepared(queries)?)?.recognitions)
    }

    /// [`ObjectModel::recognize`] of queries already prepared, through the robust stage when
    /// the model has one: each query is recognised as it is, checked by the named object's
    /// stage, and, where that stage cannot explain it, repaired (`robust.rs`) and recognised
    /// again.
    fn recognize_of<'q>(&self, queries: Cow<'q, [f32]>) -> Result<Answered<'q>> {
        let mut recognitions = self.recognize_plain(&queries)?;
        let named: Vec<usize> = recognitions.iter().map(|r| r.nearest).collect();
        let (queries, fixes) = self.repaired(queries, &named);
        if !fixes.is_empty() {
            for (&(i, _), r) in fixes.iter().zip(self.recognize_plain(queries.repaired_rows())?) {
                recognitions[i] = r;
            }
        }
        Ok(Answered { queries, recognitions, clear: fixes })
    }

    /// The recogniser's and the second stage's answer for queries as they are.
    fn recognize_plain(&self, queries: &[f32]) -> Result<Vec<Recognition>> {
        let mut rec = self.recognizer.recognize(queries, queries.len() / self.spec.features(), &self.settings.thresholds)?;
        self.check_own(queries, &mut rec);
        Ok(rec)
    }

    /// The second stage: each query the recogniser accepted as object k is measured in k's own
    /// eigenspace (queries of one object together) and reported unknown beyond k's own
    /// threshold; a query that cannot be scaled to unit energy there is unknown. A query within
    /// it is then measured against every other object's own manifold, and reported unknown when
    /// one of them lies nearer (the recogniser's answer is not the object the query looks most
    /// like).
    fn check_own(&self, queries: &[f32], rec: &mut [Recognition]) {
        let (own, s) = (&self.own, &self.settings.own);
        let m = self.spec.features();
        let measured = |r: &Recognition| r.object.filter(|&k| s.thresholds[k] != f64::INFINITY && own.has(k));
        let idx: Vec<usize> = (0..rec.len()).filter(|&i| measured(&rec[i]).is_some()).collect();
        if idx.is_empty() {
            return;
        }
        let batch = crate::dataset::rows_at(queries, m, &idx);
        let binned = own.binned(&batch);
        let mb = binned.len() / idx.len();
        let named: Vec<usize> = idx.iter().map(|&i| measured(&rec[i]).expect("measured")).collect();
        let mut d = vec![0.0; idx.len()];
        for k in 0..self.names.len() {
            let of_k: Vec<usize> = (0..idx.len()).filter(|&j| named[j] == k).collect();
            if of_k.is_empty() {
                continue;
            }
            let b: Vec<f32> = of_k.iter().flat_map(|&j| binned[j * mb..(j + 1) * mb].iter().copied()).collect();
            let mut dk = vec![0.0; of_k.len()];
            own.distances(k, &b, &mut dk);
            for (&j, &v) in of_k.iter().zip(&dk) {
                d[j] = v;
            }
        }
        // Only the queries within their object's threshold meet the other objects.
        let within: Vec<usize> = (0..idx.len()).filter(|&j| d[j] <= s.thresholds[named[j]]).collect();
        let rivals = if within.is_empty() {
            Vec::new()
        } else {
            let b: Vec<f32> = within.iter().flat_map(|&j| binned[j * mb..(j + 1) * mb].iter().copied()).collect();
            let nk: Vec<usize> = within.iter().map(|&j| named[j]).collect();
            let dk: Vec<f64> = within.iter().map(|&j| d[j]).collect();
            own.nearer(&b, &nk, &dk)
        };
        let mut rival = vec![None; idx.len()];
        for (&j, r) in within.iter().zip(rivals) {
            rival[j] = r;
        }
        for (j, &i) in idx.iter().enumerate() {
            let r = &mut rec[i];
            (r.own_distance, r.own_threshold, r.own_nearer) = (Some(d[j]), s.thresholds[named[j]], rival[j].map(|(k, _)| k));
            if !(d[j] <= r.own_threshold) || rival[j].is_some() {
                r.object = None;
            }
        }
    }

    /// Each query's object and, for a known one, its pose from that object's model with up to
    /// `top` hypotheses ([`PoseModel::estimate`]); queries of one object are estimated together.
    pub fn estimate(&self, queries: &[f32], top: usize) -> Result<Vec<ObjectEstimate>> {
        self.estimate_of(self.prepared(queries)?, top)
    }

    /// As [`ObjectModel::estimate`], where a query the normalisation stage refuses gets why,
    /// in its place, instead of failing the batch (each query normalised once). Without a stage
    /// every query has its estimate.
    pub fn estimate_each(&self, queries: &[f32], top: usize) -> Result<Vec<std::result::Result<ObjectEstimate, Rejection>>> {
        check_queries(self.spec.features(), queries.len(), "query batch")?;
        let Some(stage) = &self.stage else { return Ok(self.estimate_of(Cow::Borrowed(queries), top)?.into_iter().map(Ok).collect()) };
        let (rows, verdicts) = stage.apply_batch(queries);
        let mut est = if rows.is_empty() { Vec::new() } else { self.estimate_of(Cow::Owned(rows), top)? }.into_iter();
        Ok(verdicts.into_iter().map(|v| v.map_or_else(|| Ok(est.next().expect("one estimate per query the stage accepted")), Err)).collect())
    }

    /// Each query's `top` best (object, pose) hypotheses: the `top` objects nearest the query in
    /// the recogniser's measure, each with its pose model's `top` hypotheses
    /// ([`PoseModel::estimate`]), ranked by the pose's score (the nearer object first on a tie),
    /// the best `top` kept. A pose's score is the probability its object's pose model gives it:
    /// with the eigenspace and the refined method near 0 for every pose of an object the query
    /// is none of the views of, so an object that does not explain the query ranks low however
    /// near the recogniser finds it. Unknown objects are not set apart: these are the
    /// alternatives, whatever [`ObjectModel::recognize`] decides. Needs a model fitted with poses.
    pub fn hypotheses(&self, queries: &[f32], top: usize) -> Result<Vec<Vec<ObjectHypothesis>>> {
        if self.poses.is_empty() {
            return Err(Error::invalid("top", top, "this model was fitted without poses: it tells objects apart, with no pose hypotheses"));
        }
        let k = self.names.len();
        let (q, d) = self.distances_of(self.prepared(queries)?)?;
        let n = q.len();
        let top = top.max(1);
        let nearest: Vec<Vec<usize>> = (0..n)
            .map(|i| {
                let row = &d[i * k..(i + 1) * k];
                let mut o: Vec<usize> = (0..k).collect();
                o.sort_by(|&a, &b| row[a].total_cmp(&row[b]));
                o.truncate(top);
                o
            })
            .collect();
        let mut out: Vec<Vec<ObjectHypothesis>> = vec![Vec::new(); n];
        for o in 0..k {
            let idx: Vec<usize> = (0..n).filter(|&i| nearest[i].contains(&o)).collect();
            if idx.is_empty() {
                continue;
            }
            let batch: Vec<f32> = idx.iter().flat_map(|&i| q.row(i).iter().copied()).collect();
            for (&i, e) in idx.iter().zip(self.poses[o].estimate(&batch, top)?) {
                out[i].extend(e.hypotheses.into_iter().map(|pose| ObjectHypothesis { object: o, distance: d[i * k + o], pose }));
            }
        }
        for (h, near) in out.iter_mut().zip(&nearest) {
            let rank = |o: usize| near.iter().position(|&x| x == o).unwrap_or(usize::MAX);
            h.sort_by(|a, b| b.pose.score.total_cmp(&a.pose.score).then(rank(a.object).cmp(&rank(b.object))));
            h.truncate(top);
        }
        Ok(out)
    }

    /// [`ObjectModel::estimate`] of queries already prepared.
    fn estimate_of(&self, queries: Cow<'_, [f32]>, top: usize) -> Result<Vec<ObjectEstimate>> {
        let Answered { queries, recognitions: rec, clear } = self.recognize_of(queries)?;
        let mut poses: Vec<Option<Estimate>> = vec![None; rec.len()];
        for k in 0..self.poses.len() {
            let idx: Vec<usize> = (0..rec.len()).filter(|&i| rec[i].object == Some(k)).collect();
            if idx.is_empty() {
                continue;
            }
            for (&i, e) in idx.iter().zip(self.poses[k].estimate(&queries.rows(&idx), top)?) {
                poses[i] = Some(e);
            }
        }
        for (i, f) in clear {
            if let Some(e) = &mut poses[i] {
                crate::confidence::for_hidden(e, f);
            }
        }
        Ok(rec.into_iter().zip(poses).map(|(recognition, pose)| ObjectEstimate { recognition, pose }).collect())
    }

    /// Bytes of the numbers stored to serve queries, as [`PoseModel::model_bytes`] counts them:
    /// the recogniser's (f32), every pose model's and the robust stages' (f32).
    pub fn model_bytes(&self) -> usize {
        self.recognizer_bytes() + self.poses.iter().map(|p| p.model_bytes()).sum::<usize>() + 4 * self.robust.as_ref().map_or(0, RobustObjects::numbers)
    }

    /// Bytes of the recogniser's numbers (f32).
    pub fn recognizer_bytes(&self) -> usize {
        4 * (self.recognizer.stored_numbers() + self.own_numbers())
    }

    /// Numbers the second stage stores.
    fn own_numbers(&self) -> usize {
        self.own.numbers()
    }

    /// The recogniser's storage in the paper's Table 1 terms ([`Recognizer::storage`]).
    pub fn recognizer_storage(&self) -> Storage {
        let (m, k) = (self.spec.features(), self.names.len());
        let (n_own, l_own) = (self.own.manifold_len(), self.own.max_components());
        let mut terms = self.recognizer.storage_terms();
        terms.extend([("M", m), ("K", k), ("N_own", n_own), ("L_k", l_own)]);
        Storage::new(&terms, self.recognizer.stored_numbers() + self.own_numbers())
    }

    /// The recogniser's arrays for a model file (names start with `recognizer.`).
    pub(crate) fn recognizer_tensors(&self) -> Vec<Tensor> {
        let mut t = self.recognizer.arrays();
        t.extend(self.own.tensors());
        t
    }

    /// Every object's pose model.
    pub(crate) fn pose_models(&self) -> &[AnyModel] {
        &self.poses
    }

    /// Rebuilds a model from a model file's parts: the names, the settings, the recogniser's
    /// arrays, the pose models (already read back), the image size of a model without pose
    /// models (`views`, [`ObjectModel::fit_views`]), the normalisation stage and the caller's
    /// labels, if any.
    pub(crate) fn from_parts(
        names: Vec<String>,
        settings: ObjectSettings,
        t: &TensorSet,
        poses: Vec<AnyModel>,
        views: Option<ImageSpec>,
        stage: Option<Normalizer>,
        labels: Option<Labels>,
    ) -> Result<Self> {
        let k = names.len();
        let damaged = |m: String| t.error(format!("damaged object model: {m}"));
        let (spec, space) = match (settings.views_only, views, poses.first()) {
            (true, Some(spec), None) => (spec, None),
            (false, None, Some(p)) if poses.len() == k => (p.meta().spec, Some(p.meta().space.clone())),
            _ => return Err(damaged(format!("{k} names for {} pose models (fitted without poses: {})", poses.len(), settings.views_only))),
        };
        if k == 0 {
            return Err(damaged("no objects".into()));
        }
        if let Some(l) = labels.as_ref().filter(|l| l.values.len() != k) {
            return Err(damaged(format!("{} labels for {k} objects", l.values.len())));
        }
        settings.params.validate().map_err(|e| damaged(e.to_string()))?;
        for v in [&settings.held_out_max, &settings.held_out_median, &settings.thresholds] {
            if v.len() != k || v.iter().any(|x| x.is_nan() || *x < 0.0) {
                return Err(damaged(format!("{} per-object values for {k} objects", v.len())));
            }
        }
        if let Some(p) = poses.iter().find(|p| p.meta().spec != spec || Some(&p.meta().space) != space.as_ref() || p.meta().method != poses[0].meta().method) {
            return Err(damaged(format!("pose models of different image sizes, parameters or methods ({})", p.meta().method)));
        }
        if let Some(st) = &stage {
            st.check_spec(&spec).map_err(damaged)?;
        }
        let recognizer = (settings.params.kind.load)(t, k, spec.features(), settings.components)?;
        let o = &settings.own;
        for v in [&o.held_out_max, &o.held_out_median, &o.thresholds] {
            if v.len() != k || v.iter().any(|x| x.is_nan() || *x < 0.0) {
                return Err(damaged(format!("{} per-object values of the own eigenspaces for {k} objects", v.len())));
            }
        }
        if o.components.len() != k {
            return Err(damaged(format!("own eigenspace dimensions {:?} for {k} objects", o.components)));
        }
        let own = OwnSpaces::from_parts(t, spec, o.bin, &o.components)?;
        Ok(ObjectModel { names, spec, space, recognizer, own, settings, poses, stage, labels, robust: None })
    }
}

/// Queries as the model answered them: repaired by the robust stage where they needed it, with
/// their recognitions and, for each repaired one, its place and the probability that a fit
/// showing its share of the object reads the pose right.
struct Answered<'q> {
    queries: Patched<'q>,
    recognitions: Vec<Recognition>,
    clear: Vec<(usize, f64)>,
}

/// Per object, the largest and the median held-out distance; an object too sparse to hold views
/// out takes the largest of the others' (none calibrated: infinite, never unknown) and an
/// infinite median.
fn calibration(mut held_out: Vec<Vec<f64>>) -> (Vec<f64>, Vec<f64>) {
    let own: Vec<Option<f64>> = held_out.iter().map(|v| (!v.is_empty()).then(|| v.iter().copied().fold(0.0, f64::max))).collect();
    let widest = own.iter().flatten().copied().fold(f64::NEG_INFINITY, f64::max);
    let widest = if widest.is_finite() { widest } else { f64::INFINITY };
    let max = own.iter().map(|v| v.unwrap_or(widest)).collect();
    let median = held_out.iter_mut().map(|v| if v.is_empty() { f64::INFINITY } else { median64(v) }).collect();
    (max, median)
}

/// Sets every threshold, both stages', that `unknown` gives from the calibration in `s`: a fixed
/// distance is the recogniser's and turns the second stage off, as `off` turns both off.
fn set_thresholds(s: &mut ObjectSettings, unknown: Unknown) {
    let k = s.held_out_max.len();
    s.thresholds = match unknown {
        Unknown::Calibrated => s.held_out_max.clone(),
        Unknown::Threshold(t) => vec![t; k],
        Unknown::Off => vec![f64::INFINITY; k],
    };
    s.own.thresholds = match unknown {
        Unknown::Calibrated => s.own.held_out_max.clone(),
        Unknown::Threshold(_) | Unknown::Off => vec![f64::INFINITY; k],
    };
}

/// Every object's training views in one data set, object after object.
fn concatenate(objects: &ObjectSet) -> Result<Dataset> {
    let total = objects.total_len() * objects.spec().features();
    let mut features = Vec::new();
    features
        .try_reserve_exact(total)
        .map_err(|_| Error::invalid("training set", objects.total_len(), "cannot hold every object's training images together in memory"))?;
    let mut poses = Vec::new();
    for d in objects.objects() {
        features.extend_from_slice(d.features());
        poses.extend_from_slice(d.poses());
    }
    Dataset::new(objects.spec(), features, objects.space().clone(), poses)
}

/// Per-object distances in JSON: an infinite one (JSON has no infinity) as `null`.
mod infinite_as_null {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    pub(super) fn serialize<S: Serializer>(v: &[f64], s: S) -> Result<S::Ok, S::Error> {
        v.iter().map(|&x| if x.is_finite() { Some(x) } else { None }).collect::<Vec<_>>().serialize(s)
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
        Ok(Vec::<Option<f64>>::deserialize(d)?.into_iter().map(|x| x.unwrap_or(f64::INFINITY)).collect())
    }
}
