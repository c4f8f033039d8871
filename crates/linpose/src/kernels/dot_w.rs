//! Products of 16-bit images (the block sums of binned 8-bit images, [`crate::binning`]) with
//! weight rows in 16-bit fixed point, summed exactly in integers.
//!
//! The weights are stored as in [`super::dot_q`]: row r as integers v (|v| <= [`VMAX`], the
//! same as the two digits there) with one scale s_r = max |w_r| / VMAX. An image holds integers
//! 0 <= x <= `xmax` (at most 32,767: a gray or colour block sum of at most 255 b^2 for a factor
//! b <= 11). AVX-512 VNNI's `vpdpwssd` multiplies 32 pairs of signed 16-bit values a step and
//! adds them in twos into 16 i32 lanes: 32 pixels of one row for one instruction, where the
//! 8-bit kernel takes two digit planes of the sums (low and high byte) times two digits of the
//! weights, 4 instructions for 64 pixels against 2 here. A lane takes at most 2 xmax VMAX a
//! step, so the i32 lanes are added into i64 every [`WordRows::span`] steps (32 for sums of at
//! most 1,020, binned by 2; 8 for 4,080, by 4), and the result is exact: every path gives the
//! same integers (tested), rounded once when scaled to f32. Steps where every image of a block
//! is zero (a black background) are skipped.
//!
//! Only the VNNI path is fast; where it is missing ([`super::dot_q::fast`]) models use the 8-bit
//! kernels on the digit planes instead, and the portable body here serves as the reference.

use super::dot_q::VMAX;
use super::Level;

/// Values per step: one 512-bit vector of i16.
pub(crate) const STEP: usize = 32;
/// Images per register block of the VNNI kernel.
pub(crate) const BLOCK: usize = 4;

/// 32 i16 on a 64-byte boundary.
#[derive(Debug, Clone, Copy, Default)]
#[repr(C, align(64))]
pub(crate) struct Line(pub [i16; STEP]);

/// Weight rows in 16-bit fixed point for images of integers up to a bound (see the module doc).
#[derive(Debug, Clone)]
pub(crate) struct WordRows {
    rows: usize,
    m: usize,
    /// Per row, the scale of its integers.
    scale: Vec<f64>,
    /// Row by row, m.div_ceil(STEP) lines each, zero past m.
    lines: Vec<Line>,
    /// Steps summed in i32 before they are added into i64.
    span: usize,
}

impl WordRows {
    /// The rows of `w` (`rows` x `m`, finite), each scaled to [-VMAX, VMAX] and rounded, for
    /// images of integers in [0, `xmax`]; none when `xmax` exceeds i16 or a single step could
    /// overflow an i32 lane.
    #[track_caller]
    pub(crate) fn new(w: &[f32], m: usize, xmax: u32) -> Option<WordRows> {
        assert!(m > 0 && w.len().is_multiple_of(m), "whole rows of m > 0 weights");
        assert!(w.iter().all(|v| v.is_finite()), "finite weights");
        if xmax == 0 || xmax > i16::MAX as u32 {
            return None;
        }
        let span = (i32::MAX as u64 / (2 * xmax as u64 * VMAX as u64)) as usize;
        if span == 0 {
            return None;
        }
        let rows = w.len() / m;
        let steps = m.div_ceil(STEP);
        let mut lines = vec![Line::default(); rows * steps];
        let scale = super::dot_q::fixed_point(w, m, |r, p, v| lines[r * steps + p / STEP].0[p % STEP] = v as i16);
        Some(WordRows { rows, m, scale, lines, span })
    }

    /// Steps of the lines of one image ([`Self::lines_of`]).
    pub(crate) fn steps(&self) -> usize {
        self.m.div_ceil(STEP)
    }

    /// Steps summed in i32 lanes before they are added into i64.
    #[cfg(test)]
    pub(crate) fn span(&self) -> usize {
        self.span
    }

    /// The stored integer of row r at pixel p.
    #[cfg(test)]
    pub(crate) fn int(&self, r: usize, p: usize) -> i32 {
        self.lines[r * self.steps() + p / STEP].0[p % STEP] as i32
    }

