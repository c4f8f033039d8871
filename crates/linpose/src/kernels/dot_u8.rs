//! Products of one 8-bit image with a few f32 weight rows, accumulated in f32: the whole cost of
//! a linear-model query (K rows) and of an eigenspace projection (L rows).
//!
//! Every path computes, per row, 16 lane accumulators (lane l takes pixels l, l + 16, ...) by
//! fused multiply-adds in pixel order, then the same fixed pairwise sum of the 16 lanes, so the
//! AVX-512, AVX2 and portable paths give bit-identical results.
//!
//! A vector step whose 16 pixels are all zero (the black background of a turntable image) adds
//! `0 * w = ±0` to every accumulator, which leaves it unchanged (the weights are finite: every
//! model checks its weights on load, and an accumulator that starts at +0 never becomes -0 by
//! adding ±0), so every path skips such steps, and the weights they would have read. That is
//! exact, not an approximation: the sums are the bits of the dense ones (tested).

use super::tuning::dot_u8::{BATCH_GROUP, PIXEL_CHUNK};
use super::{dispatch, Level};

/// Pixels per vector step.
const LANES: usize = 16;
/// Weight rows per pass over the image (accumulators kept in registers).
const MAX_ROWS: usize = 8;
/// [`MAX_ROWS`] on AVX2 (16 registers of 8 lanes: 8 accumulators, the image's two vectors and
/// the weights).
const MAX_ROWS_AVX2: usize = 4;

/// `out[r] = sum_p x[p] * w[r * m + p]` for every row r (`out.len()` rows), m = `x.len()`.
#[track_caller]
pub(crate) fn dots(level: Level, x: &[u8], w: &[f32], out: &mut [f32]) {
    let m = x.len();
    assert_eq!(w.len(), m * out.len(), "weight rows of the image's length");
    // AVX2 has half AVX-512's registers, and a row's 16 lanes take two: at most 4 rows a pass
    // keep the accumulators in registers (each row's sums are the same whatever the pass).
    let per = if level.avx512() || !level.avx2() { MAX_ROWS } else { MAX_ROWS_AVX2 };
    for (rows, o) in w.chunks(m * per).zip(out.chunks_mut(per)) {
        match o.len() {
            1 => pass::<1>(level, x, rows, o),
            2 => pass::<2>(level, x, rows, o),
            3 => pass::<3>(level, x, rows, o),
            4 => pass::<4>(level, x, rows, o),
            5 => pass::<5>(level, x, rows, o),
            6 => pass::<6>(level, x, rows, o),
            7 => pass::<7>(level, x, rows, o),
            _ => pass::<8>(level, x, rows, o),
        }
    }
}

/// Images per register block of [`dots_batch`]: with [`BATCH_ROWS`] weight rows, 24 of the 32
/// AVX-512 registers accumulate.
pub(crate) const BATCH_IMAGES: usize = 6;
/// Weight rows per register block of [`dots_batch`].
pub(crate) const BATCH_ROWS: usize = 4;
/// Images per register block of [`dots_batch`]'s AVX2 kernel, which takes [`BATCH_IMAGES`] in
/// two such blocks (16 registers: 3 images by 4 rows of 8-lane accumulators, 3 image vectors and
/// a weight vector).
const AVX2_IMAGES: usize = 3;
/// Weight rows per register block of [`dots_batch`]'s AVX2 kernel.
const AVX2_ROWS: usize = 4;
const _: () = assert!(BATCH_IMAGES.is_multiple_of(AVX2_IMAGES));

// A cache block's steps fit the u32 masks of nonzero steps.
const _: () = assert!(PIXEL_CHUNK.is_multiple_of(LANES) && PIXEL_CHUNK / LANES <= 32);

