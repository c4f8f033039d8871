//! The eigenspace of more images than features (N > M) from the M x M scatter of the
//! unit-energy images instead of their N x N Gram matrix ([`super::pca`]): the same eigenimages,
//! eigenvalues and coordinates, for N M^2 + M^3 operations and about 8 M^2 bytes beside a block
//! of images rather than N^2 M + N^3 operations and 44 N^2 bytes (20,160 images of 32 x 24: a
//! 20160 x 20160 eigendecomposition, many minutes and 14 GiB, against 768 x 768, under a second).
//!
//! With x~_i = x_i / ||x_i||, c a shift (the first block's mean, so that the sums do not cancel:
//! the images' mean is far larger than their spread about it), S = sum_i (x~_i - c)(x~_i - c)^T
//! and d = mean(x~_i) - c, the covariance is C = S - N d d^T; its eigenvectors of largest
//! eigenvalue are the eigenimages u_l, its eigenvalues those of the centred Gram matrix (the
//! nonzero ones; min(N, M) values in all), and a training image's coordinates are
//! g_il = u_l . (x~_i - mu). The sums need the images once and the coordinates once more, both
//! block by block ([`Scatter::add`], [`Eigenimages::project`]), so a training set read from disk
//! is read twice and never held whole (the eigenspace's streamed fit). Each component's sign is
//! the Gram route's (its coordinate of largest magnitude positive), so the two routes give the
//! same model up to rounding.

use super::pca::{Dimension, Pca};
use crate::linalg::par;
use crate::{Error, Result};
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, MatRef, Side};
use rayon::prelude::*;

/// The scatter of unit-energy images, summed block by block.
#[derive(Debug)]
pub(crate) struct Scatter {
    m: usize,
    n: usize,
    /// The shift c (the first block's mean), empty before the first block.
    shift: Vec<f64>,
    /// sum (x~ - c)(x~ - c)^T, M x M (both halves).
    s: Mat<f64>,
    /// sum (x~ - c).
    sum: Vec<f64>,
}

impl Scatter {
    /// No images yet, of `m` features.
    pub(crate) fn new(m: usize) -> Scatter {
        Scatter { m, n: 0, shift: Vec::new(), s: Mat::zeros(m, m), sum: vec![0.0; m] }
    }

    /// Adds the images `rows` (row-major, M features each). An all-black image cannot be scaled
    /// to unit energy: `black(i)` (i its index among all the images added) is the error.
    pub(crate) fn add(&mut self, rows: &[f32], black: impl Fn(usize) -> Error) -> Result<()> {
        let m = self.m;
        let b = rows.len() / m;
        if b == 0 {
            return Ok(());
        }
        let mut unit = unit_rows(rows, m).map_err(|i| black(self.n + i))?;
        if self.shift.is_empty() {
            self.shift = (0..m).map(|j| (0..b).map(|i| unit[(i, j)]).sum::<f64>() / b as f64).collect();
        }
        for i in 0..b {
            for (j, &c) in self.shift.iter().enumerate() {
                unit[(i, j)] -= c;
                self.sum[j] += unit[(i, j)];
            }
        }
        matmul(self.s.as_mut(), Accum::Add, unit.transpose(), unit.as_ref(), 1.0, par());
        self.n += b;
        Ok(())
    }

