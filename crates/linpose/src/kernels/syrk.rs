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
//! the products of the f32 features themselves (see `crate::stream`). The integer tile sums do
//! not depend on their order and are added to C (f64) by one fused multiply-add per element and
//! panel, in panel order, so every path, band split and thread count gives the same bits.

use super::Level;
use faer::Mat;
use rayon::prelude::*;

/// Rows of P per packed group (one AVX-512 register of f64).
pub const GROUP: usize = 8;
/// Rows of a micro-tile (three groups).
const MR: usize = 24;
/// Rows of an 8-bit micro-tile (three groups of 16 i32 lanes); bands and padding are multiples
/// of it so that both kernels tile every band.
const MR16: usize = 48;
/// Most rows of C per band (one rayon task): 192 rows x 256 steps of the band's micro-panels
/// (384 KiB) stay in L2.
const BAND: usize = 192;

/// Rows per band for an n-row C: at least 8 bands so two to eight threads balance, at most BAND.
fn band_rows(np: usize) -> usize {
    (np / 8).div_ceil(MR16).clamp(1, BAND / MR16) * MR16
}

/// Number of rows a packed panel has for `n` rows of P: padded with zero rows to a multiple of 48.
pub fn padded(n: usize) -> usize {
    n.div_ceil(MR16) * MR16
}

/// Rows of P per packed group of an 8-bit panel (16 i32 lanes of one AVX-512 register).
pub const GROUP16: usize = 16;
/// Most step pairs an 8-bit panel may hold: an i32 lane sums 2 * 255^2 per pair and must stay
/// below 2^31.
pub const KCP_MAX: usize = (i32::MAX as usize) / (2 * 255 * 255);
/// Most step quads a cross panel may hold: an i32 lane sums 2 * 4 * 255 * 128 per quad.
pub const KCQ_MAX: usize = (i32::MAX as usize) / (2 * 4 * 255 * 128);
/// Step quads per cross panel used by streaming (1024 images).
pub const KCQ: usize = 256;
/// Step pairs per 8-bit panel used by streaming (1024 images): a band's micro-panels (384 KiB)
/// stay in L2, a column group's (16 KiB) in L1.
pub const KCP: usize = 512;

/// Packs the columns of a row-major `kc x m` block of 8-bit values (P = block^T) for
/// [`SyrkAcc::update_u8`]: `a` (`padded(m) * kcp` lanes, `kcp = kc.div_ceil(2)`) holds groups of
/// 16 rows of P, each step pair as 16 lanes of two i16 (steps 2j and 2j + 1, the second zero
/// past `kc`); `b` (as many lanes) the same values in groups of 8 rows, the micro-kernel's
/// broadcast side. Rows past m are zero.
pub fn pack_pairs_u8(a: &mut [i32], b: &mut [i32], block: &[u8], kc: usize, m: usize) {
    let kcp = kc.div_ceil(2);
    assert!(kcp <= KCP_MAX, "8-bit panel of {kcp} step pairs exceeds {KCP_MAX}");
    assert_eq!(a.len(), padded(m) * kcp, "packed panel size");
    assert_eq!(b.len(), padded(m) * kcp, "packed panel size");
    assert_eq!(block.len(), kc * m, "block size");
    a.par_chunks_mut(GROUP16 * kcp).enumerate().for_each(|(g, out)| {
        let p0 = g * GROUP16;
        let width = m.saturating_sub(p0).min(GROUP16);
        if width == 0 {
            out.fill(0);
            return;
        }
        for j in 0..kcp {
            let o = &mut out[j * GROUP16..(j + 1) * GROUP16];
            let first = &block[2 * j * m + p0..2 * j * m + p0 + width];
            let second = (2 * j + 1 < kc).then(|| &block[(2 * j + 1) * m + p0..(2 * j + 1) * m + p0 + width]);
            for l in 0..GROUP16 {
                o[l] = if l < width { first[l] as i32 | (second.map_or(0, |s| s[l] as i32) << 16) } else { 0 };
            }
        }
    });
    let a: &[i32] = a;
    b.par_chunks_mut(GROUP * kcp).enumerate().for_each(|(g, out)| {
        let src = &a[(g / 2) * GROUP16 * kcp..(g / 2 + 1) * GROUP16 * kcp];
        let h = (g % 2) * GROUP;
        for (o, s) in out.chunks_exact_mut(GROUP).zip(src.chunks_exact(GROUP16)) {
            o.copy_from_slice(&s[h..h + GROUP]);
        }
    });
}

/// Packs the columns of a row-major `kc x m` block of 8-bit levels for
/// [`SyrkAcc::update_u8_cross`]: `ak` / `bk` hold the levels k, `ar` / `br` the signed values
/// `r[k]`, each 32-bit lane four consecutive steps (bytes, zero past `kc`); `ak` / `ar` in groups
/// of 16 rows of P, `bk` / `br` in groups of 8 (`padded(m) * kc.div_ceil(4)` lanes each).
#[allow(clippy::too_many_arguments)] // four outputs, their block and its shape, the table
pub fn pack_quads_u8(ak: &mut [i32], ar: &mut [i32], bk: &mut [i32], br: &mut [i32], block: &[u8], kc: usize, m: usize, r: &[i8; 256]) {
    let kcq = kc.div_ceil(4);
    assert!(kcq <= KCQ_MAX, "8-bit panel of {kcq} step quads exceeds {KCQ_MAX}");
    for v in [&*ak, &*ar, &*bk, &*br] {
        assert_eq!(v.len(), padded(m) * kcq, "packed panel size");
    }
    assert_eq!(block.len(), kc * m, "block size");
    ak.par_chunks_mut(GROUP16 * kcq).zip(ar.par_chunks_mut(GROUP16 * kcq)).enumerate().for_each(|(g, (ok, or))| {
        let p0 = g * GROUP16;
        let width = m.saturating_sub(p0).min(GROUP16);
        ok.fill(0);
        or.fill(0);
        if width == 0 {
            return;
        }
        for i in 0..kc {
            let (j, shift) = (i / 4, 8 * (i % 4));
            let src = &block[i * m + p0..i * m + p0 + width];
            for (l, &v) in src.iter().enumerate() {
                ok[j * GROUP16 + l] |= (v as i32) << shift;
                or[j * GROUP16 + l] |= (r[v as usize] as u8 as i32) << shift;
            }
        }
    });
    let (ak, ar): (&[i32], &[i32]) = (ak, ar);
    for (src, dst) in [(ak, bk), (ar, br)] {
        dst.par_chunks_mut(GROUP * kcq).enumerate().for_each(|(g, out)| {
            let src = &src[(g / 2) * GROUP16 * kcq..(g / 2 + 1) * GROUP16 * kcq];
            let h = (g % 2) * GROUP;
            for (o, s) in out.chunks_exact_mut(GROUP).zip(src.chunks_exact(GROUP16)) {
                o.copy_from_slice(&s[h..h + GROUP]);
            }
        });
    }
}

