//! Products of one 8-bit image with a few f32 weight rows, accumulated in f32: the whole cost of
//! a linear-model query (K rows) and of an eigenspace projection (L rows).
//!
//! Every path computes, per row, 16 lane accumulators (lane l takes pixels l, l + 16, ...) by
//! fused multiply-adds in pixel order, then the same fixed pairwise sum of the 16 lanes, so the
//! AVX-512, AVX2 and portable paths give bit-identical results.

use super::Level;

/// Pixels per vector step.
const LANES: usize = 16;
/// Weight rows per pass over the image (accumulators kept in registers).
const MAX_ROWS: usize = 8;

/// `out[r] = sum_p x[p] * w[r * m + p]` for every row r (`out.len()` rows), m = `x.len()`.
#[track_caller]
pub fn dots(level: Level, x: &[u8], w: &[f32], out: &mut [f32]) {
    let m = x.len();
    assert_eq!(w.len(), m * out.len(), "weight rows of the image's length");
    for (rows, o) in w.chunks(m * MAX_ROWS).zip(out.chunks_mut(MAX_ROWS)) {
        match o.len() {
            1 => pass::<1>(level, x, rows, o),
            2 => pass::<2>(level, x, rows, o),
            3 => pass::<3>(level, x, rows, o),
            4 => pass::<4>(level, x, rows, o),
            5 => pass::<5>(level, x, rows, o),
            6 => pass::<6>(level, x, rows, o),
            7 => pass::<7>(level, x, rows, o),
            _ => pass::<8>(level, x, rows, o),
        }
    }
}

/// Sum of squares of the pixels, exact (in integers).
pub fn sum_squares(x: &[u8]) -> u64 {
    // Per chunk the u32 sum stays below 2^32 (65,536 * 255^2 < 2^32).
    x.chunks(1 << 16).map(|c| c.iter().map(|&v| v as u32 * v as u32).sum::<u32>() as u64).sum()
}

#[inline(always)]
fn pass<const R: usize>(level: Level, x: &[u8], w: &[f32], out: &mut [f32]) {
    let acc = match level {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: Level::Avx512 / Avx2 come from Level::detect or Level::supported, which check
        // the CPU; `w` holds R rows of x.len() values (asserted in `dots`).
        Level::Avx512 => unsafe { x86::lanes_avx512::<R>(x, w) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above (avx2 and fma detected).
        Level::Avx2 => unsafe { x86::lanes_avx2::<R>(x, w) },
        _ => lanes_portable::<R>(x, w),
    };
    for (o, a) in out.iter_mut().zip(&acc) {
        *o = reduce(a);
    }
}

/// The fixed pairwise sum of 16 lanes.
#[inline(always)]
fn reduce(a: &[f32; LANES]) -> f32 {
    let mut s = *a;
    let mut w = LANES / 2;
    while w > 0 {
        for l in 0..w {
            s[l] += s[l + w];
        }
        w /= 2;
    }
    s[0]
}

/// Pixels past the last whole vector step, into their lanes.
#[inline(always)]
fn tail<const R: usize>(x: &[u8], w: &[f32], acc: &mut [[f32; LANES]; R]) {
    let m = x.len();
    let start = m / LANES * LANES;
    for p in start..m {
        for r in 0..R {
            acc[r][p - start] = (x[p] as f32).mul_add(w[r * m + p], acc[r][p - start]);
        }
    }
}

#[inline(always)]
fn lanes_portable<const R: usize>(x: &[u8], w: &[f32]) -> [[f32; LANES]; R] {
    let m = x.len();
    let mut acc = [[0f32; LANES]; R];
    for (c, xc) in x.chunks_exact(LANES).enumerate() {
        let mut xf = [0f32; LANES];
        xf.iter_mut().zip(xc).for_each(|(f, &v)| *f = v as f32);
        for r in 0..R {
            let wr = &w[r * m + c * LANES..r * m + (c + 1) * LANES];
            for l in 0..LANES {
                acc[r][l] = xf[l].mul_add(wr[l], acc[r][l]);
            }
        }
    }
    tail(x, w, &mut acc);
    acc
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{lanes_portable, tail, LANES};
    use std::arch::x86_64::*;

    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[target_feature(enable = "avx2,fma")]
    pub unsafe fn lanes_avx2<const R: usize>(x: &[u8], w: &[f32]) -> [[f32; LANES]; R] {
        lanes_portable::<R>(x, w)
    }

    /// # Safety
    /// The CPU must support AVX-512F; `w` holds R rows of `x.len()` values.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn lanes_avx512<const R: usize>(x: &[u8], w: &[f32]) -> [[f32; LANES]; R] {
        let m = x.len();
        assert!(w.len() >= R * m);
        let mut acc = [_mm512_setzero_ps(); R];
        let (xp, wp) = (x.as_ptr(), w.as_ptr());
        for c in 0..m / LANES {
            let xv = _mm512_cvtepi32_ps(_mm512_cvtepu8_epi32(_mm_loadu_si128(xp.add(c * LANES) as *const __m128i)));
            for r in 0..R {
                acc[r] = _mm512_fmadd_ps(xv, _mm512_loadu_ps(wp.add(r * m + c * LANES)), acc[r]);
            }
        }
        let mut out = [[0f32; LANES]; R];
        for r in 0..R {
            _mm512_storeu_ps(out[r].as_mut_ptr(), acc[r]);
        }
        tail(x, w, &mut out);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_path_matches_the_reference_and_the_others_bitwise() {
        for &(m, rows) in &[(1, 1), (15, 3), (16, 2), (100, 9), (19_200 / 40, 20), (1000, 3)] {
            let x: Vec<u8> = (0..m).map(|i| ((i * 7919 + 13) % 256) as u8).collect();
            let w: Vec<f32> = (0..m * rows).map(|i| ((i * 104729) % 2001) as f32 / 1000.0 - 1.0).collect();
            let want: Vec<f64> = (0..rows).map(|r| (0..m).map(|p| x[p] as f64 * w[r * m + p] as f64).sum()).collect();
            let mut first: Option<Vec<f32>> = None;
            for level in Level::supported() {
                let mut out = vec![0f32; rows];
                dots(level, &x, &w, &mut out);
                for (o, wv) in out.iter().zip(&want) {
                    let scale: f64 = 255.0 * m as f64;
                    assert!((*o as f64 - wv).abs() <= 1e-6 * scale, "{level:?} m {m}: {o} vs {wv}");
                }
                match &first {
                    Some(f) => assert_eq!(f.iter().map(|v| v.to_bits()).collect::<Vec<_>>(), out.iter().map(|v| v.to_bits()).collect::<Vec<_>>(), "{level:?}"),
                    None => first = Some(out),
                }
            }
        }
    }

    #[test]
    fn sum_squares_is_exact() {
        let x = vec![255u8; 200_000];
        assert_eq!(sum_squares(&x), 200_000 * 65_025);
    }
}
