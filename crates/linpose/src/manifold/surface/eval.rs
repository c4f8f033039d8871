//! Evaluating the surface (and a second one on the same knots) with its derivatives at a pose.

use super::Surface;
use crate::kernels::{dispatch, surface as kernel, Level};

/// A second surface evaluated with the first ([`Surface::eval_pair`]): it, its values, and its
/// Jacobian when wanted.
type Other<'a> = (&'a Surface, &'a mut [f64], Option<&'a mut [f64]>);

#[inline(always)]
fn eval_any(s: &Surface, t: &[f64], f: &mut [f64], jac: Option<&mut [f64]>, other: Option<Other<'_>>) {
    s.eval_body(t, f, jac, other)
}

dispatch! {
    /// [`Surface::eval_body`] built for the CPU's level: on an AVX2 machine the baseline build
    /// had been a third of the rendered duck's eigenspace query (the second look's climbs).
    fn eval_built(s: &Surface, t: &[f64], f: &mut [f64], jac: Option<&mut [f64]>, other: Option<Other<'_>>) = eval_any;
}

impl Surface {
    /// The surface point at `t` into `f` (L values), and when `jac` is given its derivatives
    /// (D rows of L, row-major) too. `t` must lie in the domain ([`Surface::clamp`]).
    /// With `f` shorter than L, only its first coordinates (and Jacobian rows of that length).
    pub(crate) fn eval(&self, t: &[f64], f: &mut [f64], jac: Option<&mut [f64]>) {
        eval_built(Level::detect(), self, t, f, jac, None)
    }

    /// [`Surface::eval`] of this surface (into `f`, `jac`) and of `other` (into `g`, `jac_g`) at
    /// the same `t`: two surfaces on the same knots (the noisy match's f and offset g), the
    /// spline weights and knot indices found once. Each surface's values have the bits of its
    /// own [`Surface::eval`].
    pub(crate) fn eval_pair(&self, other: &Surface, t: &[f64], f: &mut [f64], jac: Option<&mut [f64]>, g: &mut [f64], jac_g: Option<&mut [f64]>) {
        assert!(self.shape == other.shape && self.stride == other.stride, "surfaces on different knots");
        eval_built(Level::detect(), self, t, f, jac, Some((other, g, jac_g)))
    }

    /// The body of [`Surface::eval`] (and with `other`, of [`Surface::eval_pair`]): every
    /// coordinate of the value and of the Jacobian rows summed over the 4^D corner terms in the
    /// same order on every build (multiplications and additions, no fused multiply-add), so the
    /// AVX-512 and AVX2 builds of [`eval_built`] give the same bits.
    #[inline(always)]
    pub(crate) fn eval_body(&self, t: &[f64], f: &mut [f64], mut jac: Option<&mut [f64]>, mut other: Option<Other<'_>>) {
        let d = self.params();
        if d == 2 && jac.is_none() && other.as_ref().is_none_or(|o| o.2.is_none()) {
            return kernel::values2(Level::detect(), &self.terms2(t), self.coefs(), f, other.map(|(o, g, _)| (o.coefs(), g)));
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
    pub(crate) fn terms2(&self, t: &[f64]) -> kernel::Terms2 {
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
    #[cfg(test)]
    pub(crate) fn values2(&self, t: &[f64], f: &mut [f64], other: Option<(&Surface, &mut [f64])>) {
        kernel::values2_portable(&self.terms2(t), self.coefs(), f, other.map(|(o, g)| (o.coefs(), g)))
    }
}

/// One corner's term of [`Surface::eval`]: its values `c` (at least `f.len()`) times `weight`
/// into `f`, and times each `gw[k]` into the Jacobian rows when asked for; one pass over `c`
/// (D = 1 to 3 spelled out so the loop vectorises).
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
        3 => {
            // One pass for the value and the three rows (each sum in the general loop's order).
            let (g0, rest) = g.split_at_mut(lo);
            let (g1, g2) = rest.split_at_mut(lo);
            f.iter_mut().zip(g0).zip(g1).zip(&mut g2[..lo]).zip(c).for_each(|((((v, a), b), e), &x)| {
                let x = x as f64;
                *v += weight * x;
                *a += gw[0] * x;
                *b += gw[1] * x;
                *e += gw[2] * x;
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
