//! The Gram matrix G = X X^T of 8-bit features (every value k * S8, see [`super::levels`]),
//! summed exactly in integers by the AVX-512 VNNI kernels of [`super::syrk`]: per panel of
//! 512 or 1024 pixels (`kc8`), [`SCALE_PAIRS`] times sum k_p k_q (`vpdpwssd` on pixel pairs) and
//! [`SCALE_CROSS`] times sum (k_p r_q + r_p k_q) (`vpdpbusd` on pixel quads). A VNNI
//! instruction does twice the f64 FMA's lanes, so where it issues at the FMA's rate the
//! triangle costs about half the f64 kernel's time ([`super::peak::vnni_gram_flops`] measures
//! that rate).
//!
//! Packing reads the rows once per panel: for each group of 16 images, 64 pixels at a time,
//! each row's values are turned into levels (f32 features checked: a value that is not an 8-bit
//! feature makes the whole Gram fall back to the f64 kernel; a data set's 8-bit values
//! ([`gram_u8`]) are levels already), residuals and 16-bit levels, and the
//! 16 x 16 blocks of 32-bit words are transposed so that one word holds one image's pixel pair
//! (or quad) and 16 images sit side by side, as the micro-kernels load them.
//!
//! The panels are split into runs (`chunks8`) summed into partial Grams, one per thread, and
//! added in order (at N = 222 a panel's triangle is too little work to share well at every
//! panel's fork-join). Where a 48-row tile would reach above the diagonal or into padding rows
//! only, the kernels compute 16 or 32 of its rows.
//!
//! Exactness and order: the integer tile sums are exact whatever the tile shape, and each
//! element of a partial gets one fused multiply-add per panel and pass, in panel order, so the
//! result has the same bits for any thread count and for the VNNI and portable kernels
//! (tested). It is the Gram of the f32 features up to the left-out r_p r_q term, about 1e-14
//! relative (tested against f64 sums).

use super::levels::{residuals, S8, SCALE_CROSS, SCALE_PAIRS};
use super::syrk::{padded, SyrkAcc, GROUP16, KCP_MAX, KCQ_MAX};
use super::tuning::gram8::{MAX_CHUNKS8, SMALL};
use super::Level;
use crate::kernels::Rows as Rows8;
use faer::Mat;
use rayon::prelude::*;

/// Pixels per panel: 512 for up to [`SMALL`] rows, 1024 above; an i32 lane of a tile then
/// sums at most 2 * 512 * 255^2 < 2^31. Shorter panels leave a small Gram more panels to share
/// between the partials, longer ones give a large Gram fewer passes over its triangle; chosen by
/// timing 256, 512 and 1024 at N = 222 and 2000 (M = 19,200), alternated.
fn kc8(n: usize) -> usize {
    if padded(n) <= SMALL {
        512
    } else {
        1024
    }
}

const _: () = assert!(1024 / 2 <= KCP_MAX && 1024 / 4 <= KCQ_MAX);

/// Pixels per packing chunk: one 16 x 16 block of quads (64 bytes a row).
const CHUNK: usize = 64;

/// G = X X^T for `n` row-major rows of `m` f32 values that are all 8-bit features, summed in
/// integers, on a CPU with AVX-512 VNNI; None otherwise (packing stops at the first panel with
/// a value that is not one).
#[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
pub fn gram_levels(x: &[f32], n: usize, m: usize) -> Option<Mat<f64>> {
    gram_rows8(Rows8::F32(x), n, m)
}

/// [`gram_levels`] of the features of `n` rows of `m` 8-bit values (`feature_of_u8` of each),
/// read from the bytes (a quarter of the features' memory traffic), with the same bits; None
/// on a CPU without AVX-512 VNNI.
pub(crate) fn gram_u8(pixels: &[u8], n: usize, m: usize) -> Option<Mat<f64>> {
    gram_rows8(Rows8::U8(pixels), n, m)
}

