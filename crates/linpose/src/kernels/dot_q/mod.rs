//! Products of 8-bit images with weight rows held in 16-bit fixed point, summed exactly in
//! integers: the eigenspace's 8-bit projection, without converting the pixels to f32.
//!
//! Each row r is stored as integers v (|v| <= [`VMAX`] = 32,639) with one scale
//! s_r = max |w_r| / VMAX, v = round(w / s_r): the quantisation error of a weight is at most
//! s_r / 2, so a product's error is at most s_r / 2 times the image's pixel sum (tested). A
//! product sum_p x_p v_p is then exact in integers, and its one rounding is the conversion of the
//! sum times s_r to f32.
//!
//! Why 16 bits: the error is of the order of the f32 basis's own (an estimate from an 8-bit
//! image moves from the same image's f32 estimate only at near ties between two poses), and two
//! digits take 2 instructions a step where three (24-bit fixed point, as fine as the f32 basis)
//! take 3.
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

#[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
pub use super::tuning::dot_q::DIGITS;
pub(crate) use super::tuning::dot_q::{CHUNK, GROUP};
use super::{dispatch, Level};

/// Largest stored integer: [`DIGITS`] balanced base-256 digits of at most 127.
pub(crate) const VMAX: i32 = 127 * ((1 << (8 * DIGITS)) - 1) / 255;
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
pub(crate) struct QuantRows {
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
    pub(crate) fn new(w: &[f32], m: usize) -> QuantRows {
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
    #[cfg(test)]
    pub(crate) fn rows(&self) -> usize {
        self.rows
    }

    /// The stored integer of row r at pixel p.
    #[cfg(test)]
    pub(crate) fn int(&self, r: usize, p: usize) -> i32 {
        (0..DIGITS).map(|k| self.digits()[self.at(r, k, p)] as i32 * radix(k) as i32).sum()
    }

    /// The weight row r as stored: its integers times its scale.
    #[cfg(test)]
    pub(crate) fn row(&self, r: usize) -> Vec<f64> {
        (0..self.m).map(|p| self.int(r, p) as f64 * self.scale[r]).collect()
    }
}

/// Whether the AVX-512 VNNI path runs at `level`: the only one faster than the f32 products of
/// [`super::dot_u8`] (the portable and AVX2 paths are exact too, but slower than them).
pub(crate) fn fast(level: Level) -> bool {
    level.avx512_vnni()
}

/// `out[r] = sum_p x[p] * row_r[p]` for every stored row, exact then rounded once.
#[track_caller]
pub(crate) fn dots(level: Level, x: &[u8], q: &QuantRows, out: &mut [f32]) {
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
    if level.avx512_vnni() {
        // SAFETY: the level is a token of detection that found AVX-512 F, BW and VNNI; the
        // kernel asserts the lengths it reads.
        return unsafe { vnni::sums_vnni(x, q, r0, s) };
    }
    sums_built(level, x, q, r0, s)
}

dispatch! {
    /// [`sums_portable`] at `level`.
    fn sums_built(x: &[u8], q: &QuantRows, r0: usize, s: &mut [i64]) = sums_portable;
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
pub(crate) struct FastRows(Option<QuantRows>);

/// The buffers of [`FastRows::dots_batch`], one per parallel task.
#[derive(Debug, Default)]
pub(crate) struct Scratch {
    f32s: Vec<f32>,
    i32s: Vec<i32>,
}

impl FastRows {
    /// The copy of `w` (rows of `m`), or none where [`fast`] does not hold for
    /// [`Level::detect`].
    pub(crate) fn new(w: &[f32], m: usize) -> FastRows {
        FastRows(fast(Level::detect()).then(|| QuantRows::new(w, m)))
    }

    fn at(&self, level: Level) -> Option<&QuantRows> {
        self.0.as_ref().filter(|_| fast(level))
    }

    /// Images per block the batch kernel at `level` wants: a group here, a register block of
    /// [`super::dot_u8::dots_batch`] otherwise.
    pub(crate) fn block(&self, level: Level) -> usize {
        if self.at(level).is_some() {
            GROUP * BLOCK
        } else {
            super::dot_u8::BATCH_IMAGES
        }
    }

    /// The products of `x` with every row of `w` (rows of `x.len()`) into `out`.
    pub(crate) fn dots(&self, level: Level, x: &[u8], w: &[f32], out: &mut [f32]) {
        match self.at(level) {
            Some(q) => dots(level, x, q, out),
            None => super::dot_u8::dots(level, x, w, out),
        }
    }

    /// [`FastRows::dots`] for the `xs.len() / m` images of `xs` into `into.out`, with each
    /// image's exact sum of squares into `into.energy`.
    pub(crate) fn dots_batch(&self, level: Level, xs: &[u8], m: usize, w: &[f32], into: Batch<'_>, scratch: &mut Scratch) {
        let Batch { out, energy } = into;
        match self.at(level) {
            Some(q) => dots_batch(level, xs, q, out, energy, &mut scratch.i32s),
            None => super::dot_u8::dots_batch(level, xs, m, w, out, energy, &mut scratch.f32s),
        }
    }
}

/// Where a batch's results go: each image's products (a row of them per image) and its exact
/// sum of squares.
pub(crate) struct Batch<'a> {
    pub out: &'a mut [f32],
    pub energy: &'a mut [u64],
}

/// Images per register block of [`dots_batch`]: a digit vector loaded serves this many images.
pub(crate) const BLOCK: usize = 8;
// A cache block's steps fit the u32 masks of nonzero steps.
const _: () = assert!(CHUNK <= 32);

/// [`dots`] for `xs.len() / m` images, and each image's exact sum of squares into `energy`; the
/// same bits as one image at a time (every path sums exactly). With AVX-512 VNNI (and images of
/// at most 65,536 pixels, so that no lane can overflow) the images go in groups of [`GROUP`]
/// register blocks of [`BLOCK`] images, each image read in order (16 streams, which the hardware
/// prefetcher follows, so no software prefetch), [`CHUNK`] steps at a time: the
/// chunk's pixels are copied to 64-byte boundaries while their squares and the mask of nonzero
/// steps are summed, then each row in turn passes over the steps in the mask, in registers of 8
/// images by [`DIGITS`] digits. `scratch` holds the lane sums between chunks. Images past the
/// last whole block go one at a time.
#[track_caller]
pub(crate) fn dots_batch(level: Level, xs: &[u8], q: &QuantRows, out: &mut [f32], energy: &mut [u64], scratch: &mut Vec<i32>) {
    let m = q.m;
    assert!(xs.len().is_multiple_of(m) && out.len() == xs.len() / m * q.rows && energy.len() == xs.len() / m);
    let n = xs.len() / m;
    let mut done = 0;
    #[cfg(target_arch = "x86_64")]
    if level.avx512_vnni() && m.div_ceil(STEP) <= SPAN && q.rows > 0 {
        done = n / BLOCK * BLOCK;
        for ((xb, ob), eb) in
            xs[..done * m].chunks(GROUP * BLOCK * m).zip(out[..done * q.rows].chunks_mut(GROUP * BLOCK * q.rows)).zip(energy[..done].chunks_mut(GROUP * BLOCK))
        {
            // SAFETY: the level is a token of detection that found AVX-512 F, BW and VNNI
            // (checked above); the group holds whole blocks of BLOCK images of m <= 65,536
            // pixels and one output per image and row.
            unsafe { vnni::group_vnni(xb, q, ob, eb, scratch) };
        }
    }
    let _ = scratch;
    for ((x, o), e) in xs[done * m..].chunks_exact(m).zip(out[done * q.rows..].chunks_exact_mut(q.rows)).zip(&mut energy[done..]) {
        dots(level, x, q, o);
        *e = super::dot_u8::sum_squares(x);
    }
}

#[cfg(target_arch = "x86_64")]
mod vnni;

#[cfg(test)]
mod tests;
