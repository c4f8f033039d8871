//! The symmetric rank-k update C += P P^T, lower triangle, f64: what builds the Gram matrix
//! G = X X^T (P = X, rows are images) and, streaming, X^T X (P = X^T, rows are pixels).
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

use super::Level;
use faer::Mat;
use rayon::prelude::*;

/// Rows of P per packed group (one AVX-512 register of f64).
pub const GROUP: usize = 8;
/// Rows of a micro-tile (three groups).
const MR: usize = 24;
/// Most rows of C per band (one rayon task): 192 rows x 256 steps of the band's micro-panels
/// (384 KiB) stay in L2.
const BAND: usize = 192;

/// Rows per band for an n-row C: at least 8 bands so two to eight threads balance, at most BAND.
fn band_rows(np: usize) -> usize {
    (np / 8).div_ceil(MR).clamp(1, BAND / MR) * MR
}

/// Number of rows a packed panel has for `n` rows of P: padded with zero rows to a multiple of 24.
pub fn padded(n: usize) -> usize {
    n.div_ceil(MR) * MR
}

/// Packs rows `0..n` of P, steps `k0..k0 + kc`, into `dst` (whole groups of 8 rows, at least
/// n rows; rows past n are zero), on the calling thread. `read(i, k0, out)` writes row i's `out.len()` values from step k0.
pub fn pack_rows(dst: &mut [f64], n: usize, kc: usize, k0: usize, read: impl Fn(usize, usize, &mut [f64])) {
    assert!(dst.len() % (GROUP * kc) == 0 && dst.len() >= n * kc, "packed panel size");
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
            for l in 0..GROUP {
                let p = p0 + l;
                o[l] = if p < m { block[k * m + p] as f64 - mean.map_or(0.0, |u| u[p]) } else { 0.0 };
            }
        }
    });
}

/// One band of C's rows: `rows` rows from `r0`, columns `0..r0 + rows`, stored column by
/// column (`buf[c * rows + r - r0]`).
struct Band {
    r0: usize,
    rows: usize,
    buf: Vec<f64>,
}

