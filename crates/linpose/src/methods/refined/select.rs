//! The automatic choices of a fit, from the training views alone: the number of eigenimages L,
//! the metric, the interpolant and the binning factor ([`choose`], [`coarsest_within`]), the
//! noisy match ([`choose_noise`]), the noise threshold ([`noise_threshold`]) and the
//! coordinates' interpolation errors that weight the metric ([`interpolation_variance`]).
//!
//! Along each pose axis with enough knots in turn, the training views at every other knot are
//! held out, the odd ones and then the even ones ([`both_folds`]: every knot once; a linear axis
//! keeps both its end knots, so nothing is extrapolated); the eigenspace and the surface are
//! fitted on the rest, and the held-out views are estimated with every candidate L (the leading L
//! components of that one fit). The candidate with the fewest gross errors (over
//! [`GROSS_DEG`]: a flip, a view taken for its back) among the held-out views wins, then the one
//! with the least mean pose error; a tie goes to the smaller L (cheaper queries). A mean error
//! is not bought with a flip: a candidate that halves the small errors of every view but turns
//! one view around would otherwise win on the mean, and on a nearly symmetric object that is the
//! failure users cannot see ([`better`]). The manifold fitted without the
//! held-out views has twice the knot spacing of the final one, so this scores each L where
//! interpolation matters most, on views no fit has seen; holding out the even knots too doubles
//! the views behind each score at the same spacing. The same views score the plain metric (the
//! eigenspace's unweighted distance), which the model uses when it beats every weighted L.
//!
//! No candidate's query costs as much as the eigenspace's ([`below_eigenspace`]: its product on
//! the binned image plus the query's other work, against the eigenspace's product). The binning
//! factor is chosen among the factors with the fewest gross held-out errors by the
//! one-standard-error rule ([`coarsest_within`]): the coarsest whose least error is within one
//! standard error of the least of all. The factors' held-out errors often
//! differ by a view or two, within chance, while each halving of the resolution makes a query's
//! product 4 times cheaper; the rule takes the cheaper model unless the held-out views can tell
//! them apart.
//!
//! The interpolant of the surface ([`Interpolant`]) is chosen with L: each fold's eigenspace
//! gives both interpolants' models (side by side, on separate threads), and the interpolant
//! whose best candidate has the least error wins, the spline on a tie. The folds' doubled knot
//! spacing favours the local cubic somewhat more than the final spacing does.
//!
//! When no axis has enough knots, L falls back to the eigenspace's default and the interpolant to
//! the spline.

use super::tuning::{CANDIDATES, FALLBACK_COMPONENTS, MAX_AUTO_COMPONENTS, NOISE_BLOCK, NOISE_COMPONENTS, NOISE_LEVELS, NOISE_SEED, QUERY_OVERHEAD_ROWS};
use super::{Interpolant, RefinedModel, RefinedParams, RefinedSettings, Views, INTERPOLANTS, METHOD};
use crate::confidence::GROSS_DEG;
use crate::dataset::Dataset;
use crate::manifold::folds::{both_folds, folds, interpolation_variance, mean, standard_error};
use crate::manifold::grid::Grid;
use crate::manifold::pca::{self, Dimension};
use crate::model::{ModelMeta, PoseModel};
use crate::Result;
use rayon::prelude::*;

/// One fold of [`folds`]: the kept views, the held-out ones, and the grid of the kept ones.
fn split(train: &Dataset, keep: &[bool]) -> Result<(Dataset, Dataset, Grid)> {
    let fit = train.subset(keep)?;
    let held: Vec<bool> = keep.iter().map(|k| !k).collect();
    let test = train.subset(&held)?;
    let grid = Grid::new(train.space(), fit.poses(), fit.manifest().images(), fit.manifest().root())?;
    Ok((fit, test, grid))
}

/// Every candidate L scored, with its mean held-out error (degrees).
pub(crate) type Scores = Vec<(usize, f64)>;

/// The noisy match chosen by [`choose_noise`]: L, whether weighted, and every candidate's (L,
/// weighted, mean capped held-out error in degrees).
pub(crate) type NoiseChoice = (usize, bool, Vec<(usize, bool, f64)>);

