//! Fitting: the binning factor, L, the interpolant and the noisy match chosen on held-out
//! training views, then the model built from them.

use super::model::RefinedModel;
use super::noisy::background_knots;
use super::params::{RefinedParams, RefinedSettings};
use super::select;
use super::tuning::{BIN_CANDIDATES, FALLBACK_COMPONENTS, NOISE_COMPONENTS, ROLL_SPLIT, ROLL_TURN_MAX, WEIGHT_FLOOR};
use super::METHOD;
use crate::binning::Binning;
use crate::dataset::Dataset;
use crate::manifold::grid::Grid;
use crate::manifold::pca::{self, Dimension, Pca};
use crate::manifold::roll::{self, Knot, RollKnots};
use crate::model::{Estimator, Method, ModelMeta};
use crate::second_look::SecondLook;
use crate::Result;

impl Estimator for RefinedParams {
    type Model = RefinedModel;

    fn method(&self) -> &'static Method {
        &METHOD
    }

    fn fit(&self, full: &Dataset) -> Result<RefinedModel> {
        self.validate()?;
        // The held-out fits take the binned images as given (bin 1).
        let inner = RefinedParams { bin: Some(1), ..*self };
        // The binning factor (with its images, grid and choice of L when scored), fixed or the
        // coarsest candidate within one standard error of the least held-out error.
        let (mut bin_selection, mut bin_tolerance) = (Vec::new(), 0.0);
        let (binning, train, grid, chosen) = match self.bin {
            Some(b) => {
                let binning = Binning::new(full.spec(), b)?;
                let (train, grid) = binned_views(full, binning)?;
                (binning, train, grid, None)
            }
            None => {
                let mut scored = Vec::new();
                for &b in BIN_CANDIDATES {
                    let Ok(binning) = Binning::new(full.spec(), b) else { continue };
                    let (train, grid) = binned_views(full, binning)?;
                    let choice = select::choose(train.as_ref().unwrap_or(full), &grid, &inner, b)?;
                    bin_selection.push((b, choice.least));
                    scored.push((binning, train, grid, choice));
                }
                // Among the factors with the fewest gross held-out errors, the coarsest within one
                // standard error of the least held-out error.
                let fewest = scored.iter().map(|s| s.3.gross).min().unwrap_or(0);
                let k;
                (k, bin_tolerance) = select::coarsest_within(
                    &scored.iter().map(|s| if s.3.gross == fewest { (s.3.least, s.3.standard_error) } else { (f64::INFINITY, 0.0) }).collect::<Vec<_>>(),
                );
                let (binning, train, grid, choice) = scored.swap_remove(k);
                (binning, train, grid, Some(choice))
            }
        };
        let train = train.as_ref().unwrap_or(full);
        let views = Views { full, binning };
        let space = train.space();
        // L and the interpolant, each fixed or chosen on the held-out views.
        let chosen = match chosen {
            None if self.components.is_none() || self.interpolant.is_none() => Some(select::choose(train, &grid, &inner, binning.factor())?),
            c => c,
        };
        let interpolant = self.interpolant.or(chosen.as_ref().map(|c| c.interpolant)).unwrap_or_default();
        let interpolant_selection = match (self.interpolant, &chosen) {
            (None, Some(c)) => c.by_interpolant.clone(),
            _ => Vec::new(),
        };
        let (l_max, selection, plain_error, plain) = match (self.components, chosen) {
            (None, Some(c)) => (c.components, c.scored, c.plain, c.plain_wins),
            (l, _) => (l.unwrap_or(FALLBACK_COMPONENTS), Vec::new(), None, false),
        };
        // Everything fitted from here on interpolates as the model will.
        let inner = RefinedParams { interpolant: Some(interpolant), ..inner };
        // Chosen automatically, no query's product costs as much as the eigenspace's.
        let below = if self.components.is_some() { NOISE_COMPONENTS } else { select::below_eigenspace(binning.factor()) };
        let (l_max, weighted) = if plain { (NOISE_COMPONENTS.min(below), false) } else { (l_max, self.weighted) };
        // The affine match of noisy queries may use up to the eigenspace's L = 20 coordinates
        // (within that bound): they are kept (unweighted) past the L of the weighted search.
        let l_store = if weighted { l_max.max(NOISE_COMPONENTS.min(below)) } else { l_max };
        let mut pca = pca::fit(train, Dimension::Fixed(l_store))?;
        let l_search = l_max.min(pca.dim());
        // The match of noisy queries, chosen on held-out views under simulated noise.
        let (noise_components, noise_weighted, noise_selection) = match select::choose_noise(train, views, &grid, &inner, pca.dim())? {
            Some(chosen) => chosen,
            None => (NOISE_COMPONENTS.min(pca.dim()), false, Vec::new()),
        };
        // Only the eigenimages some query uses are kept: the weighted search's and the noisy
        // match's. A query projects on no more (cheaper than the eigenspace's 20 when both
        // use fewer), and the clean search's residual is the one its choice was scored with.
        if weighted {
            pca.truncate(l_search.max(noise_components));
        }
        let l = pca.dim();
        // Each coordinate weighted by the inverse of its interpolation error (see the module
        // doc): basis and knots scaled by sqrt(w), so the search is Euclidean.
        let coord_variance = crate::manifold::folds::interpolation_variance(train, &grid, &pca.coords, l, interpolant)?;
        let sigma2 = if weighted { coord_variance.as_ref().map(|s| s[..l_search].to_vec()) } else { None };
        let scale = search_scale(sigma2.as_deref(), l_search, l);
        // The route measures a query's noise on the image as given: so is the threshold.
        let noise_threshold = select::noise_threshold(full)?.threshold;
        let mut basis = pca.basis.clone();
        let m = train.n_features();
        for (c, &w) in scale.iter().enumerate() {
            basis[c * m..(c + 1) * m].iter_mut().for_each(|v| *v *= w);
        }
        // The surface's knots: the training views, and with a camera roll the turned views
        // between the training rolls (`manifold::roll`).
        let (split, roll_turn_error) = match (full.space().in_plane_roll(), self.roll_split) {
            (None, _) => (1, None),
            (Some(r), fixed) => {
                let e = roll::turn_error(full, &grid, r);
                (fixed.unwrap_or(if e.is_some_and(|e| e <= ROLL_TURN_MAX) { ROLL_SPLIT } else { 1 }), e)
            }
        };
        let rolled = RollKnots::new(full, &grid, split)?;
        let (knots, background, axes) = match &rolled {
            None => {
                let mut knots = Vec::with_capacity(grid.sample_at.len() * l);
                for &i in &grid.sample_at {
                    knots.extend(pca.coords[i * l..(i + 1) * l].iter().zip(&scale).map(|(&v, &w)| (v * w) as f32));
                }
                (knots, background_knots(views, &grid.sample_at, &basis, l), grid.axes.clone())
            }
            Some(r) => {
                let knots = roll_knot_coords(r, &pca, &scale, &basis, binning);
                // The offset directions of the training views and of the turned ones, in the
                // grid's order.
                let trained: Vec<usize> = r.knots.iter().filter_map(|k| if let Knot::View(i) = k { Some(*i) } else { None }).collect();
                let mut of_views = background_knots(views, &trained, &basis, l).into_iter();
                let all: Vec<usize> = (0..r.turned.len()).collect();
                let mut of_turned = background_knots(Views { full: &r.turned, binning }, &all, &basis, l).into_iter();
                let background = r
                    .knots
                    .iter()
                    .flat_map(|k| match k {
                        Knot::View(_) => of_views.by_ref().take(l).collect::<Vec<_>>(),
                        Knot::Turned(_) => of_turned.by_ref().take(l).collect(),
                    })
                    .collect();
                (knots, background, r.axes.clone())
            }
        };
        let settings = RefinedSettings {
            params: *self,
            bin: binning.factor(),
            bin_selection,
            bin_tolerance,
            interpolant,
            interpolant_selection,
            components: l,
            search_components: l_search,
            energy_kept: pca.energy_kept(),
            knot_shape: axes.iter().map(Vec::len).collect(),
            roll_split: rolled.is_some().then_some(split),
            roll_turn_error,
            selection,
            plain_error,
            interpolation_variance: sigma2.unwrap_or_default(),
            residual_energy: pca.eigenvalues[l..].iter().map(|&v| v.max(0.0)).sum::<f64>() / train.len() as f64,
            noise_threshold,
            noise_components,
            noise_weighted: noise_weighted && coord_variance.is_some(),
            coord_variance: coord_variance.unwrap_or_default(),
            noise_selection,
            second_look: None,
        };
        let meta = ModelMeta {
            method: METHOD.name.into(),
            spec: full.spec(),
            space: space.clone(),
            train_poses: train.poses().to_vec(),
            settings: serde_json::Value::Null,
            normalize: None,
            stage_choice: None,
        };
        let to32 = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<f32>>();
        let look = SecondLook::fit(full, &grid, interpolant)?;
        RefinedModel::new(meta, settings, to32(&basis), to32(&pca.mean), knots, background, axes)?.with_look(look)
    }
}

