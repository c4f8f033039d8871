//! The refined eigenspace's coarse scan: every coarse surface point scored against one query,
//! the points in SIMD lanes (coordinate-major tables, L rows of n points).
//!
//! The bodies are element-wise along the points (each point's sum runs over the coordinates in
//! the same order on every path, with no fused multiply-add), so the AVX2 and AVX-512 builds of
//! the one portable body give bit-identical results; they only widen the lanes.

use super::Level;

/// `dist[i] = sum_q wt[q] (cols[q][i] - y[q])^2` over the coordinates with a non-zero weight
/// (`cols`: rows of `dist.len()` values, at least `y.len()` rows).
pub fn sq_dist(level: Level, cols: &[f32], y: &[f32], wt: &[f32], dist: &mut [f32]) {
    match level {
        #[cfg(target_arch = "x86_64")]
        Level::Avx512 => unsafe { x86::sq_dist_avx512(cols, y, wt, dist) },
        #[cfg(target_arch = "x86_64")]
        Level::Avx2 => unsafe { x86::sq_dist_avx2(cols, y, wt, dist) },
        _ => sq_dist_portable(cols, y, wt, dist),
    }
}

/// `u[i] = sum_q a[q] cols[q][i]` and `v[i] = sum_q a[q] gcols[q][i]` (rows of `u.len()` values).
pub fn dots2(level: Level, cols: &[f32], gcols: &[f32], a: &[f32], u: &mut [f32], v: &mut [f32]) {
    match level {
        #[cfg(target_arch = "x86_64")]
        Level::Avx512 => unsafe { x86::dots2_avx512(cols, gcols, a, u, v) },
        #[cfg(target_arch = "x86_64")]
        Level::Avx2 => unsafe { x86::dots2_avx2(cols, gcols, a, u, v) },
        _ => dots2_portable(cols, gcols, a, u, v),
    }
}

/// Points per block of the scans: their sums stay in registers while every coordinate's
/// values pass (one load per point and coordinate, one store per point).
const BLOCK: usize = 64;

#[inline(always)]
fn sq_dist_portable(cols: &[f32], y: &[f32], wt: &[f32], dist: &mut [f32]) {
    let n = dist.len();
    for (b, out) in dist.chunks_mut(BLOCK).enumerate() {
        let i0 = b * BLOCK;
        let mut acc = [0f32; BLOCK];
        for ((col, &yc), &w) in cols.chunks_exact(n).zip(y).zip(wt) {
            if w == 0.0 {
                continue;
            }
            match <&[f32; BLOCK]>::try_from(&col[i0..i0 + out.len()]) {
                Ok(seg) => (0..BLOCK).for_each(|k| acc[k] += w * ((seg[k] - yc) * (seg[k] - yc))),
                Err(_) => acc.iter_mut().zip(&col[i0..i0 + out.len()]).for_each(|(s, &p)| *s += w * ((p - yc) * (p - yc))),
            }
        }
        out.copy_from_slice(&acc[..out.len()]);
    }
}

#[inline(always)]
fn dots2_portable(cols: &[f32], gcols: &[f32], a: &[f32], u: &mut [f32], v: &mut [f32]) {
    let n = u.len();
    for (b, (uo, vo)) in u.chunks_mut(BLOCK).zip(v.chunks_mut(BLOCK)).enumerate() {
        let (i0, len) = (b * BLOCK, uo.len());
        let (mut su, mut sv) = ([0f32; BLOCK], [0f32; BLOCK]);
        for ((col, gcol), &aq) in cols.chunks_exact(n).zip(gcols.chunks_exact(n)).zip(a) {
            let (c, g) = (&col[i0..i0 + len], &gcol[i0..i0 + len]);
            match (<&[f32; BLOCK]>::try_from(c), <&[f32; BLOCK]>::try_from(g)) {
                (Ok(c), Ok(g)) => (0..BLOCK).for_each(|k| {
                    su[k] += aq * c[k];
                    sv[k] += aq * g[k];
                }),
                _ => {
                    su.iter_mut().zip(c).for_each(|(s, &p)| *s += aq * p);
                    sv.iter_mut().zip(g).for_each(|(s, &p)| *s += aq * p);
                }
            }
        }
        uo.copy_from_slice(&su[..len]);
        vo.copy_from_slice(&sv[..len]);
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{dots2_portable, sq_dist_portable};

    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[target_feature(enable = "avx2,fma")]
    pub unsafe fn sq_dist_avx2(cols: &[f32], y: &[f32], wt: &[f32], dist: &mut [f32]) {
        sq_dist_portable(cols, y, wt, dist)
    }

    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn sq_dist_avx512(cols: &[f32], y: &[f32], wt: &[f32], dist: &mut [f32]) {
        sq_dist_portable(cols, y, wt, dist)
    }

    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[target_feature(enable = "avx2,fma")]
    pub unsafe fn dots2_avx2(cols: &[f32], gcols: &[f32], a: &[f32], u: &mut [f32], v: &mut [f32]) {
        dots2_portable(cols, gcols, a, u, v)
    }

    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn dots2_avx512(cols: &[f32], gcols: &[f32], a: &[f32], u: &mut [f32], v: &mut [f32]) {
        dots2_portable(cols, gcols, a, u, v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_level_gives_the_same_bits_as_the_reference() {
        let (n, l) = (131, 7);
        let cols: Vec<f32> = (0..n * l).map(|i| ((i * 7919) % 1000) as f32 / 500.0 - 1.0).collect();
        let gcols: Vec<f32> = (0..n * l).map(|i| ((i * 104729) % 997) as f32 / 400.0 - 1.2).collect();
        let y: Vec<f32> = (0..l).map(|q| q as f32 * 0.1 - 0.3).collect();
        let wt: Vec<f32> = (0..l).map(|q| if q == 3 { 0.0 } else { 1.0 + q as f32 }).collect();
        let want: Vec<f32> = (0..n)
            .map(|i| (0..l).filter(|&q| wt[q] != 0.0).fold(0f32, |s, q| s + wt[q] * ((cols[q * n + i] - y[q]) * (cols[q * n + i] - y[q]))))
            .collect();
        let want_u: Vec<f32> = (0..n).map(|i| (0..l).fold(0f32, |s, q| s + y[q] * cols[q * n + i])).collect();
        let want_v: Vec<f32> = (0..n).map(|i| (0..l).fold(0f32, |s, q| s + y[q] * gcols[q * n + i])).collect();
        for level in Level::supported() {
            let mut d = vec![f32::NAN; n];
            sq_dist(level, &cols, &y, &wt, &mut d);
            assert_eq!(d, want, "{level:?}");
            let (mut u, mut v) = (vec![f32::NAN; n], vec![f32::NAN; n]);
            dots2(level, &cols, &gcols, &y, &mut u, &mut v);
            assert_eq!((u, v), (want_u.clone(), want_v.clone()), "{level:?}");
        }
    }
}
