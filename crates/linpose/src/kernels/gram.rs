//! The Gram matrix G = X X^T of N rows of M values (one image a row): its lower triangle summed
//! by the f64 micro-kernel of [`super::syrk`] (P = X), for the in-memory fit of features that
//! are not 8-bit (or are centred); uncentred 8-bit features take [`super::gram8`].
//!
//! M is cut into panels of [`KC`] steps. Each panel's rows are packed into groups of 8 (one
//! AVX-512 register holds 8 rows at one step; f32 rows are converted and transposed 8 x 8 in
//! registers by [`pack_group_f32`]), then the triangle is updated tile by tile: for each tile of
//! 24 rows, 8 columns at a time (its rows stay in L1, the columns stream from L2, a third of the
//! traffic of the other order); where the columns cross the diagonal only the rows from it are
//! computed, so only the 8 x 8 diagonal blocks compute values above it. The triangle is stored
//! as bands of rows, split into work items of one band and at most [`COLS`] columns, of about
//! equal cost, so that the threads stay balanced; the next panel is packed while one is used.
//!
//! Few images (N = 222 has about 50 tiles of 24 x 8 per column of panels) leave too little
//! output to share, so M is also split: [`chunks`] consecutive runs of panels are summed into
//! partial Grams, in parallel, and added in order (as much memory again per partial, so the
//! count is capped by [`PARTIALS_BYTES`]).
//!
//! Summation order: every element of a partial is, for each of its panels in order, its value
//! plus a sequential fused multiply-add sum over the panel's steps started from zero (as in
//! [`super::syrk`]); G is ((C_0 + C_1) + C_2) + ... The chunks depend on N and M only, so the
//! result has the same bits whatever the thread count, tile split or SIMD path; it differs from
//! a one-chunk sum by rounding only (tested).

use super::gram8::gram_levels;
use super::syrk::{bands_into_matrix, tile, zero_bands, Band, GROUP};
use super::tuning::gram::{BAND, COLS, KC, MAX_CHUNKS, MIN_PANELS, PARTIALS_BYTES};
use super::Level;
use faer::Mat;
use rayon::prelude::*;

/// Rows of C computed for n rows of X: n padded with zero rows to whole groups.
fn padded8(n: usize) -> usize {
    n.div_ceil(GROUP) * GROUP
}

/// How many partial Grams (chunks of M) to sum for n rows of m values: as many as fit in
/// [`PARTIALS_BYTES`], up to [`MAX_CHUNKS`], with at least [`MIN_PANELS`] panels each. A
/// function of n and m only, never of the thread count.
pub(crate) fn chunks(n: usize, m: usize) -> usize {
    let bytes = Acc::new(n).len() * 8;
    let by_memory = 1 + PARTIALS_BYTES / bytes.max(1);
    (m.div_ceil(KC) / MIN_PANELS).min(by_memory).clamp(1, MAX_CHUNKS)
}

/// The lower triangle of a Gram matrix, in bands.
struct Acc {
    n: usize,
    bands: Vec<Band>,
}

impl Acc {
    fn new(n: usize) -> Self {
        Acc { n, bands: zero_bands(padded8(n), BAND) }
    }

    /// Values stored.
    fn len(&self) -> usize {
        self.bands.iter().map(|b| b.buf.len()).sum()
    }

    /// C += P P^T for one packed panel of `kc` steps (`padded8(n) * kc` values), in parallel
    /// over items of one band and at most [`COLS`] columns.
    fn update(&mut self, panel: &[f64], kc: usize, level: Level) {
        let items: Vec<(usize, usize, usize, &mut [f64])> = self
            .bands
            .iter_mut()
            .flat_map(|b| {
                let (r0, rows) = (b.r0, b.rows);
                b.buf.chunks_mut(COLS * rows).enumerate().map(move |(j, out)| (r0, rows, j * COLS, out))
            })
            .collect();
        items.into_par_iter().for_each(|(r0, rows, c0, out)| item_update(r0, rows, c0, out, panel, kc, level));
    }

    /// C += other, element by element.
    fn add(&mut self, other: &Acc) {
        self.bands.par_iter_mut().zip(&other.bands).for_each(|(b, o)| b.buf.iter_mut().zip(&o.buf).for_each(|(v, &w)| *v += w));
    }

