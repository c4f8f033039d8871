//! Box-filter downsampling ("binning"): each output pixel the mean of a b x b block of input
//! pixels, channel by channel; the last `width % b` columns and `height % b` rows are left out.
//!
//! A binned image keeps the low spatial frequencies that change smoothly with pose and drops
//! the fine detail (stripes, edges, texture) whose appearance aliases between training views, so
//! a spline through binned training views interpolates the unseen ones better. Averaging b^2
//! pixels also divides independent pixel noise's variance by b^2, and every product with an
//! eigenimage costs b^2 times less.
//!
//! The sums are taken in one fixed order (the b rows of a block added down each column, then
//! the b columns across), then scaled by 1 / b^2, so an image binned here has the same bits
//! however it reached the function (features of an image file, or its 8-bit values times the
//! feature scale first).

use crate::image_io::ImageSpec;
use crate::kernels::binning::GrayBlocks;
use crate::kernels::Level;
use crate::{Error, Result};
use rayon::prelude::*;

/// Largest binning factor.
pub(crate) const MAX_FACTOR: usize = 16;

/// Binning by `factor` of images of the spec `full`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Binning {
    factor: usize,
    full: ImageSpec,
}

impl Binning {
    /// Binning of `full` images by `factor` (1 to [`MAX_FACTOR`]); a factor above 1 must leave
    /// at least 3 x 3 pixels (the pixel-noise estimate's mask).
    pub(crate) fn new(full: ImageSpec, factor: usize) -> Result<Self> {
        if !(1..=MAX_FACTOR).contains(&factor) {
            return Err(Error::invalid("bin", factor, format!("must be 1 to {MAX_FACTOR}")));
        }
        let b = Binning { factor, full };
        let s = b.spec();
        if factor > 1 && (s.width < 3 || s.height < 3) {
            return Err(Error::invalid(
                "bin",
                factor,
                format!("{}x{} images binned by {factor} leave {}x{} pixels, fewer than 3x3", full.width, full.height, s.width, s.height),
            ));
        }
        Ok(b)
    }

    /// The coarsest binning of `full` images by at most `factor` (halved while too coarse) whose
    /// binned images keep at least `views` pixels (so that the pixels do not cap the span of
    /// that many views) and 3 x 3; by 1 when none does.
    pub(crate) fn coarsest(full: ImageSpec, factor: usize, views: usize) -> Binning {
        let mut f = factor.clamp(1, MAX_FACTOR);
        while f > 1 {
            match Binning::new(full, f) {
                Ok(b) if b.spec().features() >= views => return b,
                _ => f /= 2,
            }
        }
        Binning { factor: 1, full }
    }

    /// The factor b.
    pub(crate) fn factor(&self) -> usize {
        self.factor
    }

    /// Whether images are binned at all (b > 1).
    pub(crate) fn bins(&self) -> bool {
        self.factor > 1
    }

    /// The spec of the images binned.
    pub(crate) fn full(&self) -> ImageSpec {
        self.full
    }

    /// The spec of a binned image.
    pub(crate) fn spec(&self) -> ImageSpec {
        let b = self.factor as u32;
        ImageSpec { width: self.full.width / b, height: self.full.height / b, color: self.full.color }
    }

    /// Bins one image `x` (features of [`Self::full`]) into `out` (features of [`Self::spec`]),
    /// with `acc` as scratch. Gray images binned by 2 or 4 go through a body built for the SIMD
    /// level (the same sums in the same order).
    pub(crate) fn apply(&self, x: &[f32], out: &mut [f32], acc: &mut Vec<f32>) {
        let ch = self.full.color.channels();
        let (w, b) = (self.full.width as usize, self.factor);
        let s = self.spec();
        let (wb, hb) = (s.width as usize, s.height as usize);
        assert_eq!(x.len(), self.full.features(), "an image of {} features", self.full.features());
        assert_eq!(out.len(), s.features(), "a binned image of {} features", s.features());
        let (row, span, orow) = (w * ch, wb * b * ch, wb * ch);
        let scale = 1.0 / (b * b) as f32;
        acc.resize(span, 0.0);
        if ch == 1 && b == 2 {
            return gray_means::<2>(Level::detect(), x, w, out, acc);
        }
        if ch == 1 && b == 4 {
            return gray_means::<4>(Level::detect(), x, w, out, acc);
        }
        for (yo, o) in out.chunks_exact_mut(orow).enumerate().take(hb) {
            let top = yo * b * row;
            acc.copy_from_slice(&x[top..top + span]);
            for r in 1..b {
                let src = &x[top + r * row..top + r * row + span];
                acc.iter_mut().zip(src).for_each(|(a, &v)| *a += v);
            }
            for (xo, px) in o.chunks_exact_mut(ch).enumerate() {
                for (c, v) in px.iter_mut().enumerate() {
                    let mut sum = acc[xo * b * ch + c];
                    for k in 1..b {
                        sum += acc[(xo * b + k) * ch + c];
                    }
                    *v = sum * scale;
                }
            }
        }
    }

