//! Pixel noise, measured and simulated (`uniform.rs`: [`add_uniform_noise`]). Measured:
//! Immerkaer's estimate of an image's white-noise variance (Fast noise variance estimation,
//! CVIU 64:300-302, 1996): the mean absolute response to the difference of two Laplacians,
//! [1 -2 1; -2 4 -2; 1 -2 1], times sqrt(pi / 2) / 6, squared. The mask cancels planes and
//! smooth shading, so what is left is the noise (and the image's edges, a floor that clean
//! images share).
//!
//! [`estimate_noise_sigma`] takes the whole of every image (the linear model's ridge rule).
//! The estimate a query is routed on ([`pixel_noise`], [`pixel_variance_in`] and
//! [`pixel_variance_u8_in`]) takes every [`NOISE_ROW_STEP`]-th row only: the estimate is a mean
//! over pixels, and a sample of rows costs less than the query's projection. It can be staged: a
//! first pass over a quarter of the sampled rows ([`Pass::First`]) settles a clearly clean image
//! without the rest; otherwise the rest's sums are added to the first's in the order of one
//! pass over them all, so the staged estimate has the unstaged one's bits.
//!
//! f32 images are summed in 16 f32 lanes per row, the lanes added in f64; 8-bit images exactly in
//! integers (the two agree to about 1e-6 relative). Each has an AVX-512 body ([`crate::kernels::noise`]) that
//! performs the portable body's operations in the same order, so every build gives the same bits.

mod tuning;
mod uniform;

#[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
pub use uniform::add_uniform_noise;
#[cfg(test)]
mod tests;

use crate::kernels::noise::{self, Image};
use crate::kernels::Level;
pub(crate) use tuning::FIRST_EVERY;
use tuning::{FIRST_AT, NOISE_ROW_STEP};

/// Immerkaer's fast estimate of the standard deviation of additive white noise in gray images
/// (CVIU 64(2), 1996): the mean absolute response to the Laplacian-difference mask
/// [1 -2 1; -2 4 -2; 1 -2 1], times sqrt(pi / 2) / 6, over every image's interior. In the same
/// units as the features (fractions of full brightness).
pub(crate) fn estimate_noise_sigma(features: &[f32], width: usize, height: usize) -> f64 {
    let m = width * height;
    if width < 3 || height < 3 || m == 0 {
        return 0.0;
    }
    let mut sum = 0.0f64;
    let mut count = 0usize;
    for img in features.chunks_exact(m) {
        for y in 1..height - 1 {
            for x in 1..width - 1 {
                let p = |dx: isize, dy: isize| img[(y as isize + dy) as usize * width + (x as isize + dx) as usize] as f64;
                let r = p(-1, -1) - 2.0 * p(0, -1) + p(1, -1) - 2.0 * p(-1, 0) + 4.0 * p(0, 0) - 2.0 * p(1, 0) + p(-1, 1) - 2.0 * p(0, 1) + p(1, 1);
                sum += r.abs();
                count += 1;
            }
        }
    }
    (std::f64::consts::PI / 2.0).sqrt() / 6.0 * sum / count.max(1) as f64
}

/// The pixel noise of an image (rows of `w` pixels of `ch` interleaved channels) relative to its
/// energy: Immerkaer's estimate of the noise's standard deviation (Fast noise variance
/// estimation, CVIU 64:300-302, 1996: the mean absolute response to the difference of two
/// Laplacians, which cancels smooth shading and planes), squared and over the mean square pixel,
/// i.e. the variance each unit-energy coordinate gets from white noise, times M. Edges of a
/// clean image give it a floor, measured on the training images.
pub(crate) fn pixel_noise(x: &[f32], w: usize, h: usize, ch: usize) -> f64 {
    let ms = x.iter().map(|&v| v as f64 * v as f64).sum::<f64>() / x.len() as f64;
    if ms > 0.0 {
        pixel_variance(x, w, h, ch) / ms
    } else {
        0.0
    }
}

/// Immerkaer's estimate of the variance of an image's white noise (see [`pixel_noise`]).
pub(crate) fn pixel_variance(x: &[f32], w: usize, h: usize, ch: usize) -> f64 {
    pixel_variance_in(x, w, h, ch, &mut RowsF32::new(w * ch, h, ch), 0.0)
}

