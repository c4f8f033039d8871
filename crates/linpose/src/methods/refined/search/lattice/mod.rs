//! The exact lattice search of a one-parameter manifold (a turntable): the point of the spline
//! curve closest to a query among all poses on the lattice, found without storing the lattice's
//! points and without a local search.
//!
//! On knot interval i (length h, u in [0, 1)) the curve is f(u) = sum_a H_a(u) v_a with the
//! cubic Hermite basis H = (h00, h10, h01, h11) and v = (p_i, h s_i, p_{i+1}, h s_{i+1}) (knot
//! values p, slopes s). The weighted squared distance from y is
//!
//!   sum_l wt_l (y_l - f_l(u))^2 = ||y||^2_wt - 2 sum_a H_a(u) c_a + sum_{a,b} H_a(u) H_b(u) G_ab
//!
//! with c_a = sum_l wt_l y_l v_al and G_ab = sum_l wt_l v_al v_bl: a polynomial of degree 6 in
//! u whose 7 coefficients come from the 4 + 10 numbers c, G.
//!
//! When the knots are evenly spaced on the lattice (a turntable: every interval holds the
//! lattice at the same offsets u_j), the model keeps ||f||^2 at every lattice pose (720 f32 at
//! 0.5 degrees, where the eigenspace keeps the 720 points) and a query takes the unweighted
//! distance ||y||^2 + ||f||^2 - 2 sum_a H_a(u_j) c_a at all of them from two products per knot
//! (c with unit weights), in f32, 16 poses a vector. The weighted distance lies between w_min
//! and w_max times it (the extreme weights), so only the poses whose lower bound (less the f32
//! rounding) is within the least upper bound can hold the least; those alone are measured
//! exactly in f64, and a single one is the answer unmeasured (a query's own weights are close to
//! uniform, so few are left). On AVX-512 the distances are computed only on the intervals that
//! can hold such a pose: each interval's distances are bounded below from its two knots'
//! products (the Hermite value weights sum to 1, the slope weights keep their sign) and its
//! least ||f||^2, and compared with the cut of the least distance at the intervals' first poses;
//! with more than [`PRUNE_MAX`] intervals left, every pose is computed.
//!
//! Otherwise (knots not evenly spaced on the lattice) each interval's polynomial is evaluated at
//! its own lattice poses, per query two products per knot (c) and, when the weights are not
//! uniform, seven (G; uniform weights scale sums kept in the model).
//!
//! Either way the result is the least over the whole lattice, without the lattice's points (the
//! eigenspace's k-d tree searches them) and without a local search's starts, steps and snap. The
//! distance at a lattice pose is the one
//! [`Surface::snap`](crate::manifold::surface::Surface::snap) measures there, up to
//! rounding; ties go to the lowest lattice pose.

#[cfg(test)]
mod tests;

use crate::kernels::lattice::{self as kernel, EvenQuery, LatticeView, PAIRS};
use crate::kernels::Level;
use crate::methods::refined::tuning::PRUNE_MAX;

