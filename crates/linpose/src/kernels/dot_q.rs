//! Products of 8-bit images with weight rows held in 16-bit fixed point, summed exactly in
//! integers: the eigenspace's 8-bit projection, without converting the pixels to f32.
//!
//! Each row r is stored as integers v (|v| <= [`VMAX`] = 32,639) with one scale
//! s_r = max |w_r| / VMAX, v = round(w / s_r): the quantisation error of a weight is at most
//! s_r / 2, so a product's error is at most s_r / 2 times the image's pixel sum (tested). A
//! product sum_p x_p v_p is then exact in integers, and its one rounding is the conversion of the
//! sum times s_r to f32.
//!
//! How fine that is: on the rendered objects' 1760 views (clean, +-5%, +-10%) and COIL-20's 72
//! per object, the eigenspace's and the refined eigenspace's estimates from 8-bit images through
//! this kernel differ from their estimates of the same images as f32 features on 9 of 55,680
//! queries (near ties between two lattice poses: a rendered object's mean error moved by at most
//! 0.0003 degrees, COIL-16's refined by 0.007, one view of 72 by 0.5). Three digits (24-bit
//! fixed point, as fine as the f32 basis) differed on 2, but take 3 instructions a step instead
//! of 2: the eigenspace's batch of dense images took 4.5-5.5 us a query against 3.2-3.3 us with
//! two (BENCHMARKS.md, issue 7).
//!
//! v is held as [`DIGITS`] balanced base-256 digits, v = d1 256 + d0 with each d in [-128, 127],
//! one byte each, tile by tile (every row's digit rows of [`CHUNK`] steps of 64 pixels together,
//! on 64-byte boundaries). AVX-512 VNNI's `vpdpbusd` (64 products of an unsigned and a signed
//! byte, summed in fours into 16 i32 lanes) takes one digit row per instruction, so 64 pixels of
//! one row take 2 instructions where f32 fused multiply-adds take 4 and a widening pass. Without
//! VNNI the same integers are summed digit by digit in i32 per tile (the portable body, compiled
//! for AVX2 where the CPU has it). Every path is exact, so every path gives the same bits
//! (tested), but only the VNNI path is fast ([`fast`]): models hold a [`FastRows`], which falls
//! back to [`super::dot_u8`]'s f32 products elsewhere. A step of 64 black pixels adds nothing and
//! is skipped.

use super::Level;

/// Balanced base-256 digits per stored integer (see the module doc for 2 against 3).
pub const DIGITS: usize = 2;
/// Largest stored integer: [`DIGITS`] balanced base-256 digits of at most 127.
pub const VMAX: i32 = 127 * ((1 << (8 * DIGITS)) - 1) / 255;
// The integers and their digit sums fit i32 (and VMAX's formula) up to three digits.
const _: () = assert!(DIGITS >= 1 && DIGITS <= 3);

/// 256^k, the weight of digit k.
const fn radix(k: usize) -> i64 {
    1 << (8 * k)
}
/// Pixels per `vpdpbusd` step.
const STEP: usize = 64;
/// Steps summed in i32 lanes before they are added into i64 (each lane takes 4 products of at
/// most 255 x 128 a step: 1024 steps stay below 2^31).
const SPAN: usize = 1024;

/// Each row r of `w` (rows of `m` values) in fixed point: its scale s_r = max |w_r| / [`VMAX`] (1
/// for a row of zeros) and each weight's integer round(w / s_r), within [-VMAX, VMAX], given to
/// `put(r, p, v)`; returns the scales. (The 16-bit products, [`super::dot_w`], store the same
/// integers.)
pub(crate) fn fixed_point(w: &[f32], m: usize, mut put: impl FnMut(usize, usize, i32)) -> Vec<f64> {
    let mut scale = Vec::with_capacity(w.len() / m);
    for (r, row) in w.chunks_exact(m).enumerate() {
        let amax = row.iter().fold(0f64, |a, &x| a.max((x as f64).abs()));
        let s = if amax > 0.0 { amax / VMAX as f64 } else { 1.0 };
        scale.push(s);
        for (p, &x) in row.iter().enumerate() {
            put(r, p, ((x as f64 / s).round() as i32).clamp(-VMAX, VMAX));
        }
    }
    scale
}