fn gram_rows8(x: Rows8, n: usize, m: usize) -> Option<Mat<f64>> {
    if !SyrkAcc::new(0).uses_vnni() {
        return None;
    }
    gram_levels_with(x, n, m, || SyrkAcc::new(n), Level::detect())
}

/// How many partial Grams (runs of consecutive panels) the 8-bit Gram sums: a function of n
/// and m only (never of the thread count), so the bits are too. At least 4 panels each, and
/// the extra partials within 16 MiB (N = 2000 takes one).
fn chunks8(n: usize, m: usize) -> usize {
    let bytes = padded(n) * padded(n) * 8;
    (m.div_ceil(kc8(n)) / 4).min(1 + (16 << 20) / bytes.max(1)).clamp(1, MAX_CHUNKS8)
}

/// The 8-bit Gram, packing with `level`; `acc()` makes a zero n x n accumulator.
fn gram_levels_with(x: Rows8, n: usize, m: usize, acc: impl Fn() -> SyrkAcc + Sync, level: Level) -> Option<Mat<f64>> {
    assert_eq!(x.len(), n * m, "feature rows size");
    let panels = m.div_ceil(kc8(n));
    let chunks = chunks8(n, m).min(panels.max(1));
    let parts: Vec<Option<SyrkAcc>> =
        (0..chunks).into_par_iter().map(|c| partial(x, n, m, c * panels / chunks..(c + 1) * panels / chunks, acc(), level)).collect();
    let mut parts = parts.into_iter();
    let mut sum = parts.next().flatten()?;
    for p in parts {
        sum.add(&p?);
    }
    Some(sum.into_matrix())
}

/// The sum over panels `panels` (in order) into `acc`; None when a value is not an 8-bit feature.
fn partial(x: Rows8, n: usize, m: usize, panels: std::ops::Range<usize>, mut acc: SyrkAcc, level: Level) -> Option<SyrkAcc> {
    let np = padded(n);
    let kc8 = kc8(n);
    let kc_max = kc8.min(m);
    let (lp, lq) = (np * kc_max.div_ceil(2), np * kc_max.div_ceil(4));
    let (mut pa, mut pk, mut pr) = (vec![0i32; lp], vec![0i32; lq], vec![0i32; lq]);
    for p in panels {
        let k0 = p * kc8;
        let kc = kc8.min(m - k0);
        let (kcp, kcq) = (kc.div_ceil(2), kc.div_ceil(4));
        let (a, ak, ar) = (&mut pa[..np * kcp], &mut pk[..np * kcq], &mut pr[..np * kcq]);
        if !pack_panel(x, Panel { n, m, k0, kc }, [a, ak, ar], level) {
            return None;
        }
        acc.update_u8_in_place(a, kcp, SCALE_PAIRS);
        acc.update_u8_cross_in_place(ak, ar, kcq, SCALE_CROSS);
    }
    Some(acc)
}

/// Pixels `k0..k0 + kc` of `n` rows of `m`: a panel of the rows.
#[derive(Debug, Clone, Copy)]
struct Panel {
    n: usize,
    m: usize,
    k0: usize,
    kc: usize,
}

/// Packs the panel `at` (pixels `k0..k0 + kc` of the `n` rows, padded with zero rows to [`padded`]`(n)`) in
/// groups of 16 rows, for [`SyrkAcc::update_u8_in_place`] (`a`: pixel pairs of levels) and
/// [`SyrkAcc::update_u8_cross_in_place`] (`ak`, `ar`: pixel quads of levels and residuals), in
/// parallel over the groups. False when a value is not an 8-bit feature.
fn pack_panel(x: Rows8, at: Panel, [a, ak, ar]: [&mut [i32]; 3], level: Level) -> bool {
    let Panel { n, m, k0, kc } = at;
    let (kcp, kcq) = (kc.div_ceil(2), kc.div_ceil(4));
    let np = padded(n);
    let r = residuals();
    assert!(k0 + kc <= m && x.len() == n * m, "panel inside the rows");
    assert!(a.len() == np * kcp && ak.len() == np * kcq && ar.len() == np * kcq, "packed panel size");
    a.par_chunks_mut(GROUP16 * kcp)
        .zip(ak.par_chunks_mut(GROUP16 * kcq).zip(ar.par_chunks_mut(GROUP16 * kcq)))
        .enumerate()
        .map(|(g, (a, (ak, ar)))| pack_group(x, at, g * GROUP16, [a, ak, ar], &r, level))
        .reduce(|| true, |p, q| p & q)
}

