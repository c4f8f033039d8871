//! The appearance manifold as a continuous surface: the tensor-product cubic spline through the
//! training views' eigenspace coordinates (the same spline the eigenspace resamples densely), kept
//! in Hermite form and evaluated with its derivatives at any pose, so a query's pose is found by
//! Levenberg-Marquardt on the distance to the surface instead of the nearest of a fixed grid of
//! resampled points.
//!
//! The surface may instead be the local cubic ([`Interpolant::Local`]): the same Hermite pieces,
//! with each knot's slope the derivative of the parabola through it and its two neighbours along
//! the axis ([`Spline::local`]). Everything below holds for either; only the slope operators
//! differ.
//!
//! On each grid cell the spline is the tensor product of the per-axis cubic Hermite pieces, fixed
//! by the values and the mixed slopes at the cell's 2^D corners: for a derivative mask d (which
//! axes are differentiated) the slopes are S_d Y, the per-axis slope operators of
//! [`Spline::slopes`] applied along the axes in d. A point's value is a sum of 4^D products of
//! per-axis Hermite weights with those corner vectors, and its derivative in t_k the same sum with
//! axis k's weights differentiated. Resampling this at the eigenspace's dense positions gives the
//! eigenspace's manifold points (tested).

use crate::methods::eigenspace::spline::{Boundary, Spline};
use crate::pose::{wrap_positive, PoseSpace};
use crate::Result;
use serde::{Deserialize, Serialize};

/// Most Levenberg-Marquardt iterations per start.
const MAX_ITER: usize = 8;
/// A step below this many degrees ends the iteration.
const STEP_TOL: f64 = 1e-2;

/// The step tolerance of the noisy match ([`Surface::refine_affine`]): its iteration converges
/// only linearly (Kaufman's Jacobian leaves out part of the gain's and offset's dependence on the
/// pose), and its pose is reported on the 0.5-degree lattice anyway. On the paper's grid at
/// +-5% it took a third fewer Jacobian evaluations than 0.01 (twin 12.4 -> 8.3 a query), the
/// unseen errors moving by -0.001 to +0.37 degrees (twin +-10% 16.52 -> 16.89; every one still
/// below the eigenspace's); 0.1 moved twin +-5% to 14.03, near the eigenspace's 14.43.
const AFFINE_STEP_TOL: f64 = 5e-2;

/// One pose parameter's curve ([`Surface::line_parts`]): knots (with the closing knot of a
/// circular axis), period, knot values and slopes (knot-major, L each), and L.
pub type LineParts<'a> = (&'a [f64], Option<f64>, &'a [f32], &'a [f32], usize);

/// A second surface evaluated with the first ([`Surface::eval_pair`]): it, its values, and its
/// Jacobian when wanted.
type Other<'a> = (&'a Surface, &'a mut [f64], Option<&'a mut [f64]>);

/// How the surface passes between its knots: both are cubic on each knot interval, in Hermite
/// form, and differ only in the slopes at the knots.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Interpolant {
    /// The C2 cubic spline ([`Spline::new`]): the eigenspace's own manifold, every knot's slope
    /// tied to every value.
    #[default]
    Spline,
    /// The local cubic ([`Spline::local`]): each slope the derivative of the parabola through
    /// the knot and its two neighbours (Catmull-Rom on uniform knots), C1. A coordinate that
    /// changes abruptly between two training views (an edge or a highlight passing) moves it
    /// only on the pieces around them, where the spline rings along the whole axis.
    Local,
}

/// The interpolants the automatic choice scores, the spline first (it wins a tie).
pub const INTERPOLANTS: &[Interpolant] = &[Interpolant::Spline, Interpolant::Local];

impl Interpolant {
    /// The curve of this interpolant through `knots` with `boundary` ([`Spline::new`] or
    /// [`Spline::local`]).
    pub fn along(self, knots: &[f64], boundary: Boundary) -> Result<Spline> {
        match self {
            Interpolant::Spline => Spline::new(knots, boundary),
            Interpolant::Local => Spline::local(knots, boundary),
        }
    }

    /// Its name: `spline` or `local`.
    pub fn name(self) -> &'static str {
        match self {
            Interpolant::Spline => "spline",
            Interpolant::Local => "local",
        }
    }
}

impl std::fmt::Display for Interpolant {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Interpolant {
    type Err = crate::Error;
    fn from_str(s: &str) -> Result<Self> {
        INTERPOLANTS.iter().copied().find(|i| i.name() == s).ok_or_else(|| crate::Error::invalid("interpolant", s, "expected 'spline' or 'local'"))
    }
}

/// The continuous manifold of one fitted model.
#[derive(Debug, Clone)]
pub struct Surface {
    splines: Vec<Spline>,
    periods: Vec<Option<f64>>,
    /// Knots per axis.
    shape: Vec<usize>,
    /// Flat-index stride of each axis (row-major, the last fastest).
    stride: Vec<usize>,
    /// Coordinates per point, L.
    dim: usize,
    /// For each derivative mask (2^D), each knot's L values: [mask][knot][L].
    coef: Vec<f32>,
}

impl Surface {
    /// The surface through `knots` (the training views' coordinates, `dim` each, row-major over
    /// the grid `axes`, last parameter fastest), by `interpolant` along each axis.
    pub fn new(space: &PoseSpace, axes: &[Vec<f64>], knots: &[f64], dim: usize, interpolant: Interpolant) -> Result<Self> {
        let d = axes.len();
        let shape: Vec<usize> = axes.iter().map(Vec::len).collect();
        let n: usize = shape.iter().product();
        debug_assert_eq!(knots.len(), n * dim);
        let mut splines = Vec::with_capacity(d);
        let periods: Vec<Option<f64>> = space.params().iter().map(|p| p.period).collect();
        for (ax, p) in axes.iter().zip(&periods) {
            let b = match p {
                Some(t) => Boundary::Periodic(*t),
                None => Boundary::NotAKnot,
            };
            splines.push(interpolant.along(ax, b)?);
        }
        let mut stride = vec![1; d];
        for j in (0..d.saturating_sub(1)).rev() {
            stride[j] = stride[j + 1] * shape[j + 1];
        }
        let mut coef = Vec::with_capacity((1 << d) * n * dim);
        for mask in 0..1usize << d {
            let mut cube = knots.to_vec();
            for j in (0..d).filter(|j| mask >> j & 1 == 1) {
                let inner = stride[j] * dim;
                let block = shape[j] * inner;
                let mut next = Vec::with_capacity(cube.len());
                for o in 0..cube.len() / block {
                    next.extend(splines[j].slopes(&cube[o * block..(o + 1) * block], inner));
                }
                cube = next;
            }
            coef.extend(cube.iter().map(|&v| v as f32));
        }
        Ok(Surface { splines, periods, shape, stride, dim, coef })
    }

    /// Number of pose parameters D.
    pub fn params(&self) -> usize {
        self.shape.len()
    }

    /// For one pose parameter: its knots (with the closing knot of a circular axis), its
    /// period, and the knot values and slopes (knot-major, L each) with L; None for D > 1.
    pub fn line_parts(&self) -> Option<LineParts<'_>> {
        if self.params() != 1 {
            return None;
        }
        let n = self.shape[0] * self.dim;
        Some((self.splines[0].knots(), self.periods[0], &self.coef[..n], &self.coef[n..2 * n], self.dim))
    }

