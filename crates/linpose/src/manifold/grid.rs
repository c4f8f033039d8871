//! The appearance manifold: the training images' eigenspace coordinates at their poses on the
//! training grid, joined by cubic splines along each pose axis (periodic along a circular axis, a
//! closed curve; not-a-knot along a linear one) and resampled densely.
//!
//! Resampling goes axis by axis, in the order of the pose parameters, at exactly the positions
//! numpy's `arange` gives: a circular axis from g_0 to g_0 + period exclusive, a linear axis from
//! g_0 to g_last inclusive (up to g_last + 1e-9), every `step` degrees. A spline along one
//! axis applied to values already resampled along the previous axes is the tensor-product spline,
//! so the order does not change the result beyond rounding.

use super::spline::{Boundary, Spline};
use crate::pose::{wrap_positive, PoseSpace};
use crate::{Error, Result};
use std::path::Path;

/// Most manifold points accepted (keeps a tiny step from exhausting memory).
pub(crate) const MAX_POINTS: usize = 1 << 24;

/// Most manifold values (points x dimensions) accepted.
pub(crate) const MAX_VALUES: usize = 1 << 28;

/// The training grid: the distinct values of each pose parameter, and which training sample sits
/// at each grid point.
#[derive(Debug, Clone)]
pub(crate) struct Grid {
    /// Distinct values per parameter, increasing.
    pub axes: Vec<Vec<f64>>,
    /// For each grid point in row-major order (the last parameter fastest), its training sample.
    pub sample_at: Vec<usize>,
}

impl Grid {
    /// Arranges training poses (`poses`, row-major, one row per sample, named by `images`) on
    /// their grid. Every combination of the parameters' values must be present exactly once;
    /// otherwise the error names the missing point or the duplicated images.
    pub(crate) fn new(space: &PoseSpace, poses: &[f64], images: &[String], root: &Path) -> Result<Self> {
        let d = space.len();
        let n = poses.len() / d;
        // -0.0 and 0.0 are one grid value (x + 0.0 turns -0.0 into 0.0).
        let poses: Vec<f64> = poses.iter().map(|&v| v + 0.0).collect();
        let err = |message: String| Error::Dataset { path: root.to_path_buf(), message };
        let mut axes = Vec::with_capacity(d);
        for (j, p) in space.params().iter().enumerate() {
            let mut v: Vec<f64> = (0..n).map(|i| poses[i * d + j]).collect();
            v.sort_by(f64::total_cmp);
            v.dedup_by(|a, b| a.total_cmp(b).is_eq());
            if let (Some(t), Some(lo), Some(hi)) = (p.period, v.first(), v.last()) {
                if hi - lo >= t {
                    return Err(err(format!(
                        "training values of the circular parameter '{}' span {lo} to {hi}, a whole period ({t}) or more; give each pose once within one period",
                        p.name
                    )));
                }
            }
            axes.push(v);
        }
        let total = axes.iter().try_fold(1usize, |a, v| a.checked_mul(v.len())).unwrap_or(usize::MAX);
        let mut missing_first = None;
        let mut sample_at = Vec::new();
        if total <= n {
            // As many slots as samples or fewer: either the grid is full or some pose repeats.
            sample_at = vec![usize::MAX; total];
            for i in 0..n {
                let mut flat = 0;
                for (j, ax) in axes.iter().enumerate() {
                    let k = ax.binary_search_by(|v| v.total_cmp(&poses[i * d + j])).expect("value is on its axis");
                    flat = flat * ax.len() + k;
                }
                if sample_at[flat] != usize::MAX {
                    return Err(err(format!(
                        "images '{}' and '{}' have the same training pose {:?}; the eigenspace manifold needs one image per grid point",
                        images[sample_at[flat]],
                        images[i],
                        &poses[i * d..(i + 1) * d]
                    )));
                }
                sample_at[flat] = i;
            }
        } else {
            // More grid points than samples: some point is missing. The first one in row-major
            // order comes within n + 1 steps, so the grid is never materialised.
            let have: std::collections::HashSet<Vec<u64>> = (0..n).map(|i| poses[i * d..(i + 1) * d].iter().map(|v| v.to_bits()).collect()).collect();
            let mut idx = vec![0usize; d];
            for flat in 0..total {
                let key: Vec<u64> = idx.iter().zip(&axes).map(|(&k, ax)| ax[k].to_bits()).collect();
                if !have.contains(&key) {
                    missing_first = Some(flat);
                    break;
                }
                for j in (0..d).rev() {
                    idx[j] += 1;
                    if idx[j] < axes[j].len() {
                        break;
                    }
                    idx[j] = 0;
                }
            }
        }
        if let Some(flat) = missing_first {
            let mut rest = flat;
            let mut point = vec![0.0; d];
            for j in (0..d).rev() {
                point[j] = axes[j][rest % axes[j].len()];
                rest /= axes[j].len();
            }
            let named: Vec<String> = space.params().iter().zip(&point).map(|(p, v)| format!("{} = {v}", p.name)).collect();
            let shape: Vec<String> = axes.iter().map(|a| a.len().to_string()).collect();
            return Err(err(format!(
                "the training poses do not form a full grid ({} = {total} points, {n} training images): no training image at {}; the eigenspace manifold is splined along each parameter over a complete grid",
                shape.join(" x "),
                named.join(", ")
            )));
        }
        Ok(Grid { axes, sample_at })
    }

