//! The noisy match's affine fit ([`crate::methods::refined::noisy::AffineQuery`]): its five
//! weighted sums over a surface point and its offset, 8 lanes at a time in AVX-512 (the portable
//! body's operations in the same order, so the same bits).

use super::surface::BLOCK_DIM;
use super::Level;

/// A query held in lanes: `n` values (a multiple of 8, zero weight beyond the coordinates) of w z,
/// c and w.
#[derive(Debug, Clone, Copy)]
pub(crate) struct AffineLanes<'a> {
    pub n: usize,
    pub wz: &'a [f64; BLOCK_DIM],
    pub c: &'a [f64; BLOCK_DIM],
    pub w: &'a [f64; BLOCK_DIM],
}

/// The sums (m.m, m.g, g.g, z.m, z.g) weighted, m = f + c, of the query `q` against the surface
/// point `f` and offset `g`, where `level` runs AVX-512; `None` otherwise.
#[inline]
pub(crate) fn sums(level: Level, q: AffineLanes<'_>, f: &[f64], g: &[f64]) -> Option<[f64; 5]> {
    #[cfg(target_arch = "x86_64")]
    if level.avx512() {
        // SAFETY: the level is a token of detection that found AVX-512F; the kernel asserts the
        // lengths it reads.
        return Some(unsafe { simd::affine_sums_avx512(q, f, g) });
    }
    let _ = (level, q, f, g);
    None
}

#[cfg(target_arch = "x86_64")]
mod simd {
    use super::BLOCK_DIM;
    use crate::kernels::surface::simd::lanes_sum;
    use std::arch::x86_64::*;

    /// [`crate::methods::refined::noisy::AffineQuery::residual`]'s five weighted sums compiled for
    /// AVX-512, the lanes of each added in order.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn affine_sums_avx512(q: super::AffineLanes<'_>, f: &[f64], g: &[f64]) -> [f64; 5] {
        let n = q.n;
        assert!(f.len() >= n && g.len() >= n && n <= BLOCK_DIM, "{n} values, zero beyond the coordinates");
        let mut acc = [_mm512_setzero_pd(); 5];
        for k in (0..n).step_by(8) {
            // SAFETY: k + 8 <= n, within f, g and the query's arrays of BLOCK_DIM (asserted).
            let (fk, gk, c, w, wz) = unsafe {
                (
                    _mm512_loadu_pd(f.as_ptr().add(k)),
                    _mm512_loadu_pd(g.as_ptr().add(k)),
                    _mm512_loadu_pd(q.c.as_ptr().add(k)),
                    _mm512_loadu_pd(q.w.as_ptr().add(k)),
                    _mm512_loadu_pd(q.wz.as_ptr().add(k)),
                )
            };
            // The portable body's operations, lane by lane.
            let m = _mm512_add_pd(fk, c);
            let (wm, wg) = (_mm512_mul_pd(w, m), _mm512_mul_pd(w, gk));
            acc[0] = _mm512_add_pd(acc[0], _mm512_mul_pd(wm, m));
            acc[1] = _mm512_add_pd(acc[1], _mm512_mul_pd(wm, gk));
            acc[2] = _mm512_add_pd(acc[2], _mm512_mul_pd(wg, gk));
            acc[3] = _mm512_add_pd(acc[3], _mm512_mul_pd(wz, m));
            acc[4] = _mm512_add_pd(acc[4], _mm512_mul_pd(wz, gk));
        }
        acc.map(|v| lanes_sum(v))
    }
}
