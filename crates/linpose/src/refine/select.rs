//! The automatic choice of the number of eigenimages L, from the training views alone.
//!
//! Along each pose axis with enough knots in turn, the training views at every other knot are
//! held out (a linear axis keeps both its end knots, so nothing is extrapolated); the eigenspace
//! and the surface are fitted on the rest, and the held-out views are estimated with every
//! candidate L (the leading L components of that one fit). The candidate with the least mean pose
//! error over all held-out views wins; a tie goes to the smaller L (cheaper queries). The manifold
//! fitted without the held-out views has twice the knot spacing of the final one, so this scores
//! each L where interpolation matters most, on views no fit has seen.
//!
//! When no axis has enough knots (fewer than 4), L falls back to [`FALLBACK_COMPONENTS`], the
//! eigenspace's default.

use super::{RefinedModel, RefinedParams, RefinedSettings, MAX_AUTO_COMPONENTS, METHOD};
use crate::dataset::Dataset;
use crate::eigenspace::manifold::Grid;
use crate::eigenspace::pca::{self, Dimension};
use crate::model::{ModelMeta, PoseModel};
use crate::Result;

/// L when the training grid is too small to hold views out.
pub const FALLBACK_COMPONENTS: usize = 20;

/// The candidates for L, capped by what the held-out fits can give.
pub const CANDIDATES: &[usize] = &[8, 12, 16, 20];

/// The held-out folds of `grid`: for each usable axis, which training samples are kept.
pub fn folds(train: &Dataset, grid: &Grid) -> Vec<Vec<bool>> {
    let shape = grid.shape();
    let d = shape.len();
    let mut out = Vec::new();
    for j in 0..d {
        let n = shape[j];
        if n < 4 {
            continue;
        }
        let circular = train.space().params()[j].period.is_some();
        let held = |k: usize| k % 2 == 1 && (circular || k != n - 1);
        let mut keep = vec![true; train.len()];
        for (flat, &i) in grid.sample_at.iter().enumerate() {
            let k = flat / shape[j + 1..].iter().product::<usize>() % n;
            keep[i] = !held(k);
        }
        out.push(keep);
    }
    out
}

/// Chooses L for `params` on `train` (laid out on `grid`): the chosen L and every candidate's
/// mean held-out error (degrees).
pub fn choose_components(train: &Dataset, grid: &Grid, params: &RefinedParams) -> Result<(usize, Vec<(usize, f64)>)> {
    choose(train, grid, params).map(|(l, scored, _)| (l, scored))
}

