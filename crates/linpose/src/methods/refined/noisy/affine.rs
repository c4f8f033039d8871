//! The affine fit of the noisy match: a query's coordinates against a surface point under a free
//! gain and a free offset along a second surface, solved in closed form.

use crate::kernels::affine::AffineLanes;
use crate::kernels::Level;
use crate::manifold::surface::BLOCK_DIM;
use crate::methods::refined::tuning::DEGENERATE;

/// Where a query's coordinates `z` meet the surface `alpha (f(t) + c) + beta g(t)` with the gain
/// alpha and the offset beta fitted (weighted least squares, `wt`) for each pose: the affine
/// match of a noisy query ([`super::RefinedModel`]'s noise path). `f` and `g` are the two
/// surfaces' values at t; returns the weighted squared residual and (alpha, beta).
pub(crate) fn affine_fit(z: &[f64], c: &[f64], wt: &[f64], f: &[f64], g: &[f64]) -> (f64, [f64; 2]) {
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
pub(crate) struct AffineQuery {
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
    pub(crate) fn new(z: &[f64], c: &[f64], wt: &[f64]) -> AffineQuery {
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
    pub(crate) fn residual(&self, f: &[f64], g: &[f64]) -> f64 {
        let lanes = AffineLanes { n: self.lanes, wz: &self.wz, c: &self.c, w: &self.w };
        match crate::kernels::affine::sums(Level::detect(), lanes, f, g) {
            Some(sums) => affine_solve(self.zz, sums).0,
            None => self.residual_body(f, g),
        }
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
