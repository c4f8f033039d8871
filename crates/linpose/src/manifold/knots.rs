//! The coarse candidates of a continuous search on a manifold kept as its knots
//! ([`super::dense_lattice`]): the surface through the training views at a few points per knot
//! interval (the training views among them), the nearest of them to a query in the eigenspace,
//! from which Levenberg-Marquardt on the surface finds its pose.
//!
//! The points are indexed by a k-d tree ([`super::kdtree`]) or, for few of them or beyond the
//! tree's dimensions, searched by brute force. A query's starts are its nearest point and the
//! points within a ratio of that squared distance, nearest first, less any next to a nearer start
//! on their grid (one step along every axis: the two share a basin). Everything here grows with
//! the training views: P^D points of `dim` values and D poses per view, for P points per knot
//! interval.

use super::kdtree::{KdTree, MAX_DIM};
use super::surface::Surface;

/// Points from which the tree serves (below, brute force: a few hundred products). Not tuned:
/// the eigenspace's own rule for its nearest-point search (`methods::eigenspace::search`).
const TREE_FROM: usize = 64;

/// The coarse points of a manifold kept as its knots, indexed for a query's starts.
#[derive(Debug, Clone)]
pub(crate) struct KnotStarts {
    /// Coordinates used, the first `dim` of each point.
    dim: usize,
    /// The k-d tree over the points, or None for brute force over `points`.
    tree: Option<KdTree>,
    /// The points' first `dim` coordinates (row-major), for brute force (empty with a tree).
    points: Vec<f32>,
    /// Points along each axis and whether the axis is circular.
    shape: Vec<(usize, bool)>,
    /// The points' poses (D each, row-major over their grid, last parameter fastest), in the
    /// surface's domain.
    poses: Vec<f64>,
}

/// A query's buffers for [`KnotStarts::starts`].
#[derive(Debug, Default)]
pub(crate) struct StartScratch {
    near: Vec<(f32, u32)>,
    dist: Vec<f32>,
}

impl KnotStarts {
    /// The surface's points at `per_cell` points per knot interval along each axis
    /// ([`Surface::grid_poses`]; the knots themselves for 1), indexed on their first `dim`
    /// coordinates; by a tree when `tree` allows and there are enough of them.
    pub(crate) fn new(surface: &Surface, dim: usize, per_cell: usize, tree: bool) -> KnotStarts {
        let (l, d) = (surface.dim, surface.params());
        let dim = dim.clamp(1, l.max(1));
        let poses = surface.grid_poses(per_cell);
        let shape = surface.grid_shape(per_cell);
        let n = poses.len() / d.max(1);
        let mut points = Vec::with_capacity(n * dim);
        let mut f = vec![0.0; dim];
        for t in poses.chunks_exact(d) {
            surface.eval(t, &mut f, None);
            points.extend(f.iter().map(|&v| v as f32));
        }
        let (tree, points) = if tree && dim <= MAX_DIM && n >= TREE_FROM { (Some(KdTree::new(&points, dim)), Vec::new()) } else { (None, points) };
        KnotStarts { dim, tree, points, shape, poses }
    }

    /// Whether the points are searched by a k-d tree.
    pub(crate) fn has_tree(&self) -> bool {
        self.tree.is_some()
    }

    /// The pose of point `k` (D values, in the surface's domain).
    pub(crate) fn pose(&self, k: usize) -> &[f64] {
        let d = self.shape.len();
        &self.poses[k * d..(k + 1) * d]
    }

    /// Bytes held: the tree or the points, and the poses.
    pub(crate) fn bytes(&self) -> usize {
        self.tree.as_ref().map_or(self.points.len() * 4, KdTree::bytes) + self.poses.len() * 8
    }