/// The lattice search of one model's curve (see the module doc).
#[derive(Debug, Clone, Default)]
pub(crate) struct Lattice {
    /// Coordinates searched (the first `ls` of the curve's L).
    ls: usize,
    /// Columns per row of `values`, `slopes` and the per-knot products: the knots, the first
    /// one again on a circular axis (interval i runs from knot i to knot i + 1), then zeros, so
    /// that 8 intervals (and their next knots) can be read from any interval on, to a multiple
    /// of 16 (whole vectors: a scalar tail cost as much as the rest).
    cols: usize,
    /// Knot values and slopes of the searched coordinates, [l][column].
    values: Vec<f32>,
    slopes: Vec<f32>,
    /// The seven products per knot with unit weights, [product][column] (see [`Lattice::pairs`]).
    unit: Vec<f64>,
    /// Per interval: first knot position, length, first lattice index, lattice poses in it.
    cells: Vec<(f64, f64, i64, usize)>,
    /// The lattice: anchor (the first knot) and step.
    lo: f64,
    step: f64,
    /// A last candidate off the lattice: the end of a linear axis when no lattice pose lands on
    /// it (the snap keeps poses in the domain the same way).
    end: Option<f64>,
    /// When every interval has the same length and holds the lattice at the same offsets (knots
    /// evenly spaced on the lattice, as on a turntable): those offsets u_j, so that each u_j is
    /// evaluated on 16 intervals at once.
    even: Vec<f64>,
    /// For an even lattice: per offset u_j the Hermite weights of the value and slope columns,
    /// (h00, h h10, h01, h h11) at u_j.
    herm: Vec<[f32; 4]>,
    /// For an even lattice: the curve's squared norm over the searched coordinates at each
    /// lattice pose, `[offset j][interval]` in rows of the intervals rounded up to 16 (+inf past
    /// the last interval).
    norms: Vec<f32>,
    /// For an even lattice, what the pruned scan reads ([`kernel::even_scan`]): the norms
    /// again as `[interval][offset]` in rows of the offsets rounded up to 16 (+inf past the last
    /// offset), the Hermite weights as `[weight][offset]` (0 past it), each interval's least norm
    /// (rows of `norms`' length, +inf past the last interval), and the largest h h10 and
    /// -h h11 over the offsets.
    norms_t: Vec<f32>,
    herm_t: Vec<f32>,
    norm_min: Vec<f32>,
    slope_max: [f32; 2],
    /// The largest of the norms, and of ||value|| + ||h slope|| over the knots (bounds of the
    /// f32 rounding in [`Lattice::nearest_even`]).
    norm_max: f64,
    span_max: f64,
}

/// [`Lattice::nearest_even`]'s buffers: the products and distances, and the poses left.
type EvenScratch = (Vec<f32>, Vec<(usize, usize)>);

thread_local! {
    static EVEN_SCRATCH: std::cell::RefCell<EvenScratch> = const { std::cell::RefCell::new((Vec::new(), Vec::new())) };
}


/// The places of the values of `d` (rows of `np`) no more than `cut`, in increasing order, into
/// `hits` as (column, row).
fn under(d: &[f32], np: usize, cut: f32, hits: &mut Vec<(usize, usize)>) {
    hits.extend(d.iter().enumerate().filter(|p| *p.1 <= cut).map(|p| (p.0 % np, p.0 / np)));
}

/// The Hermite weights of the knot values and slopes at u of an interval of length `h`:
/// (h00, h h10, h01, h h11), each slope carrying h.
fn hermite(u: f64, h: f64) -> [f64; 4] {
    let (u2, u3) = (u * u, u * u * u);
    [2.0 * u3 - 3.0 * u2 + 1.0, h * (u3 - 2.0 * u2 + u), -2.0 * u3 + 3.0 * u2, h * (u3 - u2)]
}

/// The (a, b) of the 10 products H_a H_b.
const PAIR_ORDER: [(usize, usize); 10] = [(0, 0), (0, 1), (1, 1), (2, 2), (2, 3), (3, 3), (0, 2), (0, 3), (1, 2), (1, 3)];

/// The coefficients (in u, degree 0 to 6) of the 14 terms of the distance: the 10 products
/// H_a H_b of [`PAIR_ORDER`] and the 4 H_a.
const TERMS: [[f64; 7]; 14] = term_polys();

