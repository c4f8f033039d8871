//! The noisy scan: the affine fit at every coarse point, pruned on the leading coordinates.

use crate::kernels::scan::Tables;
use crate::kernels::Level;
use crate::methods::refined::model::RefinedModel;
use crate::methods::refined::tuning::{DEGENERATE, NOISE_SCAN_BLOCK, NOISE_SCAN_SLACK, NOISE_SCAN_SPLIT_FROM, START_RATIO};

/// The coarse scan of the noisy match: the affine fit of [`super::affine_fit`] at every coarse
/// point with fixed weights w0 (a clean query's: nu = 0; the local search then uses the query's
/// own). With m_i = f_i + c and g_i the point's two surfaces, the w0-weighted products
/// A = m.m, B = m.g, C = g.g depend on the point alone, so a query costs two products per point,
/// u_i = (w0 z).m_i and v_i = (w0 z).g_i, and the residual z.z - u^2 / A - e^2 / S with
/// e = v - (B / A) u and S = C - B^2 / A (the fit on m, then on g's part orthogonal to m: two
/// non-negative terms, so nothing cancels when g is nearly parallel to m).
///
/// The same fit on the first [`noise_scan_split`] coordinates only leaves out non-negative
/// terms, so its residual is a lower bound of the whole one: a point whose partial residual
/// exceeds twice the whole residual of the point of least partial residual cannot be within
/// twice the least, and its block of points is not summed further.
#[derive(Debug, Clone, Default)]
pub(crate) struct NoiseScan {
    pub(crate) w0: Vec<f32>,
    /// Per point over all w0.len() coordinates: 1 / A, B / A, 1 / S (0 where the fit is
    /// degenerate).
    full: AffineTables,
    /// The same over the first `split` coordinates (empty when `split` is 0: no pruning).
    part: AffineTables,
    pub(crate) split: usize,
    /// The points whose partial fit is degenerate (1 / A or 1 / S set to 0): their partial
    /// residual leaves part of the fit out, so it is no lower bound and they are never ruled out.
    degenerate: Vec<usize>,
}

/// Per point: 1 / A, B / A, 1 / S of [`NoiseScan`] (0 where the fit is degenerate).
#[derive(Debug, Clone, Default)]
struct AffineTables {
    inv_a: Vec<f64>,
    b_over_a: Vec<f64>,
    inv_s: Vec<f64>,
}

impl AffineTables {
    /// The tables of the fit over the coordinates of `w0` (the first w0.len()).
    pub(crate) fn new(model: &RefinedModel, w0: &[f64]) -> AffineTables {
        let n = model.start_len();
        let (mut a, mut b, mut cc) = (vec![0f64; n], vec![0f64; n], vec![0f64; n]);
        for (q, &w) in w0.iter().enumerate() {
            let (col, gcol) = (&model.start_points[q * n..(q + 1) * n], &model.bg_start[q * n..(q + 1) * n]);
            let cq = model.mean_proj[q] as f64;
            for i in 0..n {
                let (m, g) = (col[i] as f64 + cq, gcol[i] as f64);
                a[i] += w * m * m;
                b[i] += w * m * g;
                cc[i] += w * g * g;
            }
        }
        let (mut inv_a, mut b_over_a, mut inv_s) = (vec![0f64; n], vec![0f64; n], vec![0f64; n]);
        for i in 0..n {
            if a[i] > 0.0 {
                (inv_a[i], b_over_a[i]) = (1.0 / a[i], b[i] / a[i]);
                let schur = cc[i] - b[i] * b[i] / a[i];
                if schur > DEGENERATE * cc[i] && schur > 0.0 {
                    inv_s[i] = 1.0 / schur;
                }
            }
        }
        AffineTables { inv_a, b_over_a, inv_s }
    }

    /// The residuals of points `range`, in place of their products `u` (with `v`), for a query
    /// of weighted sums `ac` = (w0 z).c and `zz` = (w0 z).z.
    fn residuals(&self, range: std::ops::Range<usize>, u: &mut [f32], v: &[f32], ac: f64, zz: f64) {
        let (ba, ia, is) = (&self.b_over_a[range.clone()], &self.inv_a[range.clone()], &self.inv_s[range]);
        crate::kernels::scan::affine_residuals(Level::detect(), u, v, ba, ia, is, crate::kernels::scan::AffineTerms { ac, zz });
    }

    pub(crate) fn len(&self) -> usize {
        3 * self.inv_a.len()
    }
}

impl NoiseScan {
    pub(crate) fn new(model: &RefinedModel, w0: &[f64]) -> NoiseScan {
        debug_assert!(w0.len() <= model.components());
        let split = noise_scan_split(w0.len());
        let part = if split > 0 { AffineTables::new(model, &w0[..split]) } else { AffineTables::default() };
        let degenerate = (0..part.inv_a.len()).filter(|&i| part.inv_a[i] == 0.0 || part.inv_s[i] == 0.0).collect();
        NoiseScan { w0: w0.iter().map(|&v| v as f32).collect(), full: AffineTables::new(model, w0), part, split, degenerate }
    }

