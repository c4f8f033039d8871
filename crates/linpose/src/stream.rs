//! Training the linear model on more images than memory holds: the images are read from disk in
//! blocks and only what the solver needs is accumulated.
//!
//! Which path is picked by the sizes (N images of M features):
//! - N <= M, [`SolverPath::Gram`]: the paper's minimum-norm fit through the N x N Gram matrix,
//!   exactly the in-memory fit. The N images are held as f32 (N <= M, so at most M^2 * 4 bytes:
//!   1.5 GB for 160 x 120 images) because G pairs every image with every other.
//! - N > M, [`SolverPath::LeastSquares`]: the minimum-norm exact fit no longer exists (X X^T is
//!   singular once N > M); the model is least squares, with ridge lambda,
//!   W = (X^T X + lambda I)^{-1} X^T P. X^T X (M x M) and X^T P (M x K) are accumulated block by
//!   block, so memory is M^2 * 8 bytes (twice that while factoring) whatever N. With lambda > 0
//!   this is the same model as the in-memory ridge fit W = X^T (X X^T + lambda I)^{-1} P (the
//!   push-through identity). Images whose pixels never vary (a black background) make X^T X
//!   singular, so this path needs lambda > 0 in practice; it refuses a singular system and says so.
//!   Centring is not offered on this path.
//!
//! Blocks are summed in manifest order, each by the kernel of [`crate::kernels::syrk`], so the
//! result does not depend on the thread count.

use crate::dataset::Dataset;
use crate::image_io::{read_features, ColorMode, ImageSpec};
use crate::kernels::syrk::{pack_columns, padded, SyrkAcc};
use crate::linear::{LinearModel, LinearParams};
use crate::manifest::Manifest;
use crate::model::{Estimator, ModelMeta};
use crate::{Error, Result};
use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
use rayon::prelude::*;

/// The solver a streamed fit used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SolverPath {
    /// N <= M: the minimum-norm fit through the N x N Gram matrix (the paper's model).
    Gram,
    /// N > M: least squares / ridge through X^T X (M x M).
    LeastSquares,
}

impl std::fmt::Display for SolverPath {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            SolverPath::Gram => "minimum-norm fit through the N x N Gram matrix (N <= M)",
            SolverPath::LeastSquares => "least squares / ridge through X^T X, M x M, accumulated block by block (N > M)",
        })
    }
}

/// The path [`fit_linear`] takes for `n` images of `m` features.
pub fn choose_path(n: usize, m: usize) -> SolverPath {
    if n <= m {
        SolverPath::Gram
    } else {
        SolverPath::LeastSquares
    }
}

/// Images decoded per block on the least-squares path.
pub const BLOCK: usize = 512;

/// Fits the linear model on every image of `manifest`, reading them from disk in blocks (see the
/// module documentation for the two paths). `progress` is called with images read.
pub fn fit_linear(manifest: &Manifest, color: ColorMode, params: &LinearParams, progress: &(dyn Fn(u64) + Sync)) -> Result<(LinearModel, SolverPath)> {
    let mut row0 = Vec::new();
    let (w, h) = read_features(&manifest.image_path(0), color, None, "", &mut row0)?;
    let spec = ImageSpec { width: w, height: h, color };
    let (n, m) = (manifest.len(), spec.features());
    match choose_path(n, m) {
        SolverPath::Gram => {
            let data = Dataset::load(manifest.clone(), color, progress)?;
            Ok((params.fit(&data)?, SolverPath::Gram))
        }
        SolverPath::LeastSquares => {
            let context = format!("the size of the data set's first image, {}", manifest.images()[0]);
            let read = |start: usize, block: &mut [f32]| -> Result<()> {
                block.par_chunks_mut(m).enumerate().try_for_each(|(k, slot)| {
                    let mut row = Vec::with_capacity(m);
                    read_features(&manifest.image_path(start + k), color, Some((w, h)), &context, &mut row)?;
                    slot.copy_from_slice(&row);
                    progress(1);
                    Ok(())
                })
            };
            let model = fit_least_squares(manifest, spec, params, BLOCK, read)?;
            Ok((model, SolverPath::LeastSquares))
        }
    }
}

