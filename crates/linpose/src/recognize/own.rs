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
//! the recogniser's step (with more than two pose parameters, at a few points per knot interval,
//! `Manifold::build_for`); a query's distance to object k is the distance in image space from its
//! unit-energy image to that manifold, sqrt(r^2 + d^2), r its residual off k's eigenspace and d
//! the distance within it to the nearest manifold point (the universal eigenspace's exact pruned
//! search, with one object: [`Universal::own_distances`]).
//!
//! The query is unknown when that distance exceeds the object's second threshold, calibrated as
//! the recogniser's is: each training view held out (every other knot along each pose axis, then
//! the others), the object's eigenspace and manifold refitted on the views kept (the same
//! L_k rule on the fewer views), and the held-out view's distance measured at its own pose; the
//! threshold is the largest, with no margin. An object too sparse to hold views out takes the
//! largest threshold of the others; one with a single training view has no eigenspace of its own
//! and no second stage (its threshold is infinite).
//!
//! A query within the threshold is then measured against every other object's own manifold the
//! same way, and is unknown when one of them lies nearer ([`OwnSpaces::nearer`]). The distances
//! are all in one space (the binned image, at unit energy), so they compare across objects. The
//! recogniser picks an object in a space that keeps only what tells the known objects apart; a
//! view of an object it never saw can be named as one object there while it looks more like
//! another in image space (a toy car left out, named one car, nearer a third), and then neither
//! answer can be trusted. No constant is involved: the rule asks only which distance is least.
//!
//! The eigenspaces are of the images binned as the pose models' second look bins them
//! (`second_look::SECOND_LOOK_BIN`, coarser only while the binned images keep as many
//! pixels as an object has training views): what tells a car from a car survives 4 x 4 blocks,
//! and the stage stores and multiplies b^2 times fewer numbers.
//!
//! Cost: per object M_b L_k + M_b numbers (eigenimages, mean; M_b = M / b^2) and N_k,dense L_k
//! (its manifold); per query accepted by the recogniser, L_k M_b multiply-adds and a pruned
//! search for the object recognised, then for each other object M_b multiply-adds (how far the
//! query lies outside the range of its manifold points' norms), and only where that leaves it a
//! chance to be nearer, 4 M_b more (a bound from the first 4 coordinates and the manifold's
//! segments), then L_k M_b (the residual off the eigenspace), then the search of its manifold,
//! each only where the bound before leaves a chance. On COIL-20 the first bound settles 67% of
//! the other objects, the second 30%, the residual the rest; no manifold was searched.

use super::universal::{to32, Universal};
use super::RecognizerParams;
use crate::binning::Binning;
use crate::catalog::ObjectSet;
use crate::dataset::Dataset;
use crate::image_io::ImageSpec;
use crate::manifold::chunk_rows;
use crate::manifold::folds::both_folds;
use crate::manifold::grid::{Grid, Manifold};
use crate::manifold::pca::{self, Dimension};
use crate::manifold::surface::Surface;
use crate::manifold::Interpolant;
use crate::model::{Tensor, TensorSet};
use crate::second_look::SECOND_LOOK_BIN;
use crate::{Error, Result};
use rayon::prelude::*;
use std::borrow::Cow;

/// Every object's own eigenspace with its manifold (a [`Universal`] of one object each; `None`
/// for an object of a single training view), of the images binned by `binning`.
#[derive(Debug, Clone)]
pub(crate) struct OwnSpaces {
    spaces: Vec<Option<Universal>>,
    binning: Binning,
}

/// What fitting measured: each object's own dimensions (0 without an eigenspace) and held-out
/// distances (empty for an object too sparse to hold knots out).
pub(crate) struct OwnFit {
    pub model: OwnSpaces,
    pub components: Vec<usize>,
    pub held_out: Vec<Vec<f64>>,
}

