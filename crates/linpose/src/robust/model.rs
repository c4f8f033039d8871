//! A model of any method behind the robust stage (the parent module): [`Robust`] checks each
//! query against the training views' eigenspace; one the eigenspace explains goes to the
//! method's own model as it is, one it does not (a cluttered background, an occluder) is
//! repaired first (its unexplained pixels replaced by the robust reconstruction). The model file
//! keeps the stage: its settings as the `linpose.robust` metadata, its arrays as
//! `robust.rows` and `robust.hypotheses`.

use super::verify::Answer;
use super::{tuning, Evidence, RobustSettings, Stage, Views};
use crate::confidence::Estimate;
use crate::dataset::Dataset;
use crate::image_io::ImageSpec;
use crate::model::{AnyModel, Kept, Located, Method, ModelMeta, PoseModel, SceneSearch, Storage, Tensor, TensorSet};
use crate::Result;
use rayon::prelude::*;

/// A fitted model whose queries go through the robust stage first.
#[derive(Debug)]
pub struct Robust {
    pub(super) stage: Stage,
    inner: AnyModel,
}

/// The metadata key of the stage's settings in a model file.
pub(crate) const META_KEY: &str = "linpose.robust";

/// A query's place in its batch and its repaired pixels, with the probability that a fit showing
/// that share of the object reads the pose right (`Stage::clear`) and what its answer is checked
/// against (`verify.rs`).
type Repaired = (usize, Vec<f32>, f64, Evidence);

impl Robust {
    /// `inner` (fitted on `train`) behind a robust stage fitted on `train`.
    pub fn fit(train: &Dataset, inner: AnyModel) -> Result<AnyModel> {
        Ok(AnyModel::new(Robust { stage: Stage::fit(train)?, inner }))
    }

    /// The same stage in front of `inner`, another model fitted on the same training views (of
    /// another method, say): the model [`Robust::fit`] of `inner` on those views gives, without
    /// fitting the stage again. Refuses a model of another image size or colour.
    pub fn with_inner(&self, inner: AnyModel) -> Result<AnyModel> {
        let (have, got) = (self.meta().spec, inner.meta().spec);
        if have != got {
            return Err(crate::Error::invalid(
                "robust stage",
                format!("a model of {}x{} {:?} views", got.width, got.height, got.color),
                format!("the stage is of {}x{} {:?} views", have.width, have.height, have.color),
            ));
        }
        Ok(AnyModel::new(Robust { stage: self.stage.clone(), inner }))
    }

    /// The stage's settings.
    pub fn settings(&self) -> &RobustSettings {
        self.stage.settings()
    }

    /// The method's own model.
    pub fn inner(&self) -> &AnyModel {
        &self.inner
    }

    /// Query `x` (M features) as the method sees it: None when the eigenspace explains it (it
    /// goes as it is), else the repaired image and the share of the object it shows (the
    /// reconstruction's bright pixels that the query explains).
    pub fn repair(&self, x: &[f32]) -> Option<(Vec<f32>, f64)> {
        self.stage.apply(x).map(|(r, fit, _)| (r, fit.shown))
    }

    /// The queries of a batch that need the robust fit, repaired.
    fn repaired(&self, queries: &[f32]) -> Result<Vec<Repaired>> {
        let m = self.meta().spec.features();
        crate::model::check_queries(m, queries.len(), "query batch")?;
        Ok(queries.par_chunks(m).enumerate().filter_map(|(i, x)| self.stage.apply(x).map(|(r, f, e)| (i, r, self.stage.clear(f.shown), e))).collect())
    }

    /// The method's estimates of the repaired queries `fixes`, each checked against the query's
    /// own pixels (`verify.rs`: the method's candidates, at least [`tuning::ANSWERS`] asked for,
    /// the one the kept pixels support first), with `top` hypotheses and its confidence scaled
    /// by the share of the object shown.
    fn verified(&self, fixes: &[Repaired], top: usize) -> Result<Vec<Estimate>> {
        let q: Vec<f32> = fixes.iter().flat_map(|(_, r, _, _)| r.iter().copied()).collect();
        let checks: Vec<(f64, &Evidence)> = fixes.iter().map(|(_, _, clear, e)| (*clear, e)).collect();
        self.verified_rows(&q, &checks, top)
    }