/// As [`choose_components`], and when `params` weights the coordinates, also the mean held-out
/// error of the plain (unweighted) search in [`super::NOISE_COMPONENTS`] coordinates: the
/// eigenspace's own metric, which the model falls back to when it scores better.
pub fn choose(train: &Dataset, grid: &Grid, params: &RefinedParams) -> Result<(usize, Vec<(usize, f64)>, Option<f64>)> {
    let folds = folds(train, grid);
    if folds.is_empty() {
        return Ok((FALLBACK_COMPONENTS, Vec::new(), None));
    }
    let (mut plain_sum, mut plain_n, mut plain_folds) = (0.0, 0usize, 0usize);
    let space = train.space();
    let m = train.n_features();
    let mut sums: Vec<(usize, f64, usize, usize)> = Vec::new();
    for keep in &folds {
        let fit = train.subset(keep)?;
        let held: Vec<bool> = keep.iter().map(|k| !k).collect();
        let test = train.subset(&held)?;
        let sub_grid = Grid::new(space, fit.poses(), fit.manifest().images(), fit.manifest().root())?;
        let pca = pca::fit(&fit, Dimension::Fixed(MAX_AUTO_COMPONENTS))?;
        let l_max = pca.dim();
        let sigma2 = if params.weighted { interpolation_variance(&fit, &sub_grid, &pca.coords, l_max)? } else { None };
        let plain_l = super::NOISE_COMPONENTS.min(l_max);
        let cands: Vec<(usize, bool)> = CANDIDATES
            .iter()
            .filter(|&&l| l <= l_max)
            .map(|&l| (l, false))
            .chain(params.weighted.then_some((plain_l, true)))
            .collect();
        for (c, &(l, plain)) in cands.iter().enumerate() {
            let sig = if plain { None } else { sigma2.as_ref().map(|s| s[..l].to_vec()) };
            let scale = super::weights(sig.as_deref(), l);
            let mut basis = Vec::with_capacity(l * m);
            for r in 0..l {
                basis.extend(pca.basis[r * m..(r + 1) * m].iter().map(|&v| (v * scale[r]) as f32));
            }
            let mut knots = Vec::with_capacity(sub_grid.sample_at.len() * l);
            for &i in &sub_grid.sample_at {
                knots.extend(pca.coords[i * l_max..i * l_max + l].iter().zip(&scale).map(|(&v, &w)| (v * w) as f32));
            }
            let settings = RefinedSettings { params: *params, components: l, search_components: l, energy_kept: 0.0, knot_shape: sub_grid.shape(), selection: vec![], plain_error: None,
                interpolation_variance: sig.unwrap_or_default(),
                residual_energy: pca.eigenvalues[l..].iter().map(|&v| v.max(0.0)).sum::<f64>() / fit.len() as f64,
                noise_threshold: 0.0,
            };
            let meta = ModelMeta { method: METHOD.into(), spec: fit.spec(), space: space.clone(), train_poses: vec![], settings: serde_json::Value::Null };
            let mean = pca.mean.iter().map(|&v| v as f32).collect();
            let model = RefinedModel::new(meta, settings, basis, mean, knots, sub_grid.axes.clone())?;
            let est = model.predict(test.features())?;
            let d = space.len();
            let err: f64 = (0..test.len()).map(|i| space.error_deg(test.pose(i), &est[i * d..(i + 1) * d])).sum();
            if plain {
                (plain_sum, plain_n, plain_folds) = (plain_sum + err, plain_n + test.len(), plain_folds + 1);
                continue;
            }
            if c >= sums.len() {
                sums.push((l, 0.0, 0, 0));
            }
            sums[c].1 += err;
            sums[c].2 += test.len();
            sums[c].3 += 1;
        }
    }
    // Only candidates every fold could score.
    let scored: Vec<(usize, f64)> = sums.iter().filter(|s| s.3 == folds.len()).map(|&(l, e, n, _)| (l, e / n.max(1) as f64)).collect();
    let best = scored.iter().fold((FALLBACK_COMPONENTS, f64::INFINITY), |b, &(l, e)| if e < b.1 { (l, e) } else { b });
    let plain = (plain_folds == folds.len()).then(|| plain_sum / plain_n.max(1) as f64);
    Ok((best.0, scored, plain))
}

/// The mean squared interpolation error of each of the `dim` coordinates (`coords`, N x dim, in
/// training order) over the held-out folds of `grid`: each held-out knot's coordinates against
/// the surface through the remaining knots, at its pose. None when no fold is possible.
pub fn interpolation_variance(train: &Dataset, grid: &Grid, coords: &[f64], dim: usize) -> Result<Option<Vec<f64>>> {
    let folds = folds(train, grid);
    if folds.is_empty() {
        return Ok(None);
    }
    let space = train.space();
    let d = space.len();
    let mut sum = vec![0.0; dim];
    let mut count = 0usize;
    let mut f = vec![0.0; dim];
    for keep in &folds {
        let kept: Vec<usize> = (0..train.len()).filter(|&i| keep[i]).collect();
        let poses: Vec<f64> = kept.iter().flat_map(|&i| train.pose(i).iter().copied()).collect();
        let names: Vec<String> = kept.iter().map(|&i| train.manifest().images()[i].clone()).collect();
        let sub = Grid::new(space, &poses, &names, train.manifest().root())?;
        let knots: Vec<f64> = sub.sample_at.iter().flat_map(|&k| coords[kept[k] * dim..(kept[k] + 1) * dim].iter().copied()).collect();
        let surface = super::surface::Surface::new(space, &sub.axes, &knots, dim)?;
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
    Ok(Some(sum.iter().map(|s| s / count.max(1) as f64).collect()))
}
