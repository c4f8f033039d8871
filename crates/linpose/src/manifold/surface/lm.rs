//! Levenberg-Marquardt in the pose on the (weighted) distance to the surface, the damped step it
//! shares with the refined method's noisy match, and the snap of its end to a reporting lattice:
//! the continuous searches on the surface (the refined method's, and the eigenspace's on a
//! manifold kept as its knots, [`crate::manifold::dense_lattice`]).

use super::Surface;
use crate::manifold::tuning::{DAMPING_DOWN, DAMPING_MIN, DAMPING_START, DAMPING_TRIES, DAMPING_UP, MAX_ITER, STEP_TOL};

impl Surface {
    /// Levenberg-Marquardt from `t` (in the domain) on sum_l wt_l (y_l - f_l(t))^2; returns the squared
    /// distance reached, with `t` moved to where it is reached. `buf` holds at least (D + 2) L
    /// values of scratch.
    pub(crate) fn refine(&self, y: &[f32], wt: &[f64], t: &mut [f64], buf: &mut [f64]) -> f64 {
        self.refine_to(y, wt, t, buf, STEP_TOL)
    }

    /// [`Surface::refine`] ending at a step below `tol` degrees.
    pub(crate) fn refine_to(&self, y: &[f32], wt: &[f64], t: &mut [f64], buf: &mut [f64], tol: f64) -> f64 {
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
                mu = DAMPING_START * (0..d).map(|a| h[a][a]).fold(0.0, f64::max).max(f64::MIN_POSITIVE);
            }
            let Some(c) = self.damped_step(Normal { h: &h, grad: &g }, &mut mu, t, cost, tol, |cand| {
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

/// The normal equations of a Gauss-Newton step in the pose, H delta = grad (the first D rows
/// and columns count).
#[derive(Clone, Copy)]
pub(crate) struct Normal<'a> {
    /// H = J^T W J.
    pub(crate) h: &'a [[f64; 8]; 8],
    /// grad = J^T W r, r the residual.
    pub(crate) grad: &'a [f64; 8],
}

impl Surface {
    /// One damped Gauss-Newton step of Levenberg-Marquardt from `t` on the normal equations
    /// `normal`: the damping `mu` grows 4x until `cost_at` a (domain-clamped) candidate is
    /// below `cost` (then `t` moves there and `mu` shrinks 3x), at most 12 tries, none moving any
    /// coordinate by less than `tol`. Returns the new cost, or None when no try lowered the cost
    /// (which ends the iteration).
    pub(crate) fn damped_step(
        &self,
        normal: Normal<'_>,
        mu: &mut f64,
        t: &mut [f64],
        cost: f64,
        tol: f64,
        mut cost_at: impl FnMut(&[f64]) -> f64,
    ) -> Option<f64> {
        let Normal { h, grad } = normal;
        let d = self.params();
        let mut cand = [0f64; 8];
        for _ in 0..DAMPING_TRIES {
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
            // all until the damping has grown 4^12-fold would take most of a search's
            // evaluations.
            let step = (0..d).map(|k| (cand[k] - t[k]).abs()).fold(0.0, f64::max);
            if step < tol {
                return None;
            }
            let c = cost_at(&cand[..d]);
            if c < cost {
                t.copy_from_slice(&cand[..d]);
                *mu = (*mu / DAMPING_DOWN).max(DAMPING_MIN);
                return Some(c);
            }
            *mu *= DAMPING_UP;
        }
        None
    }
}

impl Surface {
    /// The 2^D lattice points of `step` degrees around `t` (anchored at each axis's first knot,
    /// kept in the domain); `t` moves to the one of least `cost` (which evaluates what it needs
    /// at the pose it is given), which is returned.
    pub(crate) fn snap_by(&self, t: &mut [f64], step: f64, mut cost: impl FnMut(&[f64]) -> f64) -> f64 {
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
    /// Moves `t` to the nearest point of the lattice of `step` degrees anchored at the first
    /// knot of each axis (kept in the domain), without evaluating anything.
    pub(crate) fn round_to_lattice(&self, t: &mut [f64], step: f64) {
        for (j, v) in t.iter_mut().enumerate() {
            let lo = self.splines[j].span().0;
            *v = lo + ((*v - lo) / step).round() * step;
        }
        self.clamp(t);
    }

    /// Moves `t` to the closest to `y` (distances weighted by `wt`) of the 2^D points around it on the lattice of `step`
    /// degrees anchored at the first knot of each axis (kept in the domain); returns its squared
    /// distance. `f` holds L values of scratch.
    pub(crate) fn snap(&self, y: &[f32], wt: &[f64], t: &mut [f64], step: f64, f: &mut [f64]) -> f64 {
        self.snap_by(t, step, |cand| {
            self.eval(cand, f, None);
            y.iter().zip(&*f).zip(wt).map(|((&a, &b), &w)| w * (a as f64 - b) * (a as f64 - b)).sum()
        })
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
