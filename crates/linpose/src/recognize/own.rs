//! The second stage of "none of these": the recognised object's own eigenspace.
//!
//! The recogniser tells the objects apart in a space shared by all of them (the universal
//! eigenspace's L dimensions, or the linear recogniser's K outputs), which keeps what separates
//! the objects from each other and drops the rest. A view of an object the model never saw can
//! land near one object there while differing from it in details that space does not hold: a toy
//! car left out is taken for another car. So, as Murase & Nayar estimate the pose in the
//! recognised object's own eigenspace, the object named is checked in its own: each object k has
//! the eigenspace of its own unit-energy training views (L_k = min(L, N_k - 1) dimensions, L the
//! universal eigenspace's, `--recognizer-components`) and its spline manifold in it, resampled at
//! the recogniser's step; a query's distance to object k is the distance in image space from its
//! unit-energy image to that manifold, sqrt(r^2 + d^2), r its residual off k's eigenspace and d
//! the distance within it to the nearest manifold point (the universal eigenspace's exact pruned
//! search, with one object: [`Universal::own_distances`]).
//!
//! The query is unknown when that distance exceeds the object's second threshold, calibrated on
//! the object's own training views:
//!
//! 1. **Held out.** Every other knot along each pose axis is held out, then the others; the
//!    object's eigenspace and manifold are refitted on the views kept (the same L_k rule on the
//!    fewer views) and each held-out view's squared distance is measured at its own pose, in two
//!    parts: r^2 off the fold's eigenspace and w^2 within it, to the manifold interpolated from
//!    the kept knots. Keeping one knot in four and measuring the views midway between two kept
//!    knots gives the same views' parts at four times the spacing ([`strided_folds`]).
//! 2. **Brought to the model's spacing.** A held-out view lies a whole knot interval from its
//!    kept neighbours, a fresh view between training views at most half of one, so the held-out
//!    distances overstate a fresh view's. The part within the eigenspace, the interpolation
//!    error along the manifold, shrinks with the spacing at a rate measured on the object itself:
//!    rho = sum w^2 at twice the spacing / sum w^2 at four times, over the same views (at most 1;
//!    1 where no axis has 8 knots), and a fresh view keeps rho w^2, one halving more. The part
//!    off the eigenspace, what the neighbours cannot express (fine detail, a small image's
//!    aliasing, a camera's noise), is kept whole: it need not shrink with the spacing, and one
//!    ratio cannot tell its fall from a floor (correcting the whole distance by its own ratio
//!    reported a twelfth of the known views of small renders unknown).
//! 3. **What does not shrink at all.** The folds' eigenspaces span their few views whole, while
//!    the model's keeps L_k of its N_k - 1 components: what it drops of the object's own views
//!    (f, each training view's squared residual off the model's eigenspace) stays in a fresh
//!    view's distance however close the knots. So each held-out view gives x = f + r^2 + rho w^2.
//! 4. **A stated rate.** A scaled chi-square is fitted to the x by their moments (mean mu,
//!    nu = 2 mu^2 / variance degrees of freedom, at least 1: how many dimensions the distance
//!    spreads over, as the second look's K_eff), and the threshold is its quantile at 1 -
//!    [`OWN_FALSE_REJECTION`], sqrt(mu q_nu / nu). The largest x would be exceeded by a fresh
//!    view drawn like them about once in n + 1 (n held-out views: 1 in 37 on a turntable of 36
//!    training views); the fit states the rate instead.
//!
//! What each step buys on development data: BENCHMARKS.md, "Unknown objects". An object
//! too sparse to hold views out takes the largest threshold of the others; one with a single
//! training view has no eigenspace of its own and no second stage (its threshold is infinite).
//!
//! The eigenspaces are of the images binned as the pose models' second look bins them
//! ([`crate::second_look::SECOND_LOOK_BIN`], coarser only while the binned images keep as many
//! pixels as an object has training views): what tells a car from a car survives 4 x 4 blocks,
//! and the stage stores and multiplies b^2 times fewer numbers.
//!
//! Cost: per object M_b L_k + M_b numbers (eigenimages, mean; M_b = M / b^2) and N_k,dense L_k
//! (its manifold); per query, only for the one object recognised, L_k M_b multiply-adds and a
//! pruned search of that object's manifold.