/// Weight rows in fixed point (see the module doc).
#[derive(Debug, Clone)]
pub struct QuantRows {
    rows: usize,
    m: usize,
    /// Per row, the scale of its integers.
    scale: Vec<f64>,
    /// Tile by tile, every row's [`DIGITS`] digit rows (d0 first); zero past m.
    lines: Vec<Line>,
}

/// 64 digits on a 64-byte boundary.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Line([i8; STEP]);

/// Bytes of one digit row per tile.
const TILE: usize = CHUNK * STEP;

/// Index of digit k of row r (of `rows`) at pixel p in the tiled digits.
#[inline(always)]
fn at(rows: usize, r: usize, k: usize, p: usize) -> usize {
    (p / TILE) * rows * DIGITS * TILE + (r * DIGITS + k) * TILE + p % TILE
}

impl QuantRows {
    /// The rows of `w` (`rows` x `m`, finite), each scaled to [-VMAX, VMAX] and rounded.
    #[track_caller]
    pub fn new(w: &[f32], m: usize) -> QuantRows {
        assert!(m > 0 && w.len().is_multiple_of(m), "whole rows of m > 0 weights");
        assert!(w.iter().all(|v| v.is_finite()), "finite weights");
        let rows = w.len() / m;
        let mut digits = vec![0i8; rows * DIGITS * m.div_ceil(TILE) * TILE];
        let scale = fixed_point(w, m, |r, p, v| {
            let mut rest = v;
            for k in 0..DIGITS {
                let d = if k + 1 == DIGITS { rest } else { (rest + 128).rem_euclid(256) - 128 };
                debug_assert!((-128..=127).contains(&d));
                digits[at(rows, r, k, p)] = d as i8;
                rest = (rest - d) / 256;
            }
        });
        let lines = digits.chunks_exact(STEP).map(|c| Line(c.try_into().expect("64 digits"))).collect();
        QuantRows { rows, m, scale, lines }
    }

    /// The digits, tile by tile (see [`at`]).
    fn digits(&self) -> &[i8] {
        // SAFETY: a `Line` is 64 i8 with no padding, and the lines are contiguous.
        unsafe { std::slice::from_raw_parts(self.lines.as_ptr() as *const i8, self.lines.len() * STEP) }
    }

    /// Index of digit k of row r at pixel p in [`QuantRows::digits`].
    #[inline(always)]
    fn at(&self, r: usize, k: usize, p: usize) -> usize {
        at(self.rows, r, k, p)
    }

    /// Rows stored.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// The stored integer of row r at pixel p.
    pub fn int(&self, r: usize, p: usize) -> i32 {
        (0..DIGITS).map(|k| self.digits()[self.at(r, k, p)] as i32 * radix(k) as i32).sum()
    }

    /// The weight row r as stored: its integers times its scale.
    pub fn row(&self, r: usize) -> Vec<f64> {
        (0..self.m).map(|p| self.int(r, p) as f64 * self.scale[r]).collect()
    }
}

/// Whether the AVX-512 VNNI path runs at `level`: the only one faster than the f32 products of
/// [`super::dot_u8`] (the portable and AVX2 paths are exact too, but measured 3.5x slower than
/// them on AVX2).
pub fn fast(level: Level) -> bool {
    vnni(level)
}

fn vnni(level: Level) -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        level == Level::Avx512 && is_x86_feature_detected!("avx512vnni")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = level;
        false
    }
}

/// `out[r] = sum_p x[p] * row_r[p]` for every stored row, exact then rounded once.
#[track_caller]
pub fn dots(level: Level, x: &[u8], q: &QuantRows, out: &mut [f32]) {
    assert!(x.len() == q.m && out.len() == q.rows, "one image of the rows' length, one output per row");
    let mut sums = [0i64; 8];
    for r0 in (0..q.rows).step_by(8) {
        let n = (q.rows - r0).min(8);
        let s = &mut sums[..n];
        sums_at(level, x, q, r0, s);
        for (k, &v) in s.iter().enumerate() {
            out[r0 + k] = (v as f64 * q.scale[r0 + k]) as f32;
        }
    }
}