    /// The starts of query `y` (its first `dim` coordinates count) into `out`: the nearest
    /// point, then the points within `ratio` times its squared distance, nearest first (ties to
    /// the lower index), each unless it is next to a start already kept on their grid; at most
    /// `max`. A query with a NaN coordinate gets point 0.
    pub(crate) fn starts(&self, y: &[f32], ratio: f32, max: usize, s: &mut StartScratch, out: &mut Vec<usize>) {
        out.clear();
        let q = &y[..self.dim];
        let StartScratch { near, dist } = s;
        near.clear();
        match &self.tree {
            Some(t) => {
                let (first, _) = t.nearest_and_near(q, ratio, near);
                if near.is_empty() {
                    out.push(first);
                    return;
                }
            }
            None => {
                dist.clear();
                dist.extend(self.points.chunks_exact(self.dim).map(|p| p.iter().zip(q).map(|(a, b)| (a - b) * (a - b)).sum::<f32>()));
                let least = dist.iter().copied().fold(f32::INFINITY, f32::min);
                if !least.is_finite() {
                    out.push(0);
                    return;
                }
                let cut = ratio * least;
                near.extend(dist.iter().enumerate().filter(|&(_, &v)| v <= cut).map(|(i, &v)| (v, i as u32)));
            }
        }
        near.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        for &(_, i) in near.iter() {
            if out.len() == max.max(1) {
                break;
            }
            let i = i as usize;
            if !out.iter().any(|&j| self.adjacent(i, j)) {
                out.push(i);
            }
        }
    }

    /// Whether points `i` and `j` are at most one step apart along every axis of their grid.
    fn adjacent(&self, mut i: usize, mut j: usize) -> bool {
        for &(n, circular) in self.shape.iter().rev() {
            let gap = (i % n).abs_diff(j % n);
            if gap > 1 && !(circular && gap == n - 1) {
                return false;
            }
            (i, j) = (i / n, j / n);
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Param, PoseSpace};

    /// A 3 x 4 x 6 grid of knots (the last axis circular) whose coordinates are their poses: the
    /// tree's starts are brute force's, the nearest knot comes first, and no two starts are
    /// neighbours on the grid.
    #[test]
    fn tree_and_brute_force_give_the_same_distinct_starts() {
        let space = PoseSpace::new(vec![Param::linear("a"), Param::linear("b"), Param::circular("c", 360.0)]).unwrap();
        let axes = vec![vec![0.0, 10.0, 20.0], vec![0.0, 10.0, 20.0, 30.0], (0..6).map(|k| 60.0 * k as f64).collect::<Vec<_>>()];
        let mut knots = Vec::new();
        for &a in &axes[0] {
            for &b in &axes[1] {
                for &c in &axes[2] {
                    let c: f64 = c;
                    knots.extend([a as f32, b as f32, (40.0 * c.to_radians().cos()) as f32, (40.0 * c.to_radians().sin()) as f32]);
                }
            }
        }
        let k64: Vec<f64> = knots.iter().map(|&v| v as f64).collect();
        let surface = Surface::new(&space, &axes, &k64, 4, crate::manifold::Interpolant::Spline).unwrap();
        let (brute, tree) = (KnotStarts::new(&surface, 4, 1, false), KnotStarts::new(&surface, 4, 1, true));
        assert!(!brute.has_tree() && tree.has_tree());
        let (mut s, mut a, mut b) = (StartScratch::default(), Vec::new(), Vec::new());
        for q in [[1.0f32, 2.0, 39.0, 1.0], [14.0, 26.0, -30.0, 20.0], [5.0, 5.0, 0.0, 0.0]] {
            brute.starts(&q, 2.0, 8, &mut s, &mut a);
            tree.starts(&q, 2.0, 8, &mut s, &mut b);
            assert_eq!(a, b, "{q:?}");
            let d = |k: usize| knots[k * 4..k * 4 + 4].iter().zip(&q).map(|(x, y)| (x - y) * (x - y)).sum::<f32>();
            let least = (0..knots.len() / 4).map(d).fold(f32::INFINITY, f32::min);
            assert_eq!(d(a[0]), least);
            for (x, &i) in a.iter().enumerate() {
                assert!(d(i) <= 2.0 * least);
                assert!(a[..x].iter().all(|&j| !brute.adjacent(i, j)), "{a:?}");
            }
        }
        // The poses are the grid's, the last axis fastest.
        assert_eq!(brute.pose(1), &[0.0, 0.0, 60.0]);
        assert_eq!(tree.pose((4 + 1) * 6 + 2), &[10.0, 10.0, 120.0]);
    }
}
