//! Cubic interpolating splines along one pose axis, with general (non-uniform) knots: periodic for
//! a circular axis (a closed curve), not-a-knot at the ends of a linear axis. These are the
//! boundary conditions of SciPy's `CubicSpline` (`bc_type="periodic"` and the default),
//! including SciPy's special cases for two and three knots, so both resample the same manifold.
//!
//! The spline is C2 and is written in Hermite form: on [x_i, x_{i+1}] it is fixed by the values
//! y_i, y_{i+1} and the slopes s_i, s_{i+1}. The slopes are a linear function of the values,
//! s = S y, found once per axis by solving the continuity equations (SciPy's formulation)
//!
//!   dx_i s_{i-1} + 2 (dx_{i-1} + dx_i) s_i + dx_{i-1} s_{i+1} = 3 (dx_i m_{i-1} + dx_{i-1} m_i)
//!
//! (dx_i = x_{i+1} - x_i, m_i the secant slope), closed by the boundary conditions. Many curves
//! (every manifold coordinate, every point of the other axes) then share S.

use super::tuning::MAX_SPLINE_KNOTS;
use crate::{Error, Result};
use faer::linalg::matmul::matmul;
use faer::linalg::solvers::Solve;
use faer::{Accum, Mat, MatRef};

/// The end conditions of a spline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Boundary {
    /// Not-a-knot at both ends (the third derivative is continuous at the second and the
    /// second-to-last knots): SciPy's default. Two knots give a line, three a parabola.
    NotAKnot,
    /// A closed curve of the given period: the knot x_0 + period carries the value of x_0, and
    /// the first and second derivatives agree there.
    Periodic(f64),
}

/// Refuses more knots along one axis (`what`, for the message) than [`MAX_SPLINE_KNOTS`]: the
/// slope operator is a dense n x n matrix, solved from an n x n system (24 n^2 bytes, n^3
/// operations), which past that many knots the machine cannot hold (100,000 knots: 224 GiB).
pub(crate) fn check_knots(what: &'static str, n: usize) -> Result<()> {
    if n <= MAX_SPLINE_KNOTS {
        return Ok(());
    }
    Err(Error::invalid(
        what,
        format!("{n} values"),
        format!(
            "a spline through them holds a dense {n} x {n} slope operator and its system ({}): at most {MAX_SPLINE_KNOTS} values along one pose parameter (train on fewer, e.g. --train-step or --train-list)",
            crate::error::format_bytes(24 * (n as u64) * (n as u64))
        ),
    ))
}

/// A cubic spline's knots and its slope operator, reusable for any number of curves.
#[derive(Debug, Clone)]
pub(crate) struct Spline {
    /// Knots, strictly increasing; for a periodic spline the closing knot x_0 + period is last.
    x: Vec<f64>,
    /// Number of distinct values a curve has (the knots, less the closing one when periodic).
    n: usize,
    /// S: slopes at the n distinct knots from the n values (n x n).
    slope_op: Mat<f64>,
}

impl Spline {
    /// A spline through `knots` (strictly increasing, finite) with `boundary`. For a periodic
    /// spline give only the distinct knots, all within one period: the closing knot is added.
    pub(crate) fn new(knots: &[f64], boundary: Boundary) -> Result<Self> {
        Self::build(knots, boundary, false)
    }

    /// The local cubic through `knots`: each knot's slope is the derivative of the parabola
    /// through it and its two neighbours (Bessel's slope; on uniform knots the central difference,
    /// Catmull-Rom's), the ends of a linear axis the derivative of the parabola through the first
    /// or last three knots. The curve is C1, reproduces quadratics, and a value moves it only on
    /// the four pieces around its knot, where the C2 spline of [`Spline::new`] couples every knot.
    pub(crate) fn local(knots: &[f64], boundary: Boundary) -> Result<Self> {
        Self::build(knots, boundary, true)
    }