/// The exact sums of rows r0..r0 + s.len() (at most 8) against `x`, on the best path of `level`.
fn sums_at(level: Level, x: &[u8], q: &QuantRows, r0: usize, s: &mut [i64]) {
    #[cfg(target_arch = "x86_64")]
    {
        if vnni(level) {
            // SAFETY: AVX-512 F/BW (Level::Avx512) and VNNI were detected.
            return unsafe { x86::sums_vnni(x, q, r0, s) };
        }
        if level != Level::Portable && is_x86_feature_detected!("avx2") {
            // SAFETY: AVX2 was detected.
            return unsafe { x86::sums_avx2(x, q, r0, s) };
        }
    }
    let _ = level;
    sums_portable(x, q, r0, s)
}

/// The portable body of [`sums_at`]: per tile, each digit row's sum in i32 (at most 1024 products
/// of 255 x 128), then the digits' sums into i64.
#[inline(always)]
fn sums_portable(x: &[u8], q: &QuantRows, r0: usize, s: &mut [i64]) {
    let digits = q.digits();
    for (k, s) in s.iter_mut().enumerate() {
        let r = r0 + k;
        let mut tot = 0i64;
        for (t, xt) in x.chunks(TILE).enumerate() {
            let p = t * TILE;
            let d = |j: usize| -> i64 {
                let dr = &digits[q.at(r, j, p)..][..xt.len()];
                xt.iter().zip(dr).map(|(&a, &b)| a as i32 * b as i32).sum::<i32>() as i64
            };
            tot += (0..DIGITS).map(|j| radix(j) * d(j)).sum::<i64>();
        }
        *s = tot;
    }
}

/// The fixed-point copy of a model's weight rows, made where the integer kernel is [`fast`] at
/// the detected level, and the one place that chooses between the two 8-bit kernels: with the
/// copy and VNNI at the query's level, this module's exact sums; otherwise
/// [`super::dot_u8`]'s f32 products of the f32 rows the caller passes (the same rows the copy
/// was made from).
#[derive(Debug, Clone, Default)]
pub struct FastRows(Option<QuantRows>);

/// The buffers of [`FastRows::dots_batch`], one per parallel task.
#[derive(Debug, Default)]
pub struct Scratch {
    f32s: Vec<f32>,
    i32s: Vec<i32>,
}

impl FastRows {
    /// The copy of `w` (rows of `m`), or none where [`fast`] does not hold for
    /// [`Level::detect`].
    pub fn new(w: &[f32], m: usize) -> FastRows {
        FastRows(fast(Level::detect()).then(|| QuantRows::new(w, m)))
    }

    fn at(&self, level: Level) -> Option<&QuantRows> {
        self.0.as_ref().filter(|_| fast(level))
    }

    /// Images per block the batch kernel at `level` wants: a group here, a register block of
    /// [`super::dot_u8::dots_batch`] otherwise.
    pub fn block(&self, level: Level) -> usize {
        if self.at(level).is_some() {
            GROUP * BLOCK
        } else {
            super::dot_u8::BATCH_IMAGES
        }
    }

    /// The products of `x` with every row of `w` (rows of `x.len()`) into `out`.
    pub fn dots(&self, level: Level, x: &[u8], w: &[f32], out: &mut [f32]) {
        match self.at(level) {
            Some(q) => dots(level, x, q, out),
            None => super::dot_u8::dots(level, x, w, out),
        }
    }

    /// [`FastRows::dots`] for the `xs.len() / m` images of `xs`, with each image's exact sum of
    /// squares into `energy`.
    #[allow(clippy::too_many_arguments)]
    pub fn dots_batch(&self, level: Level, xs: &[u8], m: usize, w: &[f32], out: &mut [f32], energy: &mut [u64], scratch: &mut Scratch) {
        match self.at(level) {
            Some(q) => dots_batch(level, xs, q, out, energy, &mut scratch.i32s),
            None => super::dot_u8::dots_batch(level, xs, m, w, out, energy, &mut scratch.f32s),
        }
    }
}

