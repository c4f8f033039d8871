//! The noisy tree: the starts of a noisy query's search on a manifold of two parameters.

use crate::methods::refined::scratch::SEARCH_SCRATCH;
use crate::manifold::surface::Surface;
use crate::methods::refined::tuning::{SECOND_BASIN_APART, SECOND_BASIN_RATIO};

/// The start of a noisy query's search on a manifold of two parameters reported on a
/// lattice (beside a [`CoarseTree`](crate::methods::refined::search::CoarseTree), on its poses): a k-d tree over the surface points
/// m(t) = f(t) + c (the mean added back) of the noisy match's coordinates, scaled by the
/// square roots of its weights of nu = 0, with their part along `dir` removed and scaled to unit
/// length. The affine match fits z by alpha m(t) + beta g(t); `dir` is the offset surface's mean
/// direction over the lattice, so a fixed beta dir stands for beta g(t) and the unit length for
/// the gain: the tree's nearest point to the query's z, treated the same way, is the pose of
/// least angle between the two off `dir`. From it [`Surface::climb_pair`] walks the reporting
/// lattice on the affine match itself, with the query's own weights.
#[derive(Debug, Clone)]
pub(crate) struct NoisyTree {
    tree: crate::manifold::kdtree::KdTree,
    /// The square roots of the weights the points were scaled by.
    pub(crate) scale: Vec<f64>,
    /// The unit offset direction removed (in the scaled coordinates).
    dir: Vec<f64>,
    /// Each axis's period (None: linear) and the distance along it beyond which a second start
    /// counts as another basin: twice the axis's widest knot interval.
    periods: Vec<Option<f64>>,
    pub(crate) apart: Vec<f64>,
}

impl NoisyTree {
    /// The tree over the poses `poses` (n x D) of the surfaces `f` and `g` (the offset) on the
    /// knots `axes` of `space`, `c` the mean's coordinates and `w0` the weights of nu = 0 (their
    /// count: the coordinates used); None when a point has no length left off `dir`.
    pub(crate) fn new(f: &Surface, g: &Surface, space: &crate::PoseSpace, axes: &[Vec<f64>], poses: &[f64], c: &[f64], w0: &[f64]) -> Option<NoisyTree> {
        let (d, ln) = (f.params(), w0.len());
        if !(1..=crate::manifold::kdtree::MAX_DIM).contains(&ln) {
            return None;
        }
        let scale: Vec<f64> = w0.iter().map(|w| w.sqrt()).collect();
        let n = poses.len() / d;
        let (mut ms, mut dir) = (Vec::with_capacity(n * ln), vec![0.0; ln]);
        let (mut fv, mut gv) = (vec![0.0; ln], vec![0.0; ln]);
        for t in poses.chunks_exact(d) {
            f.eval_pair(g, t, &mut fv, None, &mut gv, None);
            for q in 0..ln {
                ms.push((fv[q] + c[q]) * scale[q]);
                dir[q] += gv[q] * scale[q];
            }
        }
        let norm = dir.iter().map(|v| v * v).sum::<f64>().sqrt();
        if norm > 0.0 && norm.is_finite() {
            dir.iter_mut().for_each(|v| *v /= norm);
        } else {
            dir.fill(0.0);
        }
        let mut points = vec![0f32; n * ln];
        for (m, p) in ms.chunks_exact(ln).zip(points.chunks_exact_mut(ln)) {
            if !Self::unit_off(m, &dir, p) {
                return None;
            }
        }
        let periods = space.params().iter().map(|p| p.period).collect();
        let apart = axes.iter().map(|a| SECOND_BASIN_APART * a.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max)).collect();
        Some(NoisyTree { tree: crate::manifold::kdtree::KdTree::new(&points, ln), scale, dir, periods, apart })
    }

    /// `v` (scaled coordinates) less its part along `dir`, to unit length, into `out`; false
    /// when nothing is left.
    fn unit_off(v: &[f64], dir: &[f64], out: &mut [f32]) -> bool {
        let along: f64 = v.iter().zip(dir).map(|(a, b)| a * b).sum();
        let norm = v.iter().zip(dir).map(|(a, b)| (a - along * b) * (a - along * b)).sum::<f64>().sqrt();
        if !(norm > 0.0 && norm.is_finite()) {
            return false;
        }
        out.iter_mut().zip(v.iter().zip(dir)).for_each(|(o, (a, b))| *o = ((a - along * b) / norm) as f32);
        true
    }

    /// The starts of the query's coordinates `z` (mean added back, the first `scale.len()`) on
    /// the lattice `poses` (n x D): the tree's nearest point and, when one lies within twice
    /// its squared distance, the nearest one apart from it by more than `apart[j]` degrees
    /// along some axis j (circularly on a circular axis): a second basin, as on a nearly
    /// symmetric object, whose views a half turn apart differ little (both from one search,
    /// [`crate::manifold::kdtree::KdTree::nearest_and_near`], under its distance). None when
    /// `z` has no length off the offset direction.
    pub(crate) fn starts(&self, z: &[f64], poses: &[f64]) -> Option<(usize, Option<usize>)> {
        let (ln, d, periods, apart) = (self.scale.len(), self.periods.len(), &self.periods, &self.apart);
        let (mut v, mut q) = ([0f64; crate::manifold::kdtree::MAX_DIM], [0f32; crate::manifold::kdtree::MAX_DIM]);
        v[..ln].iter_mut().zip(z.iter().zip(&self.scale)).for_each(|(o, (a, s))| *o = a * s);
        if !Self::unit_off(&v[..ln], &self.dir, &mut q[..ln]) {
            return None;
        }
        // One search for the nearest point and those within twice its squared distance, among
        // which the nearest of another basin (ties to the lower index).
        SEARCH_SCRATCH.with_borrow_mut(|sc| {
            let (i, _) = self.tree.nearest_and_near(&q[..ln], SECOND_BASIN_RATIO, &mut sc.near);
            let first = &poses[i * d..(i + 1) * d];
            let away = |k: usize| {
                poses[k * d..(k + 1) * d].iter().zip(first).zip(periods).zip(apart).any(|(((&a, &b), p), &r)| {
                    let gap = (a - b).abs();
                    p.map_or(gap, |per| gap.min(per - gap)) > r
                })
            };
            let second = sc.near.iter().filter(|&&(_, k)| away(k as usize)).min_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1))).map(|&(_, k)| k as usize);
            Some((i, second))
        })
    }

    pub(crate) fn bytes(&self) -> usize {
        self.tree.bytes() + (self.scale.len() + self.dir.len() + 2 * self.apart.len()) * 8
    }
}
