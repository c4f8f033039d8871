//! The symmetric rank-k update C += P P^T, lower triangle, f64: what builds the Gram matrix
//! G = X X^T (P = X, rows are images; driven by [`super::gram`]) and, streaming, X^T X (P = X^T,
//! rows are pixels).
//!
//! P arrives in panels of `kc` reduction steps, packed by [`pack_rows`] or [`pack_columns`]:
//! groups of 8 rows, each group `kc` steps of its 8 rows' values side by side, so that one
//! AVX-512 register holds 8 rows at one step. A micro-kernel computes a 24 x 8 tile of C over the
//! panel (24 accumulators, 3 vector loads and 8 broadcasts per step). The output is split into
//! bands of rows, one rayon task each; a band's micro-panels of 24 rows stay in L2 while the 8
//! broadcast rows stream through L1.
//!
//! Summation order, the reason for this shape: every element of C is, for each panel in order,
//! its previous value plus a sequential fused multiply-add sum over the panel's steps started
//! from zero. It depends on neither the band split, nor the thread count, nor the SIMD path (all
//! paths do the same fused operations in the same order), so results are bit-identical across
//! all of them. Splitting is over output blocks only, never over the reduction.
//!
//! 8-bit pixels (streaming X^T X): when every value is an 8-bit level k, C can be summed in
//! integers. [`SyrkAcc::update_u8`] adds s times the integer sums sum k_p k_q: panels hold pairs
//! of steps as two i16 in one 32-bit lane ([`pack_pairs_u8`]), and the AVX-512 VNNI micro-kernel
//! (`vpdpwssd`: 32 multiply-adds of i16 per instruction, four times the f64 FMA's 8) computes a
//! 48 x 8 tile in i32, which cannot overflow within a panel of at most [`KCP_MAX`] pairs.
//! [`SyrkAcc::update_u8_cross`] adds s times sum (k_p r_q + r_p k_q) for small signed r
//! (|r| <= 127) with `vpdpbusd` (u8 x i8, 64 per instruction) on quads of steps
//! ([`pack_quads_u8`]): with r the rounding residuals of the f32 features k/255, the two give
//! the products of the f32 features themselves (see `crate::methods::linear::stream`). The integer tile sums do
//! not depend on their order and are added to C (f64) by one fused multiply-add per element and
//! panel, in panel order, so every path, band split and thread count gives the same bits.
//!
//! Files: [`pack`] lays the panels out, [`tile`] is the f64 micro-kernel, [`int8`] drives the
//! 8-bit tiles (with their portable kernels) and `vnni` holds the AVX-512 VNNI ones.

mod int8;
mod pack;
mod tile;
#[cfg(target_arch = "x86_64")]
mod vnni;

use super::tuning::syrk::BAND;
#[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
pub use super::tuning::syrk::{KC, KCP, KCQ};
pub(crate) use pack::pack_rows;
#[cfg_attr(not(feature = "bench"), allow(unused_imports, unreachable_pub))] // public through crate::bench
pub use pack::{pack_columns, pack_pairs_u8, pack_quads_u8};
pub(super) use tile::tile;

use super::Level;
use faer::Mat;
use int8::{band_update_u8, band_update_u8_cross, Panel};
use rayon::prelude::*;

/// Rows of P per packed group (one AVX-512 register of f64).
pub(crate) const GROUP: usize = 8;
/// Rows of a micro-tile (three groups).
const MR: usize = 24;
/// Rows of an 8-bit micro-tile (three groups of 16 i32 lanes); bands and padding are multiples
/// of it so that both kernels tile every band.
const MR16: usize = 48;

/// Rows per band for an n-row C: at least 8 bands so two to eight threads balance, at most BAND.
fn band_rows(np: usize) -> usize {
    (np / 8).div_ceil(MR16).clamp(1, BAND / MR16) * MR16
}

/// Number of rows a packed panel has for `n` rows of P: padded with zero rows to a multiple of 48.
#[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
pub fn padded(n: usize) -> usize {
    n.div_ceil(MR16) * MR16
}