/// [`dots`] for several images at once: `out[i * rows + r] = sum_p xs[i * m + p] * w[r * m + p]`,
/// `rows = w.len() / m`, and each image's [`sum_squares`] into `energy`. Bit-identical to
/// calling [`dots`] and [`sum_squares`] image by image (each product is summed in the same lanes
/// in the same order). On AVX-512 and AVX2 the work goes in cache blocks of [`PIXEL_CHUNK`]
/// pixels of [`BATCH_GROUP`] images (converted to f32 once, into 64-byte aligned `scratch`,
/// resized as needed) and every row, and within them in register blocks: on AVX-512 6 images by
/// 4 rows (a weight vector loaded serves 6 images, an image vector 4 rows), on AVX2, with half
/// the registers of half the width, 3 images by 4 rows, each half of the 16 lanes in turn. The
/// weights are read from the outer caches once per group. That makes a batch compute-bound; one
/// image at a time is bound by reading all the weights once per image. Images past the last
/// whole block of [`BATCH_IMAGES`] go one at a time.
#[track_caller]
pub(crate) fn dots_batch(level: Level, xs: &[u8], m: usize, w: &[f32], out: &mut [f32], energy: &mut [u64], scratch: &mut Vec<f32>) {
    assert!(m > 0 && xs.len().is_multiple_of(m) && w.len().is_multiple_of(m), "whole images and weight rows of length m");
    let (n, rows) = (xs.len() / m, w.len() / m);
    assert_eq!(out.len(), n * rows, "one output per image and row");
    assert_eq!(energy.len(), n, "one energy per image");
    let mut done = 0;
    #[cfg(target_arch = "x86_64")]
    if level.avx2() && rows > 0 {
        done = n / BATCH_IMAGES * BATCH_IMAGES;
        for ((xg, og), eg) in xs[..done * m].chunks(BATCH_GROUP * m).zip(out.chunks_mut(BATCH_GROUP * rows)).zip(energy.chunks_mut(BATCH_GROUP)) {
            let g = xg.len() / m;
            // Weights already on 64-byte boundaries (every row too) are read in place; others are
            // copied block by block.
            let in_place = w.as_ptr().align_offset(64) == 0 && m.is_multiple_of(LANES);
            let (xlen, wlen, alen) = (g * PIXEL_CHUNK, if in_place { 0 } else { rows * PIXEL_CHUNK }, g * rows * LANES);
            scratch.resize(xlen + wlen + alen + LANES, 0.0);
            let skip = scratch.as_ptr().align_offset(64).min(LANES);
            let (xf, rest) = scratch[skip..].split_at_mut(xlen);
            let (wf, acc) = rest.split_at_mut(wlen);
            acc.fill(0.0);
            let steps = m / LANES;
            let mut sq = [0u64; BATCH_GROUP];
            let mut nonzero = [0u32; BATCH_GROUP];
            for c0 in (0..steps).step_by(PIXEL_CHUNK / LANES) {
                let (p0, p1) = (c0 * LANES, ((c0 + PIXEL_CHUNK / LANES).min(steps)) * LANES);
                let pc = p1 - p0;
                // The lines of each image two blocks ahead, into the L2 cache: one stream per
                // image is more than the hardware prefetcher follows, and one block ahead would
                // arrive too late for the widening's loads.
                let ahead = (p1 + PIXEL_CHUNK..(p1 + 2 * PIXEL_CHUNK).min(m)).step_by(64);
                for (((f, x), sq), nz) in xf.chunks_exact_mut(PIXEL_CHUNK).zip(xg.chunks_exact(m)).zip(&mut sq).zip(&mut nonzero) {
                    let (s, z) = if level.avx512() {
                        // SAFETY: the level is a token of detection that found AVX-512 F and BW;
                        // both slices hold pc <= PIXEL_CHUNK values, a multiple of 16.
                        unsafe { x86::widen_avx512(&x[p0..p1], &mut f[..pc]) }
                    } else {
                        // SAFETY: the level is a token of detection that found AVX2 (checked
                        // above); both slices hold pc <= PIXEL_CHUNK values, a multiple of 16.
                        unsafe { x86::widen_avx2(&x[p0..p1], &mut f[..pc]) }
                    };
                    (*sq, *nz) = (*sq + s as u64, z);
                    for p in ahead.clone() {
                        x86::prefetch(x.as_ptr().wrapping_add(p));
                    }
                }
                let (wb, stride): (&[f32], usize) = if in_place {
                    (&w[p0..], m)
                } else {
                    for (f, wr) in wf.chunks_exact_mut(PIXEL_CHUNK).zip(w.chunks_exact(m)) {
                        f[..pc].copy_from_slice(&wr[p0..p1]);
                    }
                    (wf, PIXEL_CHUNK)
                };
                for ((xb, ab), nz) in
                    xf.chunks_exact(BATCH_IMAGES * PIXEL_CHUNK).zip(acc.chunks_exact_mut(BATCH_IMAGES * rows * LANES)).zip(nonzero.chunks_exact(BATCH_IMAGES))
                {
                    // The steps where any of the block's images has a nonzero pixel.
                    let steps = nz.iter().fold(0, |a, &z| a | z);
                    if steps == 0 {
                        continue;
                    }
                    if level.avx512() {
                        // SAFETY: AVX-512F was detected (the level); the blocks hold
                        // BATCH_IMAGES images of PIXEL_CHUNK values and `rows` weight rows
                        // `stride` apart, all from 64-byte boundaries, and the steps lie below
                        // pc / 16 <= PIXEL_CHUNK / 16 (checked in the kernel).
                        unsafe { x86::block_avx512(xb, wb, stride, rows, pc / LANES, steps, ab) };
                    } else {
                        // SAFETY: AVX2 and FMA were detected (the level, checked above); the
                        // blocks are those above (the AVX2 kernel needs no alignment).
                        unsafe { x86::block_avx2(xb, wb, stride, rows, pc / LANES, steps, ab) };
                    }
                }
            }
            for (b, ((x, o), e)) in xg.chunks_exact(m).zip(og.chunks_exact_mut(rows)).zip(eg.iter_mut()).enumerate() {
                *e = sq[b] + x[steps * LANES..].iter().map(|&v| v as u64 * v as u64).sum::<u64>();
                for (r, o) in o.iter_mut().enumerate() {
                    let mut a = [[0f32; LANES]; 1];
                    a[0].copy_from_slice(&acc[(b * rows + r) * LANES..][..LANES]);
                    tail(x, &w[r * m..(r + 1) * m], &mut a);
                    *o = reduce(&a[0]);
                }
            }
        }
    }
    let _ = scratch;
    for ((x, o), e) in xs[done * m..].chunks_exact(m).zip(out[done * rows..].chunks_exact_mut(rows)).zip(&mut energy[done..]) {
        dots(level, x, w, o);
        *e = sum_squares(x);
    }
}