use super::universal::{to32, Universal};
use super::RecognizerParams;
use crate::binning::Binning;
use crate::catalog::ObjectSet;
use crate::dataset::Dataset;
use crate::image_io::ImageSpec;
use crate::methods::eigenspace::manifold::{Grid, Manifold};
use crate::methods::eigenspace::pca::{self, Dimension};
use crate::methods::refined::select::{strided_folds, StridedFold};
use crate::methods::refined::surface::Surface;
use crate::methods::refined::Interpolant;
use crate::model::{Tensor, TensorSet};
use crate::second_look::SECOND_LOOK_BIN;
use crate::{Error, Result};
use std::collections::HashMap;

/// The share of a known object's fresh views (between its training views) the second stage is
/// designed to report unknown: the upper tail of the distribution fitted to the object's
/// corrected held-out distances (the module doc) beyond its threshold. What it trades: a smaller
/// share raises every threshold, letting more views of objects the model does not know through;
/// a larger one reports more known views unknown. Not tuned on any data set: half of the issue's
/// bar of at most 2% of known unseen views reported unknown, the other half left to the first
/// stage and to views taken for another object. Development data (BENCHMARKS.md, "Unknown
/// objects") shows what it gives.
pub const OWN_FALSE_REJECTION: f64 = 0.01;

/// The standard normal quantile at 1 - [`OWN_FALSE_REJECTION`] (a test checks the two agree).
const FALSE_REJECTION_Z: f64 = 2.326_347_874_040_841;

/// Every object's own eigenspace with its manifold (a [`Universal`] of one object each; `None`
/// for an object of a single training view), of the images binned by `binning`.
#[derive(Debug, Clone)]
pub(crate) struct OwnSpaces {
    spaces: Vec<Option<Universal>>,
    binning: Binning,
}

/// What fitting measured: each object's own dimensions (0 without an eigenspace), held-out
/// distances at twice the knot spacing (empty for an object too sparse to hold knots out) and
/// calibration (`None` for such an object).
pub(crate) struct OwnFit {
    pub model: OwnSpaces,
    pub components: Vec<usize>,
    pub held_out: Vec<Vec<f64>>,
    pub calibration: Vec<Option<Calibration>>,
}

/// One object's calibrated second-stage threshold and what it was fitted from (the module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Calibration {
    /// The share of a held-out view's squared distance at twice the knot spacing that a fresh
    /// view keeps at the model's spacing ([`spacing_ratio`]; at most 1).
    pub spacing_ratio: f64,
    /// The degrees of freedom of the scaled chi-square fitted to the corrected distances.
    pub spread_dims: f64,
    /// The distance beyond which a query is unknown.
    pub threshold: f64,
}

impl OwnSpaces {
    /// Fits every object's own eigenspace on its training views, one object after the other (the
    /// largest object's fit is far smaller than the recogniser's, so the training's peak memory
    /// is unchanged).
    pub fn fit(objects: &ObjectSet, params: &RecognizerParams) -> Result<OwnFit> {
        let space = objects.space();
        let most = objects.objects().iter().map(Dataset::len).max().unwrap_or(0);
        let binning = Binning::coarsest(objects.spec(), SECOND_LOOK_BIN, most);
        let (mut spaces, mut components, mut held_out, mut calibration) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for (d, name) in objects.objects().iter().zip(objects.names()) {
            let named = |e: Error| match e {
                Error::Dataset { path, message } => Error::Dataset { path, message: format!("object '{name}': {message}") },
                e => Error::Dataset { path: d.manifest().root().to_path_buf(), message: format!("object '{name}', its own eigenspace: {e}") },
            };
            let binned = if binning.bins() {
                Some(Dataset::from_features(d.manifest().clone(), binning.spec(), binning.apply_all(d.features())).map_err(named)?)
            } else {
                None
            };
            let d = binned.as_ref().unwrap_or(d);
            if d.len() < 2 {
                spaces.push(None);
                components.push(0);
                held_out.push(Vec::new());
                calibration.push(None);
                continue;
            }
            let grid = Grid::new(space, d.poses(), d.manifest().images(), d.manifest().root()).map_err(named)?;
            let pca = pca::fit(d, Dimension::Fixed(params.components)).map_err(named)?;
            let l = pca.dim();
            let dense = Manifold::build(space, &grid, &pca.coords, l, params.manifold_step).map_err(named)?;
            let floor = residuals(d, &pca.basis, &pca.mean);
            spaces.push(Some(Universal::new(to32(&pca.basis), to32(&pca.mean), vec![to32(&dense.points)]).map_err(named)?));
            components.push(l);
            let twice = held_out_distances(d, params.components, &strided_folds(d, &grid, 2)).map_err(named)?;
            let four = held_out_distances(d, params.components, &strided_folds(d, &grid, 4)).map_err(named)?;
            calibration.push(calibrate(&twice, spacing_ratio(&twice, &four), &floor));
            held_out.push(twice.iter().map(|h| h.squared.sqrt()).collect());
        }
        Ok(OwnFit { model: OwnSpaces { spaces, binning }, components, held_out, calibration })
    }

