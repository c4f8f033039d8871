//! A query's projection on the eigenimages its route takes, with its energy, residual and pixel
//! noise.

mod binned;

use super::model::RefinedModel;
use super::query::NoiseWant;
use super::scratch::QueryScratch;
use super::tuning::{NOISE_SUB_F32, NOISE_SUB_F32_BYTES, NOISE_SUB_U8};
use crate::kernels::Level;
use crate::manifold::projector::unit_coords;
use crate::pixel_noise::{pixel_variance_in, pixel_variance_u8_in, RowsF32, RowsU8};

/// The items of `xs` (runs of `m`) at `sel` (all when None) and their count: `xs` itself when
/// those are all of them, else a copy of them in `buf`.
fn selected<'a, T: Copy>(xs: &'a [T], m: usize, sel: Option<&[usize]>, buf: &'a mut Vec<T>) -> (&'a [T], usize) {
    let n = xs.len() / m;
    match sel {
        Some(sel) if sel.len() < n => {
            buf.clear();
            sel.iter().for_each(|&j| buf.extend_from_slice(&xs[j * m..(j + 1) * m]));
            (buf, sel.len())
        }
        _ => (xs, n),
    }
}

/// The products `out` (rows of `k`, one per selected query: those at `sel`, else all) into
/// `raw` (rows of `kr`) of the task's queries i0 + j, from column `col`.
fn scatter(out: &[f32], k: usize, sel: Option<&[usize]>, i0: usize, kr: usize, col: usize, raw: &mut [f32]) {
    for (t, o) in out.chunks_exact(k).enumerate() {
        let i = i0 + sel.map_or(t, |sel| sel[t]);
        raw[i * kr + col..i * kr + col + k].copy_from_slice(o);
    }
}

impl RefinedModel {
    /// The products of the queries `xq` (rows of M, the first the task's query `i0`; those at
    /// `sel` when given, else all) with `rows` rows `rr` into `s.raw` (rows of 1 + L, the mean's
    /// product first and eigenimage c's at 1 + c) from column `rr.start`: one f32 product over
    /// `xq` itself or over a copy of the selected queries.
    fn pass_f32(&self, xq: &[f32], i0: usize, sel: Option<&[usize]>, rr: std::ops::Range<usize>, s: &mut QueryScratch) {
        let (m, kr, k) = (self.m, 1 + self.components(), rr.len());
        let (src, nx) = selected(xq, m, sel, &mut s.gather_f32);
        if nx == 0 || k == 0 {
            return;
        }
        s.xout.resize(nx * k, 0.0);
        self.proj.f32_products(&rr, src, &mut s.xout);
        scatter(&s.xout, k, sel, i0, kr, rr.start, &mut s.raw);
    }

    /// As [`Self::pass_f32`] for 8-bit images of M pixel values ([`Projector::u8_products`](crate::manifold::projector::Projector::u8_products));
    /// their sums of squares into `s.xenergy` (by selected query).
    fn pass_u8(&self, level: Level, xq: &[u8], i0: usize, sel: Option<&[usize]>, rr: std::ops::Range<usize>, s: &mut QueryScratch) {
        let (m, kr, k) = (self.m, 1 + self.components(), rr.len());
        let (src, nx) = selected(xq, m, sel, &mut s.gather_u8);
        if nx == 0 || k == 0 {
            return;
        }
        s.xout.resize(nx * k, 0.0);
        s.xenergy.resize(nx, 0);
        self.proj.u8_products(level, &rr, src, &mut s.xout, &mut s.xenergy, &mut s.products);
        scatter(&s.xout, k, sel, i0, kr, rr.start, &mut s.raw);
    }

