//! Packing of P into panels as the micro-kernels read them: f64 groups of 8 rows
//! ([`pack_rows`], [`pack_columns`]) and 8-bit groups of 16 rows as pairs of i16 steps
//! ([`pack_pairs_u8`]) or quads of byte steps ([`pack_quads_u8`]).

use super::{padded, GROUP, GROUP16, KCP_MAX, KCQ_MAX};
use rayon::prelude::*;

/// Packs the columns of a row-major `kc x m` block of 8-bit values (P = block^T) for
/// [`super::SyrkAcc::update_u8`]: `a` (`padded(m) * kcp` lanes, `kcp = kc.div_ceil(2)`) holds groups of
/// 16 rows of P, each step pair as 16 lanes of two i16 (steps 2j and 2j + 1, the second zero
/// past `kc`); `b` (as many lanes) the same values in groups of 8 rows, the micro-kernel's
/// broadcast side. Rows past m are zero.
#[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
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
/// [`super::SyrkAcc::update_u8_cross`]: `ak` / `bk` hold the levels k, `ar` / `br` the signed values
/// `r[k]`, each 32-bit lane four consecutive steps (bytes, zero past `kc`); `ak` / `ar` in groups
/// of 16 rows of P, `bk` / `br` in groups of 8 (`padded(m) * kc.div_ceil(4)` lanes each).
#[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
pub fn pack_quads_u8([ak, ar, bk, br]: [&mut [i32]; 4], block: &[u8], kc: usize, m: usize, r: &[i8; 256]) {
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
pub(crate) fn pack_rows(dst: &mut [f64], n: usize, kc: usize, k0: usize, read: impl Fn(usize, usize, &mut [f64])) {
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
#[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
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