/// Rows `i0..i0 + 16` (past n zero) of the panel `at` (pixels `k0..k0 + kc`): `a[16 j + l]` holds row l's levels
/// of pixels 2j (low 16 bits) and 2j + 1, `ak[16 j + l]` / `ar[16 j + l]` its levels /
/// residuals (as bytes) of pixels 4j..4j + 4; pixels past kc are zero. False when a value is not
/// an 8-bit feature.
fn pack_group(x: Rows8, at: Panel, i0: usize, [a, ak, ar]: [&mut [i32]; 3], r: &[i8; 256], level: Level) -> bool {
    let Panel { n, m, k0, kc } = at;
    let rows = n.saturating_sub(i0).min(GROUP16);
    // One chunk of 64 pixels of the 16 rows: levels, residuals, 16-bit levels.
    let mut l8 = Words::default();
    let mut r8 = Words::default();
    let mut l16 = [Words::default(), Words::default()];
    let mut ok = true;
    for c0 in (0..kc).step_by(CHUNK) {
        let w = CHUNK.min(kc - c0);
        for l in 0..GROUP16 {
            let [w0, w1] = &mut l16;
            let out = [l8.bytes_mut(l), r8.bytes_mut(l), w0.bytes_mut(l), w1.bytes_mut(l)];
            if l < rows {
                let at = (i0 + l) * m + k0 + c0..(i0 + l) * m + k0 + c0 + w;
                ok &= match x {
                    Rows8::U8(px) => convert_u8(&px[at], out, r, level),
                    Rows8::F32(f) => convert(&f[at], out, r, level),
                };
            } else {
                out.into_iter().for_each(|o| o.fill(0));
            }
        }
        let (jq, jp) = (c0 / 4, c0 / 2);
        let (nq, np) = (w.div_ceil(4), w.div_ceil(2));
        transpose(&l8, &mut ak[jq * GROUP16..(jq + nq) * GROUP16], level);
        transpose(&r8, &mut ar[jq * GROUP16..(jq + nq) * GROUP16], level);
        transpose(&l16[0], &mut a[jp * GROUP16..(jp + np.min(16)) * GROUP16], level);
        if np > 16 {
            transpose(&l16[1], &mut a[(jp + 16) * GROUP16..(jp + np) * GROUP16], level);
        }
    }
    ok
}

/// 16 rows of 16 32-bit words (64 bytes a row), aligned for whole-vector loads.
#[derive(Default)]
#[repr(C, align(64))]
struct Words([[u32; 16]; 16]);

impl Words {
    /// Row `row` as its 64 bytes (little-endian words).
    fn bytes_mut(&mut self, row: usize) -> &mut [u8] {
        let row = &mut self.0[row];
        // SAFETY: [u32; 16] is 64 initialised bytes with no padding, and u8 has alignment 1.
        unsafe { std::slice::from_raw_parts_mut(row.as_mut_ptr() as *mut u8, 64) }
    }
}

