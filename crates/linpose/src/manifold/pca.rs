//! The eigenspace: principal components of the unit-energy training images (Murase & Nayar),
//! computed in f64 from the N x N Gram matrix, which is far smaller than the M x M covariance
//! when N << M (36 or 222 images against 16,384 or 19,200 pixels); with more images than
//! features, from the M x M scatter instead ([`super::scatter`]), the same eigenspace.
//!
//! With x_i scaled to ||x_i|| = 1, the mean image mu subtracted (Xc = X - 1 mu^T, N x M) and
//! Xc Xc^T = V Lambda V^T, the eigenimages are u_l = Xc^T v_l / sqrt(lambda_l) (orthonormal) and the
//! training images' coordinates are g_il = u_l . (x_i - mu) = sqrt(lambda_l) v_il exactly, so the
//! manifold's knots never go through a rounded basis.

use super::scatter::Scatter;
use super::tuning::SCATTER_BLOCK;
use crate::dataset::Dataset;
use crate::linalg::{gram, par, transpose_features};
use crate::{Error, Result};
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, MatMut, Side};
use serde::{Deserialize, Serialize};

/// How many eigenimages to keep.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Dimension {
    /// A fixed number (Murase & Nayar used 8 to 20).
    Fixed(usize),
    /// The fewest whose eigenvalues hold at least this fraction of the total (in (0, 1]).
    Energy(f64),
}

/// A fitted eigenspace.
#[derive(Debug, Clone)]
pub(crate) struct Pca {
    /// The mean unit-energy training image (M).
    pub mean: Vec<f64>,
    /// The eigenimages, one row of M values each (L x M, row-major).
    pub basis: Vec<f64>,
    /// The training images' coordinates (N x L, row-major), in the training set's order.
    pub coords: Vec<f64>,
    /// Every eigenvalue of the centred Gram matrix, largest first (N values; the last is zero up
    /// to rounding, since centring removes one dimension); of the M x M covariance, M values,
    /// when fitted from the scatter (the same nonzero ones).
    pub eigenvalues: Vec<f64>,
}

impl Pca {
    /// Number of eigenimages L.
    pub(crate) fn dim(&self) -> usize {
        self.basis.len() / self.mean.len()
    }

    /// Keeps only the first `l` eigenimages (and coordinates); no-op when `l >= dim()`.
    pub(crate) fn truncate(&mut self, l: usize) {
        let (dim, m) = (self.dim(), self.mean.len());
        if l >= dim {
            return;
        }
        self.basis.truncate(l * m);
        self.coords = self.coords.chunks_exact(dim).flat_map(|c| c[..l].iter().copied()).collect();
    }

    /// The fraction of the training set's energy (about its mean) the kept eigenimages hold.
    pub(crate) fn energy_kept(&self) -> f64 {
        let total: f64 = self.eigenvalues.iter().map(|&l| l.max(0.0)).sum();
        let kept: f64 = self.eigenvalues[..self.dim()].iter().map(|&l| l.max(0.0)).sum();
        if total > 0.0 {
            kept / total
        } else {
            1.0
        }
    }
}

/// Fits the eigenspace of `train`'s images.
///
/// An image of zero energy (all black) cannot be scaled to unit energy and is refused by name.
/// L is capped at N - 1 (what centring leaves) and at the usable rank. The
/// Gram route squares the condition number: an eigenimage u_l = Xc^T v_l / sqrt(lambda_l) leaks
/// about eps * lambda_1 / lambda_l of the others (the rounding of v_l, of order eps * lambda_1,
/// amplified by 1 / lambda_l in u_l . u_k). A component with lambda_l < lambda_1 * eps / eps_f32
/// (about 2e-9 lambda_1) would leak more than the f32 rounding it is served in, so it is dropped;
/// 8-bit images never come near this (their quantisation alone is far above it).
pub(crate) fn fit(train: &Dataset, dim: Dimension) -> Result<Pca> {
    fit_from(train, dim, None)
}