    fn build(knots: &[f64], boundary: Boundary, local: bool) -> Result<Self> {
        if knots.is_empty() {
            return Err(Error::invalid("spline knots", "[]", "at least one knot is needed"));
        }
        check_knots("spline knots", knots.len())?;
        if let Some(w) = knots.windows(2).find(|w| !w[0].is_finite() || !w[1].is_finite() || w[1] <= w[0]) {
            return Err(Error::invalid("spline knots", format!("{} then {}", w[0], w[1]), "knots must be finite and strictly increasing"));
        }
        let n = knots.len();
        let mut x = knots.to_vec();
        let slope_op = match boundary {
            Boundary::NotAKnot if local => local_slopes(&x, false),
            Boundary::NotAKnot => not_a_knot_slopes(&x),
            Boundary::Periodic(period) => {
                let close = knots[0] + period;
                if !(period.is_finite() && close > knots[n - 1]) {
                    return Err(Error::invalid(
                        "spline knots",
                        format!("{} .. {}", knots[0], knots[n - 1]),
                        format!("a periodic spline's knots must lie within one period ({period}) of the first"),
                    ));
                }
                x.push(close);
                if local {
                    local_slopes(&x, true)
                } else {
                    periodic_slopes(&x)
                }
            }
        };
        if slope_op.col_iter().any(|c| c.iter().any(|v| !v.is_finite())) {
            return Err(Error::Numerical(format!("the spline system for knots {knots:?} is singular")));
        }
        Ok(Spline { x, n, slope_op })
    }

    /// The slopes s = S y of every curve at the distinct knots; `values` holds n rows of `width`
    /// values (one curve per column), row-major, and so does the result.
    pub(crate) fn slopes(&self, values: &[f64], width: usize) -> Vec<f64> {
        assert_eq!(values.len(), self.n * width, "spline values: n rows of `width`");
        let mut s = vec![0.0; values.len()];
        let y = MatRef::from_row_major_slice(values, self.n, width);
        let out = faer::MatMut::from_row_major_slice_mut(&mut s, self.n, width);
        matmul(out, Accum::Replace, self.slope_op.as_ref(), y, 1.0, faer::Par::Seq);
        s
    }

    /// The Hermite weights (w_y0, w_s0, w_y1, w_s1) of point `t` and the indices of the two
    /// values they apply to: value = w_y0 y_i + w_s0 s_i + w_y1 y_j + w_s1 s_j. Outside the knots
    /// the first or last piece is extended, as SciPy's `extrapolate=True` does.
    pub(crate) fn weights(&self, t: f64) -> ([f64; 4], usize, usize) {
        let nx = self.x.len();
        if nx == 1 {
            return ([1.0, 0.0, 0.0, 0.0], 0, 0);
        }
        // The piece [x_i, x_{i+1}] with x_i <= t (the last piece from the last interior knot on).
        let i = self.x[1..nx - 1].partition_point(|&k| k <= t);
        let h = self.x[i + 1] - self.x[i];
        let u = (t - self.x[i]) / h;
        let (u2, u3) = (u * u, u * u * u);
        let w = [2.0 * u3 - 3.0 * u2 + 1.0, h * (u3 - 2.0 * u2 + u), -2.0 * u3 + 3.0 * u2, h * (u3 - u2)];
        // The closing knot of a periodic spline is knot 0 again.
        (w, i, (i + 1) % self.n)
    }

    /// [`Spline::weights`] with their derivatives in `t`: (weights, d weights / dt, i, j), so
    /// that value' = dw_y0 y_i + dw_s0 s_i + dw_y1 y_j + dw_s1 s_j.
    #[inline]
    pub(crate) fn weights_d(&self, t: f64) -> ([f64; 4], [f64; 4], usize, usize) {
        let nx = self.x.len();
        if nx == 1 {
            return ([1.0, 0.0, 0.0, 0.0], [0.0; 4], 0, 0);
        }
        let i = self.x[1..nx - 1].partition_point(|&k| k <= t);
        let h = self.x[i + 1] - self.x[i];
        let u = (t - self.x[i]) / h;
        let (u2, u3) = (u * u, u * u * u);
        let w = [2.0 * u3 - 3.0 * u2 + 1.0, h * (u3 - 2.0 * u2 + u), -2.0 * u3 + 3.0 * u2, h * (u3 - u2)];
        let dw = [(6.0 * u2 - 6.0 * u) / h, 3.0 * u2 - 4.0 * u + 1.0, (6.0 * u - 6.0 * u2) / h, 3.0 * u2 - 2.0 * u];
        (w, dw, i, (i + 1) % self.n)
    }