    /// The block sums (not means) of an 8-bit image `x` (raw values, [`Self::full`]'s layout)
    /// into `out` (one per binned value, exact: at most 255 x 16^2 = 65,280), with `acc` as
    /// scratch; returns their exact sum of squares.
    pub(crate) fn sums_u8(&self, x: &[u8], out: &mut [u16], acc: &mut Vec<u16>) -> u64 {
        self.sums_u8_at(Level::detect(), x, out, acc)
    }

    /// [`Self::sums_u8`] at `level`: gray images binned by 2 or 4 (the query paths' factors)
    /// by a body built for the level's SIMD set (the same integers on every level), others by
    /// the general loop.
    pub(crate) fn sums_u8_at(&self, level: Level, x: &[u8], out: &mut [u16], acc: &mut Vec<u16>) -> u64 {
        let ch = self.full.color.channels();
        let (w, b) = (self.full.width as usize, self.factor);
        let s = self.spec();
        let (wb, hb) = (s.width as usize, s.height as usize);
        assert_eq!(x.len(), self.full.features(), "an image of {} values", self.full.features());
        assert_eq!(out.len(), s.features(), "a binned image of {} values", s.features());
        let (row, span, orow) = (w * ch, wb * b * ch, wb * ch);
        acc.resize(span, 0);
        if ch == 1 && b == 2 {
            return gray_sums::<2>(level, x, w, wb, out, acc);
        }
        if ch == 1 && b == 4 {
            return gray_sums::<4>(level, x, w, wb, out, acc);
        }
        let mut energy = 0u64;
        for (yo, o) in out.chunks_exact_mut(orow).enumerate().take(hb) {
            let top = yo * b * row;
            acc.iter_mut().zip(&x[top..top + span]).for_each(|(a, &v)| *a = v as u16);
            for r in 1..b {
                let src = &x[top + r * row..top + r * row + span];
                acc.iter_mut().zip(src).for_each(|(a, &v)| *a += v as u16);
            }
            for (xo, px) in o.chunks_exact_mut(ch).enumerate() {
                for (c, v) in px.iter_mut().enumerate() {
                    *v = (0..b).map(|k| acc[(xo * b + k) * ch + c]).sum();
                }
            }
            energy += o.iter().map(|&v| v as u64 * v as u64).sum::<u64>();
        }
        energy
    }

    /// [`Self::sums_u8`] of `x` as the 8-bit query path takes them: the block sums into `out`
    /// (at least [`Self::spec`]'s features; values past them are left alone); returns their sum
    /// of squares and that of `x` itself (both exact). `acc` is scratch. Gray images binned by 2
    /// or 4 go through AVX-512 BW where `level` allows (the same integers, the image's own
    /// squares summed in the same pass).
    pub(crate) fn sums_energies_u8(&self, level: Level, x: &[u8], out: &mut [u16], acc: &mut Vec<u16>) -> (u64, u64) {
        let s = self.spec();
        let mb = s.features();
        assert!(x.len() == self.full.features() && out.len() >= mb);
        if self.full.color.channels() == 1 {
            let blocks = GrayBlocks { factor: self.factor, w: self.full.width as usize, wb: s.width as usize, hb: s.height as usize };
            if let Some(sums) = crate::kernels::binning::sums_energies(level, blocks, x, out) {
                return sums;
            }
        }
        let energy = self.sums_u8_at(level, x, &mut out[..mb], acc);
        (energy, crate::kernels::dot_u8::sum_squares(x))
    }

    /// The largest block sum of an 8-bit image: 255 b^2.
    pub(crate) fn max_sum(&self) -> u32 {
        255 * (self.factor * self.factor) as u32
    }