/// [`fit`] with the training images' Gram matrix X X^T given (summed elsewhere, e.g. over
/// shards of pixels): each image's energy is its diagonal entry, and the Gram matrix of the
/// centred unit-energy images follows from it (G~_ij = G_ij / (s_i s_j) with s_i = sqrt(G_ii),
/// then centred: G~_ij - (r_i + r_j) + t, r the row means of G~, t their mean), so only the
/// eigenimages read the pixels again.
pub(crate) fn fit_with_gram(train: &Dataset, dim: Dimension, gram: Mat<f64>) -> Result<Pca> {
    assert!(gram.nrows() == train.len() && gram.ncols() == train.len(), "a Gram matrix of the training set's size");
    fit_from(train, dim, Some(gram))
}

/// The Gram matrix of the centred unit-energy images from the raw one G: with s_i = sqrt(G_ii),
/// G~_ij = G_ij / (s_i s_j), r_i the mean of row i of G~ and t the mean of r,
/// (x~_i - mu) . (x~_j - mu) = G~_ij - (r_i + r_j) + t (symmetric in every bit).
fn centred_unit_gram(g: &Mat<f64>) -> Mat<f64> {
    let n = g.nrows();
    let s: Vec<f64> = (0..n).map(|i| g[(i, i)].max(0.0).sqrt()).collect();
    let unit = Mat::from_fn(n, n, |i, j| g[(i, j)] / (s[i] * s[j]));
    let r: Vec<f64> = (0..n).map(|i| (0..n).map(|j| unit[(i, j)]).sum::<f64>() / n as f64).collect();
    let t = r.iter().sum::<f64>() / n as f64;
    Mat::from_fn(n, n, |i, j| unit[(i, j)] - (r[i] + r[j]) + t)
}

/// How many eigenimages `dim` keeps of the eigenvalues `eigenvalues` (largest first) of `n`
/// images: capped at the usable rank (see [`fit`]) and at N - 1; None when none is usable.
pub(crate) fn kept(eigenvalues: &[f64], n: usize, dim: Dimension) -> Option<usize> {
    let tol = eigenvalues[0] * (f64::EPSILON / f32::EPSILON as f64);
    let rank = eigenvalues.iter().take_while(|&&l| l > tol).count().min(n - 1);
    if rank == 0 {
        return None;
    }
    Some(match dim {
        Dimension::Fixed(k) => k.min(rank),
        Dimension::Energy(t) => {
            let total: f64 = eigenvalues.iter().map(|&v| v.max(0.0)).sum();
            let mut acc = 0.0;
            let mut l = rank;
            for (i, &v) in eigenvalues[..rank].iter().enumerate() {
                acc += v;
                // A relative slack of a few eps so that T = 1 stops at the rank, not past it.
                if acc >= t * total * (1.0 - 4.0 * n as f64 * f64::EPSILON) {
                    l = i + 1;
                    break;
                }
            }
            l
        }
    })
}

/// The error of training images (of `manifest`) that are all the same once scaled to unit energy.
pub(crate) fn all_alike(manifest: &crate::Manifest) -> Error {
    Error::Dataset {
        path: manifest.root().to_path_buf(),
        message: "the training images are all the same once scaled to unit energy: there is no eigenspace to build".into(),
    }
}

/// The error of an all-black training image `i`.
pub(crate) fn black(manifest: &crate::Manifest, i: usize) -> Error {
    Error::Dataset {
        path: manifest.image_path(i),
        message: "the image is all black (zero energy), so it cannot be scaled to unit energy for the eigenspace; remove it from the training set".into(),
    }
}