/// What [`choose`] found on one set of training images.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Choice {
    /// The chosen interpolant (the one asked for when fixed).
    pub interpolant: Interpolant,
    /// Every interpolant scored, with its least mean held-out error (degrees).
    pub by_interpolant: Vec<(Interpolant, f64)>,
    /// The chosen L (of the weighted search).
    pub components: usize,
    /// Every weighted candidate's (L, mean held-out error in degrees).
    pub scored: Scores,
    /// The plain metric's mean held-out error (None when not scored).
    pub plain: Option<f64>,
    /// The least of those mean errors (infinite when nothing could be held out).
    pub least: f64,
    /// The standard error of [`Self::least`]: the standard deviation of that candidate's
    /// held-out views' errors over the square root of their number (0 when nothing could be
    /// held out).
    pub standard_error: f64,
    /// The chosen candidate's gross held-out errors (over [`GROSS_DEG`]), the first criterion
    /// of every choice.
    pub gross: usize,
    /// Whether the plain metric was chosen over every weighted L.
    pub plain_wins: bool,
}

/// Whether held-out score `a` (gross errors, mean error) beats `b`: fewer gross errors, then a
/// smaller mean. A candidate never buys a smaller mean error with a flip.
pub(crate) fn better(a: (usize, f64), b: (usize, f64)) -> bool {
    a.0 < b.0 || (a.0 == b.0 && a.1 < b.1)
}

/// The gross errors (over [`GROSS_DEG`]) among held-out errors `v`.
fn gross(v: &[f64]) -> usize {
    v.iter().filter(|&&e| e > GROSS_DEG).count()
}

/// Chooses L for `params` on `train` (laid out on `grid`) on images binned by `bin` (which bounds L, [`below_eigenspace`]),
/// and when `params` weights the coordinates, also the mean held-out error of the plain
/// (unweighted) search in [`NOISE_COMPONENTS`] coordinates (within that bound): the
/// eigenspace's own metric, which the model falls back to when it scores better; and the least
/// error's standard error, which the choice of the binning factor weighs.
pub(crate) fn choose(train: &Dataset, grid: &Grid, params: &RefinedParams, bin: usize) -> Result<Choice> {
    let below = below_eigenspace(bin);
    let folds = both_folds(train, grid);
    let interpolants = params.fixed_interpolant().map_or(INTERPOLANTS.to_vec(), |i| vec![i]);
    if folds.is_empty() {
        let l = FALLBACK_COMPONENTS.min(below);
        let interpolant = interpolants[0];
        return Ok(Choice {
            interpolant,
            by_interpolant: Vec::new(),
            components: l,
            scored: Vec::new(),
            plain: None,
            least: f64::INFINITY,
            standard_error: 0.0,
            gross: 0,
            plain_wins: false,
        });
    }
    let mut tallies: Vec<Tally> = interpolants.iter().map(|_| Tally::default()).collect();
    let space = train.space();
    let m = train.n_features();
    for keep in &folds {
        let (fit, test, sub_grid) = split(train, keep)?;
        let pca = pca::fit(&fit, Dimension::Fixed(MAX_AUTO_COMPONENTS))?;
        let l_max = pca.dim();
        let plain_l = NOISE_COMPONENTS.min(l_max).min(below);
        // The interpolants on this fold's eigenspace, side by side (each model's trees and
        // tables are built on one thread).
        tallies.par_iter_mut().zip(&interpolants).try_for_each(|(tally, &interpolant)| -> Result<()> {
            let params = params.interpolant(interpolant);
            let sigma2 = if params.weighted { interpolation_variance(&fit, &sub_grid, &pca.coords, l_max, interpolant)? } else { None };
            let cands: Vec<(usize, bool)> =
                CANDIDATES.iter().filter(|&&l| l <= l_max && l <= below).map(|&l| (l, false)).chain(params.weighted.then_some((plain_l, true))).collect();
            for (c, &(l, plain)) in cands.iter().enumerate() {
                let sig = if plain { None } else { sigma2.as_ref().map(|s| s[..l].to_vec()) };
                let scale = super::fit::weights(sig.as_deref(), l);
                let mut basis = Vec::with_capacity(l * m);
                for (row, &s) in pca.basis.chunks_exact(m).zip(&scale).take(l) {
                    basis.extend(row.iter().map(|&v| (v * s) as f32));
                }
                let mut knots = Vec::with_capacity(sub_grid.sample_at.len() * l);
                for &i in &sub_grid.sample_at {
                    knots.extend(pca.coords[i * l_max..i * l_max + l].iter().zip(&scale).map(|(&v, &w)| (v * w) as f32));
                }
                let settings = RefinedSettings {
                    interpolation_variance: sig.unwrap_or_default(),
                    residual_energy: pca.eigenvalues[l..].iter().map(|&v| v.max(0.0)).sum::<f64>() / fit.len() as f64,
                    ..fold_settings(&params, l, sub_grid.shape())
                };
                let meta = ModelMeta { method: METHOD.name.into(), spec: fit.spec(), space: space.clone(), train_poses: vec![], settings: serde_json::Value::Null, normalize: None, stage_choice: None };
                let mean = pca.mean.iter().map(|&v| v as f32).collect();
                let background = vec![0.0; knots.len()];
                let model = RefinedModel::new(meta, settings, basis, mean, knots, background, sub_grid.axes.clone())?;
                let est = model.predict(test.features())?;
                let d = space.len();
                let errs = (0..test.len()).map(|i| space.error_deg(test.pose(i), &est[i * d..(i + 1) * d]));
                if plain {
                    tally.plain_views.extend(errs);
                    tally.plain_folds += 1;
                    continue;
                }
                if c >= tally.weighted.len() {
                    tally.weighted.push((l, 0, Vec::new()));
                }
                tally.weighted[c].1 += 1;
                tally.weighted[c].2.extend(errs);
            }
            Ok(())
        })?;
    }
    // The interpolant with the fewest gross errors, then the least error (the first, the
    // spline, on a tie).
    let choices: Vec<Choice> = interpolants.iter().zip(&tallies).map(|(&i, t)| t.choice(i, folds.len(), below)).collect();
    let by_interpolant: Vec<(Interpolant, f64)> = choices.iter().map(|c| (c.interpolant, c.least)).collect();
    let best = choices.into_iter().reduce(|a, b| if better((b.gross, b.least), (a.gross, a.least)) { b } else { a }).expect("at least one interpolant");
    Ok(Choice { by_interpolant, ..best })
}