/// Levels, residuals (as bytes) and 16-bit levels (little-endian, pixels 0..32 and 32..64) of
/// `src` (at most 64 values; the rest zero), into `[lv, rv, w0, w1]` (64 bytes each). False
/// when a value is not an 8-bit feature (its outputs are zero).
fn convert(src: &[f32], [lv, rv, w0, w1]: [&mut [u8]; 4], r: &[i8; 256], level: Level) -> bool {
    assert!(src.len() <= CHUNK && [&*lv, &*rv, &*w0, &*w1].iter().all(|o| o.len() == CHUNK));
    #[cfg(target_arch = "x86_64")]
    if level.avx512() && src.len() == CHUNK {
        // SAFETY: the level is a token of detection that found AVX-512 F and BW; src and every
        // output hold 64 values (asserted above).
        return unsafe { x86::convert_avx512(src, [lv, rv, w0, w1]) };
    }
    let _ = level;
    let mut ok = true;
    for j in 0..CHUNK {
        let k = src.get(j).map_or(Some(0), |&v| super::levels::level(v));
        ok &= k.is_some();
        let k = k.unwrap_or(0);
        (lv[j], rv[j]) = (k, r[k as usize] as u8);
        let w = if j < 32 { &mut w0[2 * j..2 * j + 2] } else { &mut w1[2 * j - 64..2 * j - 62] };
        w.copy_from_slice(&(k as u16).to_le_bytes());
    }
    ok
}

/// [`convert`] of the features of 8-bit values `src` (at most 64; each an 8-bit feature, so
/// always true): the same outputs.
fn convert_u8(src: &[u8], [lv, rv, w0, w1]: [&mut [u8]; 4], r: &[i8; 256], level: Level) -> bool {
    assert!(src.len() <= CHUNK && [&*lv, &*rv, &*w0, &*w1].iter().all(|o| o.len() == CHUNK));
    #[cfg(target_arch = "x86_64")]
    if level.avx512() && src.len() == CHUNK {
        // SAFETY: the level is a token of detection that found AVX-512 F and BW; src and every
        // output hold 64 values (asserted above).
        unsafe { x86::convert_u8_avx512(src, [lv, rv, w0, w1]) };
        return true;
    }
    let mut buf = [0f32; CHUNK];
    buf.iter_mut().zip(src).for_each(|(f, &v)| *f = crate::kernels::levels::feature_of_u8(v));
    convert(&buf[..src.len()], [lv, rv, w0, w1], r, level)
}