    /// Numbers held: 2^D x N x L.
    pub fn len(&self) -> usize {
        self.coef.len()
    }

    /// Whether the surface holds nothing (never, once built).
    pub fn is_empty(&self) -> bool {
        self.coef.is_empty()
    }

    /// The surface point at `t` into `f` (L values), and when `jac` is given its derivatives
    /// (D rows of L, row-major) too. `t` must lie in the domain ([`Surface::clamp`]).
    /// With `f` shorter than L, only its first coordinates (and Jacobian rows of that length).
    pub fn eval(&self, t: &[f64], f: &mut [f64], jac: Option<&mut [f64]>) {
        #[cfg(target_arch = "x86_64")]
        if crate::kernels::Level::detect().avx512() {
            // SAFETY: the CPU supports AVX-512F (detected).
            return unsafe { simd::eval_avx512(self, t, f, jac) };
        }
        self.eval_body(t, f, jac, None)
    }

    /// [`Surface::eval`] of this surface (into `f`, `jac`) and of `other` (into `g`, `jac_g`) at
    /// the same `t`: two surfaces on the same knots (the noisy match's f and offset g), the
    /// spline weights and knot indices found once. Each surface's values have the bits of its
    /// own [`Surface::eval`].
    pub fn eval_pair(&self, other: &Surface, t: &[f64], f: &mut [f64], jac: Option<&mut [f64]>, g: &mut [f64], jac_g: Option<&mut [f64]>) {
        assert!(self.shape == other.shape && self.stride == other.stride, "surfaces on different knots");
        #[cfg(target_arch = "x86_64")]
        if crate::kernels::Level::detect().avx512() {
            // SAFETY: the CPU supports AVX-512F (detected).
            return unsafe { simd::eval_pair_avx512(self, other, t, f, jac, g, jac_g) };
        }
        self.eval_body(t, f, jac, Some((other, g, jac_g)))
    }

    /// The body of [`Surface::eval`] (and with `other`, of [`Surface::eval_pair`]): every
    /// coordinate of the value and of the Jacobian rows summed over the 4^D corner terms in the
    /// same order on every build (multiplications and additions, no fused multiply-add), so the
    /// AVX-512 build gives the same bits.
    #[inline(always)]
    fn eval_body(&self, t: &[f64], f: &mut [f64], mut jac: Option<&mut [f64]>, mut other: Option<Other<'_>>) {
        let d = self.params();
        if d == 2 && jac.is_none() && other.as_ref().is_none_or(|o| o.2.is_none()) {
            #[cfg(target_arch = "x86_64")]
            if crate::kernels::Level::detect().avx512() {
                // SAFETY: the CPU supports AVX-512F (detected).
                return unsafe { simd::values2_avx512(self, t, f, other.map(|(o, g, _)| (o, g))) };
            }
            return self.values2(t, f, other.map(|(o, g, _)| (o, g)));
        }
        let n = self.shape.iter().product::<usize>();
        debug_assert!(f.len() <= self.dim);
        let mut w = [[0f64; 4]; 8];
        let mut dw = [[0f64; 4]; 8];
        let mut idx = [[0usize; 2]; 8];
        for j in 0..d {
            let (a, b, i0, i1) = self.splines[j].weights_d(t[j]);
            (w[j], dw[j], idx[j]) = (a, b, [i0, i1]);
        }
        f.fill(0.0);
        if let Some(g) = jac.as_deref_mut() {
            g.fill(0.0);
        }
        if let Some((_, g, jg)) = other.as_mut() {
            g.fill(0.0);
            if let Some(jg) = jg.as_deref_mut() {
                jg.fill(0.0);
            }
        }
        let mut gw = [0f64; 8];
        for combo in 0..1usize << (2 * d) {
            let (mut weight, mut knot, mut mask) = (1.0, 0, 0);
            for j in 0..d {
                let a = combo >> (2 * j) & 3;
                weight *= w[j][a];
                knot += idx[j][a >> 1] * self.stride[j];
                mask |= (a & 1) << j;
            }
            if jac.is_some() || other.as_ref().is_some_and(|o| o.2.is_some()) {
                for (k, g) in gw.iter_mut().enumerate().take(d) {
                    *g = (0..d).map(|j| if j == k { dw[j][combo >> (2 * j) & 3] } else { w[j][combo >> (2 * j) & 3] }).product();
                }
            }
            let row = mask * n + knot;
            corner_term(&self.coef[row * self.dim..], d, weight, &gw, f, jac.as_deref_mut());
            if let Some((o, g, jg)) = other.as_mut() {
                corner_term(&o.coef[row * o.dim..], d, weight, &gw, g, jg.as_deref_mut());
            }
        }
    }

    /// The 16 terms of [`Surface::eval_body`] for D = 2 at `t`, in its order: each one's offset
    /// into `coef` (a multiple of L) and its weight.
    #[inline(always)]
    fn terms2(&self, t: &[f64]) -> ([usize; 16], [f64; 16]) {
        let n = self.shape[0] * self.shape[1];
        let (w0, _, a0, b0) = self.splines[0].weights_d(t[0]);
        let (w1, _, a1, b1) = self.splines[1].weights_d(t[1]);
        let (k0, k1) = ([a0 * self.stride[0], b0 * self.stride[0]], [a1 * self.stride[1], b1 * self.stride[1]]);
        let (mut at, mut wt) = ([0usize; 16], [0f64; 16]);
        for combo in 0..16 {
            let (p, q) = (combo & 3, combo >> 2);
            at[combo] = (((p & 1) | (q & 1) << 1) * n + k0[p >> 1] + k1[q >> 1]) * self.dim;
            wt[combo] = 1.0 * w0[p] * w1[q];
        }
        (at, wt)
    }

    /// The values of [`Surface::eval_body`] for D = 2 without derivatives (and of `other`'s,
    /// into its slice): the same 16 terms in the same order, the same products and sums, so the
    /// same bits, without the general loop's bookkeeping.
    #[inline(always)]
    fn values2(&self, t: &[f64], f: &mut [f64], other: Option<(&Surface, &mut [f64])>) {
        let (at, wt) = self.terms2(t);
        let sum = |acc: &mut [f64], coef: &[f32]| {
            acc.fill(0.0);
            for (&a, &w) in at.iter().zip(&wt) {
                acc.iter_mut().zip(&coef[a..]).for_each(|(v, &x)| *v += w * x as f64);
            }
        };
        sum(f, &self.coef);
        if let Some((o, g)) = other {
            sum(g, &o.coef);
        }
    }

    /// Brings `t` into the domain: a circular parameter wrapped into [first knot, first knot +
    /// period), a linear one clamped to its knots' range.
    pub fn clamp(&self, t: &mut [f64]) {
        for (j, v) in t.iter_mut().enumerate() {
            let (lo, hi) = self.splines[j].span();
            *v = match self.periods[j] {
                Some(p) => lo + wrap_positive(*v - lo, p),
                None => v.clamp(lo, hi),
            };
        }
    }