/// Sum of squares of the pixels, exact (in integers).
pub(crate) fn sum_squares(x: &[u8]) -> u64 {
    // Per chunk the u32 sum stays below 2^32 (65,536 * 255^2 < 2^32).
    x.chunks(1 << 16).map(|c| c.iter().map(|&v| v as u32 * v as u32).sum::<u32>() as u64).sum()
}

#[inline(always)]
fn pass<const R: usize>(level: Level, x: &[u8], w: &[f32], out: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    let acc = if level.avx512() {
        // SAFETY: the level is a token of detection that found AVX-512F; `w` holds R rows of
        // x.len() values (asserted in `dots`, and again by the kernel).
        unsafe { x86::lanes_avx512::<R>(x, w) }
    } else if level.avx2() {
        // SAFETY: the level is a token of detection that found AVX2 and FMA; `w` holds R rows
        // of x.len() values (asserted in `dots`, and again by the kernel).
        unsafe { x86::lanes_avx2::<R>(x, w) }
    } else {
        lanes_built::<R>(level, x, w)
    };
    #[cfg(not(target_arch = "x86_64"))]
    let acc = lanes_built::<R>(level, x, w);
    for (o, a) in out.iter_mut().zip(&acc) {
        *o = reduce(a);
    }
}

/// The fixed pairwise sum of 16 lanes.
#[inline(always)]
fn reduce(a: &[f32; LANES]) -> f32 {
    let mut s = *a;
    let mut w = LANES / 2;
    while w > 0 {
        for l in 0..w {
            s[l] += s[l + w];
        }
        w /= 2;
    }
    s[0]
}

/// Pixels past the last whole vector step, into their lanes.
#[inline(always)]
fn tail<const R: usize>(x: &[u8], w: &[f32], acc: &mut [[f32; LANES]; R]) {
    let m = x.len();
    let start = m / LANES * LANES;
    for p in start..m {
        for r in 0..R {
            acc[r][p - start] = (x[p] as f32).mul_add(w[r * m + p], acc[r][p - start]);
        }
    }
}