    /// The full symmetric n x n matrix (the lower triangle mirrored).
    fn into_matrix(self) -> Mat<f64> {
        bands_into_matrix(self.n, self.bands)
    }
}

/// Columns `c0..` of one band (`out`, leading dimension `rows`): for each tile of 24 rows (the
/// last 8 or 16), its 8 columns at a time; in the columns that cross the diagonal only the rows
/// from it. A tile's rows of the panel (24 x kc) stay in L1 while the columns stream from L2.
fn item_update(r0: usize, rows: usize, c0: usize, out: &mut [f64], panel: &[f64], kc: usize, level: Level) {
    let gs = GROUP * kc;
    let (c1, end) = (c0 + out.len() / rows, r0 + rows);
    for r in (r0..end).step_by(3 * GROUP) {
        let re = (r + 3 * GROUP).min(end);
        for c in (c0..c1.min(re)).step_by(GROUP) {
            let rs = r.max(c);
            let q = (re - rs) / GROUP;
            let (a, b) = (&panel[(rs / GROUP) * gs..(rs / GROUP + q) * gs], &panel[(c / GROUP) * gs..(c / GROUP + 1) * gs]);
            let o = &mut out[(c - c0) * rows + rs - r0..(c - c0 + GROUP - 1) * rows + rs - r0 + q * GROUP];
            match q {
                3 => tile::<3>(level, a, b, kc, o, rows),
                2 => tile::<2>(level, a, b, kc, o, rows),
                _ => tile::<1>(level, a, b, kc, o, rows),
            }
        }
    }
}

/// G = X X^T for `n` rows of `m` values: `pack(panel, k0, kc)` fills `panel` (`padded8(n) * kc`
/// values, groups of 8 rows, zero rows past n) with steps `k0..k0 + kc`. `chunks` partial Grams
/// (see the module doc).
fn gram_with(n: usize, m: usize, level: Level, chunks: usize, pack: impl Fn(&mut [f64], usize, usize) + Sync) -> Mat<f64> {
    let np = padded8(n);
    let panels = m.div_ceil(KC);
    let chunks = chunks.clamp(1, panels.max(1));
    let mut partials: Vec<Acc> = (0..chunks)
        .into_par_iter()
        .map(|s| {
            let mut acc = Acc::new(n);
            let (mut cur, mut next) = (vec![0f64; np * KC.min(m)], vec![0f64; np * KC.min(m)]);
            let steps = |p: usize| (p * KC, KC.min(m - p * KC));
            let (first, last) = (s * panels / chunks, (s + 1) * panels / chunks);
            if first < last {
                let (k0, kc) = steps(first);
                pack(&mut cur[..np * kc], k0, kc);
            }
            // Each panel is updated while the next is packed, in one fork-join.
            for p in first..last {
                let kc = steps(p).1;
                rayon::join(
                    || acc.update(&cur[..np * kc], kc, level),
                    || {
                        if p + 1 < last {
                            let (k0, kc) = steps(p + 1);
                            pack(&mut next[..np * kc], k0, kc);
                        }
                    },
                );
                std::mem::swap(&mut cur, &mut next);
            }
            acc
        })
        .collect();
    let rest = partials.split_off(1.min(partials.len()));
    let mut acc = partials.pop().unwrap_or_else(|| Acc::new(n));
    for other in &rest {
        acc.add(other);
    }
    acc.into_matrix()
}

/// G = X X^T for `n` rows of `m` values read by `read(i, k0, out)` (row i from column k0).
pub(crate) fn gram_rows(n: usize, m: usize, read: impl Fn(usize, usize, &mut [f64]) + Sync) -> Mat<f64> {
    gram_with(n, m, Level::detect(), chunks(n, m), |panel, k0, kc| {
        panel.par_chunks_mut(GROUP * kc).enumerate().for_each(|(g, p)| {
            let rows = n.saturating_sub(g * GROUP).min(GROUP);
            super::syrk::pack_rows(p, rows, kc, k0, |i, k0, out| read(g * GROUP + i, k0, out));
        })
    })
}

