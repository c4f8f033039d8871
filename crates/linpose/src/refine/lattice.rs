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
//! u whose 7 coefficients come from the 4 + 10 numbers c, G. Per query that is two products per
//! knot (c) and, when the weights are not uniform, seven per knot (G; uniform weights scale
//! sums kept in the model), then the coefficients of each interval. When the knots are evenly
//! spaced on the lattice (a turntable: every interval holds the lattice at the same offsets u_j),
//! intervals go 8 to a vector: a lower bound of each on [0, 1] (its least Bernstein coefficient)
//! and the distance at its first offset come first, then the groups in increasing bound get a
//! Horner evaluation at every offset, until a group's bound exceeds the least distance found
//! (on COIL-20 about one group of the five is evaluated). Otherwise each interval is evaluated
//! at its own lattice poses. Either way the result is the least over the whole lattice (720
//! poses at 0.5 degrees), where the eigenspace keeps the 720 points and searches a k-d tree and
//! the local search needed starts, a spline evaluation per step and a snap. The distance at a
//! lattice pose is the one [`super::surface::Surface::snap`] measures there, up to rounding (it
//! is expanded, not summed from the residuals); ties go to the lowest lattice pose.

/// The lattice search of one model's curve (see the module doc).
#[derive(Debug, Clone, Default)]
pub struct Lattice {
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
    /// evaluated on 8 intervals at once.
    even: Vec<f64>,
}

