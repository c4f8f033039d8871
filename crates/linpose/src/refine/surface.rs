//! The appearance manifold as a continuous surface: the tensor-product cubic spline through the
//! training views' eigenspace coordinates (the same spline the eigenspace resamples densely), kept
//! in Hermite form and evaluated with its derivatives at any pose, so a query's pose is found by
//! Levenberg-Marquardt on the distance to the surface instead of the nearest of a fixed grid of
//! resampled points.
//!
//! On each grid cell the spline is the tensor product of the per-axis cubic Hermite pieces, fixed
//! by the values and the mixed slopes at the cell's 2^D corners: for a derivative mask d (which
//! axes are differentiated) the slopes are S_d Y, the per-axis slope operators of
//! [`Spline::slopes`] applied along the axes in d. A point's value is a sum of 4^D products of
//! per-axis Hermite weights with those corner vectors, and its derivative in t_k the same sum with
//! axis k's weights differentiated. Resampling this at the eigenspace's dense positions gives the
//! eigenspace's manifold points (tested).

use crate::eigenspace::spline::{Boundary, Spline};
use crate::pose::{wrap_positive, PoseSpace};
use crate::Result;

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
    /// the grid `axes`, last parameter fastest).
    pub fn new(space: &PoseSpace, axes: &[Vec<f64>], knots: &[f64], dim: usize) -> Result<Self> {
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
            splines.push(Spline::new(ax, b)?);
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
        if crate::kernels::Level::detect() == crate::kernels::Level::Avx512 {
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
        if crate::kernels::Level::detect() == crate::kernels::Level::Avx512 {
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
    fn damped_step(&self, h: &[[f64; 8]; 8], grad: &[f64; 8], mu: &mut f64, t: &mut [f64], cost: f64, tol: f64, mut cost_at: impl FnMut(&[f64]) -> f64) -> Option<f64> {
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
    /// takes a step or two). `f` holds L values of scratch.
    pub fn climb(&self, y: &[f32], wt: &[f64], t: &mut [f64], step: f64, f: &mut [f64]) -> f64 {
        let d = self.params();
        let mut cost = |idx: &[i64; 8], pose: &mut [f64; 8]| {
            for j in 0..d {
                pose[j] = self.splines[j].span().0 + idx[j] as f64 * step;
            }
            self.eval(&pose[..d], f, None);
            y.iter().zip(&*f).zip(wt).map(|((&a, &b), &w)| w * (a as f64 - b) * (a as f64 - b)).sum::<f64>()
        };
        // Lattice indices and, per axis, the count of a circular one or the last of a linear one.
        let (mut idx, mut count, mut circ) = ([0i64; 8], [0i64; 8], [false; 8]);
        for j in 0..d {
            let (lo, hi) = self.splines[j].span();
            idx[j] = ((t[j] - lo) / step).round() as i64;
            (count[j], circ[j]) = match self.periods[j] {
                Some(p) => ((p / step).round() as i64, true),
                None => (((hi - lo) / step + 1e-9).floor() as i64, false),
            };
            idx[j] = if circ[j] { idx[j].rem_euclid(count[j].max(1)) } else { idx[j].clamp(0, count[j]) };
        }
        let mut pose = [0f64; 8];
        let mut best = cost(&idx, &mut pose);
        let mut best_pose = pose;
        loop {
            let mut moved = None;
            let mut cand = [0i64; 8];
            'next: for code in 0..3usize.pow(d as u32) {
                let mut c = code;
                for j in 0..d {
                    let k = idx[j] + (c % 3) as i64 - 1;
                    c /= 3;
                    cand[j] = if circ[j] {
                        k.rem_euclid(count[j].max(1))
                    } else if (0..=count[j]).contains(&k) {
                        k
                    } else {
                        continue 'next;
                    };
                }
                if cand[..d] == idx[..d] {
                    continue;
                }
                let v = cost(&cand, &mut pose);
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
    use super::Surface;

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
