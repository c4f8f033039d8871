//! Okatani & Deguchi's linear model (MVA 2000): each encoded pose parameter is a linear function
//! of the pixels, p_j = w_j^T x (Eq. 1), fitted as the minimum-norm exact solution
//! W = X^T (X X^T)^{-1} P (Eq. 4, images as rows) through the N x N Gram matrix, trained in f64.
//!
//! Beyond the paper and off by default: ridge (G + lambda I), and mean-centring (an intercept).
//! Served in f32: the weights are stored as f32 and a query costs M*K multiply-adds.
//!
//! ```
//! use linpose::image_io::{ColorMode, ImageSpec};
//! use linpose::{Dataset, Estimator, LinearParams, Param, PoseModel, PoseSpace};
//!
//! // An elevation and a turntable angle: 12 views of 8 x 8 pixels.
//! let space = PoseSpace::new(vec![Param::linear("elevation"), Param::circular("azimuth", 360.0)])?;
//! let poses: Vec<f64> = (0..12).flat_map(|k| [30.0 + 10.0 * (k % 3) as f64, 90.0 * (k / 3) as f64]).collect();
//! // A blob circling with the azimuth, higher with the elevation.
//! let blob = |e: f64, a: f64| (0..64).map(move |i| {
//!     let (x, y) = ((i % 8) as f64 - 3.5 - 2.5 * a.to_radians().cos(), (i / 8) as f64 - 3.5 - 2.5 * a.to_radians().sin() + e / 20.0);
//!     (-(x * x + y * y) / 3.0).exp() as f32
//! });
//! let pixels: Vec<f32> = poses.chunks(2).flat_map(|p| blob(p[0], p[1])).collect();
//! let data = Dataset::new(ImageSpec { width: 8, height: 8, color: ColorMode::Gray }, pixels, space, poses)?;
//!
//! // The paper's minimum-norm exact fit reproduces every training pose (served in f32: to
//! // f32 rounding).
//! let model = LinearParams::default().fit(&data)?;
//! let pose = model.predict(data.row(7))?;
//! assert!(data.space().error_deg(data.pose(7), &pose) < 0.01);
//! // W as K x M coefficient images (elevation, cos azimuth, sin azimuth): the paper's Fig. 2.
//! assert_eq!(model.weights().len(), 3 * 64);
//! # Ok::<(), linpose::Error>(())
//! ```

mod footprint;
mod partial;
pub mod ridge;
pub(crate) mod stream;
mod tuning;

use crate::dataset::Dataset;
use crate::kernels::{combine::{combine_rows, Centred}, dot_u8::dots, AlignedF32, Level};
use crate::model::split;
use crate::linalg::{dot_f32, gram_of, mat_from_rows, mean_row};
use crate::dataset::Rows;
use crate::confidence::{pair_confidence, Estimate};
use crate::methods::linear::ridge::{loo_curve, RidgeRule};
use crate::pixel_noise::estimate_noise_sigma;
use crate::pose::PoseSpace;
use crate::model::{batch_len, AnyModel, Estimator, Method, MethodOption, ModelMeta, Origin, PoseModel, Settings, Storage, Tensor, TensorSet};
use crate::{Error, Result};
use faer::linalg::solvers::{DenseSolveCore, Llt, Solve};
use faer::{Mat, Side};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use tuning::LOO_SAMPLE;

/// The linear model in the method registry.
pub(crate) static METHOD: Method = Method {
    name: "linear",
    summary: "Okatani & Deguchi's linear model: each pose parameter a linear function of the pixels, the minimum-norm exact fit through the Gram matrix",
    origin: Origin::Paper,
    storage: "MK",
    options: &[
        MethodOption {
            name: "ridge",
            value: "L|auto",
            help: "ridge lambda added to the Gram matrix (default 0, the paper's exact minimum-norm fit), or auto: the lambda with the smallest exact leave-one-out error",
        },
        MethodOption {
            name: "noise-level",
            value: "A|auto",
            help: "train for query noise of +-A (a fraction of full brightness): ridge lambda = N A^2/3, the optimum for independent pixel noise; auto estimates the noise of the training images",
        },
        MethodOption { name: "center", value: "", help: "subtract the mean image and pose first (an intercept; the paper has none)" },
    ],
    params: |s| Ok(LinearParams::from_settings(s)?.into()),
    load: |meta, t| Ok(AnyModel::new(LinearModel::from_parts(meta, t)?)),
    footprint: |s| Ok(std::sync::Arc::new(LinearParams::from_settings(s)?)),
    stream: Some(crate::model::Stream { fit: stream::fit_streamed, passes: |_, _| 1 }),
    partial: Some(|s| Ok(std::sync::Arc::new(LinearParams::from_settings(s)?))),
};