    /// Number of grid points along each parameter.
    pub(crate) fn shape(&self) -> Vec<usize> {
        self.axes.iter().map(Vec::len).collect()
    }
}

/// The positions at which an axis with knots `g` is resampled every `step` degrees, as numpy's
/// `arange` computes them: n = ceil((stop - start) / step) values start + i * delta with
/// delta = (start + step) - start.
pub(crate) fn sample_positions(g: &[f64], period: Option<f64>, step: f64) -> Vec<f64> {
    let count = sample_count(g, period, step) as usize;
    let delta = (g[0] + step) - g[0];
    (0..count).map(|i| g[0] + i as f64 * delta).collect()
}

/// How many positions [`sample_positions`] gives (as f64, so an absurd step cannot overflow).
pub(crate) fn sample_count(g: &[f64], period: Option<f64>, step: f64) -> f64 {
    let stop = match period {
        Some(t) => g[0] + t,
        None => g[g.len() - 1] + 1e-9,
    };
    ((stop - g[0]) / step).ceil().max(0.0)
}

/// The dense manifold: points on a grid of sample positions.
#[derive(Debug, Clone)]
pub(crate) struct Manifold {
    /// Sample positions per parameter (degrees, as resampled: a circular one may pass its period).
    pub axes: Vec<Vec<f64>>,
    /// Points, one row of L coordinates per grid point, row-major over the axes.
    pub points: Vec<f64>,
}

impl Manifold {
    /// Resamples the coordinates `coords` (N x `dim`, row-major, in training-sample order) of the
    /// training images on `grid` every `step` degrees.
    pub(crate) fn build(space: &PoseSpace, grid: &Grid, coords: &[f64], dim: usize, step: f64) -> Result<Self> {
        let counts: Vec<f64> = space.params().iter().zip(&grid.axes).map(|(p, g)| sample_count(g, p.period, step)).collect();
        check_size(&counts, dim, step)?;
        let positions: Vec<Vec<f64>> = space.params().iter().zip(&grid.axes).map(|(p, g)| sample_positions(g, p.period, step)).collect();
        Self::build_at(space, grid, coords, dim, positions)
    }

