//! Whether and how to normalise, chosen on held-out training views, as the refined method chooses
//! its own settings.
//!
//! The normalisation stage ([`crate::normalize`]) centres, scales and brightens every image before
//! a method sees it. On real turntable sets it cuts the error several-fold: their makers' framing
//! scales each view so that its bounding box fills the frame, which changes with the pose, and the
//! stage's size measure varies less. On a rendered set registered exactly, it can cost: resampling
//! every view moves the near-ties between a nearly symmetric object's two sides. Which of the
//! four (off, brightness, geometry, all) serves a training set, and a method, is a question its
//! own training views can answer:
//!
//! 1. The stage of each candidate is fitted on the training views and every view goes through it.
//! 2. The views are split into held-out folds: along each pose axis with enough values in turn,
//!    the views at every other value held out, then the others (the refined method's folds,
//!    which hold every view out once at twice the training spacing); when the poses are not a
//!    grid, every other view in order, then the others.
//! 3. The method is fitted on each fold's kept views and estimates the held-out ones, as they are
//!    and with the paper's +-5% and +-10% pixel noise added before the stage (a noisy query's
//!    path: `tuning.rs`). A candidate's score is its mean error over the three conditions'
//!    views together: a stage that serves clean views and costs noisy ones is scored on both,
//!    and a view turned around (more than [`GROSS_DEG`] off) weighs in with its whole error.
//! 4. The simplest candidate (in the order off, brightness, geometry, all) whose score is within
//!    three standard errors (`MARGIN`, stage_choice/tuning.rs) of the best's (the standard
//!    deviation of the best's errors over the square root of their number) wins. A stage is
//!    taken only when the held-out views show that it pays by clearly more than chance.
//!
//! The folds are the refined method's, and the noise levels the ones it simulates for its noisy
//! match. The margin is the one constant developed on data (`tuning.rs` says how): held-out
//! views lie twice as far from the training views as a fresh view does, where registration
//! helps more than it does at the training spacing, so a gain there must be clear to last. What
//! it cannot see: a stage that serves the held-out views by more than the margin and costs the
//! fresh ones a little (docs/normalization.md has the cases measured).
//!
//! The stage is fitted once on all the training views (a median radius and brightness, which one
//! view hardly moves); only the method is refitted without the held-out views. A candidate the
//! stage cannot apply (a training view with a second object apart from the first) is recorded
//! with the reason and left out. What it costs: the method is fitted once per fold and candidate
//! (16 fits for a grid of two pose axes), on about half the training views each, and estimates
//! the held-out views three times.

mod tuning;

use crate::confidence::GROSS_DEG;
use crate::dataset::Dataset;
use crate::manifold::folds::{mean, standard_error};
use crate::manifold::grid::Grid;
use crate::model::Normalized;
use crate::model::{AnyModel, MethodSpec};
use crate::normalize::{CandidateScore, NoisyScore, NormalizeParams, Normalizer, StageChoice, StageRule};
use crate::Result;
use rayon::prelude::*;
use tuning::{MARGIN, NOISE_LEVELS, NOISE_SEED, REFUSED_DEG};

impl MethodSpec {
    /// Fits on `train` behind the normalisation stage `rule` decides: a fixed stage, or
    /// ([`StageRule::Auto`]) the one among off, brightness, geometry and all whose held-out
    /// training views score best by clearly more than chance (docs/normalization.md says how).
    /// The model's metadata records the decision ([`crate::ModelMeta::stage_choice`]).
    pub fn fit_with_stage(&self, train: &Dataset, rule: StageRule) -> Result<AnyModel> {
        let choice = match rule {
            StageRule::Fixed(p) => StageChoice::fixed(p),
            StageRule::Auto => choose(self, train)?,
        };
        self.fit_with_choice(train, choice)
    }

    /// Fits on `train` behind the normalisation `choice` made, and records it.
    pub fn fit_with_choice(&self, train: &Dataset, choice: StageChoice) -> Result<AnyModel> {
        let params = choice.params();
        if !params.is_on() {
            return Ok(AnyModel::new(Normalized::recorded(None, self.fit(train)?, Some(choice))));
        }
        let stage = Normalizer::fit(train, params)?;
        let data = stage.apply_dataset(train)?;
        let inner = self.fit(&data)?;
        Ok(AnyModel::new(Normalized::recorded(Some(stage), inner, Some(choice))))
    }
}

/// Chooses the normalisation for `spec` on `train`'s held-out views (the module doc).
pub(crate) fn choose(spec: &MethodSpec, train: &Dataset) -> Result<StageChoice> {
    choose_over(spec, &[train])
}

