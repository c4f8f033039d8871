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

pub(crate) use super::tuning::{BATCH_FROM, U8_BATCH};
use crate::kernels::{dot_q, dot_u8, dot_w, AlignedF32, Level};
use crate::model::split;
use faer::linalg::matmul::matmul;
use faer::{Accum, MatMut, MatRef, Par};
use std::ops::Range;

/// The buffers of [`Projector::planes_products`]: each plane's products and its sum of squares.
pub(crate) struct PlaneBuffers<'a> {
    pub raw: &'a mut Vec<f32>,
    pub energy: &'a mut Vec<u64>,
}

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
    pub(crate) fn u8_batch(&self, level: Level, r: &Range<usize>, queries: &[u8], out: &mut [f32], energy: &mut [u64], scratch: &mut dot_q::Scratch) {
        self.fast(r).dots_batch(level, queries, self.m, self.range(r), dot_q::Batch { out, energy }, scratch);
    }

    /// [`Self::u8_batch`] from [`BATCH_FROM`] images on, else image by image.
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
    /// else one at a time; `buffers` hold the planes' products and sums of squares), then low +
    /// 256 high.
    pub(crate) fn planes_products(
        &self,
        level: Level,
        r: &Range<usize>,
        planes: &[u8],
        out: &mut [f32],
        buffers: PlaneBuffers<'_>,
        scratch: &mut dot_q::Scratch,
    ) {
        let PlaneBuffers { raw, energy } = buffers;
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

/// 8-bit queries per parallel task for a batch of `n` (8 or more): whole blocks of `block`
/// images, at most [`U8_BATCH`], and small enough that every thread gets two tasks.
fn u8_task_rows(n: usize, block: usize) -> usize {
    n.div_ceil(2 * rayon::current_num_threads().max(1)).div_ceil(block).clamp(1, U8_BATCH / block) * block
}

/// The tasks of a batch of `n` 8-bit queries (8 or more) of `m` pixels: queries per task and
/// whether the tasks run in parallel. A batch too small to split ([`split::splits`]) runs on the
/// calling thread in tasks of at most [`U8_BATCH`]; a larger one in [`u8_task_rows`]'s tasks, each
/// of at least [`split::min_task_queries`] (in whole blocks).
pub(crate) fn u8_tasks(n: usize, m: usize, block: usize) -> (usize, bool) {
    let most = U8_BATCH / block * block;
    if !split::splits(n, m) {
        return ((n.div_ceil(block) * block).min(most), false);
    }
    (u8_task_rows(n, block).max(split::min_task_queries(m).div_ceil(block) * block).min(most), true)
}

const _: () = assert!(U8_BATCH.is_multiple_of(dot_q::GROUP * dot_q::BLOCK) && U8_BATCH.is_multiple_of(dot_u8::BATCH_IMAGES));

#[cfg(test)]
mod tests {
    //! Every product path against the rows' products summed plainly in f64, within the
    //! fixed-point forms' quantisation (a weight within 1 / 65,278 of its row's largest).
    use super::*;

    const M: usize = 150;

    /// `n` rows of M deterministic values in [-1, 1).
    fn rows(n: usize) -> Vec<f32> {
        (0..n * M).map(|i| ((i * 7919) % 1013) as f32 / 506.5 - 1.0).collect()
    }

    /// `n` images of M deterministic 8-bit values.
    fn images(n: usize, seed: usize) -> Vec<u8> {
        (0..n * M).map(|i| ((i * 104_729 + seed * 31) % 256) as u8).collect()
    }

    /// Every image's plain products with rows `r` of `w`, and the tolerance of the 8-bit paths.
    fn reference(w: &[f32], r: &Range<usize>, xs: &[f64]) -> (Vec<f64>, f64) {
        let wmax = w.iter().fold(0f32, |a, v| a.max(v.abs())) as f64;
        let mut want = Vec::new();
        let mut tol: f64 = 0.0;
        for x in xs.chunks_exact(M) {
            for row in w[r.start * M..r.end * M].chunks_exact(M) {
                want.push(x.iter().zip(row).map(|(&a, &b)| a * b as f64).sum());
            }
            tol = tol.max(1e-4 * x.iter().map(|v| v.abs()).sum::<f64>() * wmax);
        }
        (want, tol)
    }

    fn close(got: &[f32], want: &[f64], tol: f64, what: &str) {
        assert_eq!(got.len(), want.len(), "{what}");
        for (i, (&g, &w)) in got.iter().zip(want).enumerate() {
            assert!((g as f64 - w).abs() <= tol, "{what}, product {i}: {g} against {w}");
        }
    }

    #[test]
    fn every_path_gives_the_rows_products() {
        let w = rows(6);
        let r = 1..5;
        let p = Projector::new(&w, M).with_u8(r.clone()).with_words(std::slice::from_ref(&r), 4 * 255);
        let level = Level::detect();
        // f32 queries.
        let xf: Vec<f32> = images(3, 1).iter().map(|&v| v as f32 / 255.0).collect();
        let (want, _) = reference(&w, &r, &xf.iter().map(|&v| v as f64).collect::<Vec<_>>());
        let mut out = vec![0f32; 3 * r.len()];
        p.f32_products(&r, &xf, &mut out);
        close(&out, &want, 1e-4, "f32");
        // 8-bit queries one at a time (3) and in the batch kernel (9): the same bits image by
        // image, and each image's exact sum of squares.
        let mut scratch = dot_q::Scratch::default();
        for n in [3, 9] {
            let x8 = images(n, 2);
            let (want, tol) = reference(&w, &r, &x8.iter().map(|&v| v as f64).collect::<Vec<_>>());
            let (mut out, mut energy) = (vec![0f32; n * r.len()], vec![0u64; n]);
            p.u8_products(level, &r, &x8, &mut out, &mut energy, &mut scratch);
            close(&out, &want, tol, "8-bit");
            for (i, x) in x8.chunks_exact(M).enumerate() {
                let mut one = vec![0f32; r.len()];
                p.u8_one(level, &r, x, &mut one);
                assert_eq!(one, &out[i * r.len()..(i + 1) * r.len()], "batch of {n}, image {i}");
                assert_eq!(energy[i], x.iter().map(|&v| v as u64 * v as u64).sum::<u64>());
            }
        }
        // Block sums of up to 4 x 255, as digit planes (1 image: one at a time; 5: the batch
        // kernel) and as 16-bit lines.
        for n in [1, 5] {
            let sums: Vec<u16> = (0..n * M).map(|i| ((i * 7 + n) % 1021) as u16).collect();
            let (want, tol) = reference(&w, &r, &sums.iter().map(|&v| v as f64).collect::<Vec<_>>());
            let mut planes = vec![0u8; 2 * n * M];
            for (v, pl) in sums.chunks_exact(M).zip(planes.chunks_exact_mut(2 * M)) {
                let (lo, hi) = pl.split_at_mut(M);
                for ((&v, lo), hi) in v.iter().zip(lo).zip(hi) {
                    (*lo, *hi) = (v as u8, (v >> 8) as u8);
                }
            }
            let (mut out, mut raw, mut energy) = (vec![0f32; n * r.len()], Vec::new(), Vec::new());
            p.planes_products(level, &r, &planes, &mut out, PlaneBuffers { raw: &mut raw, energy: &mut energy }, &mut scratch);
            close(&out, &want, tol, "digit planes");
            let wr = p.words(&r).expect("sums of at most 1,020 take 16-bit rows");
            let mut lines = Vec::new();
            wr.lines_of(n, &mut lines);
            let values = dot_w::WordRows::values_mut(&mut lines);
            for (v, dst) in sums.chunks_exact(M).zip(values.chunks_exact_mut(wr.steps() * dot_w::STEP)) {
                dst[..M].copy_from_slice(v);
            }
            let mut out = vec![0f32; n * r.len()];
            p.words_products(level, &r, &lines, &mut out, &mut Vec::new());
            close(&out, &want, tol, "16-bit lines");
        }
    }

    #[test]
    fn unit_coords_scale_and_refuse_what_cannot_be_scaled() {
        let c = [0.5f32, -0.25];
        let mut y = [2.0f32, 4.0];
        assert_eq!(unit_coords(4.0, &c, &mut y), Some(2.0));
        assert_eq!(y, [0.5, 2.25]);
        for energy in [0.0, f64::NAN, f64::INFINITY] {
            let mut y = [2.0f32, 4.0];
            assert_eq!(unit_coords(energy, &c, &mut y), None);
            assert_eq!(y, [2.0, 4.0], "left as it is");
        }
    }
}