/// The least-squares path on images delivered by `read(start, block)`, which fills `block`
/// (rows of M features) with images `start..`, `block.len() / M` of them.
pub fn fit_least_squares(
    manifest: &Manifest,
    spec: ImageSpec,
    params: &LinearParams,
    block: usize,
    read: impl Fn(usize, &mut [f32]) -> Result<()>,
) -> Result<LinearModel> {
    if params.is_centered() {
        return Err(Error::invalid("center", true, "centring is not offered on the streaming least-squares path (N > M)"));
    }
    let lambda = params.ridge_lambda();
    let space = manifest.space();
    let (n, m, k) = (manifest.len(), spec.features(), space.encoded_len());
    let mut acc = SyrkAcc::new(m);
    let mut xtp = vec![0f64; m * k]; // X^T P, row-major M x K
    let mut buf = vec![0f32; block.min(n) * m];
    let mut panel = vec![0f64; padded(m) * crate::kernels::syrk::KC];
    let mut p = vec![0f64; block * k];
    let mut start = 0;
    while start < n {
        let b = block.min(n - start);
        let x = &mut buf[..b * m];
        read(start, x)?;
        if let Some(i) = x.iter().position(|v| !v.is_finite()) {
            return Err(Error::Dataset { path: manifest.image_path(start + i / m), message: "image has a non-finite value".into() });
        }
        for i in 0..b {
            space.encode(manifest.pose(start + i), &mut p[i * k..(i + 1) * k]);
        }
        // X^T X over the block, in panels of KC images, in order.
        let mut r0 = 0;
        while r0 < b {
            let kc = crate::kernels::syrk::KC.min(b - r0);
            let pn = &mut panel[..padded(m) * kc];
            pack_columns(pn, &x[r0 * m..(r0 + kc) * m], kc, m, None);
            acc.update(pn, kc);
            r0 += kc;
        }
        // X^T P: pixel chunks in parallel, images in order.
        xtp.par_chunks_mut(1024 * k).enumerate().for_each(|(c, out)| {
            let p0 = c * 1024;
            for i in 0..b {
                let row = &x[i * m + p0..i * m + p0 + out.len() / k];
                let pi = &p[i * k..(i + 1) * k];
                for (o, &v) in out.chunks_exact_mut(k).zip(row) {
                    o.iter_mut().zip(pi).for_each(|(o, &q)| *o += v as f64 * q);
                }
            }
        });
        start += b;
    }
    let mut a = acc.into_matrix();
    for i in 0..m {
        a[(i, i)] += lambda;
    }
    let scale = (0..m).map(|i| a[(i, i)]).fold(0.0, f64::max);
    let llt = a.llt(Side::Lower).map_err(|e| singular(lambda, &format!("{e:?}")))?;
    drop(a);
    let l = llt.L();
    let dmin = (0..m).map(|i| l[(i, i)] * l[(i, i)]).fold(f64::INFINITY, f64::min);
    if !(dmin > scale * m as f64 * 1e-13) {
        return Err(singular(lambda, &format!("smallest pivot {dmin:.3e} against a largest diagonal of {scale:.3e}")));
    }
    let rhs = Mat::from_fn(m, k, |i, j| xtp[i * k + j]);
    let wm = llt.solve(rhs.as_ref());
    let mut w = vec![0.0; k * m];
    for j in 0..k {
        for i in 0..m {
            w[j * m + i] = wm[(i, j)];
        }
    }
    let meta = ModelMeta {
        method: crate::linear::METHOD.into(),
        spec,
        space: space.clone(),
        train_poses: manifest.poses().to_vec(),
        settings: serde_json::json!({ "ridge": lambda, "center": false, "solver": "least squares (X^T X)" }),
    };
    Ok(LinearModel::new(meta, w, vec![0.0; k]))
}

fn singular(lambda: f64, detail: &str) -> Error {
    Error::SingularGram {
        detail: format!("X^T X + {lambda} I is singular ({detail})"),
        hint: "with more images than pixels the model is least squares, and pixels that never vary (a constant background) leave X^T X singular; use ridge regularisation (--ridge, e.g. 1e-3)".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Param, PoseSpace};

    fn data(n: usize, w: usize, h: usize) -> Dataset {
        let space = PoseSpace::new(vec![Param::linear("elevation"), Param::circular("azimuth", 360.0)]).unwrap();
        let poses: Vec<f64> = (0..n).flat_map(|i| [30.0 + (i % 7) as f64 * 5.0, (i * 37 % 360) as f64]).collect();
        let names = (0..n).map(|i| format!("{i}.png")).collect();
        let f: Vec<f32> = (0..n * w * h).map(|i| ((i * 7919 + i / 13) % 251) as f32 / 255.0).collect();
        let spec = ImageSpec { width: w as u32, height: h as u32, color: ColorMode::Gray };
        Dataset::from_features(Manifest::new(".", space, names, poses).unwrap(), spec, f).unwrap()
    }

    /// With ridge, least squares through X^T X is the in-memory ridge fit through X X^T.
    #[test]
    fn least_squares_path_matches_in_memory_ridge() {
        let d = data(150, 8, 5);
        let m = d.n_features();
        assert_eq!(choose_path(d.len(), m), SolverPath::LeastSquares);
        let params = LinearParams::default().ridge(1e-2);
        let want = params.fit(&d).unwrap();
        for block in [7, 64, 1000] {
            let got = fit_least_squares(d.manifest(), d.spec(), &params, block, |s, x| {
                x.copy_from_slice(&d.features()[s * m..s * m + x.len()]);
                Ok(())
            })
            .unwrap();
            let num: f64 = want.weights().iter().zip(got.weights()).map(|(a, b)| (a - b) * (a - b)).sum();
            let den: f64 = want.weights().iter().map(|a| a * a).sum();
            assert!((num / den).sqrt() < 1e-9, "block {block}: relative difference {}", (num / den).sqrt());
        }
    }

    #[test]
    fn singular_least_squares_is_refused_with_a_hint() {
        let mut d = data(60, 4, 4);
        let m = d.n_features();
        // A pixel that is zero in every image.
        let mut f = d.features().to_vec();
        f.chunks_exact_mut(m).for_each(|r| r[3] = 0.0);
        d = Dataset::from_features(d.manifest().clone(), d.spec(), f).unwrap();
        let e = fit_least_squares(d.manifest(), d.spec(), &LinearParams::default(), 16, |s, x| {
            x.copy_from_slice(&d.features()[s * m..s * m + x.len()]);
            Ok(())
        })
        .unwrap_err();
        assert!(e.to_string().contains("singular") || format!("{e:?}").contains("ridge"), "{e}");
    }
}
