//! Dense linear-algebra building blocks shared by the estimators (on faer), and the f32 kernels
//! that serve queries.

use crate::tuning::linalg::ENERGY_BLOCK;
use faer::{Mat, MatRef, Par};

/// The parallelism faer uses: rayon's global pool.
#[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
pub fn par() -> Par {
    match rayon::current_num_threads() {
        0 | 1 => Par::Seq,
        n => Par::rayon(n),
    }
}

/// An M x N f64 matrix, column-major, on huge pages where it is large
/// ([`crate::huge`]): [`transpose_features`]'s X^T.
#[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
pub struct Columns {
    buf: crate::huge::HugeBuf,
    m: usize,
    n: usize,
}

#[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
impl Columns {
    /// The matrix.
    pub fn as_ref(&self) -> MatRef<'_, f64> {
        MatRef::from_column_major_slice(self.buf.as_slice(), self.m, self.n)
    }

    /// Column j (image j), to write.
    pub fn col_mut(&mut self, j: usize) -> &mut [f64] {
        &mut self.buf.as_mut_slice()[j * self.m..(j + 1) * self.m]
    }
}

/// X^T as an M x N f64 matrix (one image per column, contiguous) from N row-major f32 feature
/// rows, each optionally minus `mean`.
#[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
pub fn transpose_features(features: &[f32], n: usize, m: usize, mean: Option<&[f64]>) -> Columns {
    debug_assert_eq!(features.len(), n * m);
    let mut xt = Columns { buf: crate::huge::HugeBuf::zeroed(m * n), m, n };
    for j in 0..n {
        let src = &features[j * m..(j + 1) * m];
        let col = xt.col_mut(j);
        match mean {
            Some(mu) => col.iter_mut().zip(src.iter().zip(mu)).for_each(|(d, (&s, &u))| *d = s as f64 - u),
            None => col.iter_mut().zip(src).for_each(|(d, &s)| *d = s as f64),
        }
    }
    xt
}

/// The mean row of N row-major feature rows.
pub(crate) fn mean_row(features: &[f32], n: usize, m: usize) -> Vec<f64> {
    let mut mu = vec![0f64; m];
    for row in features.chunks_exact(m) {
        mu.iter_mut().zip(row).for_each(|(u, &v)| *u += v as f64);
    }
    mu.iter_mut().for_each(|u| *u /= n as f64);
    mu
}

/// The Gram matrix G = X X^T (N x N) from X^T (M x N), lower triangle by the crate's f64
/// symmetric rank-k kernel (AVX-512 where the CPU has it), mirrored: exactly symmetric, and the
/// same bits whatever the thread count.
#[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
pub fn gram(xt: MatRef<'_, f64>) -> Mat<f64> {
    let (m, n) = (xt.nrows(), xt.ncols());
    let cols: Option<Vec<&[f64]>> = (0..n).map(|j| xt.col(j).try_as_col_major().map(|c| c.as_slice())).collect();
    match cols {
        Some(cols) => crate::kernels::gram::gram_f64(&cols, m),
        None => crate::kernels::gram::gram_rows(n, m, |i, k0, out| {
            let col = xt.col(i);
            out.iter_mut().enumerate().for_each(|(k, o)| *o = col[k0 + k]);
        }),
    }
}

/// The Gram matrix G = X X^T (N x N) of N row-major f32 feature rows, each optionally minus
/// `mean`, in f64 (every f32 product is exact in f64), without an f64 copy of X. Uncentred
/// 8-bit features (what PNG images give) are summed exactly in integers where the CPU has
/// AVX-512 VNNI, within about 1e-14 of the f64 sums.
#[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
pub fn gram_f32(features: &[f32], n: usize, m: usize, mean: Option<&[f64]>) -> Mat<f64> {
    crate::kernels::gram::gram_f32(features, n, m, mean)
}

/// [`gram_f32`] of a data set's features (each minus `mean` when given), with the same bits:
/// read from its 8-bit values where it keeps them ([`Dataset::rows`]) and no mean is taken, by
/// the 8-bit Gram (AVX-512 VNNI) or else the f64 kernel packing the bytes, so that the f32
/// features are not made.
pub(crate) fn gram_of(data: &crate::Dataset, mean: Option<&[f64]>) -> Mat<f64> {
    let (n, m) = (data.len(), data.n_features());
    if let (crate::dataset::Rows::U8(px), None) = (data.rows(), mean) {
        return crate::kernels::gram8::gram_u8(px, n, m).unwrap_or_else(|| crate::kernels::gram::gram_u8_fma(px, n, m));
    }
    gram_f32(data.features(), n, m, mean)
}