/// One interpolant's held-out errors in [`choose`]: each weighted candidate's L, the folds that
/// scored it and its held-out views' errors; the plain metric's errors and folds.
#[derive(Default)]
struct Tally {
    weighted: Vec<(usize, usize, Vec<f64>)>,
    plain_views: Vec<f64>,
    plain_folds: usize,
}

impl Tally {
    /// The choice of L for `interpolant` over `n_folds` folds, L at most `below` (without
    /// [`Choice::by_interpolant`]).
    fn choice(&self, interpolant: Interpolant, n_folds: usize, below: usize) -> Choice {
        // Only candidates every fold could score.
        let kept: Vec<(usize, &[f64])> = self.weighted.iter().filter(|w| w.1 == n_folds).map(|w| (w.0, &w.2[..])).collect();
        let scored: Scores = kept.iter().map(|&(l, v)| (l, mean(v))).collect();
        // The fewest gross errors, then the least mean error; a tie goes to the smaller L.
        let mut best = (FALLBACK_COMPONENTS.min(below), (usize::MAX, f64::INFINITY), &[][..]);
        for &(l, v) in &kept {
            if better((gross(v), mean(v)), best.1) {
                best = (l, (gross(v), mean(v)), v);
            }
        }
        let plain = (self.plain_folds == n_folds).then(|| mean(&self.plain_views));
        // The plain metric when it scored better than every weighted L (as the model then uses
        // it); the least error's views are the chosen candidate's.
        let plain_wins = plain.is_some_and(|p| better((gross(&self.plain_views), p), best.1));
        let (least_views, least) = if plain_wins { (&self.plain_views[..], plain.unwrap_or(f64::INFINITY)) } else { (best.2, best.1 .1) };
        Choice {
            interpolant,
            by_interpolant: Vec::new(),
            components: best.0,
            scored,
            plain,
            least,
            standard_error: standard_error(least_views),
            gross: gross(least_views),
            plain_wins,
        }
    }
}

/// The most eigenimages whose query on images binned by `bin` costs less than the eigenspace's
/// product (its [`NOISE_COMPONENTS`] rows on the images as given, 1 / bin^2 the pixels): the
/// largest of [`CANDIDATES`] with L + [`QUERY_OVERHEAD_ROWS`] under NOISE_COMPONENTS bin^2 (the
/// eigenspace's own mean row and search not counted: a margin for timing noise). Unbinned, 12.
pub(crate) fn below_eigenspace(bin: usize) -> usize {
    let bound = NOISE_COMPONENTS * bin * bin;
    CANDIDATES.iter().copied().filter(|&l| l + QUERY_OVERHEAD_ROWS < bound).max().unwrap_or(CANDIDATES[0])
}

