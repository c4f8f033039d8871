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
//!   block, so memory is about M^2 * 4 bytes whatever N: X^T X's lower triangle, copied band by
//!   band into the (zeroed, upper half untouched) matrix that is then factored in place, plus two
//!   blocks of images (1.7 GB in all for 160 x 120 images). With lambda > 0 this
//!   is the same model as the in-memory ridge fit W = X^T (X X^T + lambda I)^{-1} P (the
//!   push-through identity). With lambda = 0 it is the minimum-norm least-squares fit, pixels
//!   that are zero in every image (a black background) weighted 0 ([`crate::normal_equations`]); pixels
//!   that vary together still make X^T X singular, which is refused with the hint to add a ridge.
//!   Centring is not offered on this path.
//!
//! On the least-squares path a reader thread decodes the next block while the current one is
//! added to the normal equations ([`crate::normal_equations`], which says how 8-bit images are
//! summed exactly in integers).
//!
//! Blocks are summed in manifest order, each by the same SYRK kernels, so the
//! result does not depend on the thread count.

use crate::dataset::Dataset;
use crate::image_io::{read_features, ColorMode, ImageSpec};
use crate::manifest::Manifest;
use crate::methods::linear::ridge::RidgeRule;
use crate::methods::linear::{LinearModel, LinearParams, METHOD};
use crate::model::{AnyModel, Estimator, ModelMeta, Settings};
use crate::normal_equations::rows::{accumulate_rows, disk_reader, BLOCK};
use crate::normal_equations::NormalEquations;
use crate::pose::PoseSpace;
use crate::{Error, Result};
use std::time::Instant;

/// The solver a streamed fit used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum SolverPath {
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
pub(crate) fn choose_path(n: usize, m: usize) -> SolverPath {
    if n <= m {
        SolverPath::Gram
    } else {
        SolverPath::LeastSquares
    }
}

/// What a streamed fit did and where its time went.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct StreamStats {
    /// The solver.
    pub path: SolverPath,
    /// Images and features.
    pub n: usize,
    /// Features per image.
    pub m: usize,
    /// Seconds spent reading and decoding images (on the least-squares path on a reader thread,
    /// overlapped with the accumulation).
    pub read_s: f64,
    /// Seconds the accumulation waited for the reader (the part of reading not overlapped).
    pub wait_s: f64,
    /// Seconds accumulating X^T X and X^T P (least-squares path; 0 on the Gram path).
    pub accumulate_s: f64,
    /// Seconds solving: Cholesky factorisation and triangular solves (least squares), or the
    /// whole in-memory fit with its Gram matrix (Gram path).
    pub solve_s: f64,
    /// Whether X^T X was summed in integers (least-squares path, every image 8-bit). False on
    /// the Gram path, whose Gram matrix `linalg::gram_f32` sums in integers by itself when the
    /// features are 8-bit and the CPU has AVX-512 VNNI.
    pub integer_8bit: bool,
}

impl StreamStats {
    /// What the fit did and how long each part took, in one line.
    pub(crate) fn describe(&self) -> String {
        match self.path {
            SolverPath::LeastSquares => format!(
                "{}: reading {:.3} s (overlapped; waited {:.3} s), accumulating X^T X and X^T P {:.3} s ({:.1} GFLOP/s, {}), solving {:.3} s",
                self.path,
                self.read_s,
                self.wait_s,
                self.accumulate_s,
                self.accumulate_flops() / 1e9,
                if self.integer_8bit { "8-bit integer arithmetic" } else { "f64" },
                self.solve_s
            ),
            SolverPath::Gram => format!("{}: reading {:.3} s, Gram matrix and solve {:.3} s", self.path, self.read_s, self.solve_s),
        }
    }

    /// The accumulation's FLOP/s: M^2 N floating-point operations (the M^2 N / 2 multiply-adds of
    /// X^T X's lower triangle, counted once although the 8-bit path does them in integers in two
    /// passes) over `accumulate_s`.
    pub(crate) fn accumulate_flops(&self) -> f64 {
        (self.m as f64).powi(2) * self.n as f64 / self.accumulate_s
    }
}