/// Products per knot k of [`Lattice::pairs`]: p_k p_k, p_k s_k, s_k s_k, p_k p_{k+1},
/// p_k s_{k+1}, s_k p_{k+1}, s_k s_{k+1}.
const PAIRS: usize = 7;

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
    pub fn new(knots: &[f64], period: Option<f64>, values: &[f32], slopes: &[f32], dim: usize, ls: usize, step: f64) -> Lattice {
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
        let mut out = Lattice { ls, cols, values: v, slopes: s, unit: Vec::new(), cells, lo, step, end, even };
        let mut unit = vec![0.0; PAIRS * cols];
        out.pairs(&vec![1.0; ls], &mut unit);
        out.unit = unit;
        out
    }

    /// Bytes held (the interval table counted as four 8-byte numbers an interval).
    pub fn bytes(&self) -> usize {
        (self.values.len() + self.slopes.len()) * 4 + (self.unit.len() + 4 * self.cells.len() + self.even.len()) * 8
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
    pub fn nearest(&self, y: &[f32], wt: &[f64], uniform: Option<f64>, scratch: &mut Vec<f64>) -> f64 {
        #[cfg(target_arch = "x86_64")]
        if crate::kernels::Level::detect() == crate::kernels::Level::Avx512 {
            // SAFETY: the CPU supports AVX-512F (detected).
            return unsafe { simd::nearest_avx512(self, y, wt, uniform, scratch) };
        }
        self.nearest_body(y, wt, uniform, scratch, false)
    }

    /// The body of [`Lattice::nearest`]: the same operations on every build (no fused
    /// multiply-adds), so the AVX-512 build (`avx512`) gives the same bits.
    #[inline(always)]
    fn nearest_body(&self, y: &[f32], wt: &[f64], uniform: Option<f64>, scratch: &mut Vec<f64>, avx512: bool) -> f64 {
        let c = self.cols;
        let groups = self.cells.len().div_ceil(8);
        scratch.resize((PAIRS + 2) * c + groups * 57, 0.0);
        let (g, rest) = scratch.split_at_mut(PAIRS * c);
        let (cp, rest) = rest.split_at_mut(c);
        let (cs, scratch2) = rest.split_at_mut(c);
        match uniform {
            Some(w) => g.iter_mut().zip(&self.unit).for_each(|(o, &u)| *o = w * u),
            #[cfg(target_arch = "x86_64")]
            // SAFETY: only the AVX-512 build passes avx512 (the CPU supports it).
            None if avx512 => unsafe { simd::pairs_avx512(self, wt, g) },
            None => self.pairs(wt, g),
        }
        // cp = sum_l a_l values_l, cs = sum_l a_l slopes_l (a = wt y), 8 columns at a time
        // summed over l in registers, l in increasing order.
        #[cfg(target_arch = "x86_64")]
        if avx512 {
            // SAFETY: only the AVX-512 build passes avx512 (the CPU supports it).
            unsafe { simd::products_avx512(self, y, wt, cp, cs) };
        }
        for k0 in (0..c).step_by(8).filter(|_| !(avx512 && cfg!(target_arch = "x86_64"))) {
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
        let (g, cp, cs) = (&*g, &*cp, &*cs);
        let ni = self.cells.len();
        let (mut best, mut best_t) = (f64::INFINITY, self.lo);
        if self.even.is_empty() {
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
        } else {
            // 8 intervals at a time: their polynomials' coefficients (padding lanes get an
            // infinite constant, so they never hold the least) and a lower bound of each on
            // [0, 1] (its least Bernstein coefficient); the first offset on every interval gives
            // a distance reached; then the groups of 8 in increasing bound, every offset u_j on
            // all 8 (each keeping its least), until a group's bound exceeds the least found.
            // Ties go to the lowest lattice pose, as in a scan in order.
            let h = self.cells[0].1;
            let groups = ni.div_ceil(8);
            let (polys, bounds) = scratch2.split_at_mut(groups * 56);
            let mut best_at = (usize::MAX, 0usize);
            for (gi, i0) in (0..ni).step_by(8).enumerate() {
                let p = self.polys8(i0, h, g, cp, cs);
                let lanes = bernstein_min(&p);
                let first = horner8(&p, self.even[0]);
                let mut lb = f64::INFINITY;
                for k in 0..8.min(ni - i0) {
                    lb = lb.min(lanes[k]);
                    let v = first[k];
                    if v < best {
                        (best, best_at) = (v, (i0 + k, 0));
                    }
                }
                bounds[gi] = lb;
                for q in 0..7 {
                    polys[gi * 56 + q * 8..gi * 56 + q * 8 + 8].copy_from_slice(&p[q]);
                }
            }
            while let Some(gi) = (0..groups).filter(|&gi| !bounds[gi].is_nan()).min_by(|&a, &b| bounds[a].total_cmp(&bounds[b])) {
                // The bound is exact up to rounding: rule a group out only past a margin.
                if bounds[gi] - best > 1e-9 * (bounds[gi].abs() + best.abs()) {
                    break;
                }
                bounds[gi] = f64::NAN;
                let p: [[f64; 8]; 7] = std::array::from_fn(|q| polys[gi * 56 + q * 8..gi * 56 + q * 8 + 8].try_into().expect("8 lanes"));
                let (bv, bj) = if avx512 {
                    #[cfg(target_arch = "x86_64")]
                    // SAFETY: only the AVX-512 build passes avx512 (the CPU supports it).
                    unsafe {
                        simd::least_avx512(&p, &self.even)
                    }
                    #[cfg(not(target_arch = "x86_64"))]
                    least(&p, &self.even)
                } else {
                    least(&p, &self.even)
                };
                let i0 = 8 * gi;
                for k in 0..8.min(ni - i0) {
                    let at = (i0 + k, bj[k] as usize);
                    if bv[k] < best || (bv[k] == best && at < best_at) {
                        (best, best_at) = (bv[k], at);
                    }
                }
            }
            if let Some(cell) = self.cells.get(best_at.0) {
                best_t = self.lo + (cell.2 + best_at.1 as i64) as f64 * self.step;
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
    /// (coefficients from degree 0): lane 0 of [`Lattice::polys8`] from `i`.
    #[inline(always)]
    fn poly(&self, i: usize, h: f64, g: &[f64], cp: &[f64], cs: &[f64]) -> [f64; 7] {
        self.polys8(i, h, g, cp, cs).map(|lanes| lanes[0])
    }

    /// The distance (less ||y||^2) on intervals i0 to i0 + 7 (all of length `h`) as polynomials
    /// in u, [degree][lane]; lanes past the last interval get an infinite constant. The 14
    /// factors of the terms in the order of [`TERMS`]: the products H_a H_b (those off the
    /// diagonal twice; each slope carries h), then the linear terms times -2.
    #[inline(always)]
    fn polys8(&self, i0: usize, h: f64, g: &[f64], cp: &[f64], cs: &[f64]) -> [[f64; 8]; 7] {
        let c = self.cols;
        let row = |v: &[f64], off: usize| -> [f64; 8] { v[off..off + 8].try_into().expect("8 lanes") };
        let scaled = |r: [f64; 8], k: f64| r.map(|x| k * x);
        let h2 = h * h;
        let f: [[f64; 8]; 14] = [
            row(g, i0),
            scaled(row(g, c + i0), 2.0 * h),
            scaled(row(g, 2 * c + i0), h2),
            row(g, i0 + 1),
            scaled(row(g, c + i0 + 1), 2.0 * h),
            scaled(row(g, 2 * c + i0 + 1), h2),
            scaled(row(g, 3 * c + i0), 2.0),
            scaled(row(g, 4 * c + i0), 2.0 * h),
            scaled(row(g, 5 * c + i0), 2.0 * h),
            scaled(row(g, 6 * c + i0), 2.0 * h2),
            scaled(row(cp, i0), -2.0),
            scaled(row(cs, i0), -2.0 * h),
            scaled(row(cp, i0 + 1), -2.0),
            scaled(row(cs, i0 + 1), -2.0 * h),
        ];
        let mut p = [[0f64; 8]; 7];
        // Term by term with the term's index a constant, so its zero coefficients drop out at
        // compile time and p stays in registers (a loop over the terms kept p in memory).
        macro_rules! add_term {
            ($($t:literal)*) => {$(
                for q in 0..7 {
                    if TERMS[$t][q] != 0.0 {
                        for k in 0..8 {
                            p[q][k] += f[$t][k] * TERMS[$t][q];
                        }
                    }
                }
            )*};
        }
        add_term!(0 1 2 3 4 5 6 7 8 9 10 11 12 13);
        for lane in p[0].iter_mut().skip(self.cells.len() - i0) {
            *lane = f64::INFINITY;
        }
        p
    }
}

/// For 8 intervals at once (`p`: their polynomials' coefficients by degree), the least value
/// over the offsets `even` and the first offset index (as f64) where each is reached.
#[inline(always)]
fn least(p: &[[f64; 8]; 7], even: &[f64]) -> ([f64; 8], [f64; 8]) {
    let (mut bv, mut bj) = ([f64::INFINITY; 8], [0f64; 8]);
    for (j, &u) in even.iter().enumerate() {
        let r = horner8(p, u);
        for k in 0..8 {
            if r[k] < bv[k] {
                (bv[k], bj[k]) = (r[k], j as f64);
            }
        }
    }
    (bv, bj)
}

/// 8 polynomials (coefficients by degree) at `u`: [`least`]'s operations.
#[inline(always)]
fn horner8(p: &[[f64; 8]; 7], u: f64) -> [f64; 8] {
    let mut r = p[6];
    for q in (0..6).rev() {
        for k in 0..8 {
            r[k] = r[k] * u + p[q][k];
        }
    }
    r
}

/// b_i = sum_{k <= i} C(i, k) / C(6, k) a_k: the Bernstein coefficients on [0, 1] of the
/// degree-6 polynomial of power coefficients a.
const BERNSTEIN: [[f64; 7]; 7] = {
    let mut out = [[0f64; 7]; 7];
    let mut i = 0;
    while i < 7 {
        let mut k = 0;
        while k <= i {
            out[i][k] = binomial(i, k) / binomial(6, k);
            k += 1;
        }
        i += 1;
    }
    out
};

const fn binomial(n: usize, k: usize) -> f64 {
    let mut r = 1.0;
    let mut j = 0;
    while j < k {
        r = r * (n - j) as f64 / (j + 1) as f64;
        j += 1;
    }
    r
}

/// A lower bound of each lane's polynomial on [0, 1]: its least Bernstein coefficient (the
/// polynomial is a convex combination of them there).
#[inline(always)]
fn bernstein_min(p: &[[f64; 8]; 7]) -> [f64; 8] {
    let mut lo = [f64::INFINITY; 8];
    for row in &BERNSTEIN {
        let mut b = [0f64; 8];
        for q in 0..7 {
            for k in 0..8 {
                b[k] += row[q] * p[q][k];
            }
        }
        for k in 0..8 {
            lo[k] = if b[k] < lo[k] { b[k] } else { lo[k] };
        }
    }
    lo
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

#[cfg(target_arch = "x86_64")]
mod simd {
    use super::Lattice;

    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn nearest_avx512(s: &Lattice, y: &[f32], wt: &[f64], uniform: Option<f64>, scratch: &mut Vec<f64>) -> f64 {
        s.nearest_body(y, wt, uniform, scratch, true)
    }

    /// [`Lattice::pairs`] 8 columns at a time, the seven sums over the coordinates in registers
    /// (the same products and sums, each column's over l in increasing order: the same bits).
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn pairs_avx512(s: &Lattice, wt: &[f64], g: &mut [f64]) {
        use std::arch::x86_64::*;
        let c = s.cols;
        assert!(c.is_multiple_of(8) && c >= 16 && g.len() >= super::PAIRS * c && s.values.len() >= s.ls * c && s.slopes.len() >= s.ls * c && wt.len() >= s.ls);
        for k0 in (0..c).step_by(8) {
            // The neighbour products for the columns before c - 8 (see Lattice::pairs).
            let next = k0 + 8 < c;
            let mut acc = [_mm512_setzero_pd(); super::PAIRS];
            for (l, &w) in wt[..s.ls].iter().enumerate() {
                if w == 0.0 {
                    continue;
                }
                let wv = _mm512_set1_pd(w);
                let at = l * c + k0;
                // SAFETY: columns k0 .. k0 + 8 of row l (and k0 + 1 .. k0 + 9 when k0 + 8 < c)
                // lie within the row (asserted lengths).
                let (a, b) = unsafe { (_mm512_cvtps_pd(_mm256_loadu_ps(s.values.as_ptr().add(at))), _mm512_cvtps_pd(_mm256_loadu_ps(s.slopes.as_ptr().add(at)))) };
                let (wa, wb) = (_mm512_mul_pd(wv, a), _mm512_mul_pd(wv, b));
                acc[0] = _mm512_add_pd(acc[0], _mm512_mul_pd(wa, a));
                acc[1] = _mm512_add_pd(acc[1], _mm512_mul_pd(wa, b));
                acc[2] = _mm512_add_pd(acc[2], _mm512_mul_pd(wb, b));
                if next {
                    // SAFETY: as above.
                    let (a1, b1) = unsafe { (_mm512_cvtps_pd(_mm256_loadu_ps(s.values.as_ptr().add(at + 1))), _mm512_cvtps_pd(_mm256_loadu_ps(s.slopes.as_ptr().add(at + 1)))) };
                    acc[3] = _mm512_add_pd(acc[3], _mm512_mul_pd(wa, a1));
                    acc[4] = _mm512_add_pd(acc[4], _mm512_mul_pd(wa, b1));
                    acc[5] = _mm512_add_pd(acc[5], _mm512_mul_pd(wb, a1));
                    acc[6] = _mm512_add_pd(acc[6], _mm512_mul_pd(wb, b1));
                }
            }
            for (q, v) in acc.iter().enumerate() {
                // SAFETY: columns k0 .. k0 + 8 of product q (g holds PAIRS x c).
                unsafe { _mm512_storeu_pd(g.as_mut_ptr().add(q * c + k0), *v) };
            }
        }
    }

    /// The products cp and cs of [`Lattice::nearest_body`] in AVX-512 registers (the same
    /// operations in the same order: the same bits).
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn products_avx512(s: &Lattice, y: &[f32], wt: &[f64], cp: &mut [f64], cs: &mut [f64]) {
        use std::arch::x86_64::*;
        let c = s.cols;
        assert!(c.is_multiple_of(8) && cp.len() >= c && cs.len() >= c && s.values.len() >= s.ls * c && s.slopes.len() >= s.ls * c && wt.len() >= s.ls && y.len() >= s.ls);
        for k0 in (0..c).step_by(8) {
            let (mut sp, mut ss) = (_mm512_setzero_pd(), _mm512_setzero_pd());
            for l in 0..s.ls {
                let a = wt[l] * y[l] as f64;
                if a == 0.0 {
                    continue;
                }
                let av = _mm512_set1_pd(a);
                // SAFETY: columns k0 .. k0 + 8 of row l (asserted lengths).
                let (v, sl) = unsafe { (_mm512_cvtps_pd(_mm256_loadu_ps(s.values.as_ptr().add(l * c + k0))), _mm512_cvtps_pd(_mm256_loadu_ps(s.slopes.as_ptr().add(l * c + k0)))) };
                sp = _mm512_add_pd(sp, _mm512_mul_pd(av, v));
                ss = _mm512_add_pd(ss, _mm512_mul_pd(av, sl));
            }
            // SAFETY: columns k0 .. k0 + 8 of cp and cs (asserted).
            unsafe {
                _mm512_storeu_pd(cp.as_mut_ptr().add(k0), sp);
                _mm512_storeu_pd(cs.as_mut_ptr().add(k0), ss);
            }
        }
    }

    /// [`super::least`] in AVX-512 registers (the same operations: multiply, then add).
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn least_avx512(p: &[[f64; 8]; 7], even: &[f64]) -> ([f64; 8], [f64; 8]) {
        use std::arch::x86_64::*;
        let pv: [__m512d; 7] = std::array::from_fn(|q| _mm512_loadu_pd(p[q].as_ptr()));
        let (mut bv, mut bj) = (_mm512_set1_pd(f64::INFINITY), _mm512_setzero_pd());
        for (j, &u) in even.iter().enumerate() {
            let uv = _mm512_set1_pd(u);
            let mut r = pv[6];
            for q in (0..6).rev() {
                r = _mm512_add_pd(_mm512_mul_pd(r, uv), pv[q]);
            }
            let k = _mm512_cmp_pd_mask::<_CMP_LT_OQ>(r, bv);
            bv = _mm512_mask_mov_pd(bv, k, r);
            bj = _mm512_mask_mov_pd(bj, k, _mm512_set1_pd(j as f64));
        }
        let (mut v, mut jj) = ([0f64; 8], [0f64; 8]);
        _mm512_storeu_pd(v.as_mut_ptr(), bv);
        _mm512_storeu_pd(jj.as_mut_ptr(), bj);
        (v, jj)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pose::{Param, PoseSpace};
    use crate::refine::surface::Surface;

    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        }
    }

    /// A random curve of `dim` coordinates through knots at `at`.
    fn curve(at: &[f64], dim: usize, circular: bool, rng: &mut Rng) -> Surface {
        let space = PoseSpace::new(vec![if circular { Param::circular("azimuth", 360.0) } else { Param::linear("elevation") }]).unwrap();
        let knots: Vec<f64> = (0..at.len() * dim).map(|_| rng.next()).collect();
        Surface::new(&space, &[at.to_vec()], &knots, dim).unwrap()
    }

    /// Every lattice pose of `s` (and the end of a linear axis) with its weighted squared
    /// distance to `y`, evaluated point by point.
    fn brute(s: &Surface, y: &[f32], wt: &[f64], step: f64) -> Vec<(f64, f64)> {
        let (at, period, _, _, dim) = s.line_parts().unwrap();
        let (lo, hi) = (at[0], at[at.len() - 1]);
        let mut poses: Vec<f64> = (0..).map(|k| lo + k as f64 * step).take_while(|&t| if period.is_some() { t < hi - 1e-9 } else { t <= hi + 1e-9 }).collect();
        if period.is_none() && *poses.last().unwrap() < hi {
            poses.push(hi);
        }
        let mut f = vec![0.0; dim];
        poses
            .into_iter()
            .map(|t| {
                let mut tc = [t];
                s.clamp(&mut tc);
                s.eval(&tc, &mut f, None);
                (t, y.iter().zip(&f).zip(wt).map(|((&a, &b), &w)| w * (a as f64 - b) * (a as f64 - b)).sum())
            })
            .collect()
    }

    #[test]
    fn the_lattice_search_finds_the_least_of_every_lattice_pose() {
        let mut rng = Rng(0x2545_f491_4f6c_dd1d);
        let even36: Vec<f64> = (0..36).map(|k| 10.0 * k as f64).collect();
        let uneven: Vec<f64> = (0..20).map(|k| 18.0 * k as f64 + if k % 3 == 1 { 4.3 } else { 0.0 }).collect();
        let linear: Vec<f64> = (0..12).map(|k| 20.0 + 5.0 * k as f64 + if k == 11 { 0.3 } else { 0.0 }).collect();
        let cases: [(&[f64], bool, usize, usize); 4] = [(&even36, true, 20, 20), (&even36, true, 12, 8), (&uneven, true, 9, 9), (&linear, false, 6, 6)];
        for (at, circular, dim, ls) in cases {
            let s = curve(at, dim, circular, &mut rng);
            let (knots, period, v, sl, d) = s.line_parts().unwrap();
            let lat = Lattice::new(knots, period, v, sl, d, ls, 0.5);
            assert_eq!(lat.even.is_empty(), !std::ptr::eq(at, &even36[..]), "evenly spaced knots take the grouped search");
            let mut scratch = Vec::new();
            let mut f = vec![0.0; dim];
            for q in 0..60 {
                // Queries near the curve (a pose off the lattice, plus noise) and far from it.
                let t = knots[0] + (rng.next() + 0.5) * (knots[knots.len() - 1] - knots[0]);
                s.eval(&[t], &mut f, None);
                let spread = if q % 3 == 0 { 0.3 } else { 0.003 };
                let y: Vec<f32> = f.iter().map(|&x| (x + spread * rng.next()) as f32).collect();
                let uniform = q % 2 == 0;
                let wt: Vec<f64> = (0..dim).map(|l| if l >= ls { 0.0 } else if uniform { 0.7 } else { 0.2 + rng.next().abs() }).collect();
                let got = lat.nearest(&y, &wt, uniform.then_some(0.7), &mut scratch);
                let portable = lat.nearest_body(&y, &wt, uniform.then_some(0.7), &mut scratch, false);
                assert_eq!(got.to_bits(), portable.to_bits(), "the AVX-512 build gives the portable one's pose");
                let all = brute(&s, &y, &wt, 0.5);
                let least = all.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
                let at_got = all.iter().find(|p| (p.0 - got).abs() < 1e-9).unwrap_or_else(|| panic!("{got} is not a lattice pose"));
                // The least up to the rounding of the expanded distance.
                assert!(at_got.1 <= least + 1e-12 * (1.0 + least), "query {q}: {got} at {} against the least {least}", at_got.1);
            }
        }
    }
}