/// The one-standard-error rule (Hastie, Tibshirani & Friedman, The Elements of Statistical
/// Learning, 7.10) over candidates ordered from the costliest to the cheapest, each given as
/// (mean held-out error, its standard error): the cheapest whose error is within one standard
/// error of the least (that least's own), so a difference the held-out views cannot tell from
/// chance does not buy a costlier model. Returns its index and the standard error allowed (0
/// and 0 for no candidates; with every error infinite, nothing held out, the cheapest).
pub(crate) fn coarsest_within(scores: &[(f64, f64)]) -> (usize, f64) {
    let Some(&(least, se)) = scores.iter().min_by(|a, b| a.0.total_cmp(&b.0)) else {
        return (0, 0.0);
    };
    let k = scores.iter().rposition(|s| s.0 <= least + se).unwrap_or(0);
    (k, se)
}

/// The settings of a model fitted on one fold: `l` components, all searched, nothing chosen, the
/// interpolant of `params` (the spline when not fixed).
fn fold_settings(params: &RefinedParams, l: usize, knot_shape: Vec<usize>) -> RefinedSettings {
    RefinedSettings {
        params: *params,
        bin: 1,
        bin_selection: vec![],
        bin_tolerance: 0.0,
        interpolant: params.fixed_interpolant().unwrap_or_default(),
        interpolant_selection: vec![],
        components: l,
        search_components: l,
        energy_kept: 0.0,
        knot_shape,
        roll_split: None,
        roll_turn_error: None,
        selection: vec![],
        plain_error: None,
        interpolation_variance: vec![],
        residual_energy: 0.0,
        noise_threshold: 0.0,
        noise_components: l,
        noise_weighted: false,
        coord_variance: vec![],
        noise_selection: vec![],
        second_look: None,
    }
}

/// Chooses the match of noisy queries ([`RefinedModel`]'s affine match) from the training views
/// alone: on the folds of [`folds`], the held-out views get simulated uniform noise at each of
/// [`NOISE_LEVELS`] (clipped, fixed seed) and are estimated with every candidate, L among
/// [`CANDIDATES`] up to `l_cap`, weighted or plain; the least mean pose error wins (a tie goes
/// to the smaller L, then to the plain metric). None when no fold is possible. `train` is what
/// the model is fitted on (binned); each fold's model takes the held-out views as given
/// (`views`) with their noise and bins them, as the model will: so a query's noise is measured
/// as it will be.
pub(crate) fn choose_noise(train: &Dataset, views: Views<'_>, grid: &Grid, params: &RefinedParams, l_cap: usize) -> Result<Option<NoiseChoice>> {
    let folds = folds(train, grid);
    if folds.is_empty() {
        return Ok(None);
    }
    let space = train.space();
    let d = space.len();
    let l_fit = NOISE_COMPONENTS.min(l_cap);
    let mut scores: Vec<(usize, bool, f64, usize)> = Vec::new();
    let cap = error_cap(grid);
    for keep in &folds {
        let (fit, test, sub_grid) = split(train, keep)?;
        let pca = pca::fit(&fit, Dimension::Fixed(l_fit))?;
        let l = pca.dim();
        let coord_variance = interpolation_variance(&fit, &sub_grid, &pca.coords, l, params.fixed_interpolant().unwrap_or_default())?;
        let knots: Vec<f32> = sub_grid.sample_at.iter().flat_map(|&i| pca.coords[i * l..(i + 1) * l].iter().map(|&v| v as f32)).collect();
        let fit_full = views.full.subset(keep)?;
        let background = super::noisy::background_knots(Views { full: &fit_full, ..views }, &sub_grid.sample_at, &pca.basis, l);
        let settings = RefinedSettings {
            coord_variance: coord_variance.clone().unwrap_or_default(),
            bin: views.binning.factor(),
            ..fold_settings(params, l, sub_grid.shape())
        };
        let meta = ModelMeta { method: METHOD.name.into(), spec: views.full.spec(), space: space.clone(), train_poses: vec![], settings: serde_json::Value::Null, normalize: None, stage_choice: None };
        let to32 = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<f32>>();
        let mut model = RefinedModel::new(meta, settings, to32(&pca.basis), to32(&pca.mean), knots, background, sub_grid.axes.clone())?;
        let mut cands: Vec<(usize, bool)> = CANDIDATES.iter().filter(|&&c| c <= l).map(|&c| (c, false)).collect();
        if cands.is_empty() {
            cands.push((l, false));
        }
        if coord_variance.is_some() {
            cands.extend(cands.clone().into_iter().map(|(c, _)| (c, true)));
        }
        // The held-out views as given, with simulated noise (the fold's model bins them).
        let held: Vec<bool> = keep.iter().map(|k| !k).collect();
        let test_full = views.full.subset(&held)?;
        let m = test_full.n_features();
        let noisy: Vec<Vec<f32>> = NOISE_LEVELS
            .iter()
            .map(|&level| {
                let mut q = test_full.features().to_vec();
                crate::pixel_noise::add_uniform_noise(&mut q, m, level, NOISE_SEED).map(|_| q)
            })
            .collect::<Result<_>>()?;
        // Each candidate's match (its tables or tree) is set once for every noise level.
        for &(c, w) in &cands {
            model.set_noise_match(c, w);
            for q in &noisy {
                let est = model.predict_noisy(q)?;
                // Capped: a gross failure (wrong knot interval) weighs as much as half an
                // interval, so the rare ones of the sparse fold do not decide the choice.
                let err: f64 = (0..test.len()).map(|i| space.error_deg(test.pose(i), &est[i * d..(i + 1) * d]).min(cap)).sum();
                match scores.iter_mut().find(|s| (s.0, s.1) == (c, w)) {
                    Some(s) => (s.2, s.3) = (s.2 + err, s.3 + test.len()),
                    None => scores.push((c, w, err, test.len())),
                }
            }
        }
    }
    let scored: Vec<(usize, bool, f64)> = scores.iter().map(|&(c, w, e, n)| (c, w, e / n.max(1) as f64)).collect();
    let best = scored.iter().fold(None::<(usize, bool, f64)>, |b, &s| match b {
        Some(b) if b.2 <= s.2 => Some(b),
        _ => Some(s),
    });
    Ok(best.map(|(c, w, _)| (c, w, scored.clone())))
}