/// Chooses the normalisation of a many-object model fitting `spec` for each object's pose: the
/// objects' held-out errors pooled, behind one stage fitted on all their views.
pub(crate) fn choose_objects(objects: &crate::ObjectSet, spec: &MethodSpec) -> Result<StageChoice> {
    let sets: Vec<&Dataset> = objects.objects().iter().collect();
    choose_over(spec, &sets)
}

/// The errors of one candidate in each condition (clean, then each noise level), pooled over
/// the sets and their folds in a fixed order, or why it could not be scored.
type Conditions = std::result::Result<Vec<Vec<f64>>, String>;

/// The choice over data sets of one image size, each with its own folds, behind one stage.
fn choose_over(spec: &MethodSpec, sets: &[&Dataset]) -> Result<StageChoice> {
    let folds: Vec<Vec<Vec<bool>>> = sets.iter().map(|d| folds(d)).collect();
    if folds.iter().all(|f| f.is_empty()) {
        return Ok(StageChoice::off("too few training views to hold any out, so the images are used as they are"));
    }
    // The candidates one after the other, the folds of each in parallel.
    let scored: Vec<(NormalizeParams, Conditions)> = NormalizeParams::CHOICES
        .into_iter()
        .map(|p| {
            let stage = match p.is_on() {
                true => match Normalizer::fit_sets(sets, p) {
                    Ok(s) => Some(s),
                    Err(e) => return (p, Err(e.to_string())),
                },
                false => None,
            };
            let mut pooled: Vec<Vec<f64>> = vec![Vec::new(); 1 + NOISE_LEVELS.len()];
            for (d, f) in sets.iter().zip(&folds) {
                match held_out_errors(spec, d, stage.as_ref(), f) {
                    Ok(each) => pooled.iter_mut().zip(each).for_each(|(a, b)| a.extend(b)),
                    Err(e) => return (p, Err(e)),
                }
            }
            (p, Ok(pooled))
        })
        .collect();
    Ok(decide(&scored))
}

/// The mean and gross errors of held-out errors `e`.
fn stats(e: &[f64]) -> (usize, f64) {
    (e.iter().filter(|&&v| v > GROSS_DEG).count(), e.iter().sum::<f64>() / e.len().max(1) as f64)
}

/// The decision from every candidate's held-out errors in each condition (the same views in the
/// same order for every candidate), or why a candidate could not be scored.
fn decide(scored: &[(NormalizeParams, Conditions)]) -> StageChoice {
    let usable: Vec<(NormalizeParams, Vec<f64>)> =
        scored.iter().filter_map(|(p, r)| r.as_ref().ok().filter(|c| c.iter().all(|e| !e.is_empty())).map(|c| (*p, c.concat()))).collect();
    let best = usable.iter().min_by(|a, b| mean(&a.1).total_cmp(&mean(&b.1)));
    let chosen = best.map(|(_, b)| {
        let within = mean(b) + MARGIN * standard_error(b);
        usable.iter().find(|(_, e)| mean(e) <= within).map_or(NormalizeParams::OFF, |u| u.0)
    });
    let scores = scored
        .iter()
        .map(|(p, r)| match r {
            Ok(c) if c.iter().all(|e| !e.is_empty()) => {
                let (g, m) = stats(&c[0]);
                let pooled = c.concat();
                CandidateScore {
                    stage: p.name().into(),
                    gross: Some(g),
                    mean_deg: Some(m),
                    pooled_deg: Some(mean(&pooled)),
                    standard_error: Some(standard_error(&pooled)),
                    noisy: c[1..].iter().map(|e| stats(e)).map(|(g, m)| NoisyScore { gross: g, mean_deg: m }).collect(),
                    refused: None,
                }
            }
            Ok(_) => CandidateScore::refused(p.name(), "no held-out view"),
            Err(why) => CandidateScore::refused(p.name(), why),
        })
        .collect();
    let note = usable.is_empty().then(|| "no candidate could be scored on held-out views, so the images are used as they are".to_string());
    StageChoice {
        rule: StageRule::Auto.name().into(),
        chosen: chosen.unwrap_or(NormalizeParams::OFF).name().into(),
        held_out_views: scored.iter().find_map(|(_, r)| r.as_ref().ok().map(|c| c[0].len())).unwrap_or(0),
        noise_levels: NOISE_LEVELS.to_vec(),
        scores,
        note,
    }
}

/// The held-out folds of `train` (each the mask of the views kept): the refined method's folds on
/// the grid of its poses, or when they are not a grid, every other view in order and then the
/// others; none for fewer than 4 views.
pub(crate) fn folds(train: &Dataset) -> Vec<Vec<bool>> {
    let grid = Grid::new(train.space(), train.poses(), train.manifest().images(), train.manifest().root());
    let on_grid = grid.map(|g| crate::manifold::folds::both_folds(train, &g)).unwrap_or_default();
    if !on_grid.is_empty() || train.len() < 4 {
        return on_grid;
    }
    (0..2).map(|parity| (0..train.len()).map(|i| i % 2 != parity).collect()).collect()
}

