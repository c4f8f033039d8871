//! The refined eigenspace's coarse scan: every coarse surface point scored against one query,
//! the points in SIMD lanes (coordinate-major tables, L rows of n points).
//!
//! Each kernel is one portable body, compiled for AVX2 and for AVX-512 by [`dispatch!`].
//! The bodies are element-wise along the points (each point's sum runs over the coordinates in
//! the same order on every path, with no fused multiply-add), so every build gives bit-identical
//! results; the wider ones only widen the lanes.

use super::{dispatch, Level};

dispatch! {
    /// `dist[i] = sum_q wt[q] (cols[q][i] - y[q])^2` over the coordinates with a non-zero weight
    /// (`cols`: rows of `dist.len()` values, at least `y.len()` rows).
    pub(crate) fn sq_dist(cols: &[f32], y: &[f32], wt: &[f32], dist: &mut [f32]) = sq_dist_portable;
}

/// Two coordinate-major tables of the same points (a surface's and its offset's).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Tables<'a> {
    pub cols: &'a [f32],
    pub gcols: &'a [f32],
}

/// `u[i] = sum_q a[q] cols[q][i]` and `v[i] = sum_q a[q] gcols[q][i]` (rows of `u.len()` values).
pub(crate) fn dots2(level: Level, cols: &[f32], gcols: &[f32], a: &[f32], u: &mut [f32], v: &mut [f32]) {
    dots2_at(level, Tables { cols, gcols }, u.len(), 0, a, u, v)
}

/// [`dots2`] for the points `i0..i0 + u.len()` of rows of `n` values: the same bits as the whole
/// scan's at those points.
pub(crate) fn dots2_at(level: Level, t: Tables, n: usize, i0: usize, a: &[f32], u: &mut [f32], v: &mut [f32]) {
    assert!(i0 + u.len() <= n && u.len() == v.len(), "points inside the rows");
    dots2_built(level, t, n, i0, a, u, v)
}

dispatch! {
    /// [`dots2_at`] at `level`.
    fn dots2_built(t: Tables, n: usize, i0: usize, a: &[f32], u: &mut [f32], v: &mut [f32]) = dots2_portable;
}

dispatch! {
    /// The affine match's residual at every point, in place of `u`:
    /// `u[i] = max(zz - uu^2 inv_a[i] - e^2 inv_s[i], 0)` with `uu = u[i] + ac` and
    /// `e = v[i] - b_over_a[i] uu`, in f64 (the refined eigenspace's noisy scan; the per-point
    /// sums `u`, `v` from [`dots2`]; `q` the query's terms).
    pub(crate) fn affine_residuals(u: &mut [f32], v: &[f32], b_over_a: &[f64], inv_a: &[f64], inv_s: &[f64], q: AffineTerms) = affine_residuals_portable;
}

/// The query's terms of [`affine_residuals`]: `ac` added to each point's `u`, and `zz`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct AffineTerms {
    pub ac: f64,
    pub zz: f64,
}

#[inline(always)]
fn affine_residuals_portable(u: &mut [f32], v: &[f32], b_over_a: &[f64], inv_a: &[f64], inv_s: &[f64], q: AffineTerms) {
    let AffineTerms { ac, zz } = q;
    // Over zipped slices (no index checks: the loop vectorises).
    for ((((d, &vi), &ba), &ia), &is) in u.iter_mut().zip(v).zip(b_over_a).zip(inv_a).zip(inv_s) {
        let uu = *d as f64 + ac;
        let e = vi as f64 - ba * uu;
        *d = (zz - uu * uu * ia - e * e * is).max(0.0) as f32;
    }
}

/// Points per box of [`boxes`] and [`sq_dist_boxed`]: one AVX-512 vector.
pub(crate) const BOX: usize = 16;

/// The bounding boxes of every `BOX` (16) consecutive points (the last box maybe fewer) in the
/// first `split` rows of `cols` (rows of `n` values): for each row q, the boxes' least values,
/// then their greatest (`2 split` rows of `n.div_ceil(BOX)`).
#[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
pub fn boxes(cols: &[f32], n: usize, split: usize) -> Vec<f32> {
    let nb = n.div_ceil(BOX);
    let mut out = vec![0f32; 2 * split * nb];
    for (q, col) in cols.chunks_exact(n).take(split).enumerate() {
        for (b, c) in col.chunks(BOX).enumerate() {
            out[2 * q * nb + b] = c.iter().fold(f32::INFINITY, |a, &v| a.min(v));
            out[(2 * q + 1) * nb + b] = c.iter().fold(f32::NEG_INFINITY, |a, &v| a.max(v));
        }
    }
    out
}