/// [`pixel_variance`] with the row buffer `rows` (of w x ch values), so a batch allocates it
/// once. With `early` > 0 it is staged: the estimate from the first quarter of the sampled rows
/// ([`Pass::First`]) when that is under `early` (the image is clearly clean), else the estimate from every sampled row, the same bits as unstaged.
pub(crate) fn pixel_variance_in(x: &[f32], w: usize, h: usize, ch: usize, rows: &mut RowsF32, early: f64) -> f64 {
    let level = Level::detect();
    let pass = |rows: &mut RowsF32, pass: Pass| {
        let image = Image { w, h, ch, len: x.len() };
        match noise::mask_sums_f32(level, image, || SampledRows::new(x, w * ch, h, pass), &mut rows.sums) {
            Some(sums) => sums,
            None => immerkaer_pass(x, w, h, ch, rows, pass),
        }
    };
    rows.sums.resize(sampled_rows(h), 0.0);
    staged(w, h, ch, rows, early, pass)
}

/// Immerkaer's variance from `pass` (a body summing the sampled rows a [`Pass`] takes, and
/// counting them), staged when `early` > 0 and at least two rows would be in the first pass:
/// the first pass's estimate when under `early`, else the whole sum from the first pass's and
/// the rest's ([`MaskRows::whole`]).
#[inline(always)]
fn staged<T, R: MaskRows<T>>(w: usize, h: usize, ch: usize, rows: &mut R, early: f64, pass: impl Fn(&mut R, Pass) -> (f64, usize)) -> f64 {
    let (sum, count) = if early > 0.0 && sampled_rows(h) >= 2 * FIRST_EVERY {
        let (first, count) = pass(rows, Pass::First);
        let v = variance_from(first, count, w * ch, ch);
        if v < early {
            return v;
        }
        let (rest, more) = pass(rows, Pass::Rest);
        (rows.whole(first, rest), count + more)
    } else {
        pass(rows, Pass::All)
    };
    variance_from(sum, count, w * ch, ch)
}

/// Immerkaer's estimate (see [`pixel_noise`]) from every [`NOISE_ROW_STEP`]-th row of an image
/// of `w` pixels of `ch` channels per row: the estimate is a mean over pixels, and a sample of
/// rows costs less than the projection. `rows` sums the absolute mask responses along each.
#[cfg(test)]
fn immerkaer<T, R: MaskRows<T>>(x: &[T], w: usize, h: usize, ch: usize, rows: &mut R) -> f64 {
    let (sum, count) = immerkaer_pass(x, w, h, ch, rows, Pass::All);
    variance_from(sum, count, w * ch, ch)
}

/// The sum of the absolute mask responses along the sampled rows `pass` takes, and how many
/// rows those are (none in an image of fewer than 3 rows or columns).
#[inline(always)]
fn immerkaer_pass<T, R: MaskRows<T>>(x: &[T], w: usize, h: usize, ch: usize, rows: &mut R, pass: Pass) -> (f64, usize) {
    if w < 3 || h < 3 {
        return (0.0, 0);
    }
    let (mut sum, mut count) = (0.0f64, 0usize);
    for (k, a, b, c) in SampledRows::new(x, w * ch, h, pass) {
        let s = rows.row_sum(a, b, c);
        rows.keep(k, s);
        sum += s;
        count += 1;
    }
    sum += rows.total();
    (sum, count)
}

/// How many rows [`immerkaer_pass`] samples in an image of `h` rows: rows 1, 1 + [`NOISE_ROW_STEP`],
/// .. up to h - 2.
pub(crate) fn sampled_rows(h: usize) -> usize {
    if h < 3 {
        0
    } else {
        (h - 3) / NOISE_ROW_STEP + 1
    }
}

/// Which of the sampled rows a pass of the noise estimate sums: all of them, or, for a query
/// that may be clearly clean ([`pixel_variance_in`]'s `early`), first every [`FIRST_EVERY`]-th
/// (from sampled row [`FIRST_AT`]) and then, unless those settle it, the rest.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Pass {
    All,
    First,
    Rest,
}

