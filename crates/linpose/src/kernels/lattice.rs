//! The refined method's lattice search ([`crate::methods::refined::search::lattice`]) in AVX-512:
//! the portable bodies' operations in the same order, so the same bits. Each safe entry takes
//! the [`Level`] and runs only where it has AVX-512 (else it returns false or `None`, and the
//! caller runs its portable body).

use super::Level;

/// Products per knot of the weighted pairs ([`pairs`]): p_k p_k, p_k s_k, s_k s_k, p_k p_{k+1},
/// p_k s_{k+1}, s_k p_{k+1}, s_k s_{k+1}.
pub(crate) const PAIRS: usize = 7;

/// What the kernels read of a lattice search (its fields, by the same names: see
/// [`crate::methods::refined::search::lattice::Lattice`]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct LatticeView<'a> {
    pub ls: usize,
    pub cols: usize,
    pub values: &'a [f32],
    pub slopes: &'a [f32],
    pub even: &'a [f64],
    pub herm: &'a [[f32; 4]],
    pub norms: &'a [f32],
    pub norms_t: &'a [f32],
    pub herm_t: &'a [f32],
    pub norm_min: &'a [f32],
    pub slope_max: [f32; 2],
}

/// Lattice poses as (interval, offset).
pub(crate) type Hits = Vec<(usize, usize)>;

/// A query of the even scan: ||y||^2 in f32, and the slack of the f32 rounding.
#[derive(Debug, Clone, Copy)]
pub(crate) struct EvenQuery {
    pub yy: f32,
    pub slack: f64,
}

/// `body`, inlined into a copy compiled with AVX-512F where `level` has it (so that its loops
/// are built for it, and the kernels it calls inline), else as it is.
#[inline(always)]
pub(crate) fn with_avx512f<R>(level: Level, body: impl FnOnce() -> R) -> R {
    /// `body` compiled with AVX-512F.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    unsafe fn avx512<R>(body: impl FnOnce() -> R) -> R {
        body()
    }
    #[cfg(target_arch = "x86_64")]
    if level.avx512() {
        // SAFETY: the level is a token of detection that found AVX-512F.
        return unsafe { avx512(body) };
    }
    let _ = level;
    body()
}

/// The seven weighted products per knot into `g` (PAIRS x cols) where `level` has AVX-512
/// ([`simd::pairs_avx512`]); false otherwise.
#[inline(always)]
pub(crate) fn pairs(level: Level, s: LatticeView<'_>, wt: &[f64], g: &mut [f64]) -> bool {
    #[cfg(target_arch = "x86_64")]
    if level.avx512() {
        // SAFETY: the level is a token of detection that found AVX-512F; the kernel asserts the
        // lengths it reads and writes.
        unsafe { simd::pairs_avx512(s, wt, g) };
        return true;
    }
    let _ = (level, s, wt, g);
    false
}

/// The products cp and cs (a = wt y) where `level` has AVX-512 ([`simd::products_avx512`]);
/// false otherwise.
#[inline(always)]
pub(crate) fn products(level: Level, s: LatticeView<'_>, y: &[f32], wt: &[f64], cp: &mut [f64], cs: &mut [f64]) -> bool {
    #[cfg(target_arch = "x86_64")]
    if level.avx512() {
        // SAFETY: as in `pairs` (AVX-512F detected, the lengths asserted by the kernel).
        unsafe { simd::products_avx512(s, y, wt, cp, cs) };
        return true;
    }
    let _ = (level, s, y, wt, cp, cs);
    false
}