    /// The points a method searches for the nearest one ([`super::dense_lattice`]): the
    /// manifold resampled every `step` degrees ([`Manifold::build`]) for at most
    /// [`super::tuning::LATTICE_MAX_PARAMS`] parameters, else at
    /// [`super::tuning::KNOT_RESAMPLE`] points per knot interval along each axis (the knots
    /// among them), which grows with the training views instead of with the pose ranges.
    pub(crate) fn build_for(space: &PoseSpace, grid: &Grid, coords: &[f64], dim: usize, step: f64) -> Result<Self> {
        if super::dense_lattice(space.len()) {
            return Self::build(space, grid, coords, dim, step);
        }
        let positions: Vec<Vec<f64>> = space.params().iter().zip(&grid.axes).map(|(p, g)| subdivided(g, p.period, super::tuning::KNOT_RESAMPLE)).collect();
        let counts: Vec<f64> = positions.iter().map(|a| a.len() as f64).collect();
        check_size(&counts, dim, step)?;
        Self::build_at(space, grid, coords, dim, positions)
    }

    /// The manifold at the sample positions `positions` along each parameter.
    fn build_at(space: &PoseSpace, grid: &Grid, coords: &[f64], dim: usize, positions: Vec<Vec<f64>>) -> Result<Self> {
        // The training coordinates as a cube [n_0, ..., n_{D-1}, dim].
        let mut cube = Vec::with_capacity(grid.sample_at.len() * dim);
        for &i in &grid.sample_at {
            cube.extend_from_slice(&coords[i * dim..(i + 1) * dim]);
        }
        let mut shape = grid.shape();
        for (j, p) in space.params().iter().enumerate() {
            let boundary = match p.period {
                Some(t) => Boundary::Periodic(t),
                None => Boundary::NotAKnot,
            };
            let spline = Spline::new(&grid.axes[j], boundary)?;
            let outer: usize = shape[..j].iter().product();
            let inner: usize = shape[j + 1..].iter().product::<usize>() * dim;
            let block = shape[j] * inner;
            let mut next = Vec::with_capacity(outer * positions[j].len() * inner);
            for o in 0..outer {
                next.extend(spline.resample(&cube[o * block..(o + 1) * block], inner, &positions[j]));
            }
            cube = next;
            shape[j] = positions[j].len();
        }
        Ok(Manifold { axes: positions, points: cube })
    }

    /// Number of manifold points.
    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.axes.iter().map(Vec::len).product()
    }

    /// The pose of point `k` into `out`, circular values wrapped into [0, period).
    #[cfg(test)]
    pub(crate) fn pose(&self, space: &PoseSpace, k: usize, out: &mut [f64]) {
        pose_of(&self.axes, space, k, out)
    }
}

/// `per` positions per knot interval of the knots `g` (the knots among them): the closing
/// interval of a circular axis included, a linear axis ending at its last knot.
pub(crate) fn subdivided(g: &[f64], period: Option<f64>, per: usize) -> Vec<f64> {
    let per = per.max(1);
    let n = g.len();
    let next = |i: usize| if i + 1 < n { g[i + 1] } else { g[0] + period.unwrap_or(0.0) };
    let pieces = if period.is_some() { n } else { n - 1 };
    let mut v: Vec<f64> = (0..pieces).flat_map(|i| (0..per).map(move |k| g[i] + (next(i) - g[i]) * k as f64 / per as f64)).collect();
    if period.is_none() {
        v.push(g[n - 1]);
    }
    v
}

/// The pose of grid point `k` of sample positions `axes` (row-major, the last fastest).
pub(crate) fn pose_of(axes: &[Vec<f64>], space: &PoseSpace, mut k: usize, out: &mut [f64]) {
    for j in (0..axes.len()).rev() {
        let v = axes[j][k % axes[j].len()];
        k /= axes[j].len();
        out[j] = match space.params()[j].period {
            Some(t) => wrap_positive(v, t),
            None => v,
        };
    }
}

