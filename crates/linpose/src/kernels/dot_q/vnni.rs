//! The AVX-512 VNNI kernels of the fixed-point products: one image against up to 8 rows
//! ([`sums_vnni`]), and groups of register blocks of images ([`group_vnni`]), each `vpdpbusd`
//! multiplying 64 pixels by one digit row.

// Register blocks index several arrays (accumulators, loaded vectors) by the same loop variables.
#![allow(clippy::needless_range_loop)]

use super::{radix, Line, QuantRows, BLOCK, CHUNK, DIGITS, GROUP, SPAN, STEP, TILE};
use std::arch::x86_64::*;

/// One step of 64 pixels of `x` from pixel p (pixels past m read as zero).
///
/// # Safety
/// The CPU must support AVX-512 F and BW (this is inlined into kernels that enable them);
/// `x` must be valid for reads of pixels p..m, p < m.
#[inline(always)]
unsafe fn load_step(x: *const u8, p: usize, m: usize) -> __m512i {
    if p + STEP <= m {
        _mm512_loadu_si512(x.add(p) as *const _)
    } else {
        _mm512_maskz_loadu_epi8(u64::MAX >> (STEP - (m - p)), x.add(p) as *const i8)
    }
}

/// Blocks of BLOCK images (at most GROUP of them): the products of every image and row into
/// `out` (image-major), the sums of squares into `energy`.
///
/// # Safety
/// The CPU must support AVX-512 F, BW and VNNI.
#[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
pub(super) unsafe fn group_vnni(xs: &[u8], q: &QuantRows, out: &mut [f32], energy: &mut [u64], scratch: &mut Vec<i32>) {
    let (m, rows) = (q.m, q.rows);
    let nb = xs.len() / (BLOCK * m);
    assert!(nb <= GROUP && xs.len() == nb * BLOCK * m && out.len() == nb * BLOCK * rows && energy.len() == nb * BLOCK && m.div_ceil(STEP) <= SPAN);
    // Lane sums: [block][row][image][digit][16].
    let per_row = BLOCK * DIGITS * 16;
    scratch.clear();
    scratch.resize(nb * rows * per_row, 0);
    let acc = scratch.as_mut_ptr();
    let mut sq = [_mm512_setzero_si512(); BLOCK * GROUP];
    let steps = m.div_ceil(STEP);
    let xp = xs.as_ptr();
    // The chunk's images, copied to 64-byte boundaries (zero past m): [image][step][64].
    let mut stage = [Line([0; STEP]); GROUP * BLOCK * CHUNK];
    let sp = stage.as_mut_ptr() as *mut u8;
    for c0 in (0..steps).step_by(CHUNK) {
        let c1 = (c0 + CHUNK).min(steps);
        let mut masks = [0u32; GROUP];
        // Step by step across the images, so that the squares' sums (one chain per image)
        // interleave.
        for (g, mask) in masks[..nb].iter_mut().enumerate() {
            let sq = &mut sq[g * BLOCK..(g + 1) * BLOCK];
            for c in c0..c1 {
                let mut any = 0u64;
                for (b, sq) in sq.iter_mut().enumerate() {
                    let v = load_step(xp.add((g * BLOCK + b) * m), c * STEP, m);
                    _mm512_store_si512(sp.add((((g * BLOCK + b) * CHUNK) + c - c0) * STEP) as *mut _, v);
                    any |= _mm512_test_epi8_mask(v, v);
                    let lo = _mm512_cvtepu8_epi16(_mm512_castsi512_si256(v));
                    let hi = _mm512_cvtepu8_epi16(_mm512_extracti64x4_epi64::<1>(v));
                    *sq = _mm512_dpwssd_epi32(_mm512_dpwssd_epi32(*sq, lo, lo), hi, hi);
                }
                *mask |= ((any != 0) as u32) << (c - c0);
            }
        }
        for r in 0..rows {
            for (g, &mask) in masks[..nb].iter().enumerate() {
                if mask != 0 {
                    row_block(sp.add(g * BLOCK * CHUNK * STEP), q, r, c0, mask, acc.add((g * rows + r) * per_row));
                }
            }
        }
    }
    for i in 0..nb * BLOCK {
        let (g, b) = (i / BLOCK, i % BLOCK);
        // Per lane at most 1024 steps of 4 squares of at most 65,025 (below 2^31), and
        // 65,536 x 65,025 in all (below 2^32: the wrapped i32 sum read as u32 is exact). The
        // products' lanes take at most 1024 steps of 4 x 255 x 128 (below 2^31).
        energy[i] = _mm512_reduce_add_epi32(sq[i]) as u32 as u64;
        for r in 0..rows {
            // A loop, not an iterator's sum over a closure: the compiler did not always inline
            // the closure (the sum is of integers: exact in any order).
            let mut s = 0i64;
            for k in 0..DIGITS {
                s += radix(k) * lanes_i64(_mm512_loadu_si512(scratch.as_ptr().add((g * rows + r) * per_row + (b * DIGITS + k) * 16) as *const _));
            }
            out[i * rows + r] = (s as f64 * q.scale[r]) as f32;
        }
    }
}

