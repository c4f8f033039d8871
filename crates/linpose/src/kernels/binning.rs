//! The 8-bit query path's block sums of gray images binned by 2 or 4 (and the sums of squares of
//! the sums and of the image) in AVX-512 BW: [`crate::binning::Binning::sums_energies_u8`]'s
//! exact integers, so the same values as its portable loop.

use super::Level;

/// A gray image of `w` pixels a row, binned by `factor` into `wb` x `hb` blocks.
#[derive(Debug, Clone, Copy)]
pub(crate) struct GrayBlocks {
    pub factor: usize,
    pub w: usize,
    pub wb: usize,
    pub hb: usize,
}

/// The block sums of the gray image `x` into `out` (at least `wb` x `hb` values; those past them
/// left alone), with their sum of squares and that of `x` itself, where `level` runs the AVX-512
/// BW body for the factor (2 or 4); `None` (nothing written) otherwise.
pub(crate) fn sums_energies(level: Level, blocks: GrayBlocks, x: &[u8], out: &mut [u16]) -> Option<(u64, u64)> {
    let GrayBlocks { factor, w, wb, hb } = blocks;
    #[cfg(target_arch = "x86_64")]
    if level.avx512() && factor == 2 {
        // SAFETY: the level is a token of detection that found AVX-512 F and BW; the body
        // asserts the lengths it reads and writes.
        return Some(unsafe { simd::sums_2x2_avx512(x, w, wb, hb, out) });
    }
    #[cfg(target_arch = "x86_64")]
    if level.avx512() && factor == 4 {
        // SAFETY: as above (AVX-512 F and BW detected, the lengths asserted by the body).
        return Some(unsafe { simd::sums_4x4_avx512(x, w, wb, hb, out) });
    }
    let _ = (level, factor, w, wb, hb, x, out);
    None
}

/// The squares of the pixels of a gray image `x` of width `w` outside its top-left `used_w` x
/// `used_h` pixels (those binning leaves out), summed.
#[cfg(target_arch = "x86_64")]
fn left_out_squares(x: &[u8], w: usize, used_w: usize, used_h: usize) -> u64 {
    let sq = |v: &[u8]| v.iter().map(|&p| p as u64 * p as u64).sum::<u64>();
    x.chunks_exact(w).take(used_h).map(|r| sq(&r[used_w..])).sum::<u64>() + sq(&x[used_h * w..])
}

#[cfg(target_arch = "x86_64")]
mod simd {
    use std::arch::x86_64::*;

    /// `acc` plus the squares of the 64 bytes of `v`, summed in fours into its 16 i32 lanes (at
    /// most 260,100 a lane a call).
    #[inline]
    #[target_feature(enable = "avx512f,avx512bw")]
    fn add_squares(acc: __m512i, v: __m512i) -> __m512i {
        let lo = _mm512_cvtepu8_epi16(_mm512_castsi512_si256(v));
        let hi = _mm512_cvtepu8_epi16(_mm512_extracti64x4_epi64::<1>(v));
        _mm512_add_epi32(acc, _mm512_add_epi32(_mm512_madd_epi16(lo, lo), _mm512_madd_epi16(hi, hi)))
    }

    /// The sum of the 16 u32 lanes of `v`, which are cleared.
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn take_lanes(v: &mut __m512i) -> u64 {
        let sum = crate::kernels::sum_u32_lanes(*v);
        *v = _mm512_setzero_si512();
        sum
    }

    /// Asks for the `b` input rows of the binned row 24 input rows below binned row `yo` (of
    /// `hb`) of an image of width `w` at `x`: one image is one stream, too slow for the hardware
    /// prefetcher alone when images come from memory.
    ///
    /// # Safety
    /// `x` holds at least (b hb) rows of `w` pixels.
    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn prefetch_ahead(x: &[u8], w: usize, b: usize, yo: usize, hb: usize) {
        if yo + 24 / b < hb {
            let ahead = x.as_ptr().add((b * yo + 24) * w);
            for off in (0..b * w).step_by(64) {
                _mm_prefetch::<_MM_HINT_T0>(ahead.add(off) as *const i8);
            }
        }
    }

