//! The robust stage's threshold from the training set itself, by the stage's check (the share of
//! a view's energy where its reconstruction is dark, `super::check::dark_share`, in f64 as the
//! stage's check adds it), binned as the stage
//! bins: the training views against the eigenspace of all of them (in-sample: no step from a
//! training view, an underestimate for a query between them), and views left out against the
//! eigenspace of the others (a step from the nearest, twice a query's half step: an
//! overestimate, by far where a silhouette sweeps). Their geometric mean stands for a query half
//! a step from its nearest training view; a query beyond a multiple of it
//! ([`super::tuning::THRESHOLD_FACTOR`]) holds something the training views never showed.

use super::check::{dark_share, Basis};
use super::tuning;
use crate::binning::Binning;
use crate::dataset::Dataset;
use crate::{Error, Result};
use faer::{Mat, Side};

/// The threshold's base for `train`'s views binned by `binning`: the geometric mean of the
/// largest dark share of the training views against the eigenspace of all of them (no step from
/// a training view) and against the eigenspace of all but themselves (a step and more), for a
/// query half a step from its nearest training view.
pub(super) fn threshold(train: &Dataset, binning: Binning) -> Result<f64> {
    let n = train.len();
    if n < 3 {
        return Err(Error::invalid(
            "robust",
            format!("{n} training views"),
            "the robust stage calibrates on views left out of the others: at least 3 are needed",
        ));
    }
    let mb = binning.spec().features();
    let mut views = vec![0f32; n * mb];
    let mut acc = Vec::new();
    for (i, v) in views.chunks_exact_mut(mb).enumerate() {
        binning.apply(train.row(i), v, &mut acc);
    }
    let unit: Vec<Vec<f64>> = views
        .chunks_exact(mb)
        .map(|v| {
            let norm = v.iter().map(|&x| x as f64 * x as f64).sum::<f64>().sqrt();
            v.iter().map(|&x| x as f64 / norm.max(f64::MIN_POSITIVE)).collect()
        })
        .collect();
    let all: Vec<&Vec<f64>> = unit.iter().collect();
    let inside = worst(&all, &all, mb)?;
    let step = n.div_ceil(tuning::LEFT_OUT).max(1);
    let mut outside: f64 = 0.0;
    for i in (0..n).step_by(step) {
        let others: Vec<&Vec<f64>> = unit.iter().enumerate().filter(|&(j, _)| j != i).map(|(_, v)| v).collect();
        outside = outside.max(worst(&others, &[&unit[i]], mb)?);
    }
    Ok((inside * outside).sqrt())
}

/// The largest dark share of the views `test` against the eigenspace of the views `fit`.
fn worst(fit: &[&Vec<f64>], test: &[&Vec<f64>], mb: usize) -> Result<f64> {
    let rows = half_rows(fit, mb)?;
    let k = rows.len() / mb;
    let mut gram = vec![0f64; k * k];
    for a in 0..k {
        for c in 0..k {
            gram[a * k + c] = dot(&rows[a * mb..(a + 1) * mb], &rows[c * mb..(c + 1) * mb]);
        }
    }
    let ginv = super::search::invert(&gram, k).ok_or_else(|| Error::Numerical("the robust stage's held-out eigenspace is singular".into()))?;
    let held = Held { rows, k, mb, ginv };
    let (mut most, mut scratch) = (0f64, Vec::new());
    for v in test {
        let xb: Vec<f32> = v.iter().map(|&x| x as f32).collect();
        most = most.max(dark_share(&held, &xb, &mut scratch).unwrap_or(0.0));
    }
    Ok(most)
}

/// A held-out eigenspace's binned rows (f64, K x M_b one after another) for the check's
/// statistic, its products added in the check's order.
struct Held {
    rows: Vec<f64>,
    k: usize,
    mb: usize,
    ginv: Vec<f64>,
}

impl Basis for Held {
    fn shape(&self) -> (usize, usize) {
        (self.k, self.mb)
    }
    fn ginv(&self) -> &[f64] {
        &self.ginv
    }
    fn project(&self, xb: &[f32], p: &mut [f64]) {
        p.fill(0.0);
        for (i, &v) in xb.iter().enumerate() {
            if v != 0.0 {
                p.iter_mut().enumerate().for_each(|(j, a)| *a += self.rows[j * self.mb + i] * v as f64);
            }
        }
    }
    fn reconstruct(&self, coef: &[f64], recon: &mut [f64]) {
        for (i, r) in recon.iter_mut().enumerate() {
            *r = coef.iter().enumerate().map(|(j, &c)| self.rows[j * self.mb + i] * c).sum();
        }
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The mean of the unit-energy views `fit` and their leading eigenimages (at most
/// [`tuning::COMPONENTS`], and only those of a non-negligible eigenvalue), rows of `mb`.
fn half_rows(fit: &[&Vec<f64>], mb: usize) -> Result<Vec<f64>> {
    let n = fit.len();
    let mut mean = vec![0f64; mb];
    for v in fit {
        mean.iter_mut().zip(v.iter()).for_each(|(m, &x)| *m += x / n as f64);
    }
    let centred: Vec<Vec<f64>> = fit.iter().map(|v| v.iter().zip(&mean).map(|(x, m)| x - m).collect()).collect();
    let g = Mat::from_fn(n, n, |i, j| dot(&centred[i], &centred[j]));
    let evd =
        g.self_adjoint_eigen(Side::Lower).map_err(|e| Error::Numerical(format!("eigendecomposition of the robust stage's held-out Gram matrix: {e:?}")))?;
    let top = evd.S()[n - 1].max(0.0);
    let mut rows = mean;
    for j in (0..n).rev().take(tuning::COMPONENTS.min(n - 1)) {
        let lambda = evd.S()[j];
        if !(lambda > top * 1e-9) {
            break;
        }
        let s = 1.0 / lambda.sqrt();
        let mut u = vec![0f64; mb];
        for (i, c) in centred.iter().enumerate() {
            let w = evd.U()[(i, j)] * s;
            u.iter_mut().zip(c).for_each(|(a, &x)| *a += w * x);
        }
        rows.extend(u);
    }
    Ok(rows)
}