dispatch! {
    /// [`lanes_portable`] at `level` (where no intrinsics kernel serves it).
    fn lanes_built<const R: usize>(x: &[u8], w: &[f32]) -> [[f32; LANES]; R] = lanes_portable;
}

#[inline(always)]
fn lanes_portable<const R: usize>(x: &[u8], w: &[f32]) -> [[f32; LANES]; R] {
    let m = x.len();
    let mut acc = [[0f32; LANES]; R];
    for (c, xc) in x.chunks_exact(LANES).enumerate() {
        if xc.iter().all(|&v| v == 0) {
            continue;
        }
        let mut xf = [0f32; LANES];
        xf.iter_mut().zip(xc).for_each(|(f, &v)| *f = v as f32);
        for r in 0..R {
            let wr = &w[r * m + c * LANES..r * m + (c + 1) * LANES];
            for l in 0..LANES {
                acc[r][l] = xf[l].mul_add(wr[l], acc[r][l]);
            }
        }
    }
    tail(x, w, &mut acc);
    acc
}

#[cfg(target_arch = "x86_64")]
// Register blocks index several arrays (accumulators, loaded vectors) by the same loop variables.
#[allow(clippy::needless_range_loop)]
mod x86 {
    use super::{tail, AVX2_IMAGES, AVX2_ROWS, BATCH_IMAGES, BATCH_ROWS, LANES, PIXEL_CHUNK};
    use std::arch::x86_64::*;

    /// `out[i] = x[i] as f32`, 16 at a time (`x.len()` a multiple of 16, at most 512, `out`
    /// as long); returns the sum of the squares of `x`, exact, and the mask of the vector steps
    /// that hold a nonzero pixel (bit s for pixels 16 s..16 s + 16).
    ///
    /// # Safety
    /// The CPU must support AVX-512F and AVX-512BW.
    #[target_feature(enable = "avx512f,avx512bw")]
    pub(super) unsafe fn widen_avx512(x: &[u8], out: &mut [f32]) -> (u32, u32) {
        assert!(x.len().is_multiple_of(LANES) && out.len() == x.len() && x.len() <= 32 * LANES);
        let mut sq = _mm512_setzero_si512();
        let mut nonzero = 0u32;
        for (s, (c, o)) in x.chunks_exact(LANES).zip(out.chunks_exact_mut(LANES)).enumerate() {
            let b = _mm_loadu_si128(c.as_ptr() as *const __m128i);
            nonzero |= ((_mm_testz_si128(b, b) == 0) as u32) << s;
            let v = _mm512_cvtepu8_epi32(b);
            _mm512_storeu_ps(o.as_mut_ptr(), _mm512_cvtepi32_ps(v));
            // v * v per lane (v < 256, so the low 16 bits of each product's pair suffice).
            sq = _mm512_add_epi32(sq, _mm512_madd_epi16(v, v));
        }
        // At most 512 squares of 255 in all (< 2^31).
        (_mm512_reduce_add_epi32(sq) as u32, nonzero)
    }

    /// Hints the cache line at `p` into the L2 cache.
    #[inline(always)]
    pub(super) fn prefetch(p: *const u8) {
        // SAFETY: a prefetch is a hint that never faults, whatever the address, and SSE is part
        // of every x86_64 CPU.
        unsafe { _mm_prefetch::<_MM_HINT_T1>(p as *const i8) };
    }

    /// One cache block: the vector steps in the mask `mask` (bit c for step c, below `steps`)
    /// of BATCH_IMAGES images (`xf`, rows of PIXEL_CHUNK f32) against `rows` weight rows
    /// (`wf`, `stride` apart), added to the lane accumulators `acc` (lane l of image b and row r
    /// at `acc[(b * rows + r) * 16 + l]`), in register blocks of BATCH_ROWS rows, each
    /// accumulator updated in pixel order as in [`lanes_avx512`].
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn block_avx512(xf: &[f32], wf: &[f32], stride: usize, rows: usize, steps: usize, mask: u32, acc: &mut [f32]) {
        assert!(steps * LANES <= PIXEL_CHUNK && steps <= 32 && (steps == 32 || mask >> steps == 0));
        assert!(xf.len() >= BATCH_IMAGES * PIXEL_CHUNK && rows > 0);
        assert!(stride.is_multiple_of(LANES) && wf.len() >= (rows - 1) * stride + steps * LANES && wf.as_ptr().align_offset(64) == 0);
        assert!(acc.len() >= BATCH_IMAGES * rows * LANES);
        for r0 in (0..rows).step_by(BATCH_ROWS) {
            match (rows - r0).min(BATCH_ROWS) {
                1 => regs::<1>(xf, wf, stride, rows, r0, mask, acc),
                2 => regs::<2>(xf, wf, stride, rows, r0, mask, acc),
                3 => regs::<3>(xf, wf, stride, rows, r0, mask, acc),
                _ => regs::<BATCH_ROWS>(xf, wf, stride, rows, r0, mask, acc),
            }
        }
    }