    /// The knots, strictly increasing; for a periodic spline the closing knot x_0 + period is last.
    pub(crate) fn knots(&self) -> &[f64] {
        &self.x
    }

    /// The knots' span: the first knot and the last (for a periodic spline, the closing knot).
    pub(crate) fn span(&self) -> (f64, f64) {
        (self.x[0], self.x[self.x.len() - 1])
    }

    /// Evaluates one curve (its n values and n slopes) at `t`.
    #[cfg(test)]
    pub(crate) fn eval(&self, y: &[f64], s: &[f64], t: f64) -> f64 {
        let (w, i, j) = self.weights(t);
        w[0] * y[i] + w[1] * s[i] + w[2] * y[j] + w[3] * s[j]
    }

    /// Resamples every curve of `values` (n rows of `width`, row-major) at the points `at`:
    /// `at.len()` rows of `width`.
    pub(crate) fn resample(&self, values: &[f64], width: usize, at: &[f64]) -> Vec<f64> {
        let s = self.slopes(values, width);
        let mut out = vec![0.0; at.len() * width];
        for (row, &t) in out.chunks_exact_mut(width).zip(at) {
            let (w, i, j) = self.weights(t);
            let (yi, si) = (&values[i * width..(i + 1) * width], &s[i * width..(i + 1) * width]);
            let (yj, sj) = (&values[j * width..(j + 1) * width], &s[j * width..(j + 1) * width]);
            for c in 0..width {
                row[c] = w[0] * yi[c] + w[1] * si[c] + w[2] * yj[c] + w[3] * sj[c];
            }
        }
        out
    }
}

/// The secant slope m_k as a row over the values: (y_{k+1} - y_k) / dx_k, with y indices mod n.
fn add_secant(row: &mut [f64], x: &[f64], k: usize, coef: f64) {
    let n = row.len();
    let h = x[k + 1] - x[k];
    row[(k + 1) % n] += coef / h;
    row[k % n] -= coef / h;
}

/// S of [`Spline::local`] on the knots `x` (for a periodic spline the closing knot last): row i
/// holds the derivative at x_i of the parabola through x_{i-1}, x_i, x_{i+1} (wrapping round
/// when periodic), s_i = (dx_i m_{i-1} + dx_{i-1} m_i) / (dx_{i-1} + dx_i); the ends of a linear
/// axis take the parabola through their three knots, s_0 = ((2 dx_0 + dx_1) m_0 - dx_0 m_1) /
/// (dx_0 + dx_1) and its mirror image. Two knots of a linear axis give a line (both slopes the
/// secant), one knot a constant.
fn local_slopes(x: &[f64], periodic: bool) -> Mat<f64> {
    let n = if periodic { x.len() - 1 } else { x.len() };
    let mut s = Mat::<f64>::zeros(n, n);
    if n < 2 {
        return s;
    }
    let mut row = vec![0.0; n];
    for i in 0..n {
        row.fill(0.0);
        if n == 2 && !periodic {
            add_secant(&mut row, x, 0, 1.0);
        } else {
            // The parabola over pieces a and b (three consecutive knots), differentiated at
            // its first, middle or last knot.
            let (a, at) = match i {
                _ if periodic => ((i + n - 1) % n, 1),
                0 => (0, 0),
                _ if i == n - 1 => (n - 3, 2),
                _ => (i - 1, 1),
            };
            let b = (a + 1) % n;
            let (h0, h1) = (x[a + 1] - x[a], x[b + 1] - x[b]);
            let (w0, w1) = match at {
                0 => ((2.0 * h0 + h1) / (h0 + h1), -h0 / (h0 + h1)),
                1 => (h1 / (h0 + h1), h0 / (h0 + h1)),
                _ => (-h1 / (h0 + h1), (h0 + 2.0 * h1) / (h0 + h1)),
            };
            add_secant(&mut row, x, a, w0);
            add_secant(&mut row, x, b, w1);
        }
        for (c, &v) in row.iter().enumerate() {
            s[(i, c)] = v;
        }
    }
    s
}

