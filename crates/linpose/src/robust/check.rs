//! The robust stage's check (see the parent module): the share of a binned query's energy in the
//! pixels its least-squares reconstruction on the binned rows leaves dark ([`dark_share`]). One
//! formula for the stage's own rows ([`Binned`], f32, whose products run in
//! `crate::kernels::recon`) and for the held-out eigenspaces that calibrate its threshold
//! (`calibrate.rs`, f64): both through [`Basis`], which adds the products in f64 in the same order
//! (p over the pixels, each pixel's reconstruction over the rows), so the check a query meets is
//! the statistic its threshold was set by.

use super::tuning;
use crate::kernels::{recon, Level};
use crate::{Error, Result};

/// Binned rows a query is reconstructed on, with the inverse of their Gram matrix.
pub(crate) trait Basis {
    /// K (rows) and M_b (binned pixels).
    fn shape(&self) -> (usize, usize);
    /// K x K, row-major: the inverse of the rows' Gram matrix.
    fn ginv(&self) -> &[f64];
    /// `p = S^T xb` in f64 (K values): each p_j over the pixels in order, those of value 0 left
    /// out.
    fn project(&self, xb: &[f32], p: &mut [f64]);
    /// `recon = S coef` in f64 (M_b values): each pixel over the rows in order.
    fn reconstruct(&self, coef: &[f64], recon: &mut [f64]);
    /// The least-squares coefficients of `xb` on the rows (K values): `coef = G^-1 p`, with
    /// `p` ([`Basis::project`], K values) as scratch.
    fn coefficients(&self, xb: &[f32], p: &mut [f64], coef: &mut [f64]) {
        let (k, _) = self.shape();
        self.project(xb, p);
        let ginv = self.ginv();
        for (a, c) in coef.iter_mut().enumerate() {
            *c = (0..k).map(|b| ginv[a * k + b] * p[b]).sum();
        }
    }
}

/// The stage's binned rows (f32) in the two layouts the check reads, with the inverse of their
/// Gram matrix.
#[derive(Debug, Clone)]
pub(crate) struct Binned {
    /// K, and K padded to whole blocks of [`recon::LANES`].
    k: usize,
    kp: usize,
    /// K x M_b: the binned rows, one after another (the reconstruction reads them so).
    cols: Vec<f32>,
    /// M_b x KP: pixel by pixel, each pixel's K values padded with zeros (the products with a
    /// query and the robust fit read them so).
    small: Vec<f32>,
    /// K x K, row-major: the inverse of the rows' Gram matrix.
    ginv: Vec<f64>,
}

impl Binned {
    /// The K binned rows `cols` (K x M_b, one after another) with their Gram matrix inverted; an
    /// error when they are not independent.
    pub(crate) fn new(cols: Vec<f32>, k: usize) -> Result<Binned> {
        assert!(k > 0 && !cols.is_empty() && cols.len().is_multiple_of(k), "{k} whole rows");
        let mb = cols.len() / k;
        let kp = k.next_multiple_of(recon::LANES);
        let mut small = vec![0f32; mb * kp];
        for (j, c) in cols.chunks_exact(mb).enumerate() {
            for (i, &v) in c.iter().enumerate() {
                small[i * kp + j] = v;
            }
        }
        let mut gram = vec![0f64; k * k];
        for b in small.chunks_exact(kp) {
            for a in 0..k {
                for c in 0..k {
                    gram[a * k + c] += b[a] as f64 * b[c] as f64;
                }
            }
        }
        let ginv = super::search::invert(&gram, k).ok_or_else(|| Error::Numerical("the robust stage's binned rows are not independent".into()))?;
        Ok(Binned { k, kp, cols, small, ginv })
    }

    /// Binned pixel `i`'s K row values.
    pub(crate) fn pixel(&self, i: usize) -> &[f32] {
        &self.small[i * self.kp..i * self.kp + self.k]
    }

    /// Every binned pixel's K row values, in order.
    pub(crate) fn pixels(&self) -> impl Iterator<Item = &[f32]> + '_ {
        self.small.chunks_exact(self.kp).map(|r| &r[..self.k])
    }
}

impl Basis for Binned {
    fn shape(&self) -> (usize, usize) {
        (self.k, self.small.len() / self.kp)
    }
    fn ginv(&self) -> &[f64] {
        &self.ginv
    }
    fn project(&self, xb: &[f32], p: &mut [f64]) {
        recon::project(Level::detect(), &self.small, self.kp, xb, p);
    }
    fn reconstruct(&self, coef: &[f64], recon: &mut [f64]) {
        recon::reconstruct(Level::detect(), &self.cols, coef, recon);
    }
}

/// The share of the binned query `xb`'s energy in the pixels where its least-squares
/// reconstruction on `basis` (the gain free) is under [`tuning::DARK`] of its brightest: what
/// the training views leave dark there and the query does not. A studio view between the
/// training views differs from its reconstruction where the object is, so this share stays near
/// 0; a background, or an occluder over the backdrop, puts energy where the object is not. None
/// for a query of no energy (or of a value not finite). `scratch` holds the reconstruction, p
/// and the coefficients (kept for the next call). Costs 2K M_b multiply-adds in f64.
pub(crate) fn dark_share(basis: &impl Basis, xb: &[f32], scratch: &mut Vec<f64>) -> Option<f64> {
    let (k, mb) = basis.shape();
    assert_eq!(xb.len(), mb, "a binned query of {mb} pixels");
    scratch.resize(mb + 2 * k, 0.0);
    let (recon, rest) = scratch.split_at_mut(mb);
    let (p, coef) = rest.split_at_mut(k);
    basis.coefficients(xb, p, coef);
    basis.reconstruct(coef, recon);
    let dim = tuning::DARK * recon::peak(Level::detect(), recon);
    // The energy and the dark part, each over the pixels in order (those of value 0 add
    // nothing): one pass, the dark part's additions without a branch.
    let (mut energy, mut dark) = (0f64, 0f64);
    for (&r, &v) in recon.iter().zip(xb) {
        if v != 0.0 {
            let e = v as f64 * v as f64;
            energy += e;
            dark += if r < dim { e } else { 0.0 };
        }
    }
    (energy > 0.0 && energy.is_finite()).then_some(dark / energy)
}