/// The noise threshold of a clean query ([`RefinedSettings::noise_threshold`]), from the training
/// images alone: `clean`, the largest [`crate::pixel_noise::pixel_noise`] of a training image, and `noisy`,
/// the smallest of the same images with simulated uniform noise at the smallest of
/// [`NOISE_LEVELS`] (clipped, fixed seed). When they separate, the threshold is their geometric
/// mean, the same factor from each; otherwise `clean`. A model that bins measures a query's
/// noise on the image as given, so `train` is the images as given.
///
/// Why not `clean` itself: a fresh clean view is as likely as any of the N training views to
/// be the noisiest of the N + 1, so it exceeds the training maximum with probability 1 / (N +
/// 1), and about one clean query in N + 1 would take the noisy match, whose free gain and
/// offset cost precision. The midpoint keeps every simulated noisy training view above it.
pub(crate) fn noise_threshold(train: &Dataset) -> Result<NoiseThreshold> {
    let spec = train.spec();
    let (w, h, ch, m) = (spec.width as usize, spec.height as usize, spec.color.channels(), train.n_features());
    let noise = |x: &[f32]| crate::pixel_noise::pixel_noise(x, w, h, ch);
    let clean = (0..train.len()).into_par_iter().map(|i| noise(train.row(i))).reduce(|| 0.0, f64::max);
    let level = NOISE_LEVELS.iter().copied().fold(f64::INFINITY, f64::min);
    let mut noisy = f64::INFINITY;
    for (b, block) in train.features().chunks(NOISE_BLOCK * m).enumerate() {
        let mut q = block.to_vec();
        crate::pixel_noise::add_uniform_noise(&mut q, m, level, NOISE_SEED.wrapping_add(b as u64))?;
        noisy = noisy.min(q.par_chunks(m).map(noise).reduce(|| f64::INFINITY, f64::min));
    }
    Ok(NoiseThreshold { clean, noisy, threshold: separating(clean, noisy) })
}

/// The threshold between the noisiest clean value `clean` and the least noisy value `noisy`:
/// their geometric mean when they separate, else `clean` (0, no training noise to measure
/// against, stays 0: detection off).
pub(crate) fn separating(clean: f64, noisy: f64) -> f64 {
    if clean > 0.0 && noisy.is_finite() && noisy > clean {
        (clean * noisy).sqrt()
    } else {
        clean
    }
}

/// What [`noise_threshold`] measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct NoiseThreshold {
    /// The largest pixel noise of a clean training image.
    pub clean: f64,
    /// The smallest pixel noise of a training image with simulated noise (infinite for none).
    pub noisy: f64,
    /// The threshold.
    pub threshold: f64,
}

/// The cap on a held-out view's error when scoring the noisy match: half the smallest spacing of
/// the training grid's knots (degrees), beyond which an estimate is in the wrong knot interval.
pub(crate) fn error_cap(grid: &Grid) -> f64 {
    let h = grid.axes.iter().flat_map(|a| a.windows(2).map(|w| w[1] - w[0])).fold(f64::INFINITY, f64::min);
    if h.is_finite() {
        h / 2.0
    } else {
        f64::INFINITY
    }
}

