//! Ranked hypotheses and a confidence for every estimate ([`Estimate`]), so an estimate can say
//! "45 or 225, I can't tell" instead of a confident 45 when the truth is 225.
//!
//! Every method returns, beside its pose, the best few *distinct* poses it considered
//! ([`Hypothesis`]): local minima of its search separated from the estimate and from each other
//! by at least [`GROSS_DEG`] on the error measure, so that every alternative is one whose choice
//! would be a gross error. A nearly symmetric object (front resembling back) has two such minima
//! at almost the same distance; an asymmetric one has one far below the rest.
//!
//! **The eigenspace and the refined method** take a second look (`second_look`): the
//! basins of the query's distance to the manifold in every principal component of the training
//! views decide which is the estimate, and each is scored by its squared distance d_k as the
//! posterior of a Gaussian error: proportional to exp(-d_k / 2 s^2), with s^2
//! from the training views alone (their held-out distance, the share of it a fresh view is
//! expected at, and how many coordinates it spreads over), or from the query's own distance d_1
//! when it is farther from the manifold than that (noise, an unseen appearance), so a query the
//! model explains badly is not trusted to tell two near hypotheses apart. One more alternative
//! is no pose at all: that the query is none of the manifold's views (another object, an image
//! not registered like the training views), scored alike at the squared distance of a training
//! view held out of the manifold (the surface through the others, twice as far apart). A query
//! well nearer the manifold than that, as fresh views and noisy ones are, gives it almost no
//! weight; one farther from the manifold than that gets a confidence near 0, whatever its
//! basins. Each
//! hypothesis's [`Hypothesis::score`] is its probability among these alternatives (so the
//! scores add up to less than 1 where the query is unexplained), and the estimate's is the
//! [`Estimate::confidence`].
//!
//! **The linear model** considers one pose only; its confidence is the probability that its
//! estimate is within [`GROSS_DEG`] of the truth if each (cos, sin) pair's error were isotropic
//! Gaussian with the spread of the model's exact leave-one-out residuals on its training set: a
//! pair of length r then points within delta of its noiseless direction with probability about
//! erf(r sin(delta) / (s sqrt 2)). A short pair (the model torn between directions) or a model
//! whose left-out views scatter widely is not trusted.
//!
//! An estimate whose confidence is under [`FLAG_BELOW`] is *flagged*: not to be trusted without
//! a look.
//!
//! ```
//! use linpose::image_io::{ColorMode, ImageSpec};
//! use linpose::{Dataset, EigenspaceParams, Estimator, Param, PoseModel, PoseSpace};
//!
//! // A turntable seen every 10 degrees: 64 "pixels" round it, lit by two equal lobes half a
//! // turn apart (front and back alike), or by one.
//! let lobe = |a: f64, p: usize| (3.0 * ((p as f64 / 64.0 * std::f64::consts::TAU - a.to_radians()).cos() - 1.0)).exp();
//! let twin = |a: f64| (0..64).map(move |p| (0.2 + lobe(a, p) + lobe(a + 180.0, p)) as f32);
//! let single = |a: f64| (0..64).map(move |p| (0.2 + lobe(a, p)) as f32);
//! let space = PoseSpace::new(vec![Param::circular("azimuth", 360.0)])?;
//! let poses: Vec<f64> = (0..36).map(|k| 10.0 * k as f64).collect();
//! let spec = ImageSpec { width: 64, height: 1, color: ColorMode::Gray };
//!
//! let data = Dataset::new(spec, poses.iter().flat_map(|&a| twin(a)).collect(), space.clone(), poses.clone())?;
//! let model = EigenspaceParams::default().components(8).fit(&data)?;
//! let est = &model.estimate(&twin(123.0).collect::<Vec<f32>>(), 2)?[0];
//! // Two hypotheses half a turn apart, and no way to tell them apart.
//! let gap = (est.hypotheses[0].pose[0] - est.hypotheses[1].pose[0]).abs();
//! assert!((gap - 180.0).abs() < 2.0 && est.confidence < 0.6, "{est:?}");
//!
//! let data = Dataset::new(spec, poses.iter().flat_map(|&a| single(a)).collect(), space, poses)?;
//! let model = EigenspaceParams::default().components(8).fit(&data)?;
//! let est = &model.estimate(&single(123.0).collect::<Vec<f32>>(), 2)?[0];
//! assert!(est.confidence > 0.99 && (est.pose[0] - 123.0).abs() <= 1.0, "{est:?}");
//! # Ok::<(), linpose::Error>(())
//! ```

use serde::{Deserialize, Serialize};

