//! The AVX-512 VNNI micro-kernels of the 8-bit passes: a 48 x 8 tile in i32 lanes, per step
//! pair 24 `vpdpwssd` (or per step quad 48 `vpdpbusd`), written in assembly so that the 24
//! accumulators stay in registers (the compiler cannot commute `vpdpwssd`'s accumulator operand
//! and spills them); tiles of 16 or 32 rows in intrinsics. Each tile is then added to C in f64
//! by one fused multiply-add per element, as the portable kernels of `super::int8` do.

// Register tiles index several arrays (accumulators, loaded vectors) by the same loop variables.
#![allow(clippy::needless_range_loop)]

use super::{GROUP, GROUP16, MR16};
use std::arch::x86_64::*;

/// The 8-bit micro-kernel: 24 accumulators of 16 i32 lanes (zmm0-23) for the 48 x 8 tile,
/// per step pair three loads of `a` (zmm24-26), eight 32-bit broadcasts of `b` (8 lanes a
/// step, `bs` lanes apart) and 24 `vpdpwssd`.
///
/// # Safety
/// The CPU must support AVX-512F and AVX-512 VNNI.
#[target_feature(enable = "avx512f,avx512vnni")]
pub(super) unsafe fn tile_u8_vnni(a: &[i32], b: &[i32], bs: usize, kcp: usize, out: &mut [f64], ld: usize, s: f64) {
    assert!(a.len() >= 3 * GROUP16 * kcp && b.len() >= (kcp.max(1) - 1) * bs + GROUP && out.len() >= 7 * ld + MR16);
    let mut acc = [_mm512_setzero_si512(); 24];
    if kcp > 0 {
        // zmm(3c + q) accumulates rows 16q..16q + 16 of column c. The loop reads `a` at
        // 16 j + {0, 16 kcp, 32 kcp} and `b` at j bs for j < kcp, inside them (asserted above).
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
pub(super) unsafe fn tile_u8_vnni_q<const Q: usize>(a: &[i32], b: &[i32], bs: usize, kcp: usize, out: &mut [f64], ld: usize, s: f64) {
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
pub(super) unsafe fn tile_u8_cross_vnni_q<const Q: usize>([ak, ar, bk, br]: [&[i32]; 4], bs: usize, kcq: usize, out: &mut [f64], ld: usize, s: f64) {
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
///
/// # Safety
/// The CPU must support AVX-512F.
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
///
/// # Safety
/// The CPU must support AVX-512F.
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
pub(super) unsafe fn tile_u8_cross_vnni([ak, ar, bk, br]: [&[i32]; 4], bs: usize, kcq: usize, out: &mut [f64], ld: usize, s: f64) {
    let bl = (kcq.max(1) - 1) * bs + GROUP;
    assert!(ak.len() >= 3 * GROUP16 * kcq && ar.len() >= 3 * GROUP16 * kcq && bk.len() >= bl && br.len() >= bl);
    assert!(out.len() >= 7 * ld + MR16);
    let mut acc = [_mm512_setzero_si512(); 24];
    if kcq > 0 {
        // zmm(3c + q) accumulates rows 16q..16q + 16 of column c. The loop reads `ak`, `ar` at
        // 16 j + {0, 16 kcq, 32 kcq} and `bk`, `br` at j bs for j < kcq, inside them (asserted).
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
