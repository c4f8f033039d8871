//! The k-d tree's leaf scans ([`crate::manifold::kdtree`]): a leaf's [`LEAF`] points stored
//! coordinate by coordinate, their squared distances from a query in [`LEAF`] lanes, portable
//! and in AVX-512 with the same operations in the same order (the same bits).

use super::Level;

/// Points per leaf (one AVX-512 vector of f32).
pub(crate) const LEAF: usize = 16;

/// Largest dimension of a query (the near scan gathers a point's coordinates on the stack).
pub(crate) const MAX_DIM: usize = 32;

/// One leaf's squared distances (`rows`: `q.len()` rows of [`LEAF`] values; `items` the points'
/// indices), each summed over the coordinates in order, into `best` (least distance, ties to
/// the lower index); in AVX-512 where `level` has it.
#[inline(always)]
pub(crate) fn scan(level: Level, rows: &[f32], items: &[u32], q: &[f32], best: &mut (f32, u32)) {
    #[cfg(target_arch = "x86_64")]
    if level.avx512() {
        // SAFETY: the level is a token of detection that found AVX-512F; the kernel asserts
        // the lengths it reads.
        return unsafe { x86::scan_avx512(rows, items, q, best) };
    }
    scan_portable(rows, items, q, best)
}

/// One leaf's [`near_distance`]s into `best` and the points within `reach` times the best onto
/// `near` ([`scan_near_portable`]); in AVX-512 where `level` has it.
#[inline(always)]
pub(crate) fn scan_near(level: Level, rows: &[f32], items: &[u32], q: &[f32], best: &mut (f32, u32), reach: f32, near: &mut Vec<(f32, u32)>) {
    #[cfg(target_arch = "x86_64")]
    if level.avx512() {
        // SAFETY: the level is a token of detection that found AVX-512F; the kernel asserts
        // the lengths it reads.
        return unsafe { x86::scan_near_avx512(rows, items, q, best, reach, near) };
    }
    scan_near_portable(rows, items, q, best, reach, near)
}

/// One leaf's squared distances, each summed over the coordinates in order, into `best` (least
/// distance, ties to the lower index).
#[inline(always)]
fn scan_portable(rows: &[f32], items: &[u32], q: &[f32], best: &mut (f32, u32)) {
    let mut acc = [0f32; LEAF];
    for (row, &ql) in rows.chunks_exact(LEAF).zip(q) {
        for (a, &v) in acc.iter_mut().zip(row) {
            let d = v - ql;
            *a += d * d;
        }
    }
    take_lanes(&acc, items, best);
}

/// A leaf's distances `acc` into `best` (least distance, ties to the lower index).
#[inline(always)]
fn take_lanes(acc: &[f32; LEAF], items: &[u32], best: &mut (f32, u32)) {
    for (&a, &i) in acc.iter().zip(items) {
        if better(a, i, *best) {
            *best = (a, i);
        }
    }
}

/// The squared distance from `p` to `q` that [`crate::manifold::kdtree::KdTree::nearest_and_near`] measures: four
/// chains, chain k summing the coordinates k, k + 4, ... in order by fused multiply-adds of the
/// differences, then (c0 + c1) + (c2 + c3).
pub(crate) fn near_distance(p: &[f32], q: &[f32]) -> f32 {
    let mut c = [0f32; 4];
    for (l, (&a, &b)) in p.iter().zip(q).enumerate() {
        let d = a - b;
        c[l % 4] = d.mul_add(d, c[l % 4]);
    }
    (c[0] + c[1]) + (c[2] + c[3])
}

/// One leaf's [`near_distance`]s into `best` (least distance, ties to the lower index), then the
/// leaf's points within `reach` times the best distance (after the leaf) pushed onto `near`
/// with their distances.
#[inline(always)]
fn scan_near_portable(rows: &[f32], items: &[u32], q: &[f32], best: &mut (f32, u32), reach: f32, near: &mut Vec<(f32, u32)>) {
    let mut acc = [0f32; LEAF];
    let mut p = [0f32; MAX_DIM];
    for (j, a) in acc.iter_mut().enumerate() {
        for (l, v) in p[..q.len()].iter_mut().enumerate() {
            *v = rows[l * LEAF + j];
        }
        *a = near_distance(&p[..q.len()], q);
    }
    take_lanes(&acc, items, best);
    let bound = reach * best.0;
    near.extend(acc.iter().zip(items).filter(|&(&a, &i)| a <= bound && i != u32::MAX).map(|(&a, &i)| (a, i)));
}