    /// Rows r0..r0 + R of one cache block, the steps in `mask`, in registers.
    ///
    /// # Safety
    /// The CPU must support AVX-512F; the slices must have the lengths and alignment
    /// [`block_avx512`] asserts, and r0 + R <= rows.
    #[target_feature(enable = "avx512f")]
    unsafe fn regs<const R: usize>(xf: &[f32], wf: &[f32], stride: usize, rows: usize, r0: usize, mask: u32, acc: &mut [f32]) {
        let (xp, wp, ap) = (xf.as_ptr(), wf.as_ptr().add(r0 * stride), acc.as_mut_ptr());
        let mut a = [[_mm512_setzero_ps(); R]; BATCH_IMAGES];
        for b in 0..BATCH_IMAGES {
            for r in 0..R {
                a[b][r] = _mm512_loadu_ps(ap.add((b * rows + r0 + r) * LANES));
            }
        }
        let mut left = mask;
        while left != 0 {
            let c = left.trailing_zeros() as usize;
            left &= left - 1;
            let mut wv = [_mm512_setzero_ps(); R];
            for r in 0..R {
                wv[r] = _mm512_load_ps(wp.add(r * stride + c * LANES));
            }
            for b in 0..BATCH_IMAGES {
                let xv = _mm512_load_ps(xp.add(b * PIXEL_CHUNK + c * LANES));
                for r in 0..R {
                    a[b][r] = _mm512_fmadd_ps(xv, wv[r], a[b][r]);
                }
            }
        }
        for b in 0..BATCH_IMAGES {
            for r in 0..R {
                _mm512_storeu_ps(ap.add((b * rows + r0 + r) * LANES), a[b][r]);
            }
        }
    }