/// Parameters of the linear model. The default is exactly the paper's: no ridge, no centring.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct LinearParams {
    ridge: f64,
    center: bool,
    rule: RidgeRule,
}

impl LinearParams {
    /// Ridge lambda added to the Gram matrix's diagonal (0 = the paper's exact fit).
    pub fn ridge(mut self, lambda: f64) -> Self {
        self.ridge = lambda;
        self
    }

    /// How lambda is chosen: the fixed [`ridge`](Self::ridge) value (default), exact
    /// leave-one-out, or the noise-optimal N s^2 (see [`ridge`]).
    pub fn ridge_rule(mut self, rule: RidgeRule) -> Self {
        self.rule = rule;
        self
    }

    /// Subtract the mean image and mean pose first (equivalent to an intercept).
    pub fn center(mut self, yes: bool) -> Self {
        self.center = yes;
        self
    }

    /// The ridge lambda.
    pub fn ridge_lambda(&self) -> f64 {
        self.ridge
    }

    /// Whether the model is mean-centred.
    pub fn is_centered(&self) -> bool {
        self.center
    }

    /// How lambda is chosen.
    pub fn rule(&self) -> RidgeRule {
        self.rule
    }

    /// The parameters from settings by name ([`METHOD`]'s options).
    pub(crate) fn from_settings(settings: &Settings) -> Result<Self> {
        let r = settings.reader(&METHOD)?;
        r.exclusive("noise-level", "ridge")?;
        let p = LinearParams::default().center(r.switch("center")?);
        let number = |name: &str, v: &str| v.parse::<f64>().map_err(|_| r.error(name, v, "expected a number or 'auto'"));
        Ok(match (r.text("noise-level"), r.text("ridge")) {
            (Some("auto"), _) => p.ridge_rule(RidgeRule::NoiseAuto),
            (Some(v), _) => p.ridge_rule(RidgeRule::Noise(number("noise-level", v)?)),
            (None, Some("auto")) => p.ridge_rule(RidgeRule::Loo),
            (None, Some(v)) => p.ridge(number("ridge", v)?),
            (None, None) => p,
        })
    }

    fn validate(&self) -> Result<()> {
        if !(self.ridge.is_finite() && self.ridge >= 0.0) {
            return Err(Error::invalid("ridge", self.ridge, "must be a finite number >= 0"));
        }
        if let RidgeRule::Noise(a) = self.rule {
            if !(a.is_finite() && (0.0..=1.0).contains(&a)) {
                return Err(Error::invalid("noise level", a, "must be a fraction of full brightness in [0, 1] (0.05 = +-5%)"));
            }
        }
        Ok(())
    }
}

/// The training set's encoded poses P (N x K, row-major).
pub(crate) fn encoded_poses(train: &Dataset) -> Vec<f64> {
    let space = train.space();
    let k = space.encoded_len();
    let mut p = vec![0.0; train.len() * k];
    for i in 0..train.len() {
        space.encode(train.pose(i), &mut p[i * k..(i + 1) * k]);
    }
    p
}

/// The Gram system of a training set: what every Gram-based fit needs.
pub(crate) struct GramSystem<'a> {
    /// X (N x M, row-major): the training rows as the data set holds them (f32 features or
    /// their 8-bit values), borrowed (no f64 copy is made).
    pub x: Rows<'a>,
    /// Features per image M.
    pub m: usize,
    /// G = X X^T (N x N).
    pub g: Mat<f64>,
    /// Encoded poses (N x K), centred when asked.
    pub p: Mat<f64>,
    /// Mean image (centring only).
    pub mean_x: Option<Vec<f64>>,
    /// Mean encoded pose (centring only).
    pub mean_p: Option<Vec<f64>>,
}

impl<'a> GramSystem<'a> {
    /// Builds the system, refusing exact duplicate images ([`check_duplicates`]).
    pub(crate) fn new(train: &'a Dataset, center: bool) -> Result<Self> {
        Self::with_gram(train, center, None)
    }