/// The lower triangle of C = sum of P P^T over the panels given to [`SyrkAcc::update`].
pub struct SyrkAcc {
    n: usize,
    bands: Vec<Band>,
    level: Level,
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
        let br = band_rows(np);
        let bands = (0..np)
            .step_by(br)
            .map(|r0| {
                let rows = br.min(np - r0);
                Band { r0, rows, buf: vec![0.0; rows * (r0 + rows)] }
            })
            .collect();
        SyrkAcc { n, bands, level }
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
        let n = self.n;
        let mut c = Mat::<f64>::zeros(n, n);
        for band in self.bands {
            for col in 0..(band.r0 + band.rows).min(n) {
                let src = &band.buf[col * band.rows..(col + 1) * band.rows];
                for (rl, &v) in src.iter().enumerate() {
                    let r = band.r0 + rl;
                    if r >= col && r < n {
                        c[(r, col)] = v;
                    }
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
            tile(level, a, b, kc, out, ld);
        }
    }
}

/// out[c * ld + r] += sum_k a[r][k] b[c][k] for the 24 x 8 tile (a: three packed groups, b: one).
#[inline]
fn tile(level: Level, a: &[f64], b: &[f64], kc: usize, out: &mut [f64], ld: usize) {
    debug_assert!(a.len() == 3 * GROUP * kc && b.len() == GROUP * kc && out.len() == 7 * ld + MR);
    match level {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: Level::Avx512 is only constructed when avx512f is detected (SyrkAcc::with_level
        // checks), and the slices have the lengths the kernel reads and writes (asserted above).
        Level::Avx512 => unsafe { x86::tile_avx512(a, b, kc, out, ld) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: Level::Avx2 is only constructed when avx2 and fma are detected.
        Level::Avx2 => unsafe { x86::tile_avx2(a, b, kc, out, ld) },
        _ => tile_portable(a, b, kc, out, ld),
    }
}

/// The portable micro-kernel: the 24 x 8 tile as six 8 x 4 sub-tiles (few enough accumulators
/// for 16 registers); per element the same fused operations in the same order as the AVX-512
/// kernel.
#[inline(always)]
fn tile_portable(a: &[f64], b: &[f64], kc: usize, out: &mut [f64], ld: usize) {
    for q in 0..3 {
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
mod x86 {
    use super::{tile_portable, GROUP};
    use std::arch::x86_64::*;

    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[target_feature(enable = "avx2,fma")]
    pub unsafe fn tile_avx2(a: &[f64], b: &[f64], kc: usize, out: &mut [f64], ld: usize) {
        tile_portable(a, b, kc, out, ld)
    }

    /// # Safety
    /// The CPU must support AVX-512F; `a` holds 3 * 8 * kc values, `b` 8 * kc, `out` 7 * ld + 24.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn tile_avx512(a: &[f64], b: &[f64], kc: usize, out: &mut [f64], ld: usize) {
        assert!(a.len() >= 3 * GROUP * kc && b.len() >= GROUP * kc && out.len() >= 7 * ld + 24);
        let (a0, b0) = (a.as_ptr(), b.as_ptr());
        let (a1, a2) = (a0.add(GROUP * kc), a0.add(2 * GROUP * kc));
        let mut acc = [[_mm512_setzero_pd(); 8]; 3];
        for k in 0..kc {
            let x = [_mm512_loadu_pd(a0.add(k * 8)), _mm512_loadu_pd(a1.add(k * 8)), _mm512_loadu_pd(a2.add(k * 8))];
            for c in 0..8 {
                let y = _mm512_set1_pd(*b0.add(k * 8 + c));
                for q in 0..3 {
                    acc[q][c] = _mm512_fmadd_pd(x[q], y, acc[q][c]);
                }
            }
        }
        let o = out.as_mut_ptr();
        for c in 0..8 {
            for q in 0..3 {
                let p = o.add(c * ld + q * 8);
                _mm512_storeu_pd(p, _mm512_add_pd(_mm512_loadu_pd(p), acc[q][c]));
            }
        }
    }
}

/// G = X X^T for `n` rows of `m` values read by `read(i, k0, out)` (row i from column k0), in
/// panels of [`KC`] columns.
pub fn gram_rows(n: usize, m: usize, read: impl Fn(usize, usize, &mut [f64]) + Sync) -> Mat<f64> {
    gram_rows_with(n, m, Level::detect(), read)
}

/// Reduction steps per packed panel (measured: 256 beats 128; a panel of 222 rows is 480 KiB,
/// so it is packed and used while in L2).
pub const KC: usize = 256;

/// [`gram_rows`] with a given SIMD level. Each panel is packed (in parallel over row groups)
/// just before it is used, while it is still in cache.
pub fn gram_rows_with(n: usize, m: usize, level: Level, read: impl Fn(usize, usize, &mut [f64]) + Sync) -> Mat<f64> {
    let np = padded(n);
    let mut acc = SyrkAcc::with_level(n, level);
    let mut buf = vec![0f64; np * KC.min(m)];
    let mut k0 = 0;
    while k0 < m {
        let kc = KC.min(m - k0);
        let panel = &mut buf[..np * kc];
        panel.par_chunks_mut(GROUP * kc).enumerate().for_each(|(g, p)| {
            let rows = (n.saturating_sub(g * GROUP)).min(GROUP);
            pack_rows(p, rows, kc, k0, |i, k0, out| read(g * GROUP + i, k0, out));
        });
        acc.update(panel, kc);
        k0 += kc;
    }
    acc.into_matrix()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data(n: usize, m: usize) -> Vec<f32> {
        (0..n * m).map(|i| ((i * 2654435761usize) % 1009) as f32 / 1009.0 - 0.3).collect()
    }

    fn reference(x: &[f32], n: usize, m: usize) -> Vec<f64> {
        let mut g = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                g[i * n + j] = (0..m).map(|k| x[i * m + k] as f64 * x[j * m + k] as f64).sum();
            }
        }
        g
    }

    #[test]
    fn gram_matches_reference_on_every_path_and_paths_agree_bitwise() {
        for &(n, m) in &[(1, 3), (5, 37), (30, 300), (200, 600)] {
            let x = data(n, m);
            let want = reference(&x, n, m);
            let mut first: Option<Mat<f64>> = None;
            for level in Level::supported() {
                let g = gram_rows_with(n, m, level, |i, k0, out| {
                    out.iter_mut().zip(&x[i * m + k0..]).for_each(|(o, &v)| *o = v as f64)
                });
                for i in 0..n {
                    for j in 0..n {
                        let w = want[i * n + j];
                        assert!((g[(i, j)] - w).abs() <= 1e-13 * (m as f64) * w.abs().max(1.0), "{level:?} n {n} ({i},{j})");
                        assert_eq!(g[(i, j)].to_bits(), g[(j, i)].to_bits());
                    }
                }
                if let Some(f) = &first {
                    assert!(f.as_ref() == g.as_ref(), "{level:?} differs from the first path at n {n}");
                } else {
                    first = Some(g);
                }
            }
        }
    }

    #[test]
    fn result_does_not_depend_on_the_thread_count() {
        let (n, m) = (250, 520);
        let x = data(n, m);
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| gram_rows(n, m, |i, k0, out| out.iter_mut().zip(&x[i * m + k0..]).for_each(|(o, &v)| *o = v as f64)))
        };
        assert!(run(1).as_ref() == run(3).as_ref());
    }

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
}
