//! The projection of queries on eigenimages, shared by the eigenspace and the refined eigenspace:
//! a [`Projector`] holds the rows a query is multiplied with (the eigenimages; the refined
//! eigenspace's mean image first), 64-byte aligned, and the fixed-point forms of row ranges that
//! 8-bit queries take, and multiplies a batch of queries with any range of its rows. What a
//! method does around the products (which queries take which rows, in what chunks, with what
//! else in the same pass over the image) stays with the method.
//!
//! - f32 queries: one sequential f32 product (faer) of the queries with the rows.
//! - 8-bit queries: [`dot_q::FastRows`], the rows in 16-bit fixed point summed exactly in
//!   integers where AVX-512 VNNI runs them, else [`crate::kernels::dot_u8`]'s f32 products of the
//!   f32 rows; a batch of 8 or more in the batch kernel, fewer one at a time (the batch kernel's
//!   register blocks would sit mostly empty).
//! - Binned 8-bit queries (integer block sums of up to 255 b^2): as 16-bit images through
//!   [`dot_w::WordRows`] where VNNI runs, else as two 8-bit digit planes (low and high byte)
//!   through the 8-bit products, a query's products low + 256 high.
//!
//! [`unit_coords`] turns a query's products into its unit-energy, mean-subtracted coordinates.
//! Every path gives the bits it gave in each method before they shared it: the same kernels on
//! the same rows with the same batch shapes.

use crate::kernels::{dot_q, dot_u8, dot_w, AlignedF32, Level};
use faer::linalg::matmul::matmul;
use faer::{Accum, MatMut, MatRef, Par};
use std::ops::Range;

/// From this many 8-bit images on, a product takes the batch kernel.
pub(crate) const BATCH_FROM: usize = 8;

/// Rows of M values with the forms of some of their ranges that 8-bit queries take (see the
/// module doc).
#[derive(Debug, Clone)]
pub(crate) struct Projector {
    rows: AlignedF32,
    m: usize,
    /// Row ranges in 16-bit fixed point for 8-bit queries (empty where [`dot_q::fast`] does not
    /// hold: the f32 rows serve).
    fast: Vec<(Range<usize>, dot_q::FastRows)>,
    /// Row ranges in 16-bit fixed point for 16-bit block sums ([`dot_w`]).
    words: Vec<(Range<usize>, dot_w::WordRows)>,
    /// No fixed-point form: the f32 rows through [`dot_u8`] (for a range without one).
    none: dot_q::FastRows,
}

impl Projector {
    /// The rows `rows` (each of `m` values), without fixed-point forms.
    pub(crate) fn new(rows: &[f32], m: usize) -> Projector {
        assert!(m > 0 && rows.len().is_multiple_of(m), "whole rows of m > 0 values");
        Projector { rows: AlignedF32::new(rows), m, fast: Vec::new(), words: Vec::new(), none: dot_q::FastRows::default() }
    }

    /// With rows `r` in 16-bit fixed point for 8-bit queries (where [`dot_q::fast`]).
    pub(crate) fn with_u8(mut self, r: Range<usize>) -> Projector {
        if !r.is_empty() && !self.fast.iter().any(|f| f.0 == r) {
            let fast = dot_q::FastRows::new(self.range(&r), self.m);
            self.fast.push((r, fast));
        }
        self
    }

    /// With each of the row ranges `ranges` in 16-bit fixed point for block sums of at most
    /// `max_sum` ([`dot_w::WordRows`]), or, when one of them cannot be made, with none.
    pub(crate) fn with_words(mut self, ranges: &[Range<usize>], max_sum: u32) -> Projector {
        let mut words = Vec::new();
        for r in ranges {
            if words.iter().any(|w: &(Range<usize>, dot_w::WordRows)| &w.0 == r) {
                continue;
            }
            match dot_w::WordRows::new(self.range(r), self.m, max_sum) {
                Some(w) => words.push((r.clone(), w)),
                None => return self,
            }
        }
        self.words = words;
        self
    }

    /// Every row, row after row.
    pub(crate) fn rows(&self) -> &[f32] {
        &self.rows
    }

    /// The values of rows `r`.
    pub(crate) fn range(&self, r: &Range<usize>) -> &[f32] {
        &self.rows[r.start * self.m..r.end * self.m]
    }

    /// The 16-bit form of rows `r` for block sums, when made.
    pub(crate) fn words(&self, r: &Range<usize>) -> Option<&dot_w::WordRows> {
        self.words.iter().find(|w| &w.0 == r).map(|w| &w.1)
    }

    /// The products of block sums laid out in `lines` ([`dot_w::WordRows::lines_of`]) with rows
    /// `r` into `out` (a row of `r.len()` per image), by their 16-bit form.
    pub(crate) fn words_products(&self, level: Level, r: &Range<usize>, lines: &[dot_w::Line], out: &mut [f32], idx: &mut Vec<u32>) {
        self.words(r).expect("rows with a 16-bit form").dots_batch(level, lines, out, idx);
    }

    /// Whether the 16-bit forms for block sums were made.
    pub(crate) fn has_words(&self) -> bool {
        !self.words.is_empty()
    }