/// Row r against the block's images over the steps c0 + (bits of `mask`), added to the lane
/// sums at `acc` ([image][digit][16]).
///
/// # Safety
/// The CPU must support AVX-512 F, BW and VNNI (this is inlined into [`group_vnni`]); `sp`
/// must hold BLOCK images of CHUNK steps of 64 bytes on 64-byte boundaries, the steps c0 +
/// (bits of `mask`) must lie within row r's tiled digits, and `acc` must hold BLOCK *
/// DIGITS * 16 lanes.
#[inline(always)]
unsafe fn row_block(sp: *const u8, q: &QuantRows, r: usize, c0: usize, mask: u32, acc: *mut i32) {
    let dp = q.digits().as_ptr().add(q.at(r, 0, c0 * STEP));
    let mut a = [[_mm512_setzero_si512(); DIGITS]; BLOCK];
    for b in 0..BLOCK {
        for k in 0..DIGITS {
            a[b][k] = _mm512_loadu_si512(acc.add((b * DIGITS + k) * 16) as *const _);
        }
    }
    let mut left = mask;
    while left != 0 {
        let p = left.trailing_zeros() as usize * STEP;
        left &= left - 1;
        let w: [__m512i; DIGITS] = std::array::from_fn(|k| _mm512_load_si512(dp.add(k * TILE + p) as *const _));
        for b in 0..BLOCK {
            let v = _mm512_load_si512(sp.add(b * CHUNK * STEP + p) as *const _);
            for k in 0..DIGITS {
                a[b][k] = _mm512_dpbusd_epi32(a[b][k], v, w[k]);
            }
        }
    }
    for b in 0..BLOCK {
        for k in 0..DIGITS {
            _mm512_storeu_si512(acc.add((b * DIGITS + k) * 16) as *mut _, a[b][k]);
        }
    }
}

/// The exact sums of rows r0..r0 + s.len() (at most 8) against one image.
///
/// # Safety
/// The CPU must support AVX-512 F, BW and VNNI.
#[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
pub(super) unsafe fn sums_vnni(x: &[u8], q: &QuantRows, r0: usize, s: &mut [i64]) {
    match s.len() {
        1 => rows_vnni::<1>(x, q, r0, s),
        2 => rows_vnni::<2>(x, q, r0, s),
        3 => rows_vnni::<3>(x, q, r0, s),
        4 => rows_vnni::<4>(x, q, r0, s),
        5 => rows_vnni::<5>(x, q, r0, s),
        6 => rows_vnni::<6>(x, q, r0, s),
        7 => rows_vnni::<7>(x, q, r0, s),
        _ => rows_vnni::<8>(x, q, r0, s),
    }
}

/// The sum of the 16 i32 lanes of `a` in i64.
///
/// # Safety
/// The CPU must support AVX-512F (this is inlined into kernels that enable it).
#[inline(always)]
unsafe fn lanes_i64(a: __m512i) -> i64 {
    let lo = _mm512_cvtepi32_epi64(_mm512_castsi512_si256(a));
    let hi = _mm512_cvtepi32_epi64(_mm512_extracti64x4_epi64::<1>(a));
    _mm512_reduce_add_epi64(_mm512_add_epi64(lo, hi))
}

/// [`sums_vnni`] for R rows: per step of 64 pixels (skipped where the image is black), one
/// `vpdpbusd` per row and digit, the i32 lanes added into i64 every [`SPAN`] steps.
///
/// # Safety
/// The CPU must support AVX-512 F, BW and VNNI.
#[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
unsafe fn rows_vnni<const R: usize>(x: &[u8], q: &QuantRows, r0: usize, s: &mut [i64]) {
    let m = q.m;
    assert!(x.len() == m && s.len() == R && r0 + R <= q.rows);
    let dp = q.digits().as_ptr();
    let steps = m.div_ceil(STEP);
    let mut tot = [0i64; R];
    for s0 in (0..steps).step_by(SPAN) {
        let mut acc = [[_mm512_setzero_si512(); DIGITS]; R];
        for c in s0..(s0 + SPAN).min(steps) {
            let p = c * STEP;
            // The last step's pixels past m read as zero (the digits there are zero too).
            let xv = if p + STEP <= m {
                _mm512_loadu_si512(x.as_ptr().add(p) as *const _)
            } else {
                _mm512_maskz_loadu_epi8(u64::MAX >> (STEP - (m - p)), x.as_ptr().add(p) as *const i8)
            };
            if _mm512_test_epi8_mask(xv, xv) == 0 {
                continue;
            }
            for r in 0..R {
                for k in 0..DIGITS {
                    let w = _mm512_loadu_si512(dp.add(q.at(r0 + r, k, p)) as *const _);
                    acc[r][k] = _mm512_dpbusd_epi32(acc[r][k], xv, w);
                }
            }
        }
        for r in 0..R {
            tot[r] += (0..DIGITS).map(|k| radix(k) * lanes_i64(acc[r][k])).sum::<i64>();
        }
    }
    s.copy_from_slice(&tot);
}