    /// [`Robust::verified`] of the repaired queries `q` (rows of M), each with its probability
    /// of reading right and what it is checked against.
    fn verified_rows(&self, q: &[f32], checks: &[(f64, &Evidence)], top: usize) -> Result<Vec<Estimate>> {
        if checks.is_empty() {
            return Ok(Vec::new());
        }
        let mut est = self.inner.estimate(q, top.max(tuning::ANSWERS))?;
        let space = &self.meta().space;
        for (e, (clear, evidence)) in est.iter_mut().zip(checks) {
            let poses: Vec<&[f64]> = e.hypotheses.iter().map(|h| h.pose.as_slice()).collect();
            let j = match self.stage.answer(evidence, &poses, space) {
                Answer::Method(j) => j,
                Answer::Fit(pose) => {
                    // Not the method's: its score is 0, so the answer is flagged; its distance
                    // is unknown in the method's metric, so it is put at the farthest of the
                    // method's.
                    let distance = e.hypotheses.iter().map(|h| h.distance).fold(0.0, f64::max);
                    e.hypotheses.push(crate::confidence::Hypothesis { pose: pose.to_vec(), score: 0.0, distance });
                    e.hypotheses.len() - 1
                }
            };
            if j > 0 {
                let h = e.hypotheses.remove(j);
                e.pose.clone_from(&h.pose);
                e.confidence = h.score;
                e.hypotheses.insert(0, h);
            }
            // The answer read again from the query's own pixels (`reread.rs`), or for a located
            // view the pose its box was settled with (`settle.rs`).
            e.pose = self.stage.reread(evidence, &e.pose, space);
            if let Some(h) = e.hypotheses.first_mut() {
                h.pose.clone_from(&e.pose);
            }
            e.hypotheses.truncate(top.max(1));
            crate::confidence::for_hidden(e, *clear);
        }
        Ok(est)
    }

    /// `out` (rows of P, one per query) with the poses of the queries of `queries` (rows of M) at
    /// the places `plain`, by `predict` on them as one batch.
    fn answer_plain<T: Copy>(&self, queries: &[T], plain: &[usize], out: &mut [f64], predict: impl Fn(&[T], &mut [f64]) -> Result<()>) -> Result<()> {
        if plain.is_empty() {
            return Ok(());
        }
        let (m, p) = (self.meta().spec.features(), self.meta().space.len());
        let q = crate::dataset::rows_at(queries, m, plain);
        let mut o = vec![0.0; plain.len() * p];
        predict(&q, &mut o)?;
        for (k, &i) in plain.iter().enumerate() {
            out[i * p..(i + 1) * p].copy_from_slice(&o[k * p..(k + 1) * p]);
        }
        Ok(())
    }

    /// The estimates of a batch of `n` queries: the method's on those at the places `plain`
    /// (`queries`, rows of M), `checked` (one per place in `fixed`, in order) on the others.
    fn merged(&self, queries: &[f32], plain: &[usize], top: usize, fixed: &[usize], checked: Vec<Estimate>) -> Result<Vec<Estimate>> {
        let m = self.meta().spec.features();
        let n = plain.len() + fixed.len();
        let q = crate::dataset::rows_at(queries, m, plain);
        let plain_est = if plain.is_empty() { Vec::new() } else { self.inner.estimate(&q, top)? };
        let mut est: Vec<Option<Estimate>> = (0..n).map(|_| None).collect();
        for (&i, e) in plain.iter().zip(plain_est).chain(fixed.iter().zip(checked)) {
            est[i] = Some(e);
        }
        Ok(est.into_iter().map(|e| e.expect("every query estimated, plainly or repaired")).collect())
    }

    /// The checked estimates of the located views at the places `fixed` (those repaired).
    fn checked_located(&self, found: &[Located], fixed: &[usize], top: usize) -> Result<Vec<Estimate>> {
        let evidence: Vec<Evidence> = fixed.iter().map(|&i| self.stage.evidence_of(&found[i].view, &found[i].kept)).collect();
        let checks: Vec<(f64, &Evidence)> = fixed.iter().zip(&evidence).map(|(&i, e)| (self.stage.clear(found[i].shown), e)).collect();
        let rows: Vec<f32> = fixed.iter().flat_map(|&i| found[i].view.iter().copied()).collect();
        self.verified_rows(&rows, &checks, top)
    }