/// `spec`'s error on every held-out view of every fold of `data` behind `stage` (degrees, fold
/// by fold), as the views are and then with each of [`NOISE_LEVELS`] added before the stage; or
/// why the method could not be fitted on a fold. A held-out view the stage refuses counts
/// [`REFUSED_DEG`].
pub(crate) fn held_out_errors(spec: &MethodSpec, data: &Dataset, stage: Option<&Normalizer>, folds: &[Vec<bool>]) -> Conditions {
    let per_fold: Vec<Conditions> = folds
        .par_iter()
        .enumerate()
        .map(|(f, keep)| {
            let fail = |e: crate::Error| format!("the method could not be fitted without the held-out views: {e}");
            let kept = data.subset(keep).map_err(fail)?;
            let kept = match stage {
                Some(s) => s.apply_dataset(&kept).map_err(|e| e.to_string())?,
                None => kept,
            };
            let model = spec.fit(&kept).map_err(fail)?;
            let held: Vec<bool> = keep.iter().map(|k| !k).collect();
            let test = data.subset(&held).map_err(fail)?;
            let (m, k) = (data.n_features(), data.space().len());
            let levels = std::iter::once(0.0).chain(NOISE_LEVELS.iter().copied());
            levels
                .enumerate()
                .map(|(l, amplitude)| {
                    let mut q = test.features().to_vec();
                    crate::pixel_noise::add_uniform_noise(&mut q, m, amplitude, NOISE_SEED + (f * 16 + l) as u64).map_err(fail)?;
                    let (q, verdicts) = match stage {
                        Some(s) => s.apply_batch(&q),
                        None => (q, vec![None; test.len()]),
                    };
                    let est = if q.is_empty() { Vec::new() } else { crate::PoseModel::predict(&model, &q).map_err(fail)? };
                    let mut at = 0;
                    Ok((0..test.len())
                        .map(|i| match verdicts[i] {
                            Some(_) => REFUSED_DEG,
                            None => {
                                at += 1;
                                data.space().error_deg(test.pose(i), &est[(at - 1) * k..at * k])
                            }
                        })
                        .collect())
                })
                .collect::<std::result::Result<Vec<Vec<f64>>, String>>()
        })
        .collect();
    let per_fold = per_fold.into_iter().collect::<std::result::Result<Vec<_>, _>>()?;
    Ok((0..1 + NOISE_LEVELS.len()).map(|l| per_fold.iter().flat_map(|c| c[l].iter().copied()).collect()).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_simplest_candidate_within_one_standard_error_of_the_best_wins() {
        let off = vec![1.0, 1.2, 0.8, 1.0];
        let small_gain = vec![0.98, 1.19, 0.79, 0.99];
        let large_gain = vec![0.5, 0.6, 0.4, 0.5];
        let all = NormalizeParams::CHOICES;
        let same = |e: &Vec<f64>| -> Conditions { Ok(vec![e.clone(), e.clone(), e.clone()]) };
        // A gain within chance does not buy a stage.
        let c = decide(&[(all[0], same(&off)), (all[1], same(&small_gain)), (all[2], Err("refused".into())), (all[3], same(&off))]);
        assert_eq!(c.chosen, "off");
        assert_eq!(c.scores[2].refused.as_deref(), Some("refused"));
        // A clear one does, the simplest candidate that has it.
        let c = decide(&[(all[0], same(&off)), (all[1], same(&off)), (all[2], same(&large_gain)), (all[3], same(&large_gain))]);
        assert_eq!((c.chosen.as_str(), c.held_out_views), ("geometry", 4));
        // Not when it costs noisy views more than it gains on clean ones.
        let costly: Conditions = Ok(vec![large_gain.clone(), vec![2.0, 2.4, 1.6, 2.0], vec![2.0, 2.4, 1.6, 2.0]]);
        let c = decide(&[(all[0], same(&off)), (all[1], same(&off)), (all[2], costly), (all[3], same(&off))]);
        assert_eq!(c.chosen, "off");
        // A flip weighs in with its whole error.
        let flip = vec![0.1, 0.1, 0.1, 25.0];
        let c = decide(&[(all[0], same(&off)), (all[1], same(&flip)), (all[2], same(&off)), (all[3], same(&off))]);
        assert_eq!(c.chosen, "off");
        // Nothing scored: off, with a note.
        let c = decide(&[(all[0], Err("x".into())), (all[1], Err("x".into())), (all[2], Err("x".into())), (all[3], Err("x".into()))]);
        assert_eq!(c.chosen, "off");
        assert!(c.note.is_some());
    }
}
