//! The projection of 8-bit queries for a model that bins: block sums through the 16-bit products,
//! or as two 8-bit digit planes.

use super::{scatter, selected};
use crate::kernels::{dot_q, dot_w, Level};
use crate::methods::refined::model::RefinedModel;
use crate::methods::refined::query::NoiseWant;
use crate::methods::refined::scratch::{BinScratch, QueryScratch, BIN_SCRATCH};
use crate::methods::refined::tuning::BIN_SUB_U8;
use crate::pixel_noise::{pixel_variance_u8_in, RowsU8};

/// Binned 8-bit queries as digit planes, for [`RefinedModel::planes_pass`].
#[derive(Clone, Copy)]
struct Planes<'a> {
    /// Per query its low then its high plane, of M each.
    planes: &'a [u8],
    /// The queries that take the pass (their indices), or None for all.
    sel: Option<&'a [usize]>,
}

impl RefinedModel {
    /// Whether 8-bit queries at `level` take the 16-bit products of block sums (a model that
    /// bins, VNNI).
    pub(crate) fn words_at(&self, level: Level) -> bool {
        self.proj.has_words() && dot_q::fast(level)
    }

    /// [`Self::project_u8`] for a model that bins: each image's block sums, exact in integers
    /// (255 b^2 at most), go to the 16-bit products ([`dot_w`], where [`dot_q::fast`] and b <=
    /// 11), else split into two 8-bit digit planes, low and high, which the 8-bit products take
    /// as two images (a zero step of the high plane, the blocks darker than 256 / b^2 on average,
    /// is skipped; a query's products are low + 256 high); a query's energy is the sums' exact sum
    /// of squares (in units of the block sums: the scale cancels in each ratio, as in
    /// [`Self::project_u8`]). Its pixel noise is measured on the image as given
    /// ([`pixel_variance_u8`](crate::pixel_noise::pixel_variance_u8_in), staged), as [`Self::project_binned`] does.
    pub(crate) fn project_u8_binned(&self, level: Level, queries: &[u8], noise: NoiseWant, s: &mut QueryScratch) {
        let (l, mb) = (self.components(), self.m);
        let m = self.meta.spec.features();
        let n = queries.len() / m;
        let full = self.binning.full();
        let (w, h, ch) = (full.width as usize, full.height as usize, full.color.channels());
        s.resize(n, l);
        s.route.resize(n, 0.0);
        s.pv_full.resize(n, 0.0);
        let b2 = (self.binning.factor() * self.binning.factor()) as f64;
        let words = self.words_at(level);
        BIN_SCRATCH.with_borrow_mut(|b| {
            let BinScratch { planes, sums, acc, raw, energy, lines, lines_x, idx } = b;
            // Each image's block sums, and its pixel noise measured as given (as
            // [`Self::project_binned`]), in pixel values: the sums' energy, the route's value
            // and the noise.
            let rows_u8_full = &mut s.rows_u8_full;
            let mut sum_one = |x: &[u8], v: &mut [u16]| {
                let (e_binned, e_full) = self.binning.sums_energies_u8(level, x, v, acc);
                let e_full = e_full as f64;
                let pv = match self.early(noise, e_full, m) {
                    Some(early) => pixel_variance_u8_in(x, w, h, ch, RowsU8::reuse(rows_u8_full, w * ch, ch), early),
                    None => 0.0,
                };
                (e_binned, pv * m as f64 / e_full, pv)
            };
            let mut sel = std::mem::take(&mut s.xidx);
            match words.then(|| self.proj.words(&self.clean_rows()).expect("the clean rows' 16-bit form")) {
                // In sub-chunks whose sums are still cached for the products; each query routed
                // first, then its route's rows alone (the clean ones' mean and L_s, the noisy
                // ones' L), each route's queries copied apart when the sub-chunk mixes them.
                Some(wc) => {
                    let steps = wc.steps();
                    for (c, xq) in queries.chunks(BIN_SUB_U8 * m).enumerate() {
                        let (i0, nn) = (c * BIN_SUB_U8, xq.len() / m);
                        wc.lines_of(nn, lines);
                        let values = dot_w::WordRows::values_mut(lines);
                        for ((i, x), v) in (i0..).zip(xq.chunks_exact(m)).zip(values.chunks_exact_mut(steps * dot_w::STEP)) {
                            (s.energy[i], s.route[i], s.pv_full[i]) = sum_one(x, v);
                            s.noisy[i] = self.routed_noisy(noise, s.route[i]);
                        }
                        let (two, one);
                        let routes: &[(Option<bool>, std::ops::Range<usize>)] = if self.clean_rows() != self.noisy_rows() {
                            two = [(Some(false), self.clean_rows()), (Some(true), self.noisy_rows())];
                            &two
                        } else {
                            // The same rows for both routes: one pass.
                            one = [(None, self.clean_rows())];
                            &one
                        };
                        for (route, rr) in routes.iter().cloned() {
                            sel.clear();
                            sel.extend((0..nn).filter(|&j| route.is_none_or(|r| s.noisy[i0 + j] == r)));
                            let k = rr.len();
                            let (src, nx) = selected(lines, steps, Some(&sel[..]), lines_x);
                            if nx == 0 || k == 0 {
                                continue;
                            }
                            s.xout.resize(nx * k, 0.0);
                            self.proj.words_products(level, &rr, src, &mut s.xout, idx);
                            scatter(&s.xout, k, Some(&sel[..]), i0, 1 + l, rr.start, &mut s.raw);
                        }
                    }
                }
                None => {
                    sums.resize(n * mb, 0);
                    for ((i, x), v) in queries.chunks_exact(m).enumerate().zip(sums.chunks_exact_mut(mb)) {
                        (s.energy[i], s.route[i], s.pv_full[i]) = sum_one(x, v);
                        s.noisy[i] = self.routed_noisy(noise, s.route[i]);
                    }
                    planes.resize(2 * n * mb, 0);
                    for (v, p) in sums.chunks_exact(mb).zip(planes.chunks_exact_mut(2 * mb)) {
                        let (lo, hi) = p.split_at_mut(mb);
                        for ((&v, lo), hi) in v.iter().zip(lo).zip(hi) {
                            (*lo, *hi) = (v as u8, (v >> 8) as u8);
                        }
                    }
                    // Every query's clean rows, then the noisy ones' extra rows.
                    self.planes_pass(level, self.clean_rows(), Planes { planes: &planes[..2 * n * mb], sel: None }, raw, energy, s);
                    if self.extra_rows() > 0 {
                        sel.clear();
                        sel.extend((0..n).filter(|&i| s.noisy[i]));
                        self.planes_pass(level, self.extra_range(), Planes { planes: &planes[..2 * n * mb], sel: Some(&sel[..]) }, raw, energy, s);
                    }
                }
            }
            s.xidx = sel;
            for i in 0..n {
                // The noisy match's nu in units of the block sums (b^2 times a binned pixel's
                // mean): a pixel's noise pv gives a block mean's pv / b^2, a block sum's b^2 pv.
                let energy = s.energy[i] as f64;
                let mean = !words || !s.noisy[i];
                (s.resid[i], _) = self.finish_query(i, mean, energy, 0.0, s);
                s.noise[i] = b2 * s.pv_full[i] / energy;
            }
        });
    }

    /// The products of binned 8-bit queries given as digit `planes` with the rows `rr` into
    /// `s.raw` as [`Self::pass_f32`] ([`Projector::planes_products`](crate::manifold::projector::Projector::planes_products); `raw` and `energy`
    /// hold the planes' products and sums of squares).
    fn planes_pass(&self, level: Level, rr: std::ops::Range<usize>, planes: Planes<'_>, raw: &mut Vec<f32>, energy: &mut Vec<u64>, s: &mut QueryScratch) {
        let Planes { planes, sel } = planes;
        let (mb, k) = (self.m, rr.len());
        let (src, nx) = selected(planes, 2 * mb, sel, &mut s.gather_u8);
        if nx == 0 || k == 0 {
            return;
        }
        s.xout.resize(nx * k, 0.0);
        self.proj.planes_products(level, &rr, src, &mut s.xout, crate::manifold::projector::PlaneBuffers { raw, energy }, &mut s.products);
        scatter(&s.xout, k, sel, 0, 1 + self.components(), rr.start, &mut s.raw);
    }
}