/// An error of more than this many degrees is gross (a flip, a wrong side): hypotheses are at
/// least this far apart, and evaluation counts how many gross errors were flagged.
/// The value is the definition the project's issue tracker and `experiment` use for a gross
/// failure; not tuned.
pub const GROSS_DEG: f64 = 20.0;

pub use crate::tuning::confidence::FLAG_BELOW;

pub(crate) use crate::tuning::confidence::MAX_HYPOTHESES;

/// One pose a model considered for a query.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Hypothesis {
    /// The pose (degrees, circular values in [0, period)).
    pub pose: Vec<f64>,
    /// Its probability of being the right one, in [0, 1], among the hypotheses found and (the
    /// eigenspace and the refined method) the possibility that the query is none of the
    /// model's views: the scores add up to at most 1.
    pub score: f64,
    /// Its squared distance from the query in the method's metric (the linear model: 0).
    pub distance: f64,
}

/// A query's estimate with its ranked hypotheses and its confidence.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    /// The estimated pose: what [`crate::PoseModel::predict`] returns.
    pub pose: Vec<f64>,
    /// The probability, in [0, 1], that the estimate is within [`GROSS_DEG`] of the truth, as the
    /// model judges it from its training views.
    pub confidence: f64,
    /// The estimate first, then the distinct alternatives by decreasing score (at most the number
    /// asked for).
    pub hypotheses: Vec<Hypothesis>,
}

impl Estimate {
    /// Whether the estimate is flagged at threshold `below` (confidence under it).
    pub fn flagged(&self, below: f64) -> bool {
        !(self.confidence >= below)
    }

    /// An estimate of one pose only, with its confidence (the linear model's).
    pub(crate) fn single(pose: Vec<f64>, confidence: f64) -> Self {
        Estimate { hypotheses: vec![Hypothesis { pose: pose.clone(), score: confidence, distance: 0.0 }], pose, confidence }
    }
}

/// Takes into account how much of the object a repaired query shows: `clear` is the
/// probability that a robust fit showing that share reads the pose right, as the robust stage
/// calibrated it on its own training views ([`crate::robust::Robust`]); the confidence and every
/// hypothesis's score are scaled by it, the rest of the probability going to no pose at all.
pub(crate) fn for_hidden(est: &mut Estimate, clear: f64) {
    let f = if clear.is_nan() { 0.0 } else { clear.clamp(0.0, 1.0) };
    est.confidence *= f;
    est.hypotheses.iter_mut().for_each(|h| h.score *= f);
}

/// The probability of each of several distinct candidate poses of a query (at least
/// [`GROSS_DEG`] apart), at squared distances `d` from it, where a fresh view of the object lies
/// at squared distance `level` from the manifold on average: the posterior of an isotropic
/// Gaussian error of variance s^2 per coordinate over `dims` coordinates, exp(-d_k / 2 s^2)
/// normalised, with s^2 = max(level, d_1) / dims (d_1 the least distance: a query farther from
/// the manifold than fresh views are is not trusted to tell near candidates apart).
///
/// `unexplained`, when given, is one more alternative that is no pose: that the query is none of
/// the manifold's views (another object, an image not registered like the training views), at
/// the squared distance of a view the manifold does not hold (see
/// `second_look::SecondLookSettings::held_out`). It takes its share of the probability
/// and is not returned, so the candidates' probabilities then add up to less than 1.
pub(crate) fn posterior(d: &[f64], level: f64, dims: f64, unexplained: Option<f64>) -> Vec<f64> {
    let d1 = d.iter().copied().fold(f64::INFINITY, f64::min);
    let s2 = level.max(d1).max(f64::MIN_POSITIVE) / dims.max(1.0);
    let least = unexplained.map_or(d1, |u| u.min(d1));
    let weight = |dk: f64| if dk.is_finite() { (-(dk - least) / (2.0 * s2)).exp() } else { 0.0 };
    let w: Vec<f64> = d.iter().map(|&dk| weight(dk)).collect();
    let total: f64 = w.iter().sum::<f64>() + unexplained.map_or(0.0, weight);
    w.iter().map(|&x| x / total).collect()
}

/// The local minima of `cost` over a grid of `shape` (points per axis and whether the axis is
/// circular; row-major, the last axis fastest): the points no greater than any neighbour one step
/// along an axis (a circular axis wraps). NaN costs are never minima.
pub(crate) fn grid_minima(shape: &[(usize, bool)], cost: &[f64]) -> Vec<usize> {
    let stride = row_major_strides(shape);
    (0..cost.len()).filter(|&k| !cost[k].is_nan() && grid_neighbours(shape, &stride, k).all(|k2| !(cost[k2] < cost[k]))).collect()
}

