//! The robust stage's check in f64 on f32 binned rows (`crate::robust`'s dark share): the
//! query's products with the rows ([`project`], p = S^T x), the reconstruction from
//! coefficients ([`reconstruct`], S c) and its brightest value ([`peak`]).
//!
//! Both add the products f32 x f32 (exact in f64) in the order of the plain formula: each p_j
//! over the pixels in order, each pixel's reconstruction over the rows in order. The layouts
//! make those orders vectorise: [`project`] reads the rows pixel by pixel (a pixel's K values
//! padded to whole blocks of [`LANES`], one accumulator lane per row), [`reconstruct`] reads
//! them row by row (one lane per pixel). So every level gives the plain formula's bits, and the
//! check costs 2K M_b multiply-adds in f64 vectors instead of closure calls.

use super::Level;

/// The f64 lanes of one block of a pixel's row values in [`project`]'s layout (one AVX-512
/// vector, two AVX2 ones).
pub(crate) const LANES: usize = 8;

/// `p[j] = sum_i small[i kp + j] xb[i]` for j < `p.len()` (at most `kp`), the pixels of value 0
/// left out, in f64: `small` holds each pixel's row values padded to `kp` (a multiple of
/// [`LANES`]). Up to 4 blocks (K up to 32) take the vectorised body, more the plain loop in the
/// same order.
pub(crate) fn project(level: Level, small: &[f32], kp: usize, xb: &[f32], p: &mut [f64]) {
    assert!(kp.is_multiple_of(LANES) && p.len() <= kp && small.len() == xb.len() * kp, "rows of {kp} values a pixel");
    match kp / LANES {
        1 => project_blocks::<1>(level, small, xb, p),
        2 => project_blocks::<2>(level, small, xb, p),
        3 => project_blocks::<3>(level, small, xb, p),
        4 => project_blocks::<4>(level, small, xb, p),
        _ => {
            p.fill(0.0);
            for (row, &v) in small.chunks_exact(kp).zip(xb) {
                if v != 0.0 {
                    p.iter_mut().zip(row).for_each(|(a, &s)| *a += s as f64 * v as f64);
                }
            }
        }
    }
}

/// [`project`] for pixels of NB blocks at `level`: in AVX-512 where the level has it (the
/// compiler keeps the portable body's accumulators as scalars it re-packs every pixel), else the
/// portable body; the same products and sums either way.
fn project_blocks<const NB: usize>(level: Level, small: &[f32], xb: &[f32], p: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    if level.avx512() {
        // SAFETY: the level is a token of detection that found AVX-512 F; the body asserts the
        // lengths it reads.
        return unsafe { simd::project_avx512::<NB>(small, xb, p) };
    }
    let _ = level;
    project_body::<NB>(small, xb, p)
}

/// [`project`] for pixels of NB blocks: NB x [`LANES`] accumulators, to which each pixel of
/// value v adds its row values times v.
#[inline(always)]
fn project_body<const NB: usize>(small: &[f32], xb: &[f32], p: &mut [f64]) {
    let kp = NB * LANES;
    let mut acc = [[0f64; LANES]; NB];
    for (row, &v) in small.chunks_exact(kp).zip(xb) {
        if v == 0.0 {
            continue;
        }
        let v = v as f64;
        for (a, s) in acc.iter_mut().zip(row.chunks_exact(LANES)) {
            for l in 0..LANES {
                a[l] += s[l] as f64 * v;
            }
        }
    }
    for (j, d) in p.iter_mut().enumerate() {
        *d = acc[j / LANES][j % LANES];
    }
}

#[cfg(target_arch = "x86_64")]
mod simd {
    use super::LANES;
    use std::arch::x86_64::*;

    /// [`super::project_body`] in AVX-512 F: the NB blocks of accumulators in NB registers, each
    /// pixel's row values widened to f64 (exact), times v, added (no fused multiply-add).
    ///
    /// # Safety
    /// The CPU must support AVX-512 F.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn project_avx512<const NB: usize>(small: &[f32], xb: &[f32], p: &mut [f64]) {
        let kp = NB * LANES;
        assert!(small.len() == xb.len() * kp && p.len() <= kp, "rows of {kp} values a pixel");
        let mut acc = [_mm512_setzero_pd(); NB];
        for (i, &v) in xb.iter().enumerate() {
            if v == 0.0 {
                continue;
            }
            let v = _mm512_set1_pd(v as f64);
            let row = small.as_ptr().add(i * kp);
            for (b, a) in acc.iter_mut().enumerate() {
                let s = _mm512_cvtps_pd(_mm256_loadu_ps(row.add(b * LANES)));
                *a = _mm512_add_pd(*a, _mm512_mul_pd(s, v));
            }
        }
        let mut out = [[0f64; LANES]; NB];
        for (o, a) in out.iter_mut().zip(&acc) {
            _mm512_storeu_pd(o.as_mut_ptr(), *a);
        }
        for (j, d) in p.iter_mut().enumerate() {
            *d = out[j / LANES][j % LANES];
        }
    }
}