/// Fits the linear model on every image of `manifest`, reading them from disk in blocks (see the
/// module documentation for the two paths). `progress` is called with images read.
pub(crate) fn fit_linear(manifest: &Manifest, color: ColorMode, params: &LinearParams, progress: &(dyn Fn(u64) + Sync)) -> Result<(LinearModel, StreamStats)> {
    let mut row0 = Vec::new();
    let (w, h) = read_features(&manifest.image_path(0), color, None, "", &mut row0)?;
    let spec = ImageSpec { width: w, height: h, color };
    let (n, m) = (manifest.len(), spec.features());
    match choose_path(n, m) {
        SolverPath::Gram => {
            let t = Instant::now();
            let data = Dataset::load(manifest.clone(), color, progress)?;
            let read_s = t.elapsed().as_secs_f64();
            let t = Instant::now();
            let model = params.fit(&data)?;
            let stats =
                StreamStats { path: SolverPath::Gram, n, m, read_s, wait_s: 0.0, accumulate_s: 0.0, solve_s: t.elapsed().as_secs_f64(), integer_8bit: false };
            Ok((model, stats))
        }
        SolverPath::LeastSquares => {
            // One reader thread decodes the images of a block in order while the rayon pool
            // accumulates the previous block: decoding is a few per cent of the work.
            let context = format!("the size of the data set's first image, {}", manifest.images()[0]);
            fit_least_squares(manifest, spec, params, BLOCK, disk_reader(manifest, spec, context, progress))
        }
    }
}

/// [`crate::Method::fit_streamed`] for the linear model: [`fit_linear`] with parameters from
/// settings by name, which must give a fixed ridge (the leave-one-out and noise rules need the
/// training set in memory).
pub(crate) fn fit_streamed(manifest: &Manifest, color: ColorMode, settings: &Settings, progress: &(dyn Fn(u64) + Sync)) -> Result<(AnyModel, String)> {
    let params = LinearParams::from_settings(settings)?;
    if params.rule() != RidgeRule::Fixed {
        let r = settings.reader(&METHOD)?;
        let (name, value) = r.text("noise-level").map(|v| ("noise-level", v)).unwrap_or(("ridge", r.text("ridge").unwrap_or("auto")));
        return Err(r.error(
            name,
            value,
            "a streamed fit takes a fixed ridge (0 for the exact fit): the leave-one-out and noise rules need the training set in memory",
        ));
    }
    if params.is_centered() {
        return Err(Error::invalid("center", true, "a streamed fit is uncentred (the paper's form)"));
    }
    let (model, stats) = fit_linear(manifest, color, &params, progress)?;
    Ok((AnyModel::new(model), stats.describe()))
}

/// The least-squares path on images delivered by `read(start, block)`, which fills `block`
/// (rows of M features) with images `start..`, `block.len() / M` of them. `read` runs on a thread
/// of its own, one block ahead of the accumulation.
pub(crate) fn fit_least_squares(
    manifest: &Manifest,
    spec: ImageSpec,
    params: &LinearParams,
    block: usize,
    read: impl FnMut(usize, &mut [f32]) -> Result<()> + Send,
) -> Result<(LinearModel, StreamStats)> {
    if params.is_centered() {
        return Err(Error::invalid("center", true, "centring is not offered on the streaming least-squares path (N > M)"));
    }
    let (n, m) = (manifest.len(), spec.features());
    let mut ne = NormalEquations::new(m, manifest.space().encoded_len());
    let timing = accumulate_rows(manifest, m, 0..n, block, read, &mut ne)?;
    let t = Instant::now();
    let exact = ne.integer_8bit();
    let model = solve_model(ne, manifest.space(), manifest.poses(), spec, params.ridge_lambda())?;
    let stats = StreamStats {
        path: SolverPath::LeastSquares,
        n,
        m,
        read_s: timing.read_s,
        wait_s: timing.wait_s,
        accumulate_s: timing.accumulate_s,
        solve_s: t.elapsed().as_secs_f64(),
        integer_8bit: exact,
    };
    Ok((model, stats))
}