    /// [`Self::new`] with G given (summed elsewhere, e.g. over shards of pixels: centred about
    /// the mean image when `center`); computed from `train` when None.
    pub(crate) fn with_gram(train: &'a Dataset, center: bool, given: Option<Mat<f64>>) -> Result<Self> {
        let (n, m) = (train.len(), train.n_features());
        let k = train.space().encoded_len();
        let mut p = encoded_poses(train);
        let (mean_x, mean_p) = if center {
            let mx = mean_row(train.features(), n, m);
            let mut mp = vec![0.0; k];
            for row in p.chunks_exact(k) {
                mp.iter_mut().zip(row).for_each(|(a, &b)| *a += b / n as f64);
            }
            for row in p.chunks_exact_mut(k) {
                row.iter_mut().zip(&mp).for_each(|(a, &b)| *a -= b);
            }
            (Some(mx), Some(mp))
        } else {
            (None, None)
        };
        let g = match given {
            Some(g) => {
                assert!(g.nrows() == n && g.ncols() == n, "a given Gram matrix of the training set's size");
                g
            }
            None => gram_of(train, mean_x.as_deref()),
        };
        check_duplicates(train, &g)?;
        Ok(GramSystem { x: train.rows(), m, g, p: mat_from_rows(&p, n, k), mean_x, mean_p })
    }

    /// The Cholesky factor of [`Self::system`] with `lambda`, refusing a numerically singular
    /// system: what the fit solves (D = factor.solve(P)) and the leave-one-out spread reuses.
    pub(crate) fn factor(&self, lambda: f64, train: &Dataset) -> Result<Llt<f64>> {
        let n = self.g.nrows();
        let a = self.system(lambda);
        let scale = (0..n).map(|i| a[(i, i)]).fold(0.0, f64::max);
        let llt = a.llt(Side::Lower).map_err(|e| singular(train, &format!("{e:?}"), lambda))?;
        // A pivot tiny against the largest diagonal entry means G is singular up to rounding:
        // the solution would be noise amplified by 1/pivot.
        let l = llt.L();
        let (imin, dmin) = (0..n).map(|i| (i, l[(i, i)] * l[(i, i)])).min_by(|a, b| a.1.total_cmp(&b.1)).expect("n >= 1");
        if !(dmin > scale * n as f64 * 1e-13) {
            return Err(singular(train, &format!("pivot {imin} is {dmin:.3e}, against a largest diagonal of {scale:.3e}"), lambda));
        }
        Ok(llt)
    }

    /// The matrix [`Self::factor`] factors: G + lambda I, and for a centred system c 1 1^T added.
    fn system(&self, lambda: f64) -> Mat<f64> {
        let n = self.g.nrows();
        let mut a = self.g.clone();
        for i in 0..n {
            a[(i, i)] += lambda;
        }
        if self.mean_x.is_some() {
            // Centred rows sum to zero, so G always has the ones vector in its null space. P is
            // centred too (orthogonal to it) and X^T 1 = 0, so adding c 1 1^T changes nothing in
            // W = X^T D while making the system definite: D = (G + c 1 1^T)^-1 P = G^+ P.
            let c = (0..n).map(|i| a[(i, i)]).fold(0.0, f64::max) / n as f64;
            for j in 0..n {
                for i in 0..n {
                    a[(i, j)] += c;
                }
            }
        }
        a
    }

    /// The spread of each circular parameter's (cos, sin) pair's exact leave-one-out residuals
    /// (the RMS per component) of the fit `d` = `factor.solve(P)` ([`Self::factor`]), over at
    /// most [`LOO_SAMPLE`] evenly spaced training rows: e_i = D_i / [(G + lambda I)^-1]_ii. What
    /// the confidence of a query's pair is measured against ([`crate::confidence`]). For a
    /// centred model the inverse is that of G + c 1 1^T, an approximation.
    pub(crate) fn pair_spread(&self, factor: &Llt<f64>, d: &Mat<f64>, space: &PoseSpace) -> Vec<f64> {
        let n = self.g.nrows();
        let rows: Vec<usize> = (0..n.min(LOO_SAMPLE)).map(|j| j * n / n.min(LOO_SAMPLE)).collect();
        let unit = Mat::from_fn(n, rows.len(), |i, j| if i == rows[j] { 1.0 } else { 0.0 });
        let inv = factor.solve(unit.as_ref());
        let residual = |i: usize, j: usize, col: usize| d[(i, col)] / inv[(i, j)];
        space
            .pair_columns()
            .into_iter()
            .map(|c| {
                let ss: f64 = rows.iter().enumerate().map(|(j, &i)| residual(i, j, c).powi(2) + residual(i, j, c + 1).powi(2)).sum();
                (ss / (2 * rows.len()).max(1) as f64).sqrt()
            })
            .collect()
    }