    /// The scale of row r.
    #[cfg(test)]
    pub(crate) fn scale(&self, r: usize) -> f64 {
        self.scale[r]
    }

    /// Room for `n` images in lines, as [`Self::dots_batch`] takes them: image i's values at
    /// `i * steps() * STEP`, zero past m; the caller writes the first m of each (only the
    /// padding is cleared: a batch's lines are written once, not twice).
    pub(crate) fn lines_of(&self, n: usize, buf: &mut Vec<Line>) {
        let steps = self.steps();
        buf.resize(n * steps, Line::default());
        let tail = self.m % STEP;
        if tail != 0 {
            for image in buf[..n * steps].chunks_exact_mut(steps) {
                image[steps - 1].0[tail..].fill(0);
            }
        }
    }

    /// The values of `lines` (written as u16, read as i16: at most xmax <= 32,767).
    pub(crate) fn values_mut(lines: &mut [Line]) -> &mut [u16] {
        // SAFETY: a `Line` is 32 i16 with no padding, the lines are contiguous, and u16 has
        // i16's size and alignment.
        unsafe { std::slice::from_raw_parts_mut(lines.as_mut_ptr() as *mut u16, lines.len() * STEP) }
    }

    /// `out[i rows + r] = s_r sum_p x_i[p] v_r[p]` for every image i of `xs` (lines from
    /// [`Self::lines_of`], values in [0, xmax]) and row r, exact in integers, rounded once.
    /// `idx` is scratch. The VNNI kernel where [`super::dot_q::fast`] holds, else the portable
    /// body.
    #[track_caller]
    pub(crate) fn dots_batch(&self, level: Level, xs: &[Line], out: &mut [f32], idx: &mut Vec<u32>) {
        let steps = self.steps();
        assert!(xs.len().is_multiple_of(steps) && out.len() == xs.len() / steps * self.rows, "whole images, one output per image and row");
        #[cfg(target_arch = "x86_64")]
        if super::dot_q::fast(level) {
            for (x, o) in xs.chunks(BLOCK * steps).zip(out.chunks_mut(BLOCK * self.rows)) {
                // SAFETY: fast(level) means AVX-512 F/BW/VNNI were detected; the block holds
                // whole images of `steps` lines and one output per image and row (asserted).
                unsafe { x86::block(self, x, o, idx) };
            }
            return;
        }
        let _ = (level, idx);
        for (x, o) in xs.chunks_exact(steps).zip(out.chunks_exact_mut(self.rows)) {
            for (r, o) in o.iter_mut().enumerate() {
                *o = (self.sum_portable(x, r) as f64 * self.scale[r]) as f32;
            }
        }
    }