crate::kernels::dispatch! {
    /// `recon[i] = sum_j cols[j mb + i] coef[j]` (mb = `recon.len()`, the rows `cols` one after
    /// another), in f64, the rows added in order.
    pub(crate) fn reconstruct(cols: &[f32], coef: &[f64], recon: &mut [f64]) = reconstruct_body;
}

/// [`reconstruct`]: the first row's products, then each further row's added, pixel by pixel.
#[inline(always)]
fn reconstruct_body(cols: &[f32], coef: &[f64], recon: &mut [f64]) {
    let mb = recon.len();
    assert!(mb > 0 && !coef.is_empty() && cols.len() == coef.len() * mb, "{} rows of {mb} values", coef.len());
    let mut rows = cols.chunks_exact(mb).zip(coef);
    let (first, &a) = rows.next().expect("at least one row");
    recon.iter_mut().zip(first).for_each(|(r, &s)| *r = s as f64 * a);
    for (c, &a) in rows {
        recon.iter_mut().zip(c).for_each(|(r, &s)| *r += s as f64 * a);
    }
}

crate::kernels::dispatch! {
    /// The largest of `v` and 0: `v.iter().fold(0.0, f64::max)` (NaN left out), taken in lanes,
    /// which gives the same value whatever the order.
    pub(crate) fn peak(v: &[f64]) -> f64 = peak_body;
}

/// [`peak`]: the largest in each of [`LANES`] lanes, then of the lanes and the values past them.
#[inline(always)]
fn peak_body(v: &[f64]) -> f64 {
    let mut lanes = [0f64; LANES];
    let mut blocks = v.chunks_exact(LANES);
    for b in &mut blocks {
        for l in 0..LANES {
            lanes[l] = lanes[l].max(b[l]);
        }
    }
    lanes.iter().chain(blocks.remainder()).fold(0f64, |a, &x| a.max(x))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The formula plainly: p over the pixels in order (those of value 0 left out), the
    /// reconstruction over the rows in order.
    fn plain(cols: &[f32], k: usize, xb: &[f32], coef: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let mb = xb.len();
        let mut p = vec![0f64; k];
        for (i, &v) in xb.iter().enumerate() {
            if v != 0.0 {
                p.iter_mut().enumerate().for_each(|(j, a)| *a += cols[j * mb + i] as f64 * v as f64);
            }
        }
        let recon = (0..mb).map(|i| (0..k).map(|j| cols[j * mb + i] as f64 * coef[j]).sum()).collect();
        (p, recon)
    }

    #[test]
    fn every_level_gives_the_plain_formulas_bits() {
        // K across the block counts (and past the vectorised ones), pixels not a whole number
        // of vectors, and pixels of value 0.
        for (k, mb) in [(1, 5), (8, 64), (9, 33), (17, 1024), (17, 61), (24, 100), (32, 17), (33, 40), (41, 9)] {
            let cols: Vec<f32> = (0..k * mb).map(|i| ((i * 2654435761usize) % 1009) as f32 / 1009.0 - 0.3).collect();
            let xb: Vec<f32> = (0..mb).map(|i| if i % 5 == 2 { 0.0 } else { ((i * 40503) % 997) as f32 / 997.0 }).collect();
            let coef: Vec<f64> = (0..k).map(|j| (j as f64 * 0.37).sin() * 1.7).collect();
            let kp = k.next_multiple_of(LANES);
            let mut small = vec![0f32; mb * kp];
            for j in 0..k {
                for i in 0..mb {
                    small[i * kp + j] = cols[j * mb + i];
                }
            }
            let (want_p, want_r) = plain(&cols, k, &xb, &coef);
            for level in Level::supported() {
                let mut p = vec![f64::NAN; k];
                project(level, &small, kp, &xb, &mut p);
                let mut recon = vec![f64::NAN; mb];
                reconstruct(level, &cols, &coef, &mut recon);
                // Equal as numbers (a sum of no products may be 0 or -0).
                assert!(p.iter().zip(&want_p).all(|(a, b)| a == b), "K {k}, {mb} pixels, {level:?}: p {p:?} against {want_p:?}");
                assert!(recon.iter().zip(&want_r).all(|(a, b)| a == b), "K {k}, {mb} pixels, {level:?}: the reconstruction");
                assert_eq!(peak(level, &recon), want_r.iter().fold(0f64, |a, &x| a.max(x)), "K {k}, {mb} pixels, {level:?}: the peak");
            }
        }
        // All below 0, and a NaN among them: the peak is 0, as the fold's.
        for level in Level::supported() {
            assert_eq!(peak(level, &[-1.0, f64::NAN, -3.0, -0.5, -2.0, -1.0, -1.0, -1.0, -7.0]), 0.0);
            assert_eq!(peak(level, &[1.0, f64::NAN, 3.5, -0.5, 2.0, 1.0, 1.0, 1.0, 7.25, 2.0]), 7.25);
        }
    }
}