/// G = X X^T for `n` row-major f32 rows of `m` values, each minus `mean` when given (the f64
/// difference of the f32 value converted, as the f64 paths compute it). Uncentred 8-bit
/// features go to [`gram_levels`] (exact integer sums) where the CPU has AVX-512 VNNI,
/// everything else to the f64 kernel ([`gram_f32_fma`]).
pub(crate) fn gram_f32(x: &[f32], n: usize, m: usize, mean: Option<&[f64]>) -> Mat<f64> {
    if mean.is_none() {
        if let Some(g) = gram_levels(x, n, m) {
            return g;
        }
    }
    gram_f32_fma(x, n, m, mean)
}

/// `gram_f32` by the f64 kernel whatever the values.
#[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
pub fn gram_f32_fma(x: &[f32], n: usize, m: usize, mean: Option<&[f64]>) -> Mat<f64> {
    gram_f32_with(x, n, m, mean, Level::detect(), chunks(n, m))
}

fn gram_f32_with(x: &[f32], n: usize, m: usize, mean: Option<&[f64]>, level: Level, chunks: usize) -> Mat<f64> {
    assert_eq!(x.len(), n * m, "feature rows size");
    assert!(mean.is_none_or(|u| u.len() == m), "mean row size");
    gram_with(n, m, level, chunks, |panel, k0, kc| {
        panel.par_chunks_mut(GROUP * kc).enumerate().for_each(|(g, p)| pack_group_f32(p, x, Group { n, m, i0: g * GROUP, k0, kc }, mean, level))
    })
}

/// Where a packed group lies: rows `i0..i0 + 8` of a row-major matrix of `n` rows of `m` values
/// (rows past `n` packed as zeros), steps `k0..k0 + kc`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Group {
    pub n: usize,
    pub m: usize,
    pub i0: usize,
    pub k0: usize,
    pub kc: usize,
}

impl Group {
    /// The group's rows inside the matrix (at most 8).
    #[inline]
    fn rows(self) -> usize {
        self.n.saturating_sub(self.i0).min(GROUP)
    }
}

/// Packs the group `at` of the f32 matrix `x` (rows `i0..i0 + 8`, rows past n zero, steps
/// `k0..k0 + kc`), each value minus `mean` when given, into `out` (`8 * kc`: step k's 8 rows at
/// `out[8 k..]`).
pub(crate) fn pack_group_f32(out: &mut [f64], x: &[f32], at: Group, mean: Option<&[f64]>, level: Level) {
    let Group { n, m, i0, k0, kc } = at;
    assert!(out.len() == GROUP * kc && k0 + kc <= m && x.len() >= n * m, "packed group size");
    let rows = at.rows();
    let mut done = 0;
    #[cfg(target_arch = "x86_64")]
    if level.avx512() {
        // SAFETY: the level is a token of detection that found AVX-512F; the kernel reads rows
        // i0..i0 + rows, steps k0..k0 + kc (inside x, asserted) and writes out[..8 * (kc - kc % 8)].
        unsafe { x86::pack_group_f32_avx512(out, x, at, mean) };
        done = kc - kc % GROUP;
    } else if level.avx2() {
        // SAFETY: the level is a token of detection that found AVX2; the kernel reads rows
        // i0..i0 + rows, steps k0..k0 + kc (inside x, asserted) and writes out[..8 * (kc - kc % 4)].
        unsafe { x86::pack_group_f32_avx2(out, x, at, mean) };
        done = kc - kc % 4;
    }
    let _ = level;
    for k in done..kc {
        for l in 0..GROUP {
            out[k * GROUP + l] = if l < rows {
                let v = x[(i0 + l) * m + k0 + k] as f64;
                mean.map_or(v, |u| v - u[k0 + k])
            } else {
                0.0
            };
        }
    }
}

/// [`gram_f32_fma`] of the features of `n` rows of `m` 8-bit values (`feature_of_u8` of
/// each), packed from the bytes, with the same bits: where the 8-bit integer Gram is not to
/// be had (no AVX-512 VNNI), the fit need not make the f32 features first (a pass writing four
/// times the bytes, then reading them back to pack).
pub(crate) fn gram_u8_fma(pixels: &[u8], n: usize, m: usize) -> Mat<f64> {
    gram_u8_with(pixels, n, m, Level::detect(), chunks(n, m))
}