    /// `found`'s view repaired, when the check says so.
    fn repair_located(&self, found: &mut Located) {
        if let Some((view, fit, evidence)) = self.stage.apply(&found.view) {
            found.view = view;
            found.kept = Kept { bins: evidence.kept, theta: evidence.theta, fit_pose: evidence.fit_pose, settled: None };
            found.shown = fit.shown;
            found.repaired = true;
        }
    }

    /// `out` (rows of P, one per query) with the verified poses of the repaired queries `fixes`.
    fn put_verified(&self, fixes: &[Repaired], out: &mut [f64]) -> Result<()> {
        let p = self.meta().space.len();
        for ((i, _, _, _), e) in fixes.iter().zip(self.verified(fixes, 1)?) {
            out[i * p..(i + 1) * p].copy_from_slice(&e.pose);
        }
        Ok(())
    }

    /// The model back from a file's parts: `inner` behind the stage of `settings` and `tensors`.
    pub(crate) fn from_parts(inner: AnyModel, settings: RobustSettings, tensors: &TensorSet) -> Result<AnyModel> {
        let spec = inner.meta().spec;
        let k = settings.rows;
        let rows = tensors.f32("robust.rows", &[k, spec.features()])?;
        let rows_of = |name: &str| tensors.tensors.iter().find(|t| t.name == name).map(|t| t.shape.clone());
        let h = rows_of("robust.hypotheses").map_or(0, |s| s.first().copied().unwrap_or(0));
        let hyps = tensors.f32("robust.hypotheses", &[h, k])?;
        // The training views the answers are checked against: absent in files written before.
        let views = match rows_of("robust.views") {
            None => None,
            Some(shape) => {
                let (n, mb) = (shape.first().copied().unwrap_or(0), shape.get(1).copied().unwrap_or(0));
                let space = &inner.meta().space;
                let v = Views::new(tensors.f32("robust.views", &[n, mb])?, tensors.f64("robust.poses", &[n, space.len()])?, mb, space.clone());
                Some(v.map_err(|e| tensors.error(format!("damaged robust stage: {e}")))?)
            }
        };
        let stage = Stage::new(spec, settings, rows, hyps, views).map_err(|e| tensors.error(format!("damaged robust stage: {e}")))?;
        Ok(AnyModel::new(Robust { stage, inner }))
    }
}

/// The places in a batch of `n` queries of those not among the repaired `fixes`.
fn plain_of(n: usize, fixes: &[Repaired]) -> Vec<usize> {
    let mut fixed = vec![false; n];
    fixes.iter().for_each(|(i, _, _, _)| fixed[*i] = true);
    (0..n).filter(|&i| !fixed[i]).collect()
}