/// The training images binned by `binning` (None when it keeps them as given) and their grid.
fn binned_views(full: &Dataset, binning: Binning) -> Result<(Option<Dataset>, Grid)> {
    let binned = if binning.bins() { Some(Dataset::from_features(full.manifest().clone(), binning.spec(), binning.apply_all(full.features()))?) } else { None };
    let d = binned.as_ref().unwrap_or(full);
    let grid = Grid::new(d.space(), d.poses(), d.manifest().images(), d.manifest().root())?;
    Ok((binned, grid))
}

/// The training views as given and the binning the model applies to them: what simulated noise
/// is added to (then binned, as a query's noise would be).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Views<'a> {
    /// The training views as given.
    pub full: &'a Dataset,
    /// The binning of the model.
    pub binning: Binning,
}

/// The scale sqrt(w_l) of each of `l` coordinates from their interpolation variances: w_l =
/// 1 / (sigma_l^2 + floor), the floor [`WEIGHT_FLOOR`] times the mean variance (so no coordinate
/// is trusted without bound); all ones without variances.
pub(crate) fn weights(sigma2: Option<&[f64]>, l: usize) -> Vec<f64> {
    match sigma2 {
        Some(s) => {
            let floor = (WEIGHT_FLOOR * s.iter().sum::<f64>() / l as f64).max(f64::MIN_POSITIVE);
            s.iter().map(|&v| (1.0 / (v + floor)).sqrt()).collect()
        }
        None => vec![1.0; l],
    }
}