/// The even lattice's scan where `level` has AVX-512: the products into `buf`, then the pruned
/// scan ([`simd::pruned_avx512`], at most `P` intervals), or where it gives up the full scan
/// of every pose; the poses within the cut (`cut_of` the least distance) into `hits`. False
/// (nothing written) otherwise.
#[inline(always)]
pub(crate) fn even_scan<const P: usize>(
    level: Level,
    s: LatticeView<'_>,
    y: &[f32],
    q: EvenQuery,
    cut_of: &dyn Fn(f32) -> f32,
    buf: &mut [f32],
    hits: &mut Hits,
) -> bool {
    #[cfg(target_arch = "x86_64")]
    if level.avx512() {
        let (c, nj) = (s.cols, s.even.len());
        let np = s.norms.len() / nj;
        // SAFETY: the level is a token of detection that found AVX-512F; the kernels assert
        // the lengths they read and write.
        unsafe {
            simd::even_products_avx512(s, y, buf);
            if !simd::pruned_avx512::<P>(s, q.yy, q.slack, cut_of, buf, hits) {
                let least = simd::even_poses_avx512(s, q.yy, buf);
                simd::under_avx512(&buf[2 * (c + 16)..2 * (c + 16) + nj * np], np, cut_of(least), hits);
            }
        }
        return true;
    }
    let _ = (level, s, y, q, cut_of, buf, hits);
    false
}

/// The even scan's steps one by one where `level` has AVX-512 (for the tests that hold the
/// pruned scan to the full one): the products, then the pruned scan's poses into the first of
/// `hits` and the full scan's into the second; whether the pruned scan ran (it leaves its
/// poses empty where it gives up). `None` without AVX-512.
#[cfg(test)]
pub(crate) fn even_scans<const P: usize>(
    level: Level,
    s: LatticeView<'_>,
    y: &[f32],
    q: EvenQuery,
    cut_of: &dyn Fn(f32) -> f32,
    buf: &mut [f32],
    hits: (&mut Hits, &mut Hits),
) -> Option<bool> {
    let (pruned, full) = hits;
    #[cfg(target_arch = "x86_64")]
    if level.avx512() {
        let (c, nj) = (s.cols, s.even.len());
        let np = s.norms.len() / nj;
        // SAFETY: as in `even_scan`.
        unsafe {
            simd::even_products_avx512(s, y, buf);
            let ran = simd::pruned_avx512::<P>(s, q.yy, q.slack, cut_of, buf, pruned);
            let least = simd::even_poses_avx512(s, q.yy, buf);
            simd::under_avx512(&buf[2 * (c + 16)..2 * (c + 16) + nj * np], np, cut_of(least), full);
            return Some(ran);
        }
    }
    let _ = (level, s, y, q, cut_of, buf, pruned, full);
    None
}

/// The AVX-512 bodies.
#[cfg(target_arch = "x86_64")]
mod simd {
    use super::{LatticeView, PAIRS};

    /// The products of [`crate::methods::refined::search::lattice::Lattice::even_distances`] (cp and cs into `buf`), 16 columns a vector
    /// (the same products and sums in the same order).
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub(crate) unsafe fn even_products_avx512(s: LatticeView<'_>, y: &[f32], buf: &mut [f32]) {
        use std::arch::x86_64::*;
        let c = s.cols;
        assert!(c.is_multiple_of(16) && buf.len() >= 2 * (c + 16));
        assert!(y.len() >= s.ls && s.values.len() >= s.ls * c && s.slopes.len() >= s.ls * c);
        let base = buf.as_mut_ptr();
        // SAFETY: within buf (asserted length).
        let (cp, cs) = unsafe { (base, base.add(c + 16)) };
        for k0 in (0..c).step_by(16) {
            let (mut sp, mut ss) = (_mm512_setzero_ps(), _mm512_setzero_ps());
            for (l, &yl) in y[..s.ls].iter().enumerate() {
                let a = _mm512_set1_ps(yl);
                // SAFETY: columns k0 .. k0 + 16 of row l (asserted lengths).
                let (v, sl) = unsafe { (_mm512_loadu_ps(s.values.as_ptr().add(l * c + k0)), _mm512_loadu_ps(s.slopes.as_ptr().add(l * c + k0))) };
                sp = _mm512_add_ps(sp, _mm512_mul_ps(a, v));
                ss = _mm512_add_ps(ss, _mm512_mul_ps(a, sl));
            }
            // SAFETY: columns k0 .. k0 + 16 of cp and cs (asserted).
            unsafe {
                _mm512_storeu_ps(cp.add(k0), sp);
                _mm512_storeu_ps(cs.add(k0), ss);
            }
        }
    }

