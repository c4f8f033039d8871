//! What the linear model's fit allocates, for the memory plan ([`crate::memory`]); bytes, with N
//! images, M features, K encoded pose values:
//!
//! - in memory: 24 N^2 (G, G + lambda I, its Cholesky factor; f64) + 2 KiB N and the weights.
//!   With `ridge auto`: 38 N^2 (G and its eigendecomposition). With a noise level A > 0 the fit
//!   also holds each view's expected noisy version, 2N rows: 4 (2N) M + 24 (2N)^2. With
//!   `noise-level auto`: the larger of that and 8 N^2 + 4 N M / channels (an image plane copied
//!   while G is held).
//! - streamed ([`super::stream`]), N > M: 4 M'(M' + 192) (X^T X's lower triangle in bands, then
//!   the lower half of the M x M matrix it is copied into and factored in place; M' = M padded
//!   to 48) + 2 x 1024 x 5 M (two blocks of images, f32 and 8-bit) + 10 KiB M' (packed
//!   panels) + 48 M K. For N <= M as in memory (it loads the set). It takes a fixed ridge,
//!   uncentred: the leave-one-out and noise-level rules (the latter fits expected noisy views
//!   beside the clean ones) and centring keep a fit from streaming ([`StreamBlock`]).

use super::ridge::RidgeRule;
use super::tuning::{GRAM_SYSTEM_BYTES, LOO_SYSTEM_BYTES};
use super::{LinearParams, METHOD};
use crate::error::{Error, StreamChange};
use crate::kernels::syrk::{padded, KC, KCP, KCQ};
use crate::model::footprint::{system, Footprint, Parts, Sizes, StreamBlock};
use crate::normal_equations::rows::BLOCK;
use std::sync::Arc;

impl Footprint for LinearParams {
    fn fit(&self, s: &Sizes) -> Parts {
        let (n, m, k) = (s.n as f64, s.m as f64, s.k as f64);
        // The fit's rows: the images, and for a fixed noise level each one's expected noisy
        // view as well (at most 2N rows, copied).
        let augmented = matches!(self.rule(), RidgeRule::Noise(a) if a > 0.0);
        let r = if augmented { 2.0 * n } else { n };
        let per = if self.rule() == RidgeRule::Loo { LOO_SYSTEM_BYTES } else { GRAM_SYSTEM_BYTES };
        let gram = if self.rule() == RidgeRule::Loo {
            format!("N x N Gram of {} images and its eigendecomposition", r as usize)
        } else {
            format!("N x N Gram of {} images", r as usize)
        };
        let system = Parts::default().add(system(r, per), gram);
        // `noise-level auto` reads one plane of the images (a copy) while G is held.
        let noise_auto = Parts::default().add(8.0 * r * r, "the Gram matrix").add(4.0 * n * m / s.channels as f64, "an image plane");
        let base = Parts::default().add(if augmented { 4.0 * r * m } else { 0.0 }, "the expected noisy views").add(24.0 * k * m, "the weights");
        if self.rule() == RidgeRule::NoiseAuto {
            base.stage(system, noise_auto)
        } else {
            base.stage(system, Parts::default())
        }
    }

    /// The least-squares path accumulates X^T X block by block, whatever N; for N <= M the
    /// streamed fit loads the set and fits it in memory (the same model).
    fn streamed(&self, s: &Sizes) -> Option<Parts> {
        if s.n <= s.m {
            return None;
        }
        let (m, np, k) = (s.m as f64, padded(s.m) as f64, s.k as f64);
        let block = BLOCK.min(s.n) as f64;
        // X^T X's lower triangle in bands (192 rows at most), then copied into the M x M matrix
        // whose lower half only is touched (the band freed as it is copied), factored in place.
        // Named by the matrix, whatever part is largest (the blocks, for small M).
        Some(
            Parts::default()
                .add(4.0 * np * (np + 192.0), format!("X^T X of {} features", s.m))
                .add(2.0 * block * m * 5.0, "two blocks of images, as f32 and 8-bit")
                .add(np * (KCP * 8 + KCQ * 16 + KC * 8) as f64, "the packed panels")
                .add(48.0 * m * k, "X^T P and the weights")
                .named(format!("X^T X of {} features", s.m)),
        )
    }

    /// With more images than features the least-squares path: less memory and time than the
    /// N x N Gram matrix, the same model with a ridge, the only fit with ridge 0.
    fn stream_first(&self, s: &Sizes) -> bool {
        s.n > s.m
    }

    fn stream_block(&self) -> Option<StreamBlock> {
        let setting = |name: &str, value: String, reason, change| StreamBlock {
            reason,
            change,
            error: Error::Setting {
                method: METHOD.name,
                name: name.into(),
                value,
                reason: "a streamed fit takes a fixed ridge (0 for the exact fit): the leave-one-out and noise rules need the training set in memory".into(),
            },
            // A fixed ridge (the default), the centring kept.
            unblocked: Arc::new(LinearParams::default().center(self.is_centered())),
        };
        match self.rule() {
            RidgeRule::Loo => Some(setting("ridge", "auto".into(), "ridge auto (leave-one-out) needs the training set in memory", StreamChange::FixedRidge)),
            // The noise rule fits expected noisy views beside the clean ones (or estimates the
            // noise from the images): in memory.
            RidgeRule::Noise(a) => Some(setting("noise-level", a.to_string(), "the noise-level rule needs the training set in memory", StreamChange::FixedNoiseLevel)),
            RidgeRule::NoiseAuto => Some(setting("noise-level", "auto".into(), "the noise-level rule needs the training set in memory", StreamChange::FixedNoiseLevel)),
            RidgeRule::Fixed if self.is_centered() => Some(StreamBlock {
                reason: "a streamed fit is uncentred",
                change: StreamChange::NoCentring,
                error: Error::invalid("center", true, "a streamed fit is uncentred (the paper's form)"),
                unblocked: Arc::new(self.center(false)),
            }),
            RidgeRule::Fixed => None,
        }
    }
}