    /// W^T = D^T X (K x M), row-major: each row is one coefficient image w_j (paper Fig. 2).
    /// Computed from the rows (features or their 8-bit values: the same bits) in pixel chunks
    /// (in parallel), each summed over the images in order, so the result does not depend on
    /// the thread count.
    pub(crate) fn weights(&self, d: &Mat<f64>) -> Vec<f64> {
        let (n, m, k) = (self.g.nrows(), self.m, d.ncols());
        // The chunk's K sums and its row within 32 KiB, in the core's L1 cache (this machine's
        // is 48 KiB). At K = 3 (the rendered duck's fit, 222 x 19,200) chunks of 1024 and 512
        // values timed alike and 2048 about 3% slower (medians of 200 fits, alternated builds);
        // a hardware size, not tuned further.
        let chunk = ((4096 / (k + 1)) & !63).max(64);
        let d_rows: Vec<f64> = (0..n * k).map(|t| d[(t / k, t % k)]).collect();
        let level = Level::detect();
        let parts: Vec<Vec<f64>> = (0..m.div_ceil(chunk))
            .into_par_iter()
            .map(|c| {
                let (p0, p1) = (c * chunk, ((c + 1) * chunk).min(m));
                let len = p1 - p0;
                let (mut w, mut row) = (vec![0.0; k * len], vec![0.0; len]);
                combine_rows(level, Centred { x: self.x, mean: self.mean_x.as_deref(), m }, p0, &d_rows, k, &mut w, &mut row);
                w
            })
            .collect();
        let mut out = vec![0.0; k * m];
        for (c, w) in parts.iter().enumerate() {
            let (p0, len) = (c * chunk, w.len() / k);
            for j in 0..k {
                out[j * m + p0..j * m + p0 + len].copy_from_slice(&w[j * len..(j + 1) * len]);
            }
        }
        out
    }

    /// Exact leave-one-out residuals of the fit with `lambda` (docs/method.md): for sample i,
    /// e_i = [(G + lambda I)^{-1} P]_i / [(G + lambda I)^{-1}]_ii, returned as the left-out
    /// predictions P_i - e_i (N x K, row-major, uncentred).
    pub(crate) fn loo_predictions(&self, lambda: f64, train: &Dataset) -> Result<Vec<f64>> {
        let n = self.g.nrows();
        let mut a = self.g.clone();
        for i in 0..n {
            a[(i, i)] += lambda;
        }
        let llt = a.llt(Side::Lower).map_err(|e| singular(train, &format!("{e:?}"), lambda))?;
        let inv = llt.inverse();
        let d = llt.solve(self.p.as_ref());
        let k = self.p.ncols();
        let mut out = vec![0.0; n * k];
        for i in 0..n {
            for j in 0..k {
                let e = d[(i, j)] / inv[(i, i)];
                out[i * k + j] = self.p[(i, j)] - e + self.mean_p.as_ref().map_or(0.0, |mp| mp[j]);
            }
        }
        Ok(out)
    }
}

fn singular(train: &Dataset, detail: &str, lambda: f64) -> Error {
    let hint = if lambda > 0.0 {
        format!("even with ridge {lambda}; the images may be (near) constant or identical - try a larger --ridge")
    } else {
        "the training images are linearly dependent, e.g. the same image under two poses, in which case the pose cannot be told from the image at all; remove duplicates or use ridge regularisation (--ridge, e.g. 1e-6)".to_string()
    };
    let _ = train;
    Error::SingularGram { detail: detail.to_string(), hint }
}

/// The training set plus, for each view, the mean of its noisy versions: uniform noise of +-a
/// clipped to [0, 1] is not zero-mean near black and white (a black background brightens by
/// a/4 on average), so a query's expected value is E[clip(x + u)] = (x + a)^2 / 4a for x < a,
/// x for a <= x <= 1 - a, and 1 - (1 - x + a)^2 / 4a above. Fitting both makes the model answer
/// the mean noisy view like the clean one; ridge N a^2 / 3 then handles the zero-mean part.
fn with_expected_noisy_views(train: &Dataset, a: f64) -> Result<Dataset> {
    let m = train.n_features();
    let expect = |x: f32| expected_clipped(x as f64, a) as f32;
    let mut images = train.manifest().images().to_vec();
    let mut poses = train.poses().to_vec();
    let mut features = train.features().to_vec();
    for i in 0..train.len() {
        let row: Vec<f32> = train.row(i).iter().map(|&x| expect(x)).collect();
        if row != train.row(i) {
            images.push(format!("{} (mean noisy view)", train.manifest().images()[i]));
            poses.extend_from_slice(train.pose(i));
            features.extend_from_slice(&row);
        }
    }
    let manifest = crate::manifest::Manifest::new(train.manifest().root(), train.space().clone(), images, poses)?;
    debug_assert_eq!(features.len(), manifest.len() * m);
    Dataset::from_features(manifest, train.spec(), features)
}

