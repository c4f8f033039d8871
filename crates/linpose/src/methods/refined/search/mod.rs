//! The clean query's search ([`RefinedModel::pose_of_clean`]): the least of the weighted distance
//! to the surface, found in one of three ways by the model's shape.
//!
//! - One pose parameter reported on a lattice (a turntable): the exact least over every lattice
//!   pose ([`lattice`]), without a local search.
//! - Two, reported on a lattice: the nearest point of the coarse tree ([`CoarseTree`]:
//!   the surface on a lattice of [`crate::methods::refined::tuning::TREE_STEP`] reporting steps,
//!   in the coordinates weighted for nu = 0), then the climb on the reporting lattice with the
//!   query's own weights.
//! - Otherwise (more than two parameters, whose manifold is kept as its knots and whose coarse
//!   points are the surface at two points per knot interval; a continuous estimate; or a lattice
//!   too large for those): the distance to every
//!   coarse surface point (by bounding boxes of points, which rule most of them out on the leading
//!   coordinates first), Levenberg-Marquardt in the pose from the distinct closest ones (a start
//!   next to a closer one on the coarse grid shares its basin), and the best end snapped to the
//!   lattice.

pub(crate) mod lattice;
mod tree;

pub(crate) use tree::CoarseTree;

use super::model::RefinedModel;
use super::scratch::{SearchScratch, SEARCH_SCRATCH};
use super::tuning::{BOX_SPLIT, START_RATIO};
use crate::kernels::Level;

/// Coordinates of the coarse points' bounding boxes ([`RefinedModel::start_boxes`],
/// [`crate::kernels::scan::sq_dist_boxed`]) of a model of `l`: the leading [`BOX_SPLIT`].
pub(crate) fn box_split(l: usize) -> usize {
    BOX_SPLIT.min(l)
}

/// The `k` smallest of `dist` no more than twice the smallest (the only ones
/// [`RefinedModel::distinct_starts`] keeps), with their indices, in increasing order (ties: the
/// lower index). Two passes: the minimum (vectorised), then the few points under twice it.
/// `k` is at least 1.
pub(crate) fn smallest(dist: &[f32], k: usize) -> Vec<(f32, usize)> {
    smallest_under(dist, k, crate::kernels::scan::least(Level::detect(), dist))
}

/// [`smallest`] given the least of `dist`, `lo`.
pub(crate) fn smallest_under(dist: &[f32], k: usize, lo: f32) -> Vec<(f32, usize)> {
    crate::kernels::scan::smallest_under_cut(Level::detect(), dist, k, START_RATIO * lo.max(0.0) + f32::MIN_POSITIVE)
}

impl RefinedModel {
    /// The starts worth a local search among the closest coarse points `best` (increasing
    /// distance): those within twice the closest one's distance, less any next to a closer start
    /// on the coarse grid (one step along every axis), whose basin it shares.
    pub(crate) fn distinct_starts(&self, best: &[(f32, usize)]) -> Vec<usize> {
        let first = best.first().map_or(0.0, |b| b.0);
        let mut kept: Vec<usize> = Vec::with_capacity(best.len());
        for &(v, i) in best {
            if v > START_RATIO * first.max(0.0) + f32::MIN_POSITIVE {
                break;
            }
            if !kept.iter().any(|&j| self.adjacent(i, j)) {
                kept.push(i);
            }
        }
        kept
    }

    /// Whether coarse points `i` and `j` are at most one grid step apart along every axis.
    fn adjacent(&self, mut i: usize, mut j: usize) -> bool {
        for &(n, circular) in self.start_shape.iter().rev() {
            let (a, b) = (i % n, j % n);
            let gap = a.abs_diff(b);
            if gap > 1 && !(circular && gap == n - 1) {
                return false;
            }
            (i, j) = (i / n, j / n);
        }
        true
    }
}

impl RefinedModel {
    /// The pose (degrees, circular values in [0, period)) of a clean query's coordinates `y`
    /// into `out`, its weights 1 / (sigma_l^2 + floor + nu) for noise `nu` per coordinate: on a
    /// one-parameter lattice the lattice search, with two parameters on a lattice the
    /// coarse tree's nearest point and the climb, else Levenberg-Marquardt from the distinct
    /// closest coarse points, snapped to the lattice.
    pub(crate) fn pose_of_clean(&self, y: &[f32], nu: f64, out: &mut [f64]) {
        let (l, d, ls) = (self.components(), self.axes.len(), self.settings.search());
        let k = self.settings.params.starts.min(self.start_len());
        let mut t = [0f64; 8];
        SEARCH_SCRATCH.with_borrow_mut(|sc| {
            let SearchScratch { wt, w32, dist, buf, lb, .. } = sc;
            wt.clear();
            wt.extend(self.inv_weight.iter().enumerate().map(|(c, &iw)| if c < ls { iw / (iw + nu) } else { 0.0 }));
            if let Some(lat) = &self.lattice {
                let uniform = wt[..ls].iter().all(|&w| w == wt[0]).then_some(wt[0]);
                t[0] = lat.nearest(y, wt, uniform, buf);
                return;
            }
            if let Some(c) = &self.tree {
                let i = c.tree.nearest(&y[..ls]);
                t[..d].copy_from_slice(&c.poses[i * d..(i + 1) * d]);
                self.surface.climb(y, wt, &mut t[..d], self.settings.params.resolution);
                return;
            }
            w32.clear();
            w32.extend(wt.iter().map(|&w| w as f32));
            // Every coarse point's distance, then the k closest.
            dist.resize(self.start_len(), 0.0);
            let split = box_split(self.components());
            let boxes = crate::kernels::scan::Boxes { boxes: &self.start_boxes, split };
            let lo = crate::kernels::scan::sq_dist_boxed(Level::detect(), &self.start_points, boxes, y, w32, dist, lb);
            let best = smallest_under(dist, k, lo);
            buf.resize((d + 2) * l, 0.0);
            let mut best_cost = f64::INFINITY;
            for i in self.distinct_starts(&best) {
                let mut s = [0f64; 8];
                s[..d].copy_from_slice(&self.start_poses[i * d..(i + 1) * d]);
                let c = self.surface.refine(y, wt, &mut s[..d], buf);
                if c < best_cost {
                    (best_cost, t) = (c, s);
                }
            }
            if self.settings.params.resolution > 0.0 {
                self.surface.snap(y, wt, &mut t[..d], self.settings.params.resolution, &mut buf[..l]);
            }
        });
        self.write_pose(&t[..d], out);
    }
}