/// Rows of P per packed group of an 8-bit panel (16 i32 lanes of one AVX-512 register).
pub(crate) const GROUP16: usize = 16;
/// Most step pairs an 8-bit panel may hold: an i32 lane sums 2 * 255^2 per pair and must stay
/// below 2^31.
pub(crate) const KCP_MAX: usize = (i32::MAX as usize) / (2 * 255 * 255);
/// Most step quads a cross panel may hold: an i32 lane sums 2 * 4 * 255 * 128 per quad.
pub(crate) const KCQ_MAX: usize = (i32::MAX as usize) / (2 * 4 * 255 * 128);

/// One band of C's rows: `rows` rows from `r0`, columns `0..r0 + rows`, stored column by
/// column (`buf[c * rows + r - r0]`).
pub(super) struct Band {
    pub(super) r0: usize,
    pub(super) rows: usize,
    pub(super) buf: Vec<f64>,
}

/// Zero bands of `per` rows (the last one shorter) covering the lower triangle of `np` rows.
pub(super) fn zero_bands(np: usize, per: usize) -> Vec<Band> {
    (0..np)
        .step_by(per)
        .map(|r0| {
            let rows = per.min(np - r0);
            Band { r0, rows, buf: vec![0.0; rows * (r0 + rows)] }
        })
        .collect()
}

/// The full symmetric n x n matrix of a lower triangle held in bands (rows past n are padding).
pub(super) fn bands_into_matrix(n: usize, bands: Vec<Band>) -> Mat<f64> {
    let mut c = Mat::<f64>::zeros(n, n);
    for band in bands {
        for col in 0..(band.r0 + band.rows).min(n) {
            let (lo, hi) = (band.r0.max(col), (band.r0 + band.rows).min(n));
            if lo < hi {
                let src = &band.buf[col * band.rows + lo - band.r0..col * band.rows + hi - band.r0];
                let dst = c.col_mut(col).try_as_col_major_mut().expect("fresh matrix is column-major").as_slice_mut();
                dst[lo..hi].copy_from_slice(src);
            }
        }
    }
    for j in 0..n {
        for i in 0..j {
            c[(i, j)] = c[(j, i)];
        }
    }
    c
}

/// The lower triangle of C = sum of P P^T over the panels given to [`SyrkAcc::update`].
#[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
pub struct SyrkAcc {
    n: usize,
    bands: Vec<Band>,
    /// The SIMD level the kernels run with (the 8-bit ones with VNNI where it has it).
    level: Level,
}

#[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
impl SyrkAcc {
    /// A zero n x n accumulator using the detected SIMD level.
    pub fn new(n: usize) -> Self {
        let np = padded(n);
        SyrkAcc { n, bands: zero_bands(np, band_rows(np)), level: Level::detect() }
    }

    /// Whether [`SyrkAcc::update_u8`] runs the AVX-512 VNNI kernel (otherwise the portable one,
    /// which gives the same bits, more slowly).
    pub fn uses_vnni(&self) -> bool {
        self.level.avx512_vnni()
    }

    /// Uses the portable 8-bit kernel even where VNNI is available (for tests).
    #[cfg(any(test, feature = "bench"))]
    pub fn without_vnni(mut self) -> Self {
        self.level = self.level.without_vnni();
        self
    }

    /// C += s * P P^T for one 8-bit panel of `kcp` step pairs packed by [`pack_pairs_u8`]: the
    /// integer sums are exact, each element of C gets one fused multiply-add.
    pub fn update_u8(&mut self, a: &[i32], b: &[i32], kcp: usize, s: f64) {
        self.pairs(a, b, GROUP, kcp, s);
    }

    /// [`SyrkAcc::update_u8`] with the broadcast side read in place from `a` (the halves of its
    /// groups of 16, 16 lanes a step apart) instead of from a copy in groups of 8.
    pub fn update_u8_in_place(&mut self, a: &[i32], kcp: usize, s: f64) {
        self.pairs(a, a, GROUP16, kcp, s);
    }

    /// C += s * (K^T R + R^T K) for one panel of `kcq` step quads packed by [`pack_quads_u8`]
    /// (K the levels, R their signed values): exact integer sums, one fused multiply-add per
    /// element of C.
    pub fn update_u8_cross(&mut self, ak: &[i32], ar: &[i32], bk: &[i32], br: &[i32], kcq: usize, s: f64) {
        self.cross([ak, ar, bk, br], GROUP, kcq, s);
    }

