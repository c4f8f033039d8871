//! How much of each binned pixel the stage's eigenspace cannot explain in a studio view of the
//! object: the tolerance of the repair's keep rule (`repair.rs`).
//!
//! Sixteen eigenimages reconstruct an object's fine detail (print, edges, a toy car's interior)
//! only roughly, so a fit's residual there is large on the object's own pixels, not only on
//! clutter; a single threshold then takes the detail for an outlier and the repair replaces it
//! by the reconstruction's blur, which the method reads as a neighbouring pose. The stage knows
//! where that happens from its own training views: each one's residual off its least-squares
//! reconstruction on the binned rows, per unit of its gain. A fit's tolerance at a bin is the
//! larger of its threshold and [`tuning::DETAIL`] times the largest such residual there among
//! the training views nearest the fit in the eigenspace (P + 1 for P pose parameters, in the
//! fit's gain). Where the training views leave nothing unexplained (the backdrop, a plain
//! surface) the threshold stands, so the background and an occluder there are still found.
//!
//! The residuals are computed when the stage is made, from the training views it keeps for the
//! answer's check (`verify.rs`): N x M_b numbers more in memory, none more in the model file; a
//! stage without its views (an older file, a many-object model's) keeps the single threshold.

use super::check::{Basis, Binned};
use super::tuning;

/// Per training view: its coordinates in the stage's eigenspace per unit gain (the
/// least-squares coefficients on the binned rows after the first, over the first), and its
/// binned residual off that reconstruction per unit gain (absolute values).
#[derive(Debug, Clone)]
pub(crate) struct Detail {
    /// N x (K - 1).
    coords: Vec<f32>,
    /// N x M_b.
    residual: Vec<f32>,
    /// Training views the tolerance takes at a fit: P + 1.
    near: usize,
    /// M_b.
    mb: usize,
}

impl Detail {
    /// The detail of the binned training views `views` (N x M_b) on `binned`, whose poses have
    /// `p` parameters, in their order. A view the rows cannot put in a positive gain is never
    /// nearest a fit and widens nothing. None when the rows are the mean image alone.
    pub(crate) fn of(views: &[f32], binned: &Binned, p: usize) -> Option<Detail> {
        let (k, mb) = binned.shape();
        if k < 2 {
            return None;
        }
        let (mut coords, mut residual) = (Vec::new(), Vec::new());
        let (mut proj, mut coef, mut recon) = (vec![0f64; k], vec![0f64; k], vec![0f64; mb]);
        for v in views.chunks_exact(mb) {
            binned.coefficients(v, &mut proj, &mut coef);
            let gain = coef[0];
            if !(gain > 0.0 && gain.is_finite()) {
                // Never nearest, nothing to widen: the indices stay the views'.
                coords.extend(std::iter::repeat_n(f32::INFINITY, k - 1));
                residual.extend(std::iter::repeat_n(0f32, mb));
                continue;
            }
            binned.reconstruct(&coef, &mut recon);
            coords.extend(coef[1..].iter().map(|&c| (c / gain) as f32));
            residual.extend(v.iter().zip(&recon).map(|(&x, &r)| ((f64::from(x) - r).abs() / gain) as f32));
        }
        Some(Detail { coords, residual, near: p + 1, mb })
    }

    /// The training view nearest a fit of coefficients `coef` (the first its gain) in the
    /// eigenspace, per unit gain; None when the gain is not positive.
    pub(crate) fn nearest(&self, coef: &[f64]) -> Option<usize> {
        self.nearest_n(coef, 1).map(|v| v[0].1)
    }

    /// The `n` training views nearest a fit of coefficients `coef` (squared distance, index),
    /// in no order; None when the gain is not positive or there are no views.
    fn nearest_n(&self, coef: &[f64], n: usize) -> Option<Vec<(f32, usize)>> {
        let gain = coef[0];
        if !(gain > 0.0 && gain.is_finite()) {
            return None;
        }
        let d = coef.len() - 1;
        let y: Vec<f32> = coef[1..].iter().map(|&c| (c / gain) as f32).collect();
        let mut near: Vec<(f32, usize)> =
            self.coords.chunks_exact(d).enumerate().map(|(i, c)| (c.iter().zip(&y).map(|(a, b)| (a - b) * (a - b)).sum(), i)).collect();
        let n = n.min(near.len());
        if n == 0 {
            return None;
        }
        near.select_nth_unstable_by(n - 1, |a, b| a.0.total_cmp(&b.0));
        near.truncate(n);
        Some(near)
    }

    /// The tolerance at each binned pixel of `support` (others keep `theta`) of a fit of
    /// coefficients `coef` (the first its gain) and threshold `theta`; None when the gain is not
    /// positive.
    pub(crate) fn tolerance(&self, coef: &[f64], theta: f32, support: &[u32]) -> Option<Vec<f32>> {
        let near = self.nearest_n(coef, self.near)?;
        let mb = self.mb;
        let gain = coef[0];
        let scale = tuning::DETAIL * gain as f32;
        let mut tol = vec![theta; mb];
        for &i in support {
            let i = i as usize;
            let most = near.iter().map(|&(_, v)| self.residual[v * mb + i]).fold(0f32, f32::max);
            tol[i] = theta.max(scale * most);
        }
        Some(tol)
    }
}
