//! Resampling an image under a scale and a translation (the same scale along both axes, so the
//! aspect ratio is kept), separably: each output column and row is a weighted sum of source
//! pixels with Keys' cubic kernel (a = -1/2, the interpolant of bicubic resizing), widened by the
//! scale when the image shrinks so that the result is not aliased. Pixels outside the source
//! frame are background: the values here are deviations from it, so they are 0.
//!
//! A source position is split into the object's integer corner and a fractional part that does
//! not depend on it, and the kernel's taps and weights come from the fractional part alone: an
//! image moved by whole pixels is resampled with the same weights, and gives the same output bit
//! for bit.

/// Keys' cubic convolution kernel with a = -1/2.
fn keys(x: f64) -> f64 {
    let x = x.abs();
    if x < 1.0 {
        (1.5 * x - 2.5) * x * x + 1.0
    } else if x < 2.0 {
        ((-0.5 * x + 2.5) * x - 4.0) * x + 2.0
    } else {
        0.0
    }
}

/// The taps of one output position: the first source index and the normalised weights.
pub(crate) struct Taps {
    first: i64,
    weights: Vec<f32>,
}

impl Taps {
    /// The taps within a frame of `len` pixels: the first one's index and their weights (the
    /// others fall on background, which is 0 here).
    fn inside(&self, len: usize) -> (usize, &[f32]) {
        let n = self.weights.len() as i64;
        let lo = (-self.first).clamp(0, n);
        let hi = (len as i64 - self.first).clamp(lo, n);
        if lo == hi {
            return (0, &[]);
        }
        ((self.first + lo) as usize, &self.weights[lo as usize..hi as usize])
    }
}

/// The taps of `out` output positions along one axis: output position u samples the source at
/// `origin + rel + (u - (out - 1) / 2) * step` (pixel indices), with a kernel widened to
/// `max(1, step)` source pixels.
pub(crate) fn taps(out: usize, origin: i64, rel: f64, step: f64) -> Vec<Taps> {
    let width = step.max(1.0);
    let centre = (out as f64 - 1.0) / 2.0;
    (0..out)
        .map(|u| {
            let pos = rel + (u as f64 - centre) * step;
            let lo = (pos - 2.0 * width).ceil();
            let hi = (pos + 2.0 * width).floor();
            let mut weights: Vec<f64> = (lo as i64..=hi as i64).map(|k| keys((k as f64 - pos) / width)).collect();
            let sum: f64 = weights.iter().sum();
            weights.iter_mut().for_each(|v| *v /= sum);
            Taps { first: origin + lo as i64, weights: weights.into_iter().map(|v| v as f32).collect() }
        })
        .collect()
}

/// Resamples `dev` (`(w, h, c)`: `w` x `h` pixels of `c` interleaved channels, deviations from the background)
/// through the column taps `tx` and row taps `ty` into `out` (`tx.len()` x `ty.len()` pixels),
/// each value times `gain`.
pub(crate) fn resample(dev: &[f32], (w, h, c): (usize, usize, usize), tx: &[Taps], ty: &[Taps], gain: f32, out: &mut [f32]) {
    let ow = tx.len();
    debug_assert_eq!(out.len(), ow * ty.len() * c);
    // Rows first: every source row through the column taps (each tap's span clipped to the
    // frame once, so the inner loops have no branch).
    let spans: Vec<(usize, &[f32])> = tx.iter().map(|t| t.inside(w)).collect();
    let mut rows = vec![0.0f32; h * ow * c];
    for y in 0..h {
        let src = &dev[y * w * c..(y + 1) * w * c];
        let dst = &mut rows[y * ow * c..(y + 1) * ow * c];
        if c == 1 {
            for (d, &(x, wts)) in dst.iter_mut().zip(&spans) {
                *d = wts.iter().zip(&src[x..x + wts.len()]).map(|(a, b)| a * b).sum();
            }
        } else {
            for (u, &(x, wts)) in spans.iter().enumerate() {
                for (k, &wt) in wts.iter().enumerate() {
                    for ch in 0..c {
                        dst[u * c + ch] += wt * src[(x + k) * c + ch];
                    }
                }
            }
        }
    }
    out.fill(0.0);
    for (v, t) in ty.iter().enumerate() {
        let dst = &mut out[v * ow * c..(v + 1) * ow * c];
        let (y0, wts) = t.inside(h);
        for (k, &wt) in wts.iter().enumerate() {
            let src = &rows[(y0 + k) * ow * c..(y0 + k + 1) * ow * c];
            for (d, s) in dst.iter_mut().zip(src) {
                *d += wt * s;
            }
        }
    }
    if gain != 1.0 {
        out.iter_mut().for_each(|v| *v *= gain);
    }
}