/// Images per register block of [`dots_batch`]: a digit vector loaded serves this many images.
pub const BLOCK: usize = 8;
/// Steps (of 64 pixels) per cache block of [`dots_batch`]: the group's images' copies (16 KiB)
/// stay in L1 while every row passes over them.
pub const CHUNK: usize = 16;
/// Register blocks per group of [`dots_batch`]: a row's digits, once in L1, serve this many.
pub const GROUP: usize = 2;
// A cache block's steps fit the u32 masks of nonzero steps.
const _: () = assert!(CHUNK <= 32);

/// [`dots`] for `xs.len() / m` images, and each image's exact sum of squares into `energy`; the
/// same bits as one image at a time (every path sums exactly). With AVX-512 VNNI (and images of
/// at most 65,536 pixels, so that no lane can overflow) the images go in groups of [`GROUP`]
/// register blocks of [`BLOCK`] images, each image read in order (16 streams, which the hardware
/// prefetcher follows: software prefetching measured slower), [`CHUNK`] steps at a time: the
/// chunk's pixels are copied to 64-byte boundaries while their squares and the mask of nonzero
/// steps are summed, then each row in turn passes over the steps in the mask, in registers of 8
/// images by [`DIGITS`] digits. `scratch` holds the lane sums between chunks. Images past the
/// last whole block go one at a time.
#[track_caller]
pub fn dots_batch(level: Level, xs: &[u8], q: &QuantRows, out: &mut [f32], energy: &mut [u64], scratch: &mut Vec<i32>) {
    let m = q.m;
    assert!(xs.len().is_multiple_of(m) && out.len() == xs.len() / m * q.rows && energy.len() == xs.len() / m);
    let n = xs.len() / m;
    let mut done = 0;
    #[cfg(target_arch = "x86_64")]
    if vnni(level) && m.div_ceil(STEP) <= SPAN && q.rows > 0 {
        done = n / BLOCK * BLOCK;
        for ((xb, ob), eb) in
            xs[..done * m].chunks(GROUP * BLOCK * m).zip(out[..done * q.rows].chunks_mut(GROUP * BLOCK * q.rows)).zip(energy[..done].chunks_mut(GROUP * BLOCK))
        {
            // SAFETY: AVX-512 F/BW and VNNI were detected; the group holds whole blocks of BLOCK
            // images of m <= 65,536 pixels and one output per image and row.
            unsafe { x86::group_vnni(xb, q, ob, eb, scratch) };
        }
    }
    let _ = scratch;
    for ((x, o), e) in xs[done * m..].chunks_exact(m).zip(out[done * q.rows..].chunks_exact_mut(q.rows)).zip(&mut energy[done..]) {
        dots(level, x, q, o);
        *e = super::dot_u8::sum_squares(x);
    }
}

#[cfg(target_arch = "x86_64")]
// Register blocks index several arrays (accumulators, loaded vectors) by the same loop variables.
#[allow(clippy::needless_range_loop)]
mod x86 {
    use super::{radix, Line, QuantRows, BLOCK, CHUNK, DIGITS, GROUP, SPAN, STEP, TILE};
    use std::arch::x86_64::*;

    /// One step of 64 pixels of `x` from pixel p (pixels past m read as zero).
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
    pub unsafe fn group_vnni(xs: &[u8], q: &QuantRows, out: &mut [f32], energy: &mut [u64], scratch: &mut Vec<i32>) {
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
                let a = |k: usize| lanes_i64(_mm512_loadu_si512(scratch.as_ptr().add((g * rows + r) * per_row + (b * DIGITS + k) * 16) as *const _));
                let s: i64 = (0..DIGITS).map(|k| radix(k) * a(k)).sum();
                out[i * rows + r] = (s as f64 * q.scale[r]) as f32;
            }
        }
    }

    /// Row r against the block's images over the steps c0 + (bits of `mask`), added to the lane
    /// sums at `acc` ([image][digit][16]).
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

    /// [`super::sums_portable`] compiled for AVX2.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub unsafe fn sums_avx2(x: &[u8], q: &QuantRows, r0: usize, s: &mut [i64]) {
        super::sums_portable(x, q, r0, s)
    }

    /// The exact sums of rows r0..r0 + s.len() (at most 8) against one image.
    ///
    /// # Safety
    /// The CPU must support AVX-512 F, BW and VNNI.
    #[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
    pub unsafe fn sums_vnni(x: &[u8], q: &QuantRows, r0: usize, s: &mut [i64]) {
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
    #[inline(always)]
    unsafe fn lanes_i64(a: __m512i) -> i64 {
        let lo = _mm512_cvtepi32_epi64(_mm512_castsi512_si256(a));
        let hi = _mm512_cvtepi32_epi64(_mm512_extracti64x4_epi64::<1>(a));
        _mm512_reduce_add_epi64(_mm512_add_epi64(lo, hi))
    }

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
}

