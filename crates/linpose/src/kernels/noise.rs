//! Immerkaer's noise estimate ([`crate::pixel_noise`]) in AVX-512: the sums of the mask's
//! absolute responses along an image's sampled rows, f32 and 8-bit, with the portable bodies'
//! operations in the same order, so the same bits (and the same integers).

use super::Level;

/// A sampled row: its index among the sampled rows, with the rows above, at and below it.
pub(crate) type Sampled<'a, T> = (usize, &'a [T], &'a [T], &'a [T]);

/// An image: `w` pixels of `ch` channels a row, `h` rows, `len` values.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Image {
    pub w: usize,
    pub h: usize,
    pub ch: usize,
    pub len: usize,
}

/// What the 8-bit sums read of their row buffers: all ones for a row's responses (0 past them,
/// whole vectors of 32), and how many rows the 32 u32 lanes take between flushes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct RowsU8<'a> {
    pub keep: &'a [u16],
    pub flush_every: usize,
}

/// The sum of the absolute mask responses along the sampled rows (`sampled` makes them), each
/// row's sum into `sums[k]`, and how many rows, where `level` has AVX-512 and the image suits
/// the kernel (at least 3 x 3 pixels, at most 8 channels); `None` (nothing made or written)
/// otherwise.
#[inline(always)]
pub(crate) fn mask_sums_f32<'a, I: Iterator<Item = Sampled<'a, f32>>>(
    level: Level,
    image: Image,
    sampled: impl FnOnce() -> I,
    sums: &mut [f64],
) -> Option<(f64, usize)> {
    let Image { w, h, ch, len } = image;
    #[cfg(target_arch = "x86_64")]
    if level.avx512() && !(w < 3 || h < 3 || 2 * ch > 16 || len < w * ch * h) {
        // SAFETY: the level is a token of detection that found AVX-512 F and BW; the rows are
        // slices (of `w ch` values, as the kernel reads them) and `sums[k]` is bounds-checked.
        return Some(unsafe { simd::pixel_variance_avx512(w * ch, ch, sampled(), sums) });
    }
    let _ = (level, w, h, ch, len, sampled, sums);
    None
}

/// The exact sum of the absolute mask responses of an 8-bit image along the sampled rows
/// (`sampled` makes them), and how many rows, where `level` has AVX-512 with VL and the image
/// suits the kernel (at least 3 x 3 pixels, at most 16 channels); `None` (nothing made)
/// otherwise.
#[inline(always)]
pub(crate) fn mask_sums_u8<'a, I: Iterator<Item = Sampled<'a, u8>>>(
    level: Level,
    image: Image,
    sampled: impl FnOnce() -> I,
    rows: RowsU8<'_>,
) -> Option<(f64, usize)> {
    let Image { w, h, ch, len } = image;
    #[cfg(target_arch = "x86_64")]
    if level.avx512_vl() && !(w < 3 || h < 3 || 2 * ch > 32 || len < w * ch * h) {
        // SAFETY: the level is a token of detection that found AVX-512 F, BW and VL; the kernel
        // asserts the mask's length against the row.
        return Some(unsafe { simd::pixel_variance_u8_avx512(w * ch, ch, sampled(), rows) });
    }
    let _ = (level, w, h, ch, len, sampled, rows);
    None
}

/// The AVX-512 bodies.
#[cfg(target_arch = "x86_64")]
mod simd {
    use super::{RowsU8, Sampled};

    /// 0, 1, .., 63: the permutation indices of the shifted vectors, widened to each lane's
    /// width where they are loaded.
    static IOTA: [u8; 64] = {
        let mut v = [0u8; 64];
        let mut j = 0;
        while j < 64 {
            v[j] = j as u8;
            j += 1;
        }
        v
    };