fn gram_u8_with(pixels: &[u8], n: usize, m: usize, level: Level, chunks: usize) -> Mat<f64> {
    assert_eq!(pixels.len(), n * m, "8-bit rows size");
    gram_with(n, m, level, chunks, |panel, k0, kc| {
        panel.par_chunks_mut(GROUP * kc).enumerate().for_each(|(g, p)| pack_group_u8(p, pixels, Group { n, m, i0: g * GROUP, k0, kc }, level))
    })
}

/// [`pack_group_f32`] of the features of 8-bit rows: each value k packed as the f64 of the
/// f32 feature k * S8 (the same single f32 product as `feature_of_u8`, so the same bits).
fn pack_group_u8(out: &mut [f64], px: &[u8], at: Group, level: Level) {
    let Group { n, m, i0, k0, kc } = at;
    assert!(out.len() == GROUP * kc && k0 + kc <= m && px.len() >= n * m, "packed group size");
    let rows = at.rows();
    let mut done = 0;
    #[cfg(target_arch = "x86_64")]
    if level.avx2() {
        // SAFETY: the level is a token of detection that found AVX2 (AVX-512 levels include
        // it); the kernel reads rows i0..i0 + rows, steps k0..k0 + kc (inside px, asserted) and
        // writes out[..8 * (kc - kc % 4)].
        unsafe { x86::pack_group_u8_avx2(out, px, at) };
        done = kc - kc % 4;
    }
    let _ = level;
    for k in done..kc {
        for l in 0..GROUP {
            out[k * GROUP + l] = if l < rows { crate::kernels::levels::feature_of_u8(px[(i0 + l) * m + k0 + k]) as f64 } else { 0.0 };
        }
    }
}

/// G = X X^T for the f64 rows `rows` (one image each, at least `m` values), by the f64 kernel.
/// The same bits as [`gram_rows`] on the same values; the rows are packed 8 at a time by an
/// AVX-512 transpose where the level has it ([`pack_group_f64`]).
pub(crate) fn gram_f64(rows: &[&[f64]], m: usize) -> Mat<f64> {
    let (n, level) = (rows.len(), Level::detect());
    assert!(rows.iter().all(|r| r.len() >= m), "rows of m values");
    gram_with(n, m, level, chunks(n, m), |panel, k0, kc| {
        panel.par_chunks_mut(GROUP * kc).enumerate().for_each(|(g, p)| pack_group_f64(p, &rows[(g * GROUP).min(n)..(g * GROUP + GROUP).min(n)], k0, kc, level))
    })
}

