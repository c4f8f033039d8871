//! How far a repaired query can be trusted given how much of its object it shows, calibrated on
//! the training set's own views when the stage is fitted.
//!
//! A repaired query's fit says which share of the reconstruction's bright pixels the query
//! explains (`Fit::shown`). Whether a pose can still be read from that share depends on the
//! object: a share that pins a car's pose may leave a cup's undecided. So the stage measures it
//! on its own training views: each of a few views (at most [`tuning::HIDDEN_VIEWS`], taken
//! evenly) is put on clutter made of another training view, shifted and dimmed (clutter that
//! resembles the object is the hard case), and hidden by an opaque rectangle grown from a random
//! side until it covers a share of the view's bright pixels ([`tuning::HIDDEN_SHARES`]), filled
//! with a flat value or with another shifted training view; the stage fits it robustly, as a
//! query (those its check passes are left out: they keep their confidence), and the fit reads
//! *right* when the hypothesis nearest its coefficients (in its gain) is within [`GROSS_DEG`]
//! of the view's pose. (The view's own hypothesis counts: judged by the nearest of the others,
//! as for a query between training views, a nearly symmetric object's clean views often read
//! wrong, its far side nearer in coefficients than its neighbours, and on COIL-20 objects 1-10 in
//! texture scenes, refined, 0-80% hidden, 23-96% of the estimates within 20 degrees were flagged,
//! against 7-83% with it, and 90-100% of the gross errors against 40-100%.) The probability that a fit reads right is then fitted as a logistic in `shown`
//! (two numbers, stored in the stage's settings), with one pseudo-observation at each end (a fit
//! that shows nothing reads wrong, one that shows everything reads right) so that a set whose
//! fits all read right, or all wrong, still gives finite numbers. A repaired query's confidence
//! is its method's times that probability at its `shown` ([`crate::confidence::for_hidden`]).
//!
//! The synthetic queries are training views, not views between them, and the clutter is the
//! object's own views, not the scene's: what it measures is how much of the object a pose needs,
//! not how the scene looks. It is the robust fit that is judged, not the method behind it: a
//! fit that reads right may still be answered wrongly by the method (its own confidence speaks
//! for that). It costs one robust fit per synthetic query (about
//! `HIDDEN_VIEWS x HIDDEN_SHARES x HIDDEN_DRAWS`, a few hundred) when the stage is fitted.

use super::reread::Reread;
use super::scan::Lattice;
use super::{search, tuning, Stage};
use crate::confidence::GROSS_DEG;
use crate::dataset::Dataset;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// The probability that a repaired query showing `shown` of its object reads its pose right:
/// the logistic of `logit` ([a, b]: 1 / (1 + exp(-(a + b shown)))), or, for a stage of a model
/// file written before the calibration, the linear ramp between
/// [`tuning::LEGACY_SHOWN_LOW`] and [`tuning::LEGACY_SHOWN_HIGH`].
pub(crate) fn clear(logit: Option<[f64; 2]>, shown: f64) -> f64 {
    let p = match logit {
        Some([a, b]) => 1.0 / (1.0 + (-(a + b * shown)).exp()),
        None => ((shown - tuning::LEGACY_SHOWN_LOW) / (tuning::LEGACY_SHOWN_HIGH - tuning::LEGACY_SHOWN_LOW)).clamp(0.0, 1.0),
    };
    if p.is_nan() {
        0.0
    } else {
        p
    }
}

/// One synthetic query's outcome: the share of the object its fit says it shows, and whether
/// the fit reads the view's pose right.
type Outcome = (f64, bool);

/// The logistic [a, b] of the probability that `stage`'s fit of a hidden view of `train` (the
/// views the stage was fitted on) reads its pose right, against the share it shows.
pub(super) fn calibrate(stage: &Stage, train: &Dataset) -> [f64; 2] {
    let outcomes = outcomes(stage, train);
    logistic(&outcomes)
}

/// The synthetic queries' outcomes (see the module doc), in a fixed order: the same training
/// views give the same outcomes.
fn outcomes(stage: &Stage, train: &Dataset) -> Vec<Outcome> {
    let n = train.len();
    let mb = stage.binning.spec().features();
    let mut views = vec![0f32; n * mb];
    let mut acc = Vec::new();
    for (i, v) in views.chunks_exact_mut(mb).enumerate() {
        stage.binning.apply(train.row(i), v, &mut acc);
    }
    let held = held_out(stage, train, &views);
    let (lattice, queries) = match &held {
        Some((l, off)) => (Some(l), off.clone()),
        None => (stage.lattice.as_ref(), (0..n).collect()),
    };
    let every = queries.len().div_ceil(tuning::HIDDEN_VIEWS).max(1);
    let jobs: Vec<(usize, usize, usize)> = queries
        .iter()
        .step_by(every)
        .flat_map(|&i| (0..tuning::HIDDEN_SHARES.len()).flat_map(move |s| (0..tuning::HIDDEN_DRAWS).map(move |d| (i, s, d))))
        .collect();
    jobs.par_iter()
        .filter_map(|&(i, s, d)| {
            let mut rng = ChaCha8Rng::seed_from_u64(((i as u64) << 20) ^ ((s as u64) << 10) ^ d as u64);
            let xb = hidden_view(stage, &views, i, tuning::HIDDEN_SHARES[s], &mut rng);
            let share = stage.dark_share_binned(&xb)?;
            if share <= stage.settings.threshold {
                // The check passes it: it is answered as it is, its confidence untouched.
                return None;
            }
            let fit = search::fit_on(stage, &xb, &search::coarse_on(stage, &xb, lattice), lattice);
            Some((fit.shown, reads_right(stage, train, i, &fit)))
        })
        .collect()
}