/// S for not-a-knot ends (SciPy's rows, including its 2- and 3-knot special cases).
fn not_a_knot_slopes(x: &[f64]) -> Mat<f64> {
    let n = x.len();
    let mut s = Mat::<f64>::zeros(n, n);
    match n {
        1 => {}
        2 => {
            // A line: both slopes are the secant.
            for i in 0..2 {
                s[(i, 1)] = 1.0 / (x[1] - x[0]);
                s[(i, 0)] = -1.0 / (x[1] - x[0]);
            }
        }
        3 => {
            // A parabola: p'(x_0) = m_0 - dx_0 q, p'(x_1) = m_0 + dx_0 q, p'(x_2) = m_1 + dx_1 q,
            // q = (m_1 - m_0) / (x_2 - x_0) the second divided difference.
            let (d0, d1, d) = (x[1] - x[0], x[2] - x[1], x[2] - x[0]);
            let mut m0 = [0.0; 3];
            let mut m1 = [0.0; 3];
            add_secant(&mut m0, x, 0, 1.0);
            add_secant(&mut m1, x, 1, 1.0);
            for c in 0..3 {
                let q = (m1[c] - m0[c]) / d;
                s[(0, c)] = m0[c] - d0 * q;
                s[(1, c)] = m0[c] + d0 * q;
                s[(2, c)] = m1[c] + d1 * q;
            }
        }
        _ => {
            let dx: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
            let mut a = Mat::<f64>::zeros(n, n);
            let mut c = Mat::<f64>::zeros(n, n);
            let mut row = vec![0.0; n];
            for i in 1..n - 1 {
                a[(i, i - 1)] = dx[i];
                a[(i, i)] = 2.0 * (dx[i - 1] + dx[i]);
                a[(i, i + 1)] = dx[i - 1];
                row.fill(0.0);
                add_secant(&mut row, x, i - 1, 3.0 * dx[i]);
                add_secant(&mut row, x, i, 3.0 * dx[i - 1]);
                row.iter().enumerate().for_each(|(j, &v)| c[(i, j)] = v);
            }
            // First piece: dx_1 s_0 + (x_2 - x_0) s_1 = ((dx_0 + 2d) dx_1 m_0 + dx_0^2 m_1) / d.
            let d = x[2] - x[0];
            a[(0, 0)] = dx[1];
            a[(0, 1)] = d;
            row.fill(0.0);
            add_secant(&mut row, x, 0, (dx[0] + 2.0 * d) * dx[1] / d);
            add_secant(&mut row, x, 1, dx[0] * dx[0] / d);
            row.iter().enumerate().for_each(|(j, &v)| c[(0, j)] = v);
            // Last piece, mirrored.
            let d = x[n - 1] - x[n - 3];
            a[(n - 1, n - 1)] = dx[n - 3];
            a[(n - 1, n - 2)] = d;
            row.fill(0.0);
            add_secant(&mut row, x, n - 3, dx[n - 2] * dx[n - 2] / d);
            add_secant(&mut row, x, n - 2, (2.0 * d + dx[n - 2]) * dx[n - 3] / d);
            row.iter().enumerate().for_each(|(j, &v)| c[(n - 1, j)] = v);
            s = a.partial_piv_lu().solve(c.as_ref());
        }
    }
    s
}