/// A row-major N x K matrix as faer's column-major one.
pub(crate) fn mat_from_rows(data: &[f64], n: usize, k: usize) -> Mat<f64> {
    Mat::from_fn(n, k, |i, j| data[i * k + j])
}

/// f32 lanes of [`energy`]'s running sums: four independent chains of 16 (one AVX-512 vector
/// each), so neither the dependent adds nor the vector width bound the loop.
const ENERGY_LANES: usize = 64;

/// The f32 lane sums `s` in f64, in eight independent chains (a vector of f64) then their sum.
#[inline(always)]
fn lanes_sum(s: &[f32; ENERGY_LANES]) -> f64 {
    let mut v = [0f64; 8];
    for (k, &a) in s.iter().enumerate() {
        v[k % 8] += a as f64;
    }
    ((v[0] + v[4]) + (v[1] + v[5])) + ((v[2] + v[6]) + (v[3] + v[7]))
}

/// ||x||^2: 64 independent f32 lanes (four chains of one AVX-512 vector), each block of 2048
/// values (32 a lane) summed into f64 in eight chains. Compiled for the detected SIMD level
/// (the same operations, so the same bits: queries are scaled by it, and both methods'
/// projections take it).
pub(crate) fn energy(x: &[f32]) -> f64 {
    energy_built(crate::kernels::Level::detect(), x)
}

/// (||x||^2, x . w): [`energy`] (the same bits) with x . w summed alongside it the same way, in
/// one pass over `x` (the refined model's product of a query with the mean, which its residual
/// takes, without a row of its own in the product with the eigenimages).
pub(crate) fn energy_and_dot(x: &[f32], w: &[f32]) -> (f64, f64) {
    assert_eq!(x.len(), w.len(), "x and w of one length");
    energy_and_dot_built(crate::kernels::Level::detect(), x, w)
}

crate::kernels::dispatch! {
    /// [`energy`] at `level`.
    fn energy_built(x: &[f32]) -> f64 = energy_body;
}

crate::kernels::dispatch! {
    /// [`energy_and_dot`] at `level`.
    fn energy_and_dot_built(x: &[f32], w: &[f32]) -> (f64, f64) = energy_and_dot_body;
}

#[inline(always)]
fn energy_body(x: &[f32]) -> f64 {
    let mut sq = 0f64;
    for xb in x.chunks(ENERGY_BLOCK) {
        let mut s = [0f32; ENERGY_LANES];
        let xc = xb.chunks_exact(ENERGY_LANES);
        let xr = xc.remainder();
        for a in xc {
            for k in 0..ENERGY_LANES {
                s[k] += a[k] * a[k];
            }
        }
        sq += lanes_sum(&s) + xr.iter().map(|&v| v as f64 * v as f64).sum::<f64>();
    }
    sq
}

#[inline(always)]
fn energy_and_dot_body(x: &[f32], w: &[f32]) -> (f64, f64) {
    let (mut sq, mut dot) = (0f64, 0f64);
    for (xb, wb) in x.chunks(ENERGY_BLOCK).zip(w.chunks(ENERGY_BLOCK)) {
        let (mut s, mut t) = ([0f32; ENERGY_LANES], [0f32; ENERGY_LANES]);
        let (xc, wc) = (xb.chunks_exact(ENERGY_LANES), wb.chunks_exact(ENERGY_LANES));
        let (xr, wr) = (xc.remainder(), wc.remainder());
        for (a, b) in xc.zip(wc) {
            for k in 0..ENERGY_LANES {
                s[k] += a[k] * a[k];
                t[k] += a[k] * b[k];
            }
        }
        sq += lanes_sum(&s) + xr.iter().map(|&v| v as f64 * v as f64).sum::<f64>();
        dot += lanes_sum(&t) + xr.iter().zip(wr).map(|(&v, &u)| v as f64 * u as f64).sum::<f64>();
    }
    (sq, dot)
}