dispatch! {
    /// [`sq_dist`] for the points that can lie within twice the least distance, +inf for the
    /// others; returns the least distance. Each box of [`BOX`] points ([`boxes`], over the first
    /// `split` coordinates) gets a lower bound of its points' distances: the weighted squared
    /// distance from the query to the box in those coordinates, the same terms as a point's in the
    /// same order, each no larger (rounding is monotone), so no larger than any of its points'
    /// sums. The points of the box of least bound are scored in full; twice their least distance
    /// bounds the cut, and only boxes whose bound is within it are scored. Every distance given has
    /// the bits of [`sq_dist`]'s. `lb` is scratch.
    pub(crate) fn sq_dist_boxed(cols: &[f32], b: Boxes, y: &[f32], wt: &[f32], dist: &mut [f32], lb: &mut Vec<f32>) -> f32 = sq_dist_boxed_portable;
}

/// The points' bounding boxes ([`boxes`]) over their first `split` coordinates.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Boxes<'a> {
    pub boxes: &'a [f32],
    pub split: usize,
}

#[inline(always)]
fn sq_dist_boxed_portable(cols: &[f32], b: Boxes, y: &[f32], wt: &[f32], dist: &mut [f32], lb: &mut Vec<f32>) -> f32 {
    let Boxes { boxes, split } = b;
    let n = dist.len();
    let nb = n.div_ceil(BOX);
    let split = split.min(y.len());
    assert!(boxes.len() >= 2 * split * nb, "a box for every {BOX} points");
    lb.clear();
    lb.resize(nb, 0.0);
    for q in 0..split {
        let (w, yc) = (wt[q], y[q]);
        if w == 0.0 {
            continue;
        }
        let (lo, hi) = (&boxes[2 * q * nb..(2 * q + 1) * nb], &boxes[(2 * q + 1) * nb..(2 * q + 2) * nb]);
        for ((l, &a), &b) in lb.iter_mut().zip(lo).zip(hi) {
            // The distance to [a, b] is 0 inside, the nearer end's outside.
            let d = if yc < a {
                a - yc
            } else if yc > b {
                yc - b
            } else {
                0.0
            };
            *l += w * (d * d);
        }
    }
    let Some(first) = argmin_portable(lb) else {
        // No finite bound (a NaN query): score everything.
        dist.chunks_mut(BOX).enumerate().for_each(|(b, out)| score_box(cols, n, b, y, wt, out));
        return dist.iter().fold(f32::INFINITY, |a, &v| if v < a { v } else { a });
    };
    let fb = &mut dist[first * BOX..((first + 1) * BOX).min(n)];
    score_box(cols, n, first, y, wt, fb);
    let u = fb.iter().fold(f32::INFINITY, |a, &v| if v < a { v } else { a });
    let cut = 2.0 * u.max(0.0) + f32::MIN_POSITIVE;
    let mut lanes = [f32::INFINITY; 17];
    for (b, out) in dist.chunks_mut(BOX).enumerate() {
        if !(lb[b] > cut) {
            if b != first {
                score_box(cols, n, b, y, wt, out);
            }
            lane_min(&mut lanes, out);
        } else {
            out.fill(f32::INFINITY);
        }
    }
    reduce_min(&lanes)
}

/// The distances of box `b`'s points (`out`, [`BOX`] or fewer), every coordinate.
#[inline(always)]
fn score_box(cols: &[f32], n: usize, b: usize, y: &[f32], wt: &[f32], out: &mut [f32]) {
    let mut acc = [0f32; BOX];
    let len = out.len();
    add_sq::<BOX>(cols, n, b * BOX, y, wt, &mut acc[..len]);
    out.copy_from_slice(&acc[..len]);
}

dispatch! {
    /// The least of `v` (+inf when empty or all NaN).
    pub(crate) fn least(v: &[f32]) -> f32 = least_portable;
}

#[inline(always)]
fn least_portable(v: &[f32]) -> f32 {
    let mut lanes = [f32::INFINITY; 17];
    lane_min(&mut lanes, v);
    reduce_min(&lanes)
}

dispatch! {
    /// The index of the least of `v` (the first of equals; None when empty or all NaN).
    pub(crate) fn argmin(v: &[f32]) -> Option<usize> = argmin_portable;
}