    /// The exact integer sum of one image's lines with row r, in i32 span by span as the
    /// kernel adds them (the same integers: every partial sum is exact).
    fn sum_portable(&self, x: &[Line], r: usize) -> i64 {
        let steps = self.steps();
        let w = &self.lines[r * steps..(r + 1) * steps];
        let mut total = 0i64;
        for (xc, wc) in x.chunks(self.span).zip(w.chunks(self.span)) {
            let mut lanes = [0i32; STEP / 2];
            for (xl, wl) in xc.iter().zip(wc) {
                for (k, lane) in lanes.iter_mut().enumerate() {
                    *lane += xl.0[2 * k] as i32 * wl.0[2 * k] as i32 + xl.0[2 * k + 1] as i32 * wl.0[2 * k + 1] as i32;
                }
            }
            total += lanes.iter().map(|&v| v as i64).sum::<i64>();
        }
        total
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{Line, WordRows, BLOCK, STEP};
    use std::arch::x86_64::*;

    /// Up to [`BLOCK`] images (`xs`, whole images of `q.steps()` lines) against every row into
    /// `out` (per image, one value per row): the steps where some image is not zero listed in
    /// `idx`, then rows two at a time over them.
    ///
    /// # Safety
    /// The CPU must support AVX-512 F, BW and VNNI.
    #[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
    pub(super) unsafe fn block(q: &WordRows, xs: &[Line], out: &mut [f32], idx: &mut Vec<u32>) {
        let steps = q.steps();
        let nb = xs.len() / steps;
        idx.clear();
        for s in 0..steps {
            let mut any = _mm512_setzero_si512();
            for b in 0..nb {
                any = _mm512_or_si512(any, _mm512_load_si512(xs.as_ptr().add(b * steps + s) as *const _));
            }
            if _mm512_test_epi16_mask(any, any) != 0 {
                idx.push(s as u32);
            }
        }
        let xp = xs.as_ptr() as *const i16;
        let wp = q.lines.as_ptr() as *const i16;
        let rows = q.rows;
        let mut sums = [[0i64; BLOCK]; 2];
        let mut r = 0;
        while r < rows {
            let pair = rows - r >= 2;
            match (nb, pair) {
                (4, true) => rows_block::<4, 2>(xp, wp, steps, r, q.span, idx, &mut sums),
                (4, false) => rows_block::<4, 1>(xp, wp, steps, r, q.span, idx, &mut sums),
                (3, true) => rows_block::<3, 2>(xp, wp, steps, r, q.span, idx, &mut sums),
                (3, false) => rows_block::<3, 1>(xp, wp, steps, r, q.span, idx, &mut sums),
                (2, true) => rows_block::<2, 2>(xp, wp, steps, r, q.span, idx, &mut sums),
                (2, false) => rows_block::<2, 1>(xp, wp, steps, r, q.span, idx, &mut sums),
                (_, true) => rows_block::<1, 2>(xp, wp, steps, r, q.span, idx, &mut sums),
                (_, false) => rows_block::<1, 1>(xp, wp, steps, r, q.span, idx, &mut sums),
            }
            let nr = if pair { 2 } else { 1 };
            for (j, s) in sums[..nr].iter().enumerate() {
                for (b, &v) in s[..nb].iter().enumerate() {
                    out[b * rows + r + j] = (v as f64 * q.scale[r + j]) as f32;
                }
            }
            r += nr;
        }
    }

    /// Rows r.. (R of them) against B images over the listed steps: i32 lanes for `span` steps
    /// at a time, then added into i64 lanes; the sums into `sums[j][b]`.
    ///
    /// # Safety
    /// The CPU must support AVX-512 F, BW and VNNI; `xp` must hold B images of `steps` lines
    /// and `wp` rows r..r + R of `steps` lines, all on 64-byte boundaries, and every step of
    /// `idx` must be below `steps`.
    #[inline]
    #[allow(clippy::needless_range_loop)]
    #[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
    unsafe fn rows_block<const B: usize, const R: usize>(
        xp: *const i16,
        wp: *const i16,
        steps: usize,
        r: usize,
        span: usize,
        idx: &[u32],
        sums: &mut [[i64; BLOCK]; 2],
    ) {
        let mut wide = [[_mm512_setzero_si512(); B]; R];
        for chunk in idx.chunks(span) {
            let mut acc = [[_mm512_setzero_si512(); B]; R];
            for &s in chunk {
                let off = s as usize * STEP;
                let mut w = [_mm512_setzero_si512(); R];
                for (j, w) in w.iter_mut().enumerate() {
                    *w = _mm512_load_si512(wp.add((r + j) * steps * STEP + off) as *const _);
                }
                for b in 0..B {
                    let x = _mm512_load_si512(xp.add(b * steps * STEP + off) as *const _);
                    for j in 0..R {
                        acc[j][b] = _mm512_dpwssd_epi32(acc[j][b], x, w[j]);
                    }
                }
            }
            for j in 0..R {
                for b in 0..B {
                    let a = acc[j][b];
                    let lo = _mm512_cvtepi32_epi64(_mm512_castsi512_si256(a));
                    let hi = _mm512_cvtepi32_epi64(_mm512_extracti64x4_epi64::<1>(a));
                    wide[j][b] = _mm512_add_epi64(wide[j][b], _mm512_add_epi64(lo, hi));
                }
            }
        }
        for j in 0..R {
            for b in 0..B {
                sums[j][b] = _mm512_reduce_add_epi64(wide[j][b]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn weights(rows: usize, m: usize) -> Vec<f32> {
        (0..rows * m).map(|i| ((i * 2654435761usize) % 2003) as f32 / 1001.0 - 1.0).collect()
    }

    /// n images of m values in [0, xmax], with runs of zeros (skipped steps) and the bound itself.
    fn images(n: usize, m: usize, xmax: u32, q: &WordRows) -> (Vec<Vec<i16>>, Vec<Line>) {
        // A buffer that held other values first: lines_of clears the padding.
        let mut buf = vec![Line([-1; STEP]); n * q.steps() + 3];
        q.lines_of(n, &mut buf);
        let mut plain = Vec::new();
        for i in 0..n {
            let x: Vec<i16> = (0..m)
                .map(|p| {
                    let black = (p / 40 + i) % 3 == 0;
                    if black {
                        0
                    } else if p % 7 == 0 {
                        xmax as i16
                    } else {
                        (((p * 7919 + i * 104729) % (xmax as usize + 1)) as i16).max(0)
                    }
                })
                .collect();
            for (p, &v) in x.iter().enumerate() {
                buf[i * q.steps() + p / STEP].0[p % STEP] = v;
            }
            plain.push(x);
        }
        (plain, buf)
    }

    #[test]
    fn products_are_exact_on_every_path_and_batch_size() {
        for (m, xmax) in [(100, 1020u32), (1000, 4080), (4096, 1020), (257, 16320), (300, 30855)] {
            let rows = 5;
            let w = weights(rows, m);
            let q = WordRows::new(&w, m, xmax).unwrap();
            assert!(q.span() >= 1);
            for n in [1, 2, 3, 4, 5, 9] {
                let (plain, buf) = images(n, m, xmax, &q);
                let mut idx = Vec::new();
                let outs: Vec<Vec<f32>> = Level::supported()
                    .into_iter()
                    .map(|level| {
                        let mut out = vec![0.0; n * rows];
                        q.dots_batch(level, &buf, &mut out, &mut idx);
                        out
                    })
                    .collect();
                for (i, x) in plain.iter().enumerate() {
                    for r in 0..rows {
                        let exact: i64 = x.iter().enumerate().map(|(p, &v)| v as i64 * q.int(r, p) as i64).sum();
                        let want = (exact as f64 * q.scale(r)) as f32;
                        for out in &outs {
                            assert_eq!(out[i * rows + r], want, "m {m} xmax {xmax} n {n} image {i} row {r}");
                        }
                        // Against the weights themselves: within half a step of the scale per unit of pixel sum.
                        let sum: f64 = x.iter().map(|&v| v as f64).sum();
                        let f: f64 = x.iter().zip(&w[r * m..(r + 1) * m]).map(|(&v, &wv)| v as f64 * wv as f64).sum();
                        assert!((want as f64 - f).abs() <= q.scale(r) / 2.0 * sum + 1e-5 * f.abs() + 1e-3, "{want} against {f}");
                    }
                }
            }
        }
    }

    #[test]
    fn the_integers_are_the_8_bit_kernels() {
        let (rows, m) = (3, 200);
        let mut w = weights(rows, m);
        w[m..2 * m].fill(0.0);
        let (q, d) = (WordRows::new(&w, m, 1020).unwrap(), super::super::dot_q::QuantRows::new(&w, m));
        for r in 0..rows {
            for p in 0..m {
                assert_eq!(q.int(r, p), d.int(r, p), "row {r} pixel {p}");
            }
        }
    }

    #[test]
    fn bounds_beyond_i16_are_refused_and_the_span_follows_the_bound() {
        let w = weights(2, 64);
        assert!(WordRows::new(&w, 64, 0).is_none());
        assert!(WordRows::new(&w, 64, 32_768).is_none());
        assert_eq!(WordRows::new(&w, 64, 32_767).unwrap().span(), 1, "2 x 32,767 x VMAX fits a lane");
        assert_eq!(WordRows::new(&w, 64, 1020).unwrap().span(), 32);
        assert_eq!(WordRows::new(&w, 64, 4080).unwrap().span(), 8);
        assert_eq!(WordRows::new(&w, 64, 30_855).unwrap().span(), 1);
    }
}