impl Pass {
    /// Whether this pass sums sampled row `k`.
    #[inline(always)]
    fn takes(self, k: usize) -> bool {
        match self {
            Pass::All => true,
            Pass::First => k % FIRST_EVERY == FIRST_AT,
            Pass::Rest => k % FIRST_EVERY != FIRST_AT,
        }
    }

    /// The first sampled row after `k` this pass sums (`None`: the first of all).
    #[inline(always)]
    fn after(self, k: Option<usize>) -> usize {
        let mut k = k.map_or(0, |k| k + 1);
        while !self.takes(k) {
            k += 1;
        }
        k
    }
}

/// The rows [`immerkaer_pass`] samples that a [`Pass`] sums, each as its index among the sampled
/// rows with the rows above and below it (an image of `row` values a row, at least 3 rows); the
/// next sample's cache lines are asked for while one is summed (they are too far apart for the
/// hardware prefetcher).
struct SampledRows<'a, T> {
    x: &'a [T],
    row: usize,
    /// The next sampled row to give, and how many there are.
    k: usize,
    n: usize,
    pass: Pass,
}

impl<'a, T> SampledRows<'a, T> {
    #[inline(always)]
    fn new(x: &'a [T], row: usize, h: usize, pass: Pass) -> Self {
        assert!(h >= 3 && x.len() >= row * h, "an image of at least 3 rows of {row} values");
        let k = pass.after(None);
        let rows = SampledRows { x, row, k, n: sampled_rows(h), pass };
        rows.prefetch(pass.after(Some(k)));
        rows
    }

    /// Asks for the cache lines of sampled row `k` and its neighbours (if there is such a row).
    #[inline(always)]
    fn prefetch(&self, k: usize) {
        if k < self.n {
            let yy = 1 + NOISE_ROW_STEP * k;
            prefetch(&self.x[(yy - 1) * self.row..(yy + 2) * self.row]);
        }
    }
}