/// E[clip(x + u, 0, 1)] for u uniform in [-a, a] (0 < a <= 1/2 keeps the two branches apart;
/// larger a is handled by the same formulas clamped to [0, 1]).
pub(crate) fn expected_clipped(x: f64, a: f64) -> f64 {
    let v = if x < a {
        (x + a).powi(2) / (4.0 * a)
    } else if x > 1.0 - a {
        1.0 - (1.0 - x + a).powi(2) / (4.0 * a)
    } else {
        x
    };
    v.clamp(0.0, 1.0)
}

/// Exact duplicate images under different poses make the problem impossible in principle (the
/// paper, section 2): name the two images. Found through the Gram matrix G (centred or not):
/// identical rows i, j have ||x_i - x_j||^2 = G_ii + G_jj - 2 G_ij = 0, which G's rounding
/// (each entry a sum of M products, within 4 M eps of the sum of the two diagonals) keeps
/// below 4 M eps (G_ii + G_jj); only pairs that close are compared in full. The pair reported
/// is the first in order (the later image least, then the earlier).
fn check_duplicates(train: &Dataset, g: &Mat<f64>) -> Result<()> {
    let n = g.nrows();
    let tol = 4.0 * train.n_features() as f64 * f64::EPSILON;
    let same = |i: usize, j: usize| match train.rows() {
        Rows::U8(x) => {
            let m = train.n_features();
            x[i * m..(i + 1) * m] == x[j * m..(j + 1) * m]
        }
        Rows::F32(_) => train.row(i) == train.row(j),
    };
    for i in 1..n {
        for j in 0..i {
            let s = g[(i, i)] + g[(j, j)];
            if s - 2.0 * g[(j, i)] <= tol * s && same(i, j) {
                let names = train.manifest().images();
                let same_pose = train.space().same_pose(train.pose(i), train.pose(j), 1e-9);
                return Err(Error::SingularGram {
                    detail: format!("images '{}' and '{}' are identical", names[j], names[i]),
                    hint: if same_pose {
                        "the same view is listed twice; remove one".into()
                    } else {
                        format!(
                            "they carry different poses ({:?} and {:?}), so no method can tell these poses apart from the image; remove one, or use ridge regularisation (--ridge) to fit a compromise",
                            train.pose(j),
                            train.pose(i)
                        )
                    },
                });
            }
        }
    }
    Ok(())
}

impl Estimator for LinearParams {
    type Model = LinearModel;

    fn method(&self) -> &'static Method {
        &METHOD
    }

    /// The exact leave-one-out estimates in closed form (docs/method.md, one factorisation), for
    /// uncentred models: at ridge 0 the paper's model's LOO error.
    fn leave_one_out(&self, train: &Dataset) -> Option<Result<Vec<f64>>> {
        (!self.center).then(|| leave_one_out(self, train))
    }

    fn fit(&self, train: &Dataset) -> Result<LinearModel> {
        self.fit_with_gram(train, None)
    }
}

