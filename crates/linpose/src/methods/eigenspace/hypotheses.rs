//! The eigenspace's ranked hypotheses ([`crate::confidence`]): the query's distance to every
//! manifold point, the local minima of that distance over the manifold's pose grid, ranked
//! against the nearest point (the estimate).
//!
//! The scan is the brute-force distance to all N_dense points (the k-d tree gives the nearest
//! point only), so asking for hypotheses costs about as much as the eigenspace's brute-force
//! search: N_dense x L multiply-adds a query.

use super::EigenspaceModel;
use crate::confidence::{grid_minima, ranked, Estimate};
use crate::model::check_queries;
use crate::{Error, Result};
use rayon::prelude::*;

impl EigenspaceModel {
    /// [`crate::PoseModel::estimate`]: each query's nearest manifold point (the estimate, as
    /// `predict` gives it) with the distinct local minima of its distance.
    pub(crate) fn estimate_with(&self, queries: &[f32], top: usize) -> Result<Vec<Estimate>> {
        let (l, m) = (self.components(), self.mean.len());
        check_queries(m, queries.len(), "query batch")?;
        let n = queries.len() / m;
        let mut y = vec![0f32; n * l];
        self.project_into(queries, &mut y)?;
        if let Some(i) = y.chunks_exact(l).position(|c| c[0].is_nan()) {
            return Err(Error::invalid(
                "query",
                format!("#{i} of the batch"),
                "the image is all black or not finite (zero or non-finite energy), so it cannot be scaled to unit energy",
            ));
        }
        let shape: Vec<(usize, bool)> = self.axes.iter().zip(self.meta.space.params()).map(|(a, p)| (a.len(), p.period.is_some())).collect();
        let held_out: f64 = self.settings.held_out_variance.iter().sum();
        Ok(y.par_chunks_exact(l)
            .map_init(Vec::new, |dist, c| {
                dist.clear();
                dist.extend(self.points.chunks_exact(l).map(|p| p.iter().zip(c).map(|(&a, &b)| (a - b) as f64 * (a - b) as f64).sum::<f64>()));
                let k = self.index.nearest(c);
                let others = grid_minima(&shape, dist).into_iter().filter(|&j| j != k).map(|j| (self.manifold_pose(j), dist[j])).collect();
                ranked(&self.meta.space, (self.manifold_pose(k), dist[k]), others, held_out, l, top)
            })
            .collect())
    }
}