/// Packs the rows `rows` (at most 8; the rest of the group zero), steps `k0..k0 + kc`, into
/// `out` (`8 * kc`: step k's 8 rows at `out[8 k..]`).
pub(crate) fn pack_group_f64(out: &mut [f64], rows: &[&[f64]], k0: usize, kc: usize, level: Level) {
    assert!(out.len() == GROUP * kc && rows.len() <= GROUP && rows.iter().all(|r| r.len() >= k0 + kc), "packed group size");
    let mut done = 0;
    #[cfg(target_arch = "x86_64")]
    if level.avx512() {
        // SAFETY: the level is a token of detection that found AVX-512F; the kernel asserts the
        // lengths it reads and writes.
        unsafe { x86::pack_group_f64_avx512(out, rows, k0, kc) };
        done = kc - kc % GROUP;
    }
    let _ = level;
    for k in done..kc {
        for l in 0..GROUP {
            out[k * GROUP + l] = rows.get(l).map_or(0.0, |r| r[k0 + k]);
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{Group, GROUP};
    use std::arch::x86_64::*;

    /// Stores the 8 x 8 transpose of `r` (row l's 8 steps in `r[l]`) at `o`: step j's 8 rows at
    /// `o[8 j..]`. Pairs of rows are unpacked, then quads and halves permuted.
    ///
    /// # Safety
    /// The CPU must support AVX-512F (this is inlined into kernels that enable it); `o` must be
    /// valid for writes of 64 values.
    #[inline(always)]
    unsafe fn store_transposed(r: &[__m512d; 8], o: *mut f64) {
        let lo2 = _mm512_setr_epi64(0, 1, 8, 9, 4, 5, 12, 13);
        let hi2 = _mm512_setr_epi64(2, 3, 10, 11, 6, 7, 14, 15);
        let lo4 = _mm512_setr_epi64(0, 1, 2, 3, 8, 9, 10, 11);
        let hi4 = _mm512_setr_epi64(4, 5, 6, 7, 12, 13, 14, 15);
        // t[2j] = (r[2j][0], r[2j+1][0], r[2j][2], r[2j+1][2], ..), t[2j+1] the odd steps.
        let t = [
            _mm512_unpacklo_pd(r[0], r[1]),
            _mm512_unpackhi_pd(r[0], r[1]),
            _mm512_unpacklo_pd(r[2], r[3]),
            _mm512_unpackhi_pd(r[2], r[3]),
            _mm512_unpacklo_pd(r[4], r[5]),
            _mm512_unpackhi_pd(r[4], r[5]),
            _mm512_unpacklo_pd(r[6], r[7]),
            _mm512_unpackhi_pd(r[6], r[7]),
        ];
        // u: rows 0-3 at steps (0, 4), (1, 5), (2, 6), (3, 7); v: rows 4-7.
        let u = [
            _mm512_permutex2var_pd(t[0], lo2, t[2]),
            _mm512_permutex2var_pd(t[1], lo2, t[3]),
            _mm512_permutex2var_pd(t[0], hi2, t[2]),
            _mm512_permutex2var_pd(t[1], hi2, t[3]),
        ];
        let v = [
            _mm512_permutex2var_pd(t[4], lo2, t[6]),
            _mm512_permutex2var_pd(t[5], lo2, t[7]),
            _mm512_permutex2var_pd(t[4], hi2, t[6]),
            _mm512_permutex2var_pd(t[5], hi2, t[7]),
        ];
        for j in 0..4 {
            _mm512_storeu_pd(o.add(j * GROUP), _mm512_permutex2var_pd(u[j], lo4, v[j]));
            _mm512_storeu_pd(o.add((j + 4) * GROUP), _mm512_permutex2var_pd(u[j], hi4, v[j]));
        }
    }

    /// Steps `0..kc - kc % 8` of [`super::pack_group_f32`]: per 8 steps, 8 row vectors
    /// converted (and the mean subtracted), transposed in registers, stored as 8 steps.
    ///
    /// # Safety
    /// The CPU must support AVX-512F; rows `i0..i0 + rows` of `x` (row length m) must hold steps
    /// `k0..k0 + kc`, `out` 8 * kc values and `mean` (when given) m.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn pack_group_f32_avx512(out: &mut [f64], x: &[f32], at: Group, mean: Option<&[f64]>) {
        let (Group { m, i0, k0, kc, .. }, rows) = (at, at.rows());
        assert!(out.len() >= GROUP * kc && rows <= GROUP && (rows == 0 || (i0 + rows - 1) * m + k0 + kc <= x.len()));
        assert!(mean.is_none_or(|u| u.len() >= k0 + kc));
        let (xp, o) = (x.as_ptr(), out.as_mut_ptr());
        for k in (0..kc - kc % GROUP).step_by(GROUP) {
            let mut r = [_mm512_setzero_pd(); 8];
            let mu = mean.map(|u| _mm512_loadu_pd(u.as_ptr().add(k0 + k)));
            if k % 16 == 0 {
                // The rows' lines 8 ahead (into the next panel at the end): a group reads 8
                // rows far apart, short runs each, which the hardware prefetchers miss.
                for l in 0..rows {
                    _mm_prefetch::<_MM_HINT_T0>(xp.wrapping_add((i0 + l) * m + k0 + k + 128) as *const i8);
                }
            }
            for (l, rl) in r.iter_mut().enumerate().take(rows) {
                let v = _mm512_cvtps_pd(_mm256_loadu_ps(xp.add((i0 + l) * m + k0 + k)));
                *rl = match mu {
                    Some(u) => _mm512_sub_pd(v, u),
                    None => v,
                };
            }
            store_transposed(&r, o.add(k * GROUP));
        }
    }

    /// Steps `0..kc - kc % 4` of [`super::pack_group_f32`] on AVX2: per 4 steps, each row's 4
    /// values converted (and the mean subtracted), then rows 0-3 and 4-7 transposed 4 x 4 in
    /// registers and stored as 4 steps of 8 rows. The compiler's code for the scalar loop had
    /// cost COIL-20's linear fit about a tenth of its time on an AVX2 machine.
    ///
    /// # Safety
    /// The CPU must support AVX2; rows `i0..i0 + rows` of `x` (row length m) must hold steps
    /// `k0..k0 + kc`, `out` 8 * kc values and `mean` (when given) m.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn pack_group_f32_avx2(out: &mut [f64], x: &[f32], at: Group, mean: Option<&[f64]>) {
        let (Group { m, i0, k0, kc, .. }, rows) = (at, at.rows());
        assert!(out.len() >= GROUP * kc && rows <= GROUP && (rows == 0 || (i0 + rows - 1) * m + k0 + kc <= x.len()));
        assert!(mean.is_none_or(|u| u.len() >= k0 + kc));
        let (xp, o) = (x.as_ptr(), out.as_mut_ptr());
        for k in (0..kc - kc % 4).step_by(4) {
            let mut r = [_mm256_setzero_pd(); 8];
            let mu = mean.map(|u| _mm256_loadu_pd(u.as_ptr().add(k0 + k)));
            for (l, rl) in r.iter_mut().enumerate().take(rows) {
                let v = _mm256_cvtps_pd(_mm_loadu_ps(xp.add((i0 + l) * m + k0 + k)));
                *rl = match mu {
                    Some(u) => _mm256_sub_pd(v, u),
                    None => v,
                };
            }
            store_steps_avx2(&r, o.add(k * GROUP));
        }
    }

    /// Stores 4 steps of 8 rows (`r[l]`: row l's 4 values) at `o` (step j's 8 rows at
    /// `o[8 j..]`): rows 0-3 and 4-7 transposed 4 x 4 in registers.
    ///
    /// # Safety
    /// The CPU must support AVX2; `o` must be valid for 32 values.
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn store_steps_avx2(r: &[__m256d; 8], o: *mut f64) {
        for (h, q) in r.chunks_exact(4).enumerate() {
            let (t0, t1) = (_mm256_unpacklo_pd(q[0], q[1]), _mm256_unpackhi_pd(q[0], q[1]));
            let (t2, t3) = (_mm256_unpacklo_pd(q[2], q[3]), _mm256_unpackhi_pd(q[2], q[3]));
            let steps = [
                _mm256_permute2f128_pd::<0x20>(t0, t2),
                _mm256_permute2f128_pd::<0x20>(t1, t3),
                _mm256_permute2f128_pd::<0x31>(t0, t2),
                _mm256_permute2f128_pd::<0x31>(t1, t3),
            ];
            for (j, v) in steps.into_iter().enumerate() {
                _mm256_storeu_pd(o.add(j * GROUP + 4 * h), v);
            }
        }
    }

    /// Steps `0..kc - kc % 4` of [`super::pack_group_u8`] on AVX2: per 4 steps, each row's 4
    /// bytes widened, converted and multiplied by S8 in f32 (the feature's one rounding), then
    /// to f64 and transposed by [`store_steps_avx2`].
    ///
    /// # Safety
    /// The CPU must support AVX2; rows `i0..i0 + rows` of `px` (row length m) must hold steps
    /// `k0..k0 + kc` and `out` 8 * kc values.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn pack_group_u8_avx2(out: &mut [f64], px: &[u8], at: Group) {
        let (Group { m, i0, k0, kc, .. }, rows) = (at, at.rows());
        assert!(out.len() >= GROUP * kc && rows <= GROUP && (rows == 0 || (i0 + rows - 1) * m + k0 + kc <= px.len()));
        let (xp, o) = (px.as_ptr(), out.as_mut_ptr());
        let s8 = _mm_set1_ps(crate::kernels::levels::S8);
        for k in (0..kc - kc % 4).step_by(4) {
            let mut r = [_mm256_setzero_pd(); 8];
            for (l, rl) in r.iter_mut().enumerate().take(rows) {
                let b = _mm_cvtsi32_si128(std::ptr::read_unaligned(xp.add((i0 + l) * m + k0 + k) as *const i32));
                *rl = _mm256_cvtps_pd(_mm_mul_ps(_mm_cvtepi32_ps(_mm_cvtepu8_epi32(b)), s8));
            }
            store_steps_avx2(&r, o.add(k * GROUP));
        }
    }

    /// Steps `0..kc - kc % 8` of [`super::pack_group_f64`]: per 8 steps, 8 row vectors
    /// transposed in registers, stored as 8 steps.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn pack_group_f64_avx512(out: &mut [f64], rows: &[&[f64]], k0: usize, kc: usize) {
        assert!(out.len() >= GROUP * kc && rows.len() <= GROUP && rows.iter().all(|r| r.len() >= k0 + kc));
        let o = out.as_mut_ptr();
        for k in (0..kc - kc % GROUP).step_by(GROUP) {
            let mut r = [_mm512_setzero_pd(); 8];
            // As in pack_group_f32_avx512: the rows' lines 8 ahead (one line a row a step).
            for row in rows {
                _mm_prefetch::<_MM_HINT_T0>(row.as_ptr().wrapping_add(k0 + k + 64) as *const i8);
            }
            for (rl, row) in r.iter_mut().zip(rows) {
                *rl = _mm512_loadu_pd(row.as_ptr().add(k0 + k));
            }
            store_transposed(&r, o.add(k * GROUP));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_data::{data, reference};
    use super::*;

    fn read(x: &[f32], m: usize) -> impl Fn(usize, usize, &mut [f64]) + Sync + '_ {
        move |i, k0, out| out.iter_mut().zip(&x[i * m + k0..]).for_each(|(o, &v)| *o = v as f64)
    }

    /// Sizes that are and are not multiples of 8, 24 and the band, with one and several panels.
    const SIZES: [(usize, usize); 6] = [(1, 3), (5, 37), (13, 300), (40, 260), (200, 600), (250, 1100)];

    #[test]
    fn gram_matches_reference_on_every_path_and_paths_agree_bitwise() {
        for &(n, m) in &SIZES {
            let x = data(n, m);
            let want = reference(&x, n, m);
            let mut first: Option<Mat<f64>> = None;
            for level in Level::supported() {
                let g = gram_with(n, m, level, chunks(n, m), |panel, k0, kc| {
                    for (g, p) in panel.chunks_mut(GROUP * kc).enumerate() {
                        super::super::syrk::pack_rows(p, n.saturating_sub(g * GROUP).min(GROUP), kc, k0, |i, k0, out| read(&x, m)(g * GROUP + i, k0, out));
                    }
                });
                for i in 0..n {
                    for j in 0..n {
                        let w = want[i * n + j];
                        assert!((g[(i, j)] - w).abs() <= 1e-13 * (m as f64) * w.abs().max(1.0), "{level:?} n {n} ({i},{j})");
                        assert_eq!(g[(i, j)].to_bits(), g[(j, i)].to_bits());
                    }
                }
                // The f32 packing gives the same panels (so the same bits).
                assert!(gram_f32_with(&x, n, m, None, level, chunks(n, m)).as_ref() == g.as_ref(), "{level:?} n {n}: f32 packing");
                if let Some(f) = &first {
                    assert!(f.as_ref() == g.as_ref(), "{level:?} differs from the first path at n {n}");
                } else {
                    first = Some(g);
                }
            }
        }
    }

    #[test]
    fn bytes_give_the_bits_of_their_f32_features_on_every_level() {
        for &(n, m) in &SIZES {
            let px: Vec<u8> = (0..n * m).map(|i| ((i * 2654435761usize) % 256) as u8).collect();
            let x: Vec<f32> = px.iter().map(|&v| crate::kernels::levels::feature_of_u8(v)).collect();
            for level in Level::supported() {
                let want = gram_f32_with(&x, n, m, None, level, chunks(n, m));
                assert!(gram_u8_with(&px, n, m, level, chunks(n, m)).as_ref() == want.as_ref(), "{level:?} n {n} m {m}");
                // Every group and step split, the tails (kc % 4) included.
                for (k0, kc) in [(0, m), (m / 3, m - m / 3), (m - 1, 1), (1, m.min(7) - 1)] {
                    for g in 0..n.div_ceil(GROUP) + 1 {
                        let (mut got, mut want) = (vec![1.0; GROUP * kc], vec![1.0; GROUP * kc]);
                        pack_group_u8(&mut got, &px, Group { n, m, i0: g * GROUP, k0, kc }, level);
                        pack_group_f32(&mut want, &x, Group { n, m, i0: g * GROUP, k0, kc }, None, level);
                        assert!(got.iter().zip(&want).all(|(a, b)| a.to_bits() == b.to_bits()), "{level:?} group {g} k0 {k0} kc {kc}");
                    }
                }
            }
        }
    }

    #[test]
    fn f64_rows_give_the_bits_of_the_row_reader() {
        for &(n, m) in &SIZES {
            let x: Vec<f64> = data(n, m).iter().map(|&v| v as f64 * 1.3 - 0.01).collect();
            let rows: Vec<&[f64]> = x.chunks_exact(m).collect();
            let want = gram_rows(n, m, |i, k0, out| out.copy_from_slice(&x[i * m + k0..i * m + k0 + out.len()]));
            assert!(gram_f64(&rows, m).as_ref() == want.as_ref(), "n {n} m {m}");
            for level in Level::supported() {
                for (k0, kc) in [(0, m), (m / 3, m - m / 3), (m - 1, 1)] {
                    for g in 0..n.div_ceil(GROUP) + 1 {
                        let group = &rows[(g * GROUP).min(n)..(g * GROUP + GROUP).min(n)];
                        let (mut got, mut want) = (vec![1.0; GROUP * kc], vec![1.0; GROUP * kc]);
                        pack_group_f64(&mut got, group, k0, kc, level);
                        super::super::syrk::pack_rows(&mut want, group.len(), kc, k0, |i, k0, out| out.copy_from_slice(&group[i][k0..k0 + out.len()]));
                        assert!(got == want, "{level:?} group {g} steps {k0}+{kc}");
                    }
                }
            }
        }
    }

    #[test]
    fn f32_packing_matches_the_row_reader_with_a_mean() {
        let (n, m) = (21, 75);
        let x = data(n, m);
        let mu: Vec<f64> = (0..m).map(|k| (k as f64 * 0.37).sin() * 0.1).collect();
        for level in Level::supported() {
            for (k0, kc) in [(0, 75), (3, 64), (10, 13), (70, 5)] {
                for g in 0..n.div_ceil(GROUP) + 1 {
                    let (mut got, mut want) = (vec![1.0; GROUP * kc], vec![1.0; GROUP * kc]);
                    pack_group_f32(&mut got, &x, Group { n, m, i0: g * GROUP, k0, kc }, Some(&mu), level);
                    super::super::syrk::pack_rows(&mut want, n.saturating_sub(g * GROUP).min(GROUP), kc, k0, |i, k0, out| {
                        let row = &x[(g * GROUP + i) * m + k0..];
                        out.iter_mut().zip(row.iter().zip(&mu[k0..])).for_each(|(o, (&v, &u))| *o = v as f64 - u)
                    });
                    assert!(got == want, "{level:?} group {g} steps {k0}+{kc}");
                }
            }
        }
    }

    /// Partial Grams over chunks of M add up to the one-chunk Gram up to rounding (each element
    /// a sum of m products of f32 values, so relative 1e-12 is far above f64 rounding).
    #[test]
    fn split_m_matches_the_one_chunk_gram() {
        for &(n, m) in &[(30, 5000), (222, 2600)] {
            let x = data(n, m);
            let one = gram_f32_with(&x, n, m, None, Level::detect(), 1);
            for k in [2, 3, 8] {
                let split = gram_f32_with(&x, n, m, None, Level::detect(), k);
                let scale = (0..n).map(|i| one[(i, i)]).fold(0f64, f64::max);
                for j in 0..n {
                    for i in 0..n {
                        assert!((split[(i, j)] - one[(i, j)]).abs() <= 1e-12 * scale, "n {n} chunks {k} ({i},{j})");
                    }
                }
            }
        }
        assert_eq!(chunks(222, 19_200), MAX_CHUNKS);
        assert_eq!(chunks(2000, 19_200), 2);
    }

    #[test]
    fn result_does_not_depend_on_the_thread_count() {
        for (n, m) in [(250, 5200), (40, 3000)] {
            let x = data(n, m);
            assert!(chunks(n, m) > 1);
            let run = |threads| {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                pool.install(|| (gram_rows(n, m, read(&x, m)), gram_f32(&x, n, m, None)))
            };
            let (a, b) = (run(1), run(3));
            assert!(a.0.as_ref() == b.0.as_ref() && a.1.as_ref() == b.1.as_ref() && a.0.as_ref() == a.1.as_ref());
        }
    }
}