impl LinearParams {
    /// [`Estimator::fit`] with the training set's Gram matrix given (see
    /// [`GramSystem::with_gram`]); the noise rule with a level above 0, which fits an augmented
    /// set, computes its own.
    pub(crate) fn fit_with_gram(&self, train: &Dataset, gram: Option<Mat<f64>>) -> Result<LinearModel> {
        self.validate()?;
        let augmented;
        let (fit_set, gram) = match self.rule {
            RidgeRule::Noise(a) if a > 0.0 => {
                augmented = with_expected_noisy_views(train, a)?;
                (&augmented, None)
            }
            _ => (train, gram),
        };
        let sys = GramSystem::with_gram(fit_set, self.center, gram)?;
        let n = train.len() as f64;
        let (lambda, loo) = match self.rule {
            RidgeRule::Fixed => (self.ridge, None),
            RidgeRule::Loo => {
                let c = loo_curve(&sys, train)?;
                (c.lambda, Some(c.loo_mean_deg))
            }
            RidgeRule::Noise(a) => (n * a * a / 3.0, None),
            RidgeRule::NoiseAuto => {
                let spec = train.spec();
                let (w, h, c) = (spec.width as usize, spec.height as usize, spec.color.channels());
                // One plane per channel (RGB features are interleaved), averaged.
                let s2 = (0..c)
                    .map(|ch| {
                        let plane: Vec<f32> = train.features().iter().skip(ch).step_by(c).copied().collect();
                        estimate_noise_sigma(&plane, w, h).powi(2)
                    })
                    .sum::<f64>()
                    / c as f64;
                (n * s2, None)
            }
        };
        let factor = sys.factor(lambda, fit_set)?;
        let d = factor.solve(sys.p.as_ref());
        let w = sys.weights(&d);
        let spread = sys.pair_spread(&factor, &d, train.space());
        let k = train.space().encoded_len();
        // Centred: p = W^T (x - mu_x) + mu_p, so the bias is mu_p - W^T mu_x.
        let bias = match (&sys.mean_x, &sys.mean_p) {
            (Some(mx), Some(mp)) => {
                let m = train.n_features();
                (0..k).map(|j| mp[j] - w[j * m..(j + 1) * m].iter().zip(mx).map(|(a, b)| a * b).sum::<f64>()).collect()
            }
            _ => vec![0.0; k],
        };
        let meta = ModelMeta {
            method: METHOD.name.into(),
            spec: train.spec(),
            space: train.space().clone(),
            train_poses: train.poses().to_vec(),
            settings: serde_json::json!({ "params": self, "lambda": lambda, "loo_mean_deg": loo }),
            normalize: None,
            stage_choice: None,
        };
        Ok(LinearModel::new(meta, w, bias, spread))
    }
}

/// A fitted linear model: K coefficient images of M features, and a bias (zero unless centred).
#[derive(Debug, Clone)]
pub struct LinearModel {
    meta: ModelMeta,
    w64: Vec<f64>,
    w32: Vec<f32>,
    /// The f32 weights / 255, for 8-bit queries, 64-byte aligned (the kernel's AVX-512 loads of
    /// misaligned rows straddle cache lines: about 1.5x slower on COIL-20's 72-image batches).
    w8: AlignedF32,
    bias: Vec<f64>,
    /// Each circular parameter's pair's leave-one-out spread ([`GramSystem::pair_spread`]).
    spread: Vec<f64>,
}

impl LinearModel {
    /// The model of weights `w64` and `bias`, whose circular pairs' residuals spread by `spread`
    /// (recorded in the settings as `pair_spread`).
    pub(crate) fn new(mut meta: ModelMeta, w64: Vec<f64>, bias: Vec<f64>, spread: Vec<f64>) -> Self {
        if let Some(o) = meta.settings.as_object_mut() {
            o.insert("pair_spread".into(), serde_json::json!(spread));
        }
        let w32 = w64.iter().map(|&v| v as f32).collect();
        Self::with_u8(meta, w64, w32, bias, spread)
    }

    /// The model with its 8-bit serving weights, made from the f32 weights the model file holds,
    /// so a fitted model and the same model read back from its file give the same bits.
    fn with_u8(meta: ModelMeta, w64: Vec<f64>, w32: Vec<f32>, bias: Vec<f64>, spread: Vec<f64>) -> Self {
        let w8: Vec<f32> = w32.iter().map(|&v| (v as f64 / 255.0) as f32).collect();
        LinearModel { meta, w64, w32, w8: AlignedF32::new(&w8), bias, spread }
    }

    /// Each circular parameter's (cos, sin) pair's leave-one-out spread (RMS per component),
    /// against which a query's pair length sets the confidence.
    pub fn pair_spread(&self) -> &[f64] {
        &self.spread
    }

    /// The coefficient vectors w_j, one row of M values per encoded parameter (paper Fig. 2), in
    /// the f64 precision they were trained in.
    pub fn weights(&self) -> &[f64] {
        &self.w64
    }

    /// The bias per encoded parameter (zero for the paper's model).
    pub fn bias(&self) -> &[f64] {
        &self.bias
    }

    /// The encoded estimate W^T x + b in f64 (no decoding): what the identities are tested on.
    pub fn predict_encoded_f64(&self, x: &[f32]) -> Vec<f64> {
        let m = self.meta.spec.features();
        self.w64.chunks_exact(m).zip(&self.bias).map(|(w, b)| w.iter().zip(x).map(|(&a, &v)| a * v as f64).sum::<f64>() + b).collect()
    }