impl<'a, T> Iterator for SampledRows<'a, T> {
    type Item = (usize, &'a [T], &'a [T], &'a [T]);

    #[inline(always)]
    fn next(&mut self) -> Option<Self::Item> {
        let (x, row, k) = (self.x, self.row, self.k);
        if k >= self.n {
            return None;
        }
        self.k = self.pass.after(Some(k));
        self.prefetch(self.pass.after(Some(self.k)));
        let yy = 1 + NOISE_ROW_STEP * k;
        Some((k, &x[(yy - 1) * row..yy * row], &x[yy * row..(yy + 1) * row], &x[(yy + 1) * row..(yy + 2) * row]))
    }
}

/// Immerkaer's variance from the sum of the mask's absolute responses over `count` rows of
/// `row` values of `ch` channels (less `ch` at each end); 0 without any.
fn variance_from(sum: f64, count: usize, row: usize, ch: usize) -> f64 {
    if count == 0 || row <= 2 * ch {
        return 0.0;
    }
    let total = ((row - 2 * ch) * count) as f64;
    let sigma = (std::f64::consts::PI / 2.0).sqrt() * sum / (6.0 * total);
    sigma * sigma
}

/// Hints every cache line of `v` into the caches (nothing off x86-64).
#[inline(always)]
fn prefetch<T>(v: &[T]) {
    #[cfg(target_arch = "x86_64")]
    {
        let (p, bytes) = (v.as_ptr() as *const i8, std::mem::size_of_val(v));
        for off in (0..bytes).step_by(64) {
            // SAFETY: a prefetch never faults; the address lies inside `v`.
            unsafe { std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p.add(off)) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = v;
}

/// The row sums of [`immerkaer_pass`]: the absolute responses along row b (its neighbours a and c) of
/// the second difference along x of the second difference across the three rows, over the row's
/// pixels less `ch` at each end. A trait with always-inlined methods (not a closure), so that the
/// AVX-512 builds of [`pixel_variance_in`] and [`pixel_variance_u8_in`] compile it for AVX-512 too.
trait MaskRows<T> {
    fn row_sum(&mut self, a: &[T], b: &[T], c: &[T]) -> f64;
    /// Keeps sampled row `k`'s sum `s` (as returned by `row_sum`) where the rows are summed
    /// again in their order (nothing by default).
    #[inline(always)]
    fn keep(&mut self, _k: usize, _s: f64) {}
    /// The sum over every sampled row from a staged estimate's two passes' sums (their sum by
    /// default: exact for integer sums).
    #[inline(always)]
    fn whole(&self, first: f64, rest: f64) -> f64 {
        first + rest
    }
    /// What the rows summed without returning it (0 when each row returns its own).
    fn total(&mut self) -> f64 {
        0.0
    }
}

/// f32 rows: the differences across rows into `dy`, then 16 lane sums so the loop vectorises
/// (the row's last responses into the first lanes, as a partial vector); each sampled row's sum
/// kept in `sums`, so a staged estimate adds them up in one pass's order.
pub(crate) struct RowsF32 {
    dy: Vec<f32>,
    sums: Vec<f64>,
    ch: usize,
}

impl RowsF32 {
    /// Made for an image of `h` rows of `row` values of `ch` channels.
    pub(crate) fn new(row: usize, h: usize, ch: usize) -> RowsF32 {
        RowsF32 { dy: vec![0f32; row], sums: vec![0.0; sampled_rows(h)], ch }
    }

    /// The buffer in `slot` (new if none) made for rows of `row` values of `ch` channels (every
    /// row overwrites it whole).
    pub(crate) fn reuse(slot: &mut Option<RowsF32>, row: usize, ch: usize) -> &mut RowsF32 {
        let r = slot.get_or_insert_with(|| RowsF32::new(row, 0, ch));
        r.ch = ch;
        r.dy.resize(row, 0.0);
        r
    }
}

impl MaskRows<f32> for RowsF32 {
    #[inline(always)]
    fn keep(&mut self, k: usize, s: f64) {
        self.sums[k] = s;
    }

    /// Every sampled row's kept sum, added in the order of one pass over them all (the same
    /// bits as unstaged).
    #[inline(always)]
    fn whole(&self, _first: f64, _rest: f64) -> f64 {
        self.sums.iter().fold(0.0, |s, &v| s + v)
    }

    #[inline(always)]
    fn row_sum(&mut self, a: &[f32], b: &[f32], c: &[f32]) -> f64 {
        let (dy, ch) = (&mut self.dy, self.ch);
        let n = dy.len() - 2 * ch;
        dy.iter_mut().zip(a.iter().zip(b).zip(c)).for_each(|(d, ((&p, &q), &r))| *d = p - 2.0 * q + r);
        let (d0, d1, d2) = (&dy[..n], &dy[ch..ch + n], &dy[2 * ch..2 * ch + n]);
        let mut lanes = [0f32; 16];
        let (c0, c1, c2) = (d0.chunks_exact(16), d1.chunks_exact(16), d2.chunks_exact(16));
        let (t0, t1, t2) = (c0.remainder(), c1.remainder(), c2.remainder());
        for ((p, q), r) in c0.zip(c1).zip(c2) {
            for l in 0..16 {
                lanes[l] += (p[l] - 2.0 * q[l] + r[l]).abs();
            }
        }
        // The rest into the first lanes (as a last, partial vector).
        for l in 0..t0.len() {
            lanes[l] += (t0[l] - 2.0 * t1[l] + t2[l]).abs();
        }
        let mut sum = -0.0f64;
        for v in lanes {
            sum += v as f64;
        }
        sum
    }
}

/// 8-bit rows, exact in integers: the differences across rows (within +-510) and the mask's
/// responses (within +-2040) in i16 lanes, over whole vectors of 32 (responses past the row's end
/// masked to 0), summed in 32 u32 lanes across rows and added up once per image (an integer sum:
/// the same value in any order), flushed to u64 before a lane could pass 2^32.
pub(crate) struct RowsU8 {
    /// The differences across rows, zero past the row's end.
    dy: Vec<i16>,
    /// All ones for the row's responses, 0 past them.
    keep: Vec<u16>,
    acc: [u32; 32],
    rows: usize,
    flush_every: usize,
    total: u64,
    ch: usize,
}

impl RowsU8 {
    /// The buffers in `slot` when they are made for rows of `row` values of `ch` channels, else
    /// new ones put there.
    pub(crate) fn reuse(slot: &mut Option<RowsU8>, row: usize, ch: usize) -> &mut RowsU8 {
        // The mask's length and the channels fix every buffer's (see new).
        if !slot.as_ref().is_some_and(|r| r.ch == ch && r.keep.len() == row.saturating_sub(2 * ch).div_ceil(32) * 32) {
            *slot = Some(RowsU8::new(row, ch));
        }
        slot.as_mut().expect("just filled")
    }

    fn new(row: usize, ch: usize) -> RowsU8 {
        let n = row.saturating_sub(2 * ch);
        let n32 = n.div_ceil(32) * 32;
        let mut keep = vec![0u16; n32];
        keep[..n].fill(u16::MAX);
        let flush_every = (u32::MAX as usize / ((n32 / 32).max(1) * 2040)).max(1);
        RowsU8 { dy: vec![0i16; n32 + 2 * ch], keep, acc: [0; 32], rows: 0, flush_every, total: 0, ch }
    }

    #[inline(always)]
    fn flush(&mut self) {
        self.total += self.acc.iter().map(|&v| v as u64).sum::<u64>();
        (self.acc, self.rows) = ([0; 32], 0);
    }
}

impl MaskRows<u8> for RowsU8 {
    #[inline(always)]
    fn row_sum(&mut self, a: &[u8], b: &[u8], c: &[u8]) -> f64 {
        let ch = self.ch;
        self.dy.iter_mut().zip(a.iter().zip(b).zip(c)).for_each(|(d, ((&p, &q), &r))| *d = p as i16 - 2 * q as i16 + r as i16);
        let n32 = self.keep.len();
        let (d0, d1, d2) = (&self.dy[..n32], &self.dy[ch..ch + n32], &self.dy[2 * ch..2 * ch + n32]);
        for (((p, q), r), m) in d0.chunks_exact(32).zip(d1.chunks_exact(32)).zip(d2.chunks_exact(32)).zip(self.keep.chunks_exact(32)) {
            for l in 0..32 {
                self.acc[l] += ((p[l] - 2 * q[l] + r[l]).unsigned_abs() & m[l]) as u32;
            }
        }
        self.rows += 1;
        if self.rows == self.flush_every {
            self.flush();
        }
        0.0
    }

    #[inline(always)]
    fn total(&mut self) -> f64 {
        self.flush();
        let t = self.total;
        self.total = 0;
        t as f64
    }
}

/// [`pixel_variance_u8_in`], unstaged and with buffers of its own (for tests).
#[cfg(test)]
pub(crate) fn pixel_variance_u8(x: &[u8], w: usize, h: usize, ch: usize) -> f64 {
    pixel_variance_u8_in(x, w, h, ch, &mut RowsU8::new(w * ch, ch), 0.0)
}

/// [`pixel_variance`] of an 8-bit image given as raw pixel values, in their units (255^2 times
/// that of its features, pixel / 255): the same mask and rows, summed exactly in integers (the
/// f32 path rounds, so the two agree to about 1e-6 relative). With the row buffers `rows` (made
/// for rows of w x ch values), so a batch allocates them once; staged when `early` > 0, as
/// [`pixel_variance_in`] (the two passes' integer sums add up to the one pass's exactly).
pub(crate) fn pixel_variance_u8_in(x: &[u8], w: usize, h: usize, ch: usize, rows: &mut RowsU8, early: f64) -> f64 {
    let level = Level::detect();
    let pass = |rows: &mut RowsU8, pass: Pass| {
        let image = Image { w, h, ch, len: x.len() };
        let lanes = noise::RowsU8 { keep: &rows.keep, flush_every: rows.flush_every };
        match noise::mask_sums_u8(level, image, || SampledRows::new(x, w * ch, h, pass), lanes) {
            Some(sums) => sums,
            None => immerkaer_pass(x, w, h, ch, rows, pass),
        }
    };
    staged(w, h, ch, rows, early, pass)
}
