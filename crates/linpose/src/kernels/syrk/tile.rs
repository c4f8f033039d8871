//! The f64 micro-kernel: one (8 Q) x 8 tile of C over one packed panel, in AVX-512 intrinsics
//! (8 Q accumulators, per step Q loads and 8 broadcasts), in AVX2 intrinsics for the 24 x 8
//! tile (sub-tiles of 6 x 8 with 12 accumulators, as many as 16 registers hold beside the
//! loads), or the portable body built for the level (the same fused multiply-adds in the same
//! order, so the same bits).

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
    #[cfg(target_arch = "x86_64")]
    if Q == 3 && level.avx2() {
        // SAFETY: the level is a token of detection that found AVX2 and FMA; the kernel asserts
        // the lengths it reads and writes.
        return unsafe { x86::tile24_avx2(a, b, kc, out, ld) };
    }
    tile_built::<Q>(level, a, b, kc, out, ld)
}

dispatch! {
    /// [`tile_portable`] at `level`, for the tiles the intrinsics kernels do not serve (on AVX2,
    /// the 8 and 16 rows that finish a column: split in 6-row sub-tiles, their last would have
    /// too few accumulators to be faster than these 8 x 4 ones).
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
    pub(super) unsafe fn tile_avx512<const Q: usize>(a: &[f64], b: &[f64], kc: usize, out: &mut [f64], ld: usize) {
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

    /// [`super::tile`] for Q = 3 in AVX2 registers, transposed: the 24 x 8 tile as four 6 x 8
    /// sub-tiles, each over the whole panel with 12 accumulators (a row's 8 columns in two
    /// vectors), per step 2 loads of the 8 columns and 6 broadcasts of the rows; the sums are
    /// turned round into C once per panel. (The portable body's 8 x 4 sub-tiles keep 8
    /// accumulators, too few to cover the fused multiply-add's latency at two a cycle; 12 x 4
    /// ones need 17 registers with their loads, and the spilled one then waits on memory.)
    /// Each element is the same sequential fused sum as the other kernels' (the product's
    /// operands in the same order), so the same bits.
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA; `a` holds 24 * kc values, `b` 8 * kc, `out` 7 * ld + 24.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn tile24_avx2(a: &[f64], b: &[f64], kc: usize, out: &mut [f64], ld: usize) {
        assert!(a.len() >= 3 * GROUP * kc && b.len() >= GROUP * kc && out.len() >= 7 * ld + 3 * GROUP);
        let (a0, b0, o) = (a.as_ptr(), b.as_ptr(), out.as_mut_ptr());
        for s in 0..4 {
            // Row r of the tile is row r % 8 of packed group r / 8.
            let rows: [usize; 6] = std::array::from_fn(|i| (6 * s + i) / GROUP * GROUP * kc + (6 * s + i) % GROUP);
            let mut acc = [[_mm256_setzero_pd(); 2]; 6];
            for k in 0..kc {
                let y = [_mm256_loadu_pd(b0.add(k * GROUP)), _mm256_loadu_pd(b0.add(k * GROUP + 4))];
                for i in 0..6 {
                    let x = _mm256_broadcast_sd(&*a0.add(rows[i] + k * GROUP));
                    for h in 0..2 {
                        acc[i][h] = _mm256_fmadd_pd(x, y[h], acc[i][h]);
                    }
                }
            }
            let mut t = [[0f64; GROUP]; 6];
            for i in 0..6 {
                for h in 0..2 {
                    _mm256_storeu_pd(t[i].as_mut_ptr().add(4 * h), acc[i][h]);
                }
            }
            for c in 0..GROUP {
                for i in 0..6 {
                    *o.add(c * ld + 6 * s + i) += t[i][c];
                }
            }
        }
    }
}
