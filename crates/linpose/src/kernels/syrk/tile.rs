//! The f64 micro-kernel: one (8 Q) x 8 tile of C over one packed panel, in AVX-512 intrinsics
//! (8 Q accumulators, per step Q loads and 8 broadcasts) or the portable body built for the
//! level (the same fused multiply-adds in the same order, so the same bits).

use super::GROUP;
use crate::kernels::{dispatch, Level};

/// out[c * ld + r] += sum_k a[r][k] b[c][k] for the (8 Q) x 8 tile (a: Q packed groups, b: one);
/// Q = 3 is the 24 x 8 tile, 1 and 2 finish a column of tiles that is not a multiple of 24 rows.
#[inline]
pub(in crate::kernels) fn tile<const Q: usize>(level: Level, a: &[f64], b: &[f64], kc: usize, out: &mut [f64], ld: usize) {
    debug_assert!(a.len() == Q * GROUP * kc && b.len() == GROUP * kc && out.len() >= 7 * ld + Q * GROUP);
    #[cfg(target_arch = "x86_64")]
    if level.avx512() {
        // SAFETY: the level is a token of detection that found AVX-512F; the kernel asserts the
        // lengths it reads and writes.
        return unsafe { x86::tile_avx512::<Q>(a, b, kc, out, ld) };
    }
    tile_built::<Q>(level, a, b, kc, out, ld)
}

dispatch! {
    /// [`tile_portable`] at `level` (where the intrinsics kernel does not serve it).
    fn tile_built<const Q: usize>(a: &[f64], b: &[f64], kc: usize, out: &mut [f64], ld: usize) = tile_portable;
}

/// The portable micro-kernel: the tile as 8 x 4 sub-tiles (few enough accumulators for 16
/// registers); per element the same fused operations in the same order as the AVX-512 kernel.
#[inline(always)]
fn tile_portable<const Q: usize>(a: &[f64], b: &[f64], kc: usize, out: &mut [f64], ld: usize) {
    for q in 0..Q {
        let aq = &a[q * GROUP * kc..(q + 1) * GROUP * kc];
        for h in 0..2 {
            let mut acc = [[0f64; GROUP]; 4];
            for (x, y) in aq.chunks_exact(GROUP).zip(b.chunks_exact(GROUP)) {
                for c in 0..4 {
                    let yc = y[h * 4 + c];
                    for l in 0..GROUP {
                        acc[c][l] = x[l].mul_add(yc, acc[c][l]);
                    }
                }
            }
            for c in 0..4 {
                let o = &mut out[(h * 4 + c) * ld + q * GROUP..(h * 4 + c) * ld + (q + 1) * GROUP];
                o.iter_mut().zip(&acc[c]).for_each(|(o, &v)| *o += v);
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
// The register tile indexes the accumulators and the loaded vectors by the same loop variables.
#[allow(clippy::needless_range_loop)]
mod x86 {
    use super::GROUP;
    use std::arch::x86_64::*;

    /// [`super::tile`] in registers: 8 Q accumulators, per step Q loads and 8 broadcasts. The
    /// tile's lines of C are prefetched first, so that they arrive while the sums run.
    ///
    /// # Safety
    /// The CPU must support AVX-512F; `a` holds Q * 8 * kc values, `b` 8 * kc, `out` 7 * ld + 8 Q.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn tile_avx512<const Q: usize>(a: &[f64], b: &[f64], kc: usize, out: &mut [f64], ld: usize) {
        assert!(a.len() >= Q * GROUP * kc && b.len() >= GROUP * kc && out.len() >= 7 * ld + Q * GROUP);
        let (a0, b0, o) = (a.as_ptr(), b.as_ptr(), out.as_mut_ptr());
        for c in 0..8 {
            for q in 0..Q {
                _mm_prefetch::<_MM_HINT_T0>(o.add(c * ld + q * 8) as *const i8);
            }
        }
        let mut acc = [[_mm512_setzero_pd(); 8]; Q];
        for k in 0..kc {
            let mut x = [_mm512_setzero_pd(); Q];
            for q in 0..Q {
                x[q] = _mm512_loadu_pd(a0.add(q * GROUP * kc + k * 8));
            }
            for c in 0..8 {
                let y = _mm512_set1_pd(*b0.add(k * 8 + c));
                for q in 0..Q {
                    acc[q][c] = _mm512_fmadd_pd(x[q], y, acc[q][c]);
                }
            }
        }
        for c in 0..8 {
            for q in 0..Q {
                let p = o.add(c * ld + q * 8);
                _mm512_storeu_pd(p, _mm512_add_pd(_mm512_loadu_pd(p), acc[q][c]));
            }
        }
    }
}
