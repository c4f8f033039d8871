//! The normal equations of least squares on images, summed image by image: X^T X (M x M, its
//! lower triangle), X^T P (M x K) and each encoded column's P^T P, over any set of images. They
//! are sums, so sets of images summed apart (blocks read in turn, [`rows`]; shards on other
//! machines) add up to those of the union: the linear model's streamed fit
//! (`methods::linear::stream`) and the merged statistics of [`crate::partial`] both solve what
//! this accumulates.
//!
//! Blocks whose values are all 8-bit levels (what every 8-bit image gives: the feature of level k
//! is the f32 value k * fl(1/255) = V_k 2^-31 with V_k an integer) are summed in integers by the
//! crate's AVX-512 VNNI SYRK kernels: with V_k = k m + r_k (m = fl(1/255) 2^31, |r_k| <= 127),
//! the products of two features are 2^-62 (m^2 k_p k_q + m (k_p r_q + r_p k_q) + r_p r_q). The
//! first two sums are exact in integers, in two passes (`vpdpwssd` on pairs of images,
//! `vpdpbusd` on quads) that together take half the instructions of the f64 kernel's FMAs; the
//! last, under 4e-15 per image, is left out. X^T X is thus that of the same f32 features as the
//! in-memory path, to about 1e-14 relative, at about twice the f64 kernel's speed. From the
//! first block that is not 8-bit (16-bit images, say), the rest is summed in f64; so is
//! everything on a CPU without AVX-512 VNNI (the same model to about 1e-14 in X^T X, not the same
//! bits). Blocks are summed in the order given, each by the same SYRK kernels, so the result
//! does not depend on the thread count.
//!
//! The solve is W = (X^T X + lambda I)^{-1} X^T P by Cholesky. A pixel that is zero in every
//! image (a black background) has a zero row and column in X^T X and in X^T P: its weight is 0
//! in the minimum-norm least-squares solution, and it is solved as such (a unit pivot, a zero
//! right-hand side), so lambda = 0 gives the minimum-norm least-squares fit whenever the pixels
//! that do vary are linearly independent over the images. Otherwise the system is refused as
//! singular, with the hint to add a ridge.

pub(crate) mod rows;

use crate::kernels::levels::{residuals as level_residuals, SCALE_CROSS, SCALE_PAIRS};
use crate::kernels::syrk::{pack_columns, pack_pairs_u8, pack_quads_u8, padded, SyrkAcc, KC, KCP, KCQ};
use crate::pose::PoseSpace;
use crate::{Error, Result};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{cholesky_in_place, cholesky_in_place_scratch};
use faer::linalg::triangular_solve::{solve_lower_triangular_in_place, solve_upper_triangular_in_place};
use faer::{Mat, MatMut, MatRef};
use rayon::prelude::*;

/// X^T X, X^T P and P^T P of the images added so far.
pub(crate) struct NormalEquations {
    m: usize,
    k: usize,
    /// Images added.
    n: usize,
    acc: SyrkAcc,
    /// X^T P, row-major M x K.
    xtp: Vec<f64>,
    /// Each encoded column's sum of squares.
    ptp: Vec<f64>,
    /// Every block so far 8-bit, on a CPU with AVX-512 VNNI (without it the portable integer
    /// kernel gives the same bits but is slower than the f64 kernel, so the f64 path is taken).
    exact: bool,
    scratch: Scratch,
}

/// Packing buffers, kept between blocks.
#[derive(Default)]
struct Scratch {
    /// 8-bit panels, step pairs.
    pa: Vec<i32>,
    pb: Vec<i32>,
    /// 8-bit panels, step quads.
    quads: [Vec<i32>; 4],
    /// f64 panel.
    panel: Vec<f64>,
}

/// The solved model: W^T (K x M, row-major, one coefficient image per encoded column) and the
/// spread of each circular pair's training residuals.
pub(crate) struct Solved {
    pub w: Vec<f64>,
    pub spread: Vec<f64>,
    /// Pixels zero in every image (weight 0).
    pub dark: usize,
}

