//! The paper's linear model as a recogniser: the minimum-norm exact fit of one-hot object targets
//! Y (N x K) to the training images, W = X^T G^-1 Y through the N x N Gram matrix G = X X^T of
//! every object's training images (the pose fit's system with K right-hand sides: one more
//! solve). A query's outputs o = W^T x; its distance to object k is ||o - e_k||, so the nearest
//! object is the largest output. Images are taken as they are, as the paper's pose model takes
//! them.
//!
//! A training view's outputs are exactly its one-hot target. Its held-out distance, what
//! calibrates the unknown-object threshold, is that of its outputs from the fit without it and
//! the other views of its fold (every other knot of its object along each axis held out, then
//! the others, as the universal eigenspace holds them out): for the held-out block B the exact
//! residuals E_B = [(G^-1)_BB]^-1 (G^-1 Y)_B, the block form of the leave-one-out identity
//! e_i = (G^-1 Y)_i / (G^-1)_ii (docs/method.md), so the N x N system is factored once. Holding
//! out a single view would leave its near twins (the other side of a symmetric object) in the
//! fit and understate how far a fresh view lands.

use super::tuning::{LINEAR_RECOGNIZER_BYTES, NEIGHBOUR, SINGULAR_RIDGE};
use super::{Fitted, Recognize, Recognizer, RecognizerParams};
use crate::catalog::ObjectSet;
use crate::dataset::Dataset;
use crate::linalg::mat_from_rows;
use crate::manifold::chunk_rows;
use crate::manifold::grid::Grid;
use crate::manifold::projector::Projector;
use crate::methods::linear::GramSystem;
use crate::model::footprint::{system, Parts, Sizes};
use crate::model::{Tensor, TensorSet};
use crate::Result;
use faer::linalg::solvers::{DenseSolveCore, Solve};
use faer::Mat;
use rayon::prelude::*;
use std::sync::Arc;

/// The linear recogniser in the recogniser registry.
pub(crate) static RECOGNIZER: Recognizer = Recognizer {
    name: "linear",
    summary: "the paper's minimum-norm linear model with one-hot object targets, the largest output",
    storage: "M K + K (M L_k + M) + N_own L_k",
    fit: |objects, all, _params, views_only| {
        let (model, held_out) = LinearRecognizer::fit(objects, all, views_only)?;
        Ok(Fitted { model: Arc::new(model), components: 0, energy_kept: 1.0, held_out })
    },
    load: |t, objects, m, _components| Ok(Arc::new(LinearRecognizer::from_parts(t, objects, m)?)),
    footprint,
};

/// What fitting allocates, for the memory plan: the N x N system of all objects' images, with
/// the factor's inverse (32 N^2).
fn footprint(s: &Sizes, _objects: usize, _params: &RecognizerParams) -> Parts {
    Parts::default().add(system(s.n as f64, LINEAR_RECOGNIZER_BYTES), format!("N x N Gram of all {} images and its inverse", s.n))
}

/// A fitted linear recogniser: K coefficient images.
#[derive(Debug, Clone)]
pub(crate) struct LinearRecognizer {
    /// W^T (K x M).
    proj: Projector,
    k: usize,
}