/// Whether `fit` of a hidden view of training view `i` reads its pose right: the pose of the
/// lattice hypothesis it started from, or else of the hypothesis nearest its coefficients (in
/// its gain), within [`GROSS_DEG`] of the view's.
fn reads_right(stage: &Stage, train: &Dataset, i: usize, fit: &super::Fit) -> bool {
    reads_right_at(stage, train, train.pose(i), fit)
}

/// [`reads_right`] of a view at `truth`.
pub(super) fn reads_right_at(stage: &Stage, train: &Dataset, truth: &[f64], fit: &super::Fit) -> bool {
    let space = train.space();
    if let Some(pose) = &fit.pose {
        return space.error_deg(truth, pose) <= GROSS_DEG;
    }
    let k = stage.settings.rows;
    // The stage's hypotheses are the training views taken every `step`.
    let step = super::hypothesis_step(train.len());
    fit.coef[0] > 0.0 && {
        let y: Vec<f64> = fit.coef[1..].iter().map(|c| c / fit.coef[0]).collect();
        let dist = |h: usize| stage.hyps[h * k + 1..(h + 1) * k].iter().zip(&y).map(|(&a, b)| (a as f64 - b).powi(2)).sum::<f64>();
        let best = (0..stage.hyps.len() / k).min_by(|&a, &b| dist(a).total_cmp(&dist(b)));
        best.is_some_and(|h| space.error_deg(truth, train.pose(h * step)) <= GROSS_DEG)
    }
}

/// For a stage with a dense lattice (`scan.rs`): the lattice of the training views at every
/// other value of each parameter of at least four values (knots twice as far apart), and the
/// views off it, each as far from its nearest knots as a query halfway between two training
/// views is from the stage's own, at twice the spacing; None without a lattice, or when the
/// views at every other value are not a lattice the reread can interpolate.
fn held_out(stage: &Stage, train: &Dataset, views: &[f32]) -> Option<(Lattice, Vec<usize>)> {
    stage.lattice.as_ref()?;
    let (n, mb, space) = (train.len(), stage.binning.spec().features(), train.space());
    let values: Vec<Vec<f64>> = (0..space.len())
        .map(|j| {
            let mut v: Vec<f64> = (0..n).map(|i| train.pose(i)[j]).collect();
            v.sort_by(f64::total_cmp);
            v.dedup();
            v
        })
        .collect();
    let kept = |i: usize| values.iter().zip(train.pose(i)).all(|(v, &t)| v.len() < 4 || v.iter().position(|&u| u == t).is_some_and(|k| k % 2 == 0));
    let (knots, off): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| kept(i));
    if off.is_empty() {
        return None;
    }
    let kv: Vec<f32> = knots.iter().flat_map(|&i| views[i * mb..(i + 1) * mb].iter().copied()).collect();
    let kp: Vec<f64> = knots.iter().flat_map(|&i| train.pose(i).iter().copied()).collect();
    let reread = Reread::of(&kv, &kp, space, stage.binning.spec())?;
    Some((Lattice::of(&reread, &stage.binned, &stage.support)?, off))
}