    /// The number of points along each axis of [`Surface::grid_poses`], and whether the axis is
    /// circular.
    pub fn grid_shape(&self, per_cell: usize) -> Vec<(usize, bool)> {
        let per_cell = per_cell.max(1);
        self.shape.iter().zip(&self.periods).map(|(&n, p)| if p.is_some() { (n * per_cell, true) } else { ((n - 1) * per_cell + 1, false) }).collect()
    }

    /// The poses of a regular grid over the domain with `per_cell` points per knot interval
    /// along each axis (the knots included), row-major.
    pub fn grid_poses(&self, per_cell: usize) -> Vec<f64> {
        let per_cell = per_cell.max(1);
        let axes: Vec<Vec<f64>> = self
            .splines
            .iter()
            .zip(&self.periods)
            .zip(&self.shape)
            .map(|((s, p), &n)| {
                let knots = s.knots();
                let pieces = if p.is_some() { n } else { n - 1 };
                let mut v = Vec::new();
                for i in 0..pieces {
                    for k in 0..per_cell {
                        v.push(knots[i] + (knots[i + 1] - knots[i]) * k as f64 / per_cell as f64);
                    }
                }
                if p.is_none() {
                    v.push(knots[n - 1]);
                }
                v
            })
            .collect();
        let total: usize = axes.iter().map(Vec::len).product();
        let d = axes.len();
        let mut out = Vec::with_capacity(total * d);
        for mut k in 0..total {
            let start = out.len();
            out.resize(start + d, 0.0);
            for j in (0..d).rev() {
                out[start + j] = axes[j][k % axes[j].len()];
                k /= axes[j].len();
            }
        }
        out
    }

    /// Levenberg-Marquardt from `t` (in the domain) on sum_l wt_l (y_l - f_l(t))^2; returns the squared
    /// distance reached, with `t` moved to where it is reached. `buf` holds at least (D + 2) L
    /// values of scratch.
    pub fn refine(&self, y: &[f32], wt: &[f64], t: &mut [f64], buf: &mut [f64]) -> f64 {
        let (d, l) = (self.params(), self.dim);
        let (f, rest) = buf.split_at_mut(l);
        let (jac, rest) = rest.split_at_mut(d * l);
        let ftry = &mut rest[..l];
        let dist = |f: &[f64]| y.iter().zip(f).zip(wt).map(|((&a, &b), &w)| w * (a as f64 - b) * (a as f64 - b)).sum::<f64>();
        self.eval(t, f, Some(jac));
        let mut cost = dist(f);
        let mut mu = -1.0;
        for _ in 0..MAX_ITER {
            // Normal equations H = J^T J, g = J^T (y - f).
            let mut h = [[0f64; 8]; 8];
            let mut g = [0f64; 8];
            for a in 0..d {
                let ja = &jac[a * l..(a + 1) * l];
                g[a] = ja.iter().zip(y.iter().zip(f.iter())).zip(wt).map(|((&j, (&yv, &fv)), &w)| w * j * (yv as f64 - fv)).sum();
                for b in 0..=a {
                    let v: f64 = ja.iter().zip(&jac[b * l..(b + 1) * l]).zip(wt).map(|((p, q), w)| w * p * q).sum();
                    (h[a][b], h[b][a]) = (v, v);
                }
            }
            if mu < 0.0 {
                mu = 1e-3 * (0..d).map(|a| h[a][a]).fold(0.0, f64::max).max(f64::MIN_POSITIVE);
            }
            let Some(c) = self.damped_step(&h, &g, &mut mu, t, cost, STEP_TOL, |cand| {
                self.eval(cand, ftry, None);
                dist(ftry)
            }) else {
                break;
            };
            cost = c;
            self.eval(t, f, Some(jac));
        }
        cost
    }
}

impl Surface {
    /// One damped Gauss-Newton step of Levenberg-Marquardt from `t` on the normal equations
    /// (`h`, `grad`): the damping `mu` grows 4x until `cost_at` a (domain-clamped) candidate is
    /// below `cost` (then `t` moves there and `mu` shrinks 3x), at most 12 tries, none moving any
    /// coordinate by less than `tol`. Returns the new cost, or None when no try lowered the cost
    /// (which ends the iteration).
    #[allow(clippy::too_many_arguments)]
    fn damped_step(
        &self,
        h: &[[f64; 8]; 8],
        grad: &[f64; 8],
        mu: &mut f64,
        t: &mut [f64],
        cost: f64,
        tol: f64,
        mut cost_at: impl FnMut(&[f64]) -> f64,
    ) -> Option<f64> {
        let d = self.params();
        let mut cand = [0f64; 8];
        for _ in 0..12 {
            let mut a = *h;
            for (k, row) in a.iter_mut().enumerate().take(d) {
                row[k] += *mu;
            }
            let delta = solve(&mut a, grad, d)?;
            for k in 0..d {
                cand[k] = t[k] + delta[k];
            }
            self.clamp(&mut cand[..d]);
            // A step below the tolerance ends the iteration without being tried: at the
            // minimum, every damped step fails to lower the cost (by rounding), and trying them
            // all until the damping has grown 4^12-fold was two thirds of the evaluations.
            let step = (0..d).map(|k| (cand[k] - t[k]).abs()).fold(0.0, f64::max);
            if step < tol {
                return None;
            }
            let c = cost_at(&cand[..d]);
            if c < cost {
                t.copy_from_slice(&cand[..d]);
                *mu = (*mu / 3.0).max(1e-12);
                return Some(c);
            }
            *mu *= 4.0;
        }
        None
    }
}

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
    /// to a multiple of 8 values (as [`Surface::climb_pair`] gives them), zero beyond.
    pub fn residual(&self, f: &[f64], g: &[f64]) -> f64 {
        #[cfg(target_arch = "x86_64")]
        if crate::kernels::Level::detect().avx512() {
            // SAFETY: the CPU supports AVX-512F (detected).
            return unsafe { simd::affine_residual_avx512(self, f, g) };
        }
        self.residual_body(f, g)
    }

    #[inline(always)]
    fn residual_body(&self, f: &[f64], g: &[f64]) -> f64 {
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

/// The weighted squared distance sum w (y - f)^2 over values given in multiples of 8 (zero
/// weight beyond the coordinates), summed 8 lanes at a time.
fn lane_distance(y: &[f64], w: &[f64], f: &[f64]) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if crate::kernels::Level::detect().avx512() {
        // SAFETY: the CPU supports AVX-512F (detected).
        return unsafe { simd::lane_distance_avx512(y, w, f) };
    }
    lane_distance_body(y, w, f)
}

#[inline(always)]
fn lane_distance_body(y: &[f64], w: &[f64], f: &[f64]) -> f64 {
    let n = f.len() / 8 * 8;
    let (y, w, f) = (&y[..n], &w[..n], &f[..n]);
    let mut acc = [0f64; 8];
    for k in (0..n).step_by(8) {
        for i in k..k + 8 {
            let e = y[i] - f[i];
            acc[i - k] += w[i] * e * e;
        }
    }
    acc.iter().sum()
}

