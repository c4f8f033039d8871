//! The 8-bit passes over one band of C: each 48 x 8 tile (or the 16 or 32 rows of it that lie
//! on or below the diagonal and above the padding) summed exactly in i32 by the AVX-512 VNNI
//! kernels of `super::vnni` where the level has VNNI, else by the portable kernels here, then
//! added to C by one fused multiply-add per element (the same bits either way).

#[cfg(target_arch = "x86_64")]
use super::vnni;
use super::{Band, GROUP, GROUP16, MR16};
use crate::kernels::Level;

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

/// A packed 8-bit panel of `steps` step pairs (or, with four sides, step quads): `sides` the
/// 16-row groups (the levels, then for a cross panel the signed values), then the broadcast
/// sides, at `bs` lanes a step.
#[derive(Debug, Clone, Copy)]
pub(super) struct Panel<'a, const N: usize> {
    pub sides: [&'a [i32]; N],
    pub bs: usize,
    pub steps: usize,
}

/// One band of C += s * P P^T for an 8-bit panel `p` of step pairs: `a` the 16-row groups, `b`
/// the broadcast side; rows of C at or past `n16` are padding.
pub(super) fn band_update_u8(band: &mut Band, n16: usize, p: Panel<'_, 2>, s: f64, level: Level) {
    let Panel { sides: [a, b], bs, steps: kcp } = p;
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
            if level.avx512_vnni() {
                // SAFETY: the level is a token of detection that found AVX-512 F and VNNI; the
                // slices have the lengths the kernels read and write (asserted by them).
                unsafe {
                    match q {
                        3 => vnni::tile_u8_vnni(ap, bp, bs, kcp, out, ld, s),
                        2 => vnni::tile_u8_vnni_q::<2>(ap, bp, bs, kcp, out, ld, s),
                        _ => vnni::tile_u8_vnni_q::<1>(ap, bp, bs, kcp, out, ld, s),
                    }
                }
                continue;
            }
            let _ = level;
            tile_u8_portable(q, Panel { sides: [ap, bp], bs, steps: kcp }, out, ld, s);
        }
    }
}

/// One band of C += s * (K^T R + R^T K) for a cross panel of `kcq` step quads (as
/// [`band_update_u8`], the levels and the signed values side by side).
pub(super) fn band_update_u8_cross(band: &mut Band, n16: usize, p: Panel<'_, 4>, s: f64, level: Level) {
    let Panel { sides: [ak, ar, bk, br], bs, steps: kcq } = p;
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
            if level.avx512_vnni() {
                // SAFETY: the level is a token of detection that found AVX-512 F and VNNI; the
                // slices have the lengths the kernels read and write (asserted by them).
                unsafe {
                    match q {
                        3 => vnni::tile_u8_cross_vnni([akp, arp, bkp, brp], bs, kcq, out, ld, s),
                        2 => vnni::tile_u8_cross_vnni_q::<2>([akp, arp, bkp, brp], bs, kcq, out, ld, s),
                        _ => vnni::tile_u8_cross_vnni_q::<1>([akp, arp, bkp, brp], bs, kcq, out, ld, s),
                    }
                }
                continue;
            }
            let _ = level;
            tile_u8_cross_portable(q, Panel { sides: [akp, arp, bkp, brp], bs, steps: kcq }, out, ld, s);
        }
    }
}

/// out[c * ld + r] += s * sum_j (lo(a[r][j]) lo(b[c][j]) + hi(a[r][j]) hi(b[c][j])) for the
/// (16 q) x 8 8-bit tile (q <= 3), summed exactly in i32 (a: q packed groups of 16, b: 8 lanes a
/// step, `bs` lanes apart).
fn tile_u8_portable(q: usize, p: Panel<'_, 2>, out: &mut [f64], ld: usize, s: f64) {
    let Panel { sides: [a, b], bs, steps: kcp } = p;
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
fn tile_u8_cross_portable(q: usize, p: Panel<'_, 4>, out: &mut [f64], ld: usize, s: f64) {
    let Panel { sides: [ak, ar, bk, br], bs, steps: kcq } = p;
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