const fn term_polys() -> [[f64; 7]; 14] {
    // h00 = 2u^3 - 3u^2 + 1, h10 = u^3 - 2u^2 + u, h01 = -2u^3 + 3u^2, h11 = u^3 - u^2.
    let h: [[f64; 4]; 4] = [[1.0, 0.0, -3.0, 2.0], [0.0, 1.0, -2.0, 1.0], [0.0, 0.0, 3.0, -2.0], [0.0, 0.0, -1.0, 1.0]];
    let mut out = [[0f64; 7]; 14];
    let mut t = 0;
    while t < 10 {
        let (a, b) = PAIR_ORDER[t];
        let mut i = 0;
        while i < 4 {
            let mut j = 0;
            while j < 4 {
                out[t][i + j] += h[a][i] * h[b][j];
                j += 1;
            }
            i += 1;
        }
        t += 1;
    }
    let mut a = 0;
    while a < 4 {
        let mut i = 0;
        while i < 4 {
            out[10 + a][i] = h[a][i];
            i += 1;
        }
        a += 1;
    }
    out
}

impl Lattice {
    /// The search of the curve with knots `knots` (the closing knot last on a circular axis of
    /// `period`), knot `values` and `slopes` (knot-major, `dim` each), over its first `ls` coordinates, on
    /// the lattice of `step` degrees anchored at the first knot.
    pub(crate) fn new(knots: &[f64], period: Option<f64>, values: &[f32], slopes: &[f32], dim: usize, ls: usize, step: f64) -> Lattice {
        let n = values.len() / dim;
        let intervals = if period.is_some() { n } else { n - 1 };
        let cols = (intervals.div_ceil(8) * 8 + 1).max(intervals + 9).max(n + 1).div_ceil(16) * 16;
        let (mut v, mut s) = (vec![0f32; ls * cols], vec![0f32; ls * cols]);
        for l in 0..ls {
            for k in 0..n {
                v[l * cols + k] = values[k * dim + l];
                s[l * cols + k] = slopes[k * dim + l];
            }
            if period.is_some() {
                v[l * cols + n] = v[l * cols];
                s[l * cols + n] = s[l * cols];
            }
        }
        let lo = knots[0];
        // The lattice poses: lo + k step in the domain, each in the interval that holds it.
        let last = match period {
            Some(p) => ((p / step) - 1e-9).ceil() as i64 - 1,
            None => ((knots[n - 1] - lo) / step + 1e-9).floor() as i64,
        };
        let mut cells = Vec::with_capacity(intervals);
        let mut k = 0i64;
        for i in 0..intervals {
            let (x0, x1) = (knots[i], knots[i + 1]);
            let first = k;
            let closed = i + 1 == intervals;
            while k <= last && (closed || lo + k as f64 * step < x1) {
                k += 1;
            }
            cells.push((x0, x1 - x0, first, (k - first) as usize));
        }
        let end = match period {
            None if lo + last as f64 * step < knots[n - 1] => Some(knots[n - 1]),
            _ => None,
        };
        let (h0, c0) = (cells[0].1, cells[0].3);
        let offset = |c: &(f64, f64, i64, usize)| lo + c.2 as f64 * step - c.0;
        let even = cells.iter().all(|c| (c.1 - h0).abs() <= 1e-9 * h0 && c.3 == c0 && (offset(c) - offset(&cells[0])).abs() <= 1e-9 * step);
        let even = if even { (0..c0).map(|j| (lo + (cells[0].2 + j as i64) as f64 * step - cells[0].0) / h0).collect() } else { Vec::new() };
        let mut out = Lattice {
            ls,
            cols,
            values: v,
            slopes: s,
            unit: Vec::new(),
            cells,
            lo,
            step,
            end,
            even,
            herm: Vec::new(),
            norms: Vec::new(),
            norms_t: Vec::new(),
            herm_t: Vec::new(),
            norm_min: Vec::new(),
            slope_max: [0.0; 2],
            norm_max: 0.0,
            span_max: 0.0,
        };
        if out.even.is_empty() {
            let mut unit = vec![0.0; PAIRS * cols];
            out.pairs(&vec![1.0; ls], &mut unit);
            out.unit = unit;
        } else {
            let herm: Vec<[f64; 4]> = out.even.iter().map(|&u| hermite(u, h0)).collect();
            out.herm = herm.iter().map(|h| h.map(|v| v as f32)).collect();
            let np = intervals.div_ceil(16) * 16;
            out.norms = vec![f32::INFINITY; out.even.len() * np];
            let (origin, unit) = (vec![0f32; ls], vec![1.0; ls]);
            for (j, &h) in herm.iter().enumerate() {
                for i in 0..intervals {
                    let norm = out.exact(&origin, &unit, i, h);
                    out.norms[j * np + i] = norm as f32;
                    out.norm_max = out.norm_max.max(norm);
                }
            }
            for i in 0..intervals {
                let norm = |v: &[f32]| (0..ls).map(|l| (v[l * cols + i] as f64).powi(2)).sum::<f64>().sqrt();
                out.span_max = out.span_max.max(norm(&out.values) + h0 * norm(&out.slopes));
            }
            let (nj, npo) = (out.even.len(), out.even.len().div_ceil(16) * 16);
            out.norms_t = vec![f32::INFINITY; intervals * npo];
            out.herm_t = vec![0.0; 4 * npo];
            out.norm_min = vec![f32::INFINITY; np];
            for j in 0..nj {
                for a in 0..4 {
                    out.herm_t[a * npo + j] = out.herm[j][a];
                }
                out.slope_max = [out.slope_max[0].max(out.herm[j][1]), out.slope_max[1].max(-out.herm[j][3])];
                for i in 0..intervals {
                    let v = out.norms[j * np + i];
                    out.norms_t[i * npo + j] = v;
                    out.norm_min[i] = out.norm_min[i].min(v);
                }
            }
        }
        out
    }