    /// Whether object `k` has an eigenspace of its own.
    pub fn has(&self, k: usize) -> bool {
        self.spaces.get(k).is_some_and(Option::is_some)
    }

    /// Each query's distance to object `k`'s manifold in its own eigenspace into `out` (one per
    /// query); NaN for a query that cannot be scaled to unit energy. Object `k` has one
    /// ([`OwnSpaces::has`]).
    pub fn distances(&self, k: usize, queries: &[f32], out: &mut [f64]) {
        if let Some(s) = &self.spaces[k] {
            if self.binning.bins() {
                s.own_distances(&self.binning.apply_all(queries), out);
            } else {
                s.own_distances(queries, out);
            }
        }
    }

    /// The binning factor of the images the own eigenspaces are of.
    pub fn bin(&self) -> usize {
        self.binning.factor()
    }

    /// Numbers stored: every object's eigenimages, mean and manifold points.
    pub fn numbers(&self) -> usize {
        self.spaces.iter().flatten().map(Universal::numbers).sum()
    }

    /// Manifold points over all objects, N_own.
    pub fn manifold_len(&self) -> usize {
        self.spaces.iter().flatten().map(Universal::manifold_len).sum()
    }

    /// The largest own dimension L_k.
    pub fn max_components(&self) -> usize {
        self.spaces.iter().flatten().map(Universal::components).max().unwrap_or(0)
    }

    /// The arrays, object k's under `recognizer.own.K.` (`basis`, `mean`, `manifold.0`).
    pub fn tensors(&self) -> Vec<Tensor> {
        self.spaces.iter().enumerate().filter_map(|(k, s)| s.as_ref().map(|s| s.tensors(&prefix(k)))).flatten().collect()
    }

    /// Reads back [`OwnSpaces::tensors`] for objects of images `spec` binned by `bin`, and own
    /// dimensions `components` (0: none).
    pub fn from_parts(t: &TensorSet, spec: ImageSpec, bin: usize, components: &[usize]) -> Result<Self> {
        let binning = Binning::new(spec, bin).map_err(|e| t.error(format!("damaged second-stage settings: {e}")))?;
        let m = binning.spec().features();
        let spaces =
            components.iter().enumerate().map(|(k, &l)| (l > 0).then(|| Universal::from_parts(t, &prefix(k), 1, m, l)).transpose()).collect::<Result<_>>()?;
        Ok(OwnSpaces { spaces, binning })
    }
}

/// Object `k`'s arrays' prefix in a model file.
fn prefix(k: usize) -> String {
    format!("recognizer.own.{k}.")
}

/// One held-out view's squared distance, with the view and the axis its knots were left out along.
#[derive(Debug, Clone, Copy)]
struct HeldOut {
    view: usize,
    axis: usize,
    squared: f64,
    /// Its part off the fold's eigenspace (the rest is within it, to the manifold).
    residual: f64,
}

impl HeldOut {
    /// Its part within the fold's eigenspace.
    fn within(&self) -> f64 {
        self.squared - self.residual
    }
}

/// Each measured view's squared distance to its object's manifold in the eigenspace fitted
/// without it (the views kept by each fold, `components` dimensions at most), at the view's own
/// pose: the residual off that eigenspace and the distance within it to the manifold
/// interpolated from the kept knots (the same splines). Empty when no axis has knots enough.
fn held_out_distances(train: &Dataset, components: usize, folds: &[StridedFold]) -> Result<Vec<HeldOut>> {
    let space = train.space();
    let mut out = Vec::new();
    for fold in folds {
        let kept = train.subset(&fold.keep)?;
        let pca = pca::fit(&kept, Dimension::Fixed(components))?;
        let l = pca.dim();
        let sub = Grid::new(space, kept.poses(), kept.manifest().images(), kept.manifest().root())?;
        let knots: Vec<f64> = sub.sample_at.iter().flat_map(|&k| pca.coords[k * l..(k + 1) * l].iter().copied()).collect();
        let surface = Surface::new(space, &sub.axes, &knots, l, Interpolant::Spline)?;
        let mut f = vec![0.0; l];
        for i in (0..train.len()).filter(|&i| fold.measured[i]) {
            let (residual, y) = split(train.row(i), &pca.basis, &pca.mean);
            let mut t = train.pose(i).to_vec();
            surface.clamp(&mut t);
            surface.eval(&t, &mut f, None);
            let within: f64 = y.iter().zip(&f).map(|(a, b)| (a - b) * (a - b)).sum();
            out.push(HeldOut { view: i, axis: fold.axis, squared: residual + within, residual });
        }
    }
    Ok(out)
}