impl OwnSpaces {
    /// Fits every object's own eigenspace on its training views, one object after the other (the
    /// largest object's fit is far smaller than the recogniser's, so the training's peak memory
    /// is unchanged).
    ///
    /// With `views_only`, each object's manifold is its training views' points themselves and a
    /// view is held out together with its nearest other view: its held-out distance is its
    /// distance, residual included, to the second nearest other view of its object in the
    /// object's eigenspace ([`super::universal::nearest_other`]; the eigenspace fitted with
    /// every view: refitting without each pair would cost one eigenspace per view); the poses are
    /// not read.
    pub(super) fn fit(objects: &ObjectSet, params: &RecognizerParams, views_only: bool) -> Result<OwnFit> {
        let space = objects.space();
        let most = objects.objects().iter().map(Dataset::len).max().unwrap_or(0);
        let binning = Binning::coarsest(objects.spec(), SECOND_LOOK_BIN, most);
        let (mut spaces, mut components, mut held_out) = (Vec::new(), Vec::new(), Vec::new());
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
                continue;
            }
            if views_only {
                let pca = pca::fit(d, Dimension::Fixed(params.components)).map_err(named)?;
                let l = pca.dim();
                let residuals: Vec<f64> = (0..d.len()).map(|i| project(d.row(i), &pca).1).collect();
                held_out.push(super::universal::nearest_other(&pca.coords, l, Some(&residuals)));
                spaces.push(Some(Universal::new(to32(&pca.basis), to32(&pca.mean), vec![to32(&pca.coords)]).map_err(named)?));
                components.push(l);
                continue;
            }
            let grid = Grid::new(space, d.poses(), d.manifest().images(), d.manifest().root()).map_err(named)?;
            let pca = pca::fit(d, Dimension::Fixed(params.components)).map_err(named)?;
            let l = pca.dim();
            let dense = Manifold::build_for(space, &grid, &pca.coords, l, params.manifold_step).map_err(named)?;
            spaces.push(Some(Universal::new(to32(&pca.basis), to32(&pca.mean), vec![to32(&dense.points)]).map_err(named)?));
            components.push(l);
            held_out.push(held_out_distances(d, &grid, params.components).map_err(named)?);
        }
        Ok(OwnFit { model: OwnSpaces { spaces, binning }, components, held_out })
    }

    /// Whether object `k` has an eigenspace of its own.
    pub(super) fn has(&self, k: usize) -> bool {
        self.spaces.get(k).is_some_and(Option::is_some)
    }

    /// The queries binned as the own eigenspaces' images are (the queries themselves when they
    /// are not binned).
    pub(super) fn binned<'a>(&self, queries: &'a [f32]) -> Cow<'a, [f32]> {
        if self.binning.bins() {
            Cow::Owned(self.binning.apply_all(queries))
        } else {
            Cow::Borrowed(queries)
        }
    }

    /// Each query's distance to object `k`'s manifold in its own eigenspace into `out` (one per
    /// query), the queries [`OwnSpaces::binned`]; NaN for a query that cannot be scaled to unit
    /// energy. Object `k` has one ([`OwnSpaces::has`]).
    pub(super) fn distances(&self, k: usize, binned: &[f32], out: &mut [f64]) {
        if let Some(s) = &self.spaces[k] {
            s.own_distances(binned, out);
        }
    }

    /// For each query ([`OwnSpaces::binned`]) recognised as `named[i]` at distance `d[i]` in that
    /// object's own eigenspace: the object, of the others with an eigenspace of their own, whose
    /// manifold lies nearest the query when nearer than `d[i]`, with its distance. Every object is
    /// measured, but mostly by bounds ([`Universal::own_distances_under`]); chunks of queries in
    /// parallel, each against every object (one query is answered on the calling thread: its
    /// objects are too little work each to hand to other threads).
    pub(super) fn nearer(&self, binned: &[f32], named: &[usize], d: &[f64]) -> Vec<Option<(usize, f64)>> {
        let n = named.len();
        let mut out = vec![None; n];
        if n == 0 {
            return out;
        }
        let mb = binned.len() / n;
        let rows = chunk_rows(n);
        binned.par_chunks(rows * mb).zip(named.par_chunks(rows)).zip(d.par_chunks(rows)).zip(out.par_chunks_mut(rows)).for_each(|(((q, named), d), out)| {
            let (mut bounds, mut dj) = (vec![0.0; named.len()], vec![0.0; named.len()]);
            for (j, s) in self.spaces.iter().enumerate() {
                let Some(s) = s else { continue };
                // The named object itself is not a rival: a bound of 0 skips its search.
                bounds.iter_mut().zip(named.iter().zip(d)).for_each(|(b, (&k, &d))| *b = if k == j { 0.0 } else { d });
                s.own_distances_under(q, &bounds, &mut dj);
                for (((o, &k), &d), &v) in out.iter_mut().zip(named).zip(d).zip(&dj) {
                    if k != j && v < d && o.is_none_or(|(_, b): (usize, f64)| v < b) {
                        *o = Some((j, v));
                    }
                }
            }
        });
        out
    }

    /// The binning factor of the images the own eigenspaces are of.
    pub(super) fn bin(&self) -> usize {
        self.binning.factor()
    }

    /// Numbers stored: every object's eigenimages, mean and manifold points.
    pub(super) fn numbers(&self) -> usize {
        self.spaces.iter().flatten().map(Universal::numbers).sum()
    }

    /// Manifold points over all objects, N_own.
    pub(super) fn manifold_len(&self) -> usize {
        self.spaces.iter().flatten().map(Universal::manifold_len).sum()
    }

    /// The largest own dimension L_k.
    pub(super) fn max_components(&self) -> usize {
        self.spaces.iter().flatten().map(Universal::components).max().unwrap_or(0)
    }

    /// The arrays, object k's under `recognizer.own.K.` (`basis`, `mean`, `manifold.0`).
    pub(super) fn tensors(&self) -> Vec<Tensor> {
        self.spaces.iter().enumerate().filter_map(|(k, s)| s.as_ref().map(|s| s.tensors(&prefix(k)))).flatten().collect()
    }

    /// Reads back [`OwnSpaces::tensors`] for objects of images `spec` binned by `bin`, and own
    /// dimensions `components` (0: none).
    pub(super) fn from_parts(t: &TensorSet, spec: ImageSpec, bin: usize, components: &[usize]) -> Result<Self> {
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

/// Each training view's distance to its object's manifold in the eigenspace fitted without it
/// (the views kept by each fold of `both_folds`, `components` dimensions at most), at the view's
/// own pose: the residual off that eigenspace and the distance within it to the manifold
/// interpolated from the kept knots (the same splines). Empty when no axis has knots enough.
fn held_out_distances(train: &Dataset, grid: &Grid, components: usize) -> Result<Vec<f64>> {
    let space = train.space();
    let mut out = Vec::new();
    for keep in both_folds(train, grid) {
        let kept = train.subset(&keep)?;
        let pca = pca::fit(&kept, Dimension::Fixed(components))?;
        let l = pca.dim();
        let sub = Grid::new(space, kept.poses(), kept.manifest().images(), kept.manifest().root())?;
        let knots: Vec<f64> = sub.sample_at.iter().flat_map(|&k| pca.coords[k * l..(k + 1) * l].iter().copied()).collect();
        let surface = Surface::new(space, &sub.axes, &knots, l, Interpolant::Spline)?;
        let mut f = vec![0.0; l];
        for i in (0..train.len()).filter(|&i| !keep[i]) {
            let (y, residual) = project(train.row(i), &pca);
            let mut t = train.pose(i).to_vec();
            surface.clamp(&mut t);
            surface.eval(&t, &mut f, None);
            let within: f64 = y.iter().zip(&f).map(|(a, b)| (a - b) * (a - b)).sum();
            out.push((residual.max(0.0) + within).sqrt());
        }
    }
    Ok(out)
}

/// A training view's coordinates in the eigenspace `pca` and its squared residual off it, the
/// view scaled to unit energy (a training view has energy: the eigenspace's fit refuses one that
/// has none).
fn project(x: &[f32], pca: &pca::Pca) -> (Vec<f64>, f64) {
    let m = x.len();
    let norm = x.iter().map(|&v| v as f64 * v as f64).sum::<f64>().sqrt();
    let c: Vec<f64> = x.iter().zip(&pca.mean).map(|(&v, &mu)| v as f64 / norm - mu).collect();
    let y: Vec<f64> = pca.basis.chunks_exact(m).map(|u| u.iter().zip(&c).map(|(a, b)| a * b).sum()).collect();
    let residual = c.iter().map(|v| v * v).sum::<f64>() - y.iter().map(|v| v * v).sum::<f64>();
    (y, residual)
}
