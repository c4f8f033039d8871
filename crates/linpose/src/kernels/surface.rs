//! The spline surface's kernels ([`crate::manifold::surface`]): the weighted distance of the
//! climb, the 3 x 3 block of a two-parameter surface's points, and a two-parameter point's
//! values; portable and in AVX-512 with the same operations in the same order (no fused
//! multiply-adds), so the same bits.

use super::Level;

/// Coordinates a block evaluates at most ([`block2`]'s rows).
pub(crate) const BLOCK_DIM: usize = 32;

/// A surface's coefficients: for each derivative mask, each knot's `dim` values.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Coefs<'a> {
    pub coef: &'a [f32],
    pub dim: usize,
}

/// The knot grid of a two-parameter surface: its knots and each axis's stride between them.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Grid2 {
    pub knots: usize,
    pub stride: [usize; 2],
}

/// One axis's spline weights at a pose: the value weights, the slope weights and the two knots of
/// its interval.
pub(crate) type AxisWeights = ([f64; 4], [f64; 4], usize, usize);

/// The 3 x 3 poses of a block, as their weights along each axis (`None`: skipped), and the
/// coordinates evaluated (the first `lo`).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Block {
    pub w0: [Option<AxisWeights>; 3],
    pub w1: [Option<AxisWeights>; 3],
    pub lo: usize,
}

/// The 16 terms of a two-parameter point: each one's offset into the coefficients and its
/// weight.
pub(crate) type Terms2 = ([usize; 16], [f64; 16]);

/// The weighted squared distance sum w (y - f)^2 over values given in multiples of 8 (zero
/// weight beyond the coordinates), summed 8 lanes at a time; in AVX-512 where `level` has it.
pub(crate) fn lane_distance(level: Level, y: &[f64], w: &[f64], f: &[f64]) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if level.avx512() {
        // SAFETY: the level is a token of detection that found AVX-512F; the kernel asserts the
        // lengths it reads.
        return unsafe { simd::lane_distance_avx512(y, w, f) };
    }
    lane_distance_body(y, w, f)
}

/// [`lane_distance`]'s portable body.
#[inline(always)]
pub(crate) fn lane_distance_body(y: &[f64], w: &[f64], f: &[f64]) -> f64 {
    let n = f.len() / 8 * 8;
    let (y, w, f) = (&y[..n], &w[..n], &f[..n]);
    let mut acc = [0f64; 8];
    for k in (0..n).step_by(8) {
        for i in k..k + 8 {
            let e = y[i] - f[i];
            acc[i - k] += w[i] * e * e;
        }
    }
    acc.iter().sum()
}

/// The block of points (`block`: their weights, asked for only when used) of the surface `s` on
/// `grid` (and of `other`, on the same knots) into `fv` (and `gv`) where `level` runs AVX-512
/// ([`simd::block2_avx512`]); false (nothing written) otherwise.
pub(crate) fn block2(
    level: Level,
    grid: Grid2,
    s: Coefs<'_>,
    other: Option<Coefs<'_>>,
    block: impl FnOnce() -> Block,
    fv: &mut [[f64; BLOCK_DIM]; 9],
    gv: &mut [[f64; BLOCK_DIM]; 9],
) -> bool {
    #[cfg(target_arch = "x86_64")]
    if level.avx512() {
        // SAFETY: the level is a token of detection that found AVX-512F; the kernel asserts the
        // lengths it reads and writes.
        unsafe { simd::block2_avx512(grid, s, other, &block(), fv, gv) };
        return true;
    }
    let _ = (level, grid, s, other, block, fv, gv);
    false
}

/// The values of a two-parameter point from its `terms` (the first `f.len()` coordinates of
/// `s`, and of `other` into its slice); in AVX-512 where `level` has it, the same bits.
#[inline(always)]
pub(crate) fn values2(level: Level, terms: &Terms2, s: Coefs<'_>, f: &mut [f64], other: Option<(Coefs<'_>, &mut [f64])>) {
    #[cfg(target_arch = "x86_64")]
    if level.avx512() {
        // SAFETY: the level is a token of detection that found AVX-512F; the kernel asserts the
        // lengths it reads.
        return unsafe { simd::values2_avx512(terms, s, f, other) };
    }
    values2_portable(terms, s, f, other)
}