    /// The eigenimages kept by `dim` (capped at N - 1 and at the usable rank, as
    /// [`super::pca::fit`] caps them); None when the images are all the same once scaled to unit
    /// energy (no eigenspace).
    pub(crate) fn eigen(self, dim: Dimension) -> Result<Option<Eigenimages>> {
        let (m, n) = (self.m, self.n as f64);
        let d: Vec<f64> = self.sum.iter().map(|&v| v / n).collect();
        let mean: Vec<f64> = self.shift.iter().zip(&d).map(|(&c, &v)| c + v).collect();
        let c = Mat::from_fn(m, m, |i, j| self.s[(i, j)] - n * d[i] * d[j]);
        let evd = c.self_adjoint_eigen(Side::Lower).map_err(|e| Error::Numerical(format!("eigendecomposition of the scatter matrix: {e:?}")))?;
        // faer sorts eigenvalues in nondecreasing order: reverse to largest first.
        let eigenvalues: Vec<f64> = (0..m).rev().map(|i| evd.S()[i]).collect();
        let Some(l) = super::pca::kept(&eigenvalues, self.n, dim) else { return Ok(None) };
        let u = evd.U();
        let basis: Vec<f64> = (0..l).flat_map(|c| (0..m).map(move |r| u[(r, m - 1 - c)])).collect();
        let mean_proj = basis.chunks_exact(m).map(|b| b.iter().zip(&mean).map(|(a, b)| a * b).sum()).collect();
        Ok(Some(Eigenimages { m, mean, basis, mean_proj, eigenvalues }))
    }
}

/// The eigenimages from a [`Scatter`], before the training images' coordinates are known.
#[derive(Debug, Clone)]
pub(crate) struct Eigenimages {
    m: usize,
    mean: Vec<f64>,
    /// L x M, row-major.
    basis: Vec<f64>,
    /// u_l . mu.
    mean_proj: Vec<f64>,
    eigenvalues: Vec<f64>,
}

impl Eigenimages {
    /// Eigenimages kept, L.
    pub(crate) fn dim(&self) -> usize {
        self.basis.len() / self.m
    }

    /// The coordinates u_l . (x~ - mu) of the images `rows` (row-major, M each) into `out` (L
    /// each); an all-black image is refused as [`Scatter::add`] refuses it.
    pub(crate) fn project(&self, rows: &[f32], out: &mut [f64], black: impl Fn(usize) -> Error) -> Result<()> {
        let (m, l) = (self.m, self.dim());
        let b = rows.len() / m;
        let unit = unit_rows(rows, m).map_err(black)?;
        let basis = MatRef::from_row_major_slice(&self.basis, l, m);
        let mut g = Mat::<f64>::zeros(b, l);
        matmul(g.as_mut(), Accum::Replace, unit.as_ref(), basis.transpose(), 1.0, par());
        for (i, o) in out[..b * l].chunks_exact_mut(l).enumerate() {
            for (c, v) in o.iter_mut().enumerate() {
                *v = g[(i, c)] - self.mean_proj[c];
            }
        }
        Ok(())
    }

    /// The eigenspace, with the training images' coordinates `coords` (N x L, in the training
    /// set's order, from [`Eigenimages::project`]): each component's sign turned so that its
    /// coordinate of largest magnitude is positive (the Gram route's sign).
    pub(crate) fn into_pca(self, mut coords: Vec<f64>) -> Pca {
        let (m, l) = (self.m, self.dim());
        let mut basis = self.basis;
        for c in 0..l {
            let big = coords.iter().skip(c).step_by(l).copied().max_by(|a, b| a.abs().total_cmp(&b.abs())).unwrap_or(0.0);
            if big < 0.0 {
                coords.iter_mut().skip(c).step_by(l).for_each(|v| *v = -*v);
                basis[c * m..(c + 1) * m].iter_mut().for_each(|v| *v = -*v);
            }
        }
        Pca { mean: self.mean, basis, coords, eigenvalues: self.eigenvalues }
    }
}

/// The images `rows` scaled to unit energy, in f64 (b x M); the index of an all-black one.
fn unit_rows(rows: &[f32], m: usize) -> std::result::Result<Mat<f64>, usize> {
    let b = rows.len() / m;
    let norms: Vec<f64> = rows.par_chunks_exact(m).map(|r| r.iter().map(|&v| v as f64 * v as f64).sum::<f64>().sqrt()).collect();
    // Features are finite (the readers check), so a norm is zero only for a black image.
    if let Some(i) = norms.iter().position(|&s| s <= 0.0) {
        return Err(i);
    }
    Ok(Mat::from_fn(b, m, |i, j| rows[i * m + j] as f64 / norms[i]))
}