    /// The eigenspace coordinates, residual and noise of f32 queries (rows of M) into `s.y`
    /// (rows of L), `s.resid` and `s.noise`. In sub-chunks whose queries stay in cache from the
    /// products to the energy and noise (rayon splits the batch, see [`chunk_rows`](crate::manifold::chunk_rows)). Without
    /// `routed`: the products of every query with [`Self::clean_rows`] (the mean's, when used,
    /// summed with the query's energy in one pass, [`crate::linalg::energy_and_dot`]: a row
    /// fewer in the product, whose kernel takes 4 at a time), then each query's energy and,
    /// when `noise` says so, its pixel noise ([`pixel_variance`](crate::pixel_noise::pixel_variance), staged at `early` times
    /// the noise threshold, see [`NoiseWant`]), which routes it; the queries routed to the noisy
    /// match take the [`Self::extra_range`] too. With `routed` (a model that bins: routed on the
    /// images as given, `s.noisy`) each query takes its route's rows alone, the clean ones
    /// [`Self::clean_rows`], the noisy ones [`Self::noisy_rows`]. Then [`Self::finish_query`].
    fn project_f32(&self, queries: &[f32], noise: NoiseWant, routed: bool, s: &mut QueryScratch) {
        let (l, m) = (self.components(), self.m);
        let n = queries.len() / m;
        let spec = self.binning.spec();
        let (w, h, ch) = (spec.width as usize, spec.height as usize, spec.color.channels());
        s.resize(n, l);
        let sub = if std::mem::size_of_val(queries) <= NOISE_SUB_F32_BYTES { n.max(1) } else { NOISE_SUB_F32 };
        let mut sel = std::mem::take(&mut s.xidx);
        let mut other = std::mem::take(&mut s.xidx2);
        // The clean search's eigenimages go through the product; the mean's product (the
        // first of [`Self::clean_rows`] when it is used) is summed with the energy.
        let (take_mean, eigen_clean) = (self.uses_residual(), 1..1 + self.settings.search());
        for (c, xq) in queries.chunks(sub * m).enumerate() {
            let (i0, nn) = (c * sub, xq.len() / m);
            if routed {
                sel.clear();
                other.clear();
                (0..nn).for_each(|j| if s.noisy[i0 + j] { sel.push(j) } else { other.push(j) });
                self.pass_f32(xq, i0, Some(&other[..]), eigen_clean.clone(), s);
                self.pass_f32(xq, i0, Some(&sel[..]), self.noisy_rows(), s);
            } else {
                self.pass_f32(xq, i0, None, eigen_clean.clone(), s);
            }
            for (i, x) in (i0..).zip(xq.chunks_exact(m)) {
                // The product with the mean, where the query takes it, in the pass that sums
                // its energy.
                let energy = if take_mean && !(routed && s.noisy[i]) {
                    let (energy, dot) = crate::linalg::energy_and_dot(x, &self.proj.rows()[..m]);
                    s.raw[i * (1 + l)] = dot as f32;
                    energy
                } else {
                    crate::linalg::energy(x)
                };
                s.benergy[i] = energy;
                s.pv[i] = match self.early(noise, energy, m) {
                    Some(early) => pixel_variance_in(x, w, h, ch, RowsF32::reuse(&mut s.rows_f32, w * ch, ch), early),
                    None => 0.0,
                };
                if !routed {
                    // The route's value as route_values forms it.
                    s.noisy[i] = self.routed_noisy(noise, s.pv[i] / energy * m as f64);
                }
            }
            if !routed && self.extra_rows() > 0 {
                sel.clear();
                sel.extend((0..nn).filter(|&j| s.noisy[i0 + j]));
                self.pass_f32(xq, i0, Some(&sel[..]), self.extra_range(), s);
            }
            for i in i0..i0 + nn {
                let mean = !(routed && s.noisy[i]);
                (s.resid[i], s.noise[i]) = self.finish_query(i, mean, s.benergy[i], s.pv[i], s);
            }
        }
        (s.xidx, s.xidx2) = (sel, other);
    }

    /// As [`Self::project_f32`] (not routed) for 8-bit images given as raw pixel values (n of
    /// them): the products by [`dot_q::FastRows::dots_batch`](crate::kernels::dot_q::FastRows::dots_batch) (the integer kernel where it is
    /// fast, else [`dot_u8::dots_batch`](crate::kernels::dot_u8::dots_batch)) from 8 queries on (one at a time below), the energy
    /// exact in integers, the pixel noise by [`pixel_variance_u8`](crate::pixel_noise::pixel_variance_u8_in), all in pixel values: the
    /// 1 / 255 of the features cancels in each ratio.
    pub(crate) fn project_u8(&self, level: Level, queries: &[u8], noise: NoiseWant, s: &mut QueryScratch) {
        let (l, m) = (self.components(), self.m);
        let spec = self.binning.spec();
        let (w, h, ch) = (spec.width as usize, spec.height as usize, spec.color.channels());
        s.resize(queries.len() / m, l);
        let mut sel = std::mem::take(&mut s.xidx);
        // In sub-chunks whose images stay in cache from the products to the noise pass.
        for (c, xq) in queries.chunks(NOISE_SUB_U8 * m).enumerate() {
            let (i0, nn) = (c * NOISE_SUB_U8, xq.len() / m);
            self.pass_u8(level, xq, i0, None, self.clean_rows(), s);
            for (i, x) in (i0..).zip(xq.chunks_exact(m)) {
                s.energy[i] = s.xenergy[i - i0];
                let energy = s.energy[i] as f64;
                s.pv[i] = match self.early(noise, energy, m) {
                    Some(early) => pixel_variance_u8_in(x, w, h, ch, RowsU8::reuse(&mut s.rows_u8, w * ch, ch), early),
                    None => 0.0,
                };
                // The route's value as route_values forms it.
                s.noisy[i] = self.routed_noisy(noise, s.pv[i] / energy * m as f64);
            }
            if self.extra_rows() > 0 {
                sel.clear();
                sel.extend((0..nn).filter(|&j| s.noisy[i0 + j]));
                self.pass_u8(level, xq, i0, Some(&sel[..]), self.extra_range(), s);
            }
            for i in i0..i0 + nn {
                (s.resid[i], s.noise[i]) = self.finish_query(i, true, s.energy[i] as f64, s.pv[i], s);
            }
        }
        s.xidx = sel;
    }