    /// [`SyrkAcc::update_u8_cross`] with the broadcast side read in place from `ak` and `ar`
    /// (as [`SyrkAcc::update_u8_in_place`]).
    pub fn update_u8_cross_in_place(&mut self, ak: &[i32], ar: &[i32], kcq: usize, s: f64) {
        self.cross([ak, ar, ak, ar], GROUP16, kcq, s);
    }

    /// The pair pass, the broadcast side `b` at `bs` lanes a step.
    fn pairs(&mut self, a: &[i32], b: &[i32], bs: usize, kcp: usize, s: f64) {
        let np = padded(self.n);
        assert!(kcp <= KCP_MAX, "8-bit panel of {kcp} step pairs exceeds {KCP_MAX}");
        assert!(a.len() == np * kcp && b.len() == np * kcp, "packed 8-bit panel size");
        let (level, n16) = (self.level, self.n.div_ceil(GROUP16) * GROUP16);
        self.bands.par_iter_mut().for_each(|band| band_update_u8(band, n16, Panel { sides: [a, b], bs, steps: kcp }, s, level));
    }

    /// The cross pass, the broadcast sides `bk`, `br` at `bs` lanes a step.
    fn cross(&mut self, [ak, ar, bk, br]: [&[i32]; 4], bs: usize, kcq: usize, s: f64) {
        let np = padded(self.n);
        assert!(kcq <= KCQ_MAX, "8-bit panel of {kcq} step quads exceeds {KCQ_MAX}");
        for v in [ak, ar, bk, br] {
            assert_eq!(v.len(), np * kcq, "packed 8-bit panel size");
        }
        let (level, n16) = (self.level, self.n.div_ceil(GROUP16) * GROUP16);
        self.bands.par_iter_mut().for_each(|band| band_update_u8_cross(band, n16, Panel { sides: [ak, ar, bk, br], bs, steps: kcq }, s, level));
    }

    /// C += other's C (both n x n, element by element).
    pub fn add(&mut self, other: &SyrkAcc) {
        assert_eq!(self.n, other.n, "accumulator sizes");
        self.bands.par_iter_mut().zip(&other.bands).for_each(|(b, o)| b.buf.iter_mut().zip(&o.buf).for_each(|(v, &w)| *v += w));
    }

    /// Writes the lower triangle of C packed row by row (element (r, c), c <= r < n, at
    /// r (r + 1) / 2 + c) to `w` as little-endian f64, without a copy of the triangle.
    pub fn write_packed_lower(&self, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        let mut bytes = Vec::new();
        let mut result = Ok(());
        self.packed_rows(|row| {
            if result.is_ok() {
                bytes.clear();
                bytes.extend(row.iter().flat_map(|v| v.to_le_bytes()));
                result = w.write_all(&bytes);
            }
        });
        result
    }

    /// Hands the packed lower triangle's rows to `emit` in order. The bands hold C column by
    /// column, so rows are gathered CHUNK at a time: one cache line of each column serves them
    /// all.
    fn packed_rows(&self, mut emit: impl FnMut(&[f64])) {
        const CHUNK: usize = 8;
        let n = self.n;
        let mut rows = vec![0f64; CHUNK * n];
        for band in &self.bands {
            let end = (band.r0 + band.rows).min(n);
            for ra in (band.r0..end).step_by(CHUNK) {
                let rb = (ra + CHUNK).min(end);
                for c in 0..rb {
                    let col = &band.buf[c * band.rows + ra - band.r0..c * band.rows + rb - band.r0];
                    for (i, &v) in col.iter().enumerate() {
                        rows[i * n + c] = v;
                    }
                }
                for r in ra..rb {
                    emit(&rows[(r - ra) * n..(r - ra) * n + r + 1]);
                }
            }
        }
    }

    /// C += the lower triangle in `bytes`: [`SyrkAcc::write_packed_lower`]'s little-endian f64
    /// values, read where they lie.
    pub fn add_packed_lower_bytes(&mut self, bytes: &[u8]) {
        let n = self.n;
        assert_eq!(bytes.len(), n * (n + 1) / 2 * 8, "packed lower triangle size");
        self.add_packed_rows(|r, row| {
            let src = &bytes[r * (r + 1) / 2 * 8..(r * (r + 1) / 2 + r + 1) * 8];
            row.iter_mut().zip(src.chunks_exact(8)).for_each(|(v, b)| *v = f64::from_le_bytes(b.try_into().expect("8 bytes")));
        });
    }

