//! The coarse tree: the start of a clean query's search on a manifold of two parameters.

use crate::manifold::surface::Surface;
use crate::methods::refined::tuning::MAX_TREE_POSES;

/// The start of a clean query's search on a manifold of two parameters reported on a
/// lattice: a k-d tree over the surface at every pose of the lattice of twice the reporting
/// step, in the search's L_s coordinates. A clean query's coordinates are scaled by the weights
/// of nu = 0, so the tree's nearest point is the closest such pose in that metric; from it
/// [`Surface::climb`] walks the reporting lattice with the query's own weights.
#[derive(Debug, Clone)]
pub(crate) struct CoarseTree {
    pub(crate) tree: crate::manifold::kdtree::KdTree,
    /// The lattice's poses (n x D).
    pub(crate) poses: Vec<f64>,
}

impl CoarseTree {
    /// The tree over `surface` on the lattice of `step` degrees anchored at each axis's first
    /// knot, in the first `ls` coordinates; None for one parameter, more than
    /// [`crate::manifold::kdtree::MAX_DIM`] coordinates or more than [`MAX_TREE_POSES`] poses.
    pub(crate) fn new(surface: &Surface, space: &crate::PoseSpace, axes: &[Vec<f64>], ls: usize, step: f64) -> Option<CoarseTree> {
        let d = axes.len();
        if !(2..=8).contains(&d) || !(1..=crate::manifold::kdtree::MAX_DIM).contains(&ls) || step <= 0.0 {
            return None;
        }
        let counts: Vec<f64> = axes.iter().zip(space.params()).map(|(a, p)| crate::manifold::grid::sample_count(a, p.period, step)).collect();
        if counts.iter().product::<f64>() > MAX_TREE_POSES as f64 {
            return None;
        }
        let at: Vec<Vec<f64>> =
            axes.iter().zip(space.params()).map(|(a, p)| crate::manifold::grid::sample_positions(a, p.period, step)).collect();
        let n: usize = at.iter().map(Vec::len).product();
        let (mut poses, mut points) = (Vec::with_capacity(n * d), Vec::with_capacity(n * ls));
        let mut f = vec![0.0; ls];
        let mut t = vec![0.0; d];
        for k in 0..n {
            // The eigenspace manifold's order (the last axis fastest), its circular values
            // wrapped into [0, period) and brought back into the surface's domain.
            crate::manifold::grid::pose_of(&at, space, k, &mut t);
            surface.clamp(&mut t);
            surface.eval(&t, &mut f, None);
            poses.extend_from_slice(&t);
            points.extend(f.iter().map(|&v| v as f32));
        }
        Some(CoarseTree { tree: crate::manifold::kdtree::KdTree::new(&points, ls), poses })
    }
}