/// Packs rows `0..n` of P, steps `k0..k0 + kc`, into `dst` (whole groups of 8 rows, at least
/// n rows; rows past n are zero), on the calling thread. `read(i, k0, out)` writes row i's `out.len()` values from step k0.
pub fn pack_rows(dst: &mut [f64], n: usize, kc: usize, k0: usize, read: impl Fn(usize, usize, &mut [f64])) {
    assert!(dst.len().is_multiple_of(GROUP * kc) && dst.len() >= n * kc, "packed panel size");
    let mut row = vec![0f64; kc];
    for (g, out) in dst.chunks_exact_mut(GROUP * kc).enumerate() {
        for l in 0..GROUP {
            let i = g * GROUP + l;
            if i < n {
                read(i, k0, &mut row);
            } else {
                row.fill(0.0);
            }
            for (k, &v) in row.iter().enumerate() {
                out[k * GROUP + l] = v;
            }
        }
    }
}

/// Packs the columns of a row-major `kc x m` block of f32 values (P = block^T: row p of P is
/// column p of the block, over the block's `kc` rows) into `dst` (`padded(m) * kc` values),
/// each value minus `mean[p]` when given.
pub fn pack_columns(dst: &mut [f64], block: &[f32], kc: usize, m: usize, mean: Option<&[f64]>) {
    assert_eq!(dst.len(), padded(m) * kc, "packed panel size");
    assert_eq!(block.len(), kc * m, "block size");
    dst.par_chunks_mut(GROUP * kc).enumerate().for_each(|(g, out)| {
        let p0 = g * GROUP;
        for k in 0..kc {
            let o = &mut out[k * GROUP..(k + 1) * GROUP];
            for (l, o) in o.iter_mut().enumerate() {
                let p = p0 + l;
                *o = if p < m { block[k * m + p] as f64 - mean.map_or(0.0, |u| u[p]) } else { 0.0 };
            }
        }
    });
}

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
pub struct SyrkAcc {
    n: usize,
    bands: Vec<Band>,
    level: Level,
    /// Whether the 8-bit updates use the AVX-512 VNNI kernel.
    vnni: bool,
}

impl SyrkAcc {
    /// A zero n x n accumulator using the best SIMD level.
    pub fn new(n: usize) -> Self {
        Self::with_level(n, Level::detect())
    }

    /// A zero n x n accumulator using `level` (which the CPU must support).
    pub fn with_level(n: usize, level: Level) -> Self {
        assert!(Level::supported().contains(&level), "SIMD level {level:?} not supported here");
        let np = padded(n);
        let bands = zero_bands(np, band_rows(np));
        SyrkAcc { n, bands, level, vnni: level == Level::Avx512 && vnni_supported() }
    }

    /// Whether [`SyrkAcc::update_u8`] runs the AVX-512 VNNI kernel (otherwise the portable one,
    /// which gives the same bits, more slowly).
    pub fn uses_vnni(&self) -> bool {
        self.vnni
    }

    /// Uses the portable 8-bit kernel even where VNNI is available (for tests).
    pub fn without_vnni(mut self) -> Self {
        self.vnni = false;
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
        let (vnni, n16) = (self.vnni, self.n.div_ceil(GROUP16) * GROUP16);
        self.bands.par_iter_mut().for_each(|band| band_update_u8(band, n16, a, b, bs, kcp, s, vnni));
    }

    /// The cross pass, the broadcast sides `bk`, `br` at `bs` lanes a step.
    fn cross(&mut self, [ak, ar, bk, br]: [&[i32]; 4], bs: usize, kcq: usize, s: f64) {
        let np = padded(self.n);
        assert!(kcq <= KCQ_MAX, "8-bit panel of {kcq} step quads exceeds {KCQ_MAX}");
        for v in [ak, ar, bk, br] {
            assert_eq!(v.len(), np * kcq, "packed 8-bit panel size");
        }
        let (vnni, n16) = (self.vnni, self.n.div_ceil(GROUP16) * GROUP16);
        self.bands.par_iter_mut().for_each(|band| band_update_u8_cross(band, n16, [ak, ar, bk, br], bs, kcq, s, vnni));
    }

    /// C += other's C (both n x n, element by element).
    pub fn add(&mut self, other: &SyrkAcc) {
        assert_eq!(self.n, other.n, "accumulator sizes");
        self.bands.par_iter_mut().zip(&other.bands).for_each(|(b, o)| b.buf.iter_mut().zip(&o.buf).for_each(|(v, &w)| *v += w));
    }