    /// [`crate::pixel_noise`]'s `pixel_variance` in AVX-512 registers, whole image in one call, with the
    /// portable body's bits: per sampled row the differences across its rows, 16 pixels a
    /// vector, the next vector's too, and from the two the differences at offsets ch and 2 ch
    /// (a permutation across both, as in [`pixel_variance_u8_avx512`]); the responses'
    /// absolute values summed in 16 f32 lanes (lane l taking response l of each vector, the
    /// last one partial, as the portable row sums does), the lanes then added in f64.
    ///
    /// # Safety
    /// The CPU must support AVX-512 F and BW.
    #[target_feature(enable = "avx512f,avx512bw")]
    pub(crate) unsafe fn pixel_variance_avx512<'a>(row: usize, ch: usize, sampled: impl Iterator<Item = Sampled<'a, f32>>, sums: &mut [f64]) -> (f64, usize) {
        use std::arch::x86_64::*;
        let two = _mm512_set1_ps(2.0);
        macro_rules! diff {
            ($a:expr, $b:expr, $c:expr, $p:expr) => {{
                let p: usize = $p;
                let m = if p >= row { 0 } else { u16::MAX >> (16 - (row - p).min(16)) };
                let at = p.min(row);
                // SAFETY: masked to the row's values.
                let (av, bv, cv) =
                    unsafe { (_mm512_maskz_loadu_ps(m, $a.add(at)), _mm512_maskz_loadu_ps(m, $b.add(at)), _mm512_maskz_loadu_ps(m, $c.add(at))) };
                _mm512_add_ps(_mm512_sub_ps(av, _mm512_mul_ps(two, bv)), cv)
            }};
        }
        // Lane j of the shifted vectors: lane j + s of [cur, next].
        // SAFETY: 16 bytes from ch and from 2 ch lie within IOTA (2 ch <= 16).
        let (i1, i2) = unsafe {
            (
                _mm512_cvtepu8_epi32(_mm_loadu_si128(IOTA.as_ptr().add(ch) as *const _)),
                _mm512_cvtepu8_epi32(_mm_loadu_si128(IOTA.as_ptr().add(2 * ch) as *const _)),
            )
        };
        let n = row - 2 * ch;
        let (mut sum, mut count) = (0.0f64, 0usize);
        for (k, a, b, c) in sampled {
            let (a, b, c) = (a.as_ptr(), b.as_ptr(), c.as_ptr());
            let mut acc = _mm512_setzero_ps();
            let mut cur = diff!(a, b, c, 0);
            for q in (0..n).step_by(16) {
                let next = diff!(a, b, c, q + 16);
                let d1 = _mm512_permutex2var_ps(cur, i1, next);
                let d2 = _mm512_permutex2var_ps(cur, i2, next);
                let v = _mm512_add_ps(_mm512_sub_ps(cur, _mm512_mul_ps(two, d1)), d2);
                // The last vector's responses past n are 0 (adding 0 leaves a lane's sum).
                let keep = if q + 16 <= n { u16::MAX } else { u16::MAX >> (16 - (n - q)) };
                acc = _mm512_add_ps(acc, _mm512_maskz_mov_ps(keep, _mm512_abs_ps(v)));
                cur = next;
            }
            let mut lanes = [0f32; 16];
            // SAFETY: 16 f32.
            unsafe { _mm512_storeu_ps(lanes.as_mut_ptr(), acc) };
            let mut lane_sum = -0.0f64;
            for v in lanes {
                lane_sum += v as f64;
            }
            sums[k] = lane_sum;
            sum += lane_sum;
            count += 1;
        }
        (sum, count)
    }

    /// [`crate::pixel_noise`]'s `pixel_variance_u8_in` in AVX-512 BW registers, whole image in one call (a call
    /// per row cost as much as the row's 4 vectors at 128 pixels): per sampled row, the
    /// differences across its rows, 32 pixels a vector in i16 (0 past the row), the next
    /// vector's too, and from the two the differences at offsets ch and 2 ch (a permutation
    /// across both, in registers; written out and read back at those offsets, as the portable
    /// body does, each load waited on the store); the mask's responses' absolute values (0 past
    /// the row's responses) summed in
    /// pairs into 16 u32 lanes, flushed to u64 twice as often as `rows` says for its 32 lanes.
    /// The same integer sum, so the same value.
    ///
    /// # Safety
    /// The CPU must support AVX-512 F, BW and VL.
    #[target_feature(enable = "avx512f,avx512bw,avx512vl")]
    pub(crate) unsafe fn pixel_variance_u8_avx512<'a>(row: usize, ch: usize, sampled: impl Iterator<Item = Sampled<'a, u8>>, rows: RowsU8<'_>) -> (f64, usize) {
        use std::arch::x86_64::*;
        // (Macros, not closures: a closure does not take the function's target features, and
        // its intrinsics were called, not inlined.)
        macro_rules! diff {
            ($a:expr, $b:expr, $c:expr, $p:expr) => {{
                let p: usize = $p;
                let m = if p >= row { 0 } else { u32::MAX >> (32 - (row - p).min(32)) };
                let at = p.min(row);
                // SAFETY: masked to the row's pixels.
                let (av, bv, cv) = unsafe {
                    (
                        _mm512_cvtepu8_epi16(_mm256_maskz_loadu_epi8(m, $a.add(at) as *const i8)),
                        _mm512_cvtepu8_epi16(_mm256_maskz_loadu_epi8(m, $b.add(at) as *const i8)),
                        _mm512_cvtepu8_epi16(_mm256_maskz_loadu_epi8(m, $c.add(at) as *const i8)),
                    )
                };
                _mm512_sub_epi16(_mm512_add_epi16(av, cv), _mm512_add_epi16(bv, bv))
            }};
        }
        // Lane j of the shifted vectors: lane j + s of [cur, next] (from a constant: an index
        // array written on the stack stalled the vector load of it).
        // SAFETY: 32 bytes from ch and from 2 ch lie within IOTA (2 ch <= 32).
        let (i1, i2) = unsafe {
            (
                _mm512_cvtepu8_epi16(_mm256_loadu_si256(IOTA.as_ptr().add(ch) as *const _)),
                _mm512_cvtepu8_epi16(_mm256_loadu_si256(IOTA.as_ptr().add(2 * ch) as *const _)),
            )
        };
        let n32 = rows.keep.len();
        assert!(n32 >= row - 2 * ch && n32.is_multiple_of(32));
        // Each lane takes two responses a vector, twice the portable lanes' bound.
        let (mut acc, ones, flush_every) = (_mm512_setzero_si512(), _mm512_set1_epi16(1), (rows.flush_every / 2).max(1));
        let (mut total, mut since, mut count) = (0u64, 0usize, 0usize);
        for (_, a, b, c) in sampled {
            let (a, b, c) = (a.as_ptr(), b.as_ptr(), c.as_ptr());
            let mut cur = diff!(a, b, c, 0);
            for q in (0..n32).step_by(32) {
                let next = diff!(a, b, c, q + 32);
                let d1 = _mm512_permutex2var_epi16(cur, i1, next);
                let d2 = _mm512_permutex2var_epi16(cur, i2, next);
                let v = _mm512_abs_epi16(_mm512_sub_epi16(_mm512_add_epi16(cur, d2), _mm512_add_epi16(d1, d1)));
                // SAFETY: q + 32 <= n32 = keep.len().
                let v = _mm512_and_si512(v, unsafe { _mm512_loadu_si512(rows.keep.as_ptr().add(q) as *const _) });
                // Pairs of responses summed into i32 lanes (at most 4080 a vector).
                acc = _mm512_add_epi32(acc, _mm512_madd_epi16(v, ones));
                cur = next;
            }
            count += 1;
            since += 1;
            if since == flush_every {
                total += super::super::sum_u32_lanes(acc);
                (acc, since) = (_mm512_setzero_si512(), 0);
            }
        }
        total += super::super::sum_u32_lanes(acc);
        (total as f64, count)
    }
}
