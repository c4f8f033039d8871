//! A batch of queries: each projected, routed to the clean search or the noisy match by its
//! pixel noise, and given its pose.

use super::model::RefinedModel;
use super::scratch::QueryScratch;
use super::tuning::NOISE_EARLY;
use crate::kernels::{dot_w, Level};
use crate::manifold::chunk_rows;
use crate::manifold::projector::BATCH_FROM;
use crate::manifold::projector::u8_tasks;
use crate::model::{batch_len, split};
use crate::Result;
use rayon::prelude::*;

/// Where a query goes, with its noise per coordinate there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Route {
    /// The clean search, its weights 1 / (sigma_l^2 + floor + nu) for this nu.
    Clean(f64),
    /// The noisy match, its weights for this nu.
    Noisy(f64),
}

/// What a query's projection computes of its pixel noise.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum NoiseWant {
    /// Nothing (a model without the noisy match).
    None,
    /// The whole estimate: the noisy match weights its coordinates by it.
    Full,
    /// Enough to route the query: staged, a query whose first pass is under [`NOISE_EARLY`]
    /// times the threshold is clean without the rest.
    Route,
}

/// The error for the first query left NaN (zero or non-finite energy), if any.
fn no_black_query(out: &[f64], p: usize) -> Result<()> {
    match out.chunks_exact(p).position(|o| o[0].is_nan()) {
        Some(i) => Err(crate::model::unscalable_query(i)),
        None => Ok(()),
    }
}

impl RefinedModel {
    /// Whether a query goes to the noisy match: all of them for `NoiseWant::Full`, none for
    /// `None`, else when its route's value `route` (what [`Self::pose_routed`] compares) is over
    /// the threshold.
    #[inline]
    pub(crate) fn routed_noisy(&self, noise: NoiseWant, route: f64) -> bool {
        match noise {
            NoiseWant::None => false,
            NoiseWant::Full => true,
            NoiseWant::Route => self.settings.noise_threshold > 0.0 && route > self.settings.noise_threshold,
        }
    }

    /// The `early` of the staged pixel-noise estimate of a query of `m` pixels and energy
    /// `energy` (in the estimate's units), `None` for no estimate. The route compares the
    /// estimate times M / energy with the threshold ([`Self::poses_of`]).
    #[inline]
    pub(crate) fn early(&self, noise: NoiseWant, energy: f64, m: usize) -> Option<f64> {
        match noise {
            NoiseWant::None => None,
            NoiseWant::Full => Some(0.0),
            NoiseWant::Route => Some(NOISE_EARLY * self.settings.noise_threshold * energy / m as f64),
        }
    }

    /// The pose (degrees, circular values in [0, period)) of eigenspace coordinates `y` of a
    /// query with residual `residual` off the eigenspace, by its route: the route's value (the
    /// query's [`pixel_noise`](crate::pixel_noise::pixel_noise), compared with the threshold)
    /// and the noisy match's nu (its pixel noise per unit-energy coordinate) are given apart, since
    /// a model that bins routes on the image as given and matches on
    /// the binned one.
    fn pose_routed(&self, y: &[f32], residual: f64, route: f64, noise_nu: f64, out: &mut [f64]) {
        match self.route_of(residual, route, noise_nu) {
            Route::Noisy(nu) => self.pose_of_noisy(y, nu, out),
            Route::Clean(nu) => self.pose_of_clean(y, nu, out),
        }
    }

    /// Where a query goes ([`Self::pose_routed`]'s arguments), with its noise for that route.
    pub(crate) fn route_of(&self, residual: f64, route: f64, noise_nu: f64) -> Route {
        // Noise per coordinate from the energy off the search's L_s coordinates beyond the
        // training views' (isotropic noise puts (M - L_s) times its per-coordinate variance
        // there: the residual the choice of L_s was scored with); the weights
        // 1 / (sigma_l^2 + floor + nu) relative to the stored 1 / (sigma_l^2 + floor).
        let (m, ls) = (self.m, self.settings.search());
        if self.routed_noisy(NoiseWant::Route, route) {
            return Route::Noisy(noise_nu);
        }
        Route::Clean(((residual - self.clean_residual_energy) / (m.saturating_sub(ls).max(1)) as f64).max(0.0))
    }

    /// The route's values of query `i` of a task's projected queries `s`: its residual, the
    /// value compared with the noise threshold and the noisy match's nu.
    pub(crate) fn route_values(&self, s: &QueryScratch, i: usize) -> (f64, f64, f64) {
        if self.binning.bins() {
            (s.resid[i], s.route[i], s.noise[i])
        } else {
            (s.resid[i], s.noise[i] * self.m as f64, s.noise[i])
        }
    }

    /// The poses of a task's projected queries into `out` (NaN for a query that could not be
    /// projected).
    fn poses_of(&self, s: &QueryScratch, out: &mut [f64]) {
        let (l, p) = (self.components(), self.meta.space.len());
        for (i, (c, o)) in s.y.chunks_exact(l).zip(out.chunks_exact_mut(p)).enumerate() {
            if c[0].is_nan() {
                o.fill(f64::NAN);
            } else {
                let (r, route, nu) = self.route_values(s, i);
                self.pose_routed(c, r, route, nu, o);
            }
        }
    }

    /// What a query's projection computes of its pixel noise: enough to route it, when the
    /// model has the noisy match.
    pub(crate) fn noise_want(&self) -> NoiseWant {
        if self.settings.noise_threshold > 0.0 {
            NoiseWant::Route
        } else {
            NoiseWant::None
        }
    }

    /// [`PoseModel::predict_into`](crate::PoseModel::predict_into), computing `noise` of each query's pixel noise.
    pub(crate) fn predict_with(&self, queries: &[f32], noise: NoiseWant, out: &mut [f64]) -> Result<()> {
        let (m, p) = (self.meta.spec.features(), self.meta.space.len());
        let n = batch_len(m, queries.len(), out.len(), p)?;
        let rows = chunk_rows(n);
        queries.par_chunks(rows * m).zip(out.par_chunks_mut(rows * p)).for_each_init(QueryScratch::default, |s, (q, o)| {
            self.project_binned(q, noise, s);
            self.poses_of(s, o);
        });
        no_black_query(out, p)
    }

    /// [`PoseModel::predict_u8_into`](crate::PoseModel::predict_u8_into), computing `noise` of each query's pixel noise.
    pub(crate) fn predict_u8_with(&self, queries: &[u8], noise: NoiseWant, out: &mut [f64]) -> Result<()> {
        let (m, p) = (self.meta.spec.features(), self.meta.space.len());
        let n = batch_len(m, queries.len(), out.len(), p)?;
        let level = Level::detect();
        let block = if self.words_at(level) { dot_w::BLOCK } else { self.proj.u8_block(level, &self.clean_rows()) };
        // The small-batch rule of the other methods (crate::model::split): a batch under the
        // threshold, or of fewer than BATCH_FROM queries (one task), runs on the calling thread.
        let (rows, parallel) = if n >= BATCH_FROM { u8_tasks(n, m, block) } else { (n, false) };
        let task = |s: &mut QueryScratch, (q, o): (&[u8], &mut [f64])| {
            if self.binning.bins() {
                self.project_u8_binned(level, q, noise, s);
            } else {
                self.project_u8(level, q, noise, s);
            }
            self.poses_of(s, o);
        };
        split::for_each_task(queries, rows * m, out, rows * p, parallel, QueryScratch::default, task);
        no_black_query(out, p)
    }
}