#[inline(always)]
fn argmin_portable(v: &[f32]) -> Option<usize> {
    let least = least_portable(v);
    // Its block of 16 tested without branches, then its place there.
    let b = v.chunks(16).position(|c| c.iter().fold(false, |hit, &x| hit | (x == least)));
    b.and_then(|b| v[16 * b..].iter().position(|&x| x == least).map(|i| 16 * b + i))
}

/// Points per block of the scans: their sums stay in registers while every coordinate's
/// values pass (one load per point and coordinate, one store per point).
const BLOCK: usize = 64;

#[inline(always)]
fn sq_dist_portable(cols: &[f32], y: &[f32], wt: &[f32], dist: &mut [f32]) {
    let n = dist.len();
    for (b, out) in dist.chunks_mut(BLOCK).enumerate() {
        let mut acc = [0f32; BLOCK];
        add_sq::<BLOCK>(cols, n, b * BLOCK, y, wt, &mut acc[..out.len()]);
        out.copy_from_slice(&acc[..out.len()]);
    }
}

/// Adds `wt[q] (cols[q][i0 + k] - y[q])^2` to `acc[k]` for the coordinates with a non-zero
/// weight, in increasing order (`cols`: rows of `n` values). With `acc` of exactly N values the
/// length is fixed, so the sums stay in registers.
#[inline(always)]
fn add_sq<const N: usize>(cols: &[f32], n: usize, i0: usize, y: &[f32], wt: &[f32], acc: &mut [f32]) {
    let len = acc.len();
    if let Ok(a) = <&mut [f32; N]>::try_from(&mut *acc) {
        for ((col, &yc), &w) in cols.chunks_exact(n).zip(y).zip(wt) {
            if w == 0.0 {
                continue;
            }
            let seg: &[f32; N] = col[i0..i0 + N].try_into().expect("a whole block");
            // Plain loops: a closure here can be compiled apart, without the caller's AVX-512.
            for k in 0..N {
                a[k] += w * ((seg[k] - yc) * (seg[k] - yc));
            }
        }
        return;
    }
    for ((col, &yc), &w) in cols.chunks_exact(n).zip(y).zip(wt) {
        if w == 0.0 {
            continue;
        }
        for (s, &p) in acc.iter_mut().zip(&col[i0..i0 + len]) {
            *s += w * ((p - yc) * (p - yc));
        }
    }
}

/// `lanes[k] = min(lanes[k], v[16 i + k])` over every whole 16 values of `v`, and the rest's
/// least into lane 16 (NaN ignored): the lanes stay in a register, no partial stores.
#[inline(always)]
fn lane_min(lanes: &mut [f32; 17], v: &[f32]) {
    let mut m: [f32; 16] = lanes[..16].try_into().expect("16 lanes");
    let chunks = v.chunks_exact(16);
    let rest = chunks.remainder().iter().fold(lanes[16], |a, &b| if b < a { b } else { a });
    for c in chunks {
        for k in 0..16 {
            m[k] = if c[k] < m[k] { c[k] } else { m[k] };
        }
    }
    lanes[..16].copy_from_slice(&m);
    lanes[16] = rest;
}

/// The least of the lanes.
#[inline(always)]
fn reduce_min(lanes: &[f32; 17]) -> f32 {
    lanes.iter().fold(f32::INFINITY, |a, &b| if b < a { b } else { a })
}

#[inline(always)]
fn dots2_portable(t: Tables, n: usize, first: usize, a: &[f32], u: &mut [f32], v: &mut [f32]) {
    let Tables { cols, gcols } = t;
    for (b, (uo, vo)) in u.chunks_mut(BLOCK).zip(v.chunks_mut(BLOCK)).enumerate() {
        let (i0, len) = (first + b * BLOCK, uo.len());
        let (mut su, mut sv) = ([0f32; BLOCK], [0f32; BLOCK]);
        for ((col, gcol), &aq) in cols.chunks_exact(n).zip(gcols.chunks_exact(n)).zip(a) {
            let (c, g) = (&col[i0..i0 + len], &gcol[i0..i0 + len]);
            match (<&[f32; BLOCK]>::try_from(c), <&[f32; BLOCK]>::try_from(g)) {
                (Ok(c), Ok(g)) => (0..BLOCK).for_each(|k| {
                    su[k] += aq * c[k];
                    sv[k] += aq * g[k];
                }),
                _ => {
                    su.iter_mut().zip(c).for_each(|(s, &p)| *s += aq * p);
                    sv.iter_mut().zip(g).for_each(|(s, &p)| *s += aq * p);
                }
            }
        }
        // Whole blocks by fixed-size stores (a slice copy of a run-time length calls memmove).
        match (<&mut [f32; BLOCK]>::try_from(&mut *uo), <&mut [f32; BLOCK]>::try_from(&mut *vo)) {
            (Ok(uo), Ok(vo)) => (*uo, *vo) = (su, sv),
            _ => {
                uo.copy_from_slice(&su[..len]);
                vo.copy_from_slice(&sv[..len]);
            }
        }
    }
}