    fn fast(&self, r: &Range<usize>) -> &dot_q::FastRows {
        self.fast.iter().find(|f| &f.0 == r).map_or(&self.none, |f| &f.1)
    }

    /// Images per block the 8-bit batch kernel at `level` wants for rows `r`.
    pub(crate) fn u8_block(&self, level: Level, r: &Range<usize>) -> usize {
        self.fast(r).block(level)
    }

    /// Each row of `r`'s product with `v` (M values), summed in f64 from the f32 values.
    pub(crate) fn dots_f64(&self, r: &Range<usize>, v: &[f32]) -> Vec<f32> {
        self.range(r).chunks_exact(self.m).map(|u| u.iter().zip(v).map(|(&a, &b)| a as f64 * b as f64).sum::<f64>() as f32).collect()
    }

    /// The products of the f32 `queries` (rows of M) with rows `r` into `out` (a row of
    /// `r.len()` per query): one sequential f32 product.
    pub(crate) fn f32_products(&self, r: &Range<usize>, queries: &[f32], out: &mut [f32]) {
        let (m, k) = (self.m, r.len());
        let n = queries.len() / m;
        let ut = MatRef::from_column_major_slice(self.range(r), m, k);
        matmul(MatMut::from_row_major_slice_mut(out, n, k), Accum::Replace, MatRef::from_row_major_slice(queries, n, m), ut, 1.0f32, Par::Seq);
    }

    /// The products of the 8-bit image `x` (M pixel values) with rows `r` into `out`.
    #[inline]
    pub(crate) fn u8_one(&self, level: Level, r: &Range<usize>, x: &[u8], out: &mut [f32]) {
        self.fast(r).dots(level, x, self.range(r), out);
    }

    /// The products of the 8-bit `queries` with rows `r` into `out` (as [`Self::f32_products`])
    /// by the batch kernel, and each image's exact sum of squares into `energy`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn u8_batch(&self, level: Level, r: &Range<usize>, queries: &[u8], out: &mut [f32], energy: &mut [u64], scratch: &mut dot_q::Scratch) {
        self.fast(r).dots_batch(level, queries, self.m, self.range(r), out, energy, scratch);
    }

    /// [`Self::u8_batch`] from [`BATCH_FROM`] images on, else image by image.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn u8_products(&self, level: Level, r: &Range<usize>, queries: &[u8], out: &mut [f32], energy: &mut [u64], scratch: &mut dot_q::Scratch) {
        let (m, k) = (self.m, r.len());
        if queries.len() / m >= BATCH_FROM {
            self.u8_batch(level, r, queries, out, energy, scratch);
        } else {
            for ((x, o), e) in queries.chunks_exact(m).zip(out.chunks_exact_mut(k)).zip(energy.iter_mut()) {
                self.u8_one(level, r, x, o);
                *e = dot_u8::sum_squares(x);
            }
        }
    }

    /// The products of binned 8-bit images given as digit planes (`planes`: per image its low
    /// then its high byte plane, of M each) with rows `r` into `out` (a row of `r.len()` per
    /// image): each plane as an 8-bit image ([`BATCH_FROM`] planes or more in the batch kernel,
    /// else one at a time; `raw` and `energy` hold the planes' products and sums of squares),
    /// then low + 256 high.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn planes_products(
        &self,
        level: Level,
        r: &Range<usize>,
        planes: &[u8],
        out: &mut [f32],
        raw: &mut Vec<f32>,
        energy: &mut Vec<u64>,
        scratch: &mut dot_q::Scratch,
    ) {
        let (m, k) = (self.m, r.len());
        let n = planes.len() / (2 * m);
        raw.resize(2 * n * k, 0.0);
        energy.resize(2 * n, 0);
        if 2 * n >= BATCH_FROM {
            self.u8_batch(level, r, planes, raw, energy, scratch);
        } else {
            for (x, o) in planes.chunks_exact(m).zip(raw.chunks_exact_mut(k)) {
                self.u8_one(level, r, x, o);
            }
        }
        for (o, pair) in out.chunks_exact_mut(k).zip(raw.chunks_exact(2 * k)) {
            let (lo, hi) = pair.split_at(k);
            o.iter_mut().zip(lo.iter().zip(hi)).for_each(|(v, (&a, &b))| *v = a + 256.0 * b);
        }
    }
}

/// Turns `y`, a query's products with the eigenimages, into its unit-energy, mean-subtracted
/// coordinates y_l / ||x|| - c_l (in f32; `mean_proj` holds c_l, each eigenimage's product with
/// the mean image), given its energy ||x||^2; returns ||x||. A query of zero or non-finite
/// energy cannot be scaled: `y` is left as it is and None returned.
#[inline]
pub(crate) fn unit_coords(energy: f64, mean_proj: &[f32], y: &mut [f32]) -> Option<f64> {
    let norm = energy.sqrt();
    if !(norm > 0.0 && norm.is_finite()) {
        return None;
    }
    let inv = (1.0 / norm) as f32;
    y.iter_mut().zip(mean_proj).for_each(|(v, &c)| *v = *v * inv - c);
    Some(norm)
}