/// `out[16 j + l] = src[l][j]` for the first `out.len() / 16` words j of each row.
fn transpose(src: &Words, out: &mut [i32], level: Level) {
    let count = out.len() / GROUP16;
    assert!(count <= 16 && out.len() == count * GROUP16);
    #[cfg(target_arch = "x86_64")]
    if level.avx512() {
        // SAFETY: the level is a token of detection that found AVX-512F; out holds count * 16
        // words, count <= 16 (asserted above).
        unsafe { x86::transpose_avx512(src, out) };
        return;
    }
    let _ = level;
    for (j, o) in out.chunks_exact_mut(GROUP16).enumerate() {
        for (l, v) in o.iter_mut().enumerate() {
            *v = src.0[l][j] as i32;
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{Words, GROUP16, S8};
    use std::arch::x86_64::*;

    /// m = S8 2^31, the level's weight in V = k m + r.
    const M8: i32 = 8_421_505;

    /// [`super::convert_u8`] on 64 values: k the byte, r = V - k m with V = fl(k S8) 2^31.
    ///
    /// # Safety
    /// The CPU must support AVX-512 F and BW; `src` and every output must hold 64 values.
    #[target_feature(enable = "avx512f,avx512bw")]
    pub(super) unsafe fn convert_u8_avx512(src: &[u8], [lv, rv, w0, w1]: [&mut [u8]; 4]) {
        let (s8, two31, m8) = (_mm512_set1_ps(S8), _mm512_set1_ps(2147483648.0), _mm512_set1_epi32(M8));
        _mm_prefetch::<_MM_HINT_T0>(src.as_ptr().wrapping_add(2 * 64) as *const i8);
        let bytes = _mm512_loadu_si512(src.as_ptr() as *const __m512i);
        _mm512_storeu_si512(lv.as_mut_ptr() as *mut __m512i, bytes);
        _mm512_storeu_si512(w0.as_mut_ptr() as *mut __m512i, _mm512_cvtepu8_epi16(_mm512_castsi512_si256(bytes)));
        _mm512_storeu_si512(w1.as_mut_ptr() as *mut __m512i, _mm512_cvtepu8_epi16(_mm512_extracti64x4_epi64::<1>(bytes)));
        for q in 0..4 {
            let k = _mm512_cvtepu8_epi32(_mm_loadu_si128(src.as_ptr().add(16 * q) as *const __m128i));
            // The feature fl(k S8) as the reader makes it, then its integer V = v 2^31 (exact).
            let v = _mm512_mul_ps(_mm512_cvtepi32_ps(k), s8);
            let big = _mm512_cvttps_epu32(_mm512_mul_ps(v, two31));
            let r = _mm512_sub_epi32(big, _mm512_mullo_epi32(k, m8));
            _mm_storeu_si128(rv.as_mut_ptr().add(16 * q) as *mut __m128i, _mm512_cvtepi32_epi8(r));
        }
    }

    /// [`super::convert`] on 64 values: k = trunc(v 255 + 0.5), accepted when k <= 255 and
    /// k * S8 == v; r = V - k m with V = v 2^31 (an integer below 2^32 for every level).
    ///
    /// # Safety
    /// The CPU must support AVX-512F and BW; `src` and every output must hold 64 values.
    #[target_feature(enable = "avx512f,avx512bw")]
    pub(super) unsafe fn convert_avx512(src: &[f32], [lv, rv, w0, w1]: [&mut [u8]; 4]) -> bool {
        let (c255, half, s8, two31) = (_mm512_set1_ps(255.0), _mm512_set1_ps(0.5), _mm512_set1_ps(S8), _mm512_set1_ps(2147483648.0));
        let (top, m8) = (_mm512_set1_epi32(255), _mm512_set1_epi32(M8));
        let mut bad: __mmask16 = 0;
        for q in 0..4 {
            // The row's lines two chunks ahead (into the next panel at the end): a group reads
            // 16 rows far apart, 4 lines each, which the hardware prefetchers miss.
            _mm_prefetch::<_MM_HINT_T0>(src.as_ptr().wrapping_add(2 * 64 + 16 * q) as *const i8);
            let v = _mm512_loadu_ps(src.as_ptr().add(16 * q));
            let k = _mm512_cvttps_epi32(_mm512_add_ps(_mm512_mul_ps(v, c255), half));
            let back = _mm512_mul_ps(_mm512_cvtepi32_ps(k), s8);
            let good = _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(back, v) & _mm512_cmple_epu32_mask(k, top);
            bad |= !good;
            let k = _mm512_maskz_mov_epi32(good, k);
            let big = _mm512_cvttps_epu32(_mm512_mul_ps(v, two31));
            let r = _mm512_maskz_mov_epi32(good, _mm512_sub_epi32(big, _mm512_mullo_epi32(k, m8)));
            _mm_storeu_si128(lv.as_mut_ptr().add(16 * q) as *mut __m128i, _mm512_cvtepi32_epi8(k));
            _mm_storeu_si128(rv.as_mut_ptr().add(16 * q) as *mut __m128i, _mm512_cvtepi32_epi8(r));
            let w = if q < 2 { w0.as_mut_ptr().add(32 * q) } else { w1.as_mut_ptr().add(32 * (q - 2)) };
            _mm256_storeu_si256(w as *mut __m256i, _mm512_cvtepi32_epi16(k));
        }
        bad == 0
    }

    /// The 16 x 16 word transpose of `src`, its first `out.len() / 16` rows stored: 32-bit and
    /// 64-bit unpacks within 128-bit lanes, then two rounds of 128-bit lane shuffles.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn transpose_avx512(src: &Words, out: &mut [i32]) {
        let count = out.len() / GROUP16;
        assert!(count <= 16);
        let r: [__m512i; 16] = std::array::from_fn(|l| _mm512_load_si512(src.0[l].as_ptr() as *const _));
        // t[2i], t[2i + 1]: rows 2i, 2i + 1 interleaved (words 4q, 4q + 1 / 4q + 2, 4q + 3).
        let t: [__m512i; 16] = std::array::from_fn(|i| {
            let (x, y) = (r[i & !1], r[i | 1]);
            if i % 2 == 0 {
                _mm512_unpacklo_epi32(x, y)
            } else {
                _mm512_unpackhi_epi32(x, y)
            }
        });
        // u[4g + c], lane q: word 4q + c of rows 4g..4g + 4.
        let u: [__m512i; 16] = std::array::from_fn(|i| {
            let (g, c) = (i / 4, i % 4);
            let (x, y) = (t[4 * g + c / 2], t[4 * g + 2 + c / 2]);
            if c % 2 == 0 {
                _mm512_unpacklo_epi64(x, y)
            } else {
                _mm512_unpackhi_epi64(x, y)
            }
        });
        let o = out.as_mut_ptr();
        for c in 0..4 {
            let w0 = _mm512_shuffle_i32x4::<0x88>(u[c], u[4 + c]);
            let w1 = _mm512_shuffle_i32x4::<0xDD>(u[c], u[4 + c]);
            let w2 = _mm512_shuffle_i32x4::<0x88>(u[8 + c], u[12 + c]);
            let w3 = _mm512_shuffle_i32x4::<0xDD>(u[8 + c], u[12 + c]);
            // Word j = 4q + c of every row: q = 0, 2 from (w0, w2), q = 1, 3 from (w1, w3).
            for (q, v) in [
                (0, _mm512_shuffle_i32x4::<0x88>(w0, w2)),
                (2, _mm512_shuffle_i32x4::<0xDD>(w0, w2)),
                (1, _mm512_shuffle_i32x4::<0x88>(w1, w3)),
                (3, _mm512_shuffle_i32x4::<0xDD>(w1, w3)),
            ] {
                let j = 4 * q + c;
                if j < count {
                    _mm512_storeu_si512(o.add(j * GROUP16) as *mut _, v);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_data::reference;
    use super::*;

    /// n rows of m 8-bit features, every level present.
    fn levels(n: usize, m: usize) -> Vec<f32> {
        (0..n * m).map(|i| ((i * 2654435761usize) >> 7) % 256).map(|k| k as f32 * S8).collect()
    }

    /// Sizes around the tile (48 rows), the group (16), the chunk (64) and the panel (1024);
    /// the last sums two partial Grams.
    const SIZES: [(usize, usize); 7] = [(1, 1), (5, 37), (17, 130), (49, 1025), (100, 2100), (16, 64), (30, 8300)];

    #[test]
    fn integer_gram_is_that_of_the_f32_features_on_every_path() {
        for &(n, m) in &SIZES {
            let x = levels(n, m);
            let want = reference(&x, n, m);
            let mut first: Option<Mat<f64>> = None;
            for level in Level::supported() {
                for vnni in [false, true] {
                    if vnni && !SyrkAcc::new(n).uses_vnni() {
                        continue;
                    }
                    let acc = || if vnni { SyrkAcc::new(n) } else { SyrkAcc::new(n).without_vnni() };
                    let g = gram_levels_with(Rows8::F32(&x), n, m, acc, level).expect("8-bit features");
                    let u8_rows: Vec<u8> = x.iter().map(|&v| (v * 255.0).round() as u8).collect();
                    let g8 = gram_levels_with(Rows8::U8(&u8_rows), n, m, acc, level).expect("8-bit values");
                    assert!(g8.as_ref() == g.as_ref(), "{level:?} vnni {vnni}: the 8-bit values' Gram differs at n {n} m {m}");
                    for i in 0..n {
                        for j in 0..n {
                            let w = want[i * n + j];
                            // The left-out residual products and f64 rounding: far below 1e-13.
                            assert!((g[(i, j)] - w).abs() <= 1e-13 * w.abs().max(1.0), "{level:?} vnni {vnni} n {n} m {m} ({i},{j}): {} vs {w}", g[(i, j)]);
                            assert_eq!(g[(i, j)].to_bits(), g[(j, i)].to_bits());
                        }
                    }
                    match &first {
                        Some(f) => assert!(f.as_ref() == g.as_ref(), "{level:?} vnni {vnni}: bits differ at n {n} m {m}"),
                        None => first = Some(g),
                    }
                }
            }
        }
    }

    #[test]
    fn packing_paths_agree_and_refuse_other_values() {
        let (n, m) = (37, 200);
        let mut x = levels(n, m);
        let np = padded(n);
        for (k0, kc) in [(0usize, 200usize), (3, 130), (64, 64), (199, 1)] {
            let (kcp, kcq) = (kc.div_ceil(2), kc.div_ceil(4));
            let pack = |x: &[f32], level| {
                let (mut a, mut ak, mut ar) = (vec![7; np * kcp], vec![7; np * kcq], vec![7; np * kcq]);
                let ok = pack_panel(Rows8::F32(x), Panel { n, m, k0, kc }, [&mut a[..], &mut ak[..], &mut ar[..]], level);
                (ok, a, ak, ar)
            };
            let want = pack(&x, Level::supported()[0]);
            let (ok, a, ak, ar) = &want;
            assert!(ok);
            // The layout, read back: pairs, quads of levels and of residuals.
            let r = residuals();
            let lv = |i: usize, p: usize| if i < n && p < kc { (x[i * m + k0 + p] * 255.0).round() as i32 } else { 0 };
            for i in 0..np {
                let (g, l) = (i / 16, i % 16);
                for j in 0..kcp {
                    assert_eq!(a[g * 16 * kcp + j * 16 + l], lv(i, 2 * j) | lv(i, 2 * j + 1) << 16);
                }
                for j in 0..kcq {
                    let bytes = |f: &dyn Fn(i32) -> u8| i32::from_le_bytes(std::array::from_fn(|t| f(lv(i, 4 * j + t))));
                    assert_eq!(ak[g * 16 * kcq + j * 16 + l], bytes(&|k| k as u8));
                    assert_eq!(ar[g * 16 * kcq + j * 16 + l], bytes(&|k| r[k as usize] as u8));
                }
            }
            for level in Level::supported() {
                assert!(pack(&x, level) == want, "{level:?} steps {k0}+{kc}");
            }
        }
        for bad in [0.3, -S8, 256.0 * S8, f32::NAN, f32::INFINITY, 2.5 * S8] {
            x[20 * m + 150] = bad;
            for level in Level::supported() {
                let (mut a, mut ak, mut ar) = (vec![0; np * 100], vec![0; np * 50], vec![0; np * 50]);
                assert!(
                    !pack_panel(Rows8::F32(&x), Panel { n, m, k0: 0, kc: m }, [&mut a[..], &mut ak[..], &mut ar[..]], level),
                    "{bad} accepted by {level:?}"
                );
            }
            assert!(gram_levels_with(Rows8::F32(&x), n, m, || SyrkAcc::new(n), Level::detect()).is_none());
        }
    }

    #[test]
    fn result_does_not_depend_on_the_thread_count() {
        assert_eq!((chunks8(30, 8300), chunks8(222, 19_200), chunks8(2000, 19_200), chunks8(222, 3000)), (2, 2, 1, 1));
        let (n, m) = (130, 8300);
        let x = levels(n, m);
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| gram_levels_with(Rows8::F32(&x), n, m, || SyrkAcc::new(n), Level::detect()).expect("8-bit"))
        };
        assert!(run(1).as_ref() == run(3).as_ref());
    }
}
