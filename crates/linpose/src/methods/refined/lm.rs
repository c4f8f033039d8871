//! Levenberg-Marquardt on the noisy match's affine fit: the refined method's search of a noisy
//! query on the shared surface (the clean search's, and the snap to the lattice, are the
//! surface's own: `crate::manifold::surface::lm`).

use crate::manifold::surface::lm::Normal;
use crate::manifold::surface::Surface;
use crate::manifold::tuning::{DAMPING_START, MAX_ITER};

use super::noisy::affine_fit;
use super::tuning::AFFINE_STEP_TOL;

impl Surface {
    /// Levenberg-Marquardt in the pose from `t` on the affine match of [`affine_fit`]: at each
    /// pose the gain and offset are solved exactly and the step is taken on the reduced residual
    /// (variable projection, with Kaufman's Jacobian alpha J_f + beta J_g). `bg` is the offset
    /// surface g, on the same knots. Returns the weighted squared residual reached and its
    /// (alpha, beta), with `t` moved there. `buf` holds at least (2 D + 5) L values.
    /// Only the first `z.len()` coordinates count.
    pub(crate) fn refine_affine(&self, bg: &Surface, z: &[f64], c: &[f64], wt: &[f64], t: &mut [f64], buf: &mut [f64]) -> (f64, [f64; 2]) {
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
                mu = DAMPING_START * (0..d).map(|a| h[a][a]).fold(0.0, f64::max).max(f64::MIN_POSITIVE);
            }
            let mut trial = ab;
            let Some(cst) = self.damped_step(Normal { h: &h, grad: &grad }, &mut mu, t, cost, AFFINE_STEP_TOL, |cand| {
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
}