impl NormalEquations {
    /// Zero sums for images of `m` features and `k` encoded pose values.
    pub(crate) fn new(m: usize, k: usize) -> Self {
        let acc = SyrkAcc::new(m);
        let exact = acc.uses_vnni();
        NormalEquations { m, k, n: 0, acc, xtp: vec![0.0; m * k], ptp: vec![0.0; k], exact, scratch: Scratch::default() }
    }

    /// Features per image.
    pub(crate) fn m(&self) -> usize {
        self.m
    }

    /// Images added.
    pub(crate) fn n(&self) -> usize {
        self.n
    }

    /// Whether every image so far was summed in integers (8-bit levels, AVX-512 VNNI).
    pub(crate) fn integer_8bit(&self) -> bool {
        self.exact
    }

    /// Adds `p.len() / K` images: their features `f` (rows of M), the same as 8-bit levels `q`
    /// when every value is one, and their encoded poses `p` (rows of K).
    pub(crate) fn add(&mut self, f: &[f32], q: Option<&[u8]>, p: &[f64]) {
        let (m, k) = (self.m, self.k);
        let b = p.len() / k;
        assert!(f.len() == b * m && p.len() == b * k, "block sizes");
        let np = padded(m);
        let s = &mut self.scratch;
        self.exact &= q.is_some(); // from the first block that is not 8-bit on, f64
        for row in p.chunks_exact(k) {
            self.ptp.iter_mut().zip(row).for_each(|(s, &v)| *s += v * v);
        }
        // X^T X over the block, in panels, in order.
        let mut r0 = 0;
        while r0 < b {
            match q.filter(|_| self.exact) {
                Some(q) => {
                    let kc = (2 * KCP).min(4 * KCQ).min(b - r0);
                    let q8 = &q[r0 * m..(r0 + kc) * m];
                    let kcp = kc.div_ceil(2);
                    s.pa.resize(np * KCP, 0);
                    s.pb.resize(np * KCP, 0);
                    let (a, bb) = (&mut s.pa[..np * kcp], &mut s.pb[..np * kcp]);
                    pack_pairs_u8(a, bb, q8, kc, m);
                    self.acc.update_u8(a, bb, kcp, SCALE_PAIRS);
                    let kcq = kc.div_ceil(4);
                    s.quads.iter_mut().for_each(|v| v.resize(np * KCQ, 0));
                    let [ak, ar, bk, br] = s.quads.each_mut().map(|v| &mut v[..np * kcq]);
                    pack_quads_u8([ak, ar, bk, br], q8, kc, m, &level_residuals());
                    self.acc.update_u8_cross(ak, ar, bk, br, kcq, SCALE_CROSS);
                    r0 += kc;
                }
                None => {
                    let kc = KC.min(b - r0);
                    s.panel.resize(np * KC, 0.0);
                    let pn = &mut s.panel[..np * kc];
                    pack_columns(pn, &f[r0 * m..(r0 + kc) * m], kc, m, None);
                    self.acc.update(pn, kc);
                    r0 += kc;
                }
            }
        }
        // X^T P: pixel chunks in parallel, images in order.
        self.xtp.par_chunks_mut(1024 * k).enumerate().for_each(|(c, out)| {
            let p0 = c * 1024;
            for i in 0..b {
                let pi = &p[i * k..(i + 1) * k];
                for (o, &v) in out.chunks_exact_mut(k).zip(&f[i * m + p0..]) {
                    o.iter_mut().zip(pi).for_each(|(o, &q)| *o += v as f64 * q);
                }
            }
        });
        self.n += b;
    }

    /// Adds another set's sums (images of the same size and pose space).
    pub(crate) fn merge(&mut self, other: &NormalEquations) {
        assert!(self.m == other.m && self.k == other.k, "normal equations of one size");
        self.acc.add(&other.acc);
        self.xtp.iter_mut().zip(&other.xtp).for_each(|(a, &b)| *a += b);
        self.ptp.iter_mut().zip(&other.ptp).for_each(|(a, &b)| *a += b);
        self.exact &= other.exact;
        self.n += other.n;
    }

    /// Writes X^T X's lower triangle packed row by row (M (M + 1) / 2 little-endian f64) to `w`,
    /// without a copy of it.
    pub(crate) fn write_xtx(&self, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        self.acc.write_packed_lower(w)
    }