    /// Bytes held (the interval table counted as four 8-byte numbers an interval).
    pub(crate) fn bytes(&self) -> usize {
        (self.values.len() + self.slopes.len() + 4 * self.herm.len() + self.norms.len() + self.norms_t.len() + self.herm_t.len() + self.norm_min.len() + 2) * 4
            + (self.unit.len() + 4 * self.cells.len() + self.even.len() + 2) * 8
    }

    /// The seven weighted products per knot, [product][column] into `g` (PAIRS x cols).
    #[inline(always)]
    fn pairs(&self, wt: &[f64], g: &mut [f64]) {
        let c = self.cols;
        g.fill(0.0);
        let (pp, rest) = g.split_at_mut(c);
        let (ps, rest) = rest.split_at_mut(c);
        let (ss, rest) = rest.split_at_mut(c);
        let (pp1, rest) = rest.split_at_mut(c);
        let (ps1, rest) = rest.split_at_mut(c);
        let (sp1, ss1) = rest.split_at_mut(c);
        for (l, &w) in wt.iter().enumerate().take(self.ls) {
            if w == 0.0 {
                continue;
            }
            let (v, s) = (&self.values[l * c..(l + 1) * c], &self.slopes[l * c..(l + 1) * c]);
            for k in 0..c {
                let (a, b) = (v[k] as f64, s[k] as f64);
                pp[k] += w * a * a;
                ps[k] += w * a * b;
                ss[k] += w * b * b;
            }
            // Intervals start in the first c - 9 columns at most (see new): c - 8, a multiple
            // of 8, covers them with whole vectors (the columns past it stay 0, as the padding's
            // products are).
            for k in 0..c - 8 {
                let (a, b, a1, b1) = (v[k] as f64, s[k] as f64, v[k + 1] as f64, s[k + 1] as f64);
                pp1[k] += w * a * a1;
                ps1[k] += w * a * b1;
                sp1[k] += w * b * a1;
                ss1[k] += w * b * b1;
            }
        }
    }

    /// The lattice pose closest to `y` under the weights `wt` (only the first `ls` count; all
    /// alike when `uniform` gives their common value). `scratch` is reused between calls.
    pub(crate) fn nearest(&self, y: &[f32], wt: &[f64], uniform: Option<f64>, scratch: &mut Vec<f64>) -> f64 {
        let level = Level::detect();
        kernel::with_avx512f(level, || {
            if self.even.is_empty() {
                self.nearest_body(y, wt, uniform, scratch, level)
            } else {
                self.nearest_even(y, wt, level)
            }
        })
    }