    /// # Safety
    /// The CPU must support AVX-512F; `w` holds R rows of `x.len()` values.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn lanes_avx512<const R: usize>(x: &[u8], w: &[f32]) -> [[f32; LANES]; R] {
        let m = x.len();
        assert!(w.len() >= R * m);
        let mut acc = [_mm512_setzero_ps(); R];
        let (xp, wp) = (x.as_ptr(), w.as_ptr());
        for c in 0..m / LANES {
            let b = _mm_loadu_si128(xp.add(c * LANES) as *const __m128i);
            if _mm_testz_si128(b, b) != 0 {
                continue;
            }
            let xv = _mm512_cvtepi32_ps(_mm512_cvtepu8_epi32(b));
            for r in 0..R {
                acc[r] = _mm512_fmadd_ps(xv, _mm512_loadu_ps(wp.add(r * m + c * LANES)), acc[r]);
            }
        }
        let mut out = [[0f32; LANES]; R];
        for r in 0..R {
            _mm512_storeu_ps(out[r].as_mut_ptr(), acc[r]);
        }
        tail(x, w, &mut out);
        out
    }

    /// [`widen_avx512`] on AVX2: the same values, sums of squares and mask.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn widen_avx2(x: &[u8], out: &mut [f32]) -> (u32, u32) {
        assert!(x.len().is_multiple_of(LANES) && out.len() == x.len() && x.len() <= 32 * LANES);
        let mut sq = _mm256_setzero_si256();
        let mut nonzero = 0u32;
        for (s, (c, o)) in x.chunks_exact(LANES).zip(out.chunks_exact_mut(LANES)).enumerate() {
            let b = _mm_loadu_si128(c.as_ptr() as *const __m128i);
            nonzero |= ((_mm_testz_si128(b, b) == 0) as u32) << s;
            let (lo, hi) = (_mm256_cvtepu8_epi32(b), _mm256_cvtepu8_epi32(_mm_unpackhi_epi64(b, b)));
            _mm256_storeu_ps(o.as_mut_ptr(), _mm256_cvtepi32_ps(lo));
            _mm256_storeu_ps(o.as_mut_ptr().add(LANES / 2), _mm256_cvtepi32_ps(hi));
            // v * v per lane (v < 256, so the low 16 bits of each product's pair suffice).
            sq = _mm256_add_epi32(sq, _mm256_add_epi32(_mm256_madd_epi16(lo, lo), _mm256_madd_epi16(hi, hi)));
        }
        // At most 512 squares of 255 in all (< 2^31).
        let mut lanes = [0u32; 8];
        _mm256_storeu_si256(lanes.as_mut_ptr() as *mut __m256i, sq);
        (lanes.iter().sum(), nonzero)
    }

    /// [`block_avx512`] on AVX2: each 16-lane accumulator as two halves of 8 lanes, summed one
    /// half after the other (the halves are independent sums, so the order of each is that of
    /// [`lanes_avx2`]) in register blocks of [`AVX2_IMAGES`] images by up to [`AVX2_ROWS`]
    /// rows: 12 accumulators, the images' vectors and one weight vector in the 16 registers.
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn block_avx2(xf: &[f32], wf: &[f32], stride: usize, rows: usize, steps: usize, mask: u32, acc: &mut [f32]) {
        assert!(steps * LANES <= PIXEL_CHUNK && steps <= 32 && (steps == 32 || mask >> steps == 0));
        assert!(xf.len() >= BATCH_IMAGES * PIXEL_CHUNK && rows > 0);
        assert!(stride >= steps * LANES && wf.len() >= (rows - 1) * stride + steps * LANES);
        assert!(acc.len() >= BATCH_IMAGES * rows * LANES);
        for b0 in (0..BATCH_IMAGES).step_by(AVX2_IMAGES) {
            for h in [0, LANES / 2] {
                for r0 in (0..rows).step_by(AVX2_ROWS) {
                    match (rows - r0).min(AVX2_ROWS) {
                        1 => regs_avx2::<1>(xf, wf, stride, rows, Regs { b0, r0, h }, mask, acc),
                        2 => regs_avx2::<2>(xf, wf, stride, rows, Regs { b0, r0, h }, mask, acc),
                        3 => regs_avx2::<3>(xf, wf, stride, rows, Regs { b0, r0, h }, mask, acc),
                        _ => regs_avx2::<AVX2_ROWS>(xf, wf, stride, rows, Regs { b0, r0, h }, mask, acc),
                    }
                }
            }
        }
    }

    /// Where a register block of [`block_avx2`] lies: images b0..b0 + AVX2_IMAGES, rows
    /// r0..r0 + R, lanes h..h + 8.
    #[derive(Clone, Copy)]
    struct Regs {
        b0: usize,
        r0: usize,
        h: usize,
    }

    /// The register block `at` (images b0..b0 + AVX2_IMAGES, rows r0..r0 + R, lanes h..h + 8)
    /// of one cache block, the steps in `mask`, in registers.
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA; the slices must have the lengths [`block_avx2`]
    /// asserts, b0 + AVX2_IMAGES <= BATCH_IMAGES, r0 + R <= rows and h + 8 <= 16.
    #[target_feature(enable = "avx2,fma")]
    unsafe fn regs_avx2<const R: usize>(xf: &[f32], wf: &[f32], stride: usize, rows: usize, at: Regs, mask: u32, acc: &mut [f32]) {
        let Regs { b0, r0, h } = at;
        let (xp, wp, ap) = (xf.as_ptr().add(b0 * PIXEL_CHUNK + h), wf.as_ptr().add(r0 * stride + h), acc.as_mut_ptr().add(h));
        let at = |b: usize, r: usize| ((b0 + b) * rows + r0 + r) * LANES;
        let mut a = [[_mm256_setzero_ps(); R]; AVX2_IMAGES];
        for b in 0..AVX2_IMAGES {
            for r in 0..R {
                a[b][r] = _mm256_loadu_ps(ap.add(at(b, r)));
            }
        }
        let mut left = mask;
        while left != 0 {
            let c = left.trailing_zeros() as usize;
            left &= left - 1;
            let mut xv = [_mm256_setzero_ps(); AVX2_IMAGES];
            for b in 0..AVX2_IMAGES {
                xv[b] = _mm256_loadu_ps(xp.add(b * PIXEL_CHUNK + c * LANES));
            }
            for r in 0..R {
                let wv = _mm256_loadu_ps(wp.add(r * stride + c * LANES));
                for b in 0..AVX2_IMAGES {
                    a[b][r] = _mm256_fmadd_ps(xv[b], wv, a[b][r]);
                }
            }
        }
        for b in 0..AVX2_IMAGES {
            for r in 0..R {
                _mm256_storeu_ps(ap.add(at(b, r)), a[b][r]);
            }
        }
    }

    /// [`lanes_avx512`] on AVX2: each row's 16 lanes in two 8-lane accumulators, the same
    /// fused multiply-adds in the same order (so the same bits). The compiler's vectorisation
    /// of the portable body, which this replaces on AVX2, kept the zero test and the widening
    /// scalar (BENCHMARKS.md, "Hand-written kernels against the libraries'").
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA; `w` holds R rows of `x.len()` values.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn lanes_avx2<const R: usize>(x: &[u8], w: &[f32]) -> [[f32; LANES]; R] {
        let m = x.len();
        assert!(w.len() >= R * m);
        let (mut lo, mut hi) = ([_mm256_setzero_ps(); R], [_mm256_setzero_ps(); R]);
        let (xp, wp) = (x.as_ptr(), w.as_ptr());
        for c in 0..m / LANES {
            let b = _mm_loadu_si128(xp.add(c * LANES) as *const __m128i);
            if _mm_testz_si128(b, b) != 0 {
                continue;
            }
            let xl = _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(b));
            let xh = _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_unpackhi_epi64(b, b)));
            for r in 0..R {
                let p = wp.add(r * m + c * LANES);
                lo[r] = _mm256_fmadd_ps(xl, _mm256_loadu_ps(p), lo[r]);
                hi[r] = _mm256_fmadd_ps(xh, _mm256_loadu_ps(p.add(LANES / 2)), hi[r]);
            }
        }
        let mut out = [[0f32; LANES]; R];
        for r in 0..R {
            _mm256_storeu_ps(out[r].as_mut_ptr(), lo[r]);
            _mm256_storeu_ps(out[r].as_mut_ptr().add(LANES / 2), hi[r]);
        }
        tail(x, w, &mut out);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_path_matches_the_reference_and_the_others_bitwise() {
        for &(m, rows) in &[(1, 1), (15, 3), (16, 2), (100, 9), (19_200 / 40, 20), (1000, 3)] {
            let x: Vec<u8> = (0..m).map(|i| ((i * 7919 + 13) % 256) as u8).collect();
            let w: Vec<f32> = (0..m * rows).map(|i| ((i * 104729) % 2001) as f32 / 1000.0 - 1.0).collect();
            let want: Vec<f64> = (0..rows).map(|r| (0..m).map(|p| x[p] as f64 * w[r * m + p] as f64).sum()).collect();
            let mut first: Option<Vec<f32>> = None;
            for level in Level::supported() {
                let mut out = vec![0f32; rows];
                dots(level, &x, &w, &mut out);
                for (o, wv) in out.iter().zip(&want) {
                    let scale: f64 = 255.0 * m as f64;
                    assert!((*o as f64 - wv).abs() <= 1e-6 * scale, "{level:?} m {m}: {o} vs {wv}");
                }
                match &first {
                    Some(f) => assert_eq!(f.iter().map(|v| v.to_bits()).collect::<Vec<_>>(), out.iter().map(|v| v.to_bits()).collect::<Vec<_>>(), "{level:?}"),
                    None => first = Some(out),
                }
            }
        }
    }

    #[test]
    fn the_batch_gives_the_bits_of_one_image_at_a_time() {
        for &(m, n, rows) in &[(16, 6, 4), (100, 13, 20), (19_200 / 40, 7, 3), (37, 12, 5), (480, 5, 20)] {
            let xs: Vec<u8> = (0..m * n).map(|i| ((i * 7919 + 13) % 256) as u8).collect();
            let w: Vec<f32> = (0..m * rows).map(|i| ((i * 104729) % 2001) as f32 / 1000.0 - 1.0).collect();
            for level in Level::supported() {
                let mut one = vec![0f32; n * rows];
                xs.chunks_exact(m).zip(one.chunks_exact_mut(rows)).for_each(|(x, o)| dots(level, x, &w, o));
                // The weights on a 64-byte boundary (read in place when m is a multiple of 16)
                // and off one (copied block by block).
                let aligned = crate::kernels::AlignedF32::new(&w);
                let mut shifted = vec![0f32; w.len() + 16];
                let at = (shifted.as_ptr().align_offset(64) + 1) % 16;
                shifted[at..at + w.len()].copy_from_slice(&w);
                assert_eq!(aligned.as_ptr().align_offset(64), 0);
                for wv in [&aligned[..], &shifted[at..at + w.len()]] {
                    let mut batch = vec![0f32; n * rows];
                    let mut energy = vec![0u64; n];
                    dots_batch(level, &xs, m, wv, &mut batch, &mut energy, &mut Vec::new());
                    let want: Vec<u64> = xs.chunks_exact(m).map(sum_squares).collect();
                    assert_eq!(energy, want, "{level:?} m {m} n {n}");
                    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&one), bits(&batch), "{level:?} m {m} n {n} rows {rows}");
                }
            }
        }
    }

    /// The dense sum: every pixel, zero or not, by a fused multiply-add into lane p % 16 in
    /// pixel order, then the fixed pairwise sum of the lanes.
    fn dense(x: &[u8], w: &[f32]) -> f32 {
        let mut acc = [0f32; LANES];
        for (p, (&v, &wv)) in x.iter().zip(w).enumerate() {
            acc[p % LANES] = (v as f32).mul_add(wv, acc[p % LANES]);
        }
        reduce(&acc)
    }

    #[test]
    fn skipping_zero_steps_gives_the_bits_of_the_dense_sums() {
        // Images with black backgrounds: zero steps in runs, steps with one nonzero pixel, whole
        // zero images, and zero cache blocks shared by a whole register block of images.
        for &(m, n, rows) in &[(19_200 / 10, 13, 20), (16 * 60 + 7, 12, 5), (384 * 3, 18, 4)] {
            let xs: Vec<u8> = (0..m * n)
                .map(|i| {
                    let (img, p) = (i / m, i % m);
                    let step = p / LANES;
                    let v = ((i * 7919 + 13) % 255 + 1) as u8;
                    match img % 4 {
                        0 => 0,
                        1 if step % 5 == 2 && p % LANES == 7 => v,
                        1 => 0,
                        _ if (step + img).is_multiple_of(3) || p >= m / 2 => v,
                        _ => 0,
                    }
                })
                .collect();
            let w: Vec<f32> = (0..m * rows).map(|i| ((i * 104729) % 2001) as f32 / 1000.0 - 1.0).collect();
            let want: Vec<u32> = xs.chunks_exact(m).flat_map(|x| w.chunks_exact(m).map(|wr| dense(x, wr).to_bits()).collect::<Vec<_>>()).collect();
            assert!(xs.chunks_exact(m).any(|x| x.chunks_exact(LANES).any(|c| c.iter().all(|&v| v == 0))));
            for level in Level::supported() {
                let mut one = vec![0f32; n * rows];
                xs.chunks_exact(m).zip(one.chunks_exact_mut(rows)).for_each(|(x, o)| dots(level, x, &w, o));
                assert_eq!(one.iter().map(|v| v.to_bits()).collect::<Vec<_>>(), want, "{level:?} m {m} one at a time");
                let aligned = crate::kernels::AlignedF32::new(&w);
                let mut batch = vec![0f32; n * rows];
                let mut energy = vec![0u64; n];
                dots_batch(level, &xs, m, &aligned, &mut batch, &mut energy, &mut Vec::new());
                assert_eq!(batch.iter().map(|v| v.to_bits()).collect::<Vec<_>>(), want, "{level:?} m {m} batch");
                assert_eq!(energy, xs.chunks_exact(m).map(sum_squares).collect::<Vec<_>>());
            }
        }
    }

    #[test]
    fn sum_squares_is_exact() {
        let x = vec![255u8; 200_000];
        assert_eq!(sum_squares(&x), 200_000 * 65_025);
    }
}
