//! The affine fit of the noisy match: a query's coordinates against a surface point under a free
//! gain and a free offset along a second surface, solved in closed form.

use crate::manifold::surface::BLOCK_DIM;
use crate::methods::refined::tuning::DEGENERATE;

/// Where a query's coordinates `z` meet the surface `alpha (f(t) + c) + beta g(t)` with the gain
/// alpha and the offset beta fitted (weighted least squares, `wt`) for each pose: the affine
/// match of a noisy query ([`super::RefinedModel`]'s noise path). `f` and `g` are the two
/// surfaces' values at t; returns the weighted squared residual and (alpha, beta).
pub fn affine_fit(z: &[f64], c: &[f64], wt: &[f64], f: &[f64], g: &[f64]) -> (f64, [f64; 2]) {
    let (mut a, mut b, mut cc, mut u, mut v, mut zz) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for ((((&zl, &cl), &w), &fl), &gl) in z.iter().zip(c).zip(wt).zip(f).zip(g) {
        let m = fl + cl;
        a += w * m * m;
        b += w * m * gl;
        cc += w * gl * gl;
        u += w * zl * m;
        v += w * zl * gl;
        zz += w * zl * zl;
    }
    affine_solve(zz, [a, b, cc, u, v])
}

/// [`affine_fit`]'s residual for many surface points against one query: z, c and the weights
/// held in lanes of 8 (zero beyond the coordinates used), each sum taken lane by lane and the
/// lanes added at the end, so the products vectorise (the sums are taken in another order than
/// [`affine_fit`]'s: equal to rounding).
pub struct AffineQuery {
    lanes: usize,
    /// w z, c and w per coordinate.
    wz: [f64; BLOCK_DIM],
    c: [f64; BLOCK_DIM],
    w: [f64; BLOCK_DIM],
    zz: f64,
}

impl AffineQuery {
    /// The query `z`, the mean's coordinates `c` and the weights `wt` (at most 32
    /// coordinates, all of the same length).
    pub fn new(z: &[f64], c: &[f64], wt: &[f64]) -> AffineQuery {
        let n = z.len();
        assert!(n <= BLOCK_DIM && c.len() == n && wt.len() == n);
        let mut q = AffineQuery { lanes: n.div_ceil(8) * 8, wz: [0.0; BLOCK_DIM], c: [0.0; BLOCK_DIM], w: [0.0; BLOCK_DIM], zz: 0.0 };
        for i in 0..n {
            (q.wz[i], q.c[i], q.w[i]) = (wt[i] * z[i], c[i], wt[i]);
            q.zz += wt[i] * z[i] * z[i];
        }
        q
    }

    /// The residual at the surface point `f` with offset `g`: the query's coordinates rounded up
    /// to a multiple of 8 values (as [`Surface::climb_pair`](crate::manifold::surface::Surface::climb_pair) gives them), zero beyond.
    pub fn residual(&self, f: &[f64], g: &[f64]) -> f64 {
        #[cfg(target_arch = "x86_64")]
        if crate::kernels::Level::detect().avx512() {
            // SAFETY: the CPU supports AVX-512F (detected).
            return unsafe { simd::affine_residual_avx512(self, f, g) };
        }
        self.residual_body(f, g)
    }

    #[inline(always)]
    pub(crate) fn residual_body(&self, f: &[f64], g: &[f64]) -> f64 {
        let n = self.lanes;
        assert!(f.len() >= n && g.len() >= n, "{n} values, zero beyond the coordinates");
        let mut acc = [[0f64; 8]; 5];
        for k in (0..n).step_by(8) {
            for i in k..k + 8 {
                let m = f[i] + self.c[i];
                let (wm, wg) = (self.w[i] * m, self.w[i] * g[i]);
                acc[0][i - k] += wm * m;
                acc[1][i - k] += wm * g[i];
                acc[2][i - k] += wg * g[i];
                acc[3][i - k] += self.wz[i] * m;
                acc[4][i - k] += self.wz[i] * g[i];
            }
        }
        affine_solve(self.zz, acc.map(|a| a.iter().sum())).0
    }
}

/// [`affine_fit`]'s residual and (alpha, beta) from its weighted sums (m.m, m.g, g.g, z.m, z.g),
/// m = f + c, and z.z.
fn affine_solve(zz: f64, [a, b, cc, u, v]: [f64; 5]) -> (f64, [f64; 2]) {
    let det = a * cc - b * b;
    if det > DEGENERATE * a * cc && det > 0.0 {
        let (al, be) = ((cc * u - b * v) / det, (a * v - b * u) / det);
        ((zz - al * u - be * v).max(0.0), [al, be])
    } else if a > 0.0 {
        ((zz - u * u / a).max(0.0), [u / a, 0.0])
    } else {
        (zz, [0.0, 0.0])
    }
}

#[cfg(target_arch = "x86_64")]
mod simd {
    use super::BLOCK_DIM;
    use crate::manifold::surface::simd::lanes_sum;
    use std::arch::x86_64::*;

    /// [`super::AffineQuery::residual`] compiled for AVX-512.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn affine_residual_avx512(q: &super::AffineQuery, f: &[f64], g: &[f64]) -> f64 {
        let n = q.lanes;
        assert!(f.len() >= n && g.len() >= n && n <= BLOCK_DIM, "{n} values, zero beyond the coordinates");
        let mut acc = [_mm512_setzero_pd(); 5];
        for k in (0..n).step_by(8) {
            // SAFETY: k + 8 <= n, within f, g and the query's arrays of BLOCK_DIM (asserted).
            let (fk, gk, c, w, wz) = unsafe {
                (
                    _mm512_loadu_pd(f.as_ptr().add(k)),
                    _mm512_loadu_pd(g.as_ptr().add(k)),
                    _mm512_loadu_pd(q.c.as_ptr().add(k)),
                    _mm512_loadu_pd(q.w.as_ptr().add(k)),
                    _mm512_loadu_pd(q.wz.as_ptr().add(k)),
                )
            };
            // The portable body's operations, lane by lane.
            let m = _mm512_add_pd(fk, c);
            let (wm, wg) = (_mm512_mul_pd(w, m), _mm512_mul_pd(w, gk));
            acc[0] = _mm512_add_pd(acc[0], _mm512_mul_pd(wm, m));
            acc[1] = _mm512_add_pd(acc[1], _mm512_mul_pd(wm, gk));
            acc[2] = _mm512_add_pd(acc[2], _mm512_mul_pd(wg, gk));
            acc[3] = _mm512_add_pd(acc[3], _mm512_mul_pd(wz, m));
            acc[4] = _mm512_add_pd(acc[4], _mm512_mul_pd(wz, gk));
        }
        super::affine_solve(q.zz, acc.map(|v| lanes_sum(v))).0
    }
}