    /// What the kernels read of the search.
    fn view(&self) -> LatticeView<'_> {
        LatticeView {
            ls: self.ls,
            cols: self.cols,
            values: &self.values,
            slopes: &self.slopes,
            even: &self.even,
            herm: &self.herm,
            norms: &self.norms,
            norms_t: &self.norms_t,
            herm_t: &self.herm_t,
            norm_min: &self.norm_min,
            slope_max: self.slope_max,
        }
    }

    /// [`Lattice::nearest`] on an even lattice. The unweighted distance d at every lattice pose
    /// is ||y||^2 + ||f||^2 - 2 y.f, from the stored norms and y.f, a cubic in u per interval of
    /// two products per knot; it is computed in f32 (16 poses a vector), within `slack` of d.
    /// The weighted distance lies between w_min d and w_max d (the extreme weights of the
    /// searched coordinates), so only the poses whose lower bound is within the least upper
    /// bound can hold the least, and only those are measured exactly, in f64 (none when one
    /// alone is left). The same pose as measuring every lattice pose exactly, up to the f64
    /// rounding of near ties; the same operations on every build (no fused multiply-adds), so
    /// the AVX-512 build (at a `level` with AVX-512) gives the same bits.
    #[inline(always)]
    fn nearest_even(&self, y: &[f32], wt: &[f64], level: Level) -> f64 {
        let (c, ls, nj) = (self.cols, self.ls, self.even.len());
        let np = self.norms.len() / nj;
        let (mut wmin, mut wmax) = (f64::INFINITY, 0f64);
        for &w in &wt[..ls] {
            wmin = wmin.min(w);
            wmax = wmax.max(w);
        }
        let yy: f64 = y[..ls].iter().map(|&v| v as f64 * v as f64).sum();
        // The f32 rounding of d: the products' (up to 40 terms of |y_l| |v_l|, bounded by
        // ||y|| ||v||, in the knots' values and slopes) and the sums' (of ||y||^2 and the
        // norms), each well below 1e-5 of these magnitudes.
        let slack = 1e-5 * (1.0 + yy + self.norm_max + yy.sqrt() * self.span_max);
        // The cut from the least d, in f32, rounded up.
        let cut_of = |least: f32| {
            let cut = (wmax * (least as f64 + slack)) / wmin.max(f64::MIN_POSITIVE) + slack;
            if (cut as f32 as f64) < cut {
                (cut as f32).next_up()
            } else {
                cut as f32
            }
        };
        let npo = self.herm_t.len() / 4;
        EVEN_SCRATCH.with_borrow_mut(|(buf, hits)| {
            // cp and cs, each with a vector of zeros past it (the last group reads column np),
            // then d (or the pruned scan's bounds and distances); every other number is written
            // before it is read.
            let len = 2 * (c + 16) + (nj * np).max(np + PRUNE_MAX * npo);
            if buf.len() != len {
                buf.clear();
                buf.resize(len, 0.0);
            }
            hits.clear();
            if !kernel::even_scan::<PRUNE_MAX>(level, self.view(), y, EvenQuery { yy: yy as f32, slack }, &cut_of, buf, hits) {
                let least = self.even_distances(y, yy as f32, buf);
                under(&buf[2 * (c + 16)..2 * (c + 16) + nj * np], np, cut_of(least), hits);
            }
            // In increasing lattice pose: ties go to the lowest.
            hits.sort_unstable();
            let (mut best, mut best_at) = (f64::INFINITY, hits.first().copied().unwrap_or((0, 0)));
            if hits.len() > 1 || self.end.is_some() {
                let h = self.cells[0].1;
                for &(i, j) in hits.iter() {
                    let v = self.exact(y, wt, i, hermite(self.even[j], h));
                    if v < best {
                        (best, best_at) = (v, (i, j));
                    }
                }
            }
            let mut t = self.lo + (self.cells[best_at.0].2 + best_at.1 as i64) as f64 * self.step;
            if let Some(e) = self.end {
                // The end of a linear axis: u = 1 in the last interval, the next knot's value.
                if self.exact(y, wt, self.cells.len() - 1, [0.0, 0.0, 1.0, 0.0]) < best {
                    t = e;
                }
            }
            t
        })
    }

    /// The weighted squared distance from `y` to the curve on interval `i` at Hermite weights
    /// `h` (see [`hermite`]), in f64.
    fn exact(&self, y: &[f32], wt: &[f64], i: usize, h: [f64; 4]) -> f64 {
        let c = self.cols;
        (0..self.ls)
            .map(|l| {
                let (v, s) = (&self.values[l * c..], &self.slopes[l * c..]);
                let f = h[0] * v[i] as f64 + h[1] * s[i] as f64 + h[2] * v[i + 1] as f64 + h[3] * s[i + 1] as f64;
                wt[l] * (y[l] as f64 - f).powi(2)
            })
            .sum()
    }

    /// The f32 distances of [`Lattice::nearest_even`] into `buf` (cp, cs, each `cols` + 16
    /// long, then d laid out as `norms`): cp = sum_l y_l values_l and cs = sum_l y_l slopes_l
    /// (l in increasing order), then d = (yy + norm) - 2 y.f with y.f = ((h0 cp_i + h1 cs_i) +
    /// h2 cp_i+1) + h3 cs_i+1; returns the least d. The AVX-512 scan's operations
    /// ([`kernel::even_scan`]).
    fn even_distances(&self, y: &[f32], yy: f32, buf: &mut [f32]) -> f32 {
        let (c, nj) = (self.cols, self.even.len());
        let np = self.norms.len() / nj;
        let (cp, rest) = buf.split_at_mut(c + 16);
        let (cs, d) = rest.split_at_mut(c + 16);
        cp[..c].fill(0.0);
        cs[..c].fill(0.0);
        for (l, &a) in y[..self.ls].iter().enumerate() {
            let (v, s) = (&self.values[l * c..(l + 1) * c], &self.slopes[l * c..(l + 1) * c]);
            for k in 0..c {
                cp[k] += a * v[k];
                cs[k] += a * s[k];
            }
        }
        let mut least = f32::INFINITY;
        for j in 0..nj {
            let [h0, h1, h2, h3] = self.herm[j];
            for i in 0..np {
                let dot = h0 * cp[i] + h1 * cs[i] + h2 * cp[i + 1] + h3 * cs[i + 1];
                let v = (yy + self.norms[j * np + i]) - 2.0 * dot;
                d[j * np + i] = v;
                least = if v < least { v } else { least };
            }
        }
        least
    }

    /// cp = sum_l a_l values_l, cs = sum_l a_l slopes_l (a = wt y), 8 columns at a time summed
    /// over l in registers, l in increasing order ([`kernel::products`]' operations).
    #[inline(always)]
    fn products(&self, y: &[f32], wt: &[f64], cp: &mut [f64], cs: &mut [f64]) {
        let c = self.cols;
        for k0 in (0..c).step_by(8) {
            let (mut sp, mut ss) = ([0f64; 8], [0f64; 8]);
            for l in 0..self.ls {
                let a = wt[l] * y[l] as f64;
                if a == 0.0 {
                    continue;
                }
                let (v, s) = (&self.values[l * c + k0..l * c + k0 + 8], &self.slopes[l * c + k0..l * c + k0 + 8]);
                for k in 0..8 {
                    sp[k] += a * v[k] as f64;
                    ss[k] += a * s[k] as f64;
                }
            }
            cp[k0..k0 + 8].copy_from_slice(&sp);
            cs[k0..k0 + 8].copy_from_slice(&ss);
        }
    }

    /// The body of [`Lattice::nearest`]: the same operations on every build (no fused
    /// multiply-adds), so the AVX-512 build (at a `level` with AVX-512) gives the same bits.
    #[inline(always)]
    fn nearest_body(&self, y: &[f32], wt: &[f64], uniform: Option<f64>, scratch: &mut Vec<f64>, level: Level) -> f64 {
        let c = self.cols;
        scratch.resize((PAIRS + 2) * c, 0.0);
        let (g, rest) = scratch.split_at_mut(PAIRS * c);
        let (cp, cs) = rest.split_at_mut(c);
        match uniform {
            Some(w) => g.iter_mut().zip(&self.unit).for_each(|(o, &u)| *o = w * u),
            None => {
                if !kernel::pairs(level, self.view(), wt, g) {
                    self.pairs(wt, g)
                }
            }
        }
        if !kernel::products(level, self.view(), y, wt, cp, cs) {
            self.products(y, wt, cp, cs);
        }
        let (g, cp, cs) = (&*g, &*cp, &*cs);
        let ni = self.cells.len();
        let (mut best, mut best_t) = (f64::INFINITY, self.lo);
        debug_assert!(self.even.is_empty(), "an even lattice takes nearest_even");
        let mut vals = [0f64; 64];
        for (i, &(x0, h, first, count)) in self.cells.iter().enumerate() {
            let poly = self.poly(i, h, g, cp, cs);
            let mut j = 0;
            while j < count {
                let take = (count - j).min(vals.len());
                for (o, v) in vals[..take].iter_mut().enumerate() {
                    let u = (self.lo + (first + (j + o) as i64) as f64 * self.step - x0) / h;
                    *v = horner(&poly, u);
                }
                for (o, &v) in vals[..take].iter().enumerate() {
                    if v < best {
                        (best, best_t) = (v, self.lo + (first + (j + o) as i64) as f64 * self.step);
                    }
                }
                j += take;
            }
        }
        if let Some(t) = self.end {
            // The end of a linear axis: u = 1 in the last interval.
            let i = ni - 1;
            if horner(&self.poly(i, self.cells[i].1, g, cp, cs), 1.0) < best {
                best_t = t;
            }
        }
        best_t
    }

    /// The distance (less ||y||^2) on interval `i` (of length `h`) as a polynomial in u
    /// (coefficients from degree 0). The 14 factors of the terms in the order of [`TERMS`]: the
    /// products H_a H_b (those off the diagonal twice; each slope carries h), then the linear
    /// terms times -2.
    fn poly(&self, i: usize, h: f64, g: &[f64], cp: &[f64], cs: &[f64]) -> [f64; 7] {
        let c = self.cols;
        let h2 = h * h;
        let f: [f64; 14] = [
            g[i],
            2.0 * h * g[c + i],
            h2 * g[2 * c + i],
            g[i + 1],
            2.0 * h * g[c + i + 1],
            h2 * g[2 * c + i + 1],
            2.0 * g[3 * c + i],
            2.0 * h * g[4 * c + i],
            2.0 * h * g[5 * c + i],
            2.0 * h2 * g[6 * c + i],
            -2.0 * cp[i],
            -2.0 * h * cs[i],
            -2.0 * cp[i + 1],
            -2.0 * h * cs[i + 1],
        ];
        let mut p = [0f64; 7];
        for (ft, term) in f.iter().zip(&TERMS) {
            for (pq, &tq) in p.iter_mut().zip(term) {
                if tq != 0.0 {
                    *pq += ft * tq;
                }
            }
        }
        p
    }
}

/// The degree-6 polynomial `p` (coefficients from degree 0) at `u`.
#[inline(always)]
fn horner(p: &[f64; 7], u: f64) -> f64 {
    let mut r = p[6];
    for q in (0..6).rev() {
        r = r * u + p[q];
    }
    r
}