#[cfg(test)]
mod tests {
    use super::*;

    fn weights(n: usize) -> Vec<f32> {
        (0..n).map(|i| ((i * 104_729) % 2001) as f32 / 1000.0 - 1.0).collect()
    }

    /// Pixels with whole black steps of 64 (every fourth), black images (every fifth) and
    /// bright ones.
    fn images(m: usize, n: usize) -> Vec<u8> {
        (0..m * n).map(|i| if ((i % m) / 64) % 4 == 1 || (i / m) % 5 == 3 { 0 } else { ((i * 7919 + 13) % 256) as u8 }).collect()
    }

    /// The exact sum of row r against `x`, in i64 from the stored integers.
    fn exact(q: &QuantRows, x: &[u8], r: usize) -> f32 {
        let s: i64 = x.iter().enumerate().map(|(p, &v)| v as i64 * q.int(r, p) as i64).sum();
        (s as f64 * q.scale[r]) as f32
    }

    #[test]
    fn digits_rebuild_the_integers_and_the_rows_stay_within_half_a_step() {
        for m in [300, 1025, 2048] {
            let w = weights(3 * m);
            let q = QuantRows::new(&w, m);
            assert_eq!((q.rows(), q.m), (3, m));
            for r in 0..3 {
                let row = q.row(r);
                for (p, (&a, &b)) in w[r * m..].iter().zip(&row).enumerate() {
                    assert!((a as f64 - b).abs() <= q.scale[r] / 2.0 * (1.0 + 1e-12), "row {r} pixel {p}");
                    assert!((0..DIGITS).all(|k| q.digits()[q.at(r, k, p)] >= -128), "balanced digits");
                    assert!(q.int(r, p).abs() <= VMAX);
                }
            }
            // Every tile's digits past m are zero.
            let used: usize =
                (0..3).map(|r| (0..m).flat_map(|p| (0..DIGITS).map(move |k| (r, k, p))).filter(|&(r, k, p)| q.digits()[q.at(r, k, p)] != 0).count()).sum();
            assert_eq!(used, q.digits().iter().filter(|&&d| d != 0).count());
        }
        // The extremes land on +-VMAX.
        let q = QuantRows::new(&[0.5, -0.5, 0.25], 3);
        assert_eq!((q.int(0, 0), q.int(0, 1)), (VMAX, -VMAX));
        assert!((q.int(0, 2) - VMAX / 2).abs() <= 1, "{}", q.int(0, 2));
        let z = QuantRows::new(&[0.0; 4], 4);
        assert!((0..4).all(|p| z.int(0, p) == 0));
    }

    #[test]
    fn every_path_gives_the_exact_sums() {
        for &(m, rows) in &[(1, 1), (63, 3), (64, 2), (100, 9), (19_200 / 40, 20), (1000, 3), (1024, 8), (64 * 1030 + 5, 2)] {
            let w = weights(m * rows);
            let q = QuantRows::new(&w, m);
            let x = &images(m, 1)[..];
            let want: Vec<f32> = (0..rows).map(|r| exact(&q, x, r)).collect();
            for level in Level::supported() {
                let mut out = vec![0f32; rows];
                dots(level, x, &q, &mut out);
                assert_eq!(out, want, "{level:?} m {m}");
            }
            // Within the quantisation of the weights of the f64 products.
            for (r, &got) in want.iter().enumerate() {
                let f: f64 = x.iter().zip(&w[r * m..(r + 1) * m]).map(|(&a, &b)| a as f64 * b as f64).sum();
                let bound = q.scale[r] / 2.0 * x.iter().map(|&v| v as f64).sum::<f64>() + f.abs() * 1e-7;
                assert!((got as f64 - f).abs() <= bound, "m {m} row {r}: {got} vs {f}");
            }
        }
    }