/// Whether point `i` at squared distance `a` replaces `best`: a lesser distance, or the same
/// distance and a lower index; an infinite distance never does (brute force starts from an
/// infinite best and keeps the first strictly lesser one).
#[inline(always)]
fn better(a: f32, i: u32, best: (f32, u32)) -> bool {
    a < best.0 || (a == best.0 && i < best.1 && a != f32::INFINITY)
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::LEAF;
    use std::arch::x86_64::*;

    /// A leaf's squared distances in one AVX-512 vector, summed a coordinate at a time: the
    /// subtractions, products and sums of [`super::scan_portable`] in the same order (no fused
    /// multiply-add), so the same bits.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn leaf_distances(rows: &[f32], q: &[f32]) -> __m512 {
        assert!(rows.len() >= q.len() * LEAF);
        let mut acc = _mm512_setzero_ps();
        for (l, &ql) in q.iter().enumerate() {
            let d = _mm512_sub_ps(_mm512_loadu_ps(rows.as_ptr().add(l * LEAF)), _mm512_set1_ps(ql));
            acc = _mm512_add_ps(acc, _mm512_mul_ps(d, d));
        }
        acc
    }

    /// The lanes `hits` of the distances `a` into `best` (least distance, ties to the lower
    /// index).
    #[inline(always)]
    fn take_best(mut hits: u16, a: &[f32; LEAF], items: &[u32], best: &mut (f32, u32)) {
        while hits != 0 {
            let j = hits.trailing_zeros() as usize;
            hits &= hits - 1;
            if super::better(a[j], items[j], *best) {
                *best = (a[j], items[j]);
            }
        }
    }

    /// [`super::scan_portable`] in one AVX-512 vector per coordinate ([`leaf_distances`]).
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn scan_avx512(rows: &[f32], items: &[u32], q: &[f32], best: &mut (f32, u32)) {
        assert!(items.len() == LEAF);
        let acc = leaf_distances(rows, q);
        // Only lanes at most the best distance can change it.
        let hits = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(acc, _mm512_set1_ps(best.0));
        if hits == 0 {
            return;
        }
        let mut a = [0f32; LEAF];
        _mm512_storeu_ps(a.as_mut_ptr(), acc);
        take_best(hits, &a, items, best);
    }

    /// [`super::scan_near_portable`] in one AVX-512 vector per chain of [`super::near_distance`] (the same
    /// fused multiply-adds and sums, so the same bits).
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn scan_near_avx512(rows: &[f32], items: &[u32], q: &[f32], best: &mut (f32, u32), reach: f32, near: &mut Vec<(f32, u32)>) {
        assert!(items.len() == LEAF && rows.len() >= q.len() * LEAF);
        let diff = |l: usize| _mm512_sub_ps(_mm512_loadu_ps(rows.as_ptr().add(l * LEAF)), _mm512_set1_ps(q[l]));
        // The four chains in registers: whole groups of four coordinates, then the rest.
        let (mut c0, mut c1, mut c2, mut c3) = (_mm512_setzero_ps(), _mm512_setzero_ps(), _mm512_setzero_ps(), _mm512_setzero_ps());
        let whole = q.len() / 4 * 4;
        for l in (0..whole).step_by(4) {
            let (d0, d1, d2, d3) = (diff(l), diff(l + 1), diff(l + 2), diff(l + 3));
            c0 = _mm512_fmadd_ps(d0, d0, c0);
            c1 = _mm512_fmadd_ps(d1, d1, c1);
            c2 = _mm512_fmadd_ps(d2, d2, c2);
            c3 = _mm512_fmadd_ps(d3, d3, c3);
        }
        let rest = q.len() - whole;
        if rest > 0 {
            let d = diff(whole);
            c0 = _mm512_fmadd_ps(d, d, c0);
        }
        if rest > 1 {
            let d = diff(whole + 1);
            c1 = _mm512_fmadd_ps(d, d, c1);
        }
        if rest > 2 {
            let d = diff(whole + 2);
            c2 = _mm512_fmadd_ps(d, d, c2);
        }
        let acc = _mm512_add_ps(_mm512_add_ps(c0, c1), _mm512_add_ps(c2, c3));
        let mut a = [0f32; LEAF];
        _mm512_storeu_ps(a.as_mut_ptr(), acc);
        take_best(_mm512_cmp_ps_mask::<_CMP_LE_OQ>(acc, _mm512_set1_ps(best.0)), &a, items, best);
        // Unused lanes (index u32::MAX) are never near.
        let valid = _mm512_cmpneq_epi32_mask(_mm512_loadu_si512(items.as_ptr().cast()), _mm512_set1_epi32(-1));
        let mut hits = _mm512_mask_cmp_ps_mask::<_CMP_LE_OQ>(valid, acc, _mm512_set1_ps(reach * best.0));
        while hits != 0 {
            let j = hits.trailing_zeros() as usize;
            hits &= hits - 1;
            near.push((a[j], items[j]));
        }
    }
}