/// The residual of [`affine_fit`] from its weighted sums `s` = (m.m, m.g, g.g, z.m, z.g), m = f + c,
/// and z.z.
pub fn affine_residual(zz: f64, s: [f64; 5]) -> f64 {
    affine_solve(zz, s).0
}

fn affine_solve(zz: f64, [a, b, cc, u, v]: [f64; 5]) -> (f64, [f64; 2]) {
    let det = a * cc - b * b;
    if det > 1e-9 * a * cc && det > 0.0 {
        let (al, be) = ((cc * u - b * v) / det, (a * v - b * u) / det);
        ((zz - al * u - be * v).max(0.0), [al, be])
    } else if a > 0.0 {
        ((zz - u * u / a).max(0.0), [u / a, 0.0])
    } else {
        (zz, [0.0, 0.0])
    }
}

impl Surface {
    /// Levenberg-Marquardt in the pose from `t` on the affine match of [`affine_fit`]: at each
    /// pose the gain and offset are solved exactly and the step is taken on the reduced residual
    /// (variable projection, with Kaufman's Jacobian alpha J_f + beta J_g). `bg` is the offset
    /// surface g, on the same knots. Returns the weighted squared residual reached and its
    /// (alpha, beta), with `t` moved there. `buf` holds at least (2 D + 5) L values.
    /// Only the first `z.len()` coordinates count.
    pub fn refine_affine(&self, bg: &Surface, z: &[f64], c: &[f64], wt: &[f64], t: &mut [f64], buf: &mut [f64]) -> (f64, [f64; 2]) {
        let (d, l) = (self.params(), z.len());
        let (f, rest) = buf.split_at_mut(l);
        let (g, rest) = rest.split_at_mut(l);
        let (jf, rest) = rest.split_at_mut(d * l);
        let (jg, rest) = rest.split_at_mut(d * l);
        let (ftry, rest) = rest.split_at_mut(l);
        let gtry = &mut rest[..l];
        self.eval_pair(bg, t, f, Some(jf), g, Some(jg));
        let (mut cost, mut ab) = affine_fit(z, c, wt, f, g);
        let mut mu = -1.0;
        for _ in 0..MAX_ITER {
            let mut h = [[0f64; 8]; 8];
            let mut grad = [0f64; 8];
            // The reduced residual r = z - alpha (f + c) - beta g and its Jacobian in t.
            // (In place: f becomes r and jf the Jacobian; both are evaluated afresh after a step.)
            for q in 0..l {
                f[q] = z[q] - ab[0] * (f[q] + c[q]) - ab[1] * g[q];
            }
            for q in 0..d * l {
                jf[q] = ab[0] * jf[q] + ab[1] * jg[q];
            }
            let (r, jac) = (&*f, &*jf);
            for a in 0..d {
                let ja = &jac[a * l..(a + 1) * l];
                grad[a] = ja.iter().zip(r).zip(wt).map(|((&j, &rv), &w)| w * j * rv).sum();
                for b in 0..=a {
                    let v: f64 = ja.iter().zip(&jac[b * l..(b + 1) * l]).zip(wt).map(|((p, q), w)| w * p * q).sum();
                    (h[a][b], h[b][a]) = (v, v);
                }
            }
            if mu < 0.0 {
                mu = 1e-3 * (0..d).map(|a| h[a][a]).fold(0.0, f64::max).max(f64::MIN_POSITIVE);
            }
            let mut trial = ab;
            let Some(cst) = self.damped_step(&h, &grad, &mut mu, t, cost, AFFINE_STEP_TOL, |cand| {
                self.eval_pair(bg, cand, ftry, None, gtry, None);
                let (cst, abt) = affine_fit(z, c, wt, ftry, gtry);
                trial = abt;
                cst
            }) else {
                break;
            };
            (cost, ab) = (cst, trial);
            self.eval_pair(bg, t, f, Some(jf), g, Some(jg));
        }
        (cost, ab)
    }

    /// The 2^D lattice points of `step` degrees around `t` (anchored at each axis's first knot,
    /// kept in the domain); `t` moves to the one of least `cost` (which evaluates what it needs
    /// at the pose it is given), which is returned.
    pub fn snap_by(&self, t: &mut [f64], step: f64, mut cost: impl FnMut(&[f64]) -> f64) -> f64 {
        let d = self.params();
        let mut base = [0f64; 8];
        for j in 0..d {
            let lo = self.splines[j].span().0;
            base[j] = lo + ((t[j] - lo) / step).floor() * step;
        }
        let (mut best, mut cand, mut out) = (f64::INFINITY, [0f64; 8], [0f64; 8]);
        for corner in 0..1usize << d {
            for j in 0..d {
                cand[j] = base[j] + step * (corner >> j & 1) as f64;
            }
            self.clamp(&mut cand[..d]);
            let c = cost(&cand[..d]);
            if c < best {
                (best, out) = (c, cand);
            }
        }
        t.copy_from_slice(&out[..d]);
        best
    }
}

impl Surface {
    /// Moves `t` to the closest to `y` (distances weighted by `wt`) of the 2^D points around it on the lattice of `step`
    /// degrees anchored at the first knot of each axis (kept in the domain); returns its squared
    /// distance. `f` holds L values of scratch.
    pub fn snap(&self, y: &[f32], wt: &[f64], t: &mut [f64], step: f64, f: &mut [f64]) -> f64 {
        self.snap_by(t, step, |cand| {
            self.eval(cand, f, None);
            y.iter().zip(&*f).zip(wt).map(|((&a, &b), &w)| w * (a as f64 - b) * (a as f64 - b)).sum()
        })
    }
}

impl Surface {
    /// Moves `t`, a pose on the lattice of `step` degrees anchored at the first knot of each axis,
    /// to a local least over that lattice of the distance to `y` (weighted by `wt`): to the best
    /// of its 3^D - 1 neighbours (a circular axis wraps, a linear one ends at its last lattice
    /// point) as long as one is closer; returns its squared distance. Every move lowers the
    /// distance, so no pose is visited twice and the walk ends (from the coarse tree's point it
    /// takes a step or two).
    pub fn climb(&self, y: &[f32], wt: &[f64], t: &mut [f64], step: f64) -> f64 {
        // Coordinates of zero weight add nothing.
        let lo = wt.iter().rposition(|&w| w != 0.0).map_or(0, |i| i + 1).min(y.len());
        let lanes = lo.div_ceil(8) * 8;
        // On the stack up to the block climb's width (a query's only allocation otherwise).
        let (mut stack, mut heap) = ([0f64; 2 * BLOCK_DIM], Vec::new());
        let both = if 2 * lanes <= stack.len() {
            &mut stack[..2 * lanes]
        } else {
            heap.resize(2 * lanes, 0.0);
            &mut heap[..]
        };
        let (y64, w64) = both.split_at_mut(lanes);
        y64[..lo].iter_mut().zip(y).for_each(|(o, &v)| *o = v as f64);
        w64[..lo].copy_from_slice(&wt[..lo]);
        let (y64, w64) = (&*y64, &*w64);
        self.climb_pair(None, lo, t, step, |f, _| lane_distance(y64, w64, f))
    }

