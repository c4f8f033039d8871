//! An exact k-d tree for the nearest manifold point.
//!
//! Each node splits its points at the median of its widest coordinate (the spread taken over
//! the node's own points), so on an eigenspace manifold the splits fall on the leading
//! components, where the points spread, again and again. (A tree that cycles through the
//! coordinates would split each of the first components once and the leading ones no more
//! often than the rest, though a manifold's points vary most along them.)
//!
//! The search is the classic branch and bound with the incremental cell distance (Arya & Mount):
//! the nearer child first, the farther one only when the squared distance from the query to its
//! cell can beat the best point so far. Leaves hold [`LEAF`] points stored coordinate by
//! coordinate, so one leaf's distances are [`LEAF`]-lane vector operations; each distance sums
//! the squared differences coordinate by coordinate in order, the sum brute force computes, so
//! the tree returns brute force's point: the least distance, ties to the lower index (the
//! pruning keeps cells whose bound equals the best distance).

/// Points per leaf (one AVX-512 vector of f32).
pub const LEAF: usize = 16;

/// Largest dimension the tree is built for (the incremental distance keeps one offset per
/// coordinate on the stack).
pub const MAX_DIM: usize = 32;

/// A node: `dim < u32::MAX` splits coordinate `dim` at `split`, child `a` holding the points
/// with that coordinate <= `split` and `b` those >= `split`; `dim == u32::MAX` is leaf `a`.
#[derive(Debug, Clone, Copy)]
struct Node {
    dim: u32,
    split: f32,
    a: u32,
    b: u32,
}

const IS_LEAF: u32 = u32::MAX;

/// The tree over `n` points of `dim` coordinates.
#[derive(Debug, Clone)]
pub struct KdTree {
    dim: usize,
    nodes: Vec<Node>,
    /// Per leaf, `dim` rows of [`LEAF`] coordinates; unused lanes hold +infinity (never nearest).
    leaves: Vec<f32>,
    /// Per leaf, the [`LEAF`] points' indices (`u32::MAX` in unused lanes).
    items: Vec<u32>,
}

impl KdTree {
    /// Builds the tree over `points` (rows of `dim` finite coordinates, fewer than 2^32 rows,
    /// `1 <= dim <= MAX_DIM`).
    pub fn new(points: &[f32], dim: usize) -> KdTree {
        assert!((1..=MAX_DIM).contains(&dim) && points.len().is_multiple_of(dim), "rows of 1 to {MAX_DIM} coordinates");
        let n = points.len() / dim;
        assert!(n < u32::MAX as usize, "fewer than 2^32 points");
        let mut ids: Vec<u32> = (0..n as u32).collect();
        let mut t = KdTree { dim, nodes: Vec::with_capacity(2 * n / LEAF + 1), leaves: Vec::new(), items: Vec::new() };
        t.build(points, &mut ids);
        t
    }

    fn build(&mut self, points: &[f32], ids: &mut [u32]) -> u32 {
        let dim = self.dim;
        let at = self.nodes.len() as u32;
        if ids.len() <= LEAF {
            let (leaf, base) = (self.items.len() / LEAF, self.leaves.len());
            self.leaves.resize(base + dim * LEAF, f32::INFINITY);
            for (j, &i) in ids.iter().enumerate() {
                for (l, &v) in points[i as usize * dim..][..dim].iter().enumerate() {
                    self.leaves[base + l * LEAF + j] = v;
                }
            }
            self.items.extend(ids.iter().copied().chain(std::iter::repeat(u32::MAX)).take(LEAF));
            self.nodes.push(Node { dim: IS_LEAF, split: 0.0, a: leaf as u32, b: 0 });
            return at;
        }
        let coord = |i: u32, l: usize| points[i as usize * dim + l];
        // Every coordinate's range in one pass over the node's points (row by row).
        let (mut lo, mut hi) = ([f32::INFINITY; MAX_DIM], [f32::NEG_INFINITY; MAX_DIM]);
        for &i in ids.iter() {
            let p = &points[i as usize * dim..][..dim];
            for l in 0..dim {
                (lo[l], hi[l]) = (lo[l].min(p[l]), hi[l].max(p[l]));
            }
        }
        let mut widest = (f32::NEG_INFINITY, 0);
        for l in 0..dim {
            if hi[l] - lo[l] > widest.0 {
                widest = (hi[l] - lo[l], l);
            }
        }
        let l = widest.1;
        // Split by count, so the depth is log2(n / LEAF) whatever the values (equal points too).
        let mid = ids.len() / 2;
        ids.select_nth_unstable_by(mid, |&x, &y| coord(x, l).total_cmp(&coord(y, l)));
        let split = coord(ids[mid], l);
        self.nodes.push(Node { dim: l as u32, split, a: 0, b: 0 });
        let (left, right) = ids.split_at_mut(mid);
        let a = self.build(points, left);
        let b = self.build(points, right);
        let node = &mut self.nodes[at as usize];
        (node.a, node.b) = (a, b);
        at
    }