/// S for a closed curve: `x` ends with the closing knot; the continuity equation holds at every
/// distinct knot, the neighbours taken cyclically (with two distinct knots both neighbours are the
/// same slope, and the equations give SciPy's 3-point special case).
fn periodic_slopes(x: &[f64]) -> Mat<f64> {
    let n = x.len() - 1;
    if n == 1 {
        return Mat::zeros(1, 1); // one value over the whole period: a constant
    }
    let dx: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
    let mut a = Mat::<f64>::zeros(n, n);
    let mut c = Mat::<f64>::zeros(n, n);
    let mut row = vec![0.0; n];
    for i in 0..n {
        let prev = (i + n - 1) % n; // the piece ending at knot i
        a[(i, prev)] += dx[i];
        a[(i, i)] += 2.0 * (dx[prev] + dx[i]);
        a[(i, (i + 1) % n)] += dx[prev];
        row.fill(0.0);
        add_secant(&mut row, x, prev, 3.0 * dx[i]);
        add_secant(&mut row, x, i, 3.0 * dx[prev]);
        row.iter().enumerate().for_each(|(j, &v)| c[(i, j)] = v);
    }
    a.partial_piv_lu().solve(c.as_ref())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// More knots than a dense slope operator can hold: an error naming them, before anything
    /// is allocated (100,000 knots would need 224 GiB), on either boundary and either slope rule.
    #[test]
    fn too_many_knots_are_refused() {
        let knots: Vec<f64> = (0..100_000).map(|i| i as f64 * 0.0036).collect();
        for boundary in [Boundary::NotAKnot, Boundary::Periodic(360.0)] {
            for e in [Spline::new(&knots, boundary).unwrap_err(), Spline::local(&knots, boundary).unwrap_err()] {
                let e = e.to_string();
                assert!(e.contains("100000 values") && e.contains("at most 16384") && e.contains("GiB"), "{e}");
            }
        }
        assert!(check_knots("x", MAX_SPLINE_KNOTS).is_ok());
    }

    /// SciPy's values (fixtures/spline_scipy.py). The spline is a handful of O(1) operations on
    /// O(1) numbers, so both sides agree to a few ulps of the values' scale; 1e-12 leaves room for
    /// the different solve (dense LU here, banded or cyclic in SciPy).
    #[test]
    fn matches_scipy_cubic_spline() {
        let fx: serde_json::Value = serde_json::from_str(include_str!("fixtures/spline_scipy.json")).unwrap();
        for case in fx["cases"].as_array().unwrap() {
            let v = |k: &str| case[k].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect::<Vec<f64>>();
            let (x, y, xq, yq, dq) = (v("x"), v("y"), v("xq"), v("yq"), v("dq"));
            let b = match case["period"].as_f64() {
                Some(p) => Boundary::Periodic(p),
                None => Boundary::NotAKnot,
            };
            let sp = Spline::new(&x, b).unwrap();
            let s = sp.slopes(&y, 1);
            let scale = y.iter().fold(1.0f64, |a, v| a.max(v.abs()));
            for ((&t, &want), &dwant) in xq.iter().zip(&yq).zip(&dq) {
                let got = sp.eval(&y, &s, t);
                assert!((got - want).abs() <= 1e-12 * scale, "{}: at {t}: {got} vs scipy {want}", case["name"]);
                // The derivative, by the Hermite basis' derivative through a tiny central difference
                // would lose digits; check it at the knots through the slopes instead.
                if let Some(k) = x.iter().position(|&xk| xk == t) {
                    assert!((s[k] - dwant).abs() <= 1e-11 * scale, "{}: slope at {t}: {} vs scipy {dwant}", case["name"], s[k]);
                }
            }
        }
    }

    #[test]
    fn passes_through_its_knots() {
        let x = [0.0, 0.5, 2.0, 2.25, 7.0, 9.0, 9.5];
        let y = [1.0, -2.0, 0.5, 3.0, -1.0, 0.0, 4.0];
        for b in [Boundary::NotAKnot, Boundary::Periodic(12.0)] {
            for sp in [Spline::new(&x, b).unwrap(), Spline::local(&x, b).unwrap()] {
                let r = sp.resample(&y, 1, &x);
                for (a, b) in r.iter().zip(&y) {
                    assert!((a - b).abs() <= 4.0 * f64::EPSILON * 4.0, "{a} vs {b}");
                }
            }
        }
    }

    /// Bessel's slopes are the derivatives of the parabola through three knots: a parabola is
    /// reproduced exactly, ends and uneven spacing included, slopes and values between knots.
    #[test]
    fn the_local_cubic_reproduces_a_parabola() {
        let x = [-1.0, 0.5, 2.0, 2.25, 7.0, 9.0, 9.5];
        let p = |t: f64| 3.0 * t * t - 2.0 * t + 1.0;
        let y: Vec<f64> = x.iter().map(|&t| p(t)).collect();
        let sp = Spline::local(&x, Boundary::NotAKnot).unwrap();
        let s = sp.slopes(&y, 1);
        for (&t, &sk) in x.iter().zip(&s) {
            assert!((sk - (6.0 * t - 2.0)).abs() < 1e-12 * 60.0, "slope at {t}: {sk}");
        }
        for k in 0..=105 {
            let t = -1.0 + 0.1 * k as f64;
            assert!((sp.eval(&y, &s, t) - p(t)).abs() < 1e-12 * 300.0, "at {t}");
        }
        // Two knots: a line; on even periodic knots the slopes are central differences.
        let line = Spline::local(&[1.0, 3.0], Boundary::NotAKnot).unwrap();
        assert_eq!(line.slopes(&[2.0, 6.0], 1), vec![2.0, 2.0]);
        let even: Vec<f64> = (0..12).map(|k| 30.0 * k as f64).collect();
        let v: Vec<f64> = (0..12).map(|k| ((k * 7) % 5) as f64).collect();
        let s = Spline::local(&even, Boundary::Periodic(360.0)).unwrap().slopes(&v, 1);
        for k in 0..12 {
            let want = (v[(k + 1) % 12] - v[(k + 11) % 12]) / 60.0;
            assert!((s[k] - want).abs() < 1e-15, "slope {k}: {} vs {want}", s[k]);
        }
    }

    /// A value moves the local cubic only on the four pieces around its knot; the spline's
    /// moves everywhere.
    #[test]
    fn the_local_cubic_moves_only_near_a_changed_value() {
        let x: Vec<f64> = (0..12).map(|k| 30.0 * k as f64).collect();
        let y0 = vec![0.0; 12];
        let mut y1 = y0.clone();
        y1[5] = 1.0;
        let at: Vec<f64> = (0..360).map(|t| t as f64 + 0.5).collect();
        for (sp, local) in [(Spline::local(&x, Boundary::Periodic(360.0)).unwrap(), true), (Spline::new(&x, Boundary::Periodic(360.0)).unwrap(), false)] {
            let (a, b) = (sp.resample(&y0, 1, &at), sp.resample(&y1, 1, &at));
            for ((&t, &u), &v) in at.iter().zip(&a).zip(&b) {
                let near = (90.0..210.0).contains(&t);
                if local {
                    assert_eq!(u != v, near, "at {t}");
                } else if !near {
                    assert!(u != v, "the spline rings at {t}");
                }
            }
        }
    }

    #[test]
    fn periodic_curve_closes() {
        let x = [0.0, 45.0, 100.0, 200.0, 270.0];
        let y = [0.0, 1.0, -1.0, 2.0, 0.5];
        let sp = Spline::new(&x, Boundary::Periodic(360.0)).unwrap();
        let s = sp.slopes(&y, 1);
        // Just before the closing knot the curve returns to y_0, with the slope s_0.
        let (a, b) = (sp.eval(&y, &s, 360.0 - 1e-7), sp.eval(&y, &s, 360.0 - 2e-7));
        assert!((a - y[0]).abs() < 1e-6);
        assert!(((a - b) / 1e-7 - s[0]).abs() < 1e-4);
    }

    #[test]
    fn reproduces_cubics_with_not_a_knot() {
        // Not-a-knot reproduces any cubic exactly, whatever the knot spacing.
        let f = |t: f64| 0.5 * t * t * t - 2.0 * t * t + t - 3.0;
        let x = [-1.0, 0.0, 0.3, 1.7, 2.0, 4.5];
        let y: Vec<f64> = x.iter().map(|&t| f(t)).collect();
        let sp = Spline::new(&x, Boundary::NotAKnot).unwrap();
        let s = sp.slopes(&y, 1);
        for t in [-1.5, -0.5, 0.1, 1.0, 3.3, 4.5, 5.0] {
            assert!((sp.eval(&y, &s, t) - f(t)).abs() < 1e-11, "{t}");
        }
    }

    #[test]
    fn bad_knots_are_errors() {
        assert!(Spline::new(&[], Boundary::NotAKnot).is_err());
        assert!(Spline::new(&[0.0, 1.0, 1.0], Boundary::NotAKnot).is_err());
        assert!(Spline::new(&[0.0, f64::NAN], Boundary::NotAKnot).is_err());
        assert!(Spline::new(&[0.0, 360.0], Boundary::Periodic(360.0)).is_err());
    }
}
