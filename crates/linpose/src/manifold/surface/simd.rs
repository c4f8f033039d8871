//! The AVX-512 bodies of the surface's evaluation and climb: the portable bodies' operations in the
//! same order (no fused multiply-adds), so the same bits.

use super::{Surface, BLOCK_DIM};
use std::arch::x86_64::*;

/// [`super::climb::lane_distance`] compiled for AVX-512.
///
/// # Safety
/// The CPU must support AVX-512F.
#[target_feature(enable = "avx512f")]
pub unsafe fn lane_distance_avx512(y: &[f64], w: &[f64], f: &[f64]) -> f64 {
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

/// [`Surface::block2`] with each run of 8 coordinates of the 4 sums along the second axis
/// held in registers and each point summed from them.
///
/// # Safety
/// The CPU must support AVX-512F.
#[target_feature(enable = "avx512f")]
pub unsafe fn block2_avx512(
    s: &Surface,
    other: Option<&Surface>,
    lo: usize,
    p0: &[Option<f64>; 3],
    p1: &[Option<f64>; 3],
    fv: &mut [[f64; BLOCK_DIM]; 9],
    gv: &mut [[f64; BLOCK_DIM]; 9],
) {
    let n = s.shape[0] * s.shape[1];
    assert!(lo <= BLOCK_DIM && lo <= s.dim && other.is_none_or(|o| lo <= o.dim && o.coef.len() == s.coef.len() * o.dim / s.dim));
    let w0 = p0.map(|p| p.map(|t| s.splines[0].weights_d(t)));
    let w1 = p1.map(|p| p.map(|t| s.splines[1].weights_d(t)));
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
            let (k0, k1) = ([i0 * s.stride[0], j0 * s.stride[0]], [i1 * s.stride[1], j1 * s.stride[1]]);
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
            one(&s.coef, s.dim, fv);
            if let Some(o) = other {
                one(&o.coef, o.dim, gv);
            }
        }
    }
}

/// [`Surface::values2`] with each run of 8 coordinates summed over the 16 terms in one
/// register: the same products and sums in the same order (no fused multiply-add), so the
/// same bits.
///
/// # Safety
/// The CPU must support AVX-512F.
#[target_feature(enable = "avx512f")]
pub unsafe fn values2_avx512(s: &Surface, t: &[f64], f: &mut [f64], other: Option<(&Surface, &mut [f64])>) {
    let (at, wt) = s.terms2(t);
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
    sum(f, &s.coef, s.dim);
    if let Some((o, g)) = other {
        sum(g, &o.coef, o.dim);
    }
}