    /// The f32 serving path for one query into `enc` (K values).
    #[inline]
    fn encoded_f32(&self, x: &[f32], enc: &mut [f64]) {
        let m = x.len();
        for ((e, w), b) in enc.iter_mut().zip(self.w32.chunks_exact(m)).zip(&self.bias) {
            *e = dot_f32(w, x) as f64 + b;
        }
    }

    pub(crate) fn from_parts(meta: ModelMeta, t: &TensorSet) -> Result<Self> {
        let (k, m) = (meta.space.encoded_len(), meta.spec.features());
        let w32 = t.f32("weights", &[k, m])?;
        let bias = t.f64("bias", &[k])?;
        if w32.iter().any(|v| !v.is_finite()) || bias.iter().any(|v| !v.is_finite()) {
            return Err(t.error("the weights hold non-finite values"));
        }
        let spread: Vec<f64> = meta
            .settings
            .get("pair_spread")
            .and_then(|v| serde_json::from_value(v.clone()).ok())
            .ok_or_else(|| t.error("damaged linear settings: no pair_spread"))?;
        if spread.len() != meta.space.pair_columns().len() || spread.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(t.error(format!("damaged linear settings: pair_spread {spread:?}")));
        }
        let w64 = w32.iter().map(|&v| v as f64).collect();
        Ok(Self::with_u8(meta, w64, w32, bias, spread))
    }
}

impl PoseModel for LinearModel {
    fn method(&self) -> &'static Method {
        &METHOD
    }

    fn meta(&self) -> &ModelMeta {
        &self.meta
    }

    fn predict_into(&self, queries: &[f32], out: &mut [f64]) -> Result<()> {
        let m = self.meta.spec.features();
        let (p, k) = (self.meta.space.len(), self.meta.space.encoded_len());
        let n = batch_len(m, queries.len(), out.len(), p)?;
        let space = &self.meta.space;
        let one = |(x, o): (&[f32], &mut [f64])| {
            let mut enc = [0f64; 16];
            let enc = if k <= 16 { &mut enc[..k] } else { unreachable!("at most 8 parameters") };
            self.encoded_f32(x, enc);
            space.decode(enc, o);
        };
        if n >= 16 {
            queries.par_chunks_exact(m).zip(out.par_chunks_exact_mut(p)).for_each(one);
        } else {
            queries.chunks_exact(m).zip(out.chunks_exact_mut(p)).for_each(one);
        }
        Ok(())
    }

    /// One hypothesis, the estimate; its confidence from the lengths of its (cos, sin) pairs
    /// against their leave-one-out spread ([`crate::confidence`]).
    fn estimate(&self, queries: &[f32], _top: usize) -> Result<Vec<Estimate>> {
        let m = self.meta.spec.features();
        let (p, k) = (self.meta.space.len(), self.meta.space.encoded_len());
        crate::model::check_queries(m, queries.len(), "query batch")?;
        let cols = self.meta.space.pair_columns();
        Ok(queries
            .par_chunks_exact(m)
            .map(|x| {
                let mut enc = vec![0f64; k];
                self.encoded_f32(x, &mut enc);
                let mut pose = vec![0.0; p];
                self.meta.space.decode(&enc, &mut pose);
                let lengths: Vec<f64> = cols.iter().map(|&c| enc[c].hypot(enc[c + 1])).collect();
                Estimate::single(pose, pair_confidence(&lengths, &self.spread))
            })
            .collect())
    }

    /// 8-bit queries: K products of the pixels with the weights / 255 by the crate's 8-bit SIMD
    /// product kernel.
    fn predict_u8_into(&self, queries: &[u8], out: &mut [f64]) -> Result<()> {
        let m = self.meta.spec.features();
        let (p, k) = (self.meta.space.len(), self.meta.space.encoded_len());
        let n = batch_len(m, queries.len(), out.len(), p)?;
        let (space, level) = (&self.meta.space, Level::detect());
        let one = |(x, o): (&[u8], &mut [f64])| {
            let (mut e32, mut enc) = ([0f32; 16], [0f64; 16]);
            dots(level, x, &self.w8, &mut e32[..k]);
            for j in 0..k {
                enc[j] = e32[j] as f64 + self.bias[j];
            }
            space.decode(&enc[..k], o);
        };
        // A batch too small to be worth the thread pool's round trip runs on the calling thread.
        if n >= 16 && split::splits(n, m) {
            queries.par_chunks_exact(m).zip(out.par_chunks_exact_mut(p)).with_min_len(split::min_task_queries(m).max(8)).for_each(one);
        } else {
            queries.chunks_exact(m).zip(out.chunks_exact_mut(p)).for_each(one);
        }
        Ok(())
    }

    fn model_bytes(&self) -> usize {
        self.w32.len() * 4 + self.bias.len() * 8
    }

    fn storage(&self) -> Storage {
        let (m, k) = (self.meta.spec.features(), self.meta.space.encoded_len());
        Storage::new(&[("M", m), ("K", k)], m * k)
    }

    fn coefficients(&self) -> Option<&[f64]> {
        Some(&self.w64)
    }

    fn tensors(&self) -> Vec<Tensor> {
        let (k, m) = (self.meta.space.encoded_len(), self.meta.spec.features());
        vec![Tensor::f32("weights", vec![k, m], self.w32.clone()), Tensor::f64("bias", vec![k], self.bias.clone())]
    }
}

