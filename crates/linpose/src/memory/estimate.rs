//! What each path allocates, from N, M, K and the method's settings: the formulas of
//! [`super`]'s documentation, with the constants of [`super::tuning`]. Each estimate is a sum
//! of named parts (the largest names it), and where a fit's stages free one stage's arrays
//! before the next allocates its own, the larger stage only.

use super::tuning::*;
use super::{Job, Params};
use crate::kernels::syrk::{padded, KC, KCP, KCQ};
use crate::methods::eigenspace::Dimension;
use crate::methods::linear::ridge::RidgeRule;
use crate::methods::linear::stream::BLOCK;
use crate::recognize::RecognizerKind;

/// What a path needs: bytes, and its largest part in words.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Estimate {
    /// Peak resident bytes, an upper bound by design (see the memory module's tuning constants).
    pub bytes: u64,
    /// The largest part, e.g. "N x N Gram of 100800 images".
    pub what: String,
}

/// A sum of named parts.
#[derive(Default)]
struct Parts(Vec<(f64, String)>);

impl Parts {
    fn add(mut self, bytes: f64, what: impl Into<String>) -> Self {
        if bytes > 0.0 {
            self.0.push((bytes, what.into()));
        }
        self
    }

    fn total(&self) -> f64 {
        self.0.iter().map(|p| p.0).sum()
    }

    /// The larger of two stages that do not overlap, added.
    fn stage(self, a: Parts, b: Parts) -> Self {
        let larger = if a.total() >= b.total() { a } else { b };
        larger.0.into_iter().fold(self, |s, (v, w)| s.add(v, w))
    }

    /// The estimate: the parts, the process and its decoding threads, named by the largest part
    /// (`name` when there is none).
    fn estimate(self, job: &Job, name: &str) -> Estimate {
        let what = self.0.iter().max_by(|a, b| a.0.total_cmp(&b.0)).map_or_else(|| name.to_string(), |p| p.1.clone());
        let parts = self.add(OVERHEAD_BYTES as f64, "the process").add((job.threads * job.m) as f64 * THREAD_FEATURE_BYTES as f64, "decoding");
        let bytes = parts.total().ceil();
        Estimate { bytes: if bytes >= u64::MAX as f64 { u64::MAX } else { bytes as u64 }, what }
    }
}

fn f(n: usize) -> f64 {
    n as f64
}

/// An N x N system of `per` bytes per N^2 and [`ROW_BYTES`] per row, with a freed N x N matrix
/// the heap may keep ([`HEAP_MATRIX_BYTES`]).
fn system(n: f64, per: f64) -> f64 {
    let matrix = 8.0 * n * n;
    per * n * n + ROW_BYTES * n + if matrix < HEAP_MATRIX_BYTES as f64 { matrix } else { 0.0 }
}

/// The training images as f32 (and their normalised copy).
fn images(job: &Job) -> Parts {
    let (n, m) = (f(job.n), f(job.m));
    let p = Parts::default().add(4.0 * n * m, format!("{} images of {} features as f32", job.n, job.m));
    let p = if job.normalize { p.add(4.0 * n * m, "the normalised images") } else { p };
    if job.choose_stage {
        p.add(4.0 * n * m, "the held-out folds' normalised views (choosing the normalisation)")
    } else {
        p
    }
}

/// The in-memory path: the images loaded, then the method's fit.
pub(crate) fn in_memory(job: &Job) -> Estimate {
    match &job.objects {
        Some(_) => objects(job),
        None => images(job).stage(fit(job), Parts::default()),
    }
    .estimate(job, "the images")
}