/// The `k` smallest of `dist` at most `cut`, with their indices, in increasing order (ties: the
/// lower index); built for AVX-512 F and BW where `level` has them (comparisons only: the same
/// result). `k` is at least 1.
pub(crate) fn smallest_under_cut(level: Level, dist: &[f32], k: usize, cut: f32) -> Vec<(f32, usize)> {
    #[cfg(target_arch = "x86_64")]
    if level.avx512() {
        // SAFETY: the level is a token of detection that found AVX-512 F and BW.
        return unsafe { smallest_avx512(dist, k, cut) };
    }
    smallest_body(dist, k, cut)
}

/// [`smallest_body`] compiled for AVX-512 F and BW.
///
/// # Safety
/// The CPU must support AVX-512 F and BW.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw")]
unsafe fn smallest_avx512(dist: &[f32], k: usize, cut: f32) -> Vec<(f32, usize)> {
    smallest_body(dist, k, cut)
}

/// The body of [`smallest_under_cut`]: two passes, blocks of 16 tested without branches first (few
/// hold a point under the cut), then the points of those.
#[inline(always)]
fn smallest_body(dist: &[f32], k: usize, cut: f32) -> Vec<(f32, usize)> {
    let mut best: Vec<(f32, usize)> = Vec::with_capacity(k + 1);
    // Blocks of 16 tested without branches first: few hold a point under the cut.
    for (b, c) in dist.chunks(16).enumerate() {
        if !c.iter().fold(false, |hit, &v| hit | (v <= cut)) {
            continue;
        }
        for (i, &v) in c.iter().enumerate() {
            if v <= cut && (best.len() < k || v < best[best.len() - 1].0) {
                let at = best.partition_point(|b| b.0 <= v);
                best.insert(at, (v, 16 * b + i));
                best.truncate(k);
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_level_gives_the_same_bits_as_the_reference() {
        let (n, l) = (131, 7);
        let cols: Vec<f32> = (0..n * l).map(|i| ((i * 7919) % 1000) as f32 / 500.0 - 1.0).collect();
        let gcols: Vec<f32> = (0..n * l).map(|i| ((i * 104729) % 997) as f32 / 400.0 - 1.2).collect();
        let y: Vec<f32> = (0..l).map(|q| q as f32 * 0.1 - 0.3).collect();
        let wt: Vec<f32> = (0..l).map(|q| if q == 3 { 0.0 } else { 1.0 + q as f32 }).collect();
        let want: Vec<f32> =
            (0..n).map(|i| (0..l).filter(|&q| wt[q] != 0.0).fold(0f32, |s, q| s + wt[q] * ((cols[q * n + i] - y[q]) * (cols[q * n + i] - y[q])))).collect();
        let want_u: Vec<f32> = (0..n).map(|i| (0..l).fold(0f32, |s, q| s + y[q] * cols[q * n + i])).collect();
        let want_v: Vec<f32> = (0..n).map(|i| (0..l).fold(0f32, |s, q| s + y[q] * gcols[q * n + i])).collect();
        for level in Level::supported() {
            let mut d = vec![f32::NAN; n];
            sq_dist(level, &cols, &y, &wt, &mut d);
            assert_eq!(d, want, "{level:?}");
            let (mut u, mut v) = (vec![f32::NAN; n], vec![f32::NAN; n]);
            dots2(level, &cols, &gcols, &y, &mut u, &mut v);
            assert_eq!((&u, &v), (&want_u, &want_v), "{level:?}");
            // A range of points (not on a block boundary) gives the same bits.
            let (mut ur, mut vr) = (vec![f32::NAN; 70], vec![f32::NAN; 70]);
            dots2_at(level, Tables { cols: &cols, gcols: &gcols }, n, 37, &y, &mut ur, &mut vr);
            assert_eq!((&ur[..], &vr[..]), (&want_u[37..107], &want_v[37..107]), "{level:?}");
        }
    }

    #[test]
    fn argmin_finds_the_first_least() {
        for level in Level::supported() {
            assert_eq!(argmin(level, &[]), None);
            assert_eq!(least(level, &[]), f32::INFINITY);
            assert_eq!(least(level, &[3.0, f32::NAN, -2.5, 7.0]), -2.5);
            assert_eq!(argmin(level, &[f32::NAN, f32::NAN]), None);
            let v: Vec<f32> = (0..100).map(|i| ((i * 37) % 101) as f32).collect();
            assert_eq!(argmin(level, &v), Some(0));
            let mut w: Vec<f32> = (0..70).map(|i| 5.0 + (i % 7) as f32).collect();
            (w[33], w[50], w[12]) = (1.0, 1.0, f32::NAN);
            assert_eq!(argmin(level, &w), Some(33), "{level:?}");
            w[69] = -1.0;
            assert_eq!(argmin(level, &w), Some(69), "{level:?}");
        }
    }

    #[test]
    fn the_affine_residuals_agree_on_every_level() {
        let n = 133;
        let u0: Vec<f32> = (0..n).map(|i| ((i * 7919) % 1000) as f32 / 300.0 - 1.0).collect();
        let v: Vec<f32> = (0..n).map(|i| ((i * 104729) % 997) as f32 / 400.0 - 1.2).collect();
        let ba: Vec<f64> = (0..n).map(|i| (i % 17) as f64 / 9.0 - 0.5).collect();
        let ia: Vec<f64> = (0..n).map(|i| 0.5 + (i % 5) as f64 / 7.0).collect();
        let is: Vec<f64> = (0..n).map(|i| if i % 11 == 0 { 0.0 } else { 1.0 + (i % 3) as f64 }).collect();
        let (ac, zz) = (0.37, 9.5);
        let want: Vec<f32> = (0..n)
            .map(|i| {
                let uu = u0[i] as f64 + ac;
                let e = v[i] as f64 - ba[i] * uu;
                (zz - uu * uu * ia[i] - e * e * is[i]).max(0.0) as f32
            })
            .collect();
        for level in Level::supported() {
            let mut u = u0.clone();
            affine_residuals(level, &mut u, &v, &ba, &ia, &is, AffineTerms { ac, zz });
            assert_eq!(u, want, "{level:?}");
        }
    }

    /// The boxed scan gives the full scan's bits for every point within twice the least
    /// distance (and +inf or the same bits elsewhere), on points along a curve where most boxes
    /// are ruled out, for every split and level.
    #[test]
    fn the_boxed_scan_keeps_every_point_within_twice_the_least() {
        let (n, l) = (700, 9);
        // Points along a curve, so that a query near one part of it rules out most blocks.
        let cols: Vec<f32> = (0..l)
            .flat_map(|q| (0..n).map(move |i| ((i as f32 * 0.013 * (q + 1) as f32).sin() + 0.01 * ((i * 31 + q * 7) % 13) as f32) / (q + 1) as f32))
            .collect();
        for (qi, at) in [0usize, 77, 300, 699].into_iter().enumerate() {
            let y: Vec<f32> = (0..l).map(|q| cols[q * n + at] + 0.003 * (q as f32 - 4.0)).collect();
            let wt: Vec<f32> = (0..l).map(|q| if q == 5 && qi % 2 == 1 { 0.0 } else { 1.0 / (1.0 + q as f32) }).collect();
            let mut full = vec![0f32; n];
            sq_dist(Level::supported()[0], &cols, &y, &wt, &mut full);
            let lo = full.iter().cloned().fold(f32::INFINITY, f32::min);
            for level in Level::supported() {
                for split in [0, 1, 3, l, l + 2] {
                    let bx = boxes(&cols, n, split.min(l));
                    let mut d = vec![f32::NAN; n];
                    let least = sq_dist_boxed(level, &cols, Boxes { boxes: &bx, split }, &y, &wt, &mut d, &mut Vec::new());
                    assert_eq!(least.to_bits(), lo.to_bits(), "boxed: query {qi}, split {split}");
                    let mut boxed_out = 0;
                    for i in 0..n {
                        if d[i] == f32::INFINITY && full[i] > 2.0 * lo {
                            boxed_out += 1;
                        } else {
                            assert_eq!(d[i].to_bits(), full[i].to_bits(), "boxed: point {i}, query {qi}, split {split}, {level:?}");
                        }
                    }
                    if (3..l).contains(&split) {
                        assert!(boxed_out > n / 2, "boxed: only {boxed_out} ruled out (query {qi}, split {split})");
                    }
                }
            }
        }
    }
}