/// A view's unit-energy image split by an eigenspace (`basis` rows of `mean`'s length): its
/// squared residual off it and its coordinates in it. A training view has energy: the
/// eigenspace's fit refuses one that has none.
fn split(x: &[f32], basis: &[f64], mean: &[f64]) -> (f64, Vec<f64>) {
    let norm = x.iter().map(|&v| v as f64 * v as f64).sum::<f64>().sqrt();
    let c: Vec<f64> = x.iter().zip(mean).map(|(&v, &mu)| v as f64 / norm - mu).collect();
    let y: Vec<f64> = basis.chunks_exact(mean.len()).map(|u| u.iter().zip(&c).map(|(a, b)| a * b).sum()).collect();
    let residual = c.iter().map(|v| v * v).sum::<f64>() - y.iter().map(|v| v * v).sum::<f64>();
    (residual.max(0.0), y)
}

/// Each training view's squared residual off its object's own eigenspace (`basis`, `mean`): what
/// the eigenspace's truncation leaves of a view that lies on the manifold, which a fresh view
/// keeps however close the knots.
fn residuals(train: &Dataset, basis: &[f64], mean: &[f64]) -> Vec<f64> {
    (0..train.len()).map(|i| split(train.row(i), basis, mean).0).collect()
}

/// The share of a held-out view's squared distance within the fold's eigenspace (to the
/// manifold interpolated from the kept knots) that a fresh view keeps at the model's own
/// spacing: the same views along the same axes, summed, at twice the knot spacing (`twice`) over
/// four times (`four`), at most 1; 1 where no axis has knots enough (8).
fn spacing_ratio(twice: &[HeldOut], four: &[HeldOut]) -> f64 {
    let at2: HashMap<_, f64> = twice.iter().map(|h| ((h.view, h.axis), h.within())).collect();
    let (mut d2, mut d4) = (0.0, 0.0);
    for h in four {
        if let Some(a) = at2.get(&(h.view, h.axis)) {
            (d2, d4) = (d2 + a, d4 + h.within());
        }
    }
    if d4 > 0.0 {
        (d2 / d4).min(1.0)
    } else {
        1.0
    }
}

/// The object's threshold from its held-out squared distances at twice the knot spacing
/// (`twice`), the share of them a fresh view keeps (`spacing_ratio`) and its training views'
/// squared residuals off its own eigenspace (`floor`); `None` when nothing was held out. See the
/// module doc.
fn calibrate(twice: &[HeldOut], spacing_ratio: f64, floor: &[f64]) -> Option<Calibration> {
    if twice.is_empty() {
        return None;
    }
    let x: Vec<f64> = twice.iter().map(|h| floor[h.view] + h.residual + spacing_ratio * h.within()).collect();
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let var = x.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n;
    let spread_dims = if var > 0.0 { (2.0 * mean * mean / var).max(1.0) } else { f64::INFINITY };
    let threshold = (mean * chi_square_quantile_ratio(spread_dims, FALSE_REJECTION_Z)).sqrt();
    Some(Calibration { spacing_ratio, spread_dims, threshold })
}