/// The exact leave-one-out estimates of the linear model with `params` on its own training set
/// (docs/method.md, closed form, one factorisation): row i is the pose (degrees) that the model
/// fitted without sample i gives sample i. At ridge 0 this is the paper's model's LOO error.
pub(crate) fn leave_one_out(params: &LinearParams, train: &Dataset) -> Result<Vec<f64>> {
    params.validate()?;
    if params.center {
        return Err(Error::invalid("center", true, "the closed-form leave-one-out error is for uncentred models"));
    }
    let sys = GramSystem::new(train, params.center)?;
    let enc = sys.loo_predictions(params.ridge, train)?;
    let space = train.space();
    let (p, k) = (space.len(), space.encoded_len());
    let mut out = vec![0.0; train.len() * p];
    for (e, o) in enc.chunks_exact(k).zip(out.chunks_exact_mut(p)) {
        space.decode(e, o);
    }
    Ok(out)
}

#[cfg(test)]
mod u8_tests {
    use super::*;
    use crate::image_io::{ColorMode, ImageSpec};
    use crate::{Manifest, Param, PoseSpace};

    /// The 8-bit path (weights / 255, SIMD kernel) agrees with the f32 path on 8-bit images, and
    /// a batch split across threads gives the bits of one run on the calling thread.
    #[test]
    fn u8_queries_match_f32_queries() {
        let (w, h) = (20usize, 9usize);
        let space = PoseSpace::new(vec![Param::linear("elevation"), Param::circular("azimuth", 360.0)]).unwrap();
        let (mut poses, mut q8) = (Vec::new(), Vec::new());
        for k in 0..30 {
            let (e, a) = (30.0 + (k % 5) as f64 * 7.0, k as f64 * 12.0);
            poses.extend([e, a]);
            for p in 0..w * h {
                q8.push(((k * 7919 + p * 104_729 + (k * p) % 97) % 251) as u8);
            }
        }
        let names = (0..30).map(|k| format!("{k}.png")).collect();
        let qf: Vec<f32> = q8.iter().map(|&v| v as f32 / 255.0).collect();
        let spec = ImageSpec { width: w as u32, height: h as u32, color: ColorMode::Gray };
        let d = Dataset::from_features(Manifest::new(".", space, names, poses).unwrap(), spec, qf.clone()).unwrap();
        for center in [false, true] {
            let model = LinearParams::default().center(center).fit(&d).unwrap();
            let pf = model.predict(&qf).unwrap();
            let mut p8 = vec![0.0; pf.len()];
            model.predict_u8_into(&q8, &mut p8).unwrap();
            for (a, b) in pf.iter().zip(&p8) {
                let d = (a - b).abs();
                assert!(d.min(360.0 - d) < 1e-3, "{a} vs {b} (center {center})");
            }
            // A batch large enough to be split across threads gives the same bits.
            let copies = split::SPLIT_FROM_PIXELS.div_ceil(q8.len()) + 1;
            let qs: Vec<u8> = q8.iter().copied().cycle().take(copies * q8.len()).collect();
            assert!(split::splits(copies * 30, w * h));
            let mut ps = vec![0.0; copies * p8.len()];
            model.predict_u8_into(&qs, &mut ps).unwrap();
            assert!(ps.chunks_exact(p8.len()).all(|c| c == &p8[..]));
        }
    }
}