/// The linear model that solves `ne` (images of `spec`, poses `train_poses` in `space`) with
/// ridge `lambda`.
pub(crate) fn solve_model(ne: NormalEquations, space: &PoseSpace, train_poses: &[f64], spec: ImageSpec, lambda: f64) -> Result<LinearModel> {
    let k = space.encoded_len();
    let exact = ne.integer_8bit();
    let solved = ne.solve(lambda, space)?;
    let meta = ModelMeta {
        method: METHOD.name.into(),
        spec,
        space: space.clone(),
        train_poses: train_poses.to_vec(),
        settings: serde_json::json!({
            "ridge": lambda,
            "center": false,
            "solver": "least squares (X^T X)",
            "accumulation": if exact { "integer (8-bit pixels)" } else { "f64" },
            "dark_pixels": solved.dark,
        }),
        normalize: None,
        stage_choice: None,
    };
    Ok(LinearModel::new(meta, solved.w, vec![0.0; k], solved.spread))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::levels::{residuals as level_residuals, S8, SCALE_CROSS, SCALE_PAIRS};
    use crate::kernels::syrk::{pack_pairs_u8, pack_quads_u8, padded, SyrkAcc};
    use crate::{Param, PoseSpace};

    fn dataset(n: usize, w: usize, h: usize, f: Vec<f32>) -> Dataset {
        let space = PoseSpace::new(vec![Param::linear("elevation"), Param::circular("azimuth", 360.0)]).unwrap();
        let poses: Vec<f64> = (0..n).flat_map(|i| [30.0 + (i % 7) as f64 * 5.0, (i * 37 % 360) as f64]).collect();
        let names = (0..n).map(|i| format!("{i}.png")).collect();
        let spec = ImageSpec { width: w as u32, height: h as u32, color: ColorMode::Gray };
        Dataset::from_features(Manifest::new(".", space, names, poses).unwrap(), spec, f).unwrap()
    }

    /// Values that are not 8-bit levels (k / 255 by division is not k * (1/255) for every k).
    fn data(n: usize, w: usize, h: usize) -> Dataset {
        let f: Vec<f32> = (0..n * w * h).map(|i| ((i * 7919 + i / 13) % 251) as f32 / 255.0).collect();
        dataset(n, w, h, f)
    }

    /// Pseudo-random 8-bit levels, as image_io makes them from 8-bit images.
    fn data_8bit(n: usize, w: usize, h: usize) -> Dataset {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let f: Vec<f32> = (0..n * w * h)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state >> 56) as f32 * S8
            })
            .collect();
        dataset(n, w, h, f)
    }

    fn stream(d: &Dataset, params: &LinearParams, block: usize) -> (LinearModel, StreamStats) {
        let m = d.n_features();
        fit_least_squares(d.manifest(), d.spec(), params, block, |s, x| {
            x.copy_from_slice(&d.features()[s * m..s * m + x.len()]);
            Ok(())
        })
        .unwrap()
    }

    fn rel_diff(want: &LinearModel, got: &LinearModel) -> f64 {
        let num: f64 = want.weights().iter().zip(got.weights()).map(|(a, b)| (a - b) * (a - b)).sum();
        let den: f64 = want.weights().iter().map(|a| a * a).sum();
        (num / den).sqrt()
    }

    fn in_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
        rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(f)
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
            let (got, stats) = stream(&d, &params, block);
            assert!(!stats.integer_8bit, "these values are not all 8-bit levels");
            let r = rel_diff(&want, &got);
            assert!(r < 1e-9, "block {block}: relative difference {r}");
        }
    }

    /// 8-bit images take the integer path: the in-memory ridge fit on the same f32 features.
    #[test]
    fn integer_8bit_path_matches_in_memory_ridge() {
        let d = data_8bit(1100, 10, 6);
        let params = LinearParams::default().ridge(1e-2);
        let want = params.fit(&d).unwrap();
        for block in [5, 64, 1024, 5000] {
            let (got, stats) = stream(&d, &params, block);
            assert_eq!(stats.integer_8bit, SyrkAcc::new(1).uses_vnni());
            let r = rel_diff(&want, &got);
            assert!(r < 1e-9, "block {block}: relative difference {r}");
        }
    }

    /// The integer sums reproduce X^T X of the f32 features: every level against f64 products.
    #[test]
    fn integer_xtx_is_that_of_the_f32_features() {
        // Two "images" of 256 pixels: every level, and the levels reversed.
        let (n, m) = (2, 256);
        let q: Vec<u8> = (0..256).map(|k| k as u8).chain((0..256).rev().map(|k| k as u8)).collect();
        let f: Vec<f64> = q.iter().map(|&k| (k as f32 * S8) as f64).collect();
        let mut acc = SyrkAcc::new(m);
        let (kcp, kcq) = (1, 1);
        let np = padded(m);
        let (mut a, mut b) = (vec![0; np * kcp], vec![0; np * kcp]);
        pack_pairs_u8(&mut a, &mut b, &q, n, m);
        acc.update_u8(&a, &b, kcp, SCALE_PAIRS);
        let mut v: [Vec<i32>; 4] = std::array::from_fn(|_| vec![0; np * kcq]);
        let [ak, ar, bk, br] = &mut v;
        pack_quads_u8([ak, ar, bk, br], &q, n, m, &level_residuals());
        acc.update_u8_cross(ak, ar, bk, br, kcq, SCALE_CROSS);
        let c = acc.into_lower(1.0);
        let mut worst = 0f64;
        for p in 0..m {
            for j in 0..=p {
                let want = f[p] * f[j] + f[m + p] * f[m + j];
                worst = worst.max((c[j * m + p] - want).abs());
            }
        }
        assert!(worst < 1e-14, "largest difference {worst:e}");
    }

    /// A block that is not 8-bit switches the rest of the fit to f64, keeping what was summed.
    #[test]
    fn switch_from_8bit_to_f64_keeps_the_model() {
        let (n, w, h) = (700, 8, 5);
        let m = w * h;
        let mut f: Vec<f32> = data_8bit(n, w, h).features().to_vec();
        f[500 * m + 3] = 0.123_456_7; // image 500 is not 8-bit
        let d = dataset(n, w, h, f);
        let params = LinearParams::default().ridge(1e-2);
        let want = params.fit(&d).unwrap();
        let (got, stats) = stream(&d, &params, 128);
        assert!(!stats.integer_8bit);
        let r = rel_diff(&want, &got);
        assert!(r < 1e-9, "relative difference {r}");
    }

    /// The same bits on 1, 2 and 8 threads, on both kernels and through the parallel Cholesky.
    #[test]
    fn streamed_models_do_not_depend_on_the_thread_count() {
        for d in [data_8bit(900, 32, 24), data(900, 32, 24)] {
            let params = LinearParams::default().ridge(1e-3);
            let fit = || stream(&d, &params, 256).0.weights().to_vec();
            let one = in_pool(1, fit);
            assert!(one == in_pool(2, fit), "1 and 2 threads differ");
            assert!(one == in_pool(8, fit), "1 and 8 threads differ");
        }
    }

    #[test]
    fn singular_least_squares_is_refused_with_a_hint() {
        let mut d = data(60, 4, 4);
        let m = d.n_features();
        // Two pixels equal in every image (a pixel zero in every image is solved: weight 0).
        let mut f = d.features().to_vec();
        f.chunks_exact_mut(m).for_each(|r| r[3] = r[2]);
        d = Dataset::from_features(d.manifest().clone(), d.spec(), f).unwrap();
        let e = fit_least_squares(d.manifest(), d.spec(), &LinearParams::default(), 16, |s, x| {
            x.copy_from_slice(&d.features()[s * m..s * m + x.len()]);
            Ok(())
        })
        .unwrap_err();
        assert!(e.to_string().contains("singular") || format!("{e:?}").contains("ridge"), "{e}");
    }

    #[test]
    fn a_reader_error_stops_the_fit() {
        let d = data(300, 4, 4);
        let e = fit_least_squares(d.manifest(), d.spec(), &LinearParams::default().ridge(1e-3), 64, |s, _| {
            if s >= 128 {
                Err(Error::invalid("test", s, "unreadable"))
            } else {
                Ok(())
            }
        })
        .unwrap_err();
        assert!(e.to_string().contains("unreadable"), "{e}");
    }
}