/// Refuses a manifold of `counts` samples along each parameter, `dim` values each, that would be
/// too large to hold.
pub(crate) fn check_size(counts: &[f64], dim: usize, step: f64) -> Result<()> {
    let points = counts.iter().product::<f64>();
    if points > MAX_POINTS as f64 || points * dim as f64 > MAX_VALUES as f64 {
        return Err(Error::invalid(
            "manifold step",
            step,
            format!(
                "would resample the manifold into {points:.0} points of {dim} values (at most {MAX_POINTS} points and {MAX_VALUES} values); use a larger step"
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Param;

    fn space2() -> PoseSpace {
        PoseSpace::new(vec![Param::linear("elevation"), Param::circular("azimuth", 360.0)]).unwrap()
    }

    #[test]
    fn sample_positions_follow_numpy_arange() {
        // np.arange(32, 77 + 1e-9, 0.5) has 91 values; np.arange(0, 360, 0.5) has 720.
        let lin = sample_positions(&[32.0, 41.0, 77.0], None, 0.5);
        assert_eq!((lin.len(), lin[0], *lin.last().unwrap()), (91, 32.0, 77.0));
        let circ = sample_positions(&[5.0, 100.0], Some(360.0), 0.5);
        assert_eq!((circ.len(), circ[0], *circ.last().unwrap()), (720, 5.0, 364.5));
        // np.arange(0, 1 + 1e-9, 0.3) = [0, 0.3, 0.6, 0.9]
        assert_eq!(sample_positions(&[0.0, 1.0], None, 0.3).len(), 4);
    }

    #[test]
    fn missing_grid_point_is_named() {
        let mut poses = Vec::new();
        let mut images = Vec::new();
        for a in [32.0, 41.0, 50.0] {
            for e in [0.0, 90.0, 180.0, 270.0] {
                if (a, e) != (41.0, 180.0) {
                    poses.extend([a, e]);
                    images.push(format!("{a}_{e}.png"));
                }
            }
        }
        let e = Grid::new(&space2(), &poses, &images, Path::new("d")).unwrap_err().to_string();
        assert!(e.contains("elevation = 41, azimuth = 180") && e.contains("3 x 4"), "{e}");
        // A duplicate instead of the missing point: both images are named.
        poses.extend([41.0, 90.0]);
        images.push("dup.png".into());
        let e = Grid::new(&space2(), &poses, &images, Path::new("d")).unwrap_err().to_string();
        assert!(e.contains("41_90.png") && e.contains("dup.png"), "{e}");
    }

    #[test]
    fn a_whole_period_on_a_circular_axis_is_refused() {
        let s = PoseSpace::new(vec![Param::circular("azimuth", 360.0)]).unwrap();
        let e = Grid::new(&s, &[0.0, 180.0, 360.0], &["a".into(), "b".into(), "c".into()], Path::new("d")).unwrap_err();
        assert!(e.to_string().contains("whole period"), "{e}");
    }

    #[test]
    fn manifold_passes_through_training_coordinates_at_the_training_step() {
        // Non-uniform knots along elevation, uniform along azimuth; the manifold resampled every
        // 10 degrees contains every knot exactly (the Hermite weights there are exactly 0 and 1).
        let elev = [30.0, 40.0, 60.0, 70.0];
        let azim: Vec<f64> = (0..36).map(|k| 10.0 * k as f64).collect();
        let (mut poses, mut images) = (Vec::new(), Vec::new());
        for &a in &elev {
            for &e in &azim {
                poses.extend([a, e]);
                images.push(format!("{a}_{e}"));
            }
        }
        let n = images.len();
        let dim = 3;
        let coords: Vec<f64> = (0..n * dim).map(|i| ((i * 37) % 11) as f64 / 7.0 - 0.5).collect();
        let grid = Grid::new(&space2(), &poses, &images, Path::new("d")).unwrap();
        let m = Manifold::build(&space2(), &grid, &coords, dim, 10.0).unwrap();
        assert_eq!(m.len(), 5 * 36); // 30..70 every 10 (50 is not a knot) by 36
        let mut pose = [0.0; 2];
        let mut hits = 0;
        for k in 0..m.len() {
            m.pose(&space2(), k, &mut pose);
            if let Some(i) = (0..n).find(|&i| poses[2 * i] == pose[0] && poses[2 * i + 1] == pose[1]) {
                assert_eq!(&m.points[k * dim..(k + 1) * dim], &coords[i * dim..(i + 1) * dim]);
                hits += 1;
            }
        }
        assert_eq!(hits, n);
    }
}