impl PoseModel for Robust {
    fn method(&self) -> &'static Method {
        self.inner.method()
    }
    fn meta(&self) -> &ModelMeta {
        self.inner.meta()
    }
    fn predict_into(&self, queries: &[f32], out: &mut [f64]) -> Result<()> {
        let fixes = self.repaired(queries)?;
        if fixes.is_empty() {
            return self.inner.predict_into(queries, out);
        }
        let plain = plain_of(queries.len() / self.meta().spec.features(), &fixes);
        self.answer_plain(queries, &plain, out, |q, o| self.inner.predict_into(q, o))?;
        self.put_verified(&fixes, out)
    }
    fn predict_u8_into(&self, queries: &[u8], out: &mut [f64]) -> Result<()> {
        let m = self.meta().spec.features();
        crate::model::check_queries(m, queries.len(), "query batch")?;
        let f: Vec<f32> = queries.iter().map(|&v| v as f32 * crate::kernels::levels::S8).collect();
        let fixes = self.repaired(&f)?;
        if fixes.is_empty() {
            return self.inner.predict_u8_into(queries, out);
        }
        // The queries the eigenspace explains through the method's 8-bit path, the repaired
        // ones through its f32 path.
        self.answer_plain(queries, &plain_of(queries.len() / m, &fixes), out, |q, o| self.inner.predict_u8_into(q, o))?;
        self.put_verified(&fixes, out)
    }
    fn estimate(&self, queries: &[f32], top: usize) -> Result<Vec<Estimate>> {
        let fixes = self.repaired(queries)?;
        if fixes.is_empty() {
            return self.inner.estimate(queries, top);
        }
        let plain = plain_of(queries.len() / self.meta().spec.features(), &fixes);
        let fixed: Vec<usize> = fixes.iter().map(|f| f.0).collect();
        self.merged(queries, &plain, top, &fixed, self.verified(&fixes, top)?)
    }
    fn model_bytes(&self) -> usize {
        self.inner.model_bytes() + self.stage.len() * 4
    }
    fn storage(&self) -> Storage {
        self.inner.storage()
    }
    fn tensors(&self) -> Vec<Tensor> {
        let mut t = self.inner.tensors();
        let k = self.stage.settings().rows;
        t.push(Tensor::f32("robust.rows", vec![k, self.stage.rows().len() / k], self.stage.rows().to_vec()));
        t.push(Tensor::f32("robust.hypotheses", vec![self.stage.hypotheses().len() / k, k], self.stage.hypotheses().to_vec()));
        if let Some((views, poses)) = self.stage.views() {
            let n = poses.len() / self.meta().space.len();
            t.push(Tensor::f32("robust.views", vec![n, views.len() / n], views.to_vec()));
            t.push(Tensor::f64("robust.poses", vec![n, poses.len() / n], poses.to_vec()));
        }
        t
    }
    fn to_bytes(&self) -> Result<Vec<u8>> {
        crate::model::file::model_bytes_with(self, &[(META_KEY, serde_json::to_string(self.stage.settings()).expect("plain struct serialises"))])
    }
    fn coefficients(&self) -> Option<&[f64]> {
        self.inner.coefficients()
    }
    fn scene_search(&self) -> Option<&dyn SceneSearch> {
        Some(self)
    }
}

impl SceneSearch for Robust {
    /// Each scene searched for the box the stage's eigenspace explains best (`locate.rs`), the
    /// box resampled to the training views' size and repaired as any query (when the check
    /// says so); a repaired view's box is then settled with the pose answered from it
    /// (`settle.rs`), and cut and repaired again.
    fn locate(&self, scenes: &[f32], spec: ImageSpec) -> Result<Vec<Located>> {
        let m = spec.features();
        crate::model::check_queries(m, scenes.len(), "scene batch")?;
        scenes
            .par_chunks(m)
            .map(|scene| {
                let scene = self.stage.scene(scene, spec)?;
                let mut found = self.stage.locate(&scene)?;
                self.repair_located(&mut found);
                if found.repaired {
                    let evidence = self.stage.evidence_of(&found.view, &found.kept);
                    let answer = self.verified_rows(&found.view, &[(self.stage.clear(found.shown), &evidence)], 1)?.remove(0).pose;
                    if let Some((bbox, pose)) = self.stage.settle(&scene, found.bbox, &answer, found.kept.theta, &self.meta().space) {
                        found = self.stage.cut(&scene, bbox);
                        self.repair_located(&mut found);
                        found.kept.settled = Some(pose);
                    }
                }
                Ok(found)
            })
            .collect()
    }
    fn method_model(&self) -> &dyn PoseModel {
        &self.inner
    }
    fn predict_located(&self, found: &[Located]) -> Result<Vec<f64>> {
        let views: Vec<f32> = found.iter().flat_map(|f| f.view.iter().copied()).collect();
        let (fixed, plain) = repaired_or_not(found);
        let p = self.meta().space.len();
        let mut out = vec![0.0; found.len() * p];
        self.answer_plain(&views, &plain, &mut out, |q, o| self.inner.predict_into(q, o))?;
        for (&i, e) in fixed.iter().zip(self.checked_located(found, &fixed, 1)?) {
            out[i * p..(i + 1) * p].copy_from_slice(&e.pose);
        }
        Ok(out)
    }
    fn estimate_located(&self, found: &[Located], top: usize) -> Result<Vec<Estimate>> {
        let views: Vec<f32> = found.iter().flat_map(|f| f.view.iter().copied()).collect();
        let (fixed, plain) = repaired_or_not(found);
        self.merged(&views, &plain, top, &fixed, self.checked_located(found, &fixed, top)?)
    }
}

/// The places of the located views that were repaired, and of the others.
fn repaired_or_not(found: &[Located]) -> (Vec<usize>, Vec<usize>) {
    (0..found.len()).partition(|&i| found[i].repaired)
}