impl LinearRecognizer {
    /// Fits on `all`, the training views of every object of `objects` row after row (object
    /// 0's first). Returns the model and, per object, its views' held-out distances.
    /// With `views_only` the poses are not read: each view is held out with its nearest other
    /// view of its object.
    pub(super) fn fit(objects: &ObjectSet, all: &Dataset, views_only: bool) -> Result<(Self, Vec<Vec<f64>>)> {
        let (n, m, k) = (all.len(), all.n_features(), objects.len());
        let mut y = vec![0.0; n * k];
        let mut offsets = Vec::with_capacity(k);
        let mut row = 0;
        for (c, d) in objects.objects().iter().enumerate() {
            offsets.push(row);
            for i in row..row + d.len() {
                y[i * k + c] = 1.0;
            }
            row += d.len();
        }
        let g = crate::linalg::gram_of(all, None);
        let sys = GramSystem { x: all.rows(), m, g, p: mat_from_rows(&y, n, k), mean_x: None, mean_p: None };
        // Views that repeat (a symmetric object's, say) make G singular while their targets
        // agree: the minimum-norm fit is then the limit of the ridge fit as the ridge goes to
        // zero, which a ridge just above the factorisation's refusal level gives.
        let factor = match sys.factor(0.0, all) {
            Ok(f) => f,
            Err(_) => {
                let scale = (0..n).map(|i| sys.g[(i, i)]).fold(0.0, f64::max);
                sys.factor(scale * n as f64 * SINGULAR_RIDGE, all)?
            }
        };
        let d = factor.solve(sys.p.as_ref());
        let inv = factor.inverse();
        let mut held_out = Vec::with_capacity(k);
        for (d_obj, &start) in objects.objects().iter().zip(&offsets) {
            // Each block of views held out together, and which of them to measure.
            let blocks: Vec<(Vec<usize>, usize)> = if views_only {
                // Each view with its nearest other views of its object (in image space, from the
                // Gram matrix), which may be near-duplicates of it: the rule of the universal
                // eigenspace's held-out distance without poses (`universal::nearest_other`,
                // `NEIGHBOUR`).
                let views = start..start + d_obj.len();
                let sq = |i: usize, j: usize| sys.g[(i, i)] + sys.g[(j, j)] - 2.0 * sys.g[(i, j)];
                views
                    .clone()
                    .map(|i| {
                        let mut nearest: Vec<usize> = views.clone().filter(|&j| j != i).collect();
                        nearest.sort_by(|&a, &b| sq(i, a).total_cmp(&sq(i, b)));
                        nearest.truncate(NEIGHBOUR - 1);
                        (std::iter::once(i).chain(nearest).collect(), 1)
                    })
                    .collect()
            } else {
                let grid = Grid::new(all.space(), d_obj.poses(), d_obj.manifest().images(), d_obj.manifest().root())?;
                let mut folds = crate::manifold::folds::both_folds(d_obj, &grid);
                if folds.is_empty() {
                    // Too few knots to hold every other one out: each view alone.
                    folds = (0..d_obj.len()).map(|i| (0..d_obj.len()).map(|j| j != i).collect()).collect();
                }
                folds
                    .into_iter()
                    .map(|keep| {
                        let block: Vec<usize> = (0..d_obj.len()).filter(|&i| !keep[i]).map(|i| start + i).collect();
                        let b = block.len();
                        (block, b)
                    })
                    .collect()
            };
            let mut dist = Vec::new();
            for (block, measured) in blocks {
                let b = block.len();
                let inv_bb = Mat::from_fn(b, b, |r, c| inv[(block[r], block[c])]);
                let d_b = Mat::from_fn(b, k, |r, c| d[(block[r], c)]);
                let e = inv_bb.partial_piv_lu().solve(d_b.as_ref());
                dist.extend((0..measured).map(|r| (0..k).map(|c| e[(r, c)].powi(2)).sum::<f64>().sqrt()));
            }
            held_out.push(dist);
        }
        let w: Vec<f32> = sys.weights(&d).iter().map(|&v| v as f32).collect();
        Ok((LinearRecognizer { proj: Projector::new(&w, m), k }, held_out))
    }

    /// Reads back [`Recognize::arrays`] for `k` objects of `m` features.
    pub(super) fn from_parts(t: &TensorSet, k: usize, m: usize) -> Result<Self> {
        let w = t.f32("recognizer.weights", &[k, m])?;
        if w.iter().any(|v| !v.is_finite()) {
            return Err(t.error("the linear recogniser holds non-finite weights"));
        }
        Ok(LinearRecognizer { proj: Projector::new(&w, m), k })
    }
}

impl Recognize for LinearRecognizer {
    /// Each query's distance to each object's one-hot outputs into `out` (rows of K).
    fn distances(&self, queries: &[f32], out: &mut [f64]) {
        let (k, m) = (self.k, self.proj.rows().len() / self.k);
        let rows = chunk_rows(queries.len() / m);
        queries.par_chunks(rows * m).zip(out.par_chunks_mut(rows * k)).for_each(|(q, o)| {
            let mut y = vec![0f32; q.len() / m * k];
            self.proj.f32_products(&(0..k), q, &mut y);
            for (y, o) in y.chunks_exact(k).zip(o.chunks_exact_mut(k)) {
                let ss: f64 = y.iter().map(|&v| v as f64 * v as f64).sum();
                for (j, o) in o.iter_mut().enumerate() {
                    *o = (ss - 2.0 * y[j] as f64 + 1.0).max(0.0).sqrt();
                }
            }
        });
    }

    /// M K.
    fn stored_numbers(&self) -> usize {
        self.proj.rows().len()
    }

    fn arrays(&self) -> Vec<Tensor> {
        let m = self.proj.rows().len() / self.k;
        vec![Tensor::f32("recognizer.weights", vec![self.k, m], self.proj.rows().to_vec())]
    }
}