    /// The lattice of `step` degrees at `t` (anchored at each axis's first knot): per axis the
    /// index of the lattice point nearest to t (wrapped on a circular axis, kept in the domain
    /// on a linear one), the count of a circular axis's points or the last index of a linear
    /// one's, and whether the axis is circular.
    fn lattice_at(&self, t: &[f64], step: f64) -> ([i64; 8], [i64; 8], [bool; 8]) {
        let (mut idx, mut count, mut circ) = ([0i64; 8], [0i64; 8], [false; 8]);
        for j in 0..self.params() {
            let (lo, hi) = self.splines[j].span();
            idx[j] = ((t[j] - lo) / step).round() as i64;
            (count[j], circ[j]) = match self.periods[j] {
                Some(p) => ((p / step).round() as i64, true),
                None => (((hi - lo) / step + 1e-9).floor() as i64, false),
            };
            idx[j] = if circ[j] { idx[j].rem_euclid(count[j].max(1)) } else { idx[j].clamp(0, count[j]) };
        }
        (idx, count, circ)
    }

    /// [`Surface::climb`] on any `cost` of the pose (which evaluates what it needs at the pose
    /// it is given): `t` moves to a local least of it over the lattice of `step` degrees, which
    /// is returned.
    pub fn climb_by(&self, t: &mut [f64], step: f64, mut cost: impl FnMut(&[f64]) -> f64) -> f64 {
        let d = self.params();
        let mut at = |idx: &[i64; 8], pose: &mut [f64; 8]| {
            for j in 0..d {
                pose[j] = self.splines[j].span().0 + idx[j] as f64 * step;
            }
            cost(&pose[..d])
        };
        let (mut idx, count, circ) = self.lattice_at(t, step);
        let mut pose = [0f64; 8];
        let mut best = at(&idx, &mut pose);
        let mut best_pose = pose;
        loop {
            let mut moved = None;
            let mut cand = [0i64; 8];
            'next: for code in 0..3usize.pow(d as u32) {
                let mut c = code;
                for j in 0..d {
                    let k = lattice_step(idx[j] + (c % 3) as i64 - 1, count[j], circ[j]);
                    c /= 3;
                    let Some(k) = k else { continue 'next };
                    cand[j] = k;
                }
                if cand[..d] == idx[..d] {
                    continue;
                }
                let v = at(&cand, &mut pose);
                if v < best {
                    (best, best_pose, moved) = (v, pose, Some(cand));
                }
            }
            match moved {
                Some(c) => idx = c,
                None => break,
            }
        }
        t.copy_from_slice(&best_pose[..d]);
        best
    }
}

/// Lattice index `k` along an axis of [`Surface::lattice_at`]'s `count` and `circ`: wrapped on
/// a circular axis, None past either end of a linear one.
fn lattice_step(k: i64, count: i64, circ: bool) -> Option<i64> {
    if circ {
        Some(k.rem_euclid(count.max(1)))
    } else {
        (0..=count).contains(&k).then_some(k)
    }
}

/// The lattice indices of a 3 x 3 block along each axis (None past a linear axis's end).
type BlockAt = [[Option<i64>; 3]; 2];

/// Most coordinates [`Surface::climb_pair`] evaluates in blocks (more go point by point).
const BLOCK_DIM: usize = 32;

impl Surface {
    /// [`Surface::climb_by`] on a cost of the surface's values (the first `lo` coordinates) and,
    /// with `other` (a surface on the same knots), of its values at the same pose:
    /// `cost(f, g)`, each given in `lo` rounded up to a multiple of 8 values, zero beyond `lo`
    /// (`g` all zero without `other`), so that the cost can sum them 8 lanes at a time. With two parameters the 3 x 3 lattice points
    /// around the walk's pose are evaluated together (`Surface::block2`): the sums along the
    /// second axis are shared by the three points along the first, about 84 vector terms for
    /// the 9 points instead of 144 (their values agree with [`Surface::eval`]'s to rounding; the
    /// sums are taken in another order). The walk is [`Surface::climb_by`]'s: the same
    /// neighbours in the same order, to the best one while it is closer. After a move the
    /// points the new block shares with the last keep their costs: 3 new points after a move
    /// along one axis, 5 after a diagonal one, instead of 9.
    pub fn climb_pair(&self, other: Option<&Surface>, lo: usize, t: &mut [f64], step: f64, mut cost: impl FnMut(&[f64], &[f64]) -> f64) -> f64 {
        let d = self.params();
        let lanes = lo.div_ceil(8) * 8;
        if d != 2 || lo > BLOCK_DIM {
            let (mut f, mut g) = (vec![0.0; lanes], vec![0.0; lanes]);
            return self.climb_by(t, step, |pose| {
                match other {
                    Some(o) => self.eval_pair(o, pose, &mut f[..lo], None, &mut g[..lo], None),
                    None => self.eval(pose, &mut f[..lo], None),
                }
                cost(&f, &g)
            });
        }
        let (idx8, count, circ) = self.lattice_at(t, step);
        let mut idx = [idx8[0], idx8[1]];
        // Lanes from lo on stay zero: block2 writes the first lo.
        let mut fv = [[0f64; BLOCK_DIM]; 9];
        let mut gv = [[0f64; BLOCK_DIM]; 9];
        let mut best = f64::NAN;
        // The last block's lattice indices and costs: after a move, the points the new block
        // shares with it keep their costs (a point's values do not depend on the others
        // evaluated with it), and only the new row and column are evaluated.
        let mut last: Option<(BlockAt, [f64; 9])> = None;
        loop {
            // The 3 lattice indices along each axis (None outside a linear axis).
            let mut at = [[None; 3]; 2];
            for j in 0..2 {
                for (s3, slot) in at[j].iter_mut().enumerate() {
                    *slot = lattice_step(idx[j] + s3 as i64 - 1, count[j], circ[j]);
                }
            }
            let pos = |j: usize, k: i64| self.splines[j].span().0 + k as f64 * step;
            let mut costs = [f64::NAN; 9];
            // Per axis, where each position stood in the last block (None: new).
            let mut was = [[None; 3]; 2];
            if let Some((old_at, old_costs)) = &last {
                for j in 0..2 {
                    for s3 in 0..3 {
                        was[j][s3] = at[j][s3].and_then(|k| old_at[j].iter().position(|&o| o == Some(k)));
                    }
                }
                for code in 0..9 {
                    if let (Some(a), Some(b)) = (was[0][code % 3], was[1][code / 3]) {
                        costs[code] = old_costs[a + 3 * b];
                    }
                }
            }
            // The points not kept, as at most two grids: the new positions along the first
            // axis at every second-axis position, then the kept ones at the new second-axis
            // positions.
            let fresh0 = std::array::from_fn::<_, 3, _>(|s3| was[0][s3].is_none());
            let fresh1 = std::array::from_fn::<_, 3, _>(|s3| was[1][s3].is_none());
            let grid = |sel0: [bool; 3], sel1: [bool; 3]| {
                (
                    std::array::from_fn::<_, 3, _>(|s3| if sel0[s3] { at[0][s3].map(|k| pos(0, k)) } else { None }),
                    std::array::from_fn::<_, 3, _>(|s3| if sel1[s3] { at[1][s3].map(|k| pos(1, k)) } else { None }),
                )
            };
            for (sel0, sel1) in [(fresh0, [true; 3]), (fresh0.map(|f| !f), fresh1)] {
                let (p0, p1) = grid(sel0, sel1);
                if p0.iter().any(Option::is_some) && p1.iter().any(Option::is_some) {
                    self.block2(other, lo, &p0, &p1, &mut fv, &mut gv);
                    for code in 0..9 {
                        if p0[code % 3].is_some() && p1[code / 3].is_some() {
                            costs[code] = cost(&fv[code][..lanes], &gv[code][..lanes]);
                        }
                    }
                }
            }
            if last.is_none() {
                best = costs[4];
            }
            // climb_by's order: the first axis fastest.
            let mut moved = None;
            for (code, &v) in costs.iter().enumerate() {
                let (a, b) = (code % 3, code / 3);
                if code == 4 || at[0][a].is_none() || at[1][b].is_none() {
                    continue;
                }
                if v < best {
                    (best, moved) = (v, Some([at[0][a].unwrap(), at[1][b].unwrap()]));
                }
            }
            match moved {
                Some(c) => idx = c,
                None => break,
            }
            last = Some((at, costs));
        }
        for j in 0..2 {
            t[j] = self.splines[j].span().0 + idx[j] as f64 * step;
        }
        best
    }

