//! The noisy match: a query detected as noisy is matched to the surface under a free gain and a
//! free offset along what clipped noise adds ([`RefinedModel::pose_of_noisy`]).
//!
//! The query's coordinates z (the mean added back) are matched against alpha (f(t) + c) +
//! beta g(t): f the surface, c the mean's coordinates, alpha a gain (noise adds energy, so a
//! unit-energy noisy query is a shrunk clean one) and beta a multiple of the offset direction g,
//! the surface through the training views' [`clip_bias_shape`] projected on the eigenimages
//! ([`background_knots`]): what uniform noise clipped to [0, 1] adds to each pixel on average,
//! which on a black background is a brightening of the background's silhouette. Both are solved
//! per pose in closed form ([`affine`]), in the first L_n coordinates, weighted by 1 or by
//! 1 / (sigma_l^2 + floor + nu) (nu the query's pixel noise per coordinate), as the fit chose on
//! held-out views under simulated noise.
//!
//! With two pose parameters reported on a lattice, the starts are the [`NoisyTree`]'s
//! nearest point and, within a ratio of its distance, the nearest of another basin, and from each
//! the climb on the reporting lattice; otherwise the [`NoiseScan`] of the coarse points gives the
//! starts of Levenberg-Marquardt, whose best end is snapped to the lattice.

mod affine;
mod scan;
mod tree;

pub(crate) use affine::{affine_fit, AffineQuery};
pub(crate) use scan::NoiseScan;
pub(crate) use tree::NoisyTree;

use super::fit::Views;
use super::model::RefinedModel;
use super::query::NoiseWant;
use super::scratch::{QueryScratch, SEARCH_SCRATCH};
use super::search::smallest;
use super::tuning::{BIAS_AMPLITUDE, WEIGHT_FLOOR};
use crate::manifold::chunk_rows;
use crate::Result;
use rayon::prelude::*;

/// How uniform noise of +-a clipped to [0, 1] moves a pixel of value v on average, up to the
/// factor a / 4: E[clip(v + n)] - v = (a / 4) (1 - v / a)^2 for v < a (brightening, 1 on black),
/// minus the mirror image below white, 0 in between. At the reference a = [`BIAS_AMPLITUDE`] this
/// shape, projected, is the offset direction g of the noisy match: on a black background it is
/// the background's silhouette, which clipped noise brightens by a / 4.
pub(super) fn clip_bias_shape(v: f32) -> f32 {
    let lo = (1.0 - v / BIAS_AMPLITUDE).max(0.0);
    let hi = (1.0 - (1.0 - v) / BIAS_AMPLITUDE).max(0.0);
    lo * lo - hi * hi
}

/// The offset direction of each knot: the training image's [`clip_bias_shape`] (of its pixels
/// as given, then binned: the bias of a binned pixel is the mean of its pixels' biases) projected
/// on `basis` (L rows of the binned M, as stored), in the knots' order.
pub(crate) fn background_knots(views: Views<'_>, sample_at: &[usize], basis: &[f64], l: usize) -> Vec<f32> {
    let m = views.binning.spec().features();
    let per: Vec<Vec<f32>> = sample_at
        .par_iter()
        .map_init(Vec::new, |acc, &i| {
            let shape: Vec<f32> = views.full.row(i).iter().map(|&v| clip_bias_shape(v)).collect();
            let b: Vec<f64> = if views.binning.bins() {
                let mut out = vec![0.0; m];
                views.binning.apply(&shape, &mut out, acc);
                out.iter().map(|&v| v as f64).collect()
            } else {
                shape.iter().map(|&v| v as f64).collect()
            };
            (0..l).map(|c| basis[c * m..(c + 1) * m].iter().zip(&b).map(|(u, v)| u * v).sum::<f64>() as f32).collect()
        })
        .collect();
    per.concat()
}

impl RefinedModel {
    /// The weights of the noisy match on the stored (scaled) coordinates, one per coordinate it
    /// uses, for pixel noise `nu` per unit-energy coordinate: the wanted weight on the unscaled
    /// coordinates (1, or 1 / (sigma_l^2 + floor + nu) when weighted) times 1 / scale^2.
    pub(crate) fn noise_weights(&self, nu: f64) -> Vec<f64> {
        let s = &self.settings;
        let l = self.components();
        let (ln, weighted) = (s.noise_components.clamp(1, l), s.noise_weighted && s.coord_variance.len() == l);
        let floor = if weighted { WEIGHT_FLOOR * s.coord_variance[..ln].iter().sum::<f64>() / ln as f64 } else { 0.0 };
        (0..ln).map(|q| if weighted { 1.0 / (s.coord_variance[q] + floor + nu) } else { 1.0 } * self.inv_weight[q]).collect()
    }

    /// Sets the noisy match (its eigenimages and whether it weights them), and the coarse scan's
    /// tables with it.
    pub(crate) fn set_noise_match(&mut self, components: usize, weighted: bool) {
        (self.settings.noise_components, self.settings.noise_weighted) = (components, weighted);
        let w0 = self.noise_weights(0.0);
        let c: Vec<f64> = self.mean_proj[..w0.len()].iter().map(|&v| v as f64).collect();
        self.noisy_tree = self.tree.as_ref().and_then(|ct| NoisyTree::new(&self.surface, &self.bg_surface, &self.meta.space, &self.axes, &ct.poses, &c, &w0));
        self.noise_scan = if self.noisy_tree.is_some() { NoiseScan::default() } else { NoiseScan::new(self, &w0) };
    }