    /// Bytes held: nodes, leaves and indices.
    pub fn bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node>() + self.leaves.len() * 4 + self.items.len() * 4
    }

    /// The index of the point nearest to `q` (`dim` coordinates): brute force's answer, the
    /// least squared distance summed coordinate by coordinate, ties to the lower index; 0 when
    /// no distance compares (a query with a NaN), as brute force gives.
    pub fn nearest(&self, q: &[f32]) -> usize {
        self.nearest_with_distance(q).0
    }

    /// [`KdTree::nearest`] with its squared distance (infinite when no distance compares).
    pub fn nearest_with_distance(&self, q: &[f32]) -> (usize, f32) {
        assert_eq!(q.len(), self.dim, "a query of the tree's dimension");
        let mut best = (f32::INFINITY, u32::MAX);
        let mut off = [0f32; MAX_DIM];
        let simd = crate::kernels::Level::detect().avx512();
        self.visit(0, 0.0, 1.0, &mut off, q, &mut best, &mut |rows, items, best| {
            #[cfg(target_arch = "x86_64")]
            if simd {
                // SAFETY: `simd` is the detected level's avx512(), true only where detection
                // found AVX-512F; `rows` holds q.len() rows of LEAF values (asserted by the kernel).
                return unsafe { x86::scan_avx512(rows, items, q, best) };
            }
            let _ = simd;
            scan(rows, items, q, best)
        });
        if best.1 == u32::MAX {
            (0, f32::INFINITY)
        } else {
            (best.1 as usize, best.0)
        }
    }

    /// The point nearest to `q` with its squared distance, and, into `near`, every point within
    /// `reach` (at least 1) times that squared distance, with its squared distance, in no
    /// particular order: one branch and bound whose cells are kept while they can hold a point
    /// within `reach` times the best distance so far. As that best only falls, no cell that
    /// could hold a point within `reach` times the final one is ever dropped; the points
    /// collected beyond it on the way are removed at the end. (A second search for the nearest
    /// point of some kind within that reach, started after the first, scans again the cells
    /// around the first point.)
    ///
    /// The distances are [`near_distance`]'s (four chains of fused multiply-adds, a quarter of
    /// the dependent adds of [`KdTree::nearest`]'s sums), so the point is brute force's under
    /// them, ties to the lower index, and may differ from [`KdTree::nearest`]'s where two
    /// points' distances agree to the last bits.
    pub fn nearest_and_near(&self, q: &[f32], reach: f32, near: &mut Vec<(f32, u32)>) -> (usize, f32) {
        assert_eq!(q.len(), self.dim, "a query of the tree's dimension");
        assert!(reach >= 1.0, "a reach of at least 1");
        near.clear();
        let mut best = (f32::INFINITY, u32::MAX);
        let mut off = [0f32; MAX_DIM];
        let simd = crate::kernels::Level::detect().avx512();
        self.visit(0, 0.0, reach, &mut off, q, &mut best, &mut |rows, items, best| {
            #[cfg(target_arch = "x86_64")]
            if simd {
                // SAFETY: `simd` is true only where detection found AVX-512F (as in
                // nearest_with_distance); the kernel asserts the lengths it reads.
                return unsafe { x86::scan_near_avx512(rows, items, q, best, reach, near) };
            }
            let _ = simd;
            scan_near(rows, items, q, best, reach, near)
        });
        let bound = reach * best.0;
        near.retain(|&(a, _)| a <= bound);
        if best.1 == u32::MAX {
            (0, f32::INFINITY)
        } else {
            (best.1 as usize, best.0)
        }
    }

    /// The branch and bound from `node`: `leaf` scores a leaf's rows and items into `best`; a
    /// cell is visited while its squared distance from `q` is at most `reach` times the best.
    #[allow(clippy::too_many_arguments)]
    fn visit(
        &self,
        node: u32,
        bound: f32,
        reach: f32,
        off: &mut [f32; MAX_DIM],
        q: &[f32],
        best: &mut (f32, u32),
        leaf: &mut impl FnMut(&[f32], &[u32], &mut (f32, u32)),
    ) {
        let nd = self.nodes[node as usize];
        if nd.dim == IS_LEAF {
            let at = nd.a as usize;
            return leaf(&self.leaves[at * self.dim * LEAF..][..self.dim * LEAF], &self.items[at * LEAF..][..LEAF], best);
        }
        let l = nd.dim as usize;
        let d = q[l] - nd.split;
        let (near, far) = if d <= 0.0 { (nd.a, nd.b) } else { (nd.b, nd.a) };
        self.visit(near, bound, reach, off, q, best, leaf);
        // The far cell lies beyond the split in coordinate l: its squared distance from q is at
        // least the bound with that coordinate's offset replaced by d.
        let old = off[l];
        let far_bound = bound - old * old + d * d;
        if far_bound <= reach * best.0 {
            off[l] = d;
            self.visit(far, far_bound, reach, off, q, best, leaf);
            off[l] = old;
        }
    }
}

/// One leaf's squared distances, each summed over the coordinates in order, into `best` (least
/// distance, ties to the lower index).
#[inline(always)]
fn scan(rows: &[f32], items: &[u32], q: &[f32], best: &mut (f32, u32)) {
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

/// The squared distance from `p` to `q` that [`KdTree::nearest_and_near`] measures: four
/// chains, chain k summing the coordinates k, k + 4, ... in order by fused multiply-adds of the
/// differences, then (c0 + c1) + (c2 + c3).
pub fn near_distance(p: &[f32], q: &[f32]) -> f32 {
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
fn scan_near(rows: &[f32], items: &[u32], q: &[f32], best: &mut (f32, u32), reach: f32, near: &mut Vec<(f32, u32)>) {
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
    /// subtractions, products and sums of [`super::scan`] in the same order (no fused
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

    /// [`super::scan`] in one AVX-512 vector per coordinate ([`leaf_distances`]).
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn scan_avx512(rows: &[f32], items: &[u32], q: &[f32], best: &mut (f32, u32)) {
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

    /// [`super::scan_near`] in one AVX-512 vector per chain of [`super::near_distance`] (the same
    /// fused multiply-adds and sums, so the same bits).
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn scan_near_avx512(rows: &[f32], items: &[u32], q: &[f32], best: &mut (f32, u32), reach: f32, near: &mut Vec<(f32, u32)>) {
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