/// The scale sqrt(w) of each of `l` coordinates: [`weights`] for the first `ls`, 1 for the rest.
pub(crate) fn search_scale(sigma2: Option<&[f64]>, ls: usize, l: usize) -> Vec<f64> {
    let mut s = weights(sigma2, ls);
    s.resize(l, 1.0);
    s
}

/// The scaled coordinates of every knot of `r` (N x L, row-major): a training view's as the
/// PCA gave them, a turned view's its binned image's at unit energy, the mean subtracted, on the
/// scaled `basis`.
fn roll_knot_coords(r: &RollKnots, pca: &Pca, scale: &[f64], basis: &[f64], binning: Binning) -> Vec<f32> {
    use rayon::prelude::*;
    let (l, m) = (scale.len(), pca.mean.len());
    let per: Vec<Vec<f32>> = (0..r.len())
        .into_par_iter()
        .map_init(
            || (vec![0f32; m], Vec::new()),
            |(binned, acc), p| match r.knots[p] {
                Knot::View(i) => pca.coords[i * l..(i + 1) * l].iter().zip(scale).map(|(&v, &w)| (v * w) as f32).collect(),
                Knot::Turned(t) => {
                    let x = r.turned.row(t);
                    if binning.bins() {
                        binning.apply(x, binned, acc);
                    } else {
                        binned.copy_from_slice(x);
                    }
                    let norm = binned.iter().map(|&v| v as f64 * v as f64).sum::<f64>().sqrt().max(f64::MIN_POSITIVE);
                    let centred: Vec<f64> = binned.iter().zip(&pca.mean).map(|(&v, &u)| v as f64 / norm - u).collect();
                    (0..l).map(|c| basis[c * m..(c + 1) * m].iter().zip(&centred).map(|(u, v)| u * v).sum::<f64>() as f32).collect()
                }
            },
        )
        .collect();
    per.concat()
}
