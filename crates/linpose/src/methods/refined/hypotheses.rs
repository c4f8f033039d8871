//! The refined model's ranked hypotheses ([`crate::confidence`]): a query's estimate (the pose
//! `predict` gives, by its own route) and the distinct local minima of the same route's distance
//! (the clean search's weighted distance, or the noisy match's affine residual) over a grid of
//! [`HYPOTHESIS_PER_CELL`] points per knot interval, each climbed on the reporting lattice.
//!
//! The calibration's held-out level is each coordinate's interpolation error on held-out training
//! views (the recorded `coord_variance`) in the route's metric: sum_l w_l sigma_l^2 / s_l^2, with
//! w_l the route's weight on the stored coordinates and s_l^2 their stored scale.

use super::model::RefinedModel;
use super::noisy::affine_fit;
use super::query::Route;
use super::scratch::QueryScratch;
use super::tuning::{HYPOTHESIS_PER_CELL, HYPOTHESIS_STEP};
use crate::confidence::{grid_minima, ranked, Estimate, GROSS_DEG, MAX_HYPOTHESES};
use crate::methods::eigenspace::chunk_rows;
use crate::model::{check_queries, unscalable_query};
use crate::Result;
use rayon::prelude::*;

/// The grid the alternatives start from: its poses (row-major, D each) and shape.
struct StartGrid {
    poses: Vec<f64>,
    shape: Vec<(usize, bool)>,
}

impl RefinedModel {
    /// [`crate::PoseModel::estimate`].
    pub(crate) fn estimate_with(&self, queries: &[f32], top: usize) -> Result<Vec<Estimate>> {
        let (l, m) = (self.components(), self.meta.spec.features());
        check_queries(m, queries.len(), "query batch")?;
        let n = queries.len() / m;
        let grid = StartGrid { poses: self.surface.grid_poses(HYPOTHESIS_PER_CELL), shape: self.surface.grid_shape(HYPOTHESIS_PER_CELL) };
        let noise = self.noise_want();
        let chunks: Vec<Vec<Option<Estimate>>> = queries
            .par_chunks(chunk_rows(n) * m)
            .map_init(QueryScratch::default, |s, q| {
                self.project_binned(q, noise, s);
                (0..q.len() / m)
                    .map(|i| {
                        let y = &s.y[i * l..(i + 1) * l];
                        if y[0].is_nan() {
                            return None;
                        }
                        let (r, route, nu) = self.route_values(s, i);
                        Some(self.estimate_one(y, self.route_of(r, route, nu), &grid, top))
                    })
                    .collect()
            })
            .collect();
        let all: Vec<Option<Estimate>> = chunks.into_iter().flatten().collect();
        if let Some(i) = all.iter().position(Option::is_none) {
            return Err(unscalable_query(i));
        }
        debug_assert_eq!(all.len(), n);
        Ok(all.into_iter().flatten().collect())
    }

    /// One projected query's estimate by its route, with its hypotheses.
    fn estimate_one(&self, y: &[f32], route: Route, grid: &StartGrid, top: usize) -> Estimate {
        let mut pose = vec![0.0; self.meta.space.len()];
        let l = self.components();
        let cv = &self.settings.coord_variance;
        let iw = &self.inv_weight;
        let held = |wt: &[f64]| if cv.len() >= wt.len() { wt.iter().enumerate().map(|(c, &w)| w * cv[c] / iw[c]).sum() } else { 0.0 };
        let mut f = vec![0.0; l];
        match route {
            Route::Clean(nu) => {
                self.pose_of_clean(y, nu, &mut pose);
                let ls = self.settings.search();
                let wt: Vec<f64> = iw[..ls].iter().map(|&w| w / (w + nu)).collect();
                let cost = |t: &[f64]| {
                    self.surface.eval(t, &mut f, None);
                    wt.iter().zip(y).zip(&f).map(|((&w, &v), &fv)| w * (v as f64 - fv) * (v as f64 - fv)).sum::<f64>()
                };
                self.rank(pose, cost, grid, held(&wt), ls, top)
            }
            Route::Noisy(nu) => {
                self.pose_of_noisy(y, nu, &mut pose);
                let wt = self.noise_weights(nu);
                let ln = wt.len();
                let c: Vec<f64> = self.mean_proj[..ln].iter().map(|&v| v as f64).collect();
                let z: Vec<f64> = y[..ln].iter().zip(&c).map(|(&v, &cv)| v as f64 + cv).collect();
                let mut g = vec![0.0; l];
                let cost = |t: &[f64]| {
                    self.surface.eval_pair(&self.bg_surface, t, &mut f, None, &mut g, None);
                    affine_fit(&z, &c, &wt, &f[..ln], &g[..ln]).0
                };
                self.rank(pose, cost, grid, held(&wt), ln, top)
            }
        }
    }

    /// Ranks the estimate `pose` against the distinct local minima of `cost` over `grid`, each
    /// climbed on the reporting lattice.
    fn rank(&self, pose: Vec<f64>, mut cost: impl FnMut(&[f64]) -> f64, grid: &StartGrid, held: f64, dims: usize, top: usize) -> Estimate {
        let (d, space) = (self.axes.len(), &self.meta.space);
        let mut t = pose.clone();
        self.surface.clamp(&mut t);
        let d1 = cost(&t);
        let costs: Vec<f64> = grid.poses.chunks_exact(d).map(&mut cost).collect();
        let mut minima = grid_minima(&grid.shape, &costs);
        minima.sort_by(|&a, &b| costs[a].total_cmp(&costs[b]));
        let step = if self.settings.params.resolution > 0.0 { self.settings.params.resolution } else { HYPOTHESIS_STEP };
        let mut others: Vec<(Vec<f64>, f64)> = Vec::new();
        let mut at = vec![0.0; space.len()];
        for k in minima {
            if others.len() >= MAX_HYPOTHESES {
                break;
            }
            let mut tk = grid.poses[k * d..(k + 1) * d].to_vec();
            self.write_pose(&tk, &mut at);
            // A start in the estimate's own basin, or in one already climbed, adds nothing.
            if space.error_deg(&at, &pose) < GROSS_DEG || others.iter().any(|o| space.error_deg(&o.0, &at) < GROSS_DEG) {
                continue;
            }
            let dk = self.surface.climb_by(&mut tk, step, &mut cost);
            self.write_pose(&tk, &mut at);
            others.push((at.clone(), dk));
        }
        ranked(space, (pose, d1), others, held, dims, top)
    }
}