/// The eigenspace of more images than features through their M x M scatter
/// ([`super::scatter`]), summed over blocks of [`SCATTER_BLOCK`] images.
fn fit_by_scatter(train: &Dataset, dim: Dimension) -> Result<Pca> {
    let (n, m) = (train.len(), train.n_features());
    let mut scatter = Scatter::new(m);
    for rows in train.features().chunks(SCATTER_BLOCK * m) {
        scatter.add(rows, |i| black(train.manifest(), i))?;
    }
    let eigen = scatter.eigen(dim)?.ok_or_else(|| all_alike(train.manifest()))?;
    let l = eigen.dim();
    let mut coords = vec![0.0; n * l];
    for (b, (rows, out)) in train.features().chunks(SCATTER_BLOCK * m).zip(coords.chunks_mut(SCATTER_BLOCK * l)).enumerate() {
        eigen.project(rows, out, |i| black(train.manifest(), b * SCATTER_BLOCK + i))?;
    }
    Ok(eigen.into_pca(coords))
}

fn fit_from(train: &Dataset, dim: Dimension, raw: Option<Mat<f64>>) -> Result<Pca> {
    let (n, m) = (train.len(), train.n_features());
    if n < 2 {
        return Err(Error::Dataset {
            path: train.manifest().root().to_path_buf(),
            message: format!("the eigenspace needs at least 2 training images, got {n}"),
        });
    }
    if raw.is_none() && n > m {
        return fit_by_scatter(train, dim);
    }
    let mut xt = transpose_features(train.features(), n, m, None);
    let mut mean = vec![0.0; m];
    for j in 0..n {
        let col = xt.col_mut(j);
        let norm = match &raw {
            Some(g) => g[(j, j)].max(0.0).sqrt(),
            None => col.iter().map(|v| v * v).sum::<f64>().sqrt(),
        };
        // Features are finite (Dataset checks), so the norm is finite and zero only when black.
        if norm <= 0.0 {
            return Err(black(train.manifest(), j));
        }
        col.iter_mut().for_each(|v| *v /= norm);
        mean.iter_mut().zip(col.iter()).for_each(|(u, &v)| *u += v);
    }
    mean.iter_mut().for_each(|u| *u /= n as f64);
    for j in 0..n {
        let col = xt.col_mut(j);
        col.iter_mut().zip(&mean).for_each(|(v, &u)| *v -= u);
    }
    let g = match raw {
        Some(g) => centred_unit_gram(&g),
        None => gram(xt.as_ref()),
    };
    let evd = g.self_adjoint_eigen(Side::Lower).map_err(|e| Error::Numerical(format!("eigendecomposition of the Gram matrix: {e:?}")))?;
    // faer sorts eigenvalues in nondecreasing order: reverse to largest first.
    let order: Vec<usize> = (0..n).rev().collect();
    let eigenvalues: Vec<f64> = order.iter().map(|&i| evd.S()[i]).collect();
    let l = kept(&eigenvalues, n, dim).ok_or_else(|| all_alike(train.manifest()))?;
    // V_L scaled by 1/sqrt(lambda) (for the basis) and the coordinates sqrt(lambda) v.
    let u_evd = evd.U();
    let mut v_scaled = Mat::<f64>::zeros(n, l);
    let mut coords = vec![0.0; n * l];
    for (c, &i) in order[..l].iter().enumerate() {
        let lam = eigenvalues[c];
        // A fixed sign (largest entry of v positive) so refits give the same basis.
        let big = (0..n).max_by(|&a, &b| u_evd[(a, i)].abs().total_cmp(&u_evd[(b, i)].abs())).expect("n >= 2");
        let sign = if u_evd[(big, i)] < 0.0 { -1.0 } else { 1.0 };
        for r in 0..n {
            let v = sign * u_evd[(r, i)];
            v_scaled[(r, c)] = v / lam.sqrt();
            coords[r * l + c] = v * lam.sqrt();
        }
    }
    // U = Xc^T V Lambda^{-1/2}, M x L column-major: the L x M row-major basis itself, written
    // in place (no M x L temporary to fault in and copy).
    let mut basis = vec![0.0; l * m];
    matmul(MatMut::from_column_major_slice_mut(&mut basis, m, l), Accum::Replace, xt.as_ref(), v_scaled.as_ref(), 1.0, par());
    Ok(Pca { mean, basis, coords, eigenvalues })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image_io::{ColorMode, ImageSpec};
    use crate::{Manifest, Param, PoseSpace};

    /// N smooth images of M pixels that vary with an angle.
    fn data(n: usize, m: usize) -> Dataset {
        data_over(n, m, 360.0)
    }

    /// [`data`] with the angle over `span` degrees (less than a turn: no pair of equal
    /// eigenvalues, so that the eigenimages are defined up to sign).
    fn data_over(n: usize, m: usize, span: f64) -> Dataset {
        let space = PoseSpace::new(vec![Param::circular("azimuth", 360.0)]).unwrap();
        let poses: Vec<f64> = (0..n).map(|i| i as f64 * span / n as f64).collect();
        let images = (0..n).map(|i| format!("{i}.png")).collect();
        let mut f = Vec::with_capacity(n * m);
        for &a in &poses {
            let t = a.to_radians();
            for p in 0..m {
                let s = p as f64 / m as f64 * std::f64::consts::TAU;
                f.push((0.5 + 0.3 * (s + t).sin() + 0.1 * (3.0 * s - 2.0 * t).cos() + 0.05 * (7.0 * s + t).sin()) as f32);
            }
        }
        let spec = ImageSpec { width: m as u32, height: 1, color: ColorMode::Gray };
        Dataset::from_features(Manifest::new(".", space, images, poses).unwrap(), spec, f).unwrap()
    }

    fn unit_rows(d: &Dataset) -> Vec<Vec<f64>> {
        (0..d.len())
            .map(|i| {
                let r: Vec<f64> = d.row(i).iter().map(|&v| v as f64).collect();
                let n = r.iter().map(|v| v * v).sum::<f64>().sqrt();
                r.iter().map(|v| v / n).collect()
            })
            .collect()
    }

    /// Back-projection mu + sum_l g_il u_l rebuilds each training image up to the energy of the
    /// discarded components: sum_i ||x_i - x^_i||^2 = sum_{l > L} lambda_l, an identity of the
    /// eigendecomposition, up to rounding of order M * N * eps (the Gram matrix's sums).
    #[test]
    fn back_projection_rebuilds_training_images_within_discarded_energy() {
        let (n, m) = (24, 300);
        let d = data(n, m);
        let x = unit_rows(&d);
        for l in [2, 3, 5, 8] {
            let pca = fit(&d, Dimension::Fixed(l)).unwrap();
            assert!(pca.dim() <= l);
            let lk = pca.dim();
            let mut total = 0.0;
            for (i, xi) in x.iter().enumerate() {
                let mut rec = pca.mean.clone();
                for c in 0..lk {
                    let g = pca.coords[i * lk + c];
                    rec.iter_mut().zip(&pca.basis[c * m..(c + 1) * m]).for_each(|(r, &u)| *r += g * u);
                }
                total += rec.iter().zip(xi).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
            }
            let discarded: f64 = pca.eigenvalues[lk..].iter().map(|&v| v.max(0.0)).sum();
            let tol = 64.0 * (m * n) as f64 * f64::EPSILON;
            assert!((total - discarded).abs() <= tol, "L={l}: residual {total:e}, discarded energy {discarded:e}");
        }
    }

    #[test]
    fn basis_is_orthonormal_and_coords_are_projections() {
        let (n, m) = (18, 200);
        let d = data(n, m);
        let pca = fit(&d, Dimension::Fixed(20)).unwrap();
        let l = pca.dim();
        assert!(l < n);
        // Leakage between eigenimages is bounded by the f32 epsilon by construction (see `fit`).
        let tol = 4.0 * f32::EPSILON as f64;
        for a in 0..l {
            for b in 0..l {
                let dot: f64 = pca.basis[a * m..(a + 1) * m].iter().zip(&pca.basis[b * m..(b + 1) * m]).map(|(x, y)| x * y).sum();
                assert!((dot - if a == b { 1.0 } else { 0.0 }).abs() < tol, "u{a}.u{b} = {dot}");
            }
        }
        let x = unit_rows(&d);
        for i in 0..n {
            for c in 0..l {
                let g: f64 = pca.basis[c * m..(c + 1) * m].iter().zip(x[i].iter().zip(&pca.mean)).map(|(u, (x, mu))| u * (x - mu)).sum();
                assert!((g - pca.coords[i * l + c]).abs() < tol, "image {i} coordinate {c}");
            }
        }
    }

    #[test]
    fn energy_threshold_picks_the_fewest_components() {
        let d = data(24, 300);
        let all = fit(&d, Dimension::Fixed(23)).unwrap();
        let total: f64 = all.eigenvalues.iter().map(|v| v.max(0.0)).sum();
        for t in [0.5, 0.9, 0.99, 1.0] {
            let p = fit(&d, Dimension::Energy(t)).unwrap();
            let l = p.dim();
            let kept: f64 = all.eigenvalues[..l].iter().sum();
            assert!(kept >= t * total * (1.0 - 1e-12), "T={t}");
            if l > 1 {
                let less: f64 = all.eigenvalues[..l - 1].iter().sum();
                assert!(less < t * total, "T={t}: {} components would do", l - 1);
            }
        }
    }

    /// More images than features: the scatter route gives the Gram route's eigenspace (the
    /// eigenvalues, the eigenimages with their signs, the coordinates), up to rounding.
    #[test]
    fn scatter_route_matches_the_gram_route() {
        let (n, m) = (90, 40);
        let d = data_over(n, m, 200.0);
        for dim in [Dimension::Fixed(6), Dimension::Energy(0.999)] {
            let by_scatter = fit(&d, dim).unwrap();
            let by_gram = fit_with_gram(&d, dim, crate::linalg::gram_of(&d, None)).unwrap();
            let l = by_gram.dim();
            assert_eq!(by_scatter.dim(), l, "{dim:?}");
            assert_eq!(by_scatter.eigenvalues.len(), m);
            let top = by_gram.eigenvalues[0];
            for c in 0..l {
                assert!((by_scatter.eigenvalues[c] - by_gram.eigenvalues[c]).abs() < 1e-10 * top, "eigenvalue {c}");
            }
            let close = |a: &[f64], b: &[f64], what: &str| {
                for (i, (x, y)) in a.iter().zip(b).enumerate() {
                    assert!((x - y).abs() < 1e-7, "{what} {i}: {x} against {y}");
                }
            };
            close(&by_scatter.mean, &by_gram.mean, "mean");
            close(&by_scatter.basis, &by_gram.basis, "basis");
            close(&by_scatter.coords, &by_gram.coords, "coordinate");
        }
    }

    #[test]
    fn all_black_image_is_named_on_either_route() {
        // More images than features: the scatter route names it alike.
        let d = data(60, 20);
        let mut f = d.features().to_vec();
        f[41 * 20..42 * 20].fill(0.0);
        let d = Dataset::from_features(d.manifest().clone(), d.spec(), f).unwrap();
        let e = fit(&d, Dimension::Fixed(3)).unwrap_err().to_string();
        assert!(e.contains("41.png") && e.contains("all black"), "{e}");
    }

    #[test]
    fn all_black_image_is_named() {
        let d = data(6, 50);
        let mut f = d.features().to_vec();
        f[3 * 50..4 * 50].fill(0.0);
        let d = Dataset::from_features(d.manifest().clone(), d.spec(), f).unwrap();
        let e = fit(&d, Dimension::Fixed(3)).unwrap_err().to_string();
        assert!(e.contains("3.png") && e.contains("all black"), "{e}");
    }
}