/// Training view `i` of the binned `views` (rows of the stage's binned size) on clutter and
/// hidden by an opaque rectangle over `share` of its bright pixels (see the module doc).
fn hidden_view(stage: &Stage, views: &[f32], i: usize, share: f64, rng: &mut ChaCha8Rng) -> Vec<f32> {
    let s = stage.binning.spec();
    let (w, h) = (s.width as usize, s.height as usize);
    let mb = w * h;
    let n = views.len() / mb;
    let view = &views[i * mb..(i + 1) * mb];
    let peak = view.iter().fold(0f32, |a, &v| a.max(v));
    // Another training view, shifted (wrapping) and scaled by `gain`.
    let other = |gain: f32, rng: &mut ChaCha8Rng| -> Vec<f32> {
        let j = if n > 1 { (i + 1 + rng.random_range(0..n - 1)) % n } else { i };
        let (dx, dy) = (rng.random_range(0..w), rng.random_range(0..h));
        let o = &views[j * mb..(j + 1) * mb];
        (0..mb).map(|p| gain * o[((p / w + dy) % h) * w + (p % w + dx) % w]).collect()
    };
    let clutter = other(rng.random_range(tuning::CLUTTER_GAIN[0]..tuning::CLUTTER_GAIN[1]), rng);
    let mut x: Vec<f32> = view.iter().zip(&clutter).map(|(&v, &c)| if v > tuning::OBJECT * peak { v } else { c }).collect();
    let bright: Vec<bool> = view.iter().map(|&v| v > tuning::BRIGHT * peak).collect();
    let total = bright.iter().filter(|&&b| b).count();
    if share <= 0.0 || total == 0 {
        return x;
    }
    // The rectangle: from a random side, across a random part of the other axis, as deep as it
    // takes to cover `share` of the bright pixels.
    let side = rng.random_range(0..4);
    let (along, across) = if side < 2 { (w, h) } else { (h, w) };
    let span = rng.random_range(across.div_ceil(2)..=across);
    let start = rng.random_range(0..=across - span);
    let at = |d: usize, c: usize| -> usize {
        let d = if side % 2 == 0 { d } else { along - 1 - d };
        if side < 2 {
            c * w + d
        } else {
            d * w + c
        }
    };
    let mut hidden = vec![false; mb];
    let mut covered = 0;
    for d in 0..along {
        if covered as f64 >= share * total as f64 {
            break;
        }
        for c in start..start + span {
            let p = at(d, c);
            hidden[p] = true;
            covered += bright[p] as usize;
        }
    }
    let fill: Vec<f32> = if rng.random_bool(0.5) {
        vec![rng.random_range(0.0..1.0) * peak; mb]
    } else {
        other(rng.random_range(tuning::CLUTTER_GAIN[0]..tuning::CLUTTER_GAIN[1]), rng)
    };
    x.iter_mut().zip(&hidden).zip(&fill).filter(|((_, &hid), _)| hid).for_each(|((v, _), &f)| *v = f);
    x
}

/// The logistic regression [a, b] of right against shown over `outcomes`, with one wrong
/// pseudo-outcome at shown 0 and one right one at shown 1 (Newton's method on the
/// log-likelihood); a slope that comes out negative (more shown, less often right: no
/// evidence that the share matters) is 0, the intercept then the log-odds of the share right.
fn logistic(outcomes: &[Outcome]) -> [f64; 2] {
    let data: Vec<Outcome> = outcomes.iter().copied().chain([(0.0, false), (1.0, true)]).collect();
    let (mut a, mut b) = (0f64, 0f64);
    for _ in 0..100 {
        let (mut ga, mut gb, mut haa, mut hab, mut hbb) = (0f64, 0f64, 0f64, 0f64, 0f64);
        for &(x, y) in &data {
            let p = 1.0 / (1.0 + (-(a + b * x)).exp());
            let r = y as u8 as f64 - p;
            let wgt = (p * (1.0 - p)).max(1e-12);
            ga += r;
            gb += r * x;
            haa += wgt;
            hab += wgt * x;
            hbb += wgt * x * x;
        }
        let det = haa * hbb - hab * hab;
        if !(det > 0.0) {
            break;
        }
        let (da, db) = ((hbb * ga - hab * gb) / det, (haa * gb - hab * ga) / det);
        a += da;
        b += db;
        if da.abs() + db.abs() < 1e-10 {
            break;
        }
    }
    if b < 0.0 || !(a.is_finite() && b.is_finite()) {
        let right = data.iter().filter(|o| o.1).count() as f64;
        return [(right / (data.len() as f64 - right)).ln(), 0.0];
    }
    [a, b]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_logistic_rises_where_the_outcomes_turn_right() {
        // Wrong under 0.4, right above.
        let o: Vec<Outcome> = (0..100).map(|i| (i as f64 / 100.0, i >= 40 || i % 7 == 0)).collect();
        let [a, b] = logistic(&o);
        let p = |s: f64| clear(Some([a, b]), s);
        assert!(b > 0.0 && p(0.1) < 0.3 && p(0.8) > 0.9 && (p(0.4) - 0.5).abs() < 0.25, "{a} {b}");
        // All right: finite, high everywhere but at the pseudo-observation's end.
        let [a, b] = logistic(&(0..50).map(|i| (0.3 + i as f64 / 100.0, true)).collect::<Vec<_>>());
        assert!(a.is_finite() && b.is_finite() && clear(Some([a, b]), 0.5) > 0.9, "{a} {b}");
        // More shown, less right: no slope.
        let [_, b] = logistic(&(0..50).map(|i| (i as f64 / 50.0, i < 25)).collect::<Vec<_>>());
        assert_eq!(b, 0.0);
    }

    #[test]
    fn without_a_calibration_the_legacy_ramp_holds() {
        assert_eq!(clear(None, 0.1), 0.0);
        assert_eq!(clear(None, 0.9), 1.0);
        assert!((clear(None, 0.4) - 0.5).abs() < 1e-12);
        assert_eq!(clear(Some([0.0, 1.0]), f64::NAN), 0.0);
    }
}