    /// The distances of [`crate::methods::refined::search::lattice::Lattice::even_distances`] at every lattice pose from the products in
    /// `buf` ([`even_products_avx512`]), 16 poses a vector (the same operations: the same bits);
    /// returns the least.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub(crate) unsafe fn even_poses_avx512(s: LatticeView<'_>, yy: f32, buf: &mut [f32]) -> f32 {
        use std::arch::x86_64::*;
        let (c, nj) = (s.cols, s.even.len());
        let np = s.norms.len() / nj;
        assert!(c.is_multiple_of(16) && np.is_multiple_of(16) && np <= c && buf.len() >= 2 * (c + 16) + nj * np && s.herm.len() == nj);
        let base = buf.as_mut_ptr();
        // SAFETY: within buf (asserted length).
        let (cp, cs, d) = unsafe { (base, base.add(c + 16), base.add(2 * (c + 16))) };
        let (mut mins, yv) = (_mm512_set1_ps(f32::INFINITY), _mm512_set1_ps(yy));
        for j in 0..nj {
            let hj = s.herm[j];
            let h = [_mm512_set1_ps(hj[0]), _mm512_set1_ps(hj[1]), _mm512_set1_ps(hj[2]), _mm512_set1_ps(hj[3])];
            for i0 in (0..np).step_by(16) {
                // SAFETY: columns i0 .. i0 + 17 of cp and cs (cols + 16 each, np <= cols), poses
                // j np + i0 .. + 16 (asserted).
                unsafe {
                    let (c0, c1) = (_mm512_loadu_ps(cp.add(i0)), _mm512_loadu_ps(cp.add(i0 + 1)));
                    let (s0, s1) = (_mm512_loadu_ps(cs.add(i0)), _mm512_loadu_ps(cs.add(i0 + 1)));
                    let v = distance(yv, _mm512_loadu_ps(s.norms.as_ptr().add(j * np + i0)), h, [c0, s0, c1, s1]);
                    _mm512_storeu_ps(d.add(j * np + i0), v);
                    mins = _mm512_min_ps(v, mins);
                }
            }
        }
        _mm512_reduce_min_ps(mins)
    }

    /// The poses of [`crate::methods::refined::search::lattice::Lattice::nearest_even`] within the cut (`cut_of` the least distance) into
    /// `hits`, from the products in `buf` ([`even_products_avx512`]), evaluating only the
    /// intervals that can hold one: per interval a lower bound of d over its poses,
    /// ||y||^2 + min ||f||^2 - 2 (max(cp_i, cp_i+1) + max h h10 max(cs_i, 0) + max -h h11
    /// max(-cs_i+1, 0)) (h00 + h01 = 1, h10 >= 0 >= h11), against the cut of the least d at
    /// the intervals' first poses. An interval whose bound, less twice `slack` (its f32
    /// rounding and d's), is above that cut holds no pose within the final cut, which is no
    /// larger; the others are evaluated with the full scan's operations on the same numbers, so
    /// the least, the cut and the poses are the full scan's. With more than `P`
    /// intervals left, returns false (and leaves `hits` empty) for the full scan.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub(crate) unsafe fn pruned_avx512<const P: usize>(
        s: LatticeView<'_>,
        yy: f32,
        slack: f64,
        cut_of: &dyn Fn(f32) -> f32,
        buf: &mut [f32],
        hits: &mut Vec<(usize, usize)>,
    ) -> bool {
        use std::arch::x86_64::*;
        let (c, nj) = (s.cols, s.even.len());
        let (np, npo) = (s.norms.len() / nj, s.herm_t.len() / 4);
        let intervals = s.norms_t.len() / npo;
        assert!(np.is_multiple_of(16) && npo.is_multiple_of(16) && np <= c && s.norm_min.len() == np && intervals <= np);
        assert!(buf.len() >= 2 * (c + 16) + np + P * npo && s.herm.len() == nj && nj <= npo);
        let base = buf.as_mut_ptr();
        // SAFETY: within buf (asserted length): cp, cs, then the bounds and the distances.
        let (cp, cs, lb, dd) = unsafe { (base, base.add(c + 16), base.add(2 * (c + 16)), base.add(2 * (c + 16) + np)) };
        let (yv, two, zero) = (_mm512_set1_ps(yy), _mm512_set1_ps(2.0), _mm512_setzero_ps());
        let h = s.herm[0];
        let h = [_mm512_set1_ps(h[0]), _mm512_set1_ps(h[1]), _mm512_set1_ps(h[2]), _mm512_set1_ps(h[3])];
        let (m1, m3) = (_mm512_set1_ps(s.slope_max[0]), _mm512_set1_ps(s.slope_max[1]));
        let mut first = _mm512_set1_ps(f32::INFINITY);
        for i0 in (0..np).step_by(16) {
            // SAFETY: columns i0 .. i0 + 17 of cp and cs (cols + 16 each, np <= cols), bounds
            // i0 .. i0 + 16 (asserted).
            unsafe {
                let (c0, c1) = (_mm512_loadu_ps(cp.add(i0)), _mm512_loadu_ps(cp.add(i0 + 1)));
                let (s0, s1) = (_mm512_loadu_ps(cs.add(i0)), _mm512_loadu_ps(cs.add(i0 + 1)));
                // The first pose of each interval, as the full scan computes it.
                first = _mm512_min_ps(distance(yv, _mm512_loadu_ps(s.norms.as_ptr().add(i0)), h, [c0, s0, c1, s1]), first);
                let most = _mm512_add_ps(
                    _mm512_add_ps(_mm512_max_ps(c0, c1), _mm512_mul_ps(m1, _mm512_max_ps(s0, zero))),
                    _mm512_mul_ps(m3, _mm512_max_ps(_mm512_sub_ps(zero, s1), zero)),
                );
                _mm512_storeu_ps(lb.add(i0), _mm512_sub_ps(_mm512_add_ps(yv, _mm512_loadu_ps(s.norm_min.as_ptr().add(i0))), _mm512_mul_ps(two, most)));
            }
        }
        // Bounds above this cannot hold a pose within the cut.
        let limit = _mm512_set1_ps((cut_of(_mm512_reduce_min_ps(first)) as f64 + 2.0 * slack) as f32);
        let mut left = [0usize; P];
        let mut n = 0;
        for i0 in (0..np).step_by(16) {
            // SAFETY: bounds i0 .. i0 + 16 (asserted); +inf past the last interval.
            let mut m = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(unsafe { _mm512_loadu_ps(lb.add(i0)) }, limit);
            while m != 0 {
                if n == P {
                    return false;
                }
                left[n] = i0 + m.trailing_zeros() as usize;
                n += 1;
                m &= m - 1;
            }
        }
        let mut mins = _mm512_set1_ps(f32::INFINITY);
        for (slot, &i) in left[..n].iter().enumerate() {
            // SAFETY: columns i and i + 1 of cp and cs, interval i's row of norms_t, the Hermite
            // weights' rows of herm_t (4 of npo) and the slot's row of distances (asserted
            // lengths).
            unsafe {
                let (c0, c1, s0, s1) = (_mm512_set1_ps(*cp.add(i)), _mm512_set1_ps(*cp.add(i + 1)), _mm512_set1_ps(*cs.add(i)), _mm512_set1_ps(*cs.add(i + 1)));
                for o in (0..npo).step_by(16) {
                    let hp = s.herm_t.as_ptr().add(o);
                    let h = [_mm512_loadu_ps(hp), _mm512_loadu_ps(hp.add(npo)), _mm512_loadu_ps(hp.add(2 * npo)), _mm512_loadu_ps(hp.add(3 * npo))];
                    let v = distance(yv, _mm512_loadu_ps(s.norms_t.as_ptr().add(i * npo + o)), h, [c0, s0, c1, s1]);
                    _mm512_storeu_ps(dd.add(slot * npo + o), v);
                    mins = _mm512_min_ps(v, mins);
                }
            }
        }
        let cut = _mm512_set1_ps(cut_of(_mm512_reduce_min_ps(mins)));
        for (slot, &i) in left[..n].iter().enumerate() {
            for o in (0..npo).step_by(16) {
                // SAFETY: the slot's distances o .. o + 16 (written above).
                let mut m = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(unsafe { _mm512_loadu_ps(dd.add(slot * npo + o)) }, cut);
                while m != 0 {
                    hits.push((i, o + m.trailing_zeros() as usize));
                    m &= m - 1;
                }
            }
        }
        true
    }

    /// The f32 distance yy + norm - 2 y.f with y.f = ((h0 cp_i + h1 cs_i) + h2 cp_i+1) + h3 cs_i+1
    /// (`k` = [cp_i, cs_i, cp_i+1, cs_i+1]) in 16 lanes: the one sequence of operations of every
    /// scan of [`crate::methods::refined::search::lattice::Lattice::nearest_even`] (the portable [`crate::methods::refined::search::lattice::Lattice::even_distances`] too), so each
    /// gives a pose the same bits.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    #[inline]
    unsafe fn distance(
        yy: std::arch::x86_64::__m512,
        norm: std::arch::x86_64::__m512,
        h: [std::arch::x86_64::__m512; 4],
        k: [std::arch::x86_64::__m512; 4],
    ) -> std::arch::x86_64::__m512 {
        use std::arch::x86_64::*;
        let dot = _mm512_add_ps(
            _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(h[0], k[0]), _mm512_mul_ps(h[1], k[1])), _mm512_mul_ps(h[2], k[2])),
            _mm512_mul_ps(h[3], k[3]),
        );
        _mm512_sub_ps(_mm512_add_ps(yy, norm), _mm512_mul_ps(_mm512_set1_ps(2.0), dot))
    }

    /// [`crate::methods::refined::search::lattice`]'s `under` 16 values a comparison (`d` in whole vectors).
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub(crate) unsafe fn under_avx512(d: &[f32], np: usize, cut: f32, hits: &mut Vec<(usize, usize)>) {
        use std::arch::x86_64::*;
        assert!(d.len().is_multiple_of(16), "whole rows of 16");
        let cv = _mm512_set1_ps(cut);
        for b in (0..d.len()).step_by(16) {
            // SAFETY: values b .. b + 16 of d.
            let mut m = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(unsafe { _mm512_loadu_ps(d.as_ptr().add(b)) }, cv);
            while m != 0 {
                let at = b + m.trailing_zeros() as usize;
                hits.push((at % np, at / np));
                m &= m - 1;
            }
        }
    }

    /// [`crate::methods::refined::search::lattice::Lattice::pairs`] 8 columns at a time, the seven sums over the coordinates in registers
    /// (the same products and sums, each column's over l in increasing order: the same bits).
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub(crate) unsafe fn pairs_avx512(s: LatticeView<'_>, wt: &[f64], g: &mut [f64]) {
        use std::arch::x86_64::*;
        let c = s.cols;
        assert!(c.is_multiple_of(8) && c >= 16 && g.len() >= PAIRS * c && s.values.len() >= s.ls * c && s.slopes.len() >= s.ls * c && wt.len() >= s.ls);
        for k0 in (0..c).step_by(8) {
            // The neighbour products for the columns before c - 8 (see Lattice::pairs).
            let next = k0 + 8 < c;
            let mut acc = [_mm512_setzero_pd(); PAIRS];
            for (l, &w) in wt[..s.ls].iter().enumerate() {
                if w == 0.0 {
                    continue;
                }
                let wv = _mm512_set1_pd(w);
                let at = l * c + k0;
                // SAFETY: columns k0 .. k0 + 8 of row l (and k0 + 1 .. k0 + 9 when k0 + 8 < c)
                // lie within the row (asserted lengths).
                let (a, b) =
                    unsafe { (_mm512_cvtps_pd(_mm256_loadu_ps(s.values.as_ptr().add(at))), _mm512_cvtps_pd(_mm256_loadu_ps(s.slopes.as_ptr().add(at)))) };
                let (wa, wb) = (_mm512_mul_pd(wv, a), _mm512_mul_pd(wv, b));
                acc[0] = _mm512_add_pd(acc[0], _mm512_mul_pd(wa, a));
                acc[1] = _mm512_add_pd(acc[1], _mm512_mul_pd(wa, b));
                acc[2] = _mm512_add_pd(acc[2], _mm512_mul_pd(wb, b));
                if next {
                    // SAFETY: as above.
                    let (a1, b1) = unsafe {
                        (_mm512_cvtps_pd(_mm256_loadu_ps(s.values.as_ptr().add(at + 1))), _mm512_cvtps_pd(_mm256_loadu_ps(s.slopes.as_ptr().add(at + 1))))
                    };
                    acc[3] = _mm512_add_pd(acc[3], _mm512_mul_pd(wa, a1));
                    acc[4] = _mm512_add_pd(acc[4], _mm512_mul_pd(wa, b1));
                    acc[5] = _mm512_add_pd(acc[5], _mm512_mul_pd(wb, a1));
                    acc[6] = _mm512_add_pd(acc[6], _mm512_mul_pd(wb, b1));
                }
            }
            for (q, v) in acc.iter().enumerate() {
                // SAFETY: columns k0 .. k0 + 8 of product q (g holds PAIRS x c).
                unsafe { _mm512_storeu_pd(g.as_mut_ptr().add(q * c + k0), *v) };
            }
        }
    }

    /// The products cp and cs of [`crate::methods::refined::search::lattice::Lattice::nearest_body`] in AVX-512 registers (the same
    /// operations in the same order: the same bits).
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub(crate) unsafe fn products_avx512(s: LatticeView<'_>, y: &[f32], wt: &[f64], cp: &mut [f64], cs: &mut [f64]) {
        use std::arch::x86_64::*;
        let c = s.cols;
        assert!(
            c.is_multiple_of(8)
                && cp.len() >= c
                && cs.len() >= c
                && s.values.len() >= s.ls * c
                && s.slopes.len() >= s.ls * c
                && wt.len() >= s.ls
                && y.len() >= s.ls
        );
        for k0 in (0..c).step_by(8) {
            let (mut sp, mut ss) = (_mm512_setzero_pd(), _mm512_setzero_pd());
            for l in 0..s.ls {
                let a = wt[l] * y[l] as f64;
                if a == 0.0 {
                    continue;
                }
                let av = _mm512_set1_pd(a);
                // SAFETY: columns k0 .. k0 + 8 of row l (asserted lengths).
                let (v, sl) = unsafe {
                    (_mm512_cvtps_pd(_mm256_loadu_ps(s.values.as_ptr().add(l * c + k0))), _mm512_cvtps_pd(_mm256_loadu_ps(s.slopes.as_ptr().add(l * c + k0))))
                };
                sp = _mm512_add_pd(sp, _mm512_mul_pd(av, v));
                ss = _mm512_add_pd(ss, _mm512_mul_pd(av, sl));
            }
            // SAFETY: columns k0 .. k0 + 8 of cp and cs (asserted).
            unsafe {
                _mm512_storeu_pd(cp.as_mut_ptr().add(k0), sp);
                _mm512_storeu_pd(cs.as_mut_ptr().add(k0), ss);
            }
        }
    }
}