    /// X^T P (M x K, row-major) and P^T P (K).
    pub(crate) fn xtp_ptp(&self) -> (&[f64], &[f64]) {
        (&self.xtp, &self.ptp)
    }

    /// The sums of `n` images back from [`Self::write_xtx`]'s bytes and [`Self::xtp_ptp`]'s
    /// arrays.
    pub(crate) fn from_parts(m: usize, k: usize, n: usize, xtx_bytes: &[u8], xtp: Vec<f64>, ptp: Vec<f64>, integer_8bit: bool) -> Self {
        assert!(xtp.len() == m * k && ptp.len() == k, "normal equation sizes");
        let mut acc = SyrkAcc::new(m);
        acc.add_packed_lower_bytes(xtx_bytes);
        NormalEquations { m, k, n, exact: integer_8bit && acc.uses_vnni(), acc, xtp, ptp, scratch: Scratch::default() }
    }

    /// Solves (X^T X + lambda I) W = X^T P (see the module documentation) and measures the pairs'
    /// spread from the training residuals.
    pub(crate) fn solve(self, lambda: f64, space: &PoseSpace) -> Result<Solved> {
        let (m, k, n) = (self.m, self.k, self.n);
        let NormalEquations { acc, xtp, ptp, scratch, .. } = self;
        drop(scratch);
        let mut a = acc.into_lower(1.0); // column-major M x M, lower triangle
        let mut dark = 0;
        for i in 0..m {
            // A pixel zero in every image: X^T X's row and column and X^T P's row are zero.
            if a[i * m + i] == 0.0 {
                a[i * m + i] = 1.0;
                dark += 1;
            } else {
                a[i * m + i] += lambda;
            }
        }
        let scale = (0..m).map(|i| a[i * m + i]).fold(0.0, f64::max);
        let par = crate::linalg::par();
        let mut mem = MemBuffer::new(cholesky_in_place_scratch::<f64>(m, par, Default::default()));
        cholesky_in_place(MatMut::from_column_major_slice_mut(&mut a, m, m), Default::default(), par, MemStack::new(&mut mem), Default::default())
            .map_err(|e| singular(lambda, &format!("{e:?}")))?;
        let l = MatRef::from_column_major_slice(&a, m, m);
        let dmin = (0..m).map(|i| l[(i, i)] * l[(i, i)]).fold(f64::INFINITY, f64::min);
        if !(dmin > scale * m as f64 * 1e-13) {
            return Err(singular(lambda, &format!("smallest pivot {dmin:.3e} against a largest diagonal of {scale:.3e}")));
        }
        let mut wm = Mat::from_fn(m, k, |i, j| xtp[i * k + j]);
        solve_lower_triangular_in_place(l, wm.as_mut(), par);
        solve_upper_triangular_in_place(l.transpose(), wm.as_mut(), par);
        drop(a);
        let mut w = vec![0.0; k * m];
        for j in 0..k {
            for i in 0..m {
                w[j * m + i] = wm[(i, j)];
            }
        }
        // The pairs' spread from the training residuals: RSS_j = P_j^T P_j - W_j^T X^T P_j -
        // lambda |W_j|^2 (X^T X W = X^T P - lambda W), over N - M degrees of freedom.
        let rss = |j: usize| {
            let wj = &w[j * m..(j + 1) * m];
            ptp[j] - wj.iter().enumerate().map(|(i, &v)| v * (xtp[i * k + j] + lambda * v)).sum::<f64>()
        };
        let dof = n.saturating_sub(m - dark).max(1) as f64;
        let spread = space.pair_columns().into_iter().map(|c| ((rss(c) + rss(c + 1)).max(0.0) / (2.0 * dof)).sqrt()).collect();
        Ok(Solved { w, spread, dark })
    }
}

fn singular(lambda: f64, detail: &str) -> Error {
    Error::SingularGram {
        detail: format!("X^T X + {lambda} I is singular ({detail})"),
        hint: "with more images than pixels the model is least squares, and pixels that vary together (or in only a few images) leave X^T X singular; use ridge regularisation (--ridge, e.g. 1e-3)".into(),
    }
}