    /// For D = 2: the first `lo` values of this surface (into `fv`) and of `other` (into `gv`)
    /// at the 3 x 3 poses (p0[a], p1[b]), point a + 3 b; a None position is skipped. For each
    /// position b and each knot interval of the first axis among the p0, the 4 sums along the
    /// second axis (value and slope at the interval's two knots) are formed once; each point
    /// then sums those 4 with its first-axis weights.
    fn block2(
        &self,
        other: Option<&Surface>,
        lo: usize,
        p0: &[Option<f64>; 3],
        p1: &[Option<f64>; 3],
        fv: &mut [[f64; BLOCK_DIM]; 9],
        gv: &mut [[f64; BLOCK_DIM]; 9],
    ) {
        #[cfg(target_arch = "x86_64")]
        if crate::kernels::Level::detect().avx512() {
            // SAFETY: the CPU supports AVX-512F (detected).
            return unsafe { simd::block2_avx512(self, other, lo, p0, p1, fv, gv) };
        }
        self.block2_body(other, lo, p0, p1, fv, gv)
    }

    #[inline(always)]
    fn block2_body(
        &self,
        other: Option<&Surface>,
        lo: usize,
        p0: &[Option<f64>; 3],
        p1: &[Option<f64>; 3],
        fv: &mut [[f64; BLOCK_DIM]; 9],
        gv: &mut [[f64; BLOCK_DIM]; 9],
    ) {
        let n = self.shape[0] * self.shape[1];
        let w0: [Option<([f64; 4], usize, usize)>; 3] = p0.map(|p| {
            p.map(|t| {
                let (w, _, i, j) = self.splines[0].weights_d(t);
                (w, i, j)
            })
        });
        let w1: [Option<([f64; 4], usize, usize)>; 3] = p1.map(|p| {
            p.map(|t| {
                let (w, _, i, j) = self.splines[1].weights_d(t);
                (w, i, j)
            })
        });
        // h[p][..lo]: sum over q of w1[q] coef[row(p, q)], for one interval and one b.
        let mut h = [[0f64; BLOCK_DIM]; 4];
        let mut hg = [[0f64; BLOCK_DIM]; 4];
        for (b, w1b) in w1.iter().enumerate() {
            let Some((wq, i1, j1)) = *w1b else { continue };
            let k1 = [i1 * self.stride[1], j1 * self.stride[1]];
            let mut done = [false; 3];
            for a in 0..3 {
                let Some((_, i0, j0)) = w0[a] else { continue };
                if done[a] {
                    continue;
                }
                let k0 = [i0 * self.stride[0], j0 * self.stride[0]];
                for p in 0..4 {
                    let sum = |acc: &mut [f64; BLOCK_DIM], coef: &[f32], dim: usize| {
                        let acc = &mut acc[..lo];
                        acc.fill(0.0);
                        for q in 0..4 {
                            let row = (((p & 1) | (q & 1) << 1) * n + k0[p >> 1] + k1[q >> 1]) * dim;
                            let w = wq[q];
                            acc.iter_mut().zip(&coef[row..row + lo]).for_each(|(v, &x)| *v += w * x as f64);
                        }
                    };
                    sum(&mut h[p], &self.coef, self.dim);
                    if let Some(o) = other {
                        sum(&mut hg[p], &o.coef, o.dim);
                    }
                }
                // Every first-axis position in this interval takes its point from these sums.
                for a2 in a..3 {
                    let Some((wp, i2, _)) = w0[a2] else { continue };
                    if i2 != i0 {
                        continue;
                    }
                    done[a2] = true;
                    let point = |out: &mut [f64; BLOCK_DIM], h: &[[f64; BLOCK_DIM]; 4]| {
                        let out = &mut out[..lo];
                        out.fill(0.0);
                        for (p, hp) in h.iter().enumerate() {
                            let w = wp[p];
                            out.iter_mut().zip(&hp[..lo]).for_each(|(v, &x)| *v += w * x);
                        }
                    };
                    point(&mut fv[a2 + 3 * b], &h);
                    if other.is_some() {
                        point(&mut gv[a2 + 3 * b], &hg);
                    }
                }
            }
        }
    }
}