/// The flat-index strides of a row-major grid of `shape` (the last axis fastest).
pub(crate) fn row_major_strides(shape: &[(usize, bool)]) -> Vec<usize> {
    let d = shape.len();
    let mut stride = vec![1usize; d];
    for j in (0..d.saturating_sub(1)).rev() {
        stride[j] = stride[j + 1] * shape[j + 1].0;
    }
    stride
}

/// The points one step from point `k` along each axis of a row-major grid of `shape` with
/// strides `stride` ([`row_major_strides`]): a circular axis wraps, a linear one ends.
pub(crate) fn grid_neighbours<'a>(shape: &'a [(usize, bool)], stride: &'a [usize], k: usize) -> impl Iterator<Item = usize> + 'a {
    shape.iter().zip(stride).flat_map(move |(&(n, circular), &st)| {
        let i = k / st % n;
        let base = k - i * st;
        let lower = if i > 0 {
            Some(i - 1)
        } else if circular && n > 1 {
            Some(n - 1)
        } else {
            None
        };
        let upper = if i + 1 < n {
            Some(i + 1)
        } else if circular && n > 1 {
            Some(0)
        } else {
            None
        };
        lower.into_iter().chain(upper).map(move |i2| base + i2 * st)
    })
}

/// The linear model's confidence in a pose decoded from pairs of length `lengths` (one per
/// circular parameter), each pair's error having spread `spread` per component (the leave-one-out
/// residuals' RMS): the product over the pairs of erf(r sin([`GROSS_DEG`]) / (s sqrt 2)).
pub(crate) fn pair_confidence(lengths: &[f64], spread: &[f64]) -> f64 {
    lengths
        .iter()
        .zip(spread)
        .map(|(&r, &s)| if s > 0.0 { libm::erf(r.max(0.0) * GROSS_DEG.to_radians().sin() / (s * std::f64::consts::SQRT_2)) } else { 1.0 })
        .product()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_equal_minima_split_the_confidence() {
        let p = posterior(&[1.0, 1.0], 1.0, 4.0, None);
        assert!((p[0] - 0.5).abs() < 1e-12 && (p[1] - 0.5).abs() < 1e-12);
    }

    #[test]
    fn a_far_alternative_leaves_the_estimate_confident() {
        assert!(posterior(&[1.0, 40.0], 1.0, 4.0, None)[0] > 0.999);
        let near = posterior(&[1.0, 1.2], 1.0, 4.0, None);
        assert!(near[0] < 0.6 && near[0] > 0.5, "{near:?}");
        // A query far from the manifold (d_1 beyond the level) trusts the gap less.
        let far = posterior(&[8.0, 16.0], 1.0, 4.0, None);
        let close = posterior(&[1.0, 9.0], 1.0, 4.0, None);
        assert!(far[0] < close[0]);
        assert!((far.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_query_farther_than_the_unexplained_level_is_not_trusted() {
        // Near the manifold, far below the unexplained level: as without it.
        let near = posterior(&[1.0, 40.0], 1.0, 20.0, Some(16.0));
        assert!(near[0] > 0.999, "{near:?}");
        assert_eq!(posterior(&[1.0, 1.2], 1.0, 20.0, Some(16.0)), posterior(&[1.0, 1.2], 1.0, 20.0, None));
        // Beyond it: no candidate is likely, however far its rivals.
        let far = posterior(&[80.0, 400.0], 1.0, 20.0, Some(16.0));
        assert!(far[0] < 1e-3, "{far:?}");
        // At it: even odds with the estimate.
        let at = posterior(&[16.0], 1.0, 20.0, Some(16.0));
        assert!((at[0] - 0.5).abs() < 1e-12, "{at:?}");
    }

    #[test]
    fn grid_minima_wrap_on_circular_axes() {
        let cost = [0.0, 1.0, 2.0, 1.5, 3.0, 0.5];
        assert_eq!(grid_minima(&[(6, true)], &cost), vec![0, 3]);
        assert_eq!(grid_minima(&[(6, false)], &cost), vec![0, 3, 5]);
        // 2 x 3, the last axis fastest and circular.
        let cost = [5.0, 1.0, 5.0, 0.0, 5.0, 5.0];
        assert_eq!(grid_minima(&[(2, false), (3, true)], &cost), vec![1, 3]);
    }

    #[test]
    fn pair_confidence_falls_with_the_pairs_length() {
        assert!(pair_confidence(&[1.0], &[0.05]) > 0.999);
        assert!(pair_confidence(&[0.1], &[0.05]) < 0.6);
        assert!(pair_confidence(&[1.0, 0.1], &[0.05, 0.05]) < pair_confidence(&[1.0, 1.0], &[0.05, 0.05]));
    }
}