    /// Multiplies every element of C by `s`.
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

/// Whether the CPU has AVX-512 VNNI (checked once).
fn vnni_supported() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        use std::sync::OnceLock;
        static VNNI: OnceLock<bool> = OnceLock::new();
        *VNNI.get_or_init(|| is_x86_feature_detected!("avx512f") && is_x86_feature_detected!("avx512vnni"))
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Where the broadcast side of column group `cg` starts in `b` and how many lanes it spans:
/// packed groups of 8 (`bs` = 8 lanes a step) or halves of groups of 16 (`bs` = 16).
fn b_side(cg: usize, bs: usize, steps: usize) -> std::ops::Range<usize> {
    let per = bs / GROUP;
    let start = (cg / per) * bs * steps + (cg % per) * GROUP;
    start..start + (steps.max(1) - 1) * bs + GROUP
}

/// The 16-row groups of the 48-row tile at row `r` that column group `c0` needs: from the
/// group holding the diagonal (none above it) to the last group holding a row below `n16` (none
/// that is only padding). Rows `rs..rs + 16 q`; q = 0 when the tile is not needed.
fn tile_rows(r: usize, c0: usize, n16: usize) -> (usize, usize) {
    let rs = r.max(c0 / GROUP16 * GROUP16);
    let re = (r + MR16).min(n16);
    (rs, re.saturating_sub(rs) / GROUP16)
}

#[allow(clippy::too_many_arguments)]
fn band_update_u8(band: &mut Band, n16: usize, a: &[i32], b: &[i32], bs: usize, kcp: usize, s: f64, vnni: bool) {
    let ld = band.rows;
    let cols = band.r0 + band.rows;
    let ga = GROUP16 * kcp;
    for cg in 0..cols / GROUP {
        let c0 = cg * GROUP;
        let bp = &b[b_side(cg, bs, kcp)];
        for t in 0..band.rows / MR16 {
            let (rs, q) = tile_rows(band.r0 + t * MR16, c0, n16);
            if q == 0 {
                continue;
            }
            let ap = &a[(rs / GROUP16) * ga..(rs / GROUP16 + q) * ga];
            let o0 = c0 * ld + rs - band.r0;
            let out = &mut band.buf[o0..o0 + (GROUP - 1) * ld + q * GROUP16];
            #[cfg(target_arch = "x86_64")]
            if vnni {
                // SAFETY: vnni is only true when avx512f and avx512vnni were detected; the slices
                // have the lengths the kernels read and write (checked by them).
                unsafe {
                    match q {
                        3 => x86::tile_u8_vnni(ap, bp, bs, kcp, out, ld, s),
                        2 => x86::tile_u8_vnni_q::<2>(ap, bp, bs, kcp, out, ld, s),
                        _ => x86::tile_u8_vnni_q::<1>(ap, bp, bs, kcp, out, ld, s),
                    }
                }
                continue;
            }
            let _ = vnni;
            tile_u8_portable(q, ap, bp, bs, kcp, out, ld, s);
        }
    }
}

#[allow(clippy::too_many_arguments)]
fn band_update_u8_cross(band: &mut Band, n16: usize, [ak, ar, bk, br]: [&[i32]; 4], bs: usize, kcq: usize, s: f64, vnni: bool) {
    let ld = band.rows;
    let cols = band.r0 + band.rows;
    let ga = GROUP16 * kcq;
    for cg in 0..cols / GROUP {
        let c0 = cg * GROUP;
        let (bkp, brp) = (&bk[b_side(cg, bs, kcq)], &br[b_side(cg, bs, kcq)]);
        for t in 0..band.rows / MR16 {
            let (rs, q) = tile_rows(band.r0 + t * MR16, c0, n16);
            if q == 0 {
                continue;
            }
            let g = rs / GROUP16;
            let (akp, arp) = (&ak[g * ga..(g + q) * ga], &ar[g * ga..(g + q) * ga]);
            let o0 = c0 * ld + rs - band.r0;
            let out = &mut band.buf[o0..o0 + (GROUP - 1) * ld + q * GROUP16];
            #[cfg(target_arch = "x86_64")]
            if vnni {
                // SAFETY: as in band_update_u8 (lengths checked by the kernels).
                unsafe {
                    match q {
                        3 => x86::tile_u8_cross_vnni([akp, arp, bkp, brp], bs, kcq, out, ld, s),
                        2 => x86::tile_u8_cross_vnni_q::<2>([akp, arp, bkp, brp], bs, kcq, out, ld, s),
                        _ => x86::tile_u8_cross_vnni_q::<1>([akp, arp, bkp, brp], bs, kcq, out, ld, s),
                    }
                }
                continue;
            }
            let _ = vnni;
            tile_u8_cross_portable(q, [akp, arp, bkp, brp], bs, kcq, out, ld, s);
        }
    }
}

/// out[c * ld + r] += s * sum_j (lo(a[r][j]) lo(b[c][j]) + hi(a[r][j]) hi(b[c][j])) for the
/// (16 q) x 8 8-bit tile (q <= 3), summed exactly in i32 (a: q packed groups of 16, b: 8 lanes a
/// step, `bs` lanes apart).
#[allow(clippy::too_many_arguments)]
fn tile_u8_portable(q: usize, a: &[i32], b: &[i32], bs: usize, kcp: usize, out: &mut [f64], ld: usize, s: f64) {
    assert!(q <= 3 && a.len() >= q * GROUP16 * kcp && b.len() >= (kcp.max(1) - 1) * bs + GROUP && out.len() >= 7 * ld + q * GROUP16);
    let mut acc = [[0i32; MR16]; GROUP];
    for j in 0..kcp {
        let x = &a[j * GROUP16..];
        let y = &b[j * bs..j * bs + GROUP];
        for (c, &yc) in y.iter().enumerate() {
            let (ylo, yhi) = (yc as i16 as i32, yc >> 16);
            for q in 0..q {
                let xq = &x[q * GROUP16 * kcp..q * GROUP16 * kcp + GROUP16];
                for (l, &v) in xq.iter().enumerate() {
                    acc[c][q * GROUP16 + l] += (v as i16 as i32) * ylo + (v >> 16) * yhi;
                }
            }
        }
    }
    for (c, col) in acc.iter().enumerate() {
        out[c * ld..c * ld + q * GROUP16].iter_mut().zip(col).for_each(|(o, &v)| *o = (v as f64).mul_add(s, *o));
    }
}

/// The four bytes of a lane, unsigned.
fn bytes_u(v: i32) -> [i32; 4] {
    v.to_le_bytes().map(|b| b as i32)
}

/// The four bytes of a lane, signed.
fn bytes_s(v: i32) -> [i32; 4] {
    v.to_le_bytes().map(|b| b as i8 as i32)
}

/// out[c * ld + r] += s * sum_j sum_b (k[r][4j+b] rr[c][4j+b] + k[c][4j+b] rr[r][4j+b]) for the
/// (16 q) x 8 tile (q <= 3), summed exactly in i32 (ak, ar: q packed groups of 16; bk, br: 8
/// lanes a step, `bs` lanes apart).
#[allow(clippy::too_many_arguments)]
fn tile_u8_cross_portable(q: usize, [ak, ar, bk, br]: [&[i32]; 4], bs: usize, kcq: usize, out: &mut [f64], ld: usize, s: f64) {
    let bl = (kcq.max(1) - 1) * bs + GROUP;
    assert!(q <= 3 && ak.len() >= q * GROUP16 * kcq && ar.len() >= q * GROUP16 * kcq && bk.len() >= bl && br.len() >= bl);
    assert!(out.len() >= 7 * ld + q * GROUP16);
    let mut acc = [[0i32; MR16]; GROUP];
    for j in 0..kcq {
        for c in 0..GROUP {
            let (kq, rq) = (bytes_u(bk[j * bs + c]), bytes_s(br[j * bs + c]));
            for q in 0..q {
                for l in 0..GROUP16 {
                    let i = q * GROUP16 * kcq + j * GROUP16 + l;
                    let (kp, rp) = (bytes_u(ak[i]), bytes_s(ar[i]));
                    acc[c][q * GROUP16 + l] += (0..4).map(|b| kp[b] * rq[b] + kq[b] * rp[b]).sum::<i32>();
                }
            }
        }
    }
    for (c, col) in acc.iter().enumerate() {
        out[c * ld..c * ld + q * GROUP16].iter_mut().zip(col).for_each(|(o, &v)| *o = (v as f64).mul_add(s, *o));
    }
}

/// out[c * ld + r] += sum_k a[r][k] b[c][k] for the (8 Q) x 8 tile (a: Q packed groups, b: one);
/// Q = 3 is the 24 x 8 tile, 1 and 2 finish a column of tiles that is not a multiple of 24 rows.
#[inline]
pub(super) fn tile<const Q: usize>(level: Level, a: &[f64], b: &[f64], kc: usize, out: &mut [f64], ld: usize) {
    debug_assert!(a.len() == Q * GROUP * kc && b.len() == GROUP * kc && out.len() >= 7 * ld + Q * GROUP);
    match level {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: Level::Avx512 is only constructed when avx512f is detected (SyrkAcc::with_level
        // checks), and the slices have the lengths the kernel reads and writes (asserted there).
        Level::Avx512 => unsafe { x86::tile_avx512::<Q>(a, b, kc, out, ld) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: Level::Avx2 is only constructed when avx2 and fma are detected.
        Level::Avx2 => unsafe { x86::tile_avx2::<Q>(a, b, kc, out, ld) },
        _ => tile_portable::<Q>(a, b, kc, out, ld),
    }
}

/// The portable micro-kernel: the tile as 8 x 4 sub-tiles (few enough accumulators for 16
/// registers); per element the same fused operations in the same order as the AVX-512 kernel.
#[inline(always)]
fn tile_portable<const Q: usize>(a: &[f64], b: &[f64], kc: usize, out: &mut [f64], ld: usize) {
    for q in 0..Q {
        let aq = &a[q * GROUP * kc..(q + 1) * GROUP * kc];
        for h in 0..2 {
            let mut acc = [[0f64; GROUP]; 4];
            for (x, y) in aq.chunks_exact(GROUP).zip(b.chunks_exact(GROUP)) {
                for c in 0..4 {
                    let yc = y[h * 4 + c];
                    for l in 0..GROUP {
                        acc[c][l] = x[l].mul_add(yc, acc[c][l]);
                    }
                }
            }
            for c in 0..4 {
                let o = &mut out[(h * 4 + c) * ld + q * GROUP..(h * 4 + c) * ld + (q + 1) * GROUP];
                o.iter_mut().zip(&acc[c]).for_each(|(o, &v)| *o += v);
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
// Register tiles index several arrays (accumulators, loaded vectors) by the same loop variables.
#[allow(clippy::needless_range_loop)]
mod x86 {
    use super::{tile_portable, GROUP, GROUP16, MR16};
    use std::arch::x86_64::*;

    /// The 8-bit micro-kernel: 24 accumulators of 16 i32 lanes (zmm0-23) for the 48 x 8 tile,
    /// per step pair three loads of `a` (zmm24-26), eight 32-bit broadcasts of `b` (8 lanes a
    /// step, `bs` lanes apart) and 24 `vpdpwssd`. Written in assembly because the compiler, unable to commute `vpdpwssd`'s
    /// accumulator operand, spilled half the accumulators to the stack (2.3x slower).
    ///
    /// # Safety
    /// The CPU must support AVX-512F and AVX-512 VNNI.
    #[target_feature(enable = "avx512f,avx512vnni")]
    pub unsafe fn tile_u8_vnni(a: &[i32], b: &[i32], bs: usize, kcp: usize, out: &mut [f64], ld: usize, s: f64) {
        assert!(a.len() >= 3 * GROUP16 * kcp && b.len() >= (kcp.max(1) - 1) * bs + GROUP && out.len() >= 7 * ld + MR16);
        let mut acc = [_mm512_setzero_si512(); 24];
        if kcp > 0 {
            // zmm(3c + q) accumulates rows 16q..16q + 16 of column c.
            core::arch::asm!(
                "2:",
                "vmovdqu32 zmm24, [{a}]",
                "vmovdqu32 zmm25, [{a} + {g}]",
                "vmovdqu32 zmm26, [{a} + {g} * 2]",
                "vpbroadcastd zmm27, dword ptr [{b}]",
                "vpdpwssd zmm0, zmm24, zmm27",
                "vpdpwssd zmm1, zmm25, zmm27",
                "vpdpwssd zmm2, zmm26, zmm27",
                "vpbroadcastd zmm28, dword ptr [{b} + 4]",
                "vpdpwssd zmm3, zmm24, zmm28",
                "vpdpwssd zmm4, zmm25, zmm28",
                "vpdpwssd zmm5, zmm26, zmm28",
                "vpbroadcastd zmm27, dword ptr [{b} + 8]",
                "vpdpwssd zmm6, zmm24, zmm27",
                "vpdpwssd zmm7, zmm25, zmm27",
                "vpdpwssd zmm8, zmm26, zmm27",
                "vpbroadcastd zmm28, dword ptr [{b} + 12]",
                "vpdpwssd zmm9, zmm24, zmm28",
                "vpdpwssd zmm10, zmm25, zmm28",
                "vpdpwssd zmm11, zmm26, zmm28",
                "vpbroadcastd zmm27, dword ptr [{b} + 16]",
                "vpdpwssd zmm12, zmm24, zmm27",
                "vpdpwssd zmm13, zmm25, zmm27",
                "vpdpwssd zmm14, zmm26, zmm27",
                "vpbroadcastd zmm28, dword ptr [{b} + 20]",
                "vpdpwssd zmm15, zmm24, zmm28",
                "vpdpwssd zmm16, zmm25, zmm28",
                "vpdpwssd zmm17, zmm26, zmm28",
                "vpbroadcastd zmm27, dword ptr [{b} + 24]",
                "vpdpwssd zmm18, zmm24, zmm27",
                "vpdpwssd zmm19, zmm25, zmm27",
                "vpdpwssd zmm20, zmm26, zmm27",
                "vpbroadcastd zmm28, dword ptr [{b} + 28]",
                "vpdpwssd zmm21, zmm24, zmm28",
                "vpdpwssd zmm22, zmm25, zmm28",
                "vpdpwssd zmm23, zmm26, zmm28",
                "add {a}, 64",
                "add {b}, {bs}",
                "dec {n}",
                "jnz 2b",
                a = inout(reg) a.as_ptr() => _,
                b = inout(reg) b.as_ptr() => _,
                n = inout(reg) kcp => _,
                g = in(reg) 4 * GROUP16 * kcp,
                bs = in(reg) 4 * bs,
                inout("zmm0") acc[0], inout("zmm1") acc[1], inout("zmm2") acc[2], inout("zmm3") acc[3],
                inout("zmm4") acc[4], inout("zmm5") acc[5], inout("zmm6") acc[6], inout("zmm7") acc[7],
                inout("zmm8") acc[8], inout("zmm9") acc[9], inout("zmm10") acc[10], inout("zmm11") acc[11],
                inout("zmm12") acc[12], inout("zmm13") acc[13], inout("zmm14") acc[14], inout("zmm15") acc[15],
                inout("zmm16") acc[16], inout("zmm17") acc[17], inout("zmm18") acc[18], inout("zmm19") acc[19],
                inout("zmm20") acc[20], inout("zmm21") acc[21], inout("zmm22") acc[22], inout("zmm23") acc[23],
                out("zmm24") _, out("zmm25") _, out("zmm26") _, out("zmm27") _, out("zmm28") _,
                options(nostack, readonly),
            );
        }
        flush(&acc, out, ld, s);
    }

    /// [`tile_u8_vnni`] for a (16 Q) x 8 tile, Q = 1 or 2 (where a 48-row tile would reach
    /// above the diagonal or into padding rows only): few enough accumulators for intrinsics.
    ///
    /// # Safety
    /// The CPU must support AVX-512F and AVX-512 VNNI.
    #[target_feature(enable = "avx512f,avx512vnni")]
    pub unsafe fn tile_u8_vnni_q<const Q: usize>(a: &[i32], b: &[i32], bs: usize, kcp: usize, out: &mut [f64], ld: usize, s: f64) {
        assert!(Q <= 2 && a.len() >= Q * GROUP16 * kcp && b.len() >= (kcp.max(1) - 1) * bs + GROUP && out.len() >= 7 * ld + Q * GROUP16);
        let (ap, bp, ga) = (a.as_ptr(), b.as_ptr(), GROUP16 * kcp);
        let mut acc = [[_mm512_setzero_si512(); Q]; GROUP];
        for j in 0..kcp {
            let x: [__m512i; Q] = std::array::from_fn(|q| _mm512_loadu_si512(ap.add(q * ga + j * GROUP16) as *const _));
            for (c, acc) in acc.iter_mut().enumerate() {
                let y = _mm512_set1_epi32(*bp.add(j * bs + c));
                for q in 0..Q {
                    acc[q] = _mm512_dpwssd_epi32(acc[q], x[q], y);
                }
            }
        }
        flush_q(&acc, out, ld, s);
    }

    /// [`tile_u8_cross_vnni`] for a (16 Q) x 8 tile, Q = 1 or 2.
    ///
    /// # Safety
    /// The CPU must support AVX-512F and AVX-512 VNNI.
    #[target_feature(enable = "avx512f,avx512vnni")]
    pub unsafe fn tile_u8_cross_vnni_q<const Q: usize>([ak, ar, bk, br]: [&[i32]; 4], bs: usize, kcq: usize, out: &mut [f64], ld: usize, s: f64) {
        let bl = (kcq.max(1) - 1) * bs + GROUP;
        assert!(Q <= 2 && ak.len() >= Q * GROUP16 * kcq && ar.len() >= Q * GROUP16 * kcq && bk.len() >= bl && br.len() >= bl);
        assert!(out.len() >= 7 * ld + Q * GROUP16);
        let ga = GROUP16 * kcq;
        let mut acc = [[_mm512_setzero_si512(); Q]; GROUP];
        for j in 0..kcq {
            let xk: [__m512i; Q] = std::array::from_fn(|q| _mm512_loadu_si512(ak.as_ptr().add(q * ga + j * GROUP16) as *const _));
            let xr: [__m512i; Q] = std::array::from_fn(|q| _mm512_loadu_si512(ar.as_ptr().add(q * ga + j * GROUP16) as *const _));
            for (c, acc) in acc.iter_mut().enumerate() {
                let (kc, rc) = (_mm512_set1_epi32(*bk.as_ptr().add(j * bs + c)), _mm512_set1_epi32(*br.as_ptr().add(j * bs + c)));
                for q in 0..Q {
                    acc[q] = _mm512_dpbusd_epi32(_mm512_dpbusd_epi32(acc[q], xk[q], rc), kc, xr[q]);
                }
            }
        }
        flush_q(&acc, out, ld, s);
    }

    /// out += s * acc for a (16 Q) x 8 tile (`acc[c][q]`: rows 16q.. of column c).
    #[target_feature(enable = "avx512f")]
    unsafe fn flush_q<const Q: usize>(acc: &[[__m512i; Q]; GROUP], out: &mut [f64], ld: usize, s: f64) {
        assert!(out.len() >= 7 * ld + Q * GROUP16);
        let (o, sv) = (out.as_mut_ptr(), _mm512_set1_pd(s));
        for (c, col) in acc.iter().enumerate() {
            for (q, &v) in col.iter().enumerate() {
                let p = o.add(c * ld + q * GROUP16);
                let lo = _mm512_cvtepi32_pd(_mm512_castsi512_si256(v));
                let hi = _mm512_cvtepi32_pd(_mm512_extracti64x4_epi64::<1>(v));
                _mm512_storeu_pd(p, _mm512_fmadd_pd(lo, sv, _mm512_loadu_pd(p)));
                _mm512_storeu_pd(p.add(8), _mm512_fmadd_pd(hi, sv, _mm512_loadu_pd(p.add(8))));
            }
        }
    }

    /// out += s * acc for the 48 x 8 tile (`acc[3c + q]`: rows 16q.. of column c), one fused
    /// multiply-add per element, as the portable kernels do.
    #[target_feature(enable = "avx512f")]
    unsafe fn flush(acc: &[__m512i; 24], out: &mut [f64], ld: usize, s: f64) {
        assert!(out.len() >= 7 * ld + MR16);
        let (o, sv) = (out.as_mut_ptr(), _mm512_set1_pd(s));
        for c in 0..8 {
            for q in 0..3 {
                let v = acc[3 * c + q];
                let p = o.add(c * ld + q * GROUP16);
                let lo = _mm512_cvtepi32_pd(_mm512_castsi512_si256(v));
                let hi = _mm512_cvtepi32_pd(_mm512_extracti64x4_epi64::<1>(v));
                _mm512_storeu_pd(p, _mm512_fmadd_pd(lo, sv, _mm512_loadu_pd(p)));
                _mm512_storeu_pd(p.add(8), _mm512_fmadd_pd(hi, sv, _mm512_loadu_pd(p.add(8))));
            }
        }
    }

    /// The cross micro-kernel for the 48 x 8 tile: per step quad three loads each of `ak` (u8
    /// levels, zmm24-26) and `ar` (i8, zmm27-29); per column c, 3 `vpdpbusd` of the row levels
    /// with the column's r broadcast from memory, and 3 of the column's levels (broadcast into
    /// zmm30/31) with the rows' r, into zmm(3c + q).
    ///
    /// # Safety
    /// The CPU must support AVX-512F and AVX-512 VNNI.
    #[target_feature(enable = "avx512f,avx512vnni")]
    pub unsafe fn tile_u8_cross_vnni([ak, ar, bk, br]: [&[i32]; 4], bs: usize, kcq: usize, out: &mut [f64], ld: usize, s: f64) {
        let bl = (kcq.max(1) - 1) * bs + GROUP;
        assert!(ak.len() >= 3 * GROUP16 * kcq && ar.len() >= 3 * GROUP16 * kcq && bk.len() >= bl && br.len() >= bl);
        assert!(out.len() >= 7 * ld + MR16);
        let mut acc = [_mm512_setzero_si512(); 24];
        if kcq > 0 {
            core::arch::asm!(
                "2:",
                "vmovdqu32 zmm24, [{ak}]",
                "vmovdqu32 zmm25, [{ak} + {g}]",
                "vmovdqu32 zmm26, [{ak} + {g} * 2]",
                "vmovdqu32 zmm27, [{ar}]",
                "vmovdqu32 zmm28, [{ar} + {g}]",
                "vmovdqu32 zmm29, [{ar} + {g} * 2]",
                "vpbroadcastd zmm30, dword ptr [{bk}]",
                "vpdpbusd zmm0, zmm24, dword ptr [{br}]{{1to16}}",
                "vpdpbusd zmm1, zmm25, dword ptr [{br}]{{1to16}}",
                "vpdpbusd zmm2, zmm26, dword ptr [{br}]{{1to16}}",
                "vpdpbusd zmm0, zmm30, zmm27",
                "vpdpbusd zmm1, zmm30, zmm28",
                "vpdpbusd zmm2, zmm30, zmm29",
                "vpbroadcastd zmm31, dword ptr [{bk} + 4]",
                "vpdpbusd zmm3, zmm24, dword ptr [{br} + 4]{{1to16}}",
                "vpdpbusd zmm4, zmm25, dword ptr [{br} + 4]{{1to16}}",
                "vpdpbusd zmm5, zmm26, dword ptr [{br} + 4]{{1to16}}",
                "vpdpbusd zmm3, zmm31, zmm27",
                "vpdpbusd zmm4, zmm31, zmm28",
                "vpdpbusd zmm5, zmm31, zmm29",
                "vpbroadcastd zmm30, dword ptr [{bk} + 8]",
                "vpdpbusd zmm6, zmm24, dword ptr [{br} + 8]{{1to16}}",
                "vpdpbusd zmm7, zmm25, dword ptr [{br} + 8]{{1to16}}",
                "vpdpbusd zmm8, zmm26, dword ptr [{br} + 8]{{1to16}}",
                "vpdpbusd zmm6, zmm30, zmm27",
                "vpdpbusd zmm7, zmm30, zmm28",
                "vpdpbusd zmm8, zmm30, zmm29",
                "vpbroadcastd zmm31, dword ptr [{bk} + 12]",
                "vpdpbusd zmm9, zmm24, dword ptr [{br} + 12]{{1to16}}",
                "vpdpbusd zmm10, zmm25, dword ptr [{br} + 12]{{1to16}}",
                "vpdpbusd zmm11, zmm26, dword ptr [{br} + 12]{{1to16}}",
                "vpdpbusd zmm9, zmm31, zmm27",
                "vpdpbusd zmm10, zmm31, zmm28",
                "vpdpbusd zmm11, zmm31, zmm29",
                "vpbroadcastd zmm30, dword ptr [{bk} + 16]",
                "vpdpbusd zmm12, zmm24, dword ptr [{br} + 16]{{1to16}}",
                "vpdpbusd zmm13, zmm25, dword ptr [{br} + 16]{{1to16}}",
                "vpdpbusd zmm14, zmm26, dword ptr [{br} + 16]{{1to16}}",
                "vpdpbusd zmm12, zmm30, zmm27",
                "vpdpbusd zmm13, zmm30, zmm28",
                "vpdpbusd zmm14, zmm30, zmm29",
                "vpbroadcastd zmm31, dword ptr [{bk} + 20]",
                "vpdpbusd zmm15, zmm24, dword ptr [{br} + 20]{{1to16}}",
                "vpdpbusd zmm16, zmm25, dword ptr [{br} + 20]{{1to16}}",
                "vpdpbusd zmm17, zmm26, dword ptr [{br} + 20]{{1to16}}",
                "vpdpbusd zmm15, zmm31, zmm27",
                "vpdpbusd zmm16, zmm31, zmm28",
                "vpdpbusd zmm17, zmm31, zmm29",
                "vpbroadcastd zmm30, dword ptr [{bk} + 24]",
                "vpdpbusd zmm18, zmm24, dword ptr [{br} + 24]{{1to16}}",
                "vpdpbusd zmm19, zmm25, dword ptr [{br} + 24]{{1to16}}",
                "vpdpbusd zmm20, zmm26, dword ptr [{br} + 24]{{1to16}}",
                "vpdpbusd zmm18, zmm30, zmm27",
                "vpdpbusd zmm19, zmm30, zmm28",
                "vpdpbusd zmm20, zmm30, zmm29",
                "vpbroadcastd zmm31, dword ptr [{bk} + 28]",
                "vpdpbusd zmm21, zmm24, dword ptr [{br} + 28]{{1to16}}",
                "vpdpbusd zmm22, zmm25, dword ptr [{br} + 28]{{1to16}}",
                "vpdpbusd zmm23, zmm26, dword ptr [{br} + 28]{{1to16}}",
                "vpdpbusd zmm21, zmm31, zmm27",
                "vpdpbusd zmm22, zmm31, zmm28",
                "vpdpbusd zmm23, zmm31, zmm29",
                "add {ak}, 64",
                "add {ar}, 64",
                "add {bk}, {bs}",
                "add {br}, {bs}",
                "dec {n}",
                "jnz 2b",
                ak = inout(reg) ak.as_ptr() => _,
                ar = inout(reg) ar.as_ptr() => _,
                bk = inout(reg) bk.as_ptr() => _,
                br = inout(reg) br.as_ptr() => _,
                n = inout(reg) kcq => _,
                g = in(reg) 4 * GROUP16 * kcq,
                bs = in(reg) 4 * bs,
                inout("zmm0") acc[0], inout("zmm1") acc[1], inout("zmm2") acc[2], inout("zmm3") acc[3],
                inout("zmm4") acc[4], inout("zmm5") acc[5], inout("zmm6") acc[6], inout("zmm7") acc[7],
                inout("zmm8") acc[8], inout("zmm9") acc[9], inout("zmm10") acc[10], inout("zmm11") acc[11],
                inout("zmm12") acc[12], inout("zmm13") acc[13], inout("zmm14") acc[14], inout("zmm15") acc[15],
                inout("zmm16") acc[16], inout("zmm17") acc[17], inout("zmm18") acc[18], inout("zmm19") acc[19],
                inout("zmm20") acc[20], inout("zmm21") acc[21], inout("zmm22") acc[22], inout("zmm23") acc[23],
                out("zmm24") _, out("zmm25") _, out("zmm26") _, out("zmm27") _,
                out("zmm28") _, out("zmm29") _, out("zmm30") _, out("zmm31") _,
                options(nostack, readonly),
            );
        }
        flush(&acc, out, ld, s);
    }

    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[target_feature(enable = "avx2,fma")]
    pub unsafe fn tile_avx2<const Q: usize>(a: &[f64], b: &[f64], kc: usize, out: &mut [f64], ld: usize) {
        tile_portable::<Q>(a, b, kc, out, ld)
    }

    /// The (8 Q) x 8 tile: 8 Q accumulators, per step Q loads and 8 broadcasts. The tile's
    /// lines of C are prefetched first, so that they arrive while the sums run.
    ///
    /// # Safety
    /// The CPU must support AVX-512F; `a` holds Q * 8 * kc values, `b` 8 * kc, `out` 7 * ld + 8 Q.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn tile_avx512<const Q: usize>(a: &[f64], b: &[f64], kc: usize, out: &mut [f64], ld: usize) {
        assert!(a.len() >= Q * GROUP * kc && b.len() >= GROUP * kc && out.len() >= 7 * ld + Q * GROUP);
        let (a0, b0, o) = (a.as_ptr(), b.as_ptr(), out.as_mut_ptr());
        for c in 0..8 {
            for q in 0..Q {
                _mm_prefetch::<_MM_HINT_T0>(o.add(c * ld + q * 8) as *const i8);
            }
        }
        let mut acc = [[_mm512_setzero_pd(); 8]; Q];
        for k in 0..kc {
            let mut x = [_mm512_setzero_pd(); Q];
            for q in 0..Q {
                x[q] = _mm512_loadu_pd(a0.add(q * GROUP * kc + k * 8));
            }
            for c in 0..8 {
                let y = _mm512_set1_pd(*b0.add(k * 8 + c));
                for q in 0..Q {
                    acc[q][c] = _mm512_fmadd_pd(x[q], y, acc[q][c]);
                }
            }
        }
        for c in 0..8 {
            for q in 0..Q {
                let p = o.add(c * ld + q * 8);
                _mm512_storeu_pd(p, _mm512_add_pd(_mm512_loadu_pd(p), acc[q][c]));
            }
        }
    }
}

/// Reduction steps per packed f64 panel of the streaming X^T X (measured: 256 beats 128).
pub const KC: usize = 256;

#[cfg(test)]
mod tests {
    use super::super::test_data::{data, reference};
    use super::*;

    #[test]
    fn column_panels_accumulate_xtx() {
        // C = X^T X over blocks of rows, against the reference on X^T.
        let (n, m) = (70, 29);
        let x = data(n, m);
        let mut xt = vec![0f32; n * m];
        for i in 0..n {
            for p in 0..m {
                xt[p * n + i] = x[i * m + p];
            }
        }
        let want = reference(&xt, m, n);
        let mut acc = SyrkAcc::new(m);
        for rows in [0..32, 32..64, 64..70] {
            let kc = rows.len();
            let mut panel = vec![0.0; padded(m) * kc];
            pack_columns(&mut panel, &x[rows.start * m..rows.end * m], kc, m, None);
            acc.update(&panel, kc);
        }
        let c = acc.into_matrix();
        for i in 0..m {
            for j in 0..m {
                assert!((c[(i, j)] - want[i * m + j]).abs() <= 1e-12 * want[i * m + j].abs().max(1.0));
            }
        }
    }
    /// The 8-bit kernel sums exactly: against an integer reference, on the VNNI and portable
    /// kernels (same bits), with odd step counts and sizes that are not multiples of 16 or 48.
    #[test]
    fn u8_panels_accumulate_exact_integer_xtx() {
        for &(n, m, kc) in &[(1usize, 1usize, 1usize), (7, 5, 3), (70, 29, 31), (300, 100, 64), (130, 200, 129)] {
            let x: Vec<u8> = (0..n * m).map(|i| ((i * 2654435761usize) >> 7) as u8).collect();
            let mut want = vec![0i64; m * m];
            for i in 0..n {
                for p in 0..m {
                    for q in 0..m {
                        want[p * m + q] += x[i * m + p] as i64 * x[i * m + q] as i64;
                    }
                }
            }
            let accs = [SyrkAcc::new(m), SyrkAcc::new(m).without_vnni()];
            let mut got = Vec::new();
            for mut acc in accs {
                let mut r0 = 0;
                while r0 < n {
                    let k = kc.min(n - r0);
                    let kcp = k.div_ceil(2);
                    let (mut a, mut b) = (vec![0; padded(m) * kcp], vec![0; padded(m) * kcp]);
                    pack_pairs_u8(&mut a, &mut b, &x[r0 * m..(r0 + k) * m], k, m);
                    acc.update_u8(&a, &b, kcp, 1.0);
                    r0 += k;
                }
                let c = acc.into_lower(1.0);
                assert_lower_is(&c, &want, m, &format!("n {n} m {m} kc {kc}"));
                got.push(c);
            }
            assert!(got[0] == got[1]);
        }
    }

    /// The cross kernel: s * sum (k_p r_q + r_p k_q) exactly, VNNI and portable the same bits,
    /// on top of what C already holds.
    #[test]
    fn u8_cross_panels_accumulate_exact_integer_sums() {
        let mut r = [0i8; 256];
        r.iter_mut().enumerate().for_each(|(k, v)| *v = ((k * 97 + 13) % 255) as i32 as i8);
        r[7] = -127;
        r[200] = 127;
        for &(n, m, kc) in &[(1usize, 1usize, 1usize), (7, 5, 3), (70, 29, 31), (300, 100, 64), (130, 200, 129)] {
            let x: Vec<u8> = (0..n * m).map(|i| ((i * 2654435761usize) >> 9) as u8).collect();
            let mut want = vec![0i64; m * m];
            for i in 0..n {
                for p in 0..m {
                    for q in 0..m {
                        let (kp, kq) = (x[i * m + p] as i64, x[i * m + q] as i64);
                        want[p * m + q] += kp * r[kq as usize] as i64 + r[kp as usize] as i64 * kq;
                    }
                }
            }
            let mut got = Vec::new();
            for mut acc in [SyrkAcc::new(m), SyrkAcc::new(m).without_vnni()] {
                acc.scale(0.0);
                let mut r0 = 0;
                while r0 < n {
                    let k = kc.min(n - r0);
                    let len = padded(m) * k.div_ceil(4);
                    let mut v = [vec![0; len], vec![0; len], vec![0; len], vec![0; len]];
                    let [ak, ar, bk, br] = &mut v;
                    pack_quads_u8(ak, ar, bk, br, &x[r0 * m..(r0 + k) * m], k, m, &r);
                    acc.update_u8_cross(ak, ar, bk, br, k.div_ceil(4), 0.5);
                    r0 += k;
                }
                let c = acc.into_lower(2.0);
                assert_lower_is(&c, &want, m, &format!("n {n} m {m} kc {kc}"));
                got.push(c);
            }
            assert!(got[0] == got[1]);
        }
    }

    /// `c` (column-major lower triangle, zero above) holds the exact integer sums `want`
    /// (row-major, m x m) below and on the diagonal.
    fn assert_lower_is(c: &[f64], want: &[i64], m: usize, what: &str) {
        for p in 0..m {
            for q in 0..m {
                let w = if p >= q { want[p * m + q] as f64 } else { 0.0 };
                assert_eq!(c[q * m + p], w, "{what} ({p},{q})");
            }
        }
    }

    #[test]
    fn scale_and_into_lower_agree_with_into_matrix() {
        let (n, m) = (40, 37);
        let x = data(n, m);
        let mut panel = vec![0.0; padded(m) * n];
        pack_columns(&mut panel, &x, n, m, None);
        let (mut a, mut b) = (SyrkAcc::new(m), SyrkAcc::new(m));
        a.update(&panel, n);
        b.update(&panel, n);
        a.scale(0.5);
        let full = b.into_matrix();
        let lower = a.into_lower(2.0);
        for j in 0..m {
            for i in 0..m {
                assert_eq!(lower[j * m + i], if i >= j { full[(i, j)] } else { 0.0 });
            }
        }
    }
}