    /// [`crate::binning::Binning::sums_energies_u8`] of a gray image of width `w` binned by 2 into `wb` x
    /// `hb`: per binned row, 64 pixels of each of its two rows a step, their adjacent pairs summed
    /// by `maddubs` (at most 510 in i16), the two rows' pair sums added (32 block sums of at most
    /// 1,020), written out, and squared in pairs into u32 lanes (at most 2,080,800 a lane a
    /// step; the image's own squares at most 520,200), added into u64 after whole rows of at
    /// most 2,048 steps in all (below 2^32 a lane; a row of at most 1,024 steps: asserted). A
    /// flush each row had cost a third of the kernel on COIL's rows of 2 steps.
    ///
    /// # Safety
    /// The CPU must support AVX-512 F and BW; `x` holds at least (2 hb) rows of `w` pixels, `w
    /// >= 2 wb`, and `out` at least `wb` x `hb` values.
    #[target_feature(enable = "avx512f,avx512bw")]
    pub(super) unsafe fn sums_2x2_avx512(x: &[u8], w: usize, wb: usize, hb: usize, out: &mut [u16]) -> (u64, u64) {
        let span = 2 * wb;
        assert!(w >= span && x.len() >= 2 * hb * w && out.len() >= wb * hb);
        assert!(span.div_ceil(64) <= 1024, "a row of at most 65,536 pixels");
        let ones = _mm512_set1_epi8(1);
        let (mut energy, mut energy_full) = (0u64, 0u64);
        let rows_per_flush = 2048 / span.div_ceil(64).max(1);
        let (mut sq, mut sq_full) = (_mm512_setzero_si512(), _mm512_setzero_si512());
        for yo in 0..hb {
            let (r0, r1) = (x.as_ptr().add(2 * yo * w), x.as_ptr().add((2 * yo + 1) * w));
            let out_row = out.as_mut_ptr().add(yo * wb);
            prefetch_ahead(x, w, 2, yo, hb);
            let mut p = 0;
            while p < span {
                // Pixels p.. of the step (64 or fewer), outputs p / 2.. (32 or fewer).
                let n = (span - p).min(64);
                let mask_in = if n == 64 { u64::MAX } else { (1u64 << n) - 1 };
                let mask_out = if n == 64 { u32::MAX } else { (1u32 << (n / 2)) - 1 };
                let a = _mm512_maskz_loadu_epi8(mask_in, r0.add(p) as *const i8);
                let b = _mm512_maskz_loadu_epi8(mask_in, r1.add(p) as *const i8);
                sq_full = add_squares(add_squares(sq_full, a), b);
                let s = _mm512_add_epi16(_mm512_maddubs_epi16(a, ones), _mm512_maddubs_epi16(b, ones));
                let o = p / 2;
                _mm512_mask_storeu_epi16(out_row.add(o) as *mut i16, mask_out, s);
                // Lanes past the row's outputs hold 0 (masked loads), so they add nothing.
                sq = _mm512_add_epi32(sq, _mm512_madd_epi16(s, s));
                p += 64;
            }
            if (yo + 1) % rows_per_flush == 0 || yo + 1 == hb {
                energy += take_lanes(&mut sq);
                energy_full += take_lanes(&mut sq_full);
            }
        }
        // The pixels the blocks leave out (a last column or row) count in the image's energy.
        (energy, energy_full + super::left_out_squares(x, w, 2 * wb, 2 * hb))
    }

    /// [`crate::binning::Binning::sums_energies_u8`] of a gray image of width `w` binned by 4 into `wb` x
    /// `hb`: per binned row, 64 pixels of each of its four rows a step, their adjacent pairs
    /// summed by `maddubs` (at most 510 in i16), the four rows' pair sums added (at most 2,040),
    /// adjacent pairs of those summed by `madd` into i32 (16 block sums of at most 4,080),
    /// written out as 16-bit values, and squared into u32 lanes (at most 16,646,400 a lane a
    /// step; the image's own squares at most 1,040,400), added into u64 after whole rows of at
    /// most 256 steps in all (below 2^32 a lane; a row of at most 128 steps: asserted).
    ///
    /// # Safety
    /// As [`sums_2x2_avx512`], with (4 hb) rows and `w >= 4 wb`.
    #[target_feature(enable = "avx512f,avx512bw")]
    pub(super) unsafe fn sums_4x4_avx512(x: &[u8], w: usize, wb: usize, hb: usize, out: &mut [u16]) -> (u64, u64) {
        let span = 4 * wb;
        assert!(w >= span && x.len() >= 4 * hb * w && out.len() >= wb * hb);
        assert!(span.div_ceil(64) <= 128, "a row of at most 8,192 pixels");
        let (ones8, ones16) = (_mm512_set1_epi8(1), _mm512_set1_epi16(1));
        let (mut energy, mut energy_full) = (0u64, 0u64);
        let rows_per_flush = 256 / span.div_ceil(64).max(1);
        let (mut sq, mut sq_full) = (_mm512_setzero_si512(), _mm512_setzero_si512());
        for yo in 0..hb {
            let r = x.as_ptr().add(4 * yo * w);
            let out_row = out.as_mut_ptr().add(yo * wb);
            prefetch_ahead(x, w, 4, yo, hb);
            let mut p = 0;
            while p < span {
                let n = (span - p).min(64);
                let mask_in = if n == 64 { u64::MAX } else { (1u64 << n) - 1 };
                let mask_out = if n == 64 { u16::MAX } else { (1u16 << (n / 4)) - 1 };
                let mut pairs = _mm512_setzero_si512();
                for k in 0..4 {
                    let v = _mm512_maskz_loadu_epi8(mask_in, r.add(k * w + p) as *const i8);
                    sq_full = add_squares(sq_full, v);
                    pairs = _mm512_add_epi16(pairs, _mm512_maddubs_epi16(v, ones8));
                }
                let q = _mm512_madd_epi16(pairs, ones16);
                let o = p / 4;
                // (A 512-bit store of the low half: the 256-bit masked store needs AVX-512 VL.)
                _mm512_mask_storeu_epi16(out_row.add(o) as *mut i16, mask_out as u32, _mm512_castsi256_si512(_mm512_cvtepi32_epi16(q)));
                sq = _mm512_add_epi32(sq, _mm512_mullo_epi32(q, q));
                p += 64;
            }
            if (yo + 1) % rows_per_flush == 0 || yo + 1 == hb {
                energy += take_lanes(&mut sq);
                energy_full += take_lanes(&mut sq_full);
            }
        }
        // The pixels the blocks leave out (a last column or row) count in the image's energy.
        (energy, energy_full + super::left_out_squares(x, w, 4 * wb, 4 * hb))
    }
}