    /// The pose of a noisy query's coordinates `y` (as [`Self::pose_routed`]), whose pixel
    /// noise puts variance `nu` on each unit-energy coordinate: the affine match. Clipped noise
    /// brightens a black background by a / 4 and adds energy, so the query is matched to
    /// alpha (f(t) + c) + beta g(t), the surface point (c the mean's coordinates) scaled by a free
    /// gain plus a free multiple of the offset direction g ([`clip_bias_shape`]), both solved
    /// per pose, in the first `noise_components` coordinates, weighted by
    /// 1 / (sigma_l^2 + floor + nu) when `noise_weighted`.
    ///
    /// With a [`NoisyTree`] (two parameters reported on a lattice) the starts are its
    /// nearest point and, within twice its distance, the nearest of another basin; from each
    /// [`Surface::climb_pair`](super::surface::Surface::climb_pair) walks the reporting lattice on the affine match, and the closer
    /// end is the pose. Otherwise the coarse scan ([`NoiseScan`]) gives the starts of
    /// Levenberg-Marquardt ([`Surface::refine_affine`](super::surface::Surface::refine_affine)), snapped to the lattice.
    pub(crate) fn pose_of_noisy(&self, y: &[f32], nu: f64, out: &mut [f64]) {
        let (l, d) = (self.components(), self.axes.len());
        let s = &self.settings;
        let wt = self.noise_weights(nu);
        let ln = wt.len();
        let c: Vec<f64> = self.mean_proj[..ln].iter().map(|&v| v as f64).collect();
        let z: Vec<f64> = y[..ln].iter().zip(&c).map(|(&v, &cv)| v as f64 + cv).collect();
        let (fs, bs) = (&self.surface, &self.bg_surface);
        if let (Some(nt), Some(ct)) = (&self.noisy_tree, &self.tree) {
            // A query with no length off the offset direction (never seen) starts from the
            // clean tree's nearest point.
            let (i, second) = nt.starts(&z, &ct.poses).unwrap_or_else(|| (ct.tree.nearest(&y[..s.search()]), None));
            let aq = AffineQuery::new(&z, &c, &wt);
            let mut cost = |f: &[f64], g: &[f64]| aq.residual(f, g);
            let mut best = (f64::INFINITY, [0f64; 8]);
            for j in std::iter::once(i).chain(second) {
                let mut t = [0f64; 8];
                t[..d].copy_from_slice(&ct.poses[j * d..(j + 1) * d]);
                let cj = fs.climb_pair(Some(bs), ln, &mut t[..d], s.params.resolution, &mut cost);
                if cj < best.0 {
                    best = (cj, t);
                }
            }
            return self.write_pose(&best.1[..d], out);
        }
        let k = s.params.starts.min(self.start_len());
        let best = SEARCH_SCRATCH.with_borrow_mut(|sc| {
            self.noise_scan.scan(&self.start_points, &self.bg_start, &z, &c, &mut sc.dist, &mut sc.lb);
            smallest(&sc.dist, k)
        });
        let mut buf = vec![0.0; (2 * d + 5) * l];
        let (mut best_cost, mut t) = (f64::INFINITY, [0f64; 8]);
        for i in self.distinct_starts(&best) {
            let mut st = [0f64; 8];
            st[..d].copy_from_slice(&self.start_poses[i * d..(i + 1) * d]);
            let cst = fs.refine_affine(bs, &z, &c, &wt, &mut st[..d], &mut buf).0;
            if cst < best_cost {
                (best_cost, t) = (cst, st);
            }
        }
        if s.params.resolution > 0.0 {
            let (f, rest) = buf.split_at_mut(ln);
            let g = &mut rest[..ln];
            fs.snap_by(&mut t[..d], s.params.resolution, |tt| {
                fs.eval_pair(bs, tt, f, None, g, None);
                affine_fit(&z, &c, &wt, f, g).0
            });
        }
        self.write_pose(&t[..d], out);
    }
}

impl RefinedModel {
    /// Estimates a batch (rows of M) through the noisy match whatever the queries' noise: how
    /// the automatic choice scores its candidates.
    pub(crate) fn predict_noisy(&self, queries: &[f32]) -> Result<Vec<f64>> {
        assert!(self.noisy_tree.is_some() || !self.noise_scan.w0.is_empty(), "the noisy match is set (set_noise_match)");
        let (l, m, p) = (self.components(), self.meta.spec.features(), self.meta.space.len());
        let n = queries.len() / m;
        let mut out = vec![0.0; n * p];
        let rows = chunk_rows(n);
        queries.par_chunks(rows * m).zip(out.par_chunks_mut(rows * p)).for_each_init(QueryScratch::default, |s, (q, o)| {
            self.project_binned(q, NoiseWant::Full, s);
            for ((c, o), &nu) in s.y.chunks_exact(l).zip(o.chunks_exact_mut(p)).zip(&s.noise) {
                if c[0].is_nan() {
                    o.fill(f64::NAN);
                } else {
                    self.pose_of_noisy(c, nu, o);
                }
            }
        });
        Ok(out)
    }
}