    /// C += the lower triangle whose row r `fill(r, row)` writes (r + 1 values), rows gathered
    /// as in [`SyrkAcc::packed_rows`].
    fn add_packed_rows(&mut self, mut fill: impl FnMut(usize, &mut [f64])) {
        const CHUNK: usize = 8;
        let n = self.n;
        let mut rows = vec![0f64; CHUNK * n];
        for band in &mut self.bands {
            let end = (band.r0 + band.rows).min(n);
            for ra in (band.r0..end).step_by(CHUNK) {
                let rb = (ra + CHUNK).min(end);
                for r in ra..rb {
                    fill(r, &mut rows[(r - ra) * n..(r - ra) * n + r + 1]);
                }
                for c in 0..rb {
                    let col = &mut band.buf[c * band.rows + ra - band.r0..c * band.rows + rb - band.r0];
                    for (i, v) in col.iter_mut().enumerate() {
                        if c <= ra + i {
                            *v += rows[i * n + c];
                        }
                    }
                }
            }
        }
    }

    /// Multiplies every element of C by `s` (the benches).
    #[cfg(any(test, feature = "bench"))]
    pub fn scale(&mut self, s: f64) {
        self.bands.par_iter_mut().for_each(|band| band.buf.iter_mut().for_each(|v| *v *= s));
    }

    /// The lower triangle of C times `s` as an n x n column-major matrix whose upper triangle is
    /// zero (what a Cholesky factorisation in place reads). Bands are freed as they are copied,
    /// and the matrix is allocated zeroed, so the pages of its upper half are never touched: the
    /// peak stays about two triangles, not a triangle and a square.
    pub fn into_lower(self, s: f64) -> Vec<f64> {
        let n = self.n;
        let mut c = vec![0f64; n * n];
        for band in self.bands {
            for col in 0..(band.r0 + band.rows).min(n) {
                let src = &band.buf[col * band.rows..(col + 1) * band.rows];
                let (lo, hi) = (band.r0.max(col), (band.r0 + band.rows).min(n));
                if lo < hi {
                    let dst = &mut c[col * n + lo..col * n + hi];
                    dst.iter_mut().zip(&src[lo - band.r0..hi - band.r0]).for_each(|(d, &v)| *d = v * s);
                }
            }
        }
        c
    }

    /// C += P P^T for one packed panel of `kc` steps (`padded(n) * kc` values).
    pub fn update(&mut self, panel: &[f64], kc: usize) {
        self.update_blocks(panel, &[kc]);
    }

    /// C += P P^T for consecutive packed panels of `kcs[0]`, `kcs[1]`, ... steps, added in that
    /// order, in one parallel pass (one fork-join for all of them).
    pub fn update_blocks(&mut self, panels: &[f64], kcs: &[usize]) {
        let np = padded(self.n);
        assert_eq!(panels.len(), np * kcs.iter().sum::<usize>(), "packed panels size");
        let level = self.level;
        self.bands.par_iter_mut().for_each(|band| {
            let mut off = 0;
            for &kc in kcs {
                band_update(band, &panels[off..off + np * kc], kc, level);
                off += np * kc;
            }
        });
    }

    /// The full symmetric n x n matrix (the lower triangle mirrored). Bands are freed as they
    /// are copied, so the peak is about one matrix plus the band buffers' half of it.
    pub fn into_matrix(self) -> Mat<f64> {
        bands_into_matrix(self.n, self.bands)
    }
}

fn band_update(band: &mut Band, panel: &[f64], kc: usize, level: Level) {
    let ld = band.rows;
    let cols = band.r0 + band.rows;
    let gs = GROUP * kc;
    for cg in 0..cols / GROUP {
        let c0 = cg * GROUP;
        let b = &panel[cg * gs..(cg + 1) * gs];
        for t in 0..band.rows / MR {
            let r = band.r0 + t * MR;
            if r + MR <= c0 {
                continue; // the tile lies wholly above the diagonal
            }
            let a = &panel[(r / GROUP) * gs..(r / GROUP + 3) * gs];
            let out = &mut band.buf[c0 * ld + t * MR..(c0 + GROUP - 1) * ld + t * MR + MR];
            tile::<3>(level, a, b, kc, out, ld);
        }
    }
}

#[cfg(test)]
mod tests;