/// What the method's fit allocates beside the f32 images.
fn fit(job: &Job) -> Parts {
    let (n, m, k) = (f(job.n), f(job.m), f(job.k));
    match job.params {
        Params::Linear(p) => {
            // The fit's rows: the images, and for a fixed noise level each one's expected noisy
            // view as well (at most 2N rows, copied).
            let augmented = matches!(p.rule(), RidgeRule::Noise(a) if a > 0.0);
            let r = if augmented { 2.0 * n } else { n };
            let per = if p.rule() == RidgeRule::Loo { LOO_SYSTEM_BYTES } else { GRAM_SYSTEM_BYTES };
            let gram = if p.rule() == RidgeRule::Loo {
                format!("N x N Gram of {} images and its eigendecomposition", r as usize)
            } else {
                format!("N x N Gram of {} images", r as usize)
            };
            let system = Parts::default().add(system(r, per), gram);
            // `noise-level auto` reads one plane of the images (a copy) while G is held.
            let noise_auto = Parts::default().add(8.0 * r * r, "the Gram matrix").add(4.0 * n * m / f(job.channels), "an image plane");
            let base = Parts::default().add(if augmented { 4.0 * r * m } else { 0.0 }, "the expected noisy views").add(24.0 * k * m, "the weights");
            if p.rule() == RidgeRule::NoiseAuto {
                base.stage(system, noise_auto)
            } else {
                base.stage(system, Parts::default())
            }
        }
        Params::Eigenspace(p) => {
            let l = f(match p.dimension() {
                Dimension::Fixed(l) => l,
                Dimension::Energy(_) => ENERGY_COMPONENTS,
            }
            .min(job.n.saturating_sub(1))
            .min(job.m)
            .max(1));
            // The PCA (a transposed f64 copy, the Gram matrix and its eigendecomposition), then,
            // the copy freed, the manifold.
            let pca = Parts::default()
                .add(8.0 * n * m, "the images' f64 transposed copy")
                .add(system(n, EVD_SYSTEM_BYTES), format!("N x N Gram of {} images and its eigendecomposition", job.n))
                .add(16.0 * m * l, "the eigenimages");
            let manifold = Parts::default().add(8.0 * m * l, "the eigenimages").add(MANIFOLD_VALUE_BYTES * f(job.lattice) * l, "the resampled manifold");
            Parts::default().stage(pca, manifold)
        }
        Params::Refined(p) => {
            // The binned copies (every candidate factor's when chosen), and the held-out fits
            // at the finest factor tried.
            let (copies, finest) = match p.bin {
                None => (4.0 * n * m * (1.0 / 4.0 + 1.0 / 16.0), 1.0),
                Some(b) if b > 1 => (4.0 * n * m / f(b * b), f(b * b)),
                Some(_) => (0.0, 1.0),
            };
            Parts::default()
                .add(copies, "the binned images")
                .add(REFINED_FULL_BYTES * n * m + REFINED_BINNED_BYTES * n * m / finest, "the held-out fits' copies of the images")
                .add(system(n, REFINED_SYSTEM_BYTES), format!("N x N Gram of {} images and its eigendecomposition", job.n))
                .add(REFINED_LATTICE_BYTES * f(job.lattice), "the held-out fits' lattice searches")
        }
    }
}

/// A data set of many objects (in memory only): the objects' images, the recogniser's fit on
/// all of them (a concatenated copy, then its PCA or its linear system), and beside it the
/// objects' pose models, as many at once as there are threads.
fn objects(job: &Job) -> Parts {
    let o = job.objects.as_ref().expect("a job of many objects");
    let (t, m) = (f(job.n), f(job.m));
    let recogniser = match o.recognizer {
        RecognizerKind::Universal => {
            let l = f(o.components.min(job.n.saturating_sub(1)).min(job.m).max(1));
            Parts::default()
                .add(8.0 * t * m, "the images' f64 transposed copy")
                .add(system(t, EVD_SYSTEM_BYTES), format!("N x N Gram of all {} images and its eigendecomposition", job.n))
                .add(16.0 * m * l + MANIFOLD_VALUE_BYTES * f(job.lattice * o.count) * l, "the universal eigenspace")
        }
        RecognizerKind::Linear => Parts::default().add(system(t, LINEAR_RECOGNIZER_BYTES), format!("N x N Gram of all {} images and its inverse", job.n)),
    };
    let one = Job { n: o.largest, objects: None, normalize: false, ..job.clone() };
    let at_once = f(job.threads.min(o.count).max(1));
    let per_object = fit(&one).total();
    images(job).add(4.0 * t * m, "the images concatenated").stage(recogniser, Parts::default()).add(at_once * per_object, "the objects' pose models")
}

/// The streamed path (a method that streams, with settings it streams with): the linear
/// model's N > M least squares accumulates X^T X block by block; for N <= M it loads the set
/// and fits it in memory (the same model), so it needs what that needs.
pub(crate) fn streamed(job: &Job) -> Estimate {
    if job.n <= job.m {
        return images(job).stage(fit(job), Parts::default()).estimate(job, "the images");
    }
    let (m, np, k) = (f(job.m), f(padded(job.m)), f(job.k));
    let block = f(BLOCK.min(job.n));
    // X^T X's lower triangle in bands (192 rows at most), then copied into the M x M matrix
    // whose lower half only is touched (the band freed as it is copied), factored in place.
    // Named by the matrix, whatever part is largest (the blocks, for small M).
    let e = Parts::default()
        .add(4.0 * np * (np + 192.0), format!("X^T X of {} features", job.m))
        .add(2.0 * block * m * 5.0, "two blocks of images, as f32 and 8-bit")
        .add(np * f(KCP * 8 + KCQ * 16 + KC * 8), "the packed panels")
        .add(48.0 * m * k, "X^T P and the weights")
        .estimate(job, "X^T X");
    Estimate { what: format!("X^T X of {} features", job.m), ..e }
}