/// Dot product of two f32 vectors with eight independent accumulators (vectorises well and
/// keeps the rounding error of a 19,200-term sum near that of pairwise summation).
#[inline]
pub(crate) fn dot_f32(a: &[f32], b: &[f32]) -> f32 {
    debug_assert_eq!(a.len(), b.len());
    let mut acc = [0f32; 16];
    let (ca, cb) = (a.chunks_exact(16), b.chunks_exact(16));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for l in 0..16 {
            acc[l] += x[l] * y[l];
        }
    }
    let mut tail = 0f32;
    for (x, y) in ra.iter().zip(rb) {
        tail += x * y;
    }
    let mut s = [0f32; 4];
    for l in 0..4 {
        s[l] = (acc[l] + acc[l + 4]) + (acc[l + 8] + acc[l + 12]);
    }
    ((s[0] + s[1]) + (s[2] + s[3])) + tail
}

/// The squared Euclidean distance between two rows of f32 values: the squared differences summed
/// in eight f32 lanes (which the compiler vectorises), then the lanes in f64. Always inlined, so
/// that a caller built for the CPU's level (`kernels::dispatch!`) vectorises it for that level.
#[inline(always)]
pub(crate) fn squared_distance(a: &[f32], b: &[f32]) -> f64 {
    let mut acc = [0f32; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for j in 0..8 {
            let d = x[j] - y[j];
            acc[j] += d * d;
        }
    }
    for (j, (x, y)) in ra.iter().zip(rb).enumerate() {
        let d = x - y;
        acc[j] += d * d;
    }
    acc.iter().map(|&v| v as f64).sum::<f64>()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gram_matches_definition() {
        let (n, m) = (5, 37);
        let f: Vec<f32> = (0..n * m).map(|i| ((i * 7919) % 101) as f32 / 101.0).collect();
        let g = gram(transpose_features(&f, n, m, None).as_ref());
        for i in 0..n {
            for j in 0..n {
                let want: f64 = (0..m).map(|t| f[i * m + t] as f64 * f[j * m + t] as f64).sum();
                assert!((g[(i, j)] - want).abs() <= 1e-12 * want.abs().max(1.0));
            }
        }
    }

    #[test]
    fn dot_matches_f64() {
        let a: Vec<f32> = (0..1003).map(|i| (i as f32 * 0.37).sin()).collect();
        let b: Vec<f32> = (0..1003).map(|i| (i as f32 * 0.11).cos()).collect();
        let want: f64 = a.iter().zip(&b).map(|(&x, &y)| x as f64 * y as f64).sum();
        assert!((dot_f32(&a, &b) as f64 - want).abs() < 1e-4);
    }

    /// The energy and the energy with a product: within f32 rounding of the f64 sums, the
    /// energy the same bits alone and beside the product, and on every build (every SIMD level
    /// this CPU runs), at lengths around the lanes and blocks (remainders included).
    #[test]
    fn energy_and_its_product_are_the_f64_sums_on_every_build() {
        for m in [0, 1, 63, 64, 65, 2047, 2048, 2049, 16384, 19200 + 7] {
            let x: Vec<f32> = (0..m).map(|i| ((i * 7919) % 257) as f32 / 256.0).collect();
            let w: Vec<f32> = (0..m).map(|i| (i as f32 * 0.37).sin() * 1e-2).collect();
            let xx: f64 = x.iter().map(|&v| v as f64 * v as f64).sum();
            let xw: f64 = x.iter().zip(&w).map(|(&v, &u)| v as f64 * u as f64).sum();
            let (e, d) = energy_and_dot(&x, &w);
            assert_eq!(e.to_bits(), energy(&x).to_bits(), "m {m}");
            assert_eq!((e.to_bits(), d.to_bits()), {
                let (a, b) = energy_and_dot_body(&x, &w);
                (a.to_bits(), b.to_bits())
            });
            assert_eq!(energy_body(&x).to_bits(), e.to_bits(), "m {m}");
            for level in crate::kernels::Level::supported() {
                let (a, b) = energy_and_dot_built(level, &x, &w);
                assert_eq!((a.to_bits(), b.to_bits()), (e.to_bits(), d.to_bits()), "m {m} {level:?}");
                assert_eq!(energy_built(level, &x).to_bits(), e.to_bits(), "m {m} {level:?}");
            }
            assert!((e - xx).abs() <= 1e-6 * xx.max(1e-30), "m {m}: {e} against {xx}");
            let scale: f64 = x.iter().zip(&w).map(|(&v, &u)| (v as f64 * u as f64).abs()).sum();
            assert!((d - xw).abs() <= 1e-6 * scale.max(1e-30), "m {m}: {d} against {xw}");
        }
    }
}