    /// Bins every image of `xs` (rows of [`Self::full`]'s features), in parallel; a copy when
    /// b = 1.
    pub(crate) fn apply_all(&self, xs: &[f32]) -> Vec<f32> {
        if !self.bins() {
            return xs.to_vec();
        }
        let (m, mb) = (self.full.features(), self.spec().features());
        let mut out = vec![0.0; xs.len() / m * mb];
        out.par_chunks_mut(mb).zip(xs.par_chunks_exact(m)).for_each_init(Vec::new, |acc, (o, x)| self.apply(x, o, acc));
        out
    }
}

crate::kernels::dispatch! {
    /// [`gray_means_body`] at `level`.
    fn gray_means<const B: usize>(x: &[f32], w: usize, out: &mut [f32], acc: &mut [f32]) = gray_means_body;
}

/// The block means by B (2 or 4) of a gray image `x` of width `w` into `out` (binned rows of
/// `acc.len() / B`), in [`Binning::apply`]'s order: the B rows of a block added down each column
/// into `acc`, then each group of B added across and scaled by 1 / B^2 (the robust stage's check
/// bins every query so).
#[inline(always)]
fn gray_means_body<const B: usize>(x: &[f32], w: usize, out: &mut [f32], acc: &mut [f32]) {
    let span = acc.len();
    let wb = span / B;
    assert!(wb > 0 && span == wb * B && span <= w && out.len().is_multiple_of(wb) && x.len() >= out.len() / wb * B * w);
    let scale = 1.0 / (B * B) as f32;
    for (yo, o) in out.chunks_exact_mut(wb).enumerate() {
        let top = yo * B * w;
        acc.copy_from_slice(&x[top..top + span]);
        for r in 1..B {
            let src = &x[top + r * w..top + r * w + span];
            acc.iter_mut().zip(src).for_each(|(a, &v)| *a += v);
        }
        for (o, p) in o.iter_mut().zip(acc.chunks_exact(B)) {
            let mut sum = p[0];
            for &v in &p[1..] {
                sum += v;
            }
            *o = sum * scale;
        }
    }
}

crate::kernels::dispatch! {
    /// [`gray_sums_body`] at `level`.
    fn gray_sums<const B: usize>(x: &[u8], w: usize, wb: usize, out: &mut [u16], acc: &mut [u16]) -> u64 = gray_sums_body;
}