/// One corner's term of [`Surface::eval`]: its values `c` (at least `f.len()`) times `weight`
/// into `f`, and times each `gw[k]` into the Jacobian rows when asked for; one pass over `c`
/// (D = 1 and 2 spelled out so the loop vectorises).
#[inline(always)]
fn corner_term(c: &[f32], d: usize, weight: f64, gw: &[f64; 8], f: &mut [f64], jac: Option<&mut [f64]>) {
    let lo = f.len();
    let c = &c[..lo];
    let Some(g) = jac else {
        f.iter_mut().zip(c).for_each(|(v, &x)| *v += weight * x as f64);
        return;
    };
    match d {
        1 => f.iter_mut().zip(&mut g[..lo]).zip(c).for_each(|((v, a), &x)| {
            let x = x as f64;
            *v += weight * x;
            *a += gw[0] * x;
        }),
        2 => {
            let (g0, g1) = g.split_at_mut(lo);
            f.iter_mut().zip(g0).zip(&mut g1[..lo]).zip(c).for_each(|(((v, a), b), &x)| {
                let x = x as f64;
                *v += weight * x;
                *a += gw[0] * x;
                *b += gw[1] * x;
            })
        }
        _ => {
            f.iter_mut().zip(c).for_each(|(v, &x)| *v += weight * x as f64);
            for k in 0..d {
                g[k * lo..(k + 1) * lo].iter_mut().zip(c).for_each(|(v, &x)| *v += gw[k] * x as f64);
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod simd {
    use super::{Surface, BLOCK_DIM};
    use std::arch::x86_64::*;

    /// [`super::lane_distance`] compiled for AVX-512.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn lane_distance_avx512(y: &[f64], w: &[f64], f: &[f64]) -> f64 {
        let n = f.len() / 8 * 8;
        assert!(y.len() >= n && w.len() >= n);
        let mut acc = _mm512_setzero_pd();
        for k in (0..n).step_by(8) {
            // SAFETY: k + 8 <= n, within the three slices (asserted).
            let (yk, wk, fk) = unsafe { (_mm512_loadu_pd(y.as_ptr().add(k)), _mm512_loadu_pd(w.as_ptr().add(k)), _mm512_loadu_pd(f.as_ptr().add(k))) };
            let e = _mm512_sub_pd(yk, fk);
            acc = _mm512_add_pd(acc, _mm512_mul_pd(_mm512_mul_pd(wk, e), e));
        }
        lanes_sum(acc)
    }

    /// The 8 lanes summed in order, as the portable code sums its lane array.
    #[target_feature(enable = "avx512f")]
    fn lanes_sum(v: __m512d) -> f64 {
        let mut a = [0f64; 8];
        // SAFETY: 8 values into an array of 8.
        unsafe { _mm512_storeu_pd(a.as_mut_ptr(), v) };
        a.iter().sum()
    }

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

    /// [`Surface::block2`] with each run of 8 coordinates of the 4 sums along the second axis
    /// held in registers and each point summed from them.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn block2_avx512(
        s: &Surface,
        other: Option<&Surface>,
        lo: usize,
        p0: &[Option<f64>; 3],
        p1: &[Option<f64>; 3],
        fv: &mut [[f64; BLOCK_DIM]; 9],
        gv: &mut [[f64; BLOCK_DIM]; 9],
    ) {
        let n = s.shape[0] * s.shape[1];
        assert!(lo <= BLOCK_DIM && lo <= s.dim && other.is_none_or(|o| lo <= o.dim && o.coef.len() == s.coef.len() * o.dim / s.dim));
        let w0 = p0.map(|p| p.map(|t| s.splines[0].weights_d(t)));
        let w1 = p1.map(|p| p.map(|t| s.splines[1].weights_d(t)));
        // The points in groups of one knot cell (usually all 9): the 16 coefficient rows of the
        // cell are read once for every point of the group.
        let mut done = [[false; 3]; 3];
        for b in 0..3 {
            for a in 0..3 {
                let (Some((_, _, i0, j0)), Some((_, _, i1, j1))) = (w0[a], w1[b]) else { continue };
                if done[b][a] {
                    continue;
                }
                // The cell's positions along each axis.
                let (mut as_, mut bs) = ([(0usize, [0f64; 4]); 3], [(0usize, [0f64; 4]); 3]);
                let (mut na, mut nb) = (0, 0);
                for (a2, w) in w0.iter().enumerate() {
                    if let Some((wp, _, i2, _)) = *w {
                        if i2 == i0 {
                            as_[na] = (a2, wp);
                            na += 1;
                        }
                    }
                }
                for (b2, w) in w1.iter().enumerate() {
                    if let Some((wq, _, i2, _)) = *w {
                        if i2 == i1 {
                            bs[nb] = (b2, wq);
                            nb += 1;
                        }
                    }
                }
                for &(b2, _) in &bs[..nb] {
                    for &(a2, _) in &as_[..na] {
                        done[b2][a2] = true;
                    }
                }
                let (k0, k1) = ([i0 * s.stride[0], j0 * s.stride[0]], [i1 * s.stride[1], j1 * s.stride[1]]);
                let mut rows = [0usize; 16];
                for (pq, r) in rows.iter_mut().enumerate() {
                    let (p, q) = (pq >> 2, pq & 3);
                    *r = ((p & 1) | (q & 1) << 1) * n + k0[p >> 1] + k1[q >> 1];
                }
                let one = |coef: &[f32], dim: usize, out: &mut [[f64; BLOCK_DIM]; 9]| {
                    assert!(rows.iter().all(|&r| (r + 1) * dim <= coef.len()));
                    let mut c = 0;
                    while c < lo {
                        let m8 = if lo - c >= 8 { 0xffu8 } else { (1u8 << (lo - c)) - 1 };
                        let mut x = [_mm512_setzero_pd(); 16];
                        for (xv, &r) in x.iter_mut().zip(&rows) {
                            // SAFETY: lanes c .. min(c + 8, lo) of row r lie within `coef`
                            // (asserted: lo <= dim); the masked load reads no others.
                            *xv = _mm512_cvtps_pd(_mm512_castps512_ps256(unsafe { _mm512_maskz_loadu_ps(m8 as u16, coef.as_ptr().add(r * dim + c)) }));
                        }
                        for &(b2, wq) in &bs[..nb] {
                            // The sums along the second axis, q in order.
                            let mut h = [_mm512_setzero_pd(); 4];
                            for (pq, xv) in x.iter().enumerate() {
                                let hp = &mut h[pq >> 2];
                                *hp = _mm512_add_pd(*hp, _mm512_mul_pd(_mm512_set1_pd(wq[pq & 3]), *xv));
                            }
                            for &(a2, wp) in &as_[..na] {
                                let mut v = _mm512_mul_pd(_mm512_set1_pd(wp[0]), h[0]);
                                for p in 1..4 {
                                    v = _mm512_add_pd(v, _mm512_mul_pd(_mm512_set1_pd(wp[p]), h[p]));
                                }
                                // SAFETY: lanes c .. min(c + 8, lo) of a row of BLOCK_DIM >= lo.
                                unsafe { _mm512_mask_storeu_pd(out[a2 + 3 * b2].as_mut_ptr().add(c), m8, v) };
                            }
                        }
                        c += 8;
                    }
                };
                one(&s.coef, s.dim, fv);
                if let Some(o) = other {
                    one(&o.coef, o.dim, gv);
                }
            }
        }
    }

    /// [`Surface::values2`] with each run of 8 coordinates summed over the 16 terms in one
    /// register: the same products and sums in the same order (no fused multiply-add), so the
    /// same bits.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn values2_avx512(s: &Surface, t: &[f64], f: &mut [f64], other: Option<(&Surface, &mut [f64])>) {
        let (at, wt) = s.terms2(t);
        let sum = |acc: &mut [f64], coef: &[f32], dim: usize| {
            let lo = acc.len();
            assert!(lo <= dim && at.iter().all(|&a| a + dim <= coef.len()));
            let mut q = 0;
            while q < lo {
                let m8 = if lo - q >= 8 { 0xff } else { (1u8 << (lo - q)) - 1 };
                let mut v = _mm512_setzero_pd();
                for (&a, &w) in at.iter().zip(&wt) {
                    // SAFETY: lanes q .. min(q + 8, lo) of the term's row lie within `coef`
                    // (asserted); the masked load reads no others.
                    let x = _mm512_castps512_ps256(unsafe { _mm512_maskz_loadu_ps(m8 as u16, coef.as_ptr().add(a + q)) });
                    v = _mm512_add_pd(v, _mm512_mul_pd(_mm512_set1_pd(w), _mm512_cvtps_pd(x)));
                }
                // SAFETY: lanes q .. min(q + 8, lo) of `acc`.
                unsafe { _mm512_mask_storeu_pd(acc.as_mut_ptr().add(q), m8, v) };
                q += 8;
            }
        };
        sum(f, &s.coef, s.dim);
        if let Some((o, g)) = other {
            sum(g, &o.coef, o.dim);
        }
    }

    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn eval_pair_avx512(s: &Surface, o: &Surface, t: &[f64], f: &mut [f64], jac: Option<&mut [f64]>, g: &mut [f64], jac_g: Option<&mut [f64]>) {
        s.eval_body(t, f, jac, Some((o, g, jac_g)))
    }

    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn eval_avx512(s: &Surface, t: &[f64], f: &mut [f64], jac: Option<&mut [f64]>) {
        s.eval_body(t, f, jac, None)
    }
}

/// Solves the small symmetric positive system `a x = b` (D <= 8) by Gaussian elimination; None
/// when it is singular.
#[allow(clippy::needless_range_loop)] // elimination reads one row of `a` while it updates another
fn solve(a: &mut [[f64; 8]; 8], b: &[f64; 8], d: usize) -> Option<[f64; 8]> {
    let mut x = *b;
    for c in 0..d {
        let p = (c..d).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))?;
        if !(a[p][c].abs() > 0.0) {
            return None;
        }
        a.swap(c, p);
        x.swap(c, p);
        for r in c + 1..d {
            let k = a[r][c] / a[c][c];
            for q in c..d {
                a[r][q] -= k * a[c][q];
            }
            x[r] -= k * x[c];
        }
    }
    for c in (0..d).rev() {
        let s: f64 = (c + 1..d).map(|q| a[c][q] * x[q]).sum();
        x[c] = (x[c] - s) / a[c][c];
    }
    x[..d].iter().all(|v| v.is_finite()).then_some(x)
}

