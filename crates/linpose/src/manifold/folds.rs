//! The held-out folds that every automatic choice of the manifold methods is scored on: along
//! each axis of the training grid, every other knot held out (then the others), the surface
//! fitted through the rest; the interpolation error those held-out knots measure; and the mean
//! and standard error of held-out scores that the one-standard-error rules compare.

use super::grid::Grid;
use super::surface::{Interpolant, Surface};
use super::tuning::MIN_FOLD_KNOTS;
use crate::dataset::Dataset;
use crate::Result;

/// The held-out folds of `grid`: for each usable axis, which training samples are kept (every
/// other knot held out, the odd ones).
pub(crate) fn folds(train: &Dataset, grid: &Grid) -> Vec<Vec<bool>> {
    folds_of(train, grid, 1)
}

/// [`folds`], then the same with the other half held out (the even knots, a linear axis still
/// keeping both its ends): every knot is held out once (the interior ones of a linear axis), at
/// the same spacing, so the score has twice the views behind it.
pub(crate) fn both_folds(train: &Dataset, grid: &Grid) -> Vec<Vec<bool>> {
    let mut out = folds_of(train, grid, 1);
    out.extend(folds_of(train, grid, 0));
    out
}

/// The folds holding out, along each usable axis in turn, the knots of index parity `parity`
/// (bar a linear axis's ends).
fn folds_of(train: &Dataset, grid: &Grid, parity: usize) -> Vec<Vec<bool>> {
    let shape = grid.shape();
    let d = shape.len();
    let mut out = Vec::new();
    for j in 0..d {
        let n = shape[j];
        if n < MIN_FOLD_KNOTS {
            continue;
        }
        let circular = train.space().params()[j].period.is_some();
        let held = |k: usize| k % 2 == parity && (circular || (k != 0 && k != n - 1));
        let mut keep = vec![true; train.len()];
        for (flat, &i) in grid.sample_at.iter().enumerate() {
            let k = flat / shape[j + 1..].iter().product::<usize>() % n;
            keep[i] = !held(k);
        }
        out.push(keep);
    }
    out
}

/// The mean squared interpolation error of each of the `dim` coordinates (`coords`, N x dim, in
/// training order) over the held-out folds of `grid` ([`folds`]): each held-out knot's coordinates
/// against the surface through the remaining knots by `interpolant`, at its pose. None when no
/// fold is possible.
pub(crate) fn interpolation_variance(train: &Dataset, grid: &Grid, coords: &[f64], dim: usize, interpolant: Interpolant) -> Result<Option<Vec<f64>>> {
    let folds = folds(train, grid);
    if folds.is_empty() {
        return Ok(None);
    }
    held_out_errors(train, &folds, coords, dim, interpolant).map(Some)
}

/// [`interpolation_variance`] over the given `folds` (each: which training samples are kept); all
/// zeros when they hold nothing out.
pub(crate) fn held_out_errors(train: &Dataset, folds: &[Vec<bool>], coords: &[f64], dim: usize, interpolant: Interpolant) -> Result<Vec<f64>> {
    let space = train.space();
    let d = space.len();
    let mut sum = vec![0.0; dim];
    let mut count = 0usize;
    let mut f = vec![0.0; dim];
    for keep in folds {
        let kept: Vec<usize> = (0..train.len()).filter(|&i| keep[i]).collect();
        let poses: Vec<f64> = kept.iter().flat_map(|&i| train.pose(i).iter().copied()).collect();
        let names: Vec<String> = kept.iter().map(|&i| train.manifest().images()[i].clone()).collect();
        let sub = Grid::new(space, &poses, &names, train.manifest().root())?;
        let knots: Vec<f64> = sub.sample_at.iter().flat_map(|&k| coords[kept[k] * dim..(kept[k] + 1) * dim].iter().copied()).collect();
        let surface = Surface::new(space, &sub.axes, &knots, dim, interpolant)?;
        for i in (0..train.len()).filter(|&i| !keep[i]) {
            let mut t = train.pose(i).to_vec();
            surface.clamp(&mut t[..d]);
            surface.eval(&t, &mut f, None);
            for (c, s) in sum.iter_mut().enumerate() {
                let r = coords[i * dim + c] - f[c];
                *s += r * r;
            }
            count += 1;
        }
    }
    Ok(sum.iter().map(|s| s / count.max(1) as f64).collect())
}

/// The mean of `v` (0 when empty).
pub(crate) fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// The standard error of the mean of `v`: its sample standard deviation over sqrt(len) (0 for
/// fewer than two values).
pub(crate) fn standard_error(v: &[f64]) -> f64 {
    let n = v.len();
    if n < 2 {
        return 0.0;
    }
    let m = mean(v);
    let var = v.iter().map(|&x| (x - m) * (x - m)).sum::<f64>() / (n - 1) as f64;
    (var / n as f64).sqrt()
}