    /// Query `i` of the task from its products (`s.raw`'s row: the mean's, then eigenimage c's
    /// at 1 + c; L of them when it went to the noisy match, `s.noisy`, else L_s), the mean's
    /// product taken when `mean`, its energy ||x||^2 and its pixel variance `pv`, in the same
    /// units: the unit-energy, mean-subtracted coordinates into `s.y` (0 past those it took; NaN
    /// for a query of zero or non-finite energy), and its residual ||x / ||x|| - mean||^2 less
    /// the energy inside the search's L_s coordinates (0 when not used or not taken) and pixel
    /// noise per unit-energy coordinate.
    fn finish_query(&self, i: usize, mean: bool, energy: f64, pv: f64, s: &mut QueryScratch) -> (f64, f64) {
        let (l, ls) = (self.components(), self.settings.search());
        let y = &mut s.y[i * l..(i + 1) * l];
        let raw = &s.raw[i * (1 + l)..(i + 1) * (1 + l)];
        let took = if s.noisy[i] { l } else { ls };
        y[..took].copy_from_slice(&raw[1..1 + took]);
        let Some(norm) = unit_coords(energy, &self.mean_proj[..took], &mut y[..took]) else {
            y.fill(f32::NAN);
            return (0.0, 0.0);
        };
        y[took..].fill(0.0);
        let resid = if mean && self.uses_residual() {
            // Unscaled coordinates: each scaled one's square times 1 / w_l.
            let inside: f64 = y[..ls].iter().zip(&self.inv_weight).map(|(&v, &iw)| v as f64 * v as f64 * iw).sum();
            1.0 - 2.0 * raw[0] as f64 / norm + self.mean_sq - inside
        } else {
            0.0
        };
        (resid, pv / energy)
    }

    /// [`Self::project_f32`] of f32 queries as given: binned first when the model bins. Then
    /// the query's pixel noise is measured on the image as given, where noise stands out from
    /// the image's own detail at every factor (binning averages noise away faster than detail:
    /// on binned training images no threshold separates the noisy from the clean), routing it
    /// against the threshold of the training images as given;
    /// the noisy match's nu is that noise binned (pv / b^2 for independent noise) per unit
    /// energy of the binned image.
    pub(crate) fn project_binned(&self, queries: &[f32], noise: NoiseWant, s: &mut QueryScratch) {
        if !self.binning.bins() {
            return self.project_f32(queries, noise, false, s);
        }
        let mut binned = std::mem::take(&mut s.binned);
        let (m, mb) = (self.meta.spec.features(), self.m);
        let n = queries.len() / m;
        binned.resize(n * mb, 0.0);
        s.route.resize(n, 0.0);
        s.pv_full.resize(n, 0.0);
        s.noisy.resize(n, false);
        let full = self.binning.full();
        let (w, h, ch) = (full.width as usize, full.height as usize, full.color.channels());
        // Each image binned, and its pixel noise measured as given (where noise stands out
        // from the image's own detail; binning averages it away faster than the detail), which
        // routes it.
        for (i, (x, o)) in queries.chunks_exact(m).zip(binned.chunks_exact_mut(mb)).enumerate() {
            self.binning.apply(x, o, &mut s.bin_acc);
            let energy = crate::linalg::energy(x);
            let pv = match self.early(noise, energy, m) {
                Some(early) => pixel_variance_in(x, w, h, ch, RowsF32::reuse(&mut s.rows_f32_full, w * ch, ch), early),
                None => 0.0,
            };
            (s.route[i], s.pv_full[i]) = (pv * m as f64 / energy, pv);
            s.noisy[i] = self.routed_noisy(noise, s.route[i]);
        }
        self.project_f32(&binned, NoiseWant::None, true, s);
        // The noisy match's nu: the noise of a binned pixel (pv / b^2, independent noise) per
        // unit energy of the binned image.
        let b2 = (self.binning.factor() * self.binning.factor()) as f64;
        for ((nu, &pv), &e) in s.noise.iter_mut().zip(&s.pv_full).zip(&s.benergy) {
            *nu = pv / (b2 * e);
        }
        s.binned = binned;
    }
}