    #[test]
    fn the_batch_gives_the_bits_of_one_image_at_a_time() {
        let sizes = [(64, 2, 4), (100, 13, 20), (19_200 / 40, 7, 3), (37, 12, 5), (480, 5, 20), (1000, 200, 6), (64 * 1030 + 5, 3, 2)];
        let more = [(1024 + 64, 8, 4), (2100, 16, 20), (2100, 17, 3), (640, 24, 1), (640, 40, 7), (19_200 / 10, 33, 20)];
        for &(m, n, rows) in sizes.iter().chain(&more) {
            let xs = images(m, n);
            let q = QuantRows::new(&weights(m * rows), m);
            let want: Vec<f32> = xs.chunks_exact(m).flat_map(|x| (0..rows).map(|r| exact(&q, x, r)).collect::<Vec<_>>()).collect();
            for level in Level::supported() {
                let mut one = vec![0f32; n * rows];
                xs.chunks_exact(m).zip(one.chunks_exact_mut(rows)).for_each(|(x, o)| dots(level, x, &q, o));
                assert_eq!(one, want, "{level:?} m {m} n {n}");
                let (mut batch, mut energy) = (vec![0f32; n * rows], vec![0u64; n]);
                dots_batch(level, &xs, &q, &mut batch, &mut energy, &mut Vec::new());
                assert_eq!(batch, want, "{level:?} m {m} n {n}");
                assert_eq!(energy, xs.chunks_exact(m).map(crate::kernels::dot_u8::sum_squares).collect::<Vec<_>>(), "{level:?} m {m} n {n}");
            }
        }
    }

    #[test]
    fn the_exact_sums_agree_with_the_f32_kernel_within_the_quantisation() {
        // The two families callers switch between (`fast`): apart by at most the weights'
        // quantisation (half a step times the pixel sum) and a few f32 steps of the sum of |x w|.
        for &(m, rows) in &[(19_200 / 40, 20), (2100, 7), (19_200, 3)] {
            let w = weights(m * rows);
            let q = QuantRows::new(&w, m);
            for x in images(m, 4).chunks_exact(m) {
                for level in Level::supported() {
                    let (mut a, mut b) = (vec![0f32; rows], vec![0f32; rows]);
                    dots(level, x, &q, &mut a);
                    crate::kernels::dot_u8::dots(level, x, &w, &mut b);
                    for r in 0..rows {
                        let mag: f64 = x.iter().zip(&w[r * m..(r + 1) * m]).map(|(&p, &v)| p as f64 * (v as f64).abs()).sum();
                        let quant = q.scale[r] / 2.0 * x.iter().map(|&v| v as f64).sum::<f64>();
                        assert!(((a[r] - b[r]) as f64).abs() <= quant + 1e-6 * mag + 1e-30, "{level:?} m {m} row {r}: {} vs {}", a[r], b[r]);
                    }
                }
            }
        }
    }

    #[test]
    fn the_largest_sums_do_not_overflow() {
        // 65,536 pixels of 255 against weights at +-VMAX: the lanes' and the energy's extremes.
        let m = 65_536;
        let xs = vec![255u8; 8 * m];
        for sign in [1f32, -1.0] {
            let q = QuantRows::new(&vec![sign; m], m);
            for level in Level::supported() {
                let (mut out, mut energy) = (vec![0f32; 8], vec![0u64; 8]);
                dots_batch(level, &xs, &q, &mut out, &mut energy, &mut Vec::new());
                assert!(out.iter().all(|&v| v == sign * 255.0 * m as f32), "{level:?} {out:?}");
                assert!(energy.iter().all(|&e| e == 65_025 * m as u64), "{level:?} {energy:?}");
            }
        }
    }
}