    /// Numbers held, all counted as 8 bytes.
    pub(crate) fn len(&self) -> usize {
        self.w0.len() + self.full.len() + self.part.len() + self.degenerate.len()
    }

    /// The residual at every coarse point that can lie within twice the least (+inf at the
    /// others) of the query coordinates `z` (mean added back, the first w0.len()), `c` the mean's
    /// coordinates, into `u` (`v` is scratch; both are resized, and every value is written).
    /// Every residual given has the bits of [`Self::scan_all`]'s.
    pub(crate) fn scan(&self, cols: &[f32], gcols: &[f32], z: &[f64], c: &[f64], u: &mut Vec<f32>, v: &mut Vec<f32>) {
        let (n, ln, s) = (self.full.inv_a.len(), self.w0.len(), self.split);
        if s == 0 {
            return self.scan_all(cols, gcols, z, c, u, v);
        }
        let level = Level::detect();
        let a: Vec<f32> = z.iter().zip(&self.w0).map(|(&zq, &w)| w * zq as f32).collect();
        let (ac, zz) = Self::sums(&self.w0, z, c);
        let (ac_s, zz_s) = Self::sums(&self.w0[..s], &z[..s], &c[..s]);
        u.resize(n, 0.0);
        v.resize(n, 0.0);
        // Lower bounds: the fit on the first s coordinates.
        crate::kernels::scan::dots2(level, &cols[..s * n], &gcols[..s * n], &a[..s], u, v);
        self.part.residuals(0..n, u, v, ac_s, zz_s);
        // Any point's whole residual bounds the least; the least partial one's is likely close.
        let Some(first) = crate::kernels::scan::argmin(level, u) else {
            return self.scan_all(cols, gcols, z, c, u, v);
        };
        self.degenerate.iter().for_each(|&i| u[i] = 0.0);
        let (mut u1, mut v1) = ([0f32], [0f32]);
        crate::kernels::scan::dots2_at(level, Tables { cols: &cols[..ln * n], gcols: &gcols[..ln * n] }, n, first, &a, &mut u1, &mut v1);
        self.full.residuals(first..first + 1, &mut u1, &v1, ac, zz);
        // Twice that residual bounds the cut of the starts; the slack covers the rounding of
        // the f32 products (about 1e-6 of z.z) many times over.
        let cut = (START_RATIO as f64 * u1[0] as f64 * (1.0 + NOISE_SCAN_SLACK) + NOISE_SCAN_SLACK * zz) as f32;
        for (b, (ub, vb)) in u.chunks_mut(NOISE_SCAN_BLOCK).zip(v.chunks_mut(NOISE_SCAN_BLOCK)).enumerate() {
            if ub.iter().fold(false, |hit, &x| hit | !(x > cut)) {
                let i0 = b * NOISE_SCAN_BLOCK;
                crate::kernels::scan::dots2_at(level, Tables { cols: &cols[..ln * n], gcols: &gcols[..ln * n] }, n, i0, &a, ub, vb);
                self.full.residuals(i0..i0 + ub.len(), ub, vb, ac, zz);
            } else {
                ub.fill(f32::INFINITY);
            }
        }
    }

    /// The residual at every coarse point into `u` (see [`Self::scan`]).
    pub(crate) fn scan_all(&self, cols: &[f32], gcols: &[f32], z: &[f64], c: &[f64], u: &mut Vec<f32>, v: &mut Vec<f32>) {
        let n = self.full.inv_a.len();
        let ln = self.w0.len();
        let a: Vec<f32> = z.iter().zip(&self.w0).map(|(&zq, &w)| w * zq as f32).collect();
        let (ac, zz) = Self::sums(&self.w0, z, c);
        u.resize(n, 0.0);
        v.resize(n, 0.0);
        crate::kernels::scan::dots2(Level::detect(), &cols[..ln * n], &gcols[..ln * n], &a, u, v);
        self.full.residuals(0..n, u, v, ac, zz);
    }

    /// (w0 z).c and (w0 z).z over the coordinates of `w0`.
    fn sums(w0: &[f32], z: &[f64], c: &[f64]) -> (f64, f64) {
        let ac: f64 = z.iter().zip(w0).zip(c).map(|((&zq, &w), &cq)| w as f64 * zq * cq).sum();
        let zz: f64 = z.iter().zip(w0).map(|(&zq, &w)| w as f64 * zq * zq).sum();
        (ac, zz)
    }
}

/// Coordinates of the noisy scan's first pass ([`NoiseScan::scan`]) for a match on `ln`: half
/// of them, from [`NOISE_SCAN_SPLIT_FROM`] on (0: no first pass). The fit's two free parameters
/// absorb much of a few coordinates, so a short first pass rules little out, and it costs a
/// residual per point.
fn noise_scan_split(ln: usize) -> usize {
    if ln >= NOISE_SCAN_SPLIT_FROM {
        ln / 2
    } else {
        0
    }
}