/// The quantile of a chi-square of `dims` degrees of freedom over its mean, at the standard
/// normal quantile `z` (Wilson & Hilferty's cube-root approximation: within 1% of the exact
/// quantile at 1 degree of freedom and the 99th percentile, closer with more); 1 for infinite
/// `dims`.
fn chi_square_quantile_ratio(dims: f64, z: f64) -> f64 {
    if dims.is_infinite() {
        return 1.0;
    }
    let a = 2.0 / (9.0 * dims);
    (1.0 - a + z * a.sqrt()).max(0.0).powi(3)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn the_false_rejection_rate_and_its_normal_quantile_agree() {
        let tail = 0.5 * libm::erfc(FALSE_REJECTION_Z / std::f64::consts::SQRT_2);
        assert!((tail - OWN_FALSE_REJECTION).abs() < 1e-12, "{tail}");
    }

    #[test]
    fn the_chi_square_quantile_is_within_a_percent_of_the_tables() {
        // The 99th percentiles of chi-square with 1, 2, 10 and 50 degrees of freedom.
        for (dims, q) in [(1.0, 6.634_897), (2.0, 9.210_340), (10.0, 23.209_251), (50.0, 76.153_891)] {
            let got = dims * chi_square_quantile_ratio(dims, FALSE_REJECTION_Z);
            assert!((got / q - 1.0).abs() < 0.01, "{dims}: {got} against {q}");
        }
        assert_eq!(chi_square_quantile_ratio(f64::INFINITY, FALSE_REJECTION_Z), 1.0);
    }

    /// Views 0..n measured along axis `axis`, squared distance `within` within the fold's
    /// eigenspace and `residual` off it (view-weighted).
    fn measured(n: usize, axis: usize, within: f64, residual: f64) -> Vec<HeldOut> {
        (0..n)
            .map(|view| {
                let w = 1.0 + view as f64 / n as f64;
                HeldOut { view, axis, squared: w * (within + residual), residual: w * residual }
            })
            .collect()
    }

    #[test]
    fn the_spacing_ratio_is_that_of_the_same_views_within_distances() {
        // Within distances of a quarter at twice the spacing of what they are at four times; the
        // parts off the eigenspace do not count.
        let got = spacing_ratio(&measured(12, 0, 1.0, 5.0), &measured(12, 0, 4.0, 0.5));
        assert!((got - 0.25).abs() < 1e-12, "{got}");
        // Distances that do not fall with the spacing: no correction, nor with no axis of knots
        // enough, nor with the views measured along another axis.
        assert_eq!(spacing_ratio(&measured(12, 0, 2.0, 0.0), &measured(12, 0, 1.0, 0.0)), 1.0);
        assert_eq!(spacing_ratio(&measured(12, 0, 1.0, 0.0), &[]), 1.0);
        assert_eq!(spacing_ratio(&measured(12, 0, 1.0, 0.0), &measured(12, 1, 4.0, 0.0)), 1.0);
    }

    #[test]
    fn fresh_views_drawn_like_the_corrected_held_out_ones_exceed_the_threshold_at_the_stated_rate() {
        // Squared distances of 6 independent Gaussian coordinates, as an object's held-out views
        // (at twice the spacing) and its fresh views (keeping a quarter of that, plus the floor).
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(34);
        let mut draw = |scale: f64| -> f64 {
            (0..6)
                .map(|_| {
                    let (u, v): (f64, f64) = (rng.random_range(f64::EPSILON..1.0), rng.random());
                    let g = (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos();
                    scale * g * g
                })
                .sum()
        };
        let held: Vec<HeldOut> = (0..4000).map(|view| HeldOut { view, axis: 0, squared: draw(4.0), residual: 0.0 }).collect();
        let floor = vec![0.0; held.len()];
        let c = calibrate(&held, 0.25, &floor).unwrap();
        assert!((c.spread_dims - 6.0).abs() < 1.0, "{}", c.spread_dims);
        // The held-out distances all within the fold's eigenspace here; off it, they count whole.
        let off: Vec<HeldOut> = held.iter().map(|h| HeldOut { residual: h.squared, ..*h }).collect();
        assert!((calibrate(&off, 0.25, &floor).unwrap().threshold / c.threshold - 2.0).abs() < 1e-9);
        let n = 100_000;
        let beyond = (0..n).filter(|_| draw(1.0).sqrt() > c.threshold).count() as f64 / n as f64;
        assert!(beyond > 0.6 * OWN_FALSE_REJECTION && beyond < 1.5 * OWN_FALSE_REJECTION, "{beyond}");
        // Uncorrected, the threshold is twice as far; a floor raises it.
        let raw = calibrate(&held, 1.0, &floor).unwrap();
        assert!((raw.threshold / c.threshold - 2.0).abs() < 1e-9);
        assert!(calibrate(&held, 0.25, &vec![1.0; held.len()]).unwrap().threshold > c.threshold);
        assert_eq!(calibrate(&[], 0.25, &floor), None);
    }
}