/// [`values2`]'s portable body: the 16 terms in order, the same products and sums.
#[inline(always)]
pub(crate) fn values2_portable(terms: &Terms2, s: Coefs<'_>, f: &mut [f64], other: Option<(Coefs<'_>, &mut [f64])>) {
    let (at, wt) = *terms;
    let sum = |acc: &mut [f64], coef: &[f32]| {
        acc.fill(0.0);
        for (&a, &w) in at.iter().zip(&wt) {
            acc.iter_mut().zip(&coef[a..]).for_each(|(v, &x)| *v += w * x as f64);
        }
    };
    sum(f, s.coef);
    if let Some((o, g)) = other {
        sum(g, o.coef);
    }
}

/// The AVX-512 bodies.
#[cfg(target_arch = "x86_64")]
pub(crate) mod simd {
    use super::{Block, Coefs, Grid2, Terms2, BLOCK_DIM};
    use std::arch::x86_64::*;

    /// [`lane_distance_body`] compiled for AVX-512.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub(crate) unsafe fn lane_distance_avx512(y: &[f64], w: &[f64], f: &[f64]) -> f64 {
        let n = f.len() / 8 * 8;
        assert!(y.len() >= n && w.len() >= n);
        let mut acc = _mm512_setzero_pd();
        for k in (0..n).step_by(8) {
            // SAFETY: k + 8 <= n, within the three slices (asserted).
            let (yk, wk, fk) = unsafe { (_mm512_loadu_pd(y.as_ptr().add(k)), _mm512_loadu_pd(w.as_ptr().add(k)), _mm512_loadu_pd(f.as_ptr().add(k))) };
            let e = _mm512_sub_pd(yk, fk);
            acc = _mm512_add_pd(acc, _mm512_mul_pd(_mm512_mul_pd(wk, e), e));
        }
        lanes_sum(acc)
    }

    /// The 8 lanes summed in order, as the portable code sums its lane array (`Iterator::sum`: from
    /// -0.0, lane by lane). Spelled out rather than by `sum`, whose generic body the compiler did not
    /// always inline here (as a call it cost the noisy match about a tenth of its time).
    #[target_feature(enable = "avx512f")]
    pub(crate) fn lanes_sum(v: __m512d) -> f64 {
        let mut a = [0f64; 8];
        // SAFETY: 8 values into an array of 8.
        unsafe { _mm512_storeu_pd(a.as_mut_ptr(), v) };
        let mut s = -0.0;
        for x in a {
            s += x;
        }
        s
    }

    /// [`crate::manifold::surface::Surface::block2`] with each run of 8 coordinates of the 4 sums along the second axis
    /// held in registers and each point summed from them.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub(crate) unsafe fn block2_avx512(
        grid: Grid2,
        s: Coefs<'_>,
        other: Option<Coefs<'_>>,
        block: &Block,
        fv: &mut [[f64; BLOCK_DIM]; 9],
        gv: &mut [[f64; BLOCK_DIM]; 9],
    ) {
        let (n, lo) = (grid.knots, block.lo);
        assert!(lo <= BLOCK_DIM && lo <= s.dim && other.is_none_or(|o| lo <= o.dim && o.coef.len() == s.coef.len() * o.dim / s.dim));
        let (w0, w1) = (block.w0, block.w1);
        // The points in groups of one knot cell (usually all 9): the 16 coefficient rows of the
        // cell are read once for every point of the group.
        let mut done = [[false; 3]; 3];
        for b in 0..3 {
            for a in 0..3 {
                let (Some((_, _, i0, j0)), Some((_, _, i1, j1))) = (w0[a], w1[b]) else { continue };
                if done[b][a] {
                    continue;
                }
                // The cell's positions along each axis.
                let (mut as_, mut bs) = ([(0usize, [0f64; 4]); 3], [(0usize, [0f64; 4]); 3]);
                let (mut na, mut nb) = (0, 0);
                for (a2, w) in w0.iter().enumerate() {
                    if let Some((wp, _, i2, _)) = *w {
                        if i2 == i0 {
                            as_[na] = (a2, wp);
                            na += 1;
                        }
                    }
                }
                for (b2, w) in w1.iter().enumerate() {
                    if let Some((wq, _, i2, _)) = *w {
                        if i2 == i1 {
                            bs[nb] = (b2, wq);
                            nb += 1;
                        }
                    }
                }
                for &(b2, _) in &bs[..nb] {
                    for &(a2, _) in &as_[..na] {
                        done[b2][a2] = true;
                    }
                }
                let (k0, k1) = ([i0 * grid.stride[0], j0 * grid.stride[0]], [i1 * grid.stride[1], j1 * grid.stride[1]]);
                let mut rows = [0usize; 16];
                for (pq, r) in rows.iter_mut().enumerate() {
                    let (p, q) = (pq >> 2, pq & 3);
                    *r = ((p & 1) | (q & 1) << 1) * n + k0[p >> 1] + k1[q >> 1];
                }
                let one = |coef: &[f32], dim: usize, out: &mut [[f64; BLOCK_DIM]; 9]| {
                    assert!(rows.iter().all(|&r| (r + 1) * dim <= coef.len()));
                    let mut c = 0;
                    while c < lo {
                        let m8 = if lo - c >= 8 { 0xffu8 } else { (1u8 << (lo - c)) - 1 };
                        let mut x = [_mm512_setzero_pd(); 16];
                        for (xv, &r) in x.iter_mut().zip(&rows) {
                            // SAFETY: lanes c .. min(c + 8, lo) of row r lie within `coef`
                            // (asserted: lo <= dim); the masked load reads no others.
                            *xv = _mm512_cvtps_pd(_mm512_castps512_ps256(unsafe { _mm512_maskz_loadu_ps(m8 as u16, coef.as_ptr().add(r * dim + c)) }));
                        }
                        for &(b2, wq) in &bs[..nb] {
                            // The sums along the second axis, q in order.
                            let mut h = [_mm512_setzero_pd(); 4];
                            for (pq, xv) in x.iter().enumerate() {
                                let hp = &mut h[pq >> 2];
                                *hp = _mm512_add_pd(*hp, _mm512_mul_pd(_mm512_set1_pd(wq[pq & 3]), *xv));
                            }
                            for &(a2, wp) in &as_[..na] {
                                let mut v = _mm512_mul_pd(_mm512_set1_pd(wp[0]), h[0]);
                                for p in 1..4 {
                                    v = _mm512_add_pd(v, _mm512_mul_pd(_mm512_set1_pd(wp[p]), h[p]));
                                }
                                // SAFETY: lanes c .. min(c + 8, lo) of a row of BLOCK_DIM >= lo.
                                unsafe { _mm512_mask_storeu_pd(out[a2 + 3 * b2].as_mut_ptr().add(c), m8, v) };
                            }
                        }
                        c += 8;
                    }
                };
                one(s.coef, s.dim, fv);
                if let Some(o) = other {
                    one(o.coef, o.dim, gv);
                }
            }
        }
    }

    /// [`values2_portable`] with each run of 8 coordinates summed over the 16 terms in one
    /// register: the same products and sums in the same order (no fused multiply-add), so the
    /// same bits.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub(crate) unsafe fn values2_avx512(terms: &Terms2, s: Coefs<'_>, f: &mut [f64], other: Option<(Coefs<'_>, &mut [f64])>) {
        let (at, wt) = *terms;
        let sum = |acc: &mut [f64], coef: &[f32], dim: usize| {
            let lo = acc.len();
            assert!(lo <= dim && at.iter().all(|&a| a + dim <= coef.len()));
            let mut q = 0;
            while q < lo {
                let m8 = if lo - q >= 8 { 0xff } else { (1u8 << (lo - q)) - 1 };
                let mut v = _mm512_setzero_pd();
                for (&a, &w) in at.iter().zip(&wt) {
                    // SAFETY: lanes q .. min(q + 8, lo) of the term's row lie within `coef`
                    // (asserted); the masked load reads no others.
                    let x = _mm512_castps512_ps256(unsafe { _mm512_maskz_loadu_ps(m8 as u16, coef.as_ptr().add(a + q)) });
                    v = _mm512_add_pd(v, _mm512_mul_pd(_mm512_set1_pd(w), _mm512_cvtps_pd(x)));
                }
                // SAFETY: lanes q .. min(q + 8, lo) of `acc`.
                unsafe { _mm512_mask_storeu_pd(acc.as_mut_ptr().add(q), m8, v) };
                q += 8;
            }
        };
        sum(f, s.coef, s.dim);
        if let Some((o, g)) = other {
            sum(g, o.coef, o.dim);
        }
    }
}