#[cfg(test)]
mod tests {
    //! The SIMD kernels of this module against their portable bodies, bit for bit (the portable
    //! bodies are what a machine without AVX-512 runs).
    use super::*;
    use crate::Param;

    /// A surface and an offset surface of `dim` coordinates on a 6 x 37 grid (elevation 30 to
    /// 70, azimuth around), from a fixed pseudo-random sequence.
    fn pair(dim: usize) -> (Surface, Surface) {
        let space = PoseSpace::new(vec![Param::linear("e"), Param::circular("a", 360.0)]).unwrap();
        let axes = vec![(0..6).map(|k| 30.0 + 8.0 * k as f64).collect::<Vec<_>>(), (0..37).map(|k| 9.5 * k as f64).collect::<Vec<_>>()];
        let n = 6 * 37 * dim;
        let f: Vec<f64> = (0..n).map(|i| ((i * 7919) % 1013) as f64 / 500.0 - 1.0).collect();
        let g: Vec<f64> = (0..n).map(|i| ((i * 104729) % 997) as f64 / 3000.0).collect();
        (Surface::new(&space, &axes, &f, dim, Interpolant::Spline).unwrap(), Surface::new(&space, &axes, &g, dim, Interpolant::Spline).unwrap())
    }

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    #[test]
    fn the_block_and_the_costs_give_their_portable_bits() {
        for dim in [1, 5, 12, 20, 32] {
            let (s, o) = pair(dim);
            let lanes = dim.div_ceil(8) * 8;
            let z: Vec<f64> = (0..dim).map(|i| 0.3 - 0.05 * i as f64).collect();
            let c: Vec<f64> = (0..dim).map(|i| 0.01 * i as f64).collect();
            let w: Vec<f64> = (0..dim).map(|i| 1.0 / (1.0 + i as f64)).collect();
            let q = AffineQuery::new(&z, &c, &w);
            let (mut y, mut wl) = (vec![0.0; lanes], vec![0.0; lanes]);
            y[..dim].copy_from_slice(&z);
            wl[..dim].copy_from_slice(&w);
            // Blocks inside one knot cell, across cells, at the ends of the linear axis and
            // across the circular one's wrap.
            for (e, a) in [(33.0, 17.0), (38.0, 9.5), (30.0, 0.0), (70.0, 359.5), (54.0, 180.0)] {
                let p0 = [-0.5, 0.0, 0.5].map(|d: f64| Some(e + d).filter(|v| (30.0..=70.0).contains(v)));
                let p1 = [-0.5, 0.0, 0.5].map(|d: f64| Some(wrap_positive(a + d, 360.0)));
                for other in [None, Some(&o)] {
                    let (mut fa, mut ga) = ([[0f64; BLOCK_DIM]; 9], [[0f64; BLOCK_DIM]; 9]);
                    let (mut fb, mut gb) = ([[0f64; BLOCK_DIM]; 9], [[0f64; BLOCK_DIM]; 9]);
                    s.block2(other, dim, &p0, &p1, &mut fa, &mut ga);
                    s.block2_body(other, dim, &p0, &p1, &mut fb, &mut gb);
                    for k in 0..9 {
                        assert_eq!((bits(&fa[k]), bits(&ga[k])), (bits(&fb[k]), bits(&gb[k])), "dim {dim}, ({e}, {a}), point {k}");
                        let (f, g) = (&fa[k][..lanes], &ga[k][..lanes]);
                        assert_eq!(q.residual(f, g).to_bits(), q.residual_body(f, g).to_bits(), "dim {dim}, point {k}");
                        assert_eq!(lane_distance(&y, &wl, f).to_bits(), lane_distance_body(&y, &wl, f).to_bits(), "dim {dim}, point {k}");
                        // The block's points are the surface's to rounding.
                        if let (Some(t0), Some(t1)) = (p0[k % 3], p1[k / 3]) {
                            let mut v = vec![0.0; dim];
                            s.eval(&[t0, t1], &mut v, None);
                            for (x, want) in fa[k][..dim].iter().zip(&v) {
                                assert!((x - want).abs() <= 1e-12 * (1.0 + want.abs()), "dim {dim}, point {k}: {x} against {want}");
                            }
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn two_parameter_values_give_the_general_paths_bits() {
        for dim in [3, 12, 20] {
            let (s, o) = pair(dim);
            for t in [[33.3, 17.2], [70.0, 359.9], [30.0, 0.0], [51.7, 200.05]] {
                let (mut f, mut g, mut jf, mut jg) = (vec![0.0; dim], vec![0.0; dim], vec![0.0; 2 * dim], vec![0.0; 2 * dim]);
                // The general path (with derivatives) against values2, portable and dispatched.
                s.eval_body(&t, &mut f, Some(&mut jf), Some((&o, &mut g, Some(&mut jg))));
                let (mut f2, mut g2) = (vec![0.0; dim], vec![0.0; dim]);
                s.values2(&t, &mut f2, Some((&o, &mut g2)));
                assert_eq!((bits(&f), bits(&g)), (bits(&f2), bits(&g2)), "portable, {t:?}");
                s.eval_pair(&o, &t, &mut f2, None, &mut g2, None);
                assert_eq!((bits(&f), bits(&g)), (bits(&f2), bits(&g2)), "dispatched, {t:?}");
            }
        }
    }
}