/// The block sums by B (2 or 4) of a gray image `x` of width `w` into `out` (binned rows of
/// `wb`), in [`Binning::sums_u8`]'s order, with `acc` (at least `wb` B values) as scratch;
/// returns their sum of squares. Written for the compiler to vectorise: the B rows added into
/// u16 lanes (at most 4 x 255), then each lane group of B summed (at most 4,080), and their
/// squares summed in u64.
#[inline(always)]
fn gray_sums_body<const B: usize>(x: &[u8], w: usize, wb: usize, out: &mut [u16], acc: &mut [u16]) -> u64 {
    let span = wb * B;
    assert!(wb > 0 && span <= w && acc.len() >= span && out.len().is_multiple_of(wb) && x.len() >= out.len() / wb * B * w);
    let acc = &mut acc[..span];
    let mut energy = 0u64;
    for (yo, o) in out.chunks_exact_mut(wb).enumerate() {
        let top = yo * B * w;
        acc.iter_mut().zip(&x[top..top + span]).for_each(|(a, &v)| *a = v as u16);
        for r in 1..B {
            let src = &x[top + r * w..top + r * w + span];
            acc.iter_mut().zip(src).for_each(|(a, &v)| *a += v as u16);
        }
        for (o, p) in o.iter_mut().zip(acc.chunks_exact(B)) {
            let mut v = 0u16;
            for &a in p {
                v += a;
            }
            *o = v;
            energy += (v as u32 * v as u32) as u64;
        }
    }
    energy
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image_io::ColorMode;

    fn spec(w: u32, h: u32, color: ColorMode) -> ImageSpec {
        ImageSpec { width: w, height: h, color }
    }

    #[test]
    fn a_block_becomes_its_mean_and_the_remainder_is_left_out() {
        // 7 x 6 gray, binned by 2: 3 x 3, the last column left out.
        let s = spec(7, 6, ColorMode::Gray);
        let x: Vec<f32> = (0..42).map(|i| i as f32).collect();
        let b = Binning::new(s, 2).unwrap();
        assert_eq!(b.spec(), spec(3, 3, ColorMode::Gray));
        let out = b.apply_all(&x);
        // Block (0, 0): pixels 0, 1, 7, 8.
        assert_eq!(out[0], (0.0 + 1.0 + 7.0 + 8.0) / 4.0);
        // Block (row 2, col 2): rows 4, 5, columns 4, 5.
        assert_eq!(out[8], (32.0 + 33.0 + 39.0 + 40.0) / 4.0);
        // Factor 1 is the identity.
        assert_eq!(Binning::new(s, 1).unwrap().apply_all(&x), x);
    }

    /// Each binned value by its definition, in f64: the mean of its block's values of its
    /// channel.
    fn naive(x: &[f32], s: ImageSpec, b: usize) -> Vec<f64> {
        let (w, ch) = (s.width as usize, s.color.channels());
        let (wb, hb) = (s.width as usize / b, s.height as usize / b);
        let mut out = Vec::new();
        for yo in 0..hb {
            for xo in 0..wb {
                for c in 0..ch {
                    let sum: f64 = (0..b).flat_map(|r| (0..b).map(move |k| ((yo * b + r) * w + xo * b + k) * ch + c)).map(|i| x[i] as f64).sum();
                    out.push(sum / (b * b) as f64);
                }
            }
        }
        out
    }

    #[test]
    fn colour_channels_are_binned_apart() {
        for (w, h, b) in [(10, 9, 3), (9, 7, 2), (33, 16, 4)] {
            let s = spec(w, h, ColorMode::Rgb);
            let x: Vec<f32> = (0..s.features()).map(|i| (i % 3) as f32 * 0.25 + ((i / 3) % 17) as f32 / 17.0).collect();
            let out = Binning::new(s, b).unwrap().apply_all(&x);
            let want = naive(&x, s, b);
            assert_eq!(out.len(), want.len());
            for (j, (&v, &e)) in out.iter().zip(&want).enumerate() {
                assert!((v as f64 - e).abs() < 1e-6, "{w}x{h} by {b}, value {j}: {v} against {e}");
            }
        }
    }

    /// Each binned value of a gray image in f32 in the order the module doc gives: the b rows
    /// of its block added down each column, then the b columns across, then scaled.
    fn in_order(x: &[f32], s: ImageSpec, b: usize) -> Vec<f32> {
        let (w, wb, hb) = (s.width as usize, s.width as usize / b, s.height as usize / b);
        let column = |yo: usize, c: usize| (1..b).fold(x[yo * b * w + c], |a, r| a + x[(yo * b + r) * w + c]);
        (0..hb).flat_map(|yo| (0..wb).map(move |xo| (1..b).fold(column(yo, xo * b), |a, k| a + column(yo, xo * b + k)) * (1.0 / (b * b) as f32))).collect()
    }

    #[test]
    fn gray_blocks_are_their_means_summed_in_order() {
        // By 2 and 4 (a body built for each SIMD level: every level checked) and by 3 (the
        // general loop).
        for (w, h, b) in [(9, 7, 2), (33, 16, 4), (131, 13, 4), (130, 9, 2), (10, 9, 3)] {
            let s = spec(w, h, ColorMode::Gray);
            let x: Vec<f32> = (0..s.features()).map(|i| ((i * 37) % 101) as f32 / 101.0 - 0.2).collect();
            let bin = Binning::new(s, b).unwrap();
            let (want, near) = (in_order(&x, s, b), naive(&x, s, b));
            let mut out = vec![0f32; bin.spec().features()];
            bin.apply(&x, &mut out, &mut Vec::new());
            assert_eq!(out.iter().map(|v| v.to_bits()).collect::<Vec<_>>(), want.iter().map(|v| v.to_bits()).collect::<Vec<_>>(), "{w}x{h} by {b}");
            assert!(out.iter().zip(&near).all(|(&v, &e)| (v as f64 - e).abs() < 1e-6), "{w}x{h} by {b}: the means");
            if b == 2 || b == 4 {
                for level in Level::supported() {
                    let mut o = vec![0f32; out.len()];
                    let mut acc = vec![0f32; bin.spec().width as usize * b];
                    match b {
                        2 => gray_means::<2>(level, &x, w as usize, &mut o, &mut acc),
                        _ => gray_means::<4>(level, &x, w as usize, &mut o, &mut acc),
                    }
                    assert!(o.iter().zip(&want).all(|(a, e)| a.to_bits() == e.to_bits()), "{w}x{h} by {b}, {level:?}");
                }
            }
        }
    }

    #[test]
    fn eight_bit_sums_are_the_means_times_the_block() {
        // Gray by 2 and 4 (the query paths' factors, a body built for each SIMD level: every
        // level checked, wide images and full blocks included), and the general loop.
        let cases = [
            (9, 7, ColorMode::Gray, 2),
            (10, 9, ColorMode::Gray, 3),
            (8, 8, ColorMode::Rgb, 2),
            (64, 48, ColorMode::Gray, 16),
            (131, 13, ColorMode::Gray, 4),
            (4100, 14, ColorMode::Gray, 4),
            (1030, 7, ColorMode::Gray, 2),
        ];
        for (w, h, color, b) in cases {
            let s = spec(w, h, color);
            let bin = Binning::new(s, b).unwrap();
            for bright in [false, true] {
                let x: Vec<u8> = (0..s.features()).map(|i| if bright { 255 } else { (i * 37 % 256) as u8 }).collect();
                let f: Vec<f32> = x.iter().map(|&v| v as f32).collect();
                let want = naive(&f, s, b);
                for level in Level::supported() {
                    let mut sums = vec![0u16; bin.spec().features()];
                    let energy = bin.sums_u8_at(level, &x, &mut sums, &mut Vec::new());
                    for (&sum, &mean) in sums.iter().zip(&want) {
                        assert_eq!(sum as f64, mean * (b * b) as f64, "{w}x{h} by {b} {level:?}");
                    }
                    assert_eq!(energy, sums.iter().map(|&v| v as u64 * v as u64).sum::<u64>(), "{w}x{h} by {b} {level:?}");
                }
            }
        }
    }

    #[test]
    fn the_query_sums_and_energies_are_the_same_on_every_path() {
        // Widths around the 64-pixel steps, odd ones leaving a column out, images that reach
        // the largest sums, and ones of more rows than the squares' lanes take between two
        // flushes (by 2, 16 rows of 128 steps; by 4, 51 rows of 5 steps).
        for (w, h, b) in [
            (128, 6, 2),
            (160, 7, 2),
            (7, 6, 2),
            (129, 7, 2),
            (62, 6, 2),
            (200, 9, 2),
            (8192, 41, 2),
            (128, 12, 4),
            (160, 13, 4),
            (14, 12, 4),
            (130, 15, 4),
            (260, 16, 4),
            (260, 222, 4),
        ] {
            let s = spec(w, h, ColorMode::Gray);
            let bin = Binning::new(s, b).unwrap();
            let mb = bin.spec().features();
            for fill in [None, Some(255u8), Some(0u8)] {
                let x: Vec<u8> = (0..s.features()).map(|i| fill.unwrap_or(((i * 91 + i / 7) % 256) as u8)).collect();
                let mut sums = vec![0u16; mb];
                let energy = bin.sums_u8(&x, &mut sums, &mut Vec::new());
                for level in Level::supported() {
                    // Room past the binned values, which stays as it was.
                    let mut out = vec![7u16; mb + 40];
                    let e = bin.sums_energies_u8(level, &x, &mut out, &mut Vec::new());
                    assert_eq!(e, (energy, x.iter().map(|&v| v as u64 * v as u64).sum()), "{w}x{h} by {b} {level:?}");
                    assert_eq!(out[..mb], sums[..], "{w}x{h} by {b} {level:?}");
                    assert!(out[mb..].iter().all(|&v| v == 7), "{w}x{h} by {b} {level:?}");
                }
            }
        }
    }

    #[test]
    fn a_factor_that_leaves_too_little_is_refused_by_name() {
        let s = spec(20, 15, ColorMode::Gray);
        assert!(Binning::new(s, 5).is_ok());
        let e = Binning::new(s, 6).unwrap_err().to_string();
        assert!(e.contains("bin") && e.contains("3x2"), "{e}");
        assert!(Binning::new(s, 0).unwrap_err().to_string().contains("bin"));
        assert!(Binning::new(s, 17).unwrap_err().to_string().contains("1 to 16"));
    }
}
